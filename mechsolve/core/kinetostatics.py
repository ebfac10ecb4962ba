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

from typing import TYPE_CHECKING

import numpy as np

from mechsolve.core.conditioning import (
    NEAR_SINGULAR_INDICATOR,
    NEAR_SINGULAR_RCOND,
    SINGULAR_INDICATOR,
    SINGULAR_RCOND,
    group_block,
    rcond_above,
)
from mechsolve.core.force_result import ForceResult
from mechsolve.core.friction import frictional, solve_friction
from mechsolve.core.loads import (
    _Q,
    apply_loads,
    condition_masks,
)
from mechsolve.core.work import driver_work, driver_work_why  # noqa: F401 (re-exported)
from mechsolve.groups.generic import NewtonGroup

if TYPE_CHECKING:
    from mechsolve.core.sweep import Analysis, Solution


def solve_forces(
    an: Analysis,
    sol: Solution,
    stroke_extremes: list[tuple[float, float]] | None = None,
    friction_hint: tuple | None = None,
) -> ForceResult:
    """Kinetostatic analysis of a solved sweep (positions, velocities, accelerations).

    ``stroke_extremes``: the extremes that ``stroke(q)`` in load conditions uses, when
    they come from elsewhere (a long sweep solved in chunks); found over ``sol`` if None.
    ``friction_hint``: for a one-position check of the equation of motion with joint
    friction, ``(law, magnitudes)`` found at the same position and speed (see
    :func:`~mechsolve.core.friction.balance`); None otherwise.
    """
    from mechsolve.core.sweep import StateView

    mech, sys_ = an.mech, an.system
    st = sol.state
    view = StateView(an, st)
    acc = _Q(an, st)
    gx, gy = mech.gravity_vector()

    # inertia and gravity, at each body's centre of mass
    massive = []
    for lk in mech.links:
        # numbers, or arrays over the positions of designs solved as one batch
        m = 0.0 if lk.mass is None else lk.mass
        J = 0.0 if lk.inertia is None else lk.inertia
        if not _any(m) and not _any(J):
            continue
        b = sys_.index[lk.name]
        s = np.asarray(lk.com if lk.com is not None else (0.0, 0.0), float)
        if s.ndim == 1 and not s.any():  # the centre at the frame's origin
            acc.force(b, s, m * (gx - st.ax[b]), m * (gy - st.ay[b]))
        else:
            r = st.rotated(b, s)  # the centre's arm: for its acceleration and moment
            rx, ry = r
            w2 = st.w[b] * st.w[b]
            # m (g - a_G), in place where the arrays are this function's own (the same
            # operations in the same order: fewer temporaries, the same rounding)
            ax = st.ax[b] - st.al[b] * ry
            ax -= w2 * rx
            ay = st.ay[b] + st.al[b] * rx
            ay -= w2 * ry
            np.subtract(gx, ax, out=ax)
            np.subtract(gy, ay, out=ay)
            ax *= m
            ay *= m
            acc.force(b, s, ax, ay, r)
        if _any(J):
            acc.torque(b, -J * st.al[b])
        massive.append((b, m, J, s))

    replay = stroke_extremes is not None
    extremes: list[tuple[float, float]] = list(stroke_extremes) if replay else []
    active = condition_masks(an, sol, view, extremes, replay)
    power_loads, load_power, springs = apply_loads(an, st, active, acc)
    energy_terms = _energy_terms(st, massive, springs, gx, gy)

    # (acc.Q is not read again: the groups accumulate their reactions in it)
    lam, singular, nonunique, near = _solve_groups(an, st, acc.Q, sol.indicator, sol.ok, own=True)
    drv = sys_.driver
    row = next(r.start for r in sys_.rows if r.constraint is drv)
    effort = -lam[:, row]
    lam = _with_separating_forces(an, st, lam, sol)
    fric = None
    if frictional(an):  # the reactions are no longer linear in the loads: iterate
        lam, fric = _with_friction(an, st, sol, lam, row, friction_hint)
        effort = -lam[:, row]
    reactions = _reactions(an, st, lam)
    if fric is not None:
        _add_friction(an, st, reactions, fric)
    ok = sol.ok & np.isfinite(lam.T).all(axis=0)  # lam.T: the rows stored whole
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
        friction=fric,
    )


def _any(x) -> bool:
    """``np.any(x)`` without its overhead for the usual plain number."""
    return x != 0.0 if isinstance(x, float) else bool(np.any(x))


def _energy_terms(st, massive: list, springs: tuple, gx: float, gy: float):
    """The kinetic and potential energies and their rates, computed when asked."""
    n = st.n

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

    return energy_terms


