"""Cam contact: a cam profile on one link touches a follower on another (a higher pair).

The cam is a closed convex curve fixed in the cam link, about its centre ``centre`` (a
point of the cam link) in a frame turned by ``cam_angle`` from the link's. The follower is
any link, jointed as the linkage has it (a rocker pinned to the ground: an oscillating
follower; a ram on a guide: a translating one; anything behind it):

* a **roller** (``roller: {centre: B, radius: r}``; ``radius: 0`` is a knife edge): the
  roller centre B of the follower stays on the cam's pitch curve (the profile offset by
  r). With the pitch curve in polar form ``rho(psi)`` about the cam's centre O, one
  equation ``|D| - rho(psi) = 0``, ``D = r_B - r_O``, ``psi = atan2(D) - theta_cam``;
* a **flat face** (``face: {through: P, normal: ANGLE}``): the line of the follower
  through P, whose normal (in the follower's frame) points away from the cam, stays
  tangent to the profile. With the profile's support function ``h(mu)`` (the distance
  from O of the tangent whose outward normal is at ``mu`` in the cam frame), one
  equation ``n . D - h(mu) = 0``, ``D = r_P - r_O``, ``mu = angle(n) - theta_cam``.

The profile is

* ``eccentric: {radius: R, eccentricity: e}``: a circle whose centre is e from O along
  the cam frame's x axis; ``rho`` and ``h`` are closed forms, so positions, Jacobian
  and the acceleration term ``gamma`` are exact;
* ``program:`` a motion program as ``mechsolve cam`` reads it (the follower type, the base
  values, ``rotation``, ``motion``, ``law``: :mod:`mechsolve.base.cam.read`); the pitch
  curve (a roller) or the support function (a flat face) follows from the program by
  the inversion of :mod:`mechsolve.base.cam.profile`, evaluated exactly (the cam angle
  where the follower is seen at psi or mu is found by Newton's method): rho, h and their
  derivatives are the program's to rounding (:attr:`Curve.accuracy` is measured against
  :func:`mechsolve.base.cam.profile.solve`; about 1e-16 m);
* ``table: {polar: [[angle, radius], ...]}`` or ``table: {points: [[x, y], ...]}``:
  the profile itself, closed (its last entry repeats its first). It is a periodic cubic
  spline of its polar radius; the pitch curve (offset by the roller) or the support
  function is resampled from it every 0.05 deg and splined again: the motion is as
  accurate as the table (a circle in 720 rows: the follower within 1e-9 m).

The multiplier is the contact's normal force: ``N`` (positive when the cam pushes the
follower, along the common normal from the cam to the follower), with its components
``Fx``, ``Fy``, and the **pressure angle** ``pressure_angle`` (deg): the acute angle
between the common normal and the direction in which the follower's point moves (the
roller centre; the face's point at the contact): normal to the line from its pivot for a
follower pinned to the ground, along its guide for one sliding on a ground guide, along its
velocity otherwise (left empty where it is at rest). A force-closed cam (``closure:
force``, the default: a spring or a load keeps the follower on the cam) loses contact where
N would turn negative: the summary lists these positions and warns (the solver keeps the
bilateral contact, so the forces there are what contact would need, not what happens).

The curves and their reading are in :mod:`mechsolve.base.cam.curves`. Grübler's count takes
the contact as a higher pair (Ph, one equation); the roller is a point of the follower, so
its spin, the local degree of freedom of the textbooks' count, is not a coordinate here
(:attr:`CamContact.local_dof` lets ``check`` print both counts).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from mechsolve.base.cam.curves import (
    TWO_PI,
    CirclePolar,
    CircleSupport,
    Curve,
    Spline,
    outward,
    program_curve,
    read_table,
    table_curve,
)
from mechsolve.base.errors import suggest
from mechsolve.base.keyspec import ANGLE, ANY, K, Key, choice, name, names
from mechsolve.base.numerics import illinois_root
from mechsolve.base.state import State
from mechsolve.joints.base import GROUND, Constraint, Joint, KeyPath, Reader


# -- the joint ----------------------------------------------------------------------------
@dataclass
class CamContact(Joint):
    """A cam on link ``cam`` touching a roller or a flat face of link ``follower``."""

    name: str
    cam: str
    follower: str
    point: str  # the roller centre, or the face's point
    centre: str  # the cam's centre: a point of the cam link
    cam_angle: float
    curve: Curve
    roller: float | None  # the roller's radius (0: a knife edge); None: a flat face
    normal: float = 0.0  # a flat face's normal, in the follower's frame
    closure: str = "force"
    profile: str = ""
    where: KeyPath = ()

    kind: ClassVar[str] = "cam_contact"
    title: ClassVar[str] = "a cam touching a roller or a flat face (a higher pair)"
    roles: ClassVar[tuple[str, str]] = ("cam", "follower")
    letter: ClassVar[str] = "H"
    pair: ClassVar[str] = "higher"
    removes: ClassVar[int] = 1
    magnitude: ClassVar[str] = "N"
    magnitude_note: ClassVar[str] = " normal"
    components: ClassVar[tuple[tuple[str, str], ...]] = (
        ("N", "N"), ("Fx", "N"), ("Fy", "N"), ("pressure_angle", "deg"),
    )  # fmt: skip
    keys: ClassVar[dict[str, Key]] = {
        "cam_contact": K(
            names("link", 2),
            "[cam, follower]: a cam profile on the first "
            "link touches the follower's roller or flat face.",
        ),  # fmt: skip
        "centre": K(
            name("point"), "The cam's centre: a point of the cam link, the profile's origin."
        ),  # fmt: skip
        "cam_angle": K(ANGLE, "The cam frame's x axis in the cam link's frame (default 0)."),
        "eccentric": K(
            ANY, "A circular cam: {radius, eccentricity} (its centre on the cam frame's x axis)."
        ),  # fmt: skip
        "program": K(
            ANY,
            "A cam from a motion program, as 'mechsolve cam' reads it: "
            "{follower, base_radius, pivot_distance, start_angle, rotation, "
            "motion, law}.",
        ),  # fmt: skip
        "table": K(
            ANY,
            "The profile as a closed table: {polar: [[angle, radius], ...]} or "
            "{points: [[x, y], ...]} (the last row repeats the first).",
        ),  # fmt: skip
        "roller": K(
            ANY,
            "A roller follower: {centre: POINT of the follower, radius: LENGTH} "
            "(radius 0: a knife edge).",
        ),  # fmt: skip
        "face": K(
            ANY,
            "A flat-faced follower: {through: POINT of the follower, normal: "
            "ANGLE in its frame, pointing away from the cam}.",
        ),  # fmt: skip
        "closure": K(
            choice("force", "form"),
            "force (default: a spring keeps the follower "
            "on the cam; loss of contact is reported) or form (a groove).",
        ),  # fmt: skip
    }

    @property
    def a(self) -> str:
        return self.cam

    @property
    def b(self) -> str:
        return self.follower

    @property
    def links(self) -> tuple[str, str]:
        return (self.cam, self.follower)

    @property
    def local_dof(self) -> int:
        """Textbooks draw a roller as a link on its own pin, whose spin is a local degree of
        freedom; here the roller centre is a point of the follower, so none is counted."""
        return 1 if self.roller is not None and self.roller > 0 else 0

    @classmethod
    def read(
        cls, r: Reader, name_: str, m: Mapping, path: tuple, points: Mapping[str, Mapping]
    ) -> CamContact:
        cam, fol = r.names(m["cam_contact"], path + ("cam_contact",), "link", 2)
        for i, ln in enumerate((cam, fol)):
            if ln not in points:
                raise r.fail(path + ("cam_contact", i), f"no link named {ln!r}"
                             + suggest(ln, list(points)))  # fmt: skip
        if cam == fol:
            raise r.fail(path + ("cam_contact",), "the cam and the follower must be two links")
        if "centre" not in m:
            raise r.fail(path, f"cam contact {name_!r} needs 'centre': the cam's centre, a "
                         f"point of {cam!r}")  # fmt: skip
        centre = r.name(m["centre"], path + ("centre",), "point")
        cam_angle = r.quantity(m.get("cam_angle", 0.0), path + ("cam_angle",), "angle")
        followers = [k for k in ("roller", "face") if k in m]
        if len(followers) != 1:
            raise r.fail(path, f"cam contact {name_!r} needs one of 'roller: {{centre, "
                         "radius}' or 'face: {through, normal}'")  # fmt: skip
        normal = 0.0
        if followers[0] == "roller":
            q = path + ("roller",)
            rm = r.mapping(m["roller"], q, ("centre", "radius"), "'roller'", ("centre", "radius"))
            point = r.name(rm["centre"], q + ("centre",), "point")
            roller: float | None = r.positive(rm["radius"], q + ("radius",), "length", True)
        else:
            q = path + ("face",)
            fm = r.mapping(m["face"], q, ("through", "normal"), "'face'", ("through", "normal"))
            point = r.name(fm["through"], q + ("through",), "point")
            normal = r.quantity(fm["normal"], q + ("normal",), "angle")
            roller = None
        for ln, p, key in ((cam, centre, ("centre",)), (fol, point, (followers[0],))):
            if p not in points[ln]:
                what = "the ground" if ln == GROUND else f"link {ln!r}"
                raise r.fail(path + key, f"{what} has no point {p!r}"
                             + suggest(p, list(points[ln])))  # fmt: skip
        profiles = [k for k in ("eccentric", "program", "table") if k in m]
        if len(profiles) != 1:
            raise r.fail(path, f"cam contact {name_!r} needs one profile: 'eccentric', "
                         "'program' or 'table'")  # fmt: skip
        kind = profiles[0]
        q = path + (kind,)
        curve: Curve
        if kind == "eccentric":
            em = r.mapping(m[kind], q, ("radius", "eccentricity"), "'eccentric'",
                           ("radius", "eccentricity"))  # fmt: skip
            R = r.positive(em["radius"], q + ("radius",), "length")
            e = r.positive(em["eccentricity"], q + ("eccentricity",), "length", True)
            if roller is not None and e >= R + roller:
                raise r.fail(q + ("eccentricity",), "the eccentricity must be less than the "
                             "radius (plus the roller's)")  # fmt: skip
            curve = CirclePolar(R + roller, e) if roller is not None else CircleSupport(R, e)
            desc = f"circle R {R * 1e3:.6g} mm, eccentricity {e * 1e3:.6g} mm"
        elif kind == "program":
            curve = program_curve(r, m[kind], q, roller)
            desc = curve.source
        else:
            curve = table_curve(r, read_table(r, m[kind], q), q, roller)
            desc = "profile table"
        closure = m.get("closure", "force")
        if closure not in ("force", "form"):
            raise r.fail(path + ("closure",), f"expected force or form, got {closure!r}")
        return cls(name_, cam, fol, point, centre, cam_angle, curve, roller, normal, closure,
                   desc, where=path)  # fmt: skip

    def check(self, mech: Any, in_range: Callable[..., None]) -> None:
        in_range(mech, self.where + ("cam_angle",), "angle", self.cam_angle)
        if self.follower == GROUND and self.cam == GROUND:
            raise mech.error(self.where, "the cam and the follower cannot both be the ground")
        if self.roller is not None:
            self._check_reach(mech)

    def _check_reach(self, mech: Any) -> None:
        """The roller centre must be able to reach the pitch curve, whatever the cam's
        angle: checked where the cam turns about a fixed centre and the follower is pinned
        to the ground (the centre moves on a circle) or slides on a ground guide (on a
        line)."""
        o = _fixed_centre(self, mech)
        if o is None:
            return
        rho = self.curve(np.linspace(0.0, TWO_PI, 3600, endpoint=False))[0]
        lo, hi = float(rho.min()), float(rho.max())
        how = _motion_direction(self, mech)
        bp = mech.local_point(self.follower, self.point)
        if how[0] == "pivot":
            piv = np.asarray(how[1])
            dist = float(np.hypot(*(piv - o)))
            arm = float(np.hypot(*(bp - mech.local_point(self.follower, how[2]))))
            near, far = abs(dist - arm), dist + arm
            path = f"on a circle of radius {arm * 1e3:.6g} mm about {how[2]}"
        elif how[0] == "guide":
            ux, uy = how[1]
            slider = how[3]
            off = bp - mech.local_point(self.follower, slider.point)
            c, s_ = math.cos(slider.block_angle), math.sin(slider.block_angle)
            p0 = np.asarray(slider.origin) + np.array([c * off[0] - s_ * off[1],
                                                       s_ * off[0] + c * off[1]])  # fmt: skip
            near, far = abs(ux * (o[1] - p0[1]) - uy * (o[0] - p0[0])), math.inf
            path = "along its guide"
        else:
            return
        if far < lo or near > hi:
            raise mech.error(
                self.where + ("roller",),
                f"the follower cannot touch the cam: its roller centre {self.point} moves "
                f"{path}, {near * 1e3:.6g} to {far * 1e3:.6g} mm from the cam's centre "
                f"{self.centre}, but the pitch curve (the profile offset by the roller) runs "
                f"{lo * 1e3:.6g} to {hi * 1e3:.6g} mm from it",
            )

    def equations(self, mech: Any, index: Mapping[str, int]) -> CamConstraint:
        return CamConstraint(self, mech, index)

    def describe(
        self, length: Callable[[float], str], angle: Callable[[float], str], unit: str
    ) -> tuple[str, str, str]:
        if self.roller is None:
            fol = f"flat face, normal {angle(self.normal)}° in the follower's frame"
        else:
            fol = f"roller radius {length(self.roller)} {unit}"
        if isinstance(self.curve, Spline):
            acc = "a periodic spline through the table"
        elif self.curve.accuracy < 1e-12:
            acc = "exact"
        else:
            acc = f"to {self.curve.accuracy * 1e3:.2g} mm"
        return (
            f"{self.cam} (cam) – {self.follower} (follower)",
            self.point,
            f"{self.profile} about {self.centre} ({acc}); {fol}; {self.closure}-closed",
        )

    def findings(
        self,
        r: Mapping[str, np.ndarray],
        ok: np.ndarray,
        u: np.ndarray,
        at: Callable,
        solve: Callable[[np.ndarray, int], Mapping[str, np.ndarray]] | None = None,
    ) -> tuple[list[str], list[str]]:
        """The summary's lines and warnings: the largest pressure angle, and for a
        force-closed cam the positions where the contact force turns negative (loss of
        contact) with the least force.

        ``solve(x, i)``: the contact's reaction solved at driver values ``x`` next to
        sample ``i``; with it the figures are located between the samples: a change of
        sign between the two samples that straddle a jump of the force (a join of the
        cam's program, sampled 1e-9 on either side) is at the jump, a smooth one is found
        by regula falsi to rounding, and an extreme by Brent's method (or it is the
        sample at a jump or kink, within 1e-9 of it). Without it they are the samples'
        (the crossings interpolated), and say so."""
        N = np.where(ok, r["N"], np.nan)
        pa = np.where(ok, r["pressure_angle"], np.nan)
        u = np.asarray(u, float)
        lines, warn = [], []

        def of(key: str) -> Callable[[np.ndarray, int], np.ndarray] | None:
            if solve is None:
                return None
            return lambda x, k: np.asarray(solve(x, k)[key], float)

        if np.any(np.isfinite(pa)):
            v, x, exact = _extreme(pa, u, +1, of("pressure_angle"))
            lines.append(f"{self.name} (cam contact): largest pressure angle "
                         + (f"{v:.6g}° at {at(x)}" if exact else
                            f"{v:.4g}° (the largest sample) at {at(x)}"))  # fmt: skip
        if self.closure != "force" or not np.any(N < 0):
            return lines, warn
        neg = N < 0
        spans = []
        k = 0
        f = of("N")
        while k < len(N):
            if not neg[k]:
                k += 1
                continue
            j = k
            while j + 1 < len(N) and neg[j + 1]:
                j += 1
            spans.append((_cross(u, N, k - 1, k, f), _cross(u, N, j, j + 1, f)))
            k = j + 1

        def where(c: tuple[float, bool] | None, end: str) -> str:
            if c is None:
                return end
            return at(c[0]) if c[1] else "about " + at(c[0])

        text = "; ".join(f"from {where(a, 'the start')} to {where(b, 'the end')}"
                         for a, b in spans)  # fmt: skip
        v, x, exact = _extreme(N, u, -1, f)
        least = f"least {v:.6g} N at {at(x)}" if exact else f"least sample {v:.4g} N"
        lines.append(f"{self.name} (cam contact): LOSS OF CONTACT (the contact force would be "
                     f"negative, {least}): {text}")  # fmt: skip
        warn.append(f"the follower leaves the cam at {self.name} over {len(spans)} span(s) "
                    "(the LOSS OF CONTACT line above): the spring or load is too weak for "
                    "the speed; the forces there assume contact")  # fmt: skip
        return lines, warn


class CamConstraint(Constraint):
    """The cam contact's one equation between the cam (body ``a``) and the follower
    (body ``b``)."""

    kind = "cam_contact"
    letter = "H"
    m = 1

    def __init__(self, j: CamContact, mech: Any, index: Mapping[str, int]) -> None:
        self.name, self.a, self.b = j.name, index[j.cam], index[j.follower]
        self.so = np.asarray(mech.local_point(j.cam, j.centre), float)
        self.sp = np.asarray(mech.local_point(j.follower, j.point), float)
        self.beta = j.cam_angle
        self.curve = j.curve
        self.roller = j.roller
        self.nloc = j.normal
        self.direction = _motion_direction(j, mech)
        self.joint = j
        self.error = mech.error
        # the follower's point of its ground joint (its pivot, or its block's point)
        self.s_joint = None
        if self.direction[0] == "pivot":
            self.s_joint = np.asarray(mech.local_point(j.follower, self.direction[2]), float)
        elif self.direction[0] == "guide":
            self.s_joint = np.asarray(mech.local_point(j.follower, self.direction[3].point))

    # -- shared pieces
    def _D(self, st: State):
        xo, yo = st.point(self.a, self.so)
        xp, yp = st.point(self.b, self.sp)
        return xp - xo, yp - yo

    def _Ddot(self, st: State):
        vox, voy = st.point_velocity(self.a, self.so)
        vpx, vpy = st.point_velocity(self.b, self.sp)
        return vpx - vox, vpy - voy

    def _Dvv(self, st: State):
        """The part of D'' quadratic in the velocities: -w_b^2 A_b s_p + w_a^2 A_a s_o."""
        rox, roy = st.rotated(self.a, self.so)
        rpx, rpy = st.rotated(self.b, self.sp)
        wa2, wb2 = st.w[self.a] ** 2, st.w[self.b] ** 2
        return -wb2 * rpx + wa2 * rox, -wb2 * rpy + wa2 * roy

    def _roller(self, st: State):
        Dx, Dy = self._D(st)
        d2 = np.maximum(Dx * Dx + Dy * Dy, 1e-300)  # at O itself: no direction, no crash
        d = np.sqrt(d2)
        psi = np.arctan2(Dy, Dx) - st.th[self.a] - self.beta
        rho, r1, r2 = self.curve(psi)
        gx = Dx / d + r1 * Dy / d2  # grad of |D| - rho(psi) with respect to D
        gy = Dy / d - r1 * Dx / d2
        return Dx, Dy, d, d2, rho, r1, r2, gx, gy

    def _face(self, st: State):
        Dx, Dy = self._D(st)
        phi = st.th[self.b] + self.nloc
        nx, ny = np.cos(phi), np.sin(phi)
        h, h1, h2 = self.curve(phi - st.th[self.a] - self.beta)
        return Dx, Dy, nx, ny, h, h1, h2

    def residual(self, st: State, u=None) -> np.ndarray:
        if self.roller is not None:
            Dx, Dy, d, _, rho, *_ = self._roller(st)
            return (d - rho)[None, :]
        Dx, Dy, nx, ny, h, _, _ = self._face(st)
        return (nx * Dx + ny * Dy - h)[None, :]

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        out: dict[int, np.ndarray] = {}
        if self.roller is not None:
            Dx, Dy, _, _, _, r1, _, gx, gy = self._roller(st)
            tb = None
            ta = r1
        else:
            Dx, Dy, nx, ny, h, h1, _ = self._face(st)
            gx, gy = nx, ny
            tb = -ny * Dx + nx * Dy - h1  # the face's normal turns with the follower
            ta = h1
        if self.b != st.nb:
            rx, ry = st.rotated(self.b, self.sp)
            blk = np.zeros((1, 3, st.n))
            blk[0, 0], blk[0, 1] = gx, gy
            blk[0, 2] = -gx * ry + gy * rx + (0.0 if tb is None else tb)
            out[self.b] = blk
        if self.a != st.nb:
            rx, ry = st.rotated(self.a, self.so)
            blk = np.zeros((1, 3, st.n))
            blk[0, 0], blk[0, 1] = -gx, -gy
            blk[0, 2] = gx * ry - gy * rx + ta
            out[self.a] = blk
        return out

    def gamma(self, st: State, udd=None) -> np.ndarray:
        Vx, Vy = self._Ddot(st)
        Ax, Ay = self._Dvv(st)
        if self.roller is not None:
            Dx, Dy, d, d2, _, r1, r2, gx, gy = self._roller(st)
            dv = (Dx * Vx + Dy * Vy) / d  # u . D'
            cr = Dx * Vy - Dy * Vx  # D x D'
            psid = cr / d2 - st.w[self.a]
            rest = ((Vx * Vx + Vy * Vy) - dv * dv) / d + gx * Ax + gy * Ay - r2 * psid**2
            rest += 2.0 * r1 * cr * (Dx * Vx + Dy * Vy) / (d2 * d2)
            return -rest[None, :]
        Dx, Dy, nx, ny, _, _, h2 = self._face(st)
        wb = st.w[self.b]
        mud = wb - st.w[self.a]
        g = wb * wb * (nx * Dx + ny * Dy) - 2.0 * wb * (-ny * Vx + nx * Vy)
        g += -(nx * Ax + ny * Ay) + h2 * mud * mud
        return g[None, :]

    def incidence(self, nb: int) -> list[list[int]]:
        return [[3 * b + k for b in (self.a, self.b) if b != nb for k in range(3)]]

    def equation_names(self) -> list[str]:
        return [f"{self.name} (contact)"]

    def cannot_close(self, st: State) -> None:
        """At the start, with the cam placed: can the follower's point (a roller) or line
        (a face) reach the cam anywhere along its own motion (about its ground pivot, along
        its ground guide)? If not, say so at the joint's key."""
        kind = self.direction[0]
        if kind not in ("pivot", "guide") or not np.isfinite(st.th[self.a, 0]):
            return
        n = 7201
        probe = State(st.nb, n)
        probe.block[:] = st.block[:, :, :1]  # the cam where the driver starts
        sj = self.s_joint
        if kind == "pivot":  # the follower turned about its pivot, every 0.05 deg
            px, py = self.direction[1]
            th = np.linspace(-math.pi, math.pi, n)
            c, s = np.cos(th), np.sin(th)
            probe.set_angle(self.b, th)
            probe.x[self.b] = px - (c * sj[0] - s * sj[1])
            probe.y[self.b] = py - (s * sj[0] + c * sj[1])
        else:  # the follower slid along its guide, over 4 times the cam's size each way
            guide = self.direction[3]
            ux, uy = self.direction[1]
            rho = self.curve(np.linspace(0.0, TWO_PI, 720, endpoint=False))[0]
            o = np.asarray(st.point(self.a, self.so), float).ravel()
            ox, oy = guide.origin
            along = (o[0] - ox) * ux + (o[1] - oy) * uy  # the foot of the cam's centre
            span = 4.0 * float(np.max(rho) + abs(along) + math.hypot(ox - o[0], oy - o[1]))
            d = along + np.linspace(-span, span, n)
            th = guide.block_angle  # a ground guide: the block's angle is fixed
            c, s = math.cos(th), math.sin(th)
            probe.set_angle(self.b, np.full(n, th))
            probe.x[self.b] = ox + d * ux - (c * sj[0] - s * sj[1])
            probe.y[self.b] = oy + d * uy - (s * sj[0] + c * sj[1])
        f = self.residual(probe)[0]
        if np.any(f <= 0) and np.any(f >= 0):
            return  # it can reach the cam: the group fails for another reason
        j = self.joint
        part = f"roller centre {j.point}" if self.roller is not None else "face"
        how = "about its pivot" if kind == "pivot" else "along its guide"
        raise self.error(
            j.where + ("roller" if self.roller is not None else "face",),
            f"the follower does not touch the cam at the start: with the cam where the "
            f"driver starts, its {part} moved {how} never reaches the cam's "
            + ("pitch curve" if self.roller is not None else "profile")
            + f" ({'always outside' if np.all(f > 0) else 'always inside'}, by "
            f"{float(np.min(np.abs(f))) * 1e3:.4g} mm at the nearest); check the cam's "
            "size and angle (cam_angle) and where the follower is jointed",
        )

    def outlines(self) -> list[tuple[int, np.ndarray]]:
        """The cam's profile in the cam link's frame (720 points, closed), and the roller
        in the follower's."""
        x = np.linspace(0.0, TWO_PI, 721)
        f, d1, _ = self.curve(x)
        c, s = np.cos(x), np.sin(x)
        if self.roller is not None:  # the pitch curve offset inward by the roller
            pts = np.stack([f * c, f * s], axis=1)
            tang = np.stack([d1 * c - f * s, d1 * s + f * c], axis=1)
            pts = pts - self.roller * outward(pts, tang)
        else:  # the envelope of the tangents: h n + h' (J n)
            pts = np.stack([f * c - d1 * s, f * s + d1 * c], axis=1)
        cb, sb = math.cos(self.beta), math.sin(self.beta)
        loc = np.stack([cb * pts[:, 0] - sb * pts[:, 1], sb * pts[:, 0] + cb * pts[:, 1]], 1)
        out = [(self.a, loc + self.so)]
        if self.roller:
            out.append((self.b, self.sp + self.roller * np.stack([np.cos(x), np.sin(x)], 1)))
        return out

    def indeterminate(self, free: np.ndarray) -> set[str]:
        return {"N", "Fx", "Fy"}

    def law_breaks(self, st: State) -> np.ndarray | None:
        """The signed angle (rad, wrapped) from each join of the cam's program (where the
        follower's velocity or acceleration jumps): the roller centre's polar angle psi
        (a face's normal's angle mu) in the cam frame, less each join's."""
        xk = self.curve.breaks()
        if not xk.size:
            return None
        if self.roller is not None:
            Dx, Dy = self._D(st)
            x = np.arctan2(Dy, Dx) - st.th[self.a] - self.beta
        else:
            x = st.th[self.b] + self.nloc - st.th[self.a] - self.beta
        d = np.asarray(x, float)[None, :] - xk[:, None]
        return np.pi - np.mod(np.pi - d, TWO_PI)

    # -- the contact's normal, point and pressure angle
    def contact(self, st: State):
        """The unit common normal (from the cam to the follower) and the contact point of
        the follower (the roller centre; the face's point touching the cam), global."""
        if self.roller is not None:
            Dx, Dy, _, _, _, _, _, gx, gy = self._roller(st)
            g = np.hypot(gx, gy)
            nx, ny = gx / g, gy / g
            px, py = st.point(self.b, self.sp)
            return nx, ny, px, py, g
        Dx, Dy, nx, ny, h, h1, _ = self._face(st)
        ox, oy = st.point(self.a, self.so)
        return nx, ny, ox + h * nx - h1 * ny, oy + h * ny + h1 * nx, np.ones(st.n)

    def reaction(self, st: State, lam: np.ndarray) -> dict[str, np.ndarray]:
        nx, ny, px, py, g = self.contact(st)
        N = -lam[:, 0] * g
        return {"N": N, "Fx": N * nx, "Fy": N * ny,
                "pressure_angle": np.degrees(self.pressure_angle(st))}  # fmt: skip

    def pressure_angle(self, st: State) -> np.ndarray:
        """The acute angle between the common normal and the direction in which the
        follower's contact point moves (rad)."""
        nx, ny, px, py, _ = self.contact(st)
        kind, data = self.direction[:2]
        if kind == "pivot":
            wx, wy = -(py - data[1]), px - data[0]
        elif kind == "guide":
            wx, wy = np.broadcast_to(data[0], (st.n,)), np.broadcast_to(data[1], (st.n,))
        else:
            bx, by = st.x[self.b], st.y[self.b]
            w = st.w[self.b]
            wx = st.vx[self.b] - w * (py - by)
            wy = st.vy[self.b] + w * (px - bx)
            small = np.hypot(wx, wy) <= 1e-12 * max(1.0, float(np.nanmax(np.hypot(wx, wy))))
            wx, wy = np.where(small, np.nan, wx), np.where(small, np.nan, wy)
        return np.arctan2(np.abs(nx * wy - ny * wx), np.abs(nx * wx + ny * wy))


