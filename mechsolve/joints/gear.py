"""The gear pair: two links whose pitch circles roll on each other (a higher pair).

Gear 1 turns about its centre ``C1`` (a point of link ``a``), gear 2 about ``C2`` (a point
of link ``b``); pitch radii ``r1``, ``r2``. With ``theta_c`` the angle of the line of
centres ``C1 -> C2`` and ``sigma = +1`` for an external pair, ``-1`` for an internal one
(link ``b`` is the ring), the pitch circles roll without slip when (one equation)

    r1 (theta_a - theta_c) + sigma r2 (theta_b - theta_c - phase) = 0

which holds with moving centres (a planet on a carrier: ``theta_c`` is the carrier's
angle). ``phase`` is gear 2's angle when gear 1's frame and the line of centres are both
at angle 0 (default 0). The speed ratio with fixed centres is ``omega_b / omega_a =
-sigma r1 / r2``.

The multiplier is the tangential force at the pitch point; the tooth force along the line
of action (pressure angle ``alpha``) also has a radial, separating part ``|F_t| tan(alpha)``
that does no work while the centre distance is held but loads the pivots: the force
analysis applies it as a known load in a second pass (:meth:`GearConstraint.separating`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from mechsolve.base.errors import suggest
from mechsolve.base.keyspec import (
    ANGLE,
    FLAG,
    LENGTH,
    K,
    Key,
    either,
    integer,
    list_of,
    names,
    whole,
)
from mechsolve.base.state import State
from mechsolve.joints.base import GROUND, Constraint, Joint, KeyPath, Reader, read_meshing_links

TWO_PI = 2.0 * math.pi
DEFAULT_PRESSURE_ANGLE = math.radians(20.0)
MAX_TEETH = 100_000  # more teeth than any gear has: a mistake
CENTRE_TOLERANCE = 1e-6  # of the pitch radii's sum: the centre distance's mismatch allowed

# keys a gear pair shares with the rack and pinion (one declaration: the file's joint
# mapping holds every kind's keys once)
MODULE = K(LENGTH, "Gears: the module m (pitch radius = m z / 2), with 'teeth'.")
TEETH = K(
    either(integer(1), list_of(integer(1), 2)),
    "Gears: tooth counts, [z1, z2] for a gear pair, z for a rack's pinion (with 'module').",
)
PRESSURE_ANGLE = K(ANGLE, "Gears: the pressure angle (default 20 deg).")
PHASE = K(
    ANGLE,
    "Gears: the meshing phase (default 0): gear 2's angle when gear 1 and the line of "
    "centres are at angle 0; a rack's pinion angle when its centre is at the line's origin.",
)


def read_count(r: Reader, value: Any, path: KeyPath) -> int:
    """A tooth count: a positive integer (``20.0`` too, a JSON Schema integer)."""
    value = whole(value)
    big = isinstance(value, (int, float)) and not isinstance(value, bool) and abs(value) > MAX_TEETH
    if big:
        raise r.fail(
            path,
            f"a tooth count of {value:g} is too large: a positive whole number up to {MAX_TEETH:,}",
        )
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise r.fail(path, f"a tooth count must be a positive whole number, got {value!r}")
    return value


def read_positive_length(r: Reader, value: Any, path: KeyPath, what: str) -> float:
    x = r.quantity(value, path, "length")
    if not (x > 0 and math.isfinite(x)):
        raise r.fail(path, f"{what} must be positive, got {value!r}")
    return x


def read_pressure_angle(r: Reader, m: Mapping, path: KeyPath) -> float:
    if "pressure_angle" not in m:
        return DEFAULT_PRESSURE_ANGLE
    alpha = r.quantity(m["pressure_angle"], path + ("pressure_angle",), "angle")
    if not 0 <= alpha < math.radians(45.0):
        raise r.fail(
            path + ("pressure_angle",),
            f"the pressure angle must be between 0 and 45 deg, got {math.degrees(alpha):.6g} deg",
        )
    return alpha


def wrap(x: np.ndarray) -> np.ndarray:
    """``x`` brought into [-pi, pi)."""
    return x - TWO_PI * np.floor((x + math.pi) / TWO_PI)


@dataclass
class GearJoint(Joint):
    """A gear pair: the pitch circle of ``a`` (radius ``r1`` about ``centres[0]``) rolls on
    that of ``b`` (radius ``r2`` about ``centres[1]``); ``internal``: ``b`` is the ring.

    The centres default to the links' first points. Reactions are the tooth force on
    ``b`` by ``a``: ``Ft`` (tangential at the pitch point, along the left normal of the
    line ``C1 -> C2``), ``Fr`` (radial, separating, ``|Ft| tan(alpha)``), ``Fn`` (along
    the line of action, ``|Ft| / cos(alpha)``) and its components ``Fx``, ``Fy``.
    """

    name: str
    a: str
    b: str
    centres: tuple[str, str]
    r1: float
    r2: float
    alpha: float = DEFAULT_PRESSURE_ANGLE
    internal: bool = False
    phase: float = 0.0
    module: float | None = None
    teeth: tuple[int, int] | None = None
    size_key: str = "radii"  # the key the radii were read from, for messages
    where: KeyPath = ()

    kind: ClassVar[str] = "gear_pair"
    title: ClassVar[str] = "two gears in mesh"
    roles: ClassVar[tuple[str, str]] = ("gear", "gear")
    letter: ClassVar[str] = "G"
    pair: ClassVar[str] = "higher"
    removes: ClassVar[int] = 1
    coordinate: ClassVar[str | None] = None
    magnitude: ClassVar[str] = "Fn"
    magnitude_note: ClassVar[str] = " tooth force"
    keys: ClassVar[dict[str, Key]] = {
        "gear_pair": K(
            names("link", 2),
            "[gear, gear]: a gear pair between two links (the second is the ring if internal).",
        ),
        "radii": K(list_of(LENGTH, 2), "Gears: the pitch radii [r1, r2]."),
        "module": MODULE,
        "teeth": TEETH,
        "pressure_angle": PRESSURE_ANGLE,
        "centres": K(
            names("point", 2),
            "Gears: the centres [C1, C2], points of the two links (default: their first points).",
        ),
        "internal": K(FLAG, "Gears: true for an internal pair (the second link is the ring)."),
        "phase": PHASE,
    }

    @property
    def point(self) -> str:  # type: ignore[override]
        """Gear 1's centre (where drawings mark the joint)."""
        return self.centres[0]

    @property
    def links(self) -> tuple[str, str]:
        return (self.a, self.b)

    @property
    def sigma(self) -> float:
        return -1.0 if self.internal else 1.0

    @property
    def distance(self) -> float:
        """The centre distance the pitch radii need."""
        return self.r2 - self.r1 if self.internal else self.r1 + self.r2

    @classmethod
    def read(
        cls, r: Reader, name: str, m: Mapping, path: tuple, points: Mapping[str, Mapping]
    ) -> GearJoint:
        a, b = read_meshing_links(r, m, "gear_pair", "gear pair", name, path, points)
        if "point" in m:
            raise r.fail(
                path + ("point",),
                "a gear pair has no joint point: give its gears' centres with 'centres: [C1, C2]'",
            )
        module, teeth, size_key = None, None, "radii"
        if "radii" in m and ("module" in m or "teeth" in m):
            other = "module" if "module" in m else "teeth"
            raise r.fail(
                path + (other,),
                f"gear pair {name!r}: give either 'radii' or 'module' with 'teeth', not both",
            )
        if "radii" in m:
            v = m["radii"]
            if not isinstance(v, list) or len(v) != 2:
                raise r.fail(path + ("radii",), "expected the two pitch radii [r1, r2]")
            r1, r2 = (
                read_positive_length(r, x, path + ("radii", i), "a pitch radius")
                for i, x in enumerate(v)
            )
        elif "module" in m or "teeth" in m:
            if "module" not in m or "teeth" not in m:
                missing = "teeth" if "module" in m else "module"
                raise r.fail(path, f"gear pair {name!r} needs {missing!r} too (module and teeth)")
            module = read_positive_length(r, m["module"], path + ("module",), "the module")
            v = m["teeth"]
            if not isinstance(v, list) or len(v) != 2:
                raise r.fail(path + ("teeth",), "expected the two tooth counts [z1, z2]")
            teeth = tuple(read_count(r, z, path + ("teeth", i)) for i, z in enumerate(v))
            r1, r2 = module * teeth[0] / 2, module * teeth[1] / 2
            size_key = "module"
        else:
            raise r.fail(
                path,
                f"gear pair {name!r} needs its size: 'radii: [r1, r2]' or 'module' with "
                "'teeth: [z1, z2]'",
            )
        alpha = read_pressure_angle(r, m, path)
        internal = m.get("internal", False)
        if not isinstance(internal, bool):
            raise r.fail(path + ("internal",), f"expected true or false, got {internal!r}")
        if internal and not r2 > r1:
            raise r.fail(
                path + (size_key,),
                f"gear pair {name!r} is internal: the second link {b!r} is the ring, so its "
                "pitch radius must be the larger",
            )
        if "centres" in m:
            centres = tuple(r.names(m["centres"], path + ("centres",), "point", 2))
        else:
            centres = tuple(next(iter(points[ln]), "") for ln in (a, b))
        phase = r.quantity(m.get("phase", 0.0), path + ("phase",), "angle")
        return cls(
            name,
            a,
            b,
            centres,  # type: ignore[arg-type]
            r1,
            r2,
            alpha,
            internal,
            phase,
            module,
            teeth,  # type: ignore[arg-type]
            size_key,
            where=path,
        )

    def check(self, mech: Any, in_range: Callable[..., None]) -> None:
        for i, (ln, c) in enumerate(zip(self.links, self.centres)):
            if not mech.has_point(ln, c):
                pts = list(mech.ground) if ln == GROUND else list(mech.link(ln).points)
                what = "the ground" if ln == GROUND else f"link {ln!r}"
                raise mech.error(
                    self.where + ("centres", i),
                    f"gear pair {self.name!r}: {what} has no point {c!r} for the centre of "
                    f"its gear" + suggest(c, pts),
                )
        in_range(mech, self.where + (self.size_key,), "length", self.r1, self.r2)
        in_range(mech, self.where + ("phase",), "angle", self.phase)
        held = held_distance(mech, *self.centres)
        if held is None:
            raise mech.error(
                self.where + ("centres",),
                f"gear pair {self.name!r}: no link (nor the ground) carries both centres "
                f"{self.centres[0]!r} and {self.centres[1]!r}, so nothing holds the centre "
                "distance; name each centre after its gear's pivot, with both pivots on the "
                "ground or on one carrier link",
            )
        carrier, d = held
        if abs(d - self.distance) > CENTRE_TOLERANCE * (self.r1 + self.r2):
            u = mech.length_unit
            f = _unit_factor(u)
            need = (
                f"r2 - r1 = {self.r2 / f:.6g} - {self.r1 / f:.6g}"
                if self.internal
                else f"r1 + r2 = {self.r1 / f:.6g} + {self.r2 / f:.6g}"
            )
            raise mech.error(
                self.where + (self.size_key,),
                f"gear pair {self.name!r}: the centres {self.centres[0]} and "
                f"{self.centres[1]} are {d / f:.6g} {u} apart on {carrier}, but the pitch "
                f"circles need {need} = {self.distance / f:.6g} {u}; move a centre or "
                "change the gears",
            )

    def equations(self, mech: Any, index: Mapping[str, int]) -> GearConstraint:
        return GearConstraint(
            self.name,
            index[self.a],
            index[self.b],
            mech.local_point(self.a, self.centres[0]),
            mech.local_point(self.b, self.centres[1]),
            self.r1,
            self.r2,
            self.sigma,
            self.alpha,
            self.phase,
        )

    def describe(
        self, length: Callable[[float], str], angle: Callable[[float], str], unit: str
    ) -> tuple[str, str, str]:
        size = f"pitch radii {length(self.r1)}, {length(self.r2)} {unit}"
        if self.module is not None and self.teeth is not None:
            size += f" (module {length(self.module)} {unit}, {self.teeth[0]}/{self.teeth[1]} teeth)"
        ratio = self.r2 / self.r1
        return (
            f"{self.a} – {self.b}" + (" (ring)" if self.internal else ""),
            f"{self.centres[0]}, {self.centres[1]}",
            f"{'internal' if self.internal else 'external'} gears, {size}, pressure angle "
            f"{angle(self.alpha)}°, speed ratio {'+' if self.internal else '-'}1/{ratio:.6g}"
            + (f", phase {angle(self.phase)}°" if self.phase else ""),
        )


