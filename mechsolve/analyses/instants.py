"""Instants: the mechanism's state and forces at given driver positions and rates.

Textbook problems of dynamic force analysis give the crank's state at one instant
(``theta = 30 deg, omega = 10 rad/s, alpha = 5 rad/s^2``) and ask for every pin force and
the driving torque. :func:`solve_instants` answers them with the solver core
(:func:`mechsolve.core.evaluate.states` and :func:`mechsolve.core.evaluate.forces`):
the mechanism is assembled at the driver's start as for a sweep, and each instant's
position is reached from there along the driver's direction, on the same branches.

Loads act as in a sweep. A ``when:`` condition is evaluated on the instant's own state
(its velocities and accelerations come from the given rates). ``stroke(q)`` needs the
extremes of ``q`` over the motion: they are those of the file's sweep, located exactly
between its samples as the run locates them (the sweep is solved only when a condition
uses ``stroke``).
"""

from __future__ import annotations

import math
import re
import unicodedata
from dataclasses import dataclass

import numpy as np

from mechsolve.base.errors import InputError
from mechsolve.base.units import OutputUnits, UnitError, parse_quantity
from mechsolve.core import evaluate as core
from mechsolve.core.loads import stroke_extremes, stroke_function
from mechsolve.core.sweep import Analysis, StateView
from mechsolve.model import Mechanism
from mechsolve.model.expr import ExprError
from mechsolve.results.results import Results

__all__ = ["Instant", "instant_names", "parse_instant", "solve_instants", "instants_table"]

# the keys an instant may give, for a revolute and a linear driver, with the kind of
# quantity each one is
_KEYS = {
    False: {"theta": "angle", "omega": "angular speed", "alpha": "angular acceleration"},
    True: {"s": "length", "v": "speed", "a": "acceleration"},
}
# other names of the same keys, as textbooks write them: Greek letters (both forms of
# theta, phi and epsilon) and the crank angle phi and angular acceleration epsilon of the
# Russian and Chinese texts
_ALIASES = {
    False: {
        "theta": ("θ", "ϑ", "phi", "φ", "ϕ"),
        "omega": ("ω",),
        "alpha": ("α", "epsilon", "ε", "ϵ"),
    },
    True: {"s": (), "v": (), "a": ()},
}
_NAME_VALUE = re.compile(r"\s*([^\W\d]\w*)\s*=\s*([^=;]+?)\s*")


def instant_names(mech: Mechanism) -> dict[str, str]:
    """Every name an instant of ``mech``'s driver takes, mapped to its key (``θ`` ->
    ``theta``; ``s``, ``v``, ``a`` for a linear driver)."""
    linear = _is_linear(mech)
    out = {k: k for k in _KEYS[linear]}
    for key, others in _ALIASES[linear].items():
        out.update(dict.fromkeys(others, key))
    return out


def _is_linear(mech: Mechanism) -> bool:

    return mech.joint(mech.driver.joint).coordinate == "length"


@dataclass
class Instant:
    """A driver position ``u`` (rad or m) with its speed and acceleration.

    ``note``: what the output should say beside it (rates taken from the file, a speed
    against the file's direction of motion)."""

    u: float
    ud: float
    udd: float
    label: str = ""
    note: str = ""


