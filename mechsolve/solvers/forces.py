"""Kinetostatics: joint reactions and the driver's effort at every solved position.

d'Alembert's principle in body coordinates: the constraint forces balance the applied
and inertia forces, ``Phi_q^T lambda = Q_applied + Q_inertia``, with
``Q_inertia = -(m a_G, m a_G, J alpha)`` per body, expressed at the body's frame origin.
The multipliers give the reactions directly:

* revolute joint ``[a, b]``: ``lambda`` is the force exerted on ``b`` by ``a``;
* slider joint ``[guide, block]``: ``-lambda_1`` is the normal force on the block by the guide
  (along the line's left normal) and ``-lambda_2`` the moment on the block by the guide;
* driver: ``-lambda`` is the torque (force) the driver applies to the driven link.

``Phi_q`` is block lower-triangular in the order of the structural groups, so its transpose
is solved group by group from the last group back to the first (the classic dyad-by-dyad
kinetostatics), each with the group's own small square block. A group whose block is
singular at a position (a toggle or dead-centre position) makes the reactions there
indeterminate: they are reported as such, never filled from a bad solve.

Power balance (a built-in check at every position)::

    P_driver = dT/dt + dV/dt - P_loads

T is the kinetic energy, V the potential energy of gravity and unconditional springs,
P_loads the power of the applied forces, torques, dampers and conditional springs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..conditioning import (
    NEAR_SINGULAR_INDICATOR,
    NEAR_SINGULAR_RCOND,
    SINGULAR_INDICATOR,
    SINGULAR_RCOND,
    group_block,
    rcond,
)
from ..groups.generic import NewtonGroup
from ..model import GROUND, Damper, PointForce, Spring, Torque
from ..numerics import simpson

if TYPE_CHECKING:
    from ..sweep import Analysis, Solution


@dataclass
class ForceResult:
    """Reactions, driver effort, energies and the power balance over the positions.

    The energies and the power balance are computed when first read (a sweep that only
    wants reactions does not pay for them).
    """

    lam: np.ndarray  # (N, nc) Lagrange multipliers
    effort: np.ndarray  # (N,) driving torque (N m) or force (N) on the driven link
    reactions: dict[str, dict[str, np.ndarray]]
    active: dict[str, np.ndarray]  # per conditional load: where it acts
    power_loads: np.ndarray  # power of the applied loads (W)
    singular: list[tuple[int, str]] = field(default_factory=list)  # (position, group label)
    ok: np.ndarray | None = None
    load_power: dict[str, np.ndarray] = field(default_factory=dict)  # power of each load
    nonunique: dict[str, set[str]] = field(default_factory=dict)  # joint -> components
    stroke_extremes: list[tuple[float, float]] = field(default_factory=list)
    speed: np.ndarray | float = 0.0  # the driver's speed at each position (rad/s or m/s)
    # singular positions whose driver effort is its limit along the motion
    effort_by_limit: list[int] = field(default_factory=list)
    # positions next to a singular one (see mechsolve.conditioning), where the computed
    # effort carries rounding amplified by 1/s^3; and those of them whose effort is its
    # limit along the motion
    near_singular: dict[int, float] = field(default_factory=dict)  # position -> s
    effort_near_limit: list[int] = field(default_factory=list)
    # (kinetic, kinetic rate, potential, potential rate) on demand
    energy_terms: Callable[[], tuple] | None = field(default=None, repr=False)
    _energies: tuple | None = field(default=None, repr=False)

    def _terms(self) -> tuple:
        if self._energies is None:
            self._energies = self.energy_terms()
        return self._energies

    @property
    def kinetic(self) -> np.ndarray:
        """Kinetic energy T (J)."""
        return self._terms()[0]

    @property
    def kinetic_rate(self) -> np.ndarray:
        """dT/dt (W)."""
        return self._terms()[1]

    @property
    def potential(self) -> np.ndarray:
        """Potential energy V of gravity and unconditional springs (J)."""
        return self._terms()[2]

    @property
    def potential_rate(self) -> np.ndarray:
        """dV/dt (W)."""
        return self._terms()[3]

    @property
    def power_input(self) -> np.ndarray:
        """Power of the driver (W)."""
        return self.effort * self.speed

    @property
    def residual(self) -> np.ndarray:
        """Power balance: P_driver - dT/dt - dV/dt + P_loads (W), zero to rounding."""
        return self.power_input - self.kinetic_rate - self.potential_rate + self.power_loads


class _Q:
    """Accumulates generalised forces (nq, N) and their power."""

    def __init__(self, an: Analysis, sol: Solution) -> None:
        self.st = sol.state
        self.nb = an.system.nb
        self.Q = np.zeros((3 * self.nb, sol.state.n))

    def force(self, b: int, s, fx, fy, r=None) -> None:
        """A force (fx, fy) at the local point ``s`` of body ``b`` (``r``: the point's
        arm from the frame's origin, global components, when known)."""
        if b == self.nb:
            return
        rx, ry = self.st.rotated(b, np.asarray(s, float)) if r is None else r
        self.Q[3 * b] += fx
        self.Q[3 * b + 1] += fy
        self.Q[3 * b + 2] += rx * fy - ry * fx

    def torque(self, b: int, t) -> None:
        if b != self.nb:
            self.Q[3 * b + 2] += t


def stroke_function(
    extremes: list[tuple[float, float]], replay: bool = False, blocks: int | None = None
):
    """``stroke(q)``: the fraction of ``q`` between its extremes over the sweep.

    Over the sweep, the extremes are found from the samples and refined by a parabola
    through the three samples around each one (so that a coarse sweep still finds the true
    ends of the stroke), and recorded in ``extremes``. With ``replay``, the recorded
    extremes are used again, in the same order: for evaluating a condition at a single
    position between samples. With ``blocks``, the positions are that many sweeps one
    after another (designs solved as one batch, :mod:`mechsolve.batch`): each has its own
    extremes, recorded as arrays over the blocks.
    """
    calls = iter(extremes) if replay else None

    def stroke(q):
        q = np.asarray(q, float)
        if blocks is not None and calls is None:
            rows = np.broadcast_to(q, (q.size,)).reshape(blocks, -1)
            lo, hi = np.empty(blocks), np.empty(blocks)
            for j, r in enumerate(rows):
                good = np.flatnonzero(np.isfinite(r))
                if good.size < 2:
                    lo[j] = hi[j] = np.nan
                else:
                    lo[j] = _extreme(r, good, np.argmin, -1.0)
                    hi[j] = _extreme(r, good, np.argmax, 1.0)
            extremes.append((lo, hi))
            span = hi - lo
            with np.errstate(invalid="ignore", divide="ignore"):
                frac = (rows - lo[:, None]) / np.where(span > 0, span, np.inf)[:, None]
            return frac.ravel()
        if calls is not None:
            lo, hi = next(calls)
        else:
            good = np.flatnonzero(np.isfinite(q))
            if good.size < 2:
                return np.full_like(q, np.nan)
            lo = _extreme(q, good, np.argmin, -1.0)
            hi = _extreme(q, good, np.argmax, 1.0)
            extremes.append((lo, hi))
        span = hi - lo
        return (q - lo) / span if span > 0 else np.zeros_like(q)

    return stroke


def _extreme(q, good, arg, sign):
    vals = q[good]
    k = int(arg(vals))
    best = vals[k]
    if 0 < k < len(vals) - 1 and good[k + 1] - good[k - 1] == 2:
        a, b, c = vals[k - 1], vals[k], vals[k + 1]
        den = a - 2 * b + c
        if den * sign < 0:  # a true parabola vertex
            best = b - (c - a) ** 2 / (8 * den)
    return best


def condition_masks(
    an: Analysis, sol: Solution, view, extremes: list, replay: bool = False
) -> dict[str, np.ndarray]:
    """Where each conditional load acts (False where a position was not solved)."""
    out = {}
    funcs = {"stroke": stroke_function(extremes, replay, getattr(an, "blocks", None))}
    n = len(sol.u)
    for load in an.mech.loads:
        if load.when is None:
            continue
        with np.errstate(invalid="ignore"):
            val = load.when.evaluate(view, funcs)
        out[load.name] = np.broadcast_to(np.asarray(val, bool), (n,)) & sol.ok
    return out


def solve_forces(
    an: Analysis, sol: Solution, stroke_extremes: list[tuple[float, float]] | None = None
) -> ForceResult:
    """Kinetostatic analysis of a solved sweep (positions, velocities, accelerations).

    ``stroke_extremes``: the extremes that ``stroke(q)`` in load conditions uses, when
    they come from elsewhere (a long sweep solved in chunks); found over ``sol`` if None.
    """
    from ..sweep import StateView

    mech, sys_ = an.mech, an.system
    st = sol.state
    n = st.n
    nb = sys_.nb
    view = StateView(an, st)
    acc = _Q(an, sol)
    gx, gy = mech.gravity_vector()

    power_loads = np.zeros(n)
    springs = [0.0, 0.0]  # potential of unconditional springs and its rate

    # inertia and gravity, at each body's centre of mass
    massive = []
    for lk in mech.links:
        # numbers, or arrays over the positions of designs solved as one batch
        m = 0.0 if lk.mass is None else lk.mass
        J = 0.0 if lk.inertia is None else lk.inertia
        if not np.any(m) and not np.any(J):
            continue
        b = sys_.index[lk.name]
        s = np.asarray(lk.com if lk.com is not None else (0.0, 0.0), float)
        if s.ndim == 1 and not s.any():  # the centre at the frame's origin
            acc.force(b, s, m * (gx - st.ax[b]), m * (gy - st.ay[b]))
        else:
            r = st.rotated(b, s)  # the centre's arm: for its acceleration and moment
            rx, ry = r
            w2 = st.w[b] * st.w[b]
            ax = st.ax[b] - st.al[b] * ry - w2 * rx
            ay = st.ay[b] + st.al[b] * rx - w2 * ry
            acc.force(b, s, m * (gx - ax), m * (gy - ay), r)
        if np.any(J):
            acc.torque(b, -J * st.al[b])
        massive.append((b, m, J, s))

    def energy_terms():
        kinetic = np.zeros(n)
        kinetic_rate = np.zeros(n)
        potential = np.zeros(n) + springs[0]
        potential_rate = np.zeros(n) + springs[1]
        with np.errstate(invalid="ignore"):  # unsolved positions stay NaN
            for b, m, J, s in massive:
                xg, yg = st.point(b, s)
                vx, vy = st.point_velocity(b, s)
                ax, ay = st.point_acceleration(b, s)
                w, al = st.w[b], st.al[b]
                kinetic += 0.5 * m * (vx * vx + vy * vy) + 0.5 * J * w * w
                kinetic_rate += m * (vx * ax + vy * ay) + J * w * al
                potential += -m * (gx * xg + gy * yg)
                potential_rate += -m * (gx * vx + gy * vy)
        return kinetic, kinetic_rate, potential, potential_rate

    replay = stroke_extremes is not None
    extremes: list[tuple[float, float]] = list(stroke_extremes) if replay else []
    active = condition_masks(an, sol, view, extremes, replay)
    load_power: dict[str, np.ndarray] = {}
    with np.errstate(invalid="ignore"):  # unsolved positions stay NaN
        for load in mech.loads:
            before = power_loads.copy()
            on = active.get(load.name)
            f = on.astype(float) if on is not None else 1.0
            if isinstance(load, PointForce):
                b = sys_.index[load.link]
                s = an.mech.local_point(load.link, load.point)
                fx, fy = load.force
                if load.frame == "link":
                    fx, fy = st.rotated(b, np.array(load.force))
                fx, fy = fx * f, fy * f
                acc.force(b, s, fx, fy)
                vx, vy = st.point_velocity(b, s)
                power_loads += fx * vx + fy * vy
            elif isinstance(load, Torque):
                b = sys_.index[load.link]
                acc.torque(b, load.torque * f)
                power_loads += load.torque * f * st.w[b]
            elif isinstance(load, Damper) and load.slider is not None:
                sl = sys_.by_joint[load.slider]
                ux, uy, *_ = sl.frame(st)
                sd = sl.velocity(st)
                fmag = -load.coefficient * sd * f  # on the block, along the line
                acc.force(sl.b, sl.sb, fmag * ux, fmag * uy)
                xp, yp = st.point(sl.b, sl.sb)
                # the reaction acts on the guide at the material point under the block
                _force_at_global(acc, st, sl.a, xp, yp, -fmag * ux, -fmag * uy)
                power_loads += fmag * sd
            elif isinstance(load, Damper) and load.drag is not None:
                b = sys_.index[load.drag[0]]
                s = an.mech.local_point(*load.drag)
                vx, vy = st.point_velocity(b, s)
                c = load.coefficient * f
                acc.force(b, s, -c * vx, -c * vy)
                power_loads += -c * (vx * vx + vy * vy)
            else:  # spring or damper between two points
                (la, pa), (lb, pb) = load.ends
                ba = nb if la == GROUND else sys_.index[la]
                bb = nb if lb == GROUND else sys_.index[lb]
                sa, sb = mech.local_point(la, pa), mech.local_point(lb, pb)
                xa, ya = st.point(ba, sa)
                xb, yb = st.point(bb, sb)
                vax, vay = st.point_velocity(ba, sa)
                vbx, vby = st.point_velocity(bb, sb)
                dx, dy = xb - xa, yb - ya
                L = np.hypot(dx, dy)
                with np.errstate(invalid="ignore", divide="ignore"):
                    ex, ey = dx / L, dy / L
                Ld = ex * (vbx - vax) + ey * (vby - vay)
                if isinstance(load, Spring):
                    t = load.stiffness * (L - load.free_length)  # tension
                    if load.when is None:
                        springs[0] = springs[0] + 0.5 * load.stiffness * (L - load.free_length) ** 2
                        springs[1] = springs[1] + t * Ld
                    else:
                        power_loads += -t * f * Ld
                    t = t * f
                else:
                    t = load.coefficient * Ld * f
                    power_loads += -t * Ld
                # tension t pulls b towards a and a towards b
                acc.force(bb, sb, -t * ex, -t * ey)
                acc.force(ba, sa, t * ex, t * ey)
            load_power[load.name] = power_loads - before

    lam, singular, nonunique, near = _solve_groups(an, st, acc.Q, sol.indicator, sol.ok)
    drv = sys_.driver
    row = next(r.start for r in sys_.rows if r.constraint is drv)
    effort = -lam[:, row]
    reactions = _reactions(an, st, lam)
    ok = sol.ok & np.all(np.isfinite(lam), axis=1)
    return ForceResult(
        lam,
        effort,
        reactions,
        active,
        power_loads,
        singular,
        ok,
        load_power=load_power,
        stroke_extremes=extremes,
        nonunique=_nonunique_components(an, nonunique),
        speed=sol.driver_rates()[0],
        energy_terms=energy_terms,
        near_singular=near,
    )


def _nonunique_components(an: Analysis, free: np.ndarray) -> dict[str, set[str]]:
    """Reaction components that redundant constraints leave indeterminate."""
    out: dict[str, set[str]] = {}
    for row in an.system.rows:
        c = row.constraint
        f = free[row.start : row.start + c.m]
        if not np.any(f):
            continue
        if c.kind == "revolute":
            comps = {k for k, on in zip(("Fx", "Fy"), f) if on} | {"F"}
        elif c.kind == "slider":
            comps = ({"N", "Fx", "Fy"} if f[0] else set()) | ({"M"} if f[1] else set())
        else:
            comps = {"effort"}
        out[c.name] = comps
    return out


def _force_at_global(acc: _Q, st, b: int, x, y, fx, fy) -> None:
    if b == acc.nb:
        return
    rx, ry = x - st.x[b], y - st.y[b]
    acc.Q[3 * b] += fx
    acc.Q[3 * b + 1] += fy
    acc.Q[3 * b + 2] += rx * fy - ry * fx


def _solve_groups(an: Analysis, st, Q: np.ndarray, indicator: np.ndarray, solved: np.ndarray):
    """Solve Phi_q^T lambda = Q group by group, last group first.

    Groups with a closed form solve their own equilibrium explicitly (the dyad-by-dyad
    kinetostatics of the textbooks); a group is singular where its indicator vanishes.
    Other groups solve their block of Phi_q^T, singular where its condition number is.
    Positions not ``solved`` (the mechanism does not close there) are not singular: they
    are reported as failures of the sweep, not here.
    """
    sys_ = an.system
    n = st.n
    # stored equation-major: each joint's multipliers are rows of N values (a group
    # writes and the reactions read them whole); lam itself is the (N, nc) view
    lam = np.full((sys_.nc, n), np.nan).T
    R = Q.copy()  # applied + inertia + reactions of the groups solved so far
    row_of = {id(r.constraint): r.start for r in sys_.rows}
    singular: list[tuple[int, str]] = []
    near = np.full(n, np.inf)  # how near a singular position: smallest indicator/rcond
    nonunique = np.zeros(sys_.nc, bool)
    for gi in reversed(range(len(an.plan))):
        g = an.plan[gi]
        if hasattr(g, "forces") and not isinstance(g, NewtonGroup):
            out: dict = {}
            ind = indicator[gi] if len(indicator) > gi else np.ones(n)
            sing = np.isfinite(ind) & (ind <= SINGULAR_INDICATOR)
            close = np.isfinite(ind) & (ind <= NEAR_SINGULAR_INDICATOR) & solved
            near = np.where(close, np.minimum(near, ind), near)
            any_sing = bool(sing.any())
            before = R[:, sing].copy() if any_sing else None
            with np.errstate(invalid="ignore", divide="ignore"):
                g.forces(st, R, out)
            if any_sing:
                # what the group passes on to the links it hangs on is not determined
                # either (it was +-inf or rounding noise): those reactions stay empty
                Rs = R[:, sing]
                Rs[Rs != before] = np.nan
                R[:, sing] = Rs
            for c, comps in out.items():
                r0 = row_of[id(c)]
                for k, v in enumerate(comps):
                    lam[:, r0 + k] = np.where(sing, np.nan, v) if any_sing else v
            singular += [(int(i), g.label) for i in np.flatnonzero(sing & solved)]
            continue
        J, blocks = group_block(g, st)
        m = J.shape[1]
        rhs = np.stack([R[3 * b + k] for b in g.bodies for k in range(3)], axis=1)  # (N, nn)
        x = np.full((n, m), np.nan)
        good = np.all(np.isfinite(J), axis=(1, 2))
        if m > J.shape[2]:  # redundant constraints: the minimum-norm multipliers
            x, rc, free = _min_norm(J, rhs, good)
            r0 = 0
            for c in g.constraints:
                nonunique[row_of[id(c)] : row_of[id(c)] + c.m] |= free[r0 : r0 + c.m]
                r0 += c.m
            regular = good & (rc > SINGULAR_RCOND)
            x[~regular] = np.nan
        else:
            rc = rcond(J)
            regular = good & (rc > SINGULAR_RCOND)
            idx = np.flatnonzero(regular & np.all(np.isfinite(rhs), axis=1))
            if idx.size:
                JT = np.transpose(J[idx], (0, 2, 1))
                x[idx] = np.linalg.solve(JT, rhs[idx][..., None])[..., 0]
        singular += [(int(i), g.label) for i in np.flatnonzero(good & ~regular & solved)]
        close = good & (rc <= NEAR_SINGULAR_RCOND) & solved
        near = np.where(close, np.minimum(near, rc), near)
        for c, r0, jac in blocks:
            lc = x[:, r0 : r0 + c.m]  # (N, m_c)
            lam[:, row_of[id(c)] : row_of[id(c)] + c.m] = lc
            for body, blk in jac.items():  # blk (m_c, 3, N)
                if body == sys_.nb:
                    continue
                for k in range(3):
                    R[3 * body + k] -= np.einsum("mn,nm->n", blk[:, k, :], lc)
    singular.sort()
    return lam, singular, nonunique, {int(i): float(near[i]) for i in np.flatnonzero(near < 1)}


def _min_norm(J: np.ndarray, rhs: np.ndarray, good: np.ndarray):
    """Minimum-norm solutions of the under-determined ``J^T x = rhs`` (N, m > n).

    Returns the solutions, the reciprocal condition of the determined part (the smallest
    of the first n singular values over the largest) and which unknowns are not unique
    (those with a component along the null space of ``J^T``).
    """
    n, m, nn = J.shape
    x = np.full((n, m), np.nan)
    rc = np.zeros(n)
    free = np.zeros(m, bool)
    idx = np.flatnonzero(good & np.all(np.isfinite(rhs), axis=1))
    if idx.size == 0:
        return x, rc, free
    JT = np.transpose(J[idx], (0, 2, 1))  # (k, nn, m)
    U, sv, Vt = np.linalg.svd(JT, full_matrices=True)  # sv (k, nn)
    tol = 1e-10 * sv[:, :1]
    rank_ok = sv[:, -1:] > tol  # the nn equations are independent
    inv = np.where(sv > tol, 1.0 / np.where(sv > 0, sv, 1.0), 0.0)
    y = np.einsum("kij,ki->kj", U, rhs[idx]) * inv  # (k, nn)
    x[idx] = np.einsum("kij,ki->kj", Vt[:, :nn, :], y)
    rc[idx] = np.where(rank_ok[:, 0], sv[:, -1] / sv[:, 0], 0.0)
    null = Vt[:, nn:, :]  # (k, m - nn, m)
    free = np.max(np.abs(null), axis=(0, 1)) > 1e-8
    return x, rc, free


def _reactions(an: Analysis, st, lam: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """Named reaction components of every joint, with the sign conventions above."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for row in an.system.rows:
        c = row.constraint
        if c.kind == "revolute":
            fx, fy = lam[:, row.start], lam[:, row.start + 1]
            out[c.name] = {"Fx": fx, "Fy": fy, "F": np.sqrt(fx * fx + fy * fy)}
        elif c.kind == "slider":
            nrm = -lam[:, row.start]
            mom = -lam[:, row.start + 1]
            ux, uy, nx, ny, _, _ = c.frame(st)
            out[c.name] = {"N": nrm, "M": mom, "Fx": nrm * nx, "Fy": nrm * ny}
    return out


def driver_work(an: Analysis, sol: Solution, fr: ForceResult) -> float:
    """Work done by the driver over the sweep (J), by the energy method.

    ``W = (T + V)(end) - (T + V)(start) - W_loads``. The kinetic and potential energies are
    state functions, exact at the ends. A constant force (global components) or torque does
    work ``F . (r_1 - r_0)`` (``T (theta_1 - theta_0)``) over each interval where it acts;
    where a condition switches between two samples, the switch is located by bisection on
    the driver coordinate, so the result does not depend on the step. The work of other
    loads (springs under a condition, dampers, link-fixed forces) is integrated with
    Simpson's rule. The energies need only the motion, so positions where the forces are
    indeterminate (singular) do not matter; if the mechanism could not be solved at some
    position, the work is not defined (NaN).
    """
    if len(sol.u) < 2 or not np.all(sol.ok):
        return float("nan")  # the motion has gaps: no work over the sweep to speak of
    mech, sys_ = an.mech, an.system
    st = sol.state
    energy = fr.kinetic + fr.potential
    work = energy[-1] - energy[0]
    for load in mech.loads:
        # "pos" is the load's potential-like function: its work is a difference of it;
        # "phi" its values at every sample
        if isinstance(load, PointForce) and load.frame == "global":
            b = sys_.index[load.link]
            s = mech.local_point(load.link, load.point)
            f = load.force
            x, y = st.point(b, s)
            phi = f[0] * x + f[1] * y

            def pos(state, i, b=b, s=s, f=f):
                x, y = state.point(b, s, [i])
                return f[0] * float(x[0]) + f[1] * float(y[0])

        elif isinstance(load, Torque):
            b = sys_.index[load.link]
            phi = load.torque * st.th[b]

            def pos(state, i, b=b, t=load.torque):
                return t * float(state.th[b, i])

        else:
            p = fr.load_power[load.name]
            work -= float(simpson(p, x=sol.t))
            continue
        on = fr.active.get(load.name)
        if on is None:
            work -= float(phi[-1] - phi[0])
            continue
        both = on[:-1] & on[1:]
        work -= float(np.sum(np.diff(phi)[both]))  # the intervals where it acts throughout
        for k in np.flatnonzero(on[:-1] != on[1:]):  # and the parts where it switches
            k = int(k)
            us, ss = _switch(an, sol, fr, load, k)
            if on[k]:
                work -= pos(ss, 0) - float(phi[k])
            else:
                work -= float(phi[k + 1]) - pos(ss, 0)
    return float(work)


def switch_points(an: Analysis, sol: Solution, fr: ForceResult) -> list[float]:
    """The driver values, bisected to rounding, where a conditional load switches between
    two samples of ``sol``."""
    out = []
    for load in an.mech.loads:
        on = fr.active.get(load.name)
        if on is None:
            continue
        for k in np.flatnonzero(on[1:] != on[:-1]):
            if sol.ok[k] and sol.ok[k + 1]:
                out.append(_switch(an, sol, fr, load, int(k))[0])
    return sorted(out)


def _switch(an: Analysis, sol: Solution, fr: ForceResult, load, k: int, points: int = 127):
    """The driver coordinate between samples k and k+1 where ``load`` switches, to
    rounding: the interval is cut into ``points + 1`` parts per round, all solved at once
    (about 8 vectorised solves instead of some 50 single ones of a bisection)."""
    from ..sweep import StateView

    lo, hi = float(sol.u[k]), float(sol.u[k + 1])
    on_lo = bool(fr.active[load.name][k])
    conditional = [ld for ld in an.mech.loads if ld.when is not None]
    which = conditional.index(load)
    state = None
    frac = np.arange(1, points + 1) / (points + 1)
    for _ in range(40):
        xs = lo + (hi - lo) * frac
        keep = (xs != lo) & (xs != hi) & np.r_[True, np.diff(xs) != 0]
        xs = xs[keep]
        if xs.size == 0:
            break
        many = an.solve(xs, start=sol.start, near=(sol, k))
        view = StateView(an, many.state)
        # stroke(q) replays the sweep's extremes in the order of the conditional loads
        funcs = {"stroke": stroke_function(list(fr.stroke_extremes), True)}
        with np.errstate(invalid="ignore"):
            vals = [
                np.broadcast_to(np.asarray(ld.when.evaluate(view, funcs), bool), xs.shape)
                for ld in conditional
            ]
        flip = np.flatnonzero((vals[which] != on_lo) & many.ok)
        if flip.size == 0:
            lo = float(xs[-1])
            continue
        j = int(flip[0])
        hi = float(xs[j])
        state = many.state.take(np.array([j]))
        if j > 0:
            lo = float(xs[j - 1])
    one = an.solve(np.array([0.5 * (lo + hi)]), start=sol.start, near=(sol, k))
    return 0.5 * (lo + hi), one.state if one.ok[0] else state
