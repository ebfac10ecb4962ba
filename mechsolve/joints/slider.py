"""The slider (a prismatic joint): a block slides along a straight line fixed in its guide.

The guide may be the ground or a moving link (a slotted bar, a sliding block on a rotating
guide). Equations (2): the block's point lies on the guide's line,
``n . (r_b + A_b s_b - r_a - A_a o_a) = 0`` with ``n`` the line's normal, and the block
keeps the guide's orientation, ``theta_b - theta_a - beta = 0``. Its multipliers are the
normal force ``N`` on the block (with its components ``Fx``, ``Fy``) and the moment ``M``
that the guide exerts on it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from mechsolve.base.errors import suggest
from mechsolve.base.keyspec import ANGLE, LENGTH, XY, K, Key, Section, either, name, names, section
from mechsolve.base.state import State
from mechsolve.joints.base import (
    GROUND,
    Constraint,
    Friction,
    Joint,
    KeyPath,
    Reader,
    read_friction,
)

GUIDE_LINE = Section(
    "guide line",
    "A slider's guide line on the guide link: through a point at an angle, or at an "
    "offset from the link's origin.",
    {
        "through": K(either(name("point"), XY), "A point of the line: a name or [x, y]."),
        "angle": K(ANGLE, "The line's angle in the guide's frame (default 0)."),
        "offset": K(LENGTH, "The line's distance from the guide's origin (default 0)."),
    },
)


def read_line(
    r: Reader, value: Any, path: KeyPath, guide: str, points: dict[str, tuple[float, float]]
) -> tuple[tuple[float, float], float]:
    """A guide line: ``[P, Q]`` (two points of the guide), ``{through, angle}`` or
    ``{offset, angle}``."""
    where = "the ground" if guide == GROUND else f"link {guide!r}"
    if isinstance(value, list) and len(value) == 2 and all(isinstance(v, str) for v in value):
        if not any("," in v for v in value) and all(v in points for v in value):
            (x0, y0), (x1, y1) = points[value[0]], points[value[1]]
            if x0 == x1 and y0 == y1:
                raise r.fail(path, f"the line {value[0]} -> {value[1]} has zero length")
            return (x0, y0), math.atan2(y1 - y0, x1 - x0)
        bad = [v for v in value if v not in points]
        if bad and not any(ch.isdigit() for ch in bad[0][:1]) and " " not in bad[0]:
            raise r.fail(path, f"{where} has no point {bad[0]!r}" + suggest(bad[0], list(points)))
    m = r.mapping(value, path, GUIDE_LINE.allowed, "a guide line ([P, Q] or {through, angle})")
    angle = r.quantity(m.get("angle", 0.0), path + ("angle",), "angle")
    if "through" in m and "offset" in m:
        raise r.fail(path, "give either 'through' or 'offset', not both")
    if "through" in m:
        t = m["through"]
        if isinstance(t, str) and t in points:
            origin = points[t]
        elif isinstance(t, str) and "," not in t:
            raise r.fail(
                path + ("through",), f"{where} has no point {t!r}" + suggest(t, list(points))
            )
        else:
            origin = r.xy(t, path + ("through",))
    else:
        e = r.quantity(m.get("offset", 0.0), path + ("offset",), "length")
        origin = (-e * math.sin(angle), e * math.cos(angle))
    return origin, angle


@dataclass
class SliderJoint(Joint):
    """A prismatic joint: ``block`` slides along a straight line fixed in ``guide``.

    The block's point ``point`` stays on the line through ``origin`` (guide frame) in the
    direction ``angle`` (guide frame); the block keeps the orientation of the guide plus
    ``block_angle``. The slider's displacement ``s`` is measured from ``origin`` along
    the line direction.
    """

    name: str
    guide: str
    block: str
    point: str
    origin: tuple[float, float]
    angle: float
    block_angle: float = 0.0
    where: KeyPath = ()
    friction: Friction | None = None

    kind: ClassVar[str] = "slider"
    title: ClassVar[str] = "a block on a guide line"
    roles: ClassVar[tuple[str, str]] = ("guide", "block")
    letter: ClassVar[str] = "P"
    coordinate: ClassVar[str | None] = "length"
    magnitude: ClassVar[str] = "N"
    magnitude_note: ClassVar[str] = " normal"
    keys: ClassVar[dict[str, Key]] = {
        "slider": K(names("link", 2), "[guide, block]: the block slides on the guide's line."),
        "line": K(
            either(names("point", 2), section("guide line")),
            "A slider's guide line: [P, Q] (two points of the guide) or {through, angle}.",
        ),
        "block_angle": K(ANGLE, "The block's angle relative to the line (default 0)."),
        "friction": K(
            section("joint friction"),
            "Friction in the joint: {coefficient: 0.15} (a slider) or {coefficient: 0.1, "
            "journal radius: 10 mm} (a revolute).",
        ),
    }

    @property
    def a(self) -> str:
        return self.guide

    @property
    def b(self) -> str:
        return self.block

    @property
    def links(self) -> tuple[str, str]:
        return (self.guide, self.block)

    @property
    def direction(self) -> np.ndarray:
        return np.array([math.cos(self.angle), math.sin(self.angle)])

    @classmethod
    def read(
        cls, r: Reader, name: str, m: Mapping, path: tuple, points: Mapping[str, Mapping]
    ) -> SliderJoint:
        a, b = r.names(m["slider"], path + ("slider",), "link", 2)
        point = r.name(m.get("point", name), path + ("point",), "point")
        if "line" not in m:
            raise r.fail(path, f"slider {name!r} needs 'line': the guide line on {a!r}")
        guide_points = points.get(a)
        if guide_points is None:
            raise r.fail(path + ("slider",), f"no link named {a!r}" + suggest(a, list(points)))
        origin, angle = read_line(r, m["line"], path + ("line",), a, guide_points)
        block_angle = r.quantity(m.get("block_angle", 0.0), path + ("block_angle",), "angle")
        fr = None
        if "friction" in m:
            fr = read_friction(r, m["friction"], path + ("friction",), cls.kind, name)
        return cls(name, a, b, point, origin, angle, block_angle, where=path, friction=fr)

    def check(self, mech: Any, in_range: Callable[..., None]) -> None:
        if self.block == GROUND:
            raise mech.error(
                self.where,
                f"slider {self.name!r}: the ground cannot be the sliding block; "
                "list the guide first: slider: [guide, block]",
            )
        if not mech.has_point(self.block, self.point):
            pts = list(mech.link(self.block).points)
            raise mech.error(
                self.where,
                f"slider {self.name!r}: link {self.block!r} has no point {self.point!r}"
                + suggest(self.point, pts),
            )
        if not all(math.isfinite(v) for v in (*self.origin, self.angle, self.block_angle)):
            raise mech.error(self.where, "the guide line must have finite coordinates")
        in_range(mech, self.where + ("line",), "length", *self.origin)
        in_range(mech, self.where + ("line",), "angle", self.angle)
        in_range(mech, self.where + ("block_angle",), "angle", self.block_angle)

    def geometry(self) -> list[float]:
        return [*self.origin, self.angle, self.block_angle]

    def with_geometry(self, cols: Any) -> SliderJoint:
        origin = cols.pair()
        return dataclasses.replace(self, origin=origin, angle=cols.one(), block_angle=cols.one())

    def equations(self, mech: Any, index: Mapping[str, int]) -> SliderConstraint:
        c = SliderConstraint(
            self.name,
            index[self.guide],
            index[self.block],
            self.origin,
            self.angle,
            mech.local_point(self.block, self.point),
            self.block_angle,
        )
        if self.friction is not None:
            c.coulomb = self.friction.coefficient
            c.viscous = self.friction.viscous
        return c

    def describe(
        self, length: Callable[[float], str], angle: Callable[[float], str], unit: str
    ) -> tuple[str, str, str]:
        ox, oy = self.origin
        return (
            f"{self.guide} (guide) – {self.block} (block)",
            self.point,
            f"line through ({length(ox)}, {length(oy)}) {unit} at {angle(self.angle)}° in the "
            "guide's frame",
        )


class SliderConstraint(Constraint):
    """The slider's two equations: the block's point on the guide's line, the block at
    the guide's angle plus ``beta``."""

    kind = "slider"
    slides = True
    letter = "P"
    m = 2

    def __init__(self, name: str, a: int, b: int, origin, angle: float, sb, beta: float) -> None:
        self.name, self.a, self.b = name, a, b
        self.o = np.asarray(origin, float)
        self.u_loc = np.array([math.cos(angle), math.sin(angle)])
        self.sb = np.asarray(sb, float)
        self.beta = beta

    # helpers shared with the slider driver and the slider outputs
    def frame(self, st: State):
        """Global line direction u, normal n, and d = r_P(block) - r_O(guide)."""
        ux, uy = st.rotated(self.a, self.u_loc)
        nx, ny = -uy, ux
        xo, yo = st.point(self.a, self.o)
        xp, yp = st.point(self.b, self.sb)
        return ux, uy, nx, ny, xp - xo, yp - yo

    def ddot(self, st: State):
        """Time derivative of d."""
        vox, voy = st.point_velocity(self.a, self.o)
        vpx, vpy = st.point_velocity(self.b, self.sb)
        return vpx - vox, vpy - voy

    def residual(self, st: State, u=None) -> np.ndarray:
        ux, uy, nx, ny, dx, dy = self.frame(st)
        return np.stack([nx * dx + ny * dy, st.th[self.b] - st.th[self.a] - self.beta])

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        ux, uy, nx, ny, dx, dy = self.frame(st)
        out = {}
        if self.a != st.nb:
            xp, yp = st.point(self.b, self.sb)
            blk = np.zeros((2, 3, st.n))
            blk[0, 0] = -nx
            blk[0, 1] = -ny
            blk[0, 2] = -(ux * (xp - st.x[self.a]) + uy * (yp - st.y[self.a]))
            blk[1, 2] = -1.0
            out[self.a] = blk
        if self.b != st.nb:
            rx, ry = st.rotated(self.b, self.sb)
            blk = np.zeros((2, 3, st.n))
            blk[0, 0] = nx
            blk[0, 1] = ny
            blk[0, 2] = ux * rx + uy * ry
            blk[1, 2] = 1.0
            out[self.b] = blk
        return out

    def gamma(self, st: State, udd=None) -> np.ndarray:
        ux, uy, nx, ny, dx, dy = self.frame(st)
        ddx, ddy = self.ddot(st)
        wa, wb = st.w[self.a], st.w[self.b]
        rax, ray = st.rotated(self.a, self.o)
        rbx, rby = st.rotated(self.b, self.sb)
        g1 = (
            wa**2 * (nx * dx + ny * dy)
            + 2 * wa * (ux * ddx + uy * ddy)
            + wb**2 * (nx * rbx + ny * rby)
            - wa**2 * (nx * rax + ny * ray)
        )
        return np.stack([g1, np.zeros(st.n)])

    # the slider's relative motion, for outputs and for a linear driver
    def displacement(self, st: State) -> np.ndarray:
        ux, uy, nx, ny, dx, dy = self.frame(st)
        return ux * dx + uy * dy

    def velocity(self, st: State) -> np.ndarray:
        ux, uy, nx, ny, dx, dy = self.frame(st)
        ddx, ddy = self.ddot(st)
        return st.w[self.a] * (nx * dx + ny * dy) + ux * ddx + uy * ddy

    def acceleration(self, st: State) -> np.ndarray:
        ux, uy, nx, ny, dx, dy = self.frame(st)
        ddx, ddy = self.ddot(st)
        aox, aoy = st.point_acceleration(self.a, self.o)
        apx, apy = st.point_acceleration(self.b, self.sb)
        wa, al = st.w[self.a], st.al[self.a]
        return (
            al * (nx * dx + ny * dy)
            - wa**2 * (ux * dx + uy * dy)
            + 2 * wa * (nx * ddx + ny * ddy)
            + ux * (apx - aox)
            + uy * (apy - aoy)
        )

    # -- what the contract asks ---------------------------------------------------------
    def incidence(self, nb: int) -> list[list[int]]:
        bodies = [b for b in (self.a, self.b) if b != nb]
        return [[3 * b + k for b in bodies for k in range(3)], [3 * b + 2 for b in bodies]]

    def equation_names(self) -> list[str]:
        return [f"{self.name} (on line)", f"{self.name} (angle)"]

    def reaction(self, st: State, lam: np.ndarray) -> dict[str, np.ndarray]:
        nrm = -lam[:, 0]
        mom = -lam[:, 1]
        ux, uy, nx, ny, _, _ = self.frame(st)
        return {"N": nrm, "M": mom, "Fx": nrm * nx, "Fy": nrm * ny}

    def indeterminate(self, free: np.ndarray) -> set[str]:
        return ({"N", "Fx", "Fy"} if free[0] else set()) | ({"M"} if free[1] else set())

    # -- friction: f |N| along the line against the sliding ----------------------------
    def slip(self, st: State) -> np.ndarray:
        return self.velocity(st)

    def load(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        grad = np.zeros_like(lam)
        grad[:, 0] = np.sign(lam[:, 0])
        return np.abs(lam[:, 0]), grad

    def friction_pull(self, st: State) -> list[tuple]:
        """The friction force acts along the line at the block's point (the moment ``M``
        the guide carries adds none: a short block's edge forces are not modelled)."""
        sg = np.sign(self.slip(st))
        ux, uy = st.rotated(self.a, self.u_loc)
        x, y = st.point(self.b, self.sb)
        zero = np.zeros(st.n)
        return [(self.b, x, y, -sg * ux, -sg * uy, zero), (self.a, x, y, sg * ux, sg * uy, zero)]

    def friction_reaction(self, st: State, t: np.ndarray) -> dict[str, np.ndarray]:
        """The guide's contact force is the normal force and the friction along the line
        (``N`` stays the normal force alone)."""
        _, _, _, fx, fy, _ = self.friction_pull(st)[0]
        return {"Fx": t * fx, "Fy": t * fy}

    def guide(self, st: State, scale: float) -> np.ndarray | None:
        if self.a != st.nb:  # a moving guide is drawn with its link
            return None
        s_all = self.displacement(st)
        s_all = s_all[np.isfinite(s_all)]
        if s_all.size == 0:
            return None
        lo, hi = float(s_all.min()), float(s_all.max())
        pad = 0.15 * (hi - lo) + 0.05 * scale
        ss = np.array([lo - pad, hi + pad])
        return np.stack([self.o[0] + ss * self.u_loc[0], self.o[1] + ss * self.u_loc[1]], axis=1)
