"""Forward dynamics of any planar mechanism in body coordinates (``mechsolve simulate``'s
general path).

The equations of motion of the bodies' coordinates ``q = (x_i, y_i, theta_i)`` with the
constraints of every joint (asked of the joint contract through
:class:`~mechsolve.system.constraints.ConstraintSystem`)::

    M(q) q'' + Phi_q^T lambda = Q(q, q', t),     Phi(q, t) = 0

Formulation: **coordinate partitioning** (Wehage and Haug). At a configuration the
Jacobian is split, by QR with column pivoting, into r independent equations (r its rank:
redundant equations, such as a parallelogram's extra link, are set aside) and r dependent
coordinates ``d`` whose block ``Phi_d`` is the best conditioned; the other ``f = nq - r``
coordinates ``z`` are independent. The motion is ``(z, z')``: at every evaluation the
dependent coordinates are closed from ``z``. The integrator (scipy's ``solve_ivp`` with
the user's rtol/atol, or RK4 with a fixed step) carries all the coordinates and rates
``(q, q')`` all the same, so that its error control sees the dependent ones too: near a
singular passage, where ``z`` maps to them ill-conditioned, it shortens its step instead
of stepping across (the integrated dependent values are Newton's start, never the
motion). At every evaluation the dependent
coordinates are solved by Newton's method on ``Phi = 0`` (to the constraint tolerance),
their rates from ``Phi_q q' = nu`` and the accelerations with the multipliers from the
augmented system ``[M Phi_r^T; Phi_r 0] [q''; lambda] = [Q; gamma]``. So the constraints
hold at position level to the Newton tolerance at every output and at velocity and
acceleration level to rounding: they do not drift however long the run. Where ``Phi_d``
becomes ill-conditioned (the chosen coordinates stop describing the motion) the
integration restarts with a new partition. The reactions at every output are the
multipliers of all equations, by least squares with minimum norm: unique where the
equations are independent, the minimum-norm solution (marked so) where they are not.

The work of the non-conservative forces (motors, dampers, forces, torques, conditional
springs) is integrated with the motion, so the energy balance ``T + V - W`` is a check of
the integration's error (constant to the integrator's tolerance).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.analyses.dynamics.multibody_friction import JointFriction
from mechsolve.analyses.dynamics.multibody_loads import ArrayLoads
from mechsolve.analyses.dynamics.multibody_pins import Pins
from mechsolve.base.state import State
from mechsolve.core.loads import _Q, apply_loads, stroke_function
from mechsolve.system.constraints import ConstraintSystem, make_driver

if TYPE_CHECKING:
    from mechsolve.core.sweep import Analysis

RECONDITION = 1e-3  # repartition when Phi_d's reciprocal condition falls below this
NEWTON_ITERATIONS = 25
S_SOLVE = 1e-8  # below this r-th relative singular value: the least-squares accelerations
RATES_RCOND = 1e-6  # consistent rates: singular directions below this of the largest are kept


class Repartition(Exception):
    """The partition no longer describes the motion (Newton failed or Phi_d is singular)."""


class NotClosing(Exception):
    """The mechanism cannot close at a state reached by the motion."""

    def __init__(self, t: float, why: str) -> None:
        super().__init__(why)
        self.t = t


@dataclass
class Source:
    """A generalised force on a joint coordinate: a motor's torque-speed law.

    ``coordinate``: the joint coordinate's constraint object (its Jacobian row ``c_q``);
    ``law(rate, t)``: the effort (torque or force) along the coordinate."""

    name: str
    coordinate: object
    law: Callable[[float, float], float]
    text: str = ""  # the law and its joint, for the summary


@dataclass
class Prescribed:
    """A joint coordinate moving by a law of time: ``u(t), u'(t), u''(t)``."""

    name: str
    coordinate: object
    law: Callable[[float], tuple[float, float, float]]


@dataclass
class Stop:
    """A condition that ends the run (``simulate``'s ``stop when``).

    ``g(t, q, q', q'')`` is positive while the condition does not hold and zero or
    negative once it does: the difference of the two sides where the condition is one
    comparison (its root is located by the integrator's event finder to the
    integrator's accuracy), else +1/-1 (the switch is located by bisection)."""

    g: Callable[[float, np.ndarray, np.ndarray, np.ndarray], float]
    text: str


@dataclass
class Partition:
    rows: np.ndarray  # independent equations
    dep: np.ndarray  # dependent coordinates
    ind: np.ndarray  # independent coordinates
    rcond: float  # Phi_d's reciprocal condition when chosen
    rcond1: float = 1.0  # its 1-norm estimate (LAPACK gecon), for the checks at each step

    def __post_init__(self) -> None:
        # the blocks Phi_d and Phi_z as index tuples, built once per partition
        self.dd = np.ix_(self.rows, self.dep)
        self.di = np.ix_(self.rows, self.ind)