def parse_instant(mech: Mechanism, spec: str | dict, where: str = "--at") -> Instant:
    """An instant from ``"theta=30 deg, omega=10 rad/s, alpha=5 rad/s^2"`` (or a mapping
    with those keys; ``s``, ``v``, ``a`` for a linear driver).

    Greek names are the same names: ``θ`` (also ``φ``, ``phi``) is ``theta``, ``ω`` is
    ``omega``, ``α`` (also ``ε``, ``epsilon``) is ``alpha``. A name given twice, under
    either spelling, is refused. The position must be given; the speed and acceleration
    default to the file's driver at that position (its constant speed and no acceleration,
    or the rates of its motion law where the law first reaches the position).

    A bare number is read as the file reads its own ``instants:``: a position in the
    file's length or angle unit (``units:``; m and deg when it names none), a speed or
    acceleration in SI (m/s, rad/s; m/s^2, rad/s^2)."""
    linear = _is_linear(mech)
    keys = _KEYS[linear]
    names = instant_names(mech)
    if isinstance(spec, str):
        pairs = []
        for part in (p for p in spec.split(",") if p.strip()):
            m = _NAME_VALUE.fullmatch(part)
            if not m:
                raise InputError(
                    f"{where}: {part.strip()!r} is not 'name=value' (in {spec!r}; e.g. "
                    f"{_example(linear)!r})"
                )
            pairs.append((m.group(1), m.group(2)))
        label = spec.strip()
    elif isinstance(spec, dict):
        pairs = [(str(k), v) for k, v in spec.items()]
        label = ", ".join(f"{k}={v}" for k, v in spec.items())
    else:
        raise InputError(f"{where}: expected {_example(linear)!r}, got {spec!r}")
    items: dict[str, object] = {}
    spelled: dict[str, str] = {}
    for name, value in pairs:
        # compatibility forms are the same letters: ϑ is θ, 𝜃 (mathematical italic) is θ
        key = names.get(name) or names.get(unicodedata.normalize("NFKC", name))
        if key is None:
            raise InputError(
                f"{where}: unknown name {name!r} in {label!r} (an instant of this driver "
                f"gives {_known(linear)})"
            )
        if key in items:
            same = (
                f"{spelled[key]!r} twice"
                if spelled[key] == name
                else f"twice, as {spelled[key]!r} and {name!r}"
            )
            raise InputError(f"{where}: {label!r} gives {key} {same}: give it once")
        items[key] = value
        spelled[key] = name
    pos, vel, acc = keys
    if pos not in items:
        raise InputError(
            f"{where}: the instant {label!r} has no {pos!r}: give {pos} (and {vel}, {acc}; "
            "by default the file's driver's)"
        )
    vals = {}
    # a bare number is in the file's units, as in its own instants: its length unit,
    # its angle unit (deg when it names none); rates in SI
    plain = {"length": mech.length_unit, "angle": mech.angle_unit or "deg"}
    for k, kind in keys.items():
        if k not in items:
            continue
        try:
            vals[k] = parse_quantity(items[k], kind, plain.get(kind))
        except UnitError as exc:
            raise InputError(f"{where}: {spelled[k]}: {exc}") from None
    u = vals[pos]
    notes = []
    if vel not in vals or acc not in vals:
        try:
            ud, udd, source = _file_rates(mech, u, linear, label, where)
        except InputError:
            if vel not in vals:
                raise
            # the speed is given, the law never reaches the position: no acceleration
            ud, udd, source = vals[vel], 0.0, "the file's motion law does not reach here"
        filled = []
        if vel not in vals:
            vals[vel] = ud
            filled.append(f"{vel} = {_rate_text(ud, linear, 1)}")
        if acc not in vals:
            vals[acc] = udd
            filled.append(f"{acc} = {_rate_text(udd, linear, 2)}")
        notes.append(f"{', '.join(filled)}: {source}")
    against = _against_the_file(mech, vals[vel], linear)
    if against:
        notes.append(against)
    return Instant(u, vals[vel], vals[acc], label, "; ".join(notes))


def _example(linear: bool) -> str:
    if linear:
        return "s=20 mm, v=0.5 m/s, a=2 m/s^2"
    return "theta=30 deg, omega=10 rad/s, alpha=5 rad/s^2"


def _known(linear: bool) -> str:
    return ", ".join(
        k + (f" ({' '.join(_ALIASES[linear][k])})" if _ALIASES[linear][k] else "")
        for k in _KEYS[linear]
    )


def _rate_text(value: float, linear: bool, order: int) -> str:
    unit = ("m/s" if order == 1 else "m/s^2") if linear else ("rad/s" if order == 1 else "rad/s^2")
    text = f"{value:.6g} {unit}"
    if order == 1 and not linear and value:
        text += f" ({abs(value) * 30 / math.pi:.6g} rpm {_sense(value)})"
    return text


def _sense(value: float) -> str:
    return "counter-clockwise" if value > 0 else "clockwise"


def _against_the_file(mech: Mechanism, speed: float, linear: bool) -> str:
    """A note when ``speed`` moves the driver against the file's direction of motion."""
    d = mech.driver
    if speed == 0 or (d.speed == 0 and d.motion is None) or np.sign(speed) == d.direction:
        return ""
    if linear:
        return (
            f"v = {speed:.6g} m/s moves the slider against the file's driver ({d.speed:.6g} "
            "m/s): velocities and the loads whose conditions read them are those of the "
            "reversed motion"
        )
    return (
        f"omega = {speed:.6g} rad/s turns the crank {_sense(speed)}, against the file's "
        f"driver ({_sense(d.direction)}): velocities and the loads whose conditions read "
        "them are those of the reversed motion"
    )


def _file_rates(
    mech: Mechanism, u: float, linear: bool, label: str, where: str
) -> tuple[float, float, str]:
    """The file's driver speed and acceleration at the driver value ``u``, and where they
    come from (for the output)."""
    d = mech.driver
    law = d.motion
    if law is None:
        what = "a constant speed" if d.speed else "at rest: positions quasi-static"
        return float(d.speed), 0.0, f"the file's driver ({what})"
    t = _first_time(mech, law, u, linear)
    if t is None:
        vel, acc = ("v", "a") if linear else ("omega", "alpha")
        raise InputError(
            f"{where}: {label!r}: the file's motion law does not reach this position "
            f"{'' if mech.sweep.duration is None else 'within the sweep '}(from its start, "
            f"in its direction), so it gives no speed here: give {vel} (and {acc})"
        )
    _, ud, udd = law.at(np.array([t]))
    return (
        float(ud[0]),
        float(udd[0]),
        f"the file's motion law where it first reaches the position, t = {t:.6g} s",
    )


