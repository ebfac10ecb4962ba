"""The constraint system Phi(q, t) = 0 in body coordinates, with its analytic derivatives.

Generalised coordinates are ``q = (x_1, y_1, theta_1, ..., x_n, y_n, theta_n)`` for the n
moving links. Each joint contributes the equations its kind knows
(:meth:`mechsolve.joints.base.Joint.equations`: a revolute two, a slider two, ...); the
driver contributes one: the driven joint coordinate equals ``u(t)``.

Everything is evaluated for N positions at once from a :class:`~mechsolve.base.state.State`.
Velocities solve ``Phi_q qdot = nu`` and accelerations ``Phi_q qddot = gamma`` with
``nu = -Phi_t`` and ``gamma = -(Phi_q qdot)_q qdot - 2 Phi_qt qdot - Phi_tt``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mechsolve.base.state import State
from mechsolve.joints.base import Constraint
from mechsolve.joints.slider import SliderConstraint
from mechsolve.model import GROUND, Driver, Mechanism


class AngleDriverConstraint(Constraint):
    """``theta_b + delta - theta_a - u(t) = 0``: the driven relative angle."""

    kind = "driver"
    letter = "D"
    m = 1

    def __init__(self, name: str, a: int, b: int, delta: float) -> None:
        self.name, self.a, self.b, self.delta = name, a, b, delta

    def value(self, st: State) -> np.ndarray:
        return st.th[self.b] + self.delta - st.th[self.a]

    def residual(self, st: State, u) -> np.ndarray:
        return (self.value(st) - u)[None, :]

    def max_residual_one(self, st: State, u) -> float:
        """``|Phi|`` at the one position of ``st``, in floats."""
        tb, ta = float(st.th[self.b, 0]), float(st.th[self.a, 0])
        return abs(tb + self.delta - ta - float(np.asarray(u).reshape(-1)[0]))

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        out = {}
        for body, sign in ((self.a, -1.0), (self.b, 1.0)):
            if body != st.nb:
                blk = np.zeros((1, 3, st.n))
                blk[0, 2] = sign
                out[body] = blk
        return out

    def nu(self, st: State, ud) -> np.ndarray:
        return np.broadcast_to(np.asarray(ud, float), (st.n,))[None, :].copy()

    def gamma(self, st: State, udd) -> np.ndarray:
        return np.broadcast_to(np.asarray(udd, float), (st.n,))[None, :].copy()

    def incidence(self, nb: int) -> list[list[int]]:
        return [[3 * b + 2 for b in (self.a, self.b) if b != nb]]

    def equation_names(self) -> list[str]:
        return [f"{self.name} (driver)"]


class SliderDriverConstraint(Constraint):
    """``s - u(t) = 0``: the driven slider displacement."""

    kind = "driver"
    letter = "D"
    m = 1

    def __init__(self, name: str, slider: SliderConstraint) -> None:
        self.name = name
        self.slider = slider
        self.a, self.b = slider.a, slider.b

    def value(self, st: State) -> np.ndarray:
        return self.slider.displacement(st)

    def residual(self, st: State, u) -> np.ndarray:
        return (self.slider.displacement(st) - u)[None, :]

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        sl = self.slider
        ux, uy, nx, ny, dx, dy = sl.frame(st)
        out = {}
        if sl.a != st.nb:
            xp, yp = st.point(sl.b, sl.sb)
            blk = np.zeros((1, 3, st.n))
            blk[0, 0] = -ux
            blk[0, 1] = -uy
            blk[0, 2] = nx * (xp - st.x[sl.a]) + ny * (yp - st.y[sl.a])
            out[sl.a] = blk
        if sl.b != st.nb:
            rx, ry = st.rotated(sl.b, sl.sb)
            blk = np.zeros((1, 3, st.n))
            blk[0, 0] = ux
            blk[0, 1] = uy
            blk[0, 2] = -(nx * rx + ny * ry)
            out[sl.b] = blk
        return out

    def nu(self, st: State, ud) -> np.ndarray:
        return np.broadcast_to(np.asarray(ud, float), (st.n,))[None, :].copy()

    def gamma(self, st: State, udd) -> np.ndarray:
        sl = self.slider
        ux, uy, nx, ny, dx, dy = sl.frame(st)
        ddx, ddy = sl.ddot(st)
        wa, wb = st.w[sl.a], st.w[sl.b]
        rax, ray = st.rotated(sl.a, sl.o)
        rbx, rby = st.rotated(sl.b, sl.sb)
        g = (
            wa**2 * (ux * dx + uy * dy)
            - 2 * wa * (nx * ddx + ny * ddy)
            + wb**2 * (ux * rbx + uy * rby)
            - wa**2 * (ux * rax + uy * ray)
        )
        return (np.broadcast_to(np.asarray(udd, float), (st.n,)) + g)[None, :]

    def incidence(self, nb: int) -> list[list[int]]:
        return [[3 * b + k for b in (self.a, self.b) if b != nb for k in range(3)]]

    def equation_names(self) -> list[str]:
        return [f"{self.name} (driver)"]


class RowSubset(Constraint):
    """Some of the equations of another constraint (the rest being redundant)."""

    def __init__(self, base: Constraint, rows: list[int]) -> None:
        self.base = base
        self.rows = list(rows)
        self.m = len(self.rows)
        self.name = base.name
        self.kind = base.kind + " (part)"
        self.a, self.b = base.a, base.b

    def incidence(self, nb: int) -> list[list[int]]:
        full = self.base.incidence(nb)
        return [full[k] for k in self.rows]

    def equation_names(self) -> list[str]:
        full = self.base.equation_names()
        return [full[k] for k in self.rows]

    def residual(self, st: State, u) -> np.ndarray:
        return self.base.residual(st, u)[self.rows]

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        return {b: blk[self.rows] for b, blk in self.base.jacobian(st).items()}

    def nu(self, st: State, ud) -> np.ndarray:
        return self.base.nu(st, ud)[self.rows]

    def gamma(self, st: State, udd) -> np.ndarray:
        return self.base.gamma(st, udd)[self.rows]

    def law_breaks(self, st: State) -> np.ndarray | None:
        return self.base.law_breaks(st)


@dataclass
class Row:
    """Where a constraint's equations sit in the system."""

    constraint: Constraint
    start: int


