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
from mechsolve.base.numerics import bisect_edge
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
    against the file's direction of motion). ``t``: the time at which the file's driver is
    there (its motion law's); None: :func:`solve_instants` finds it from ``u``."""

    u: float
    ud: float
    udd: float
    label: str = ""
    note: str = ""
    t: float | None = None  # the time (s) of the file's motion there; None: found from u


def parse_instant(mech: Mechanism, spec: str | dict, where: str = "--at") -> Instant:
    """An instant from ``"theta=30 deg, omega=10 rad/s, alpha=5 rad/s^2"`` (or a mapping
    with those keys; ``s``, ``v``, ``a`` for a linear driver).

    Greek names are the same names: ``θ`` (also ``φ``, ``phi``) is ``theta``, ``ω`` is
    ``omega``, ``α`` (also ``ε``, ``epsilon``) is ``alpha``. A name given twice, under
    either spelling, is refused. The position must be given; the speed and acceleration
    default to the file's driver at that position (its constant speed and no acceleration,
    or the rates of its motion law where the law first reaches the position: the value as
    written, 530 deg on the second turn; an angle behind the start on the turn where the
    law first meets it, which then becomes the instant's position).

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
    u, t, notes = _fill_rates(mech, vals[pos], vals, keys, label, where)
    against = _against_the_file(mech, vals[vel], linear)
    if against:
        notes.append(against)
    return Instant(u, vals[vel], vals[acc], label, "; ".join(notes), t)


def _fill_rates(
    mech: Mechanism, u: float, vals: dict, keys: dict, label: str, where: str
) -> tuple[float, float | None, list[str]]:
    """Fill the speed and acceleration that ``vals`` lacks with the file's driver's at
    ``u``; the driver value (moved to the turn where a motion law reaches the angle), the
    law's time there (None: none) and the note that says so."""
    linear = _is_linear(mech)
    _, vel, acc = keys
    if vel in vals and acc in vals:
        return u, None, []
    try:
        got = _file_rates(mech, u, linear, label, where)
    except InputError:
        if vel not in vals:
            raise
        # the speed is given, the law never reaches the position: no acceleration
        got = _Reached(vals[vel], 0.0, "the file's motion law does not reach here", None, u)
    filled = []
    if vel not in vals:
        vals[vel] = got.ud
        filled.append(f"{vel} = {_rate_text(got.ud, linear, 1)}")
    if acc not in vals:
        vals[acc] = got.udd
        filled.append(f"{acc} = {_rate_text(got.udd, linear, 2)}")
    return got.u, got.t, [f"{', '.join(filled)}: {got.source}"]


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


def _file_rates(mech: Mechanism, u: float, linear: bool, label: str, where: str) -> _Reached:
    """The file's driver speed and acceleration at the driver value ``u``, where they come
    from (for the output), and for a motion law the time and the value it reaches."""
    d = mech.driver
    law = d.motion
    if law is None:
        what = "a constant speed" if d.speed else "at rest: positions quasi-static"
        return _Reached(float(d.speed), 0.0, f"the file's driver ({what})", None, u)
    found = _law_reaches(mech, law, u, linear)
    if found is None:
        vel, acc = ("v", "a") if linear else ("omega", "alpha")
        raise InputError(
            f"{where}: {label!r}: the file's motion law does not reach this position "
            f"{'' if mech.sweep.duration is None else 'within the sweep '}(from its start; "
            f"{'' if linear else 'an angle behind the start on a later turn; '}"
            f"{_law_span(mech, law, linear)}), so it gives no speed here: give {vel} (and "
            f"{acc})"
        )
    t, value = found
    _, ud, udd = law.at(np.array([t]))
    source = f"the file's motion law where it first reaches the position, t = {t:.6g} s"
    if value != u:  # behind the start: the same angle on a later turn
        source = (
            f"the file's motion law reaches this angle on a later turn, at "
            f"{math.degrees(value):.6g} deg, t = {t:.6g} s: the instant is there"
        )
    return _Reached(float(ud[0]), float(udd[0]), source, t, value)


def _law_span(mech: Mechanism, law, linear: bool) -> str:
    """The range the motion law covers (for a message), e.g. 'it covers 0 to 540 deg'."""
    end = mech.sweep.duration or law.duration
    if not end:
        return "it has no end"
    u = law.at(np.linspace(0.0, end, 4097))[0]
    lo, hi = float(u.min()), float(u.max())
    if linear:
        f = 1.0 / parse_quantity(1.0, "length", mech.length_unit)
        return f"it covers {lo * f:.6g} to {hi * f:.6g} {mech.length_unit}"
    return f"it covers {math.degrees(lo):.6g} to {math.degrees(hi):.6g} deg"


@dataclass
class _Reached:
    """The file's driver at an instant's position: its rates, where they come from, the
    time (None: not a motion law) and the driver value (the position asked, or the same
    angle on the turn where the motion law reaches it)."""

    ud: float
    udd: float
    source: str
    t: float | None
    u: float


def _law_reaches(mech: Mechanism, law, u: float, linear: bool) -> tuple[float, float] | None:
    """``(t, value)``: the first time at which the driver's motion law reaches the value
    ``u`` itself (on whichever turn ``u`` names: 530 deg is the second turn's 170 deg),
    and ``u``; for a revolute driver and an angle behind the start that the law never
    reaches, the first time it reaches the same angle on a later turn, and that angle.
    None if it reaches neither within the sweep's duration (or the law's)."""
    found = _first_time(mech, law, u, None)
    if found is not None:
        return found[0], u
    if linear or law.direction() * (u - float(law.start)) >= 0:
        return None  # beyond the law's reach: no other turn stands in for the one named
    turn = 2 * math.pi
    found = _first_time(mech, law, u, turn)
    return None if found is None else (found[0], u + turn * found[1])


def _first_time(mech: Mechanism, law, u: float, period: float | None) -> tuple[float, int] | None:
    """The first time at which the driver's motion law reaches the value ``u`` (with a
    ``period``, any value ``u + k period``: then also that ``k``), as ``(t, k)``; None if
    it never does (within the sweep's duration, or the law's own). Any law, one that
    turns back too; a value met within rounding (1e-14 of it) is reached."""
    end = mech.sweep.duration or law.duration
    if hasattr(law, "time_at"):  # one direction of motion until it stops: exact
        travel = law.direction() * (u - float(law.start))
        if period is not None:
            travel %= period
        if travel >= 0:
            t = float(np.asarray(law.time_at(np.array([travel])))[0])
            if math.isfinite(t) and (end is None or t <= end * (1 + 1e-12)):
                value = float(law.start) + law.direction() * travel
                return t, (0 if period is None else round((value - u) / period))
    if not end:
        return None
    tol = 1e-14 * max(1.0, abs(u))

    def side(s: np.ndarray) -> np.ndarray:
        """2k on the level u + k period (u itself: 0), 2k + 1 between levels k and k + 1
        (without a period: -1 below u, 1 above)."""
        x = law.at(s)[0] - u
        p = period if period is not None else 2 * tol + np.abs(x).max() + 1.0
        k = np.round(x / p)
        return np.where(np.abs(x - k * p) <= tol, 2 * k, 2 * np.floor(x / p) + 1)

    t = np.linspace(0.0, end, 4097)
    sides = side(t)
    if sides[0] % 2 == 0:
        return 0.0, int(sides[0]) // 2
    change = np.flatnonzero(sides[1:] != sides[:-1])
    if not change.size:
        return None
    a, b = t[change[0]], t[change[0] + 1]
    first = sides[0]
    # bisection to the first time the side changes
    b = bisect_edge(lambda mid: side(np.array([mid]))[0] == first, a, b, 80)[1]
    after = int(side(np.array([b]))[0])
    # on a level, or past one: the level between the two sides
    k = after // 2 if after % 2 == 0 else max(int(first), after) // 2
    if after % 2 == 0:  # met within rounding: where it comes to rest, if it does
        b = _settle(law, b, 1.0 if first < after else -1.0, tol)
    # a crossing met within rounding: one Newton step onto the level itself
    x, v, _ = law.at(np.array([b]))
    x = float(x[0]) - u - (period or 0.0) * k
    step = x / float(v[0]) if v[0] != 0 and abs(x) <= tol else math.inf
    if abs(step) <= 1e-9 * max(1.0, b) and b - step >= 0:  # not at a stop: a small step
        b -= step
    return float(b), k


def _settle(law, b: float, sense: float, tol: float) -> float:
    """A law that comes to rest on a level (the end of a deceleration, a turning point)
    is within ``tol`` of it a little before it stops, at ``b``: the time it stops, where
    its speed (``sense``: towards the level) vanishes; ``b`` itself for a crossing."""
    _, v, acc = law.at(np.array([b]))
    v, acc = sense * float(v[0]), abs(float(acc[0]))
    if acc == 0 or v <= 0:
        return b
    reach = math.sqrt(2 * tol / acc)  # the time a stop takes from within tol of the level
    if v > 4 * acc * reach:
        return b  # too fast to stop there: a crossing
    hi = b + 8 * reach
    if sense * float(law.at(np.array([hi]))[1][0]) > 0:
        return b  # still moving on
    # bisection to the first time the speed vanishes
    return bisect_edge(lambda mid: sense * float(law.at(np.array([mid]))[1][0]) > 0, b, hi, 80)[1]


def solve_instants(
    mech: Mechanism,
    instants: list[Instant],
    *,
    method: str | None = None,
    forces: bool | None = None,
) -> Results:
    """Positions, velocities, accelerations and (with masses or loads) forces at the
    instants, as :class:`~mechsolve.results.results.Results` with one row per instant;
    its time is when the file's driver is there (:func:`_time_there`)."""
    if not instants:
        raise InputError("no instants to solve")
    an = Analysis(mech, method)
    u = np.array([i.u for i in instants])
    ud = np.array([i.ud for i in instants])
    udd = np.array([i.udd for i in instants])
    t = np.array([_time_there(an, i) for i in instants])
    sol = core.states(an, within_cycle(an, u), ud, udd, t=t)
    sol.u = u  # the positions asked (those solved are the same within the cycle)
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


# the most driver travel from the start that an instant is followed over where the machine
# has no cycle to reduce it by, in steps of the branch analysis's grid (2 degrees: 10472 rad,
# 1667 turns; a four-bar followed over 1e4 rad took 1.2 s and 122 MB, over 3e4 rad 1.9 s
# and 256 MB, over 9e5 rad 54 s and 6 GB)
MAX_TRAVEL_STEPS = 300_000


def within_cycle(an: Analysis, u: np.ndarray) -> np.ndarray:
    """The driver values ``u`` moved to within the machine's cycle from the start.

    An instant's position is reached from the driver's start along the driver's
    direction (:func:`mechsolve.core.evaluate.states`), so the work and memory grow with
    the travel. A revolute driver's machine repeats after its cycle
    (:func:`mechsolve.analyses.dynamics.cycle.machine_cycle`: one turn for a linkage, two
    for one that changes branch at a change point, three for a 20-tooth pinion driving a
    60-tooth wheel), so a travel ``x`` beyond one turn is solved at ``x mod cycle`` (the
    same configuration, on the same branch); behind the start, with the cycle of the
    motion the other way. What has no cycle (a slider driver, a crank that does not turn
    fully, a machine that does not repeat within 100 turns) is refused beyond
    :data:`MAX_TRAVEL_STEPS` steps of 2 degrees (of 2/180 pi of the mechanism's size for a
    slider) with an input error."""
    from mechsolve.analyses.dynamics.cycle import machine_cycle
    from mechsolve.core.branches import EVENT_STEP

    u = np.asarray(u, float)
    u0 = an.start_value()
    d = an.mech.driver.direction
    travel = d * (u - u0)
    out = u.copy()
    if not an.linear:
        for sense, way in ((1, an), (-1, None)):
            far = sense * travel > 2 * math.pi
            if not far.any():
                continue
            turns = machine_cycle(way or an.reversed(), acceleration=False).turns
            if turns:  # (0: no repeat within the turns looked at; None: no full turn)
                x = np.mod(sense * travel[far], 2 * math.pi * turns)
                out[far] = u0 + d * sense * x
    step = EVENT_STEP * (an.scale if an.linear else 1.0)
    left = np.abs(out - u0)
    if left.size and left.max() > MAX_TRAVEL_STEPS * step:
        k = int(np.argmax(left))
        unit, limit = ("m" if an.linear else "rad"), MAX_TRAVEL_STEPS * step
        why = (
            "a slider driver has no cycle"
            if an.linear
            else "the machine has no cycle of whole turns to reduce it by"
        )
        raise InputError(
            f"the instant at {_position_text(an, float(u[k]))} is "
            f"{abs(float(u[k]) - u0):.6g} {unit} "
            f"of driver travel from the start and {why}: it would be solved by following "
            f"the motion all the way, which mechsolve does up to {limit:.6g} {unit} (about "
            "a second and 130 MB; 9e5 rad took a minute and 6 GB): give a position nearer "
            "the start"
        )
    return out


def _position_text(an: Analysis, u: float) -> str:
    """The driver value ``u`` as given (an angle not wrapped to a turn)."""
    return an.format_u(u) if an.linear else f"driver angle {math.degrees(u):.6g}°"


def _time_there(an: Analysis, instant: Instant) -> float:
    """The time at which the file's driver is at the instant's position, from its start:
    its motion law's (where the law first reaches it), or the travel at its constant
    speed; NaN where it never is there (at rest, behind the start, beyond the law)."""
    if instant.t is not None:
        return float(instant.t)
    d = an.mech.driver
    if d.motion is not None:
        found = _first_time(an.mech, d.motion, instant.u, None)
        return math.nan if found is None else found[0]
    travel = d.direction * (instant.u - an.start_value())
    return travel / abs(d.speed) if d.speed and travel >= 0 else math.nan


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