def _motion_direction(j: CamContact, mech: Any) -> tuple:
    """How the follower's contact point moves: about a ground pivot (``("pivot", (x, y),
    point)``), along a ground guide (``("guide", (ux, uy), None, slider)``), or as its
    velocity says (``("velocity", ...)``)."""
    for other in mech.joints:
        if other is j or GROUND not in other.links or j.follower not in other.links:
            continue
        if other.coordinate == "angle" and other.removes == 2:
            x, y = mech.local_point(GROUND, other.point)  # arrays for a batch of designs
            return "pivot", (np.asarray(x, float), np.asarray(y, float)), other.point
        if other.coordinate == "length" and getattr(other, "guide", None) == GROUND:
            return "guide", (np.cos(other.angle), np.sin(other.angle)), None, other
    return "velocity", (0.0, 0.0)


def _fixed_centre(j: CamContact, mech: Any) -> np.ndarray | None:
    """The cam's centre where it is fixed (the cam on the ground, or pinned to it there)."""
    if j.cam == GROUND:
        return np.asarray(mech.local_point(GROUND, j.centre), float)
    for other in mech.joints:
        if other is j or set(other.links) != {GROUND, j.cam} or other.coordinate != "angle":
            continue
        if other.point == j.centre:
            return np.asarray(mech.local_point(GROUND, j.centre), float)
    return None


