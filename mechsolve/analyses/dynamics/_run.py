"""simulate(): size checks and the run (see :mod:`mechsolve.analyses.dynamics`)."""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np

from mechsolve.analyses.dynamics.constants import BYTES_PER_VALUE, MAX_STEPS
from mechsolve.analyses.dynamics.contact_loss import reduced_cut
from mechsolve.analyses.dynamics.integrators import _with_flywheel, integrate
from mechsolve.analyses.dynamics.model import ReducedModel
from mechsolve.analyses.dynamics.results import SimulationResults
from mechsolve.core import evaluate as core
from mechsolve.model import Mechanism


def check_size(mech: Mechanism, max_steps: int | None = None) -> None:
    """Refuse, before any work, a simulation of more than ``max_steps`` steps (output rows
    for an adaptive integrator; default :data:`MAX_STEPS`) or whose results would not fit
    in the memory available: an input error at the ``simulate`` section's step (or
    duration) with the numbers.

    The memory is estimated as rows times the columns of the results (from the numbers
    of points, links and joints) times :data:`BYTES_PER_VALUE`."""
    sim = mech.simulation
    if sim is None:
        return
    limit = MAX_STEPS if max_steps is None else max_steps
    step = sim.step or sim.duration / 500
    ratio = sim.duration / step  # inf for a step of 1e-300 s over 1e10 s
    steps = math.ceil(ratio - 1e-9) if math.isfinite(ratio) else math.inf
    rows = steps + 1
    memory = rows * _columns_estimate(mech) * BYTES_PER_VALUE
    available = _available_memory()
    over_memory = available is not None and memory > available
    if steps <= limit and not over_memory:
        return
    what = "steps" if sim.method == "rk4" else f"output times ({sim.method}'s output step)"
    whole = (
        " (the limit counts the whole duration; 'revolutions' or 'steady' may end it sooner)"
        if sim.revolutions or sim.steady
        else ""
    )
    limits = f"the limit is {limit} steps" if steps > limit else ""
    if over_memory:
        limits += (" and " if limits else "") + (
            f"this machine has {_bytes_text(available)} of memory available"
        )
    raise mech.error(
        ("simulate", "step") if sim.step else ("simulate", "duration"),
        f"a duration of {sim.duration:g} s in steps of {step:g} s is {steps:.6g} {what}, "
        f"about {_bytes_text(memory)} of results ({rows:.6g} rows of about "
        f"{_columns_estimate(mech)} values){whole}; {limits}: give a longer step or a "
        "shorter duration" + (", or raise the limit with --max-steps N" if steps > limit else ""),
    )


def _columns_estimate(mech: Mechanism) -> int:
    """About how many columns the results of a motion have: the driver's and the
    motor's, six a moving point (position, velocity, acceleration), three a link, three a
    pin's reaction and seven a slider's (reaction and travel), the energies and powers."""
    ground = set(mech.ground)
    points = {p for lk in mech.links for p in lk.points} - ground
    sliders = len(mech.sliders)
    return 20 + 6 * len(points) + 3 * len(mech.links) + 3 * len(mech.joints) + 4 * sliders


def _available_memory() -> int | None:
    """The memory available to a new process (bytes; Linux's MemAvailable), or None."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _bytes_text(n: float) -> str:
    """``12.3 GB``: a number of bytes in decimal units."""
    for unit, size in (("EB", 1e18), ("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


def simulate(
    mech: Mechanism,
    *,
    method: str | None = None,
    exact: bool = False,
    progress=None,
    max_steps: int | None = None,
) -> SimulationResults:
    """Simulate the motor-driven machine of ``mech`` (its ``motor:`` and ``simulate:``
    sections) and solve the states and joint forces along the motion. ``exact``: solve
    the equation of motion at every integrator stage instead of from its tabulation over
    a turn (see :meth:`ReducedModel.tabulate`; always so where it cannot tabulate: a
    crank that does not turn fully or whose linkage does not come back after a turn, a
    condition that reads the size of a speed, a J too sharp for a table).

    Where the motion cannot go on (the mechanism does not close, the step is too large,
    the motor's law is not finite), the results hold the motion up to there and
    ``trajectory.stopped`` says why (``trajectory.early``); a motor law that is not finite
    is an input error (``trajectory.error``), raised at once if it stops the motion at its
    start.

    ``max_steps``: refuse more steps than this (see :func:`check_size`; an adaptive
    integrator also stops after that many steps of its own)."""
    from mechsolve.analyses.dynamics.multibody_run import simulate_multibody, uses_multibody

    if uses_multibody(mech):
        check_size(mech, max_steps)
        return simulate_multibody(mech, max_steps=max_steps)
    if mech.motor is None:
        raise mech.error(
            ("motor",), "a simulation needs a 'motor' section (the driver's torque law)"
        )
    if mech.simulation is None:
        raise mech.error(("simulate",), "a simulation needs a 'simulate' section (duration, step)")
    check_size(mech, max_steps)
    machine = _with_flywheel(mech)
    if machine.driver.motion is not None:
        machine = copy.copy(machine)
        machine.driver = dataclasses.replace(machine.driver, motion=None)
    model = ReducedModel(machine, method)
    if not model.ref.ok[0]:
        raise mech.error(("driver", "start"), "the mechanism cannot close at the driver's start")
    if not exact:
        model.tabulate()
    traj = integrate(model, mech.simulation, mech.motor, progress, max_steps)
    if traj.error is not None and len(traj.t) < 2:
        raise traj.error  # the file's motor law at the start: nothing to keep
    good = np.isfinite(traj.J)
    an = model.an
    phi = traj.phi[good]
    if model.full_turn:  # the linkage repeats each turn: solved on the reference turn
        sol = model.states_by_turn(phi, traj.omega[good], traj.eps[good], traj.t[good])
    else:
        sol = core.states(an, phi, traj.omega[good], traj.eps[good], t=traj.t[good])
    if not good.all():
        traj = dataclasses.replace(
            traj, **{f: getattr(traj, f)[good] for f in ("t", "phi", "omega", "eps", "J")}
        )
    # with joint friction each row's force analysis starts from the equation of motion's
    # magnitudes there: where it self-locks at that acceleration (det(I - G) <= 0) the
    # motion's friction is the solution the equation of motion found (see friction.balance)
    mags = traj.magnitudes
    hint = None if mags is None else (None, mags[:, good])
    forces = core.forces(an, sol, model.extremes, hint)
    cut = reduced_cut(model, mech, traj, forces)  # a cam cannot pull its follower
    if cut is not None:
        traj, sol, forces = cut
    res = SimulationResults(an, sol, forces, traj, mech.motor)
    res.model = model
    return res