def _first_time(mech: Mechanism, law, u: float, linear: bool) -> float | None:
    """The first time at which the driver's motion law reaches the value ``u`` (for a
    revolute driver, the same angle on any turn); None if it never does (within the
    sweep's duration, or the law's own)."""
    from scipy.optimize import brentq

    start = float(law.start)
    period = None if linear else 2 * math.pi
    if hasattr(law, "time_at"):  # one direction of motion: exact
        travel = law.direction() * (u - start)
        if period is not None:
            travel %= period
        t = float(np.asarray(law.time_at(np.array([travel])))[0])
        end = mech.sweep.duration
        return t if math.isfinite(t) and (end is None or t <= end * (1 + 1e-12)) else None
    end = mech.sweep.duration or law.duration
    if not end:
        return None
    t = np.linspace(0.0, end, 4097)
    x = law.at(t)[0] - u  # reached where x is 0 (a multiple of a turn for an angle)
    turn = np.floor(x / period) if period is not None else np.sign(x)
    if (x[0] % period if period is not None else x[0]) == 0:
        return 0.0
    change = np.flatnonzero(turn[1:] != turn[:-1])
    if not change.size:
        return None
    k = int(change[0])
    # the level passed between the samples: the upper one's turn, or 0
    level = u + (period * max(turn[k], turn[k + 1]) if period is not None else 0.0)
    return float(brentq(lambda s: float(law.at(np.array([s]))[0][0]) - level, t[k], t[k + 1]))


def solve_instants(
    mech: Mechanism,
    instants: list[Instant],
    *,
    method: str | None = None,
    forces: bool | None = None,
) -> Results:
    """Positions, velocities, accelerations and (with masses or loads) forces at the
    instants, as :class:`~mechsolve.results.results.Results` with one row per instant."""
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
        # each condition on the instant's own state (position, velocity, acceleration),
        # first one by one so that an error names the load's file, line and key
        _conditions(an, sol, stroke_function(extremes or [], replay=True), "at the instant")
        fr = core.forces(an, sol, extremes)
    res = Results(an, sol, fr)
    res.instant_labels = [i.label for i in instants]
    res.instant_notes = [i.note for i in instants]
    return res


def _stroke_extremes(an: Analysis) -> list[tuple[float, float]]:
    """The extremes that ``stroke(q)`` uses: over the file's sweep, solved as ``run``
    solves it (with its velocities and accelerations, which conditions such as
    ``C.vx > 0 and 0.05 <= stroke(C.x) <= 0.95`` read beside the stroke), in the order
    that the force analysis asks for them, located exactly between the samples by the
    same function as the run's (:func:`mechsolve.core.loads.stroke_extremes`)."""
    mech = an.mech
    ud = udd = None
    if mech.driver.motion is not None:
        u, t, ud, udd = an.motion_values()
    else:
        u, t = an.sweep_values(an.start_value())
    sweep = core.states(an, u, ud, udd, t=t)
    # first each condition alone, so that an error names the load's file, line and key
    _conditions(an, sweep, stroke_function([]), "over the file's sweep")
    return stroke_extremes(an, sweep)


def _conditions(an: Analysis, sol, stroke, context: str) -> None:
    """Evaluate every load's ``when:`` on the states of ``sol`` in the force analysis's
    order (which records or replays the extremes of ``stroke``); an error names the
    load's ``when`` key in the file."""
    mech = an.mech
    view = StateView(an, sol.state)
    for load in mech.loads:
        if load.when is None:
            continue
        try:
            with np.errstate(invalid="ignore"):
                load.when.evaluate(view, {"stroke": stroke})
        except (InputError, ExprError) as exc:
            if isinstance(exc, InputError) and (exc.file or exc.keypath):
                raise
            raise mech.error(
                tuple(load.where or ("loads", load.name)) + ("when",),
                f"the condition of load {load.name!r} cannot be evaluated {context}: {exc}",
            ) from None


def instants_table(res: Results, units: OutputUnits | None = None) -> str:
    """Every quantity at each instant, as a readable table (one column per instant), in
    ``units`` (SI when not given)."""
    from mechsolve.results.csv import in_units

    shown = in_units(res, units).columns()
    cols = [c for c in shown if c.name not in ("t", "input.travel")]
    labels = getattr(res, "instant_labels", None) or [f"#{k + 1}" for k in range(len(res))]
    notes = getattr(res, "instant_notes", None) or [""] * len(labels)
    width = max(len(c.header) for c in cols)
    lines = []
    for k, label in enumerate(labels):
        lines.append(f"instant {k + 1}: {label}")
        if notes[k]:
            lines.append(f"  ({notes[k]})")
        if not res.ok[k]:
            lines.append(f"  not solved: {res.status()[k]}")
            continue
        for c in cols:
            v = float(c.values[k])
            text = "" if not math.isfinite(v) else f"{v + 0.0:.6g}"  # no "-0"
            lines.append(f"  {c.header:<{width}}  {text:>14}")
    return "\n".join(lines)