def _event_gap(u: np.ndarray) -> float:
    """Two samples closer than this straddle an event (a jump, a kink: they are 2e-9
    apart, the sweep's spacing some 1e7 times more)."""
    du = np.abs(np.diff(u))
    return 1e-6 * float(du.max()) if du.size else 0.0


def _cross(
    u: np.ndarray, q: np.ndarray, i: int, j: int, f: Callable | None
) -> tuple[float, bool] | None:
    """Where ``q`` changes sign between samples i and j (None: outside the sweep, or not
    determined), and whether that is located (True) or interpolated between samples."""
    if i < 0 or j >= len(q) or not (np.isfinite(q[i]) and np.isfinite(q[j])):
        return None
    lo, hi, q_lo, q_hi = float(u[i]), float(u[j]), float(q[i]), float(q[j])
    if abs(hi - lo) <= _event_gap(u):  # it jumps across zero at an event
        return 0.5 * (lo + hi), True
    if q_lo == 0.0 or q_hi == 0.0:  # a sample is the crossing
        return (lo if q_lo == 0.0 else hi), True
    if f is None:
        return lo + (hi - lo) * q_lo / (q_lo - q_hi), False
    # regula falsi (Illinois): q is smooth between the samples
    r = illinois_root(lambda x: float(f(np.array([x]), i)[0]), lo, hi, q_lo, q_hi, xrel=1e-13)
    if not r.finite:  # interpolated in the bracket narrowed so far
        return r.lo + (r.hi - r.lo) * r.f_lo / (r.f_lo - r.f_hi), False
    return (r.x, True) if r.x is not None else (0.5 * (r.lo + r.hi), True)