def _with_friction(an: Analysis, st, sol: Solution, lam: np.ndarray, row: int, hint=None):
    """The multipliers with the joints' friction (see :mod:`mechsolve.core.friction`),
    each iteration's linear solve the ideal one (groups, then separating forces)."""

    def solve(Q: np.ndarray) -> np.ndarray:
        lam1 = _solve_groups(an, st, Q, sol.indicator, sol.ok)[0]
        return _with_separating_forces(an, st, lam1, sol)

    # the equation of motion sets a regularisation (mechsolve.analyses.dynamics.model)
    s0 = an.friction_smoothing
    smoothing = None if s0 is None else (sol.driver_rates()[0], s0)
    where = lambda i: an.format_u(float(sol.u[i]))  # noqa: E731
    return solve_friction(an, st, lam, solve, row, where, smoothing, hint)


def _with_separating_forces(an: Analysis, st, lam: np.ndarray, sol: Solution) -> np.ndarray:
    """The multipliers with what the higher pairs' separating forces add (a second pass).

    A gear tooth's force has a radial part that the rolling equation's multiplier does not
    carry; it does no work while the centre distance is held, so the driver's effort does
    not change, but it loads the pivots. Each pair that has one
    (:meth:`~mechsolve.joints.base.Constraint.separating`) applies it as a known load on
    its two links; ``Phi_q^T lambda_2 = Q_separating`` is solved like the first pass and
    added: the pairs' own rows get nothing from it (the force is normal to their motion).
    """
    sys_ = an.system
    extra = None  # made when a pair has a separating force (most models have none)
    for r in sys_.rows:
        c = r.constraint
        loads = c.separating(st, lam[:, r.start : r.start + c.m])
        for b, px, py, fx, fy in loads or ():
            if b == sys_.nb:
                continue
            if extra is None:
                extra = _Q(an, st)
            extra.force(b, None, fx, fy, (px - st.x[b], py - st.y[b]))
    if extra is None:
        return lam
    lam2 = _solve_groups(an, st, extra.Q, sol.indicator, sol.ok, own=True)[0]
    return lam + lam2


def _nonunique_components(an: Analysis, free: np.ndarray) -> dict[str, set[str]]:
    """Reaction components that redundant constraints leave indeterminate."""
    out: dict[str, set[str]] = {}
    if not free.any():  # the usual case: no redundant constraints
        return out
    for row in an.system.rows:
        c = row.constraint
        f = free[row.start : row.start + c.m]
        if not np.any(f):
            continue
        comps = c.indeterminate(f)
        out[c.name] = comps
    return out


def _singular_where(ind, solved: np.ndarray, near: np.ndarray):
    """A closed-form group's singular positions from its indicator ``ind`` (None where
    it has none): ``(mask or None, any, near)``, ``near`` lowered where it is close to
    singular. One reduction where the group is far from singular everywhere (the usual
    case; a NaN in the indicator makes the minimum NaN: the full test)."""
    if ind is None or not len(ind) or ind.min() > NEAR_SINGULAR_INDICATOR:
        return None, False, near
    sing = np.isfinite(ind) & (ind <= SINGULAR_INDICATOR)
    close = np.isfinite(ind) & (ind <= NEAR_SINGULAR_INDICATOR) & solved
    return sing, bool(sing.any()), np.where(close, np.minimum(near, ind), near)


def _solve_groups(
    an: Analysis, st, Q: np.ndarray, indicator: np.ndarray, solved: np.ndarray, own: bool = False
):
    """Solve Phi_q^T lambda = Q group by group, last group first (``own``: ``Q`` may be
    overwritten, no copy is made).

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
    R = Q if own else Q.copy()  # applied + inertia + reactions of the groups solved so far
    row_of = {id(r.constraint): r.start for r in sys_.rows}
    singular: list[tuple[int, str]] = []
    near = np.full(n, np.inf)  # how near a singular position: smallest indicator/rcond
    nonunique = np.zeros(sys_.nc, bool)
    for gi in reversed(range(len(an.plan))):
        g = an.plan[gi]
        if hasattr(g, "forces") and not isinstance(g, NewtonGroup):
            out: dict = {}
            ind = indicator[gi] if len(indicator) > gi else None
            sing, any_sing, near = _singular_where(ind, solved, near)
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
            if any_sing:
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
            rc = rcond_above(J, NEAR_SINGULAR_RCOND)  # exact where it is compared below
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


def _add_friction(an: Analysis, st, reactions: dict, fric) -> None:
    """The friction forces added to the reaction components they belong to (a slider's
    contact force along its line), as each joint says (``friction_reaction``)."""
    for row in frictional(an):
        c = row.constraint
        extra = c.friction_reaction(st, fric.friction[c.name])
        if extra and c.name in reactions:
            r = dict(reactions[c.name])
            for key, value in extra.items():
                r[key] = r[key] + value
            reactions[c.name] = r


def _reactions(an: Analysis, st, lam: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """Named reaction components of every joint, with the sign conventions above."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for row in an.system.rows:
        c = row.constraint
        r = c.reaction(st, lam[:, row.start : row.start + c.m])
        if r is not None:
            out[c.name] = r
    return out
