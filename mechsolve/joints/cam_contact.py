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
velocity otherwise. A force-closed cam (``closure: force``, the default: a spring or a load
keeps the follower on the cam) loses contact where N would turn negative: the summary lists
these positions and warns (the solver keeps the bilateral contact, so the forces there are
what contact would need, not what happens).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from mechsolve.base.errors import suggest
from mechsolve.base.keyspec import ANGLE, ANY, K, Key, choice, name, names
from mechsolve.base.state import State
from mechsolve.joints.base import GROUND, Constraint, Joint, KeyPath, Reader

TWO_PI = 2.0 * math.pi
SAMPLES = 7200  # a program's cam: Newton's first guess from a sample every 0.05 deg
DENSE = 7200  # a table's profile is resampled this finely to offset it or take its support


# -- the curves ---------------------------------------------------------------------------
class Curve:
    """A periodic function of an angle with its first two derivatives: the pitch curve's
    polar radius ``rho(psi)`` (a roller) or the profile's support function ``h(mu)`` (a
    flat face). ``accuracy`` (m) bounds its error against the exact curve (0: exact)."""

    accuracy: float = 0.0
    source: str = ""

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError


class CirclePolar(Curve):
    """The polar radius about O of a circle of radius ``R`` centred ``e`` from O on the x
    axis: ``rho = e cos psi + sqrt(R^2 - e^2 sin^2 psi)`` (exact)."""

    def __init__(self, R: float, e: float) -> None:
        self.R, self.e = R, e
        self.source = f"circle R {R * 1e3:g} mm, e {e * 1e3:g} mm"

    def __call__(self, x):
        e, c, s = self.e, np.cos(x), np.sin(x)
        S = np.sqrt(self.R**2 - (e * s) ** 2)
        rho = e * c + S
        d1 = -e * s - e * e * s * c / S
        d2 = -e * c - e * e * (c * c - s * s) / S - e**4 * (s * c) ** 2 / S**3
        return rho, d1, d2


class CircleSupport(Curve):
    """The support function about O of the same circle: ``h = R + e cos mu`` (exact)."""

    def __init__(self, R: float, e: float) -> None:
        self.R, self.e = R, e
        self.source = f"circle R {R * 1e3:g} mm, e {e * 1e3:g} mm"

    def __call__(self, x):
        return self.R + self.e * np.cos(x), -self.e * np.sin(x), -self.e * np.cos(x)


class Spline(Curve):
    """A periodic cubic spline through ``(x, y)`` (x increasing over less than a turn; the
    first sample is repeated a turn later)."""

    def __init__(self, x: np.ndarray, y: np.ndarray, source: str) -> None:
        from scipy.interpolate import CubicSpline  # lazy: start-up time

        x = np.asarray(x, float)
        y = np.asarray(y, float)
        self.x0 = float(x[0])
        xs = np.append(x - self.x0, TWO_PI)
        ys = np.append(y, y[0])
        self.f = CubicSpline(xs, ys, bc_type="periodic")
        self.d1 = self.f.derivative(1)
        self.d2 = self.f.derivative(2)
        self.source = source

    def __call__(self, x):
        t = np.mod(np.asarray(x, float) - self.x0, TWO_PI)
        return self.f(t), self.d1(t), self.d2(t)