@dataclass
class Trajectory:
    """The motion at the output times: body coordinates and their rates, the
    multipliers of all equations, the energies and the constraint violation."""

    t: np.ndarray
    q: np.ndarray  # (n, nq)
    qd: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray  # (n, nc) minimum-norm multipliers of every equation
    kinetic: np.ndarray
    potential: np.ndarray
    work: np.ndarray  # of the non-conservative forces since the start
    violation: np.ndarray  # max |Phi| at each output (m or rad)
    velocity_violation: np.ndarray  # max |Phi_q q' - nu|
    redundant: bool = False  # the multipliers are minimum-norm (redundant equations)
    stopped: str = ""  # why the run ended before its duration (a stop condition too)
    early: bool = False  # it ended for a reason other than its stop condition
    event: str = ""  # "stop when", "singular" or "branch": the event that ended it
    nfev: int = 0
    partitions: int = 1
    bridges: int = 0  # output steps bridged on all coordinates (at singular positions)
    error: Exception | None = None  # an input error that stopped it (none on this path)
    # the driver coordinate, its rate and acceleration (set from the results)
    u: np.ndarray | None = None
    ud: np.ndarray | None = None
    udd: np.ndarray | None = None

    @property
    def undetermined(self) -> np.ndarray:
        """The times of the rows whose accelerations and multipliers the equations do
        not determine (at or next to a singular position): left empty (NaN)."""
        return self.t[~np.isfinite(self.qdd).all(axis=1)]

    def undetermined_text(self) -> str:
        """A summary line for :attr:`undetermined` ("" where there are none)."""
        ts = self.undetermined
        if not ts.size:
            return ""
        at = ", ".join(f"{t:.6g}" for t in ts[:8]) + (
            f" and {ts.size - 8} more" if ts.size > 8 else ""
        )
        return (
            f"  warning: the accelerations and reactions at t = {at} s are not determined "
            "(at or next to a singular position the equations give them only to worse "
            "than 1e-6 of their size): left blank in the CSV"
        )

    @property
    def energy_residual(self) -> np.ndarray:
        """``T + V - W - (T0 + V0)``: zero for an exact integration (J)."""
        e = self.kinetic + self.potential - self.work
        return e - e[0]


