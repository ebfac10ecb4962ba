"""The solver core that every analysis calls: states of the mechanism at given driver
values and rates, and the forces in a state.

:func:`states` takes driver values ``u`` with their rates ``u'`` and ``u''`` (arrays, in
any order, not necessarily a sweep) and returns the pose, velocity and acceleration of
every body, on the branches the start assembly chose and continued along the motion from
the driver's start by the sweep's continuation and branch-event logic
(:class:`~mechsolve.core.sweep.Analysis`). The kinematics is solved once per distinct driver
value, per unit of the driver coordinate (``q'`` and ``q''``); the rates then follow
exactly from the chain rule::

    q_dot  = q' u_dot
    q_ddot = q'' u_dot^2 + q' u_ddot

:func:`forces` takes such a state and the model's loads and returns every joint force and
the driver's effort (:mod:`mechsolve.core.kinetostatics`).

The sweep of ``mechsolve run``, the instants of ``--at``, and the analyses built on them
are thin callers of these two functions.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mechsolve.base.numerics import limit_from_both_sides
from mechsolve.base.state import State, scale_rates
from mechsolve.core.kinetostatics import ForceResult, solve_forces
from mechsolve.core.sweep import Analysis, Failure, Solution
from mechsolve.groups.generic import NewtonGroup

__all__ = ["states", "forces", "scale_rates"]


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
    constant = ud is None and udd is None  # the file's constant speed: one scalar to scale by
    if constant:
        ud, udd = np.full(n, float(an.speed)), np.zeros(n)
    else:
        ud = np.broadcast_to(np.asarray(an.speed if ud is None else ud, float), (n,)).copy()
        udd = np.broadcast_to(np.asarray(0.0 if udd is None else udd, float), (n,)).copy()
    u0 = an.start_value()
    kw = dict(velocity=velocity or acceleration, acceleration=acceleration, per_unit_driver=True)
    prog = an.program if constant and within is None else None
    out = prog.sweep(an, u, u0, kw["velocity"], acceleration) if prog is not None else None
    if out is None:  # (else a recognised plan's sweep from the start: mechsolve.core.program)
        out = _general(an, u, u0, within, kw)
    token = out.state.token
    rates = (np.float64(an.speed), np.float64(0.0)) if constant else (ud, udd)
    scale_rates(out.state, *rates, acceleration)
    for g in an.plan:  # the groups' results from the positions alone stay (for the forces)
        g.rates_rescaled(token, out.state.token)
    out.ud, out.udd = ud, udd
    out.has_velocity, out.has_acceleration = velocity, velocity and acceleration
    out.t = np.asarray(t, float) if t is not None else _time(an, u, u0)
    return out


def _general(an: Analysis, u: np.ndarray, u0: float, within: Solution | None, kw) -> Solution:
    """The positions ``u`` by the general sweep: on the branches of ``within`` where it
    covers them, as one sweep from the start, else the distinct values in order of their
    travel from the start (those behind it by moving the driver the other way)."""
    n = len(u)
    d = an.mech.driver.direction
    travel = d * (u - u0)
    tol = 1e-12 * (an.scale if an.linear else 1.0)
    behind = travel < -tol
    if within is not None and _inside(an, within, travel, tol):
        return an.solve(u, start=within.start, near=(within, 0), **kw)
    if n and u[0] == u0 and np.all(np.diff(travel) > 0):
        return an.solve_sweep(u, **kw)  # a sweep from the start: solved as it is
    if not behind.any():
        return _on_one_side(an, u, np.maximum(travel, 0.0), u0, d, kw)
    return _both_sides(an, u, travel, behind, u0, d, kw)


def _both_sides(an: Analysis, u, travel, behind, u0: float, d: int, kw) -> Solution:
    """Positions ahead of the start and behind it (``behind``), those behind reached by
    moving the driver the other way, in the order given."""
    n = len(u)
    ahead = np.flatnonzero(~behind)
    back = np.flatnonzero(behind)
    parts = [_on_one_side(an.reversed(), u[back], -travel[back], u0, -d, kw)]
    if ahead.size:
        parts.insert(0, _on_one_side(an, u[ahead], np.maximum(travel[ahead], 0), u0, d, kw))
    order = np.empty(n, int)
    order[np.r_[ahead, back]] = np.arange(n)
    out = _take(_concat(parts), order)
    out.u = u
    return out


def _time(an: Analysis, u: np.ndarray, u0: float) -> np.ndarray:
    """The time at each driver value at the file's constant speed from the start."""
    return np.abs(u - u0) / abs(an.speed) if an.speed else np.zeros(len(u))


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
    an: Analysis,
    sol: Solution,
    stroke_extremes: list[tuple[float, float]] | None = None,
    friction_hint: tuple | None = None,
) -> ForceResult:
    """Every joint force and the driver's effort in the states of ``sol``, with the
    model's inertia, gravity and loads (conditions evaluated on those states;
    ``stroke(q)`` over ``stroke_extremes`` when given, else over the states themselves).

    At a singular position (a toggle, a bifurcation) the reactions are not determined
    and stay empty; the driver's effort, where the motion is smooth through it, is its
    limit along the motion (see :func:`_effort_limits`). ``friction_hint``: see
    :func:`~mechsolve.core.kinetostatics.solve_forces`."""
    f = solve_forces(an, sol, stroke_extremes, friction_hint)
    if (f.singular or f.near_singular) and len(sol.u) > 1:
        _effort_limits(an, sol, f, f.stroke_extremes)
    return f


