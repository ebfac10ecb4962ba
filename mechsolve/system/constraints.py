"""The constraint system Phi(q, t) = 0 in body coordinates, with its analytic derivatives.

Generalised coordinates are ``q = (x_1, y_1, theta_1, ..., x_n, y_n, theta_n)`` for the n
moving links. Each joint contributes equations:

* revolute joint (2): ``r_a + A_a s_a - r_b - A_b s_b = 0``; its multipliers are the
  force exerted on ``b`` by ``a``;
* slider joint (2): the block's point lies on the guide's line,
  ``n . (r_b + A_b s_b - r_a - A_a o_a) = 0`` with ``n`` the line's normal, and the
  block keeps the guide's orientation, ``theta_b - theta_a - beta = 0``;
* driver (1): the driven joint coordinate equals ``u(t)``.

Everything is evaluated for N positions at once from a :class:`~mechsolve.base.state.State`.
Velocities solve ``Phi_q qdot = nu`` and accelerations ``Phi_q qddot = gamma`` with
``nu = -Phi_t`` and ``gamma = -(Phi_q qdot)_q qdot - 2 Phi_qt qdot - Phi_tt``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mechsolve.base.state import State
from mechsolve.model import GROUND, Driver, Mechanism, PinJoint, SliderJoint


def _perp(vx, vy):
    """k x v: the vector rotated by +90 degrees."""
    return -vy, vx


class Constraint:
    """Base class. ``m`` equations between bodies ``a`` and ``b`` (index ``nb`` is ground).

    Subclasses return arrays of shape (m, N) for the residual, the velocity right-hand
    side ``nu`` and the acceleration right-hand side ``gamma``, and for each moving body
    involved the Jacobian block of shape (m, 3, N).
    """

    m: int = 0
    name: str = ""
    a: int
    b: int
    kind: str = ""

    def residual(self, st: State, u) -> np.ndarray:
        raise NotImplementedError

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        raise NotImplementedError

    def nu(self, st: State, ud) -> np.ndarray:
        return np.zeros((self.m, st.n))

    def gamma(self, st: State, udd) -> np.ndarray:
        raise NotImplementedError

    @property
    def bodies(self) -> tuple[int, int]:
        return (self.a, self.b)


class RevoluteConstraint(Constraint):
    kind = "revolute"
    m = 2

    def __init__(self, name: str, a: int, b: int, sa, sb) -> None:
        self.name, self.a, self.b = name, a, b
        self.sa = np.asarray(sa, float)
        self.sb = np.asarray(sb, float)

    def residual(self, st: State, u=None) -> np.ndarray:
        xa, ya = st.point(self.a, self.sa)
        xb, yb = st.point(self.b, self.sb)
        return np.stack([xa - xb, ya - yb])

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


class SliderConstraint(Constraint):
    kind = "slider"
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


class AngleDriverConstraint(Constraint):
    """``theta_b + delta - theta_a - u(t) = 0``: the driven relative angle."""

    kind = "driver"
    m = 1

    def __init__(self, name: str, a: int, b: int, delta: float) -> None:
        self.name, self.a, self.b, self.delta = name, a, b, delta

    def value(self, st: State) -> np.ndarray:
        return st.th[self.b] + self.delta - st.th[self.a]

    def residual(self, st: State, u) -> np.ndarray:
        return (self.value(st) - u)[None, :]

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


class SliderDriverConstraint(Constraint):
    """``s - u(t) = 0``: the driven slider displacement."""

    kind = "driver"
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


class RowSubset(Constraint):
    """Some of the equations of another constraint (the rest being redundant)."""

    def __init__(self, base: Constraint, rows: list[int]) -> None:
        self.base = base
        self.rows = list(rows)
        self.m = len(self.rows)
        self.name = base.name
        self.kind = base.kind + " (part)"
        self.a, self.b = base.a, base.b

    def residual(self, st: State, u) -> np.ndarray:
        return self.base.residual(st, u)[self.rows]

    def jacobian(self, st: State) -> dict[int, np.ndarray]:
        return {b: blk[self.rows] for b, blk in self.base.jacobian(st).items()}

    def nu(self, st: State, ud) -> np.ndarray:
        return self.base.nu(st, ud)[self.rows]

    def gamma(self, st: State, udd) -> np.ndarray:
        return self.base.gamma(st, udd)[self.rows]


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
            a, b = self.index[j.a], self.index[j.b]
            if isinstance(j, PinJoint):
                c: Constraint = RevoluteConstraint(
                    j.name, a, b, mech.local_point(j.a, j.point), mech.local_point(j.b, j.point)
                )
            else:
                assert isinstance(j, SliderJoint)
                c = SliderConstraint(
                    j.name, a, b, j.origin, j.angle, mech.local_point(j.b, j.point), j.block_angle
                )
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
        for c in self.constraints:
            if type(c) is RevoluteConstraint:
                xa, ya = st.point(c.a, c.sa)
                xb, yb = st.point(c.b, c.sb)
                np.maximum(out, np.abs(xa - xb), out=out)
                np.maximum(out, np.abs(ya - yb), out=out)
            else:
                np.maximum(out, np.abs(c.residual(st, u)).max(axis=0), out=out)
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
        names = []
        for c in self.constraints:
            if c.kind == "revolute":
                names += [f"{c.name} (x)", f"{c.name} (y)"]
            elif c.kind == "slider":
                names += [f"{c.name} (on line)", f"{c.name} (angle)"]
            else:
                names += [f"{c.name} (driver)"]
        return names


def make_driver(mech: Mechanism, d: Driver, system: ConstraintSystem) -> Constraint:
    j = mech.joint(d.joint)
    a, b = system.index[j.a], system.index[j.b]
    if isinstance(j, SliderJoint):
        sl = system.by_joint[j.name]
        assert isinstance(sl, SliderConstraint)
        return SliderDriverConstraint("driver", sl)
    delta = 0.0
    if d.line is not None:
        p = mech.local_point(j.b, d.line[0])
        q = mech.local_point(j.b, d.line[1])
        delta = math.atan2(q[1] - p[1], q[0] - p[0])
    return AngleDriverConstraint("driver", a, b, delta)
