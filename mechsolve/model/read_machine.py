"""Reading requirements, the motor, the flywheel, the simulation, instants and the
torque problems of `mechsolve flywheel` (see :mod:`mechsolve.model.parse`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mechsolve.base.errors import InputError
from mechsolve.base.units import plain_float
from mechsolve.model import Driver, keys
from mechsolve.model.expr import ExprError, Expression
from mechsolve.model.expr.poles import first_pole
from mechsolve.model.read_geometry import read_units
from mechsolve.model.read_motion import _law_kind
from mechsolve.model.reader import Reader
from mechsolve.model.source import KeyPath, Source
from mechsolve.model.validate import suggest


def read_requirements(r: Reader, value: Any, linear: bool | None = None) -> list:
    """``requirements: {name: "max(abs(input.torque)) <= 300 kN m", ...}`` (see
    :mod:`mechsolve.results.requirements`); ``linear``: the driver is a slider."""
    from mechsolve.model.expr import DimensionError
    from mechsolve.model.requirement import parse_requirement

    path: KeyPath = ("requirements",)
    if not isinstance(value, dict) or not value:
        raise r.fail(
            path,
            "'requirements' maps names to checks, e.g. "
            "{peak torque: 'max(abs(input.torque)) <= 300 kN m'}",
        )
    out = []
    for name, text in value.items():
        try:
            out.append(parse_requirement(str(name), text, linear))
        except DimensionError as exc:
            raise r.fail(path + (name,), str(exc)) from None
        except ExprError as exc:
            raise r.fail(path + (name,), f"cannot read the requirement: {exc}") from None
    return out


def read_motor(
    r: Reader, value: Any, driver: Driver | None, linear: bool, path: KeyPath = ("motor",)
):
    """``motor: {stall: 50 N m, slope: 1.25 N m s}``, ``{table: [[speed, torque], ...]}``
    or ``{torque: "50 - 1.25 * omega"}`` (an expression of omega (or v) and t)."""
    import numpy as np

    from mechsolve.model.machine import Motor

    m = r.mapping(value, path, keys.MOTOR.allowed, "'motor'")
    if driver is None:
        raise r.fail(path, "a motor drives the driver joint: add a 'driver' section")
    if "joint" in m:
        j = r.name(m["joint"], path + ("joint",), "joint")
        if j != driver.joint:
            raise r.fail(
                path + ("joint",),
                f"the motor drives the driver joint {driver.joint!r}, not {j!r} "
                "(move the driver to that joint)",
            )
    effort = "force" if linear else "torque"
    speed = "speed" if linear else "angular speed"
    slope = "damping" if linear else "rotational damping"
    kinds = [k for k in ("stall", "table", "torque", "force") if k in m]
    if len(kinds) != 1 or (kinds == ["stall"] and "slope" not in m):
        raise r.fail(path, "give stall and slope (M = stall - slope * omega), table, or torque")
    if "stall" in m:
        return Motor(
            "linear",
            stall=r.quantity(m["stall"], path + ("stall",), effort),
            slope=r.quantity(m["slope"], path + ("slope",), slope),
        )
    if "table" in m:
        rows = m["table"]
        if not isinstance(rows, list) or len(rows) < 2:
            raise r.fail(path + ("table",), "'table' lists at least 2 points [speed, torque]")
        ws, ts = [], []
        for k, row in enumerate(rows):
            if not isinstance(row, list) or len(row) != 2:
                raise r.fail(path + ("table", k), "a point is [speed, torque]")
            ws.append(r.quantity(row[0], path + ("table", k, 0), speed))
            ts.append(r.quantity(row[1], path + ("table", k, 1), effort))
        if any(not b > a for a, b in zip(ws, ws[1:])):
            raise r.fail(path + ("table",), "the speeds must increase")
        return Motor("table", speeds=np.array(ws), torques=np.array(ts))
    key = kinds[0]
    text = m[key]
    if not isinstance(text, str):
        raise r.fail(
            path + (key,), f"'{key}' is an expression of omega and t, e.g. \"50 - 1.25 * omega\""
        )
    try:
        e = Expression(text, variables=("omega", "v", "t"))
        _law_kind(e, effort, f"a motor's {effort}")
    except (ExprError, TypeError) as exc:
        raise r.fail(path + (key,), str(exc)) from None
    return Motor("law", expr=e, text=text)


def read_motors(r: Reader, value: Any, joints) -> dict:
    """``motors: {left: {joint: O, stall: 5 N m, slope: 0.1 N m s}, ...}``: several motors,
    each on its joint (the general simulation path)."""
    path: KeyPath = ("motors",)
    if not isinstance(value, dict) or not value:
        raise r.fail(path, "'motors' maps names to motors, e.g. {left: {joint: O, stall: ...}}")
    by_name = {j.name: j for j in joints}
    out = {}
    for name, m in value.items():
        mp = path + (name,)
        if not isinstance(m, dict) or "joint" not in m:
            raise r.fail(mp, f"motor {name!r} needs 'joint': the joint it drives")
        j = r.name(m["joint"], mp + ("joint",), "joint")
        joint = by_name.get(j)
        if joint is None or joint.coordinate is None:
            raise r.fail(
                mp + ("joint",),
                f"no joint {j!r} with a coordinate to drive" + suggest(j, list(by_name)),
            )
        linear = joint.coordinate == "length"
        out[str(name)] = (j, read_motor(r, m, Driver(joint=j), linear, mp))
    return out


def read_flywheel(r: Reader, value: Any, links):
    from mechsolve.model.machine import Flywheel

    path: KeyPath = ("flywheel",)
    m = r.mapping(value, path, keys.FLYWHEEL.allowed, "'flywheel'", keys.FLYWHEEL.required)
    name = r.name(m["on"], path + ("on",), "link")
    if name not in {lk.name for lk in links}:
        raise r.fail(
            path + ("on",), f"no link named {name!r}" + suggest(name, [lk.name for lk in links])
        )
    return Flywheel(name, r.positive(m["inertia"], path + ("inertia",), "moment of inertia"))


def read_simulation(r: Reader, value: Any, linear: bool):
    from mechsolve.model.machine import INTEGRATORS, Simulation

    path: KeyPath = ("simulate",)
    m = r.mapping(value, path, keys.SIMULATE.allowed, "'simulate'", keys.SIMULATE.required)
    sim = Simulation(duration=r.positive(m["duration"], path + ("duration",), "time"), where=path)
    if "method" in m:
        if m["method"] not in INTEGRATORS:
            raise r.fail(
                path + ("method",),
                f"unknown integrator {m['method']!r}: one of {', '.join(INTEGRATORS)}",
            )
        sim.method = m["method"]
    if "step" in m:
        sim.step = r.positive(m["step"], path + ("step",), "time")
        if sim.step > sim.duration:
            raise r.fail(path + ("step",), "the step is longer than the duration")
    elif sim.method == "rk4":
        raise r.fail(path, "rk4 integrates with a fixed step: give 'step'")
    _read_tolerances(r, m, path, sim)
    if "from" in m:
        sim.speed0_given = True
        f = m["from"]
        sim.speed0 = (
            0.0
            if f == "rest"
            else r.quantity(f, path + ("from",), "speed" if linear else "angular speed")
        )
    if "formulation" in m:
        if m["formulation"] not in ("reduced", "multibody"):
            raise r.fail(
                path + ("formulation",),
                f"unknown formulation {m['formulation']!r}: reduced or multibody",
            )
        sim.formulation = m["formulation"]
    if "tolerance" in m:
        sim.tolerance = r.positive(m["tolerance"], path + ("tolerance",), "length")
    _read_pose_and_rates(r, m, path, sim)
    if "stop when" in m:
        sim.stop = r.expression(m["stop when"], path + ("stop when",))
        if not sim.stop.is_condition():
            raise r.fail(
                path + ("stop when",),
                f"{m['stop when']!r} is not a condition (use <, >, and...), e.g. bar.angle <= 0",
            )
    if "singular" in m:
        if m["singular"] not in ("pass", "stop", "keep branch"):
            raise r.fail(
                path + ("singular",),
                f"unknown choice {m['singular']!r}: pass (go through a singular position), "
                "stop (end the run there) or keep branch (end it where a branch would change)",
            )
        sim.singular = m["singular"]
    if "revolutions" in m:
        sim.revolutions = r.positive(m["revolutions"], path + ("revolutions",), "dimensionless")
    if "steady" in m:
        x = m["steady"]
        if isinstance(x, str):
            try:
                x = plain_float(x.strip().rstrip("%")) / (100 if x.strip().endswith("%") else 1)
            except ValueError:
                pass
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not 0 < x < 1:
            raise r.fail(
                path + ("steady",),
                "steady: the largest change of a revolution's mean speed from the one "
                "before, as a fraction between 0 and 1 (e.g. 1e-4 or 0.01 %)",
            )
        sim.steady = float(x)
    return sim


def _read_tolerances(r: Reader, m: dict, path: KeyPath, sim) -> None:
    """``rtol`` and ``atol``: numbers between 0 and 1 (or text such as "1e-10")."""
    for key in ("rtol", "atol"):
        if key in m:
            x = m[key]
            if isinstance(x, str):  # quoted: "1e-10"
                try:
                    x = plain_float(x)
                except ValueError:
                    pass
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not 0 < x < 1:
                big = isinstance(x, (int, float)) and not isinstance(x, bool) and abs(x) >= 1
                raise r.fail(
                    path + (key,),
                    f"{key} must be a number between 0 and 1"
                    + (f" ({x:g} is too large in size)" if big else ""),
                )
            setattr(sim, key, float(x))


def _read_pose_and_rates(r: Reader, m: dict, path: KeyPath, sim) -> None:
    """``pose`` and ``rates``: joint coordinates and their initial rates, each an angle or
    a length (a revolute's or a slider's: the joint decides which it needs)."""
    if "pose" in m:
        pose = m["pose"]
        if not isinstance(pose, dict) or not pose:
            raise r.fail(
                path + ("pose",), "'pose' maps joints to their coordinates, e.g. {O: 30 deg}"
            )
        for j, v in pose.items():
            jp = path + ("pose", j)
            try:  # a revolute's angle, or (with a length unit) a slider's travel
                sim.pose[str(j)] = (r.quantity(v, jp, "angle"), "angle", jp)
            except InputError:
                sim.pose[str(j)] = (r.quantity(v, jp, "length"), "length", jp)
    if "rates" in m:
        rates = m["rates"]
        if not isinstance(rates, dict) or not rates:
            raise r.fail(
                path + ("rates",), "'rates' maps joints to their initial rates, e.g. {O: 2 rad/s}"
            )
        for j, v in rates.items():
            jp = path + ("rates", j)
            try:  # a revolute's rate, or (m/s) a slider's: the joint decides which it needs
                sim.rates[str(j)] = (r.quantity(v, jp, "angular speed"), "angular speed", jp)
            except InputError:
                sim.rates[str(j)] = (r.quantity(v, jp, "speed"), "speed", jp)


def read_instants(r: Reader, value: Any, linear: bool) -> list[tuple[float, float, float, str]]:
    """``instants: [{theta: 30 deg, omega: 10 rad/s, alpha: 5 rad/s^2}, ...]`` (``s``,
    ``v``, ``a`` for a linear driver; the acceleration defaults to 0)."""
    path: KeyPath = ("instants",)
    if not isinstance(value, list) or not value:
        raise r.fail(path, "'instants' must be a list of driver states")
    sec = keys.INSTANT_LINEAR if linear else keys.INSTANT
    kinds = (
        ("length", "speed", "acceleration")
        if linear
        else ("angle", "angular speed", "angular acceleration")
    )
    out = []
    for k, item in enumerate(value):
        ip = path + (k,)
        m = r.mapping(item, ip, sec.allowed, "an instant", sec.required)
        vals = [
            r.quantity(m[key], ip + (key,), kind) if key in m else 0.0
            for key, kind in zip(sec.allowed, kinds)
        ]
        label = ", ".join(f"{key}={m[key]}" for key in sec.allowed if key in m)
        out.append((vals[0], vals[1], vals[2], label))
    return out


TORQUE_KEYS = keys.TORQUE_PROBLEM.allowed


def is_torque_problem(src: Source) -> bool:
    """A file that states a flywheel problem by its torque curve (no links)."""
    return isinstance(src.data, dict) and "torque" in src.data and "links" not in src.data


def read_torque_problem(src: Source) -> dict:
    """A flywheel problem as textbooks state it::

        name: four-stroke engine
        torque: {table: [[0 deg, 0 N m], [30 deg, 300 N m], ...], cycle: 720 deg}
        # or torque: {law: "200 + 150 * sin(2 * angle)", cycle: 360 deg}
        resisting: mean              # or a constant torque, e.g. 180 N m
        speed: 1500 rpm              # the mean speed (omega_max + omega_min) / 2
        delta: 1/80                  # optional: --delta on the command line wins

    The table's first angle starts the cycle; a table ends where the cycle does (its last
    point is taken as the first one again when it stops short)."""
    import numpy as np

    r = Reader(src)
    data = src.data
    m = r.mapping(data, (), TORQUE_KEYS, "a torque problem", keys.TORQUE_PROBLEM.required)
    if "units" in data:
        read_units(r, data["units"])
    path: KeyPath = ("torque",)
    t = r.mapping(m["torque"], path, keys.TORQUE_CURVE.allowed, "'torque'")
    cycle = r.positive(t.get("cycle", "360 deg"), path + ("cycle",), "angle")
    if ("table" in t) == ("law" in t):
        raise r.fail(path, "give the torque as a table of [angle, torque] points or as a law")
    if "table" in t:
        rows = t["table"]
        if not isinstance(rows, list) or len(rows) < 3:
            raise r.fail(path + ("table",), "'table' lists at least 3 points [angle, torque]")
        xs, ts = [], []
        for k, row in enumerate(rows):
            if not isinstance(row, list) or len(row) != 2:
                raise r.fail(path + ("table", k), "a point is [angle, torque]")
            xs.append(r.quantity(row[0], path + ("table", k, 0), "angle"))
            ts.append(r.quantity(row[1], path + ("table", k, 1), "torque"))
        x, T = np.array(xs), np.array(ts)
        if np.any(np.diff(x) <= 0):
            raise r.fail(path + ("table",), "the angles must increase")
        end = x[0] + cycle
        if x[-1] > end * (1 + 1e-12):
            raise r.fail(path + ("table",), "the table runs past the cycle")
        if x[-1] < end - 1e-12:  # close the cycle with its first point
            x, T = np.r_[x, end], np.r_[T, T[0]]
    else:
        if not isinstance(t["law"], str):
            raise r.fail(path + ("law",), "'law' is an expression of angle (rad)")
        try:
            e = Expression(t["law"], variables=("angle",))
            _law_kind(e, "torque", "the torque curve")
            x = np.linspace(0.0, cycle, 36001)
            T = np.broadcast_to(np.asarray(e.evaluate_at({"angle": x}), float), x.shape)
        except ExprError as exc:
            raise r.fail(path + ("law",), str(exc)) from None
        if not np.all(np.isfinite(T)):
            raise r.fail(path + ("law",), "the law is not finite over the cycle")
        pole = first_pole(e, "angle", x)
        if pole is not None:  # finite samples on both sides of a pole
            raise r.fail(path + ("law",), f"the law grows without bound at angle = {pole:.6g} rad")
    res = m.get("resisting", "mean")
    resisting = None if res == "mean" else r.quantity(res, ("resisting",), "torque")
    delta = None
    if "delta" in m:
        d = m["delta"]
        try:
            num, _, den = str(d).partition("/")
            delta = plain_float(num) / plain_float(den) if den else plain_float(num)
        except (ValueError, ZeroDivisionError):
            raise r.fail(
                ("delta",), f"expected a number such as 0.025 or 1/40, got {d!r}"
            ) from None
    return {
        "name": m.get("name", Path(src.file).stem if src.file else "torque curve"),
        "angles": x,
        "torque": np.asarray(T, float),
        "speed": r.positive(m["speed"], ("speed",), "angular speed"),
        "resisting": resisting,
        "delta": delta,
    }
