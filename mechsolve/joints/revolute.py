"""The revolute joint (a pin): the point ``point`` of link ``a`` and of link ``b`` coincide.

Equations (2): ``r_a + A_a s_a - r_b - A_b s_b = 0``; its multipliers are the force
exerted on ``b`` by ``a`` (``Fx``, ``Fy`` and the magnitude ``F``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from mechsolve.base.errors import suggest
from mechsolve.base.keyspec import K, Key, names, section
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


class PinReaction(Mapping):
    """A pin's reaction components ``Fx``, ``Fy`` and ``F``: the magnitude is computed
    when first read (a force analysis that reads only some joints' magnitudes, or none,
    does not pay for the others)."""

    __slots__ = ("fx", "fy", "_f")
    _KEYS = ("Fx", "Fy", "F")

    def __init__(self, fx: np.ndarray, fy: np.ndarray) -> None:
        self.fx, self.fy = fx, fy
        self._f: np.ndarray | None = None

    def __getitem__(self, key: str) -> np.ndarray:
        if key == "Fx":
            return self.fx
        if key == "Fy":
            return self.fy
        if key == "F":
            if self._f is None:
                fx, fy = self.fx, self.fy
                self._f = np.sqrt(fx * fx + fy * fy)
            return self._f
        raise KeyError(key)

    def __iter__(self):
        return iter(self._KEYS)

    def __len__(self) -> int:
        return 3

    def __repr__(self) -> str:
        return f"PinReaction({dict(self)!r})"


@dataclass
class PinJoint(Joint):
    """A revolute joint: the point ``point`` of link ``a`` and of link ``b`` coincide.

    Reactions are reported as the force exerted on ``b`` by ``a``.
    """

    name: str
    a: str
    b: str
    point: str
    where: KeyPath = ()
    friction: Friction | None = None

    kind: ClassVar[str] = "revolute"
    title: ClassVar[str] = "a pin"
    letter: ClassVar[str] = "R"
    coordinate: ClassVar[str | None] = "angle"
    keys: ClassVar[dict[str, Key]] = {
        "revolute": K(
            names("link", least=2),
            "The links pinned together: [link, link] (three or more: one pin through all).",
        ),
        "friction": K(
            section("joint friction"),
            "Friction in the joint: {coefficient: 0.1, journal radius: 10 mm} (a revolute "
            "or a slider).",
        ),
    }

    @property
    def links(self) -> tuple[str, str]:
        return (self.a, self.b)

    @property
    def label(self) -> str:
        return self.point

    def joins(self, point: str) -> bool:
        return point == self.point

    @classmethod
    def read(
        cls, r: Reader, name: str, m: Mapping, path: tuple, points: Mapping[str, Mapping]
    ) -> PinJoint:
        # one link is "2 or more" short (three or more are read as one pin through all)
        r.names(m["revolute"], path + ("revolute",), "link", least=2)
        a, b = r.names(m["revolute"], path + ("revolute",), "link", 2)
        point = r.name(m.get("point", name), path + ("point",), "point")
        fr = None
        if "friction" in m:
            fr = read_friction(r, m["friction"], path + ("friction",), cls.kind, name)
        return cls(name, a, b, point, where=path, friction=fr)

    def check(self, mech: Any, in_range: Callable[..., None]) -> None:
        for ln in self.links:
            if not mech.has_point(ln, self.point):
                pts = list(mech.ground) if ln == GROUND else list(mech.link(ln).points)
                raise mech.error(
                    self.where,
                    f"joint {self.name!r} is at point {self.point!r}, but "
                    + ("the ground" if ln == GROUND else f"link {ln!r}")
                    + f" has no point {self.point!r}"
                    + suggest(self.point, pts),
                )

    def equations(self, mech: Any, index: Mapping[str, int]) -> RevoluteConstraint:
        c = RevoluteConstraint(
            self.name,
            index[self.a],
            index[self.b],
            mech.local_point(self.a, self.point),
            mech.local_point(self.b, self.point),
        )
        if self.friction is not None:
            c.coulomb = self.friction.coefficient * self.friction.radius
            c.viscous = self.friction.viscous
        return c


class RevoluteConstraint(Constraint):
    """The pin's two equations between bodies ``a`` and ``b`` at local points ``sa``, ``sb``."""

    kind = "revolute"
    letter = "R"
    m = 2
    joins_points = True

    def __init__(self, name: str, a: int, b: int, sa, sb) -> None:
        self.name, self.a, self.b = name, a, b
        self.sa = np.asarray(sa, float)
        self.sb = np.asarray(sb, float)

    def residual(self, st: State, u=None) -> np.ndarray:
        xa, ya = st.point(self.a, self.sa)
        xb, yb = st.point(self.b, self.sb)
        return np.stack([xa - xb, ya - yb])

    def max_residual_into(self, st: State, u, out: np.ndarray) -> None:
        # row by row: stacking (2, N) temporaries is slower on long sweeps
        xa, ya = st.point(self.a, self.sa)
        xb, yb = st.point(self.b, self.sb)
        np.maximum(out, np.abs(xa - xb), out=out)
        np.maximum(out, np.abs(ya - yb), out=out)

    def max_residual_one(self, st: State, u) -> float:
        """:meth:`max_residual_into` at the one position of ``st``, in floats (the same
        operations as :meth:`State.point`; NaN when a coordinate is)."""
        if self.sa.ndim != 1 or self.sb.ndim != 1:  # one local vector per position
            return float(np.max(np.abs(self.residual(st, u))))
        (xa, ya), (xb, yb) = _point_one(st, self.a, self.sa), _point_one(st, self.b, self.sb)
        dx, dy = abs(xa - xb), abs(ya - yb)
        if dx != dx or dy != dy:
            return math.nan
        return dx if dx > dy else dy

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        out = {}
        for body, s, sign in ((self.a, self.sa, 1.0), (self.b, self.sb, -1.0)):
            if body == st.nb:
                continue
            rx, ry = st.rotated(body, s)
            blk = np.zeros((2, 3, st.n))
            blk[0, 0] = sign
            blk[1, 1] = sign
            blk[0, 2] = -sign * ry
            blk[1, 2] = sign * rx
            out[body] = blk
        return out

    def gamma(self, st: State, udd=None) -> np.ndarray:
        rax, ray = st.rotated(self.a, self.sa)
        rbx, rby = st.rotated(self.b, self.sb)
        wa2 = st.w[self.a] ** 2
        wb2 = st.w[self.b] ** 2
        return np.stack([rax * wa2 - rbx * wb2, ray * wa2 - rby * wb2])

    def incidence(self, nb: int) -> list[list[int]]:
        bodies = [b for b in (self.a, self.b) if b != nb]
        return [[3 * b + k for b in bodies] + [3 * b + 2 for b in bodies] for k in (0, 1)]

    def equation_names(self) -> list[str]:
        return [f"{self.name} (x)", f"{self.name} (y)"]

    def reaction(self, st: State, lam: np.ndarray) -> Mapping[str, np.ndarray]:
        return PinReaction(lam[:, 0], lam[:, 1])

    def indeterminate(self, free: np.ndarray) -> set[str]:
        return {k for k, on in zip(("Fx", "Fy"), free) if on} | {"F"}

    # -- friction: the friction circle rho = f r, a moment rho |F| against the slip ------
    def slip(self, st: State) -> np.ndarray:
        return st.w[self.b] - st.w[self.a]

    def load(self, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        f = np.hypot(lam[:, 0], lam[:, 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            grad = np.where(f[:, None] > 0, lam / f[:, None], 0.0)
        return f, grad

    def friction_pull(self, st: State) -> list[tuple]:
        sg = np.sign(self.slip(st))
        x, y = st.point(self.b, self.sb)
        zero = np.zeros(st.n)
        return [(self.b, x, y, zero, zero, -sg), (self.a, x, y, zero, zero, sg)]


def _point_one(st: State, i: int, s: np.ndarray) -> tuple[float, float]:
    """:meth:`State.point` of a constant local vector ``s`` at the one position of
    ``st``, in floats."""
    s0, s1 = float(s[0]), float(s[1])
    if i == st.nb:
        return s0, s1
    x, y = float(st.x[i, 0]), float(st.y[i, 0])
    if s0 == 0.0 and s1 == 0.0:
        return x, y
    c, sn = float(st.c[i, 0]), float(st.s[i, 0])
    return x + (c * s0 - sn * s1), y + (sn * s0 + c * s1)