def _extreme(
    q: np.ndarray, u: np.ndarray, sense: int, f: Callable | None
) -> tuple[float, float, bool]:
    """The largest (``sense`` +1) or smallest value of ``q``, where it is, and whether it
    is located (True) or the best sample's. A sample that straddles an event with its
    neighbour (a jump, a kink) is the value there, to 1e-9; else each neighbouring
    interval into which ``q`` still grows (a probe 1e-6 of the spacing in) is searched by
    Brent's method to 1e-9 of the spacing."""
    s = sense * q
    k = int(np.nanargmax(s))
    best, where = float(s[k]), float(u[k])
    if f is None:
        return sense * best, where, False
    gap = _event_gap(u)
    n = len(u)
    for a in (k - 1, k + 1):
        if not (0 <= a < n and np.isfinite(s[a])) or abs(u[a] - u[k]) <= gap:
            continue
        span = float(u[a] - u[k])
        probe = sense * float(f(np.array([u[k] + 1e-6 * span]), k)[0])
        if not probe > s[k]:
            continue  # it falls into this interval: the extreme is not inside it
        from scipy.optimize import minimize_scalar

        def g(x: float) -> float:
            v = sense * float(f(np.array([x]), k)[0])
            return -v if math.isfinite(v) else math.inf

        lo, hi = sorted((float(u[k]), float(u[a])))
        opt = minimize_scalar(g, bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-9 * abs(span)})  # fmt: skip
        if -opt.fun > best:
            best, where = float(-opt.fun), float(opt.x)
    return sense * best, where, True
