"""Solving a mechanism's sweep into :class:`~mechsolve.results.results.Results`.

:func:`solve` is the one entry every analysis uses (the API re-exports it); :func:`for_plots`
gives the finer sweep that plots, summaries and requirement checks read their figures from.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from mechsolve.base.errors import InputError
from mechsolve.base.units import UnitError, parse_quantity
from mechsolve.core import evaluate as core
from mechsolve.core.kept import analysis_for
from mechsolve.model import Mechanism
from mechsolve.model.keys import METHODS
from mechsolve.results.results import Results


def parse_step(mech: Mechanism, text: str | float, option: str = "--step ") -> float:
    """A sweep step from the command line: an angle (``"5 deg"``), a length for a linear
    driver (``"2 mm"``) or a time (``"0.01 s"``), converted to the driver's coordinate.
    ``option`` names it in the messages (``"step="`` for :func:`solve`'s argument)."""
    linear = mech.driver is not None and mech.joint(mech.driver.joint).coordinate == "length"
    if mech.driver is not None and mech.sweep.duration is not None:  # swept in time
        try:
            val = parse_quantity(text, "time")
        except UnitError:
            raise InputError(
                f"{option}{text!r}: this driver follows a motion law of time: give a time "
                "step such as '0.01 s'"
            ) from None
        if not val > 0:
            raise InputError(f"{option}{text!r}: the step must be positive")
        return val
    kind = "length" if linear else "angle"
    default = mech.length_unit if linear else "deg"
    try:
        val = parse_quantity(text, kind, default)
    except UnitError:
        try:
            val = parse_quantity(text, "time") * abs(mech.driver.speed)
            if val == 0:
                raise InputError(f"{option}{text!r}: a driver at rest (speed 0) has no time step")
        except UnitError:
            raise InputError(
                f"{option}{text!r}: expected {'a length' if linear else 'an angle'} such as "
                f"{'2 mm' if linear else '5 deg'}, or a time such as '0.01 s'"
            ) from None
    if not val > 0:
        raise InputError(f"{option}{text!r}: the step must be positive")
    return val


def checked_mechanism(mech: object) -> Mechanism:
    """``mech`` itself when it is a :class:`Mechanism`, else an :class:`InputError` that
    says how to get one (a path is loaded first)."""
    if not isinstance(mech, Mechanism):
        shown = repr(mech)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        raise InputError(
            f"expected a Mechanism, got {type(mech).__name__} {shown}: load the file first "
            "with ms.load(path), or load and solve it in one call with ms.run(path)"
        )
    return mech


def checked_step(mech: Mechanism, step: object) -> float | None:
    """:func:`solve`'s ``step``, checked as ``--step`` is: None (the file's), a positive
    finite number in the driver's SI unit (rad; m for a linear driver; s for a sweep in
    time), or a text such as ``"2 deg"`` read as the command line reads it."""
    if step is None:
        return None
    if isinstance(step, str):
        return parse_step(mech, step, "step=")
    if isinstance(step, bool) or not isinstance(step, numbers.Real):
        raise InputError(
            f"step={step!r}: expected a number (rad, m for a linear driver, s for a sweep in "
            "time) or a text such as '2 deg'"
        )
    if not (step > 0 and math.isfinite(step)):
        raise InputError(f"step={step!r}: the step must be a positive finite number")
    return float(step)


def checked_method(method: object) -> str | None:
    """:func:`solve`'s ``method``: None (the file's) or one of ``--method``'s choices."""
    if method is not None and (not isinstance(method, str) or method not in METHODS):
        raise InputError(f"method={method!r}: the method is one of {', '.join(map(repr, METHODS))}")
    return method


def solve(
    mech: Mechanism,
    *,
    step: float | None = None,
    method: str | None = None,
    velocity: bool | None = None,
    acceleration: bool | None = None,
    forces: bool | None = None,
) -> Results:
    """Solve the mechanism's sweep.

    Parameters
    ----------
    mech
        A mechanism from :func:`load`, or built in code: validated here if it was not,
        or was edited since it was validated.
    step
        Override the sweep step: rad, or m for a linear driver, or s for a sweep in time
        (a motion law with a ``duration``); or a text as ``--step`` takes it (``"2 deg"``,
        ``"0.01 s"``). Positive and finite, else an :class:`InputError`.
    method
        ``"auto"``, ``"newton"`` or ``"split-newton"``; default from the file.
    velocity, acceleration
        Override the file's ``outputs.quantities``.
    forces
        Run the force analysis (default: when the model has masses or loads).
    """
    checked_mechanism(mech).ensure_valid()  # built in code, or edited since: check it
    step, method = checked_step(mech, step), checked_method(method)
    an = analysis_for(mech, method, checked=True)  # kept between solves of an unchanged model
    ud = udd = None
    if mech.driver.motion is not None:  # a motion law: in time, or over driver positions
        u, t, ud, udd = an.motion_values(step)
    else:
        u, t = an.sweep_values(an.start_value(), step=step)
    vel = mech.outputs.velocity if velocity is None else velocity
    acc = mech.outputs.acceleration if acceleration is None else acceleration
    forces = mech.needs_forces if forces is None else forces
    if forces:
        vel = acc = True
    sol = core.states(an, u, ud, udd, t=t, velocity=vel or bool(acc), acceleration=bool(acc))
    force_result = core.forces(an, sol) if forces else None
    return Results(an, sol, force_result)


PLOT_STEP = math.radians(1.0)  # plots are drawn from a sweep at least this fine


def for_plots(mech: Mechanism, res: Results, method: str | None = None) -> Results:
    """The results that plots are drawn from: the same sweep at 1 degree or finer (a 360th
    of a linear driver's range), whatever step the file gives for its table, plus the
    exact driver values of its events: each rocker's and slider's limit positions, and
    where a conditional load switches or a joint's motion law is not smooth (a cam
    program's joins, where the follower's acceleration jumps:
    :meth:`~mechsolve.joints.base.Constraint.law_breaks`), sampled on both sides (1e-9
    apart) so that a curve jumps there instead of joining the samples around it.
    ``res`` itself when it is already that fine and has no switch or break to add, or
    has a motion law of time. Made once
    per run: the summary, the plots and the requirements read the same figures."""
    # of the model as solved (``mech`` or any edit of it since: see
    # Results.model_as_solved), so made once per results
    cached = getattr(res, "_plots_sweep", None)
    if cached is not None:
        cached[1].model_as_solved()  # (made before an edit of the model: as solved)
        return cached[1]
    fine = _for_plots(res.model_as_solved(), res)
    res._plots_sweep = (mech, fine)
    return fine


def _for_plots(mech: Mechanism, res: Results) -> Results:
    if mech.driver.motion is not None or len(res.u) < 2 or not np.all(res.ok[[0, -1]]):
        return res
    an = res.analysis
    travel = abs(float(res.u[-1] - res.u[0]))
    fine = travel / 360 if an.linear else PLOT_STEP
    coarse = travel / max(len(res.u) - 1, 1)
    switching = res.forces is not None and any(
        np.any(on[1:] != on[:-1]) for on in res.forces.active.values()
    )
    # the places where a joint's motion law is not smooth (a cam program's joins)
    breaks = any(r.constraint.law_breaks(res.solution.state) is not None for r in an.system.rows)
    vel, acc = res.solution.has_velocity, res.solution.has_acceleration
    if coarse <= fine * (1 + 1e-9) and not switching:
        if not breaks:
            return res
        # fine enough already: only the breaks' samples to add
        first, sol, f = res, res.solution, res.forces
        u, t = np.asarray(sol.u, float), np.asarray(sol.t, float)
    else:
        step = min(fine, coarse)
        u, t = an.sweep_values(an.start_value(), step=step, travel=travel)
        sol = core.states(an, u, t=t, velocity=vel, acceleration=acc)
        # stroke(q) over the extremes of the results' own sweep: one definition of a
        # conditional load's range, so the plots' work and mean effort are the table's
        f = core.forces(an, sol, res.forces.stroke_extremes) if res.forces is not None else None
        first = Results(an, sol, f)
    extra: list[float] = []
    for lp in first.limit_positions():
        extra += [lp.u_low, lp.u_high]
    if f is not None:
        from mechsolve.core.loads import switch_points

        h = 1e-9 * (an.scale if an.linear else 1.0)
        for us in switch_points(an, sol, f):
            extra += [us - h, us + h]
    if breaks:
        from mechsolve.core.breaks import break_points

        h = 1e-9 * (an.scale if an.linear else 1.0)
        ends = (float(u[0]), float(u[-1]))
        for ub in break_points(an, sol):
            # one at an end of the sweep: its sample there is already the one side's
            if min(abs(ub - e) for e in ends) > 10 * h:
                extra += [ub - h, ub + h]
    d = mech.driver.direction
    lo, hi = (u[0], u[-1]) if d > 0 else (u[-1], u[0])
    extra = [x for x in extra if lo < x < hi]
    if not extra:
        return first
    uu = np.concatenate([u, extra])
    order = np.argsort(d * (uu - u[0]), kind="stable")
    uu = uu[order]
    tt = np.interp(d * (uu - u[0]), d * (u - u[0]), t)
    sol = core.states(an, uu, t=tt, velocity=vel, acceleration=acc)
    f = core.forces(an, sol, f.stroke_extremes) if f is not None else None
    return Results(an, sol, f)


def positions(mech: Mechanism, step: float | None = None) -> int:
    """How many positions the sweep has (without solving it)."""
    sw = mech.sweep
    if sw.duration is not None:  # swept in time
        dt = step if step is not None else sw.time_step
        return max(0, math.ceil(sw.duration / dt - 1e-9)) + 1
    travel = sw.travel if sw.travel is not None else 2 * math.pi
    step = step if step is not None else sw.step
    if step is None:
        return 361
    ratio = travel / step
    if not ratio < 1e15:  # absurd (or infinite): the sweep itself says so
        return 10**15
    return max(0, math.ceil(ratio - 1e-9)) + 1