class Multibody:
    """The equations of motion of a mechanism in body coordinates.

    Parameters
    ----------
    an
        The mechanism's analysis (its loads, points and conditions are read through it).
    sources
        Motors acting on joint coordinates.
    prescribed
        Joint coordinates moving by a law of time (rheonomic constraints).
    tolerance
        max |Phi| to which Newton's method closes the mechanism (m; rad for angles).
    """

    def __init__(
        self,
        an: Analysis,
        sources: list[Source] | None = None,
        prescribed: list[Prescribed] | None = None,
        tolerance: float | None = None,
    ) -> None:
        self.an = an
        mech = an.mech
        self.mech = mech
        self.system = ConstraintSystem(mech, with_driver=False)
        self.prescribed = list(prescribed or [])
        for p in self.prescribed:
            self.system.constraints.append(p.coordinate)
        self.system.rows = []
        k = 0
        from mechsolve.system.constraints import Row

        for c in self.system.constraints:
            self.system.rows.append(Row(c, k))
            k += c.m
        self.system.nc = k
        self.sources = list(sources or [])
        self.nb = self.system.nb
        self.nq = 3 * self.nb
        self.nc = self.system.nc
        self.scale = an.scale
        self.tol = tolerance if tolerance is not None else 1e-10 * self.scale
        self.gx, self.gy = mech.gravity_vector()
        idx = self.system.index
        self.m = np.zeros(self.nb)
        self.J = np.zeros(self.nb)
        self.s = np.zeros((self.nb, 2))
        for lk in mech.links:
            b = idx[lk.name]
            self.m[b] = lk.mass or 0.0
            self.J[b] = lk.inertia or 0.0
            if lk.com is not None:
                self.s[b] = lk.com
        # all pins and nothing prescribed: the equations on arrays of all pins at once
        self.pins = (
            Pins(self.system.constraints, self.nb)
            if not self.prescribed and Pins.applies(self.system.constraints)
            else None
        )
        # the mass matrix's entries by flat index: its diagonal is constant, the
        # couplings of the centre of mass's arm are written at each configuration
        i, nq = np.arange(self.nb) * 3, self.nq
        self._m_diag = np.concatenate([i * (nq + 1), (i + 1) * (nq + 1), (i + 2) * (nq + 1)])
        self._m_const = np.concatenate(
            [self.m, self.m, self.J + self.m * np.sum(self.s * self.s, axis=1)]
        )
        self._m_x, self._m_xt = i * nq + i + 2, (i + 2) * nq + i
        self._m_y, self._m_yt = (i + 1) * nq + i + 2, (i + 2) * nq + i + 1
        self.conditional = [ld for ld in mech.loads if ld.when is not None]
        self.array_loads = ArrayLoads(mech, idx, self.nb) if ArrayLoads.applies(mech) else None
        self._mg, self._mgy = self.m * self.gx, self.m * self.gy
        self._sx, self._sy = self.s[:, 0].copy(), self.s[:, 1].copy()
        self.extremes: list = []
        self.nfev = 0
        self._last = None  # (t, q, q', q''): the last closed state, Newton's guess
        self._chord = None  # (partition, Phi_d) of the last evaluation
        # the joints' friction (None: ideal joints), solved with the multipliers
        self.friction = JointFriction.of(self, NotClosing)
        # the evaluation on arrays alone: pins, loads on arrays (or none), no motor, ideal
        # joints
        self.lite = (
            self.pins is not None
            and not self.sources
            and self.friction is None
            and (not mech.loads or self.array_loads is not None)
        )
        self._ev = None  # the last evaluation of accelerations(), for output()
        self.rc = 1.0  # Phi_d's reciprocal condition (1-norm) at the last rates()
        # the number of independent equations where some are redundant (set by the run
        # from its start): the rank of every partition and of the solves on every
        # equation (see multibody_full); None where they are all independent
        self.rank: int | None = None
        self.weights = np.ones(self.nq)  # the angle columns weighed by the size
        self.weights[2::3] = 1.0 / self.scale

    # -- states ---------------------------------------------------------------------
    def state(self, q: np.ndarray, qd=None, qdd=None) -> State:
        """A one-position :class:`State` with poses ``q`` (and rates)."""
        st = State(self.nb, 1)
        nb = self.nb
        st.x[:nb, 0] = q[0::3]
        st.y[:nb, 0] = q[1::3]
        st.th[:nb, 0] = q[2::3]
        st.c[:nb, 0] = np.cos(q[2::3])
        st.s[:nb, 0] = np.sin(q[2::3])
        if qd is not None:
            st.vx[:nb, 0], st.vy[:nb, 0], st.w[:nb, 0] = qd[0::3], qd[1::3], qd[2::3]
        if qdd is not None:
            st.ax[:nb, 0], st.ay[:nb, 0], st.al[:nb, 0] = qdd[0::3], qdd[1::3], qdd[2::3]
        return st

    def _u(self, t: float) -> tuple[float, float, float]:
        """The prescribed coordinates' values, rates and accelerations at ``t``."""
        if not self.prescribed:
            return 0.0, 0.0, 0.0
        vals = np.array([p.law(t) for p in self.prescribed], float)
        return vals[:, 0], vals[:, 1], vals[:, 2]

    def residual(self, q: np.ndarray, t: float) -> np.ndarray:
        if self.pins is not None:
            return self.pins.residual(q)
        st = self.state(q)
        u = self._u(t)[0]
        parts = [c.residual(st, 0.0)[:, 0] for c in self.system.constraints[: self._nj]]
        parts += [
            c.residual(st, np.atleast_1d(u)[k])[:, 0]
            for k, c in enumerate(self.system.constraints[self._nj :])
        ]
        return np.concatenate(parts) if parts else np.zeros(0)

    @property
    def _nj(self) -> int:
        return len(self.system.constraints) - len(self.prescribed)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        if self.pins is not None:
            return self.pins.jacobian(q)
        return self.system.jacobian(self.state(q))[0]

    def _nu_gamma(self, st: State, t: float, gamma: bool):
        if self.pins is not None:
            if not gamma:
                return np.zeros(self.nc)
            return self.pins.gamma(st.th[:-1, 0], st.w[:-1, 0])
        u, ud, udd = self._u(t)
        parts = []
        for k, c in enumerate(self.system.constraints):
            j = k - self._nj
            if gamma:
                parts.append(c.gamma(st, np.atleast_1d(udd)[j] if j >= 0 else 0.0)[:, 0])
            else:
                parts.append(c.nu(st, np.atleast_1d(ud)[j] if j >= 0 else 0.0)[:, 0])
        return np.concatenate(parts) if parts else np.zeros(0)

    # -- partition and closure ------------------------------------------------------
    def partition(self, q: np.ndarray) -> Partition:
        """Independent equations and dependent coordinates at ``q`` (QR with column
        pivoting; angles weighted by the mechanism's size so that lengths and angles
        compete fairly)."""
        from scipy.linalg import qr

        Jq = self.jacobian(q)
        w = np.ones(self.nq)
        w[2::3] = 1.0 / self.scale
        Js = Jq * w
        if Js.shape[0] == 0:
            return Partition(np.zeros(0, int), np.zeros(0, int), np.arange(self.nq), 1.0)
        _, R, p = qr(Js.T, pivoting=True, mode="economic")
        d = np.abs(np.diag(R))
        rank = int(np.sum(d > 1e-9 * max(d[0], 1e-300)))
        if self.rank is not None:  # the run's rank, also next to a singular position
            rank = self.rank
        rows = np.sort(p[:rank])
        _, R2, p2 = qr(Js[rows], pivoting=True, mode="economic")
        dep = np.sort(p2[:rank])
        ind = np.setdiff1d(np.arange(self.nq), dep)
        Jd = Jq[np.ix_(rows, dep)]
        return Partition(rows, dep, ind, _rcond(Jd), _lu(Jd)[1])

    def close(self, part: Partition, z: np.ndarray, t: float, guess: np.ndarray) -> np.ndarray:
        """The configuration with independent coordinates ``z``: Newton on the
        partition's equations for the dependent coordinates, from ``guess``."""
        q = guess.copy()
        q[part.ind] = z
        rows, dep = part.rows, part.dep
        if len(dep) == 0:  # no equations: every coordinate is independent
            return q
        # the chord: the factors of the last evaluation's Phi_d on this partition, a step away
        lu = self._chord[1] if self._chord is not None and self._chord[0] is part else None
        last = np.inf
        every = len(rows) == self.nc
        for _ in range(NEWTON_ITERATIONS):
            phi = self.residual(q, t)
            if not every:
                phi = phi[rows]
            size = float(np.abs(phi).max())
            if not math.isfinite(size):
                raise Repartition
            if size <= self.tol:
                # closed (a further chord step, with factors of a nearby configuration,
                # can move it away where Phi_d is ill-conditioned)
                return q
            if lu is None or size > 0.1 * last:  # the chord's Jacobian while it converges
                lu = _lu(self.jacobian(q)[part.dd])[0]
                if lu is None:
                    raise Repartition
            last = size
            q[dep] -= _solve(lu, phi)
        raise Repartition

    def guess(self, t: float) -> np.ndarray:
        """Newton's start at time ``t``: the last closed state carried on by its rates."""
        t0, q, qd, qdd = self._last
        dt = t - t0
        return q + qd * dt + (0.5 * dt * dt) * qdd

    def rates(self, part: Partition, q: np.ndarray, zd: np.ndarray, t: float):
        """All coordinates' rates from the independent ones: ``Phi_q q' = nu``."""
        Jq = self.jacobian(q)
        rows, dep, ind = part.rows, part.dep, part.ind
        qd = np.zeros(self.nq)
        qd[ind] = zd
        if len(dep) == 0:
            return qd, Jq
        lu, rc = _lu(Jq[part.dd])
        self.rc = rc
        if lu is None or rc < RECONDITION * part.rcond1:
            raise Repartition
        self._chord = (part, lu)
        rhs = -(Jq[part.di] @ zd)
        if self.pins is None:  # (pins: nu = 0)
            rhs += self._nu_gamma(self.state(q), t, gamma=False)[rows]
        qd[dep] = _solve(lu, rhs)
        return qd, Jq

    def _needs_repartition(self, part: Partition, q: np.ndarray) -> bool:
        """Phi_d has lost conditioning since the partition was chosen (by 10x): choose
        again while it is still well posed."""
        if len(part.dep) == 0:
            return False
        rc = _rcond(self.jacobian(q)[part.dd])
        if self.rank is not None and rc < 0.1 * self.partition(q).rcond:
            # redundant equations: a partition chosen next to a singular position is
            # ill-conditioned from the start; away from it one that is 10x better
            # closes the set-aside equations closer (their rates came 1e-9 off)
            return True
        return rc < 0.1 * part.rcond

    # -- mass and forces ----------------------------------------------------------------
    def mass_matrix(self, st: State) -> np.ndarray:
        """M(q) about each body's frame origin: [[m, 0, -m ry], [0, m, m rx],
        [-m ry, m rx, J + m |r|^2]] with r the centre of mass's arm."""
        return self._mass(st.c[:-1, 0], st.s[:-1, 0])

    def _arm(self, c: np.ndarray, s: np.ndarray):
        """The centres of mass's arms ``R(theta) s`` from the bodies' cos and sin."""
        sx, sy = self._sx, self._sy
        return c * sx - s * sy, s * sx + c * sy

    def _mass(self, c: np.ndarray, s: np.ndarray, arm=None) -> np.ndarray:
        """:meth:`mass_matrix` from the bodies' cos and sin (and their arms, if known)."""
        rx, ry = arm if arm is not None else self._arm(c, s)
        m = self.m
        M = np.zeros((self.nq, self.nq))
        flat = M.reshape(-1)
        flat[self._m_diag] = self._m_const  # m, m, J + m |s|^2 (|r| = |s|)
        flat[self._m_x] = flat[self._m_xt] = -m * ry  # (x, theta) and (theta, x)
        flat[self._m_y] = flat[self._m_yt] = m * rx
        return M

    def forces(self, st: State, t: float):
        """``(Q, P_nc, V)``: the generalised forces (gravity, the centripetal terms of
        off-origin centres of mass, the file's loads, the motors), the power of the
        non-conservative ones and the potential energy (gravity, unconditional springs)."""
        arrays = self.array_loads is not None
        acc = _Q(self.an, st) if self.mech.loads and not arrays else None
        w2 = st.w[:-1, 0] ** 2
        c, s = st.c[:-1, 0], st.s[:-1, 0]
        rx = c * self.s[:, 0] - s * self.s[:, 1]
        ry = s * self.s[:, 0] + c * self.s[:, 1]
        m = self.m
        Q = acc.Q[:, 0] if acc is not None else np.zeros(self.nq)
        Q[0::3] += m * (self.gx + w2 * rx)
        Q[1::3] += m * (self.gy + w2 * ry)
        Q[2::3] += m * (rx * self.gy - ry * self.gx)
        V = -float(np.sum(m * (self.gx * (st.x[:-1, 0] + rx) + self.gy * (st.y[:-1, 0] + ry))))
        P = 0.0
        if arrays:  # torques and springs that always act, on arrays
            nb = self.nb
            q = np.empty(self.nq)
            qd = np.empty(self.nq)
            q[0::3], q[1::3], q[2::3] = st.x[:nb, 0], st.y[:nb, 0], st.th[:nb, 0]
            qd[0::3], qd[1::3], qd[2::3] = st.vx[:nb, 0], st.vy[:nb, 0], st.w[:nb, 0]
            P, Vs = self.array_loads.apply(q, qd, Q)
            V += Vs
        elif acc is not None:  # the file's loads
            P, _, springs = apply_loads(self.an, st, self._active(st), acc)
            P = float(P[0])
            V += float(np.sum(springs[0]))
        for src in self.sources:
            row, rate = self._coordinate_row(src.coordinate, st)
            effort = float(src.law(rate, t))
            if not math.isfinite(effort):
                raise NotClosing(t, f"the motor {src.name}'s law gives {effort:g} at {rate:g}")
            Q += row * effort
            P += effort * rate
        return Q, P, V

    def _forces_lite(self, q, qd, c, s, arm=None):
        """:meth:`forces` from arrays, where every load is on arrays (no motor, no
        condition): gravity, the centripetal terms, torques and springs."""
        w2 = qd[2::3] ** 2
        rx, ry = arm if arm is not None else self._arm(c, s)
        m = self.m
        Q = np.empty(self.nq)
        Q[0::3] = m * (self.gx + w2 * rx)
        Q[1::3] = m * (self.gy + w2 * ry)
        Q[2::3] = m * (rx * self.gy - ry * self.gx)
        V = -float(self._mg @ (q[0::3] + rx) + self._mgy @ (q[1::3] + ry))
        P = 0.0
        if self.array_loads is not None:
            P, Vs = self.array_loads.apply(q, qd, Q)
            V += Vs
        return Q, P, V

    def _coordinate_row(self, coord, st: State):
        """A joint coordinate's Jacobian row (nq,) and its rate."""
        row = np.zeros(self.nq)
        for body, blk in coord.jacobian(st).items():
            row[3 * body : 3 * body + 3] = blk[0, :, 0]
        qd = np.empty(self.nq)
        qd[0::3], qd[1::3], qd[2::3] = st.vx[:-1, 0], st.vy[:-1, 0], st.w[:-1, 0]
        return row, float(row @ qd)

    def _active(self, st: State) -> dict:
        if not self.conditional:
            return {}
        from mechsolve.core.solution import StateView

        view = StateView(self.an, st)
        funcs = {"stroke": stroke_function(list(self.extremes), True)}
        out = {}
        for ld in self.conditional:
            with np.errstate(invalid="ignore"):
                val = ld.when.evaluate(view, funcs)
            out[ld.name] = np.broadcast_to(np.asarray(val, bool), (1,))
        return out

    # -- the equations of motion ----------------------------------------------------------
    def accelerations(self, part: Partition, q, qd, t: float, Jq=None):
        """``(q'', lambda_r, P_nc, V)`` from the augmented system on the partition's
        independent equations."""
        self.nfev += 1
        if Jq is None:
            Jq = self.jacobian(q)
        if self.lite:  # pins and loads on arrays: no State to build
            th, w = q[2::3], qd[2::3]
            c, s = np.cos(th), np.sin(th)
            arm = self._arm(c, s)
            M = self._mass(c, s, arm)
            Q, P, V = self._forces_lite(q, qd, c, s, arm)
            g = self.pins.gamma(th, w)[part.rows]
        else:
            st = self.state(q, qd)
            M = self.mass_matrix(st)
            Q, P, V = self.forces(st, t)
            g = self._nu_gamma(st, t, gamma=True)[part.rows]
        Jr = Jq[part.rows]
        r = len(part.rows)
        A = np.zeros((self.nq + r, self.nq + r))
        A[: self.nq, : self.nq] = M
        A[: self.nq, self.nq :] = Jr.T
        A[self.nq :, : self.nq] = Jr
        b = np.concatenate([Q, g])
        if self.friction is not None:  # the multipliers and the friction together
            x, Pf = self.friction.solve(st, A, b, part.rows, Jq, M, _linear, qd, t)
            P += Pf
        else:
            x = _linear(A, b)
        if not np.isfinite(x).all():
            raise NotClosing(
                t, "the accelerations are not determined (a massless link that can move?)"
            )
        if self.prescribed:  # the power the prescribed motions put in: -lambda u'
            ud = np.atleast_1d(self._u(t)[1])
            first = self.nc - len(self.prescribed)
            for k in range(len(self.prescribed)):
                at = np.flatnonzero(part.rows == first + k)
                if at.size:
                    P -= float(x[self.nq + at[0]]) * float(ud[k])
        self._ev = (q, qd, t, part, x, M, V, Jq)  # for output() at the same state
        return x[: self.nq], x[self.nq :], P, V

    def terms(self, q, qd, t: float):
        """``(Phi_q, M, Q, P_nc, V, gamma)`` at a state, on every equation."""
        Jq = self.jacobian(q)
        if self.lite:
            th = q[2::3]
            c, s = np.cos(th), np.sin(th)
            arm = self._arm(c, s)
            M = self._mass(c, s, arm)
            Q, P, V = self._forces_lite(q, qd, c, s, arm)
            return Jq, M, Q, P, V, self.pins.gamma(th, qd[2::3])
        st = self.state(q, qd)
        M = self.mass_matrix(st)
        Q, P, V = self.forces(st, t)
        return Jq, M, Q, P, V, self._nu_gamma(st, t, gamma=True)

    def free_accelerations(self, q, qd, t: float):
        """``(q'', P_nc)`` by least squares on the augmented system with every equation
        (for the steps across a singular position); with redundant equations on the
        run's rank (:func:`rank_solve`) but at the singular position."""
        self.nfev += 1
        Jq, M, Q, P, _, g = self.terms(q, qd, t)
        if self.rank is not None and self.friction is None:
            try:
                qdd, _, s = rank_solve(Jq, M, Q, g, self.rank, self.weights)
                if s >= S_SOLVE:
                    return qdd, P
            except np.linalg.LinAlgError:
                pass
        nc = Jq.shape[0]
        A = np.zeros((self.nq + nc, self.nq + nc))
        A[: self.nq, : self.nq] = M
        A[: self.nq, self.nq :] = Jq.T
        A[self.nq :, : self.nq] = Jq
        b = np.concatenate([Q, g])
        if self.friction is not None:
            st = self.state(q, qd)
            x, Pf = self.friction.solve(st, A, b, np.arange(nc), Jq, M, _free_least_squares, qd, t)
            P += Pf
        else:
            x = _free_least_squares(A, b)
        return x[: self.nq], P

    def multipliers(self, q, qd, qdd, t: float) -> np.ndarray:
        """The multipliers of every equation by least squares with minimum norm:
        ``Phi_q^T lambda = Q - M q''``."""
        st = self.state(q, qd, qdd)
        Q, _, _ = self.forces(st, t)
        rhs = Q - self.mass_matrix(st) @ qdd
        lam, *_ = np.linalg.lstsq(self.jacobian(q).T, rhs, rcond=1e-10)
        return lam

    def output(self, part: Partition, q, qd, t: float):
        """``(q'', lambda, T, V)`` at an output: what :meth:`accelerations`,
        :meth:`multipliers` and :meth:`energy` give, with one mass matrix and one
        evaluation of the forces each."""
        ev = self._ev
        if (
            ev is not None
            and ev[0] is q
            and ev[1] is qd
            and ev[2] == t
            and ev[3] is part
            and not self.conditional
            and len(part.rows) == self.nc
        ):
            # the evaluation that closed this state: its multipliers are those of every
            # equation (all independent, so unique) and no condition reads q''
            _, _, _, _, x, M, V, Jq = ev
            return x[: self.nq], x[self.nq :].copy(), 0.5 * float(qd @ M @ qd), V
        qdd, _, _, V = self.accelerations(part, q, qd, t)
        st = self.state(q, qd, qdd)
        Q, _, _ = self.forces(st, t)
        if self.friction is not None:  # the friction of that evaluation
            Q = Q + self.friction.last_Q
        M = self.mass_matrix(st)
        lam, *_ = np.linalg.lstsq(self.jacobian(q).T, Q - M @ qdd, rcond=1e-10)
        return qdd, lam, 0.5 * float(qd @ M @ qd), V

    def energy(self, q, qd, t: float) -> tuple[float, float]:
        st = self.state(q, qd)
        T = 0.5 * float(qd @ self.mass_matrix(st) @ qd)
        _, _, V = self.forces(st, t)
        return T, V

    def consistent_rates(self, q: np.ndarray, qd: np.ndarray, t: float = 0.0) -> np.ndarray:
        """The rates nearest ``qd`` (in the mass-weighted norm where there is mass) that
        satisfy ``Phi_q q' = nu``.

        Directions whose singular value is below :data:`RATES_RCOND` of the largest are
        left uncorrected: at (or next to) a singular position the residual's component
        along such a direction is rounding, and dividing it by a singular value of 1e-9
        would throw the rates far off the motion."""
        Jq = self.jacobian(q)
        nu = self._nu_gamma(self.state(q), t, gamma=False)
        r = nu - Jq @ qd
        # M = L L^T: the correction of least kinetic energy, L^-T (J L^-T)^+ r. M is
        # block diagonal (a body's 3 x 3 block), so is L: its inverse block by block
        # (the triangular solves of the whole matrix went to BLAS's threads, about 10
        # ms a call on a loaded machine)
        nb = self.nb
        i = np.arange(nb)
        blocks = self.mass_matrix(self.state(q)).reshape(nb, 3, nb, 3)[i, :, i, :]
        try:
            inv = np.linalg.inv(np.linalg.cholesky(blocks))
        except np.linalg.LinAlgError:  # a massless coordinate: the least correction
            dq, *_ = np.linalg.lstsq(Jq, r, rcond=RATES_RCOND)
            return qd + dq
        Linv = np.zeros((self.nq, self.nq))
        for b in range(nb):
            Linv[3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = inv[b]
        Jh = Jq @ Linv.T  # J L^-T
        if self.rank is None:
            dh, *_ = np.linalg.lstsq(Jh, r, rcond=RATES_RCOND)
        else:
            # redundant equations: the run's rank, down to S_SOLVE next to a singular
            # position (left there, the direction it is about to lose kept a bridge's
            # RK4 combination of turning tangents: 4.6e-6 J in T)
            U, S, Vt = np.linalg.svd(Jh, full_matrices=False)
            k = min(self.rank, int(np.sum(S > S_SOLVE * S[0])))
            dh = Vt[:k].T @ ((U[:, :k].T @ r) / S[:k])
        # (in this metric the kinetic energy changes only to second order in r, however
        # ill-conditioned J is next to a singular position)
        return qd + Linv.T @ dh


def trajectory_state(mb: Multibody, tr: Trajectory) -> State:
    """The trajectory's outputs as one :class:`State` over its N rows."""
    n, nb = len(tr.t), mb.nb
    st = State(nb, n)
    st.x[:nb], st.y[:nb], st.th[:nb] = tr.q[:, 0::3].T, tr.q[:, 1::3].T, tr.q[:, 2::3].T
    np.cos(st.th[:nb], out=st.c[:nb])
    np.sin(st.th[:nb], out=st.s[:nb])
    st.vx[:nb], st.vy[:nb], st.w[:nb] = tr.qd[:, 0::3].T, tr.qd[:, 1::3].T, tr.qd[:, 2::3].T
    st.ax[:nb], st.ay[:nb], st.al[:nb] = tr.qdd[:, 0::3].T, tr.qdd[:, 1::3].T, tr.qdd[:, 2::3].T
    st.token = State.new_token()
    return st


def free_context(mech) -> SimpleNamespace:
    """What :class:`Multibody` reads of an analysis, for a mechanism of any number of
    degrees of freedom (the sweep's :class:`~mechsolve.core.sweep.Analysis` needs one
    driver per degree of freedom): the mechanism, its constraints without a driver, its
    size and its named points (each on the body the sweep's analysis puts it on), so
    that conditions (conditional loads, ``stop when``) read the state as on the driver's
    path. ``stroke()`` needs the extremes over a turn of the driver and is refused."""
    from mechsolve.core.solution import PointRef
    from mechsolve.core.sweep import _scale

    if any(ld.when is not None and ld.when.uses("stroke") for ld in mech.loads):
        raise ValueError("stroke() needs the extremes over a turn of the driver")
    system = ConstraintSystem(mech, with_driver=False)
    points = {p: PointRef(system.nb, np.asarray(xy, float)) for p, xy in mech.ground.items()}
    for lk in mech.links:  # a point on the ground and a link is a ground point
        for p, xy in lk.points.items():
            points.setdefault(p, PointRef(system.index[lk.name], np.asarray(xy, float)))
    return SimpleNamespace(mech=mech, system=system, scale=_scale(mech), points=points)


def rank_solve(Jq: np.ndarray, M: np.ndarray, Q: np.ndarray, g: np.ndarray, rank: int, w):
    """``(q'', lambda, s)`` on every equation, ``rank`` of them independent (redundant
    equations; see :mod:`.multibody_full`).

    ``Phi_q q'' = gamma`` by least squares on the ``rank`` largest singular values of
    ``Phi_q W`` (``W = diag(w)``: the angle columns weighed by the mechanism's size), so
    that only the redundant directions are set aside, however small the ``rank``-th
    (next to a singular position); ``M q'' + Phi_q^T lambda = Q`` projected on the
    other directions (those of the motion) gives their part of ``q''``; ``lambda`` is
    the minimum-norm solution of ``Phi_q^T lambda = Q - M q''`` on the same ``rank``
    directions. ``s``: the ``rank``-th singular value of ``Phi_q W`` over the largest."""
    Js = Jq * w
    U, S, Vt = np.linalg.svd(Js)
    if rank == 0 or S[0] <= 0:
        qdd = np.linalg.solve(M, Q)
        return qdd, np.zeros(Jq.shape[0]), 1.0
    s = float(S[rank - 1] / S[0])
    Ur, Sr, Vr = U[:, :rank], S[:rank], Vt[:rank].T
    qc = w * (Vr @ ((Ur.T @ g) / Sr))  # the equations' part of q''
    N = w[:, None] * Vt[rank:].T  # the directions of the motion
    qdd = qc
    if N.shape[1]:
        qdd = qc + N @ np.linalg.solve(N.T @ M @ N, N.T @ (Q - M @ qc))
    lam = Ur @ ((Vr.T @ (w * (Q - M @ qdd))) / Sr)
    return qdd, lam, s


def _linear(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The augmented system's solution; at a singular position the least-squares one.
    LAPACK's ``gesv`` is called directly (numpy's wrapper costs more than the solve at a
    mechanism's sizes)."""
    from scipy.linalg.lapack import dgesv

    _, _, x, info = dgesv(A, b)
    if info != 0:  # a singular position: the least-squares motion
        return _least_squares(A, b)
    return x


def _least_squares(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.linalg.lstsq(A, b, rcond=1e-12)[0]


def _free_least_squares(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The augmented system with every equation across a singular position: singular
    values below sqrt(eps) of the largest count as zero. At the singular position they
    are those of the direction the equations lose, along which the stage states'
    departure from the constraints (not the motion) would be amplified by their inverse
    (1e-12 here lost 6e-4 J of the N-four-bar's 36 J in one RK4 substep)."""
    return np.linalg.lstsq(A, b, rcond=1e-8)[0]


def _lu(A: np.ndarray):
    """``(factors, rcond)``: the LU factors of a square ``A`` and LAPACK's estimate of its
    reciprocal condition in the 1-norm (cheaper than the singular values); ``(None, 0)``
    where ``A`` is singular or not finite. LAPACK is called directly: at the sizes of a
    mechanism (tens of equations) scipy's wrappers cost more than the factorisation."""
    from scipy.linalg.lapack import dgecon, dgetrf

    if A.size == 0:
        return None, 1.0
    lu, piv, info = dgetrf(A)
    if info != 0 or not np.isfinite(lu).all():
        return None, 0.0
    rc, _ = dgecon(lu, float(np.abs(A).sum(axis=0).max()), norm="1")
    return (lu, piv), float(rc)


def _solve(lu, b: np.ndarray) -> np.ndarray:
    """``A^-1 b`` from :func:`_lu`'s factors."""
    from scipy.linalg.lapack import dgetrs

    x, _ = dgetrs(lu[0], lu[1], b)
    return x


def _rcond(A: np.ndarray) -> float:
    if A.size == 0:
        return 1.0
    sv = np.linalg.svd(A, compute_uv=False)
    return float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0


def coordinate(mech, system: ConstraintSystem, joint: str, line=None):
    """A joint's coordinate (its relative angle or travel) as a one-equation
    constraint, the same measure a driver on it uses."""
    return make_driver(mech, SimpleNamespace(joint=joint, line=line), system)