def _monotone_angles(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The polar angles (increasing, within one turn from the first) and radii of the
    closed curve ``xy`` (no repeated end), or None if it is not star-shaped about O."""
    ang = np.unwrap(np.arctan2(xy[:, 1], xy[:, 0]))
    rad = np.hypot(xy[:, 0], xy[:, 1])
    if ang[-1] < ang[0]:
        ang, rad = ang[::-1], rad[::-1]
    if not np.all(np.diff(ang) > 0) or ang[-1] - ang[0] >= TWO_PI:
        return None
    return ang, rad


def polar_spline(xy: np.ndarray, source: str) -> Spline | None:
    """The polar radius of the closed curve ``xy`` as a periodic spline (None: the curve is
    not star-shaped about its centre)."""
    got = _monotone_angles(xy)
    return None if got is None else Spline(got[0], got[1], source)


def support_spline(contact: np.ndarray, normal: np.ndarray, source: str) -> Spline | None:
    """The support function from contact points and their outward normals (None: the
    normal does not turn one way: the profile is not convex)."""
    mu = np.unwrap(np.arctan2(normal[:, 1], normal[:, 0]))
    h = np.sum(contact * normal, axis=1)
    if mu[-1] < mu[0]:
        mu, h = mu[::-1], h[::-1]
    if not np.all(np.diff(mu) > 0) or mu[-1] - mu[0] >= TWO_PI:
        return None
    return Spline(mu, h, source)


def _outward(xy: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Unit outward normals of a counter-clockwise curve with tangents ``d``."""
    n = np.stack([d[:, 1], -d[:, 0]], axis=1)
    return n / np.linalg.norm(n, axis=1)[:, None]


# -- reading the profile ------------------------------------------------------------------
def _read_table(r: Reader, v: Any, path: KeyPath) -> np.ndarray:
    """The profile's points (cam frame, SI), closed: the last entry repeats the first."""
    m = r.mapping(v, path, ("polar", "points"), "a profile table ({polar: ...} or {points: ...})")
    if len(m) != 1:
        raise r.fail(path, "give the table as 'polar' ([angle, radius] rows) or 'points'")
    key = next(iter(m))
    rows = m[key]
    p = path + (key,)
    if not isinstance(rows, list) or len(rows) < 9:
        raise r.fail(p, "a profile table needs at least 8 rows and the first repeated at the end")
    pts = []
    for i, row in enumerate(rows):
        if not (isinstance(row, list) and len(row) == 2):
            raise r.fail(p + (i,), "each row is a pair: " + ("[angle, radius]" if key == "polar"
                                                          else "[x, y]"))  # fmt: skip
        if key == "polar":
            a = r.quantity(row[0], p + (i, 0), "angle")
            rad = r.positive(row[1], p + (i, 1), "length")
            pts.append((a, rad))
        else:
            pts.append(r.xy(row, p + (i,)))
    arr = np.array(pts, float)
    if key == "polar":
        a, rad = arr[:, 0], arr[:, 1]
        turn = a[-1] - a[0]
        if abs(abs(turn) - TWO_PI) > 1e-9 * TWO_PI or abs(rad[-1] - rad[0]) > 1e-9 * rad.max():
            raise r.fail(
                p,
                "the profile table is not closed: its last row must repeat its first a turn "
                f"later (from {math.degrees(a[0]):.6g} deg, {rad[0] * 1e3:.6g} mm the table "
                f"ends at {math.degrees(a[-1]):.6g} deg, {rad[-1] * 1e3:.6g} mm)",
            )
        d = np.diff(a) * np.sign(turn)
        if np.any(d <= 0):
            i = int(np.flatnonzero(d <= 0)[0]) + 1
            raise r.fail(p + (i,), "the table's angles must increase (or decrease) row by row")
        xy = np.stack([rad * np.cos(a), rad * np.sin(a)], axis=1)
    else:
        xy = arr
        size = float(np.max(np.ptp(xy, axis=0)))
        gap = float(np.hypot(*(xy[-1] - xy[0])))
        if gap > 1e-9 * size:
            raise r.fail(
                p,
                "the profile table is not closed: its last point must repeat its first "
                f"(it ends {gap * 1e3:.6g} mm from where it starts)",
            )
    return xy[:-1]


def _table_curve(r: Reader, xy: np.ndarray, path: KeyPath, roller: float | None) -> Curve:
    """The pitch curve's polar radius (a roller of radius ``roller``) or the support
    function (a flat face, ``roller`` None) of the profile table ``xy``."""
    prof = polar_spline(xy, "profile table")
    if prof is None:
        raise r.fail(path, "the profile table is not star-shaped about the cam's centre: seen "
                     "from the centre, its points must turn one way only, once")  # fmt: skip
    psi = prof.x0 + np.linspace(0.0, TWO_PI, DENSE, endpoint=False)
    rho, d1, _ = prof(psi)
    c, s = np.cos(psi), np.sin(psi)
    pts = np.stack([rho * c, rho * s], axis=1)
    tang = np.stack([d1 * c - rho * s, d1 * s + rho * c], axis=1)
    n = _outward(pts, tang)
    if roller is not None:
        out = polar_spline(pts + roller * n, f"profile table + roller {roller * 1e3:g} mm")
        if out is None:
            raise r.fail(path, "the roller is too large for this profile: its pitch curve "
                         "folds over itself")  # fmt: skip
        return out
    sup = support_spline(pts, n, "profile table")
    if sup is None:
        raise r.fail(path, "a flat face needs a convex profile: this table's profile is "
                     "concave somewhere")  # fmt: skip
    return sup


class ProgramCurve(Curve):
    """The pitch curve's polar radius (a roller) or the support function (a flat face) of
    the cam that a motion program defines, exact: at an angle x (psi or mu, cam frame)
    the cam angle theta where the follower's point is seen at x is found by Newton's
    method (from the curve sampled every 0.05 deg), then rho or h and their derivatives
    with respect to x follow from the program's s, s', s'' at theta by the inversion of
    :mod:`mechsolve.base.cam.profile` (the same formulas)."""

    def __init__(self, program: Any, f: Any, sense: int, roller: bool, source: str) -> None:
        self.program, self.f, self.sg, self.roller = program, f, float(sense), roller
        self.source = source
        th = np.linspace(0.0, TWO_PI, SAMPLES + 1)
        x, _, _, _, dx = self._at(th)
        if not (np.all(dx > 0) or np.all(dx < 0)):
            raise ValueError("its curve does not turn one way about the cam's centre")
        x = np.unwrap(x)
        if x[-1] < x[0]:
            x, th = x[::-1], th[::-1]
        self.x0, self.xs, self.ths = float(x[0]), x - x[0], th

    def _at(self, th: np.ndarray):
        """x, the curve's value and its first two derivatives in x, and dx/dtheta."""
        s, s1, s2, _ = self.program.eval(th)
        f, sg = self.f, self.sg
        if not self.roller:
            if f.oscillating:
                g = f.start_angle + s
                sin_g, cos_g = np.sin(g), np.cos(g)
                h = f.pivot * sin_g - f.offset
                h1 = f.pivot * cos_g * s1
                h2 = f.pivot * (cos_g * s2 - sin_g * s1**2)
                x, m1, m2 = math.pi / 2 - g - sg * th, -s1 - sg, -s2
            else:
                h, h1, h2 = f.base_radius + s, s1, s2
                x, m1, m2 = math.pi / 2 - sg * th, np.full_like(th, -sg), np.zeros_like(th)
            return x, h, h1 / m1, (h2 * m1 - h1 * m2) / m1**3, m1
        if f.oscillating:
            a, ln = f.pivot, f.arm
            g = f.start_angle + s
            sin_g, cos_g = np.sin(g), np.cos(g)
            px, py = a - ln * cos_g, ln * sin_g
            p1x, p1y = ln * s1 * sin_g, ln * s1 * cos_g
            p2x = ln * s2 * sin_g + ln * s1**2 * cos_g
            p2y = ln * s2 * cos_g - ln * s1**2 * sin_g
        else:
            s0 = math.sqrt(f.base_radius**2 - f.offset**2)
            px, py = np.full_like(th, f.offset), s0 + s
            p1x, p1y, p2x, p2y = np.zeros_like(th), s1, np.zeros_like(th), s2
        q1x, q1y = p1x + sg * py, p1y - sg * px  # p' - sg J p
        q2x, q2y = p2x + 2 * sg * p1y - px, p2y - 2 * sg * p1x - py  # p'' - 2 sg J p' - p
        r2 = px * px + py * py
        r = np.sqrt(r2)
        dot1, cr1 = px * q1x + py * q1y, px * q1y - py * q1x
        A = dot1 / r  # d rho / d theta
        B = cr1 / r2  # d psi / d theta
        A1 = (q1x * q1x + q1y * q1y + px * q2x + py * q2y) / r - dot1**2 / (r2 * r)
        B1 = (px * q2y - py * q2x) / r2 - 2 * cr1 * dot1 / (r2 * r2)
        x = np.arctan2(py, px) - sg * th
        return x, r, A / B, (A1 * B - A * B1) / B**3, B

    def __call__(self, x):
        x = np.asarray(x, float)
        t = np.mod(x - self.x0, TWO_PI)
        th = np.interp(t, self.xs, self.ths)
        for _ in range(4):  # quadratic convergence from a guess within 1e-7 rad
            xt, _, _, _, dx = self._at(th)
            th = th - (np.mod(xt - x + math.pi, TWO_PI) - math.pi) / dx
        _, v, d1, d2, _ = self._at(th)
        return v, d1, d2


def _program_curve(r: Reader, v: Any, path: KeyPath, roller: float | None) -> Curve:
    """The pitch curve (a roller) or the support function (a flat face) of the cam that a
    motion program as ``mechsolve cam`` reads it defines, exact (:class:`ProgramCurve`);
    its accuracy is measured against the inversion of :mod:`mechsolve.base.cam.profile`."""
    from mechsolve.base.cam.profile import solve
    from mechsolve.base.cam.read import SENSES, read_base, read_follower, read_motion

    keys = ("follower", "base_radius", "pivot_distance", "start_angle", "rotation",
            "motion", "law")  # fmt: skip
    m = r.mapping(v, path, keys, "'program'", ("follower", "motion", "rotation"))
    kind, contact, rr, arm, offset, _ = read_follower(r, m, path)
    osc = kind == "oscillating"
    if (roller is None) != (contact == "flat-faced"):
        want = "a flat-faced" if roller is None else "a roller (or knife-edge)"
        raise r.fail(path + ("follower", "type"), f"the joint's follower is {want} one; the "
                     f"program's is {kind} {contact}")  # fmt: skip
    if roller is not None and abs(rr - roller) > 1e-9:
        raise r.fail(path + ("follower", "roller_radius"), f"the program's roller radius "
                     f"{rr * 1e3:g} mm differs from the joint's {roller * 1e3:g} mm")  # fmt: skip
    t = str(m["rotation"]).strip().lower()
    if t not in SENSES:
        raise r.fail(path + ("rotation",), f"expected cw or ccw, got {m['rotation']!r}")
    sense = SENSES[t]
    limit = None if not osc else (math.pi / 2 if contact == "flat-faced" else math.pi)
    program = read_motion(r, m, osc, limit, path)
    follower, designed, _, _ = read_base(r, m, path, kind, contact, rr, offset, arm, program)
    if designed:
        raise r.fail(path, "a cam inside a linkage needs its base values (base_radius; "
                     "pivot_distance with start_angle for an oscillating follower): "
                     "'mechsolve cam' designs them")  # fmt: skip
    what = f"motion program ({kind} {contact}, {'cw' if sense < 0 else 'ccw'})"
    th = np.linspace(0.0, TWO_PI, 720, endpoint=False) + math.pi / 720
    try:
        ref = solve(program, follower, sense, th)
        if not ref.valid:
            raise ValueError("the face never reaches the cam with these base values")
        curve = ProgramCurve(program, follower, sense, roller is not None, what)
    except ValueError as exc:
        raise r.fail(path, f"this program gives no cam: {exc}") from None
    if roller is not None:
        assert ref.pitch is not None
        err = curve(np.arctan2(ref.pitch[:, 1], ref.pitch[:, 0]))[0] - np.hypot(*ref.pitch.T)
    else:
        c, s_ = np.cos(-sense * th), np.sin(-sense * th)
        n = ref.normal
        mu = np.arctan2(s_ * n[:, 0] + c * n[:, 1], c * n[:, 0] - s_ * n[:, 1])
        err = curve(mu)[0] - np.sum(ref.contact * n, axis=1)
    curve.accuracy = float(np.max(np.abs(err)))
    return curve


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
    magnitude_note: ClassVar[str] = " contact normal"
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
            curve = _program_curve(r, m[kind], q, roller)
            desc = curve.source
        else:
            curve = _table_curve(r, _read_table(r, m[kind], q), q, roller)
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
        self, r: Mapping[str, np.ndarray], ok: np.ndarray, u: np.ndarray, at: Callable
    ) -> tuple[list[str], list[str]]:
        """The summary's lines and warnings: the largest pressure angle, and for a
        force-closed cam the positions where the contact force turns negative (loss of
        contact), located between the samples by linear interpolation."""
        N = np.where(ok, r["N"], np.nan)
        pa = np.where(ok, r["pressure_angle"], np.nan)
        lines, warn = [], []
        if np.any(np.isfinite(pa)):
            i = int(np.nanargmax(pa))
            lines.append(f"cam contact {self.name}: largest pressure angle {pa[i]:.4g}° at "
                         f"{at(float(u[i]))}")  # fmt: skip
        if self.closure != "force" or not np.any(N < 0):
            return lines, warn
        neg = N < 0
        spans = []
        k = 0
        while k < len(N):
            if not neg[k]:
                k += 1
                continue
            j = k
            while j + 1 < len(N) and neg[j + 1]:
                j += 1
            spans.append((self._cross(u, N, k - 1, k), self._cross(u, N, j, j + 1)))
            k = j + 1
        text = "; ".join(
            f"from {at(a) if a is not None else 'the start'} to "
            f"{at(b) if b is not None else 'the end'}"
            for a, b in spans
        )
        lines.append(f"cam contact {self.name}: LOSS OF CONTACT (the contact force would be "
                     f"negative, least {np.nanmin(N):.4g} N): {text}")  # fmt: skip
        warn.append(f"the follower leaves the cam at {self.name} ({text}): the spring or "
                    "load is too weak for the speed; the forces there assume contact")  # fmt: skip
        return lines, warn

    @staticmethod
    def _cross(u: np.ndarray, N: np.ndarray, i: int, j: int) -> float | None:
        if i < 0 or j >= len(N) or not (np.isfinite(N[i]) and np.isfinite(N[j])):
            return None
        return float(u[i] + (u[j] - u[i]) * N[i] / (N[i] - N[j]))


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

    def outlines(self) -> list[tuple[int, np.ndarray]]:
        """The cam's profile in the cam link's frame (720 points, closed), and the roller
        in the follower's."""
        x = np.linspace(0.0, TWO_PI, 721)
        f, d1, _ = self.curve(x)
        c, s = np.cos(x), np.sin(x)
        if self.roller is not None:  # the pitch curve offset inward by the roller
            pts = np.stack([f * c, f * s], axis=1)
            tang = np.stack([d1 * c - f * s, d1 * s + f * c], axis=1)
            pts = pts - self.roller * _outward(pts, tang)
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
            wx, wy = np.full(st.n, data[0]), np.full(st.n, data[1])
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
            x, y = mech.local_point(GROUND, other.point)
            return "pivot", (float(x), float(y)), other.point
        if other.coordinate == "length" and getattr(other, "guide", None) == GROUND:
            return "guide", (math.cos(other.angle), math.sin(other.angle)), None, other
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
