"""Instants: the mechanism's state and forces at given driver positions and rates.

Textbook problems of dynamic force analysis give the crank's state at one instant
(``theta = 30 deg, omega = 10 rad/s, alpha = 5 rad/s^2``) and ask for every pin force and
the driving torque. :func:`solve_instants` answers them with the solver core
(:func:`mechsolve.core.states` and :func:`mechsolve.core.forces`): the mechanism is
assembled at the driver's start as for a sweep, and each instant's position is reached
from there along the driver's direction, on the same branches.

Loads act as in a sweep. A ``when:`` condition is evaluated on the instant's own state
(its velocities and accelerations come from the given rates). ``stroke(q)`` needs the
extremes of ``q`` over the motion: they are taken over the file's sweep (solved for its
positions only when a condition uses ``stroke``).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from . import core
from .errors import InputError
from .model import Mechanism
from .results import Results
from .sweep import Analysis, StateView
from .units import UnitError, parse_quantity

__all__ = ["Instant", "parse_instant", "solve_instants", "instants_table"]

# the keys an instant may give, for a revolute and a linear driver
_KEYS = {
    False: {"theta": "angle", "omega": "angular speed", "alpha": "angular acceleration"},
    True: {"s": "length", "v": "speed", "a": "acceleration"},
}


@dataclass
class Instant:
    """A driver position ``u`` (rad or m) with its speed and acceleration."""

    u: float
    ud: float
    udd: float
    label: str = ""


def parse_instant(mech: Mechanism, spec: str | dict, where: str = "--at") -> Instant:
    """An instant from ``"theta=30 deg, omega=10 rad/s, alpha=5 rad/s^2"`` (or a mapping
    with those keys; ``s``, ``v``, ``a`` for a linear driver). ``alpha`` (``a``) defaults
    to 0; the position and the speed must be given."""
    from .model import SliderJoint

    linear = isinstance(mech.joint(mech.driver.joint), SliderJoint)
    keys = _KEYS[linear]
    if isinstance(spec, str):
        items = {}
        for part in (p for p in spec.split(",") if p.strip()):
            m = re.fullmatch(r"\s*([A-Za-z_]+)\s*=\s*([^=;]+?)\s*", part)
            if not m:
                raise InputError(f"{where}: {part.strip()!r} is not 'name=value' (in {spec!r})")
            items[m.group(1)] = m.group(2)
        label = spec.strip()
    elif isinstance(spec, dict):
        items, label = dict(spec), ", ".join(f"{k}={v}" for k, v in spec.items())
    else:
        raise InputError(f"{where}: expected 'theta=..., omega=..., alpha=...', got {spec!r}")
    unknown = set(items) - set(keys)
    if unknown:
        raise InputError(
            f"{where}: unknown {', '.join(sorted(unknown))!s} (an instant of this driver "
            f"gives {', '.join(keys)})"
        )
    pos, vel, acc = keys
    for need in (pos, vel):
        if need not in items:
            raise InputError(
                f"{where}: the instant {label!r} has no {need!r}: give {pos}, {vel} "
                f"(and {acc}, 0 when left out)"
            )
    vals = {}
    for k, kind in keys.items():
        if k not in items:
            vals[k] = 0.0
            continue
        try:
            default = "deg" if kind == "angle" else None
            vals[k] = parse_quantity(items[k], kind, default)
        except UnitError as exc:
            raise InputError(f"{where}: {k}: {exc}") from None
    return Instant(vals[pos], vals[vel], vals[acc], label)


def solve_instants(
    mech: Mechanism,
    instants: list[Instant],
    *,
    method: str | None = None,
    forces: bool | None = None,
) -> Results:
    """Positions, velocities, accelerations and (with masses or loads) forces at the
    instants, as :class:`~mechsolve.results.Results` with one row per instant."""
    if not instants:
        raise InputError("no instants to solve")
    an = Analysis(mech, method)
    u = np.array([i.u for i in instants])
    ud = np.array([i.ud for i in instants])
    udd = np.array([i.udd for i in instants])
    sol = core.states(an, u, ud, udd, t=np.zeros(len(u)))
    forces = mech.needs_forces if forces is None else forces
    fr = None
    if forces:
        extremes = None
        if any(ld.when is not None and ld.when.uses("stroke") for ld in mech.loads):
            extremes = _stroke_extremes(an)
        fr = core.forces(an, sol, extremes)
    res = Results(an, sol, fr)
    res.instant_labels = [i.label for i in instants]
    return res


def _stroke_extremes(an: Analysis) -> list[tuple[float, float]]:
    """The extremes that ``stroke(q)`` uses, over the file's sweep (positions only)."""
    from .solvers.forces import condition_masks

    u, t = an.sweep_values(an.start_value())
    sweep = core.states(an, u, t=t, velocity=False, acceleration=False)
    extremes: list[tuple[float, float]] = []
    view = StateView(an, sweep.state)
    view.has_velocity = view.has_acceleration = False
    condition_masks(an, sweep, view, extremes)
    return extremes


def instants_table(res: Results) -> str:
    """Every quantity at each instant, as a readable table (one column per instant)."""
    cols = [c for c in res.columns() if c.name not in ("t", "input.travel")]
    labels = getattr(res, "instant_labels", None) or [f"#{k + 1}" for k in range(len(res))]
    width = max(len(c.header) for c in cols)
    lines = []
    for k, label in enumerate(labels):
        lines.append(f"instant {k + 1}: {label}")
        if not res.ok[k]:
            lines.append(f"  not solved: {res.status()[k]}")
            continue
        for c in cols:
            v = float(c.values[k])
            text = "" if not math.isfinite(v) else f"{v:.6g}"
            lines.append(f"  {c.header:<{width}}  {text:>14}")
    return "\n".join(lines)
