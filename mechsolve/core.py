"""The solver core that every analysis calls: states of the mechanism at given driver
values and rates, and the forces in a state.

:func:`states` takes driver values ``u`` with their rates ``u'`` and ``u''`` (arrays, in
any order, not necessarily a sweep) and returns the pose, velocity and acceleration of
every body, on the branches the start assembly chose and continued along the motion from
the driver's start by the sweep's continuation and branch-event logic
(:class:`~mechsolve.sweep.Analysis`). The kinematics is solved once per distinct driver
value, per unit of the driver coordinate (``q'`` and ``q''``); the rates then follow
exactly from the chain rule::

    q_dot  = q' u_dot
    q_ddot = q'' u_dot^2 + q' u_ddot

:func:`forces` takes such a state and the model's loads and returns every joint force and
the driver's effort (:mod:`mechsolve.solvers.forces`).

The sweep of ``mechsolve run``, the instants of ``--at``, and the analyses built on them
are thin callers of these two functions.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .groups.generic import NewtonGroup
from .numerics import limit_from_both_sides
from .solvers.forces import ForceResult, solve_forces
from .state import State
from .sweep import Analysis, Failure, Solution

__all__ = ["states", "forces", "scale_rates"]


def scale_rates(st: State, ud: np.ndarray, udd: np.ndarray, acceleration: bool = True) -> None:
    """Turn rates per unit driver coordinate (``q'``, ``q''``) into time rates, in place."""
    vel = st.block[5:8]  # vx, vy, w of every body
    acc = st.block[8:11]  # ax, ay, al
    ud = np.asarray(ud, float)
    udd = np.asarray(udd, float)
    if ud.size and np.all(ud == ud.flat[0]) and not np.any(udd):
        w = float(ud.flat[0])  # a constant speed: two scalar products, as the sweep does
        if acceleration and w != 1.0:
            acc *= w * w
        if w != 1.0:
            vel *= w
    else:
        ud = np.broadcast_to(ud, (st.n,))
        udd = np.broadcast_to(udd, (st.n,))
        if acceleration:
            acc *= ud * ud
            acc += vel * udd
        vel *= ud
    st.token = State.new_token()


def states(
    an: Analysis,
    u,
    ud=None,
    udd=None,
    *,
    t=None,
    velocity: bool = True,
    acceleration: bool = True,
    within: Solution | None = None,
) -> Solution:
    """Every body's state at driver values ``u`` with rates ``ud``, ``udd``.

    Parameters
    ----------
    an
        The analysis of the mechanism (constraint system, groups, start assembly rules).
    u
        Driver values (rad or m), any order; repeated values are solved once.
    ud, udd
        The driver's speed and acceleration at each value (arrays or scalars; default the
        file's constant speed and no acceleration).
    t
        Times of the positions (s), for the results' time column; default the time at the
        file's constant speed from the start.
    within
        A sweep from the driver's start, solved per unit of the driver coordinate, whose
        range holds every value of ``u``: the positions are solved on its branches (its
        start assembly and the branch switches it found), with no new start assembly
        or branch analysis. A model with Newton groups is solved as without it (their
        guesses come from continuation).

    Returns
    -------
    Solution
        Positions in the order given. The driver's start (``an.start_value()``) is where
        the mechanism is assembled; each position is reached from it along the driver's
        direction (for a revolute driver an angle behind the start is reached by going
        on round the turn).
    """
    u = np.atleast_1d(np.asarray(u, float))
    n = len(u)
    ud = np.broadcast_to(np.asarray(an.speed if ud is None else ud, float), (n,)).copy()
    udd = np.broadcast_to(np.asarray(0.0 if udd is None else udd, float), (n,)).copy()
    d = an.mech.driver.direction
    u0 = an.start_value()
    travel = d * (u - u0)
    tol = 1e-12 * (an.scale if an.linear else 1.0)
    kw = dict(velocity=velocity or acceleration, acceleration=acceleration, per_unit_driver=True)
    behind = travel < -tol
    if within is not None and _inside(an, within, travel, tol):
        out = an.solve(u, start=within.start, near=(within, 0), **kw)
    elif n and u[0] == u0 and np.all(np.diff(travel) > 0):
        out = an.solve_sweep(u, **kw)  # a sweep from the start: solved as it is
    elif not behind.any():
        out = _on_one_side(an, u, np.maximum(travel, 0.0), u0, d, kw)
    else:
        # positions behind the start are reached by moving the driver the other way
        ahead = np.flatnonzero(~behind)
        back = np.flatnonzero(behind)
        parts = [_on_one_side(an.reversed(), u[back], -travel[back], u0, -d, kw)]
        if ahead.size:
            parts.insert(0, _on_one_side(an, u[ahead], np.maximum(travel[ahead], 0), u0, d, kw))
        order = np.empty(n, int)
        order[np.r_[ahead, back]] = np.arange(n)
        out = _take(_concat(parts), order)
        out.u = u
    scale_rates(out.state, ud, udd, acceleration)
    out.ud, out.udd = ud, udd
    out.has_velocity, out.has_acceleration = velocity, velocity and acceleration
    if t is None:
        out.t = np.abs(u - u0) / abs(an.speed) if an.speed else np.zeros(n)
    else:
        out.t = np.asarray(t, float)
    return out


def _inside(an: Analysis, sweep: Solution, travel: np.ndarray, tol: float) -> bool:
    """Whether positions ``travel`` from the start can be solved on the branches of
    ``sweep``: it starts at the driver's start and covers them, and no group of the
    model needs continuation (Newton)."""
    if any(isinstance(g, NewtonGroup) for g in an.plan) or sweep.u[0] != an.start_value():
        return False
    end = an.mech.driver.direction * (sweep.u[-1] - sweep.u[0])
    return bool(np.all((travel >= -tol) & (travel <= end + tol)))


def _on_one_side(an: Analysis, u, travel, u0: float, d: int, kw) -> Solution:
    """Positions at ``travel`` >= 0 from the start in the direction ``d``: the distinct
    values solved as one sweep from the start, then taken in the order given."""
    grid, inverse = np.unique(np.r_[0.0, travel], return_inverse=True)
    out = _take(an.solve_sweep(u0 + d * grid, **kw), inverse[1:])
    out.u = np.asarray(u, float)
    return out


def _concat(parts: list[Solution]) -> Solution:
    """Solutions one after another (positions concatenated)."""
    first = parts[0]
    shift, fails = 0, []
    for p in parts:
        fails += [
            dataclasses.replace(f, first=f.first + shift, last=f.last + shift) for f in p.failures
        ]
        shift += len(p.u)
    st = State(first.state.nb, shift)
    st.block[...] = np.concatenate([p.state.block for p in parts], axis=2)

    def cat(name):
        vals = [getattr(p, name) for p in parts]
        return None if any(v is None for v in vals) else np.concatenate(vals)

    ind = [p.indicator for p in parts]
    return Solution(
        first.analysis,
        cat("u"),
        cat("t"),
        st,
        cat("ok"),
        fails,
        np.concatenate(ind, axis=1) if all(i.size for i in ind) else ind[0],
        cat("iterations"),
        cat("methods") if all(p.methods is not None for p in parts) else None,
        cat("residual_") if all(p.residual_ is not None for p in parts) else None,
        first.start,
        [w for p in parts for w in p.warnings],
        first.has_velocity,
        first.has_acceleration,
        [e for p in parts for e in p.events],
        first.flips,
    )


def forces(
    an: Analysis, sol: Solution, stroke_extremes: list[tuple[float, float]] | None = None
) -> ForceResult:
    """Every joint force and the driver's effort in the states of ``sol``, with the
    model's inertia, gravity and loads (conditions evaluated on those states;
    ``stroke(q)`` over ``stroke_extremes`` when given, else over the states themselves).

    At a singular position (a toggle, a bifurcation) the reactions are not determined
    and stay empty; the driver's effort, where the motion is smooth through it, is its
    limit along the motion (see :func:`_effort_limits`)."""
    f = solve_forces(an, sol, stroke_extremes)
    if f.singular and len(sol.u) > 1:
        _effort_limits(an, sol, f, f.stroke_extremes)
    return f


def _effort_limits(an: Analysis, sol: Solution, f: ForceResult, extremes) -> None:
    """The driver's effort at singular positions as its limit along the motion: at
    ``u -+ h`` and ``u -+ 2h`` (h = 5e-3 rad, or of the size) with the position's own
    rates, extrapolated (Richardson, O(h^4)), when both sides agree (a smooth motion);
    else it stays empty."""
    ud, udd = sol.driver_rates()
    h = 5e-3 * (an.scale if an.linear else 1.0)
    for i in sorted({i for i, _ in f.singular}):
        if np.isfinite(f.effort[i]) or not sol.ok[i]:
            continue
        x = float(sol.u[i]) + h * np.array([-1.0, 1.0, -2.0, 2.0])
        near = an.solve(x, start=sol.start, near=(sol, int(i)), per_unit_driver=True, limits=False)
        if not near.ok.all():
            continue
        scale_rates(near.state, np.full(4, ud[i]), np.full(4, udd[i]))
        near.ud, near.udd = np.full(4, ud[i]), np.full(4, udd[i])
        e = solve_forces(an, near, extremes).effort
        if not np.all(np.isfinite(e)):
            continue
        lo1, hi1, lo2, hi2 = e
        # a smooth motion changes twice as much over 4h as over 2h; a jump does not (the
        # efforts next to a singular position carry rounding of about 1e-9 of their size)
        if abs((hi2 - lo2) - 2 * (hi1 - lo1)) > 0.1 * abs(hi2 - lo2) + 1e-6 * (1 + abs(e).max()):
            continue  # not smooth through the position: no limit
        f.effort[i] = limit_from_both_sides(lo1, hi1, lo2, hi2)
        f.effort_by_limit.append(int(i))


def _take(sol: Solution, idx: np.ndarray) -> Solution:
    """The positions ``idx`` of a solution (any order, repeats allowed); failures are
    runs of consecutive unsolved positions in the new order, with the reasons of the
    sweep's runs they come from."""
    idx = np.asarray(idx, int)
    reason_at: dict[int, Failure] = {}
    for f in sol.failures:
        for i in range(f.first, f.last + 1):
            reason_at[i] = f
    ok = sol.ok[idx]
    fails: list[Failure] = []
    u = sol.u[idx]
    for j in np.flatnonzero(~ok):
        src = reason_at.get(int(idx[j]))
        group, reason = (src.group, src.reason) if src else ("the whole system", "not solved")
        last = fails[-1] if fails else None
        if last is not None and last.last == j - 1 and last.group == group:
            last.last, last.u_last = int(j), float(u[j])
        else:
            fails.append(Failure(int(j), int(j), group, reason, float(u[j]), float(u[j])))
    # events keep their driver values; which sample they follow means nothing here
    events = [dataclasses.replace(e, after=-1) for e in sol.events]
    by_limit, undetermined = set(sol.rates_by_limit), set(sol.rates_undetermined)
    return Solution(
        sol.analysis,
        u,
        sol.t[idx],
        sol.state.take(idx),
        ok,
        fails,
        sol.indicator[:, idx] if sol.indicator.size else sol.indicator,
        sol.iterations[idx],
        None if sol.methods is None else sol.methods[idx],
        None if sol.residual_ is None else sol.residual_[idx],
        sol.start,
        list(sol.warnings),
        sol.has_velocity,
        sol.has_acceleration,
        events,
        sol.flips,
        np.flatnonzero(np.isin(idx, list(by_limit))).tolist() if by_limit else [],
        np.flatnonzero(np.isin(idx, list(undetermined))).tolist() if undetermined else [],
    )