def _effort_limits(an: Analysis, sol: Solution, f: ForceResult, extremes) -> None:
    """The driver's effort at and next to singular positions as its limit along the
    motion: at ``u -+ h`` and ``u -+ 2h`` (h = 5e-3 rad, or of the size) with the
    position's own rates, extrapolated (Richardson, O(h^4)), when both sides agree (a
    smooth motion). Otherwise it stays empty at a singular position and as computed next
    to one (see :mod:`mechsolve.core.conditioning` for how near is near)."""
    ud, udd = sol.driver_rates()
    h = 5e-3 * (an.scale if an.linear else 1.0)
    singular = {i for i, _ in f.singular}
    newton = any(isinstance(g, NewtonGroup) for g in an.plan)
    n = len(sol.u)
    for i in sorted(singular | set(f.near_singular)):
        at = i in singular
        if not sol.ok[i]:
            continue
        ui = float(sol.u[i])
        if i in (0, n - 1):  # the first or last sample: the motion lies on one side
            into = np.sign(sol.u[1] - sol.u[0]) * (1 if i == 0 else -1)
            x = ui + into * h * np.arange(1.0, 5.0)
            k = i + 1 if i == 0 else i - 1
            near = _near(an, sol, [(k, x)]) if newton else _near(an, sol, [(i, x)], False)
        elif newton:  # each side by continuation from the neighbouring sample there
            near = _near(
                an,
                sol,
                [(i - 1, ui - h * np.array([2.0, 1.0])), (i + 1, ui + h * np.array([1.0, 2.0]))],
            )
            if near is not None:  # as (lo1, hi1, lo2, hi2)
                near = _take(near, np.array([1, 2, 0, 3]))
        else:
            near = _near(an, sol, [(i, ui + h * np.array([-1.0, 1.0, -2.0, 2.0]))], False)
        if near is None:
            continue
        scale_rates(near.state, np.full(4, ud[i]), np.full(4, udd[i]))
        near.ud, near.udd = np.full(4, ud[i]), np.full(4, udd[i])
        with np.errstate(invalid="ignore", divide="ignore"):
            # a point next to it may itself be singular (its rates NaN): no limit then
            e = solve_forces(an, near, extremes).effort
        if not np.all(np.isfinite(e)):
            continue
        if i in (0, n - 1):  # cubic extrapolation, checked against the quadratic one
            est = float(e @ np.array([4.0, -6.0, 4.0, -1.0]))
            quad = float(e[:3] @ np.array([3.0, -3.0, 1.0]))
            if abs(est - quad) > 1e-3 * abs(est) + 1e-6 * (1 + abs(e).max()):
                continue
            f.effort[i] = est
        else:
            lo1, hi1, lo2, hi2 = e
            # a smooth motion changes twice as much over 4h as over 2h; a jump does not
            # (the efforts next to a singular position carry rounding of about 1e-9 of
            # their size)
            if abs((hi2 - lo2) - 2 * (hi1 - lo1)) > 0.1 * abs(hi2 - lo2) + 1e-6 * (
                1 + abs(e).max()
            ):
                continue  # not smooth through the position: no limit
            est = limit_from_both_sides(lo1, hi1, lo2, hi2)
            if not at:
                # near (not at) a singular position: the computed effort is kept
                # where it agrees with the limit to within the limit's own error
                # (bounded by its difference from the plain mean of the two sides)
                err_lim = abs(est - 0.5 * (lo1 + hi1)) + 1e-6 * (1.0 + float(np.max(np.abs(e))))
                if abs(f.effort[i] - est) <= err_lim:
                    continue
            f.effort[i] = est
        (f.effort_by_limit if at else f.effort_near_limit).append(int(i))


def _near(
    an: Analysis, sol: Solution, parts: list[tuple[int, np.ndarray]], march: bool = True
) -> Solution | None:
    """Positions ``x`` reached from solved sample ``k`` of ``sol`` (each ``(k, x)`` in
    turn; with ``march``, the sample solved again first so that a Newton group's march
    starts on its pose), concatenated; None if one of them does not close."""
    out = []
    for k, x in parts:
        if not (0 <= k < len(sol.u)) or not sol.ok[k]:
            return None
        if not march:
            near = an.solve(
                x, start=sol.start, near=(sol, int(k)), per_unit_driver=True, limits=False
            )
            if not near.ok.all():
                return None
            out.append(near)
            continue
        near = an.solve(
            np.r_[sol.u[k], x],
            start=sol.start,
            near=(sol, int(k)),
            per_unit_driver=True,
            limits=False,
        )
        if not near.ok.all():
            return None
        out.append(_take(near, np.arange(1, len(x) + 1)))
    return out[0] if len(out) == 1 else _concat(out)


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