def _unit_factor(unit: str) -> float:
    """Metres per ``unit`` (for messages in the file's length unit)."""
    from mechsolve.base.units import parse_unit

    try:
        return float(parse_unit(unit).factor)
    except Exception:  # an unknown unit name: print metres
        return 1.0


def held_distance(mech: Any, p: str, q: str) -> tuple[str, float] | None:
    """The distance between points ``p`` and ``q`` on the first body that carries both (the
    ground first), with that body's description; ``None`` if no body carries both."""
    if p in mech.ground and q in mech.ground:
        return "the ground", math.dist(mech.ground[p], mech.ground[q])
    for lk in mech.links:
        if p in lk.points and q in lk.points:
            return f"link {lk.name!r}", math.dist(lk.points[p], lk.points[q])
    return None


class GearConstraint(Constraint):
    """The rolling of two pitch circles (one equation); see the module's docstring."""

    kind = "gear_pair"
    letter = "G"
    m = 1

    def __init__(
        self,
        name: str,
        a: int,
        b: int,
        s1,
        s2,
        r1: float,
        r2: float,
        sigma: float,
        alpha: float,
        phase: float,
    ) -> None:
        self.name, self.a, self.b = name, a, b
        self.s1 = np.asarray(s1, float)
        self.s2 = np.asarray(s2, float)
        self.r1, self.r2, self.sigma = r1, r2, sigma
        self.alpha, self.phase = alpha, phase
        self.k = r1 + sigma * r2  # the coefficient of theta_c

    def centres(self, st: State):
        """The centres' arms (global components) from their frames' origins, and the line
        of centres: ``(r1x, r1y, r2x, r2y, dx, dy, L)`` with ``d = C2 - C1``."""
        r1x, r1y = st.rotated(self.a, self.s1)
        r2x, r2y = st.rotated(self.b, self.s2)
        dx = st.x[self.b] + r2x - st.x[self.a] - r1x
        dy = st.y[self.b] + r2y - st.y[self.a] - r1y
        return r1x, r1y, r2x, r2y, dx, dy, np.hypot(dx, dy)

    def residual(self, st: State, u=None) -> np.ndarray:
        _, _, _, _, dx, dy, _ = self.centres(st)
        thc = np.arctan2(dy, dx)
        # theta_c enters modulo 2 pi: compare it with the angle that closes the equation
        target = (
            self.r1 * st.th[self.a] + self.sigma * self.r2 * (st.th[self.b] - self.phase)
        ) / self.k
        return (self.k * wrap(target - thc))[None, :]

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        r1x, r1y, r2x, r2y, dx, dy, L = self.centres(st)
        nx, ny = -dy / L, dx / L  # the left normal of C1 -> C2
        kl = self.k / L
        out = {}
        if self.a != st.nb:
            blk = np.zeros((1, 3, st.n))
            blk[0, 0] = kl * nx
            blk[0, 1] = kl * ny
            blk[0, 2] = self.r1 + kl * (ny * r1x - nx * r1y)
            out[self.a] = blk
        if self.b != st.nb:
            blk = np.zeros((1, 3, st.n))
            blk[0, 0] = -kl * nx
            blk[0, 1] = -kl * ny
            blk[0, 2] = self.sigma * self.r2 - kl * (ny * r2x - nx * r2y)
            out[self.b] = blk
        return out

    def gamma(self, st: State, udd=None) -> np.ndarray:
        r1x, r1y, r2x, r2y, dx, dy, L = self.centres(st)
        ex, ey = dx / L, dy / L
        nx, ny = -ey, ex
        v1x, v1y = st.point_velocity(self.a, self.s1)
        v2x, v2y = st.point_velocity(self.b, self.s2)
        ddx, ddy = v2x - v1x, v2y - v1y
        wa2, wb2 = st.w[self.a] ** 2, st.w[self.b] ** 2
        # the part of d'' that is not linear in the accelerations
        qx = wa2 * r1x - wb2 * r2x
        qy = wa2 * r1y - wb2 * r2y
        g = self.k * (
            (nx * qx + ny * qy) / L - 2 * (nx * ddx + ny * ddy) * (ex * ddx + ey * ddy) / L**2
        )
        return g[None, :]

    def incidence(self, nb: int) -> list[list[int]]:
        bodies = [b for b in (self.a, self.b) if b != nb]
        return [[3 * b + k for b in bodies for k in range(3)]]

    def equation_names(self) -> list[str]:
        return [f"{self.name} (rolling)"]

    def _forces(self, st: State, lam: np.ndarray):
        """The tooth force's parts on ``b`` by ``a``: tangential ``Ft`` along the left
        normal of C1 -> C2 and radial ``Fr`` (separating), with the unit vectors."""
        _, _, _, _, dx, dy, L = self.centres(st)
        ex, ey = dx / L, dy / L
        ft = lam[:, 0] * self.k / L
        fr = np.abs(ft) * math.tan(self.alpha)
        return ft, fr, ex, ey

    def reaction(self, st: State, lam: np.ndarray) -> dict[str, np.ndarray]:
        ft, fr, ex, ey = self._forces(st, lam)
        s = self.sigma  # the radial force on gear 2 points away from gear 1 (external)
        return {
            "Ft": ft,
            "Fr": fr,
            "Fn": np.abs(ft) / math.cos(self.alpha),
            "Fx": -ft * ey + s * fr * ex,
            "Fy": ft * ex + s * fr * ey,
        }

    def indeterminate(self, free: np.ndarray) -> set[str]:
        return {"Ft", "Fr", "Fn", "Fx", "Fy"}

    def pitch_point(self, st: State):
        r1x, r1y, _, _, dx, dy, L = self.centres(st)
        c1x, c1y = st.x[self.a] + r1x, st.y[self.a] + r1y
        return c1x + self.sigma * self.r1 * dx / L, c1y + self.sigma * self.r1 * dy / L

    def separating(self, st: State, lam: np.ndarray) -> list[tuple]:
        ft, fr, ex, ey = self._forces(st, lam)
        px, py = self.pitch_point(st)
        fx, fy = self.sigma * fr * ex, self.sigma * fr * ey  # on gear 2
        return [(self.b, px, py, fx, fy), (self.a, px, py, -fx, -fy)]

    def drawing(self, st: State, i: int) -> list[np.ndarray]:
        out = []
        t = np.linspace(0.0, TWO_PI, 97)
        for body, s, r in ((self.a, self.s1, self.r1), (self.b, self.s2, self.r2)):
            x, y = st.point(body, s, [i])
            cx, cy = float(x[0]), float(y[0])
            out.append(np.stack([cx + r * np.cos(t), cy + r * np.sin(t)], axis=1))
            if body != st.nb:  # a mark on a moving gear: its frame's x axis, to see it turn
                th = float(st.th[body, i])
                out.append(np.array([[cx, cy], [cx + r * math.cos(th), cy + r * math.sin(th)]]))
        return out