class ConstraintSystem:
    """All constraints of a mechanism in body coordinates.

    Parameters
    ----------
    mech
        The validated mechanism.
    with_driver
        Include the driver equation (needed for kinematics; left out to count the
        mechanism's degrees of freedom).
    """

    def __init__(self, mech: Mechanism, with_driver: bool = True) -> None:
        self.mech = mech
        self.body_names = mech.link_names
        self.nb = len(self.body_names)
        self.index = {n: i for i, n in enumerate(self.body_names)}
        self.index[GROUND] = self.nb
        self.constraints: list[Constraint] = []
        self.by_joint: dict[str, Constraint] = {}
        for j in mech.joints:
            c = j.equations(mech, self.index)
            self.constraints.append(c)
            self.by_joint[j.name] = c
        self.driver: Constraint | None = None
        if with_driver and mech.driver is not None:
            self.driver = make_driver(mech, mech.driver, self)
            self.constraints.append(self.driver)
        self.rows: list[Row] = []
        k = 0
        for c in self.constraints:
            self.rows.append(Row(c, k))
            k += c.m
        self.nc = k
        self.nq = 3 * self.nb

    def without(self, drop: list[tuple[Constraint, int]]) -> ConstraintSystem:
        """A copy without the equations ``drop`` (constraint, equation index)."""
        import copy

        out = copy.copy(self)
        gone: dict[int, set[int]] = {}
        for c, k in drop:
            gone.setdefault(id(c), set()).add(k)
        cons: list[Constraint] = []
        for c in self.constraints:
            rm = gone.get(id(c), set())
            if not rm:
                cons.append(c)
            elif len(rm) < c.m:
                cons.append(RowSubset(c, [k for k in range(c.m) if k not in rm]))
        out.constraints = cons
        out.rows = []
        k = 0
        for c in cons:
            out.rows.append(Row(c, k))
            k += c.m
        out.nc = k
        return out

    # -- evaluation over N positions --------------------------------------------------
    def residual(self, st: State, u) -> np.ndarray:
        """Phi for all positions, shape (nc, N)."""
        return np.concatenate([c.residual(st, u) for c in self.constraints], axis=0)

    def max_residual(self, st: State, u) -> np.ndarray:
        """max |Phi| over the equations at each position (N,).

        Joint by joint on rows of N values: batching joints into (joints, N) temporaries
        is slower, as arrays of that size are allocated by mmap, page by page.
        """
        out = np.zeros(st.n)
        if st.n == 1:  # one position: revolute joints and drivers in floats
            r = 0.0
            for c in self.constraints:
                one = getattr(c, "max_residual_one", None)
                if one is None:
                    c.max_residual_into(st, u, out)
                    continue
                v = one(st, u)
                if v != v or v > r:  # NaN kept, as np.maximum keeps it
                    r = v
                    if v != v:
                        break
            np.maximum(out, r, out=out)
            return out
        for c in self.constraints:
            c.max_residual_into(st, u, out)
        return out

    def jacobian(self, st: State) -> np.ndarray:
        """Phi_q for all positions, shape (N, nc, nq)."""
        J = np.zeros((st.n, self.nc, self.nq))
        for row in self.rows:
            for body, blk in row.constraint.jacobian(st).items():
                J[:, row.start : row.start + row.constraint.m, 3 * body : 3 * body + 3] = (
                    blk.transpose(2, 0, 1)
                )
        return J

    def nu(self, st: State, ud) -> np.ndarray:
        return np.concatenate([c.nu(st, ud) for c in self.constraints], axis=0)

    def gamma(self, st: State, udd) -> np.ndarray:
        return np.concatenate([c.gamma(st, udd) for c in self.constraints], axis=0)

    def equation_names(self) -> list[str]:
        return [n for c in self.constraints for n in c.equation_names()]


def make_driver(mech: Mechanism, d: Driver, system: ConstraintSystem) -> Constraint:
    j = mech.joint(d.joint)
    a, b = system.index[j.a], system.index[j.b]
    if j.coordinate == "length":
        sl = system.by_joint[j.name]
        return SliderDriverConstraint("driver", sl)
    delta = 0.0
    if d.line is not None:
        p = mech.local_point(j.b, d.line[0])
        q = mech.local_point(j.b, d.line[1])
        delta = math.atan2(q[1] - p[1], q[0] - p[0])
    return AngleDriverConstraint("driver", a, b, delta)
