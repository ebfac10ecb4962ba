"""Rack and pinion: a pinion (or a sector gear) rolls on a rack's straight pitch line.

The rack is link ``a`` (or the ground) with its pitch line through ``O`` in the direction
``u`` (given like a slider's line, in the rack's frame); the pinion is link ``b``, centre
``C``, pitch radius ``r``. The travel of the centre along the line relative to the rack,
``s = u . (C - O)``, and the pinion's rotation relative to the rack, ``phi = theta_b -
theta_a``, are tied by rolling without slip (one equation, a higher pair):

    s + side r (phi - phase) = 0

``side`` is +1 when the centre lies on the left of the line (``n = k x u`` side), -1 on
its right: a pinion above a rack running to the right turns clockwise as it travels right.
``phase`` is the pinion's angle relative to the rack when its centre is at the line's
origin (default 0).

The multiplier is the tangential tooth force at the pitch point (along the line); the
radial, separating part ``|F_t| tan(alpha)`` is applied by the force analysis in a second
pass (:meth:`RackConstraint.separating`), like a gear pair's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from mechsolve.base.errors import suggest
from mechsolve.base.keyspec import LENGTH, K, Key, either, name, names, section
from mechsolve.base.state import State
from mechsolve.joints.base import GROUND, Constraint, Joint, KeyPath, Reader, read_meshing_links
from mechsolve.joints.gear import (
    CENTRE_TOLERANCE,
    DEFAULT_PRESSURE_ANGLE,
    MODULE,
    PHASE,
    PRESSURE_ANGLE,
    TEETH,
    _unit_factor,
    read_count,
    read_positive_length,
    read_pressure_angle,
)
from mechsolve.joints.slider import read_line


@dataclass
class RackJoint(Joint):
    """Rack and pinion: the pinion ``pinion`` (pitch radius ``r`` about ``centre``) rolls on
    the pitch line of ``rack`` through ``origin`` at ``angle`` (the rack's frame).

    Reactions are the tooth force on the pinion by the rack: ``Ft`` (tangential, along the
    line's direction), ``Fr`` (radial, separating, ``|Ft| tan(alpha)``), ``Fn`` (along the
    line of action, ``|Ft| / cos(alpha)``) and its components ``Fx``, ``Fy``.
    """

    name: str
    rack: str
    pinion: str
    centre: str
    origin: tuple[float, float]
    angle: float
    r: float
    alpha: float = DEFAULT_PRESSURE_ANGLE
    phase: float = 0.0
    module: float | None = None
    teeth: int | None = None
    size_key: str = "radius"
    where: KeyPath = ()

    kind: ClassVar[str] = "rack"
    title: ClassVar[str] = "a pinion rolling on a rack"
    roles: ClassVar[tuple[str, str]] = ("rack", "pinion")
    letter: ClassVar[str] = "K"
    pair: ClassVar[str] = "higher"
    removes: ClassVar[int] = 1
    coordinate: ClassVar[str | None] = None
    magnitude: ClassVar[str] = "Fn"
    magnitude_note: ClassVar[str] = " tooth force"
    keys: ClassVar[dict[str, Key]] = {
        "rack": K(
            names("link", 2),
            "[rack, pinion]: the pinion rolls on the rack's pitch line (the rack may be the "
            "ground).",
        ),
        "pitch_line": K(
            either(names("point", 2), section("guide line")),
            "A rack's pitch line on the rack link, given like a slider's line: [P, Q] or "
            "{through, angle}.",
        ),
        "radius": K(LENGTH, "A rack's pinion: its pitch radius (or 'module' and 'teeth')."),
        "module": MODULE,
        "teeth": TEETH,
        "pressure_angle": PRESSURE_ANGLE,
        "centre": K(
            name("point"), "A rack's pinion centre: a point of the pinion (default its first)."
        ),
        "phase": PHASE,
    }

    @property
    def a(self) -> str:  # type: ignore[override]
        return self.rack

    @property
    def b(self) -> str:  # type: ignore[override]
        return self.pinion

    @property
    def point(self) -> str:  # type: ignore[override]
        """The pinion's centre (where drawings mark the joint)."""
        return self.centre

    @property
    def links(self) -> tuple[str, str]:
        return (self.rack, self.pinion)

    @classmethod
    def read(
        cls, r: Reader, name: str, m: Mapping, path: tuple, points: Mapping[str, Mapping]
    ) -> RackJoint:
        a, b = read_meshing_links(r, m, "rack", "rack", name, path, points)
        if "point" in m:
            raise r.fail(
                path + ("point",),
                "a rack has no joint point: give the pinion's centre with 'centre'",
            )
        if "pitch_line" not in m:
            raise r.fail(path, f"rack {name!r} needs 'pitch_line': the rack's pitch line on {a!r}")
        origin, angle = read_line(r, m["pitch_line"], path + ("pitch_line",), a, points[a])
        module, teeth, size_key = None, None, "radius"
        if "radius" in m and ("module" in m or "teeth" in m):
            other = "module" if "module" in m else "teeth"
            raise r.fail(
                path + (other,),
                f"rack {name!r}: give either 'radius' or 'module' with 'teeth', not both",
            )
        if "radius" in m:
            radius = read_positive_length(r, m["radius"], path + ("radius",), "the pitch radius")
        elif "module" in m or "teeth" in m:
            if "module" not in m or "teeth" not in m:
                missing = "teeth" if "module" in m else "module"
                raise r.fail(path, f"rack {name!r} needs {missing!r} too (module and teeth)")
            module = read_positive_length(r, m["module"], path + ("module",), "the module")
            teeth = read_count(r, m["teeth"], path + ("teeth",))
            radius = module * teeth / 2
            size_key = "module"
        else:
            raise r.fail(
                path,
                f"rack {name!r} needs the pinion's size: 'radius' or 'module' with 'teeth'",
            )
        alpha = read_pressure_angle(r, m, path)
        if "centre" in m:
            centre = r.name(m["centre"], path + ("centre",), "point")
        else:
            centre = next(iter(points[b]), "")
        phase = r.quantity(m.get("phase", 0.0), path + ("phase",), "angle")
        return cls(
            name,
            a,
            b,
            centre,
            origin,
            angle,
            radius,
            alpha,
            phase,
            module,
            teeth,
            size_key,
            where=path,
        )

    def check(self, mech: Any, in_range: Callable[..., None]) -> None:
        if not mech.has_point(self.pinion, self.centre):
            ln = self.pinion
            pts = list(mech.ground) if ln == GROUND else list(mech.link(ln).points)
            what = "the ground" if ln == GROUND else f"link {ln!r}"
            raise mech.error(
                self.where + ("centre",),
                f"rack {self.name!r}: {what} has no point {self.centre!r} for the pinion's "
                "centre" + suggest(self.centre, pts),
            )
        if not all(math.isfinite(v) for v in (*self.origin, self.angle)):
            raise mech.error(self.where + ("pitch_line",), "the pitch line must be finite")
        in_range(mech, self.where + ("pitch_line",), "length", *self.origin)
        in_range(mech, self.where + (self.size_key,), "length", self.r)
        in_range(mech, self.where + ("phase",), "angle", self.phase)
        # the centre's distance from the pitch line, where the rack's body holds both
        if mech.has_point(self.rack, self.centre):
            c = mech.local_point(self.rack, self.centre)
            n = (-math.sin(self.angle), math.cos(self.angle))
            d = abs(n[0] * (c[0] - self.origin[0]) + n[1] * (c[1] - self.origin[1]))
            where = "the ground" if self.rack == GROUND else f"link {self.rack!r}"
            self._check_distance(mech, d, f"on {where}")

    def check_start(self, mech: Any, c: Constraint, st: State) -> None:
        """The centre at the pitch radius from the line in the assembled start (what
        holds it there may be a slider, which the file alone does not settle)."""
        _, _, nx, ny, dx, dy = c.frame(st)  # type: ignore[attr-defined]
        d = float(np.abs(nx * dx + ny * dy)[0])
        if math.isfinite(d):
            self._check_distance(mech, d, "at the start position")

    def _check_distance(self, mech: Any, d: float, where: str) -> None:
        if abs(d - self.r) > CENTRE_TOLERANCE * self.r:
            u = mech.length_unit
            f = _unit_factor(u)
            raise mech.error(
                self.where + (self.size_key,),
                f"rack {self.name!r}: the pinion's centre {self.centre} is {d / f:.6g} {u} "
                f"from the pitch line {where}, but its pitch radius is {self.r / f:.6g} {u}; "
                "move the centre or the line, or change the pinion",
            )

    def equations(self, mech: Any, index: Mapping[str, int]) -> RackConstraint:
        return RackConstraint(
            self.name,
            index[self.rack],
            index[self.pinion],
            self.origin,
            self.angle,
            mech.local_point(self.pinion, self.centre),
            self.r,
            self.alpha,
            self.phase,
        )

    def describe(
        self, length: Callable[[float], str], angle: Callable[[float], str], unit: str
    ) -> tuple[str, str, str]:
        ox, oy = self.origin
        size = f"pitch radius {length(self.r)} {unit}"
        if self.module is not None and self.teeth is not None:
            size += f" (module {length(self.module)} {unit}, {self.teeth} teeth)"
        return (
            f"{self.rack} (rack) – {self.pinion} (pinion)",
            self.centre,
            f"pinion {size}, pressure angle {angle(self.alpha)}°; pitch line through "
            f"({length(ox)}, {length(oy)}) {unit} at {angle(self.angle)}° in the rack's frame"
            + (f", phase {angle(self.phase)}°" if self.phase else ""),
        )


class RackConstraint(Constraint):
    """The rolling of a pinion on a rack's pitch line (one equation)."""

    kind = "rack"
    letter = "K"
    m = 1

    def __init__(
        self,
        name: str,
        a: int,
        b: int,
        origin,
        angle: float,
        sc,
        r: float,
        alpha: float,
        phase: float,
    ) -> None:
        self.name, self.a, self.b = name, a, b
        self.o = np.asarray(origin, float)
        self.u_loc = np.array([math.cos(angle), math.sin(angle)])
        self.sc = np.asarray(sc, float)
        self.r, self.alpha, self.phase = r, alpha, phase

    def frame(self, st: State):
        """The line's direction u, its normal n, and d = C - O (global)."""
        ux, uy = st.rotated(self.a, self.u_loc)
        xo, yo = st.point(self.a, self.o)
        xc, yc = st.point(self.b, self.sc)
        return ux, uy, -uy, ux, xc - xo, yc - yo

    def side(self, st: State) -> np.ndarray:
        """+1 where the pinion's centre is on the left of the line, -1 on its right."""
        _, _, nx, ny, dx, dy = self.frame(st)
        return np.where(nx * dx + ny * dy >= 0, 1.0, -1.0)

    def travel(self, st: State) -> np.ndarray:
        """The centre's travel along the line from its origin, relative to the rack."""
        ux, uy, _, _, dx, dy = self.frame(st)
        return ux * dx + uy * dy

    def residual(self, st: State, u=None) -> np.ndarray:
        phi = st.th[self.b] - st.th[self.a] - self.phase
        return (self.travel(st) + self.side(st) * self.r * phi)[None, :]

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        ux, uy, nx, ny, dx, dy = self.frame(st)
        sr = self.side(st) * self.r
        out = {}
        if self.a != st.nb:
            rox, roy = st.rotated(self.a, self.o)
            blk = np.zeros((1, 3, st.n))
            blk[0, 0] = -ux
            blk[0, 1] = -uy
            # u turns with the rack; O moves with it
            blk[0, 2] = nx * dx + ny * dy - (ux * -roy + uy * rox) - sr
            out[self.a] = blk
        if self.b != st.nb:
            rcx, rcy = st.rotated(self.b, self.sc)
            blk = np.zeros((1, 3, st.n))
            blk[0, 0] = ux
            blk[0, 1] = uy
            blk[0, 2] = ux * -rcy + uy * rcx + sr
            out[self.b] = blk
        return out

    def gamma(self, st: State, udd=None) -> np.ndarray:
        ux, uy, nx, ny, dx, dy = self.frame(st)
        vox, voy = st.point_velocity(self.a, self.o)
        vcx, vcy = st.point_velocity(self.b, self.sc)
        ddx, ddy = vcx - vox, vcy - voy
        wa, wb = st.w[self.a], st.w[self.b]
        rox, roy = st.rotated(self.a, self.o)
        rcx, rcy = st.rotated(self.b, self.sc)
        g = (
            wa**2 * (ux * dx + uy * dy)
            - 2 * wa * (nx * ddx + ny * ddy)
            + wb**2 * (ux * rcx + uy * rcy)
            - wa**2 * (ux * rox + uy * roy)
        )
        return g[None, :]

    def incidence(self, nb: int) -> list[list[int]]:
        bodies = [b for b in (self.a, self.b) if b != nb]
        return [[3 * b + k for b in bodies for k in range(3)]]

    def equation_names(self) -> list[str]:
        return [f"{self.name} (rolling)"]

    def _forces(self, st: State, lam: np.ndarray):
        """The tooth force's parts on the pinion: tangential ``Ft`` along u, radial ``Fr``
        (separating) along ``side n``."""
        ux, uy, nx, ny, _, _ = self.frame(st)
        ft = -lam[:, 0]
        fr = np.abs(ft) * math.tan(self.alpha)
        side = self.side(st)
        return ft, fr, ux, uy, side * nx, side * ny

    def reaction(self, st: State, lam: np.ndarray) -> dict[str, np.ndarray]:
        ft, fr, ux, uy, ex, ey = self._forces(st, lam)
        return {
            "Ft": ft,
            "Fr": fr,
            "Fn": np.abs(ft) / math.cos(self.alpha),
            "Fx": ft * ux + fr * ex,
            "Fy": ft * uy + fr * ey,
        }

    def indeterminate(self, free: np.ndarray) -> set[str]:
        return {"Ft", "Fr", "Fn", "Fx", "Fy"}

    def pitch_point(self, st: State):
        """The pitch point: the foot of the centre on the line."""
        _, _, nx, ny, dx, dy = self.frame(st)
        xc, yc = st.point(self.b, self.sc)
        h = nx * dx + ny * dy
        return xc - h * nx, yc - h * ny

    def separating(self, st: State, lam: np.ndarray) -> list[tuple]:
        ft, fr, ux, uy, ex, ey = self._forces(st, lam)
        px, py = self.pitch_point(st)
        return [(self.b, px, py, fr * ex, fr * ey), (self.a, px, py, -fr * ex, -fr * ey)]

    def drawing(self, st: State, i: int) -> list[np.ndarray]:
        idx = [i]
        x, y = st.point(self.b, self.sc, idx)
        cx, cy = float(x[0]), float(y[0])
        th = float(st.th[self.b, i]) if self.b != st.nb else 0.0
        t = np.linspace(0.0, 2 * math.pi, 97)
        out = [
            np.stack([cx + self.r * np.cos(t), cy + self.r * np.sin(t)], axis=1),
            np.array([[cx, cy], [cx + self.r * math.cos(th), cy + self.r * math.sin(th)]]),
        ]
        # the pitch line, around the pitch point: two pitch diameters either way
        px, py = (float(v[0]) for v in self.pitch_point(st.take(idx)))
        ux, uy = (float(v[0]) for v in st.rotated(self.a, self.u_loc, idx))
        span = 4 * self.r
        out.append(np.array([[px - span * ux, py - span * uy], [px + span * ux, py + span * uy]]))
        return out
