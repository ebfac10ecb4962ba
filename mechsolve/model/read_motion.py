"""Reading the driver, its motion law, the sweep, the assembly, outputs and solver
options (see :mod:`mechsolve.model.parse`)."""

from __future__ import annotations

import math
from typing import Any

from mechsolve.base.keyspec import whole
from mechsolve.base.units import plain_float
from mechsolve.model import (
    GROUND,
    MAX_POSITIONS,
    Assembly,
    Driver,
    Limit,
    Outputs,
    SolverOptions,
    Sweep,
    keys,
)
from mechsolve.model.expr import ExprError, Expression, compatible, describe_dim
from mechsolve.model.reader import Reader, _kind
from mechsolve.model.source import KeyPath
from mechsolve.model.validate import suggest

METHODS = keys.METHODS  # solver.method and --method


def read_driver(r: Reader, value: Any, joints) -> Driver:
    path: KeyPath = ("driver",)
    m = r.mapping(value, path, keys.DRIVER.allowed, "'driver'", keys.DRIVER.required)
    jname = r.name(m["joint"], path + ("joint",), "joint")
    joint = next((j for j in joints if j.name == jname), None)
    linear = joint is not None and joint.coordinate == "length"
    d = Driver(jname, where=path)
    if "speed" in m:
        d.speed = r.quantity(m["speed"], path + ("speed",), "speed" if linear else "angular speed")
    if "direction" in m:
        direction = m["direction"]
        if linear:
            ok = {"forward": 1, "backward": -1}
        else:
            ok = {"ccw": 1, "cw": -1, "counterclockwise": 1, "clockwise": -1}
        if direction not in ok:
            raise r.fail(
                path + ("direction",),
                f"direction must be one of {', '.join(ok)}, got {direction!r}",
            )
        d.speed = abs(d.speed) * ok[direction]
        d.sense = ok[direction]
    if "start" in m:
        s = m["start"]
        if isinstance(s, dict):
            sm = r.mapping(
                s,
                path + ("start",),
                keys.LIMIT_START.allowed,
                "a limit start",
                keys.LIMIT_START.required,
            )
            q = r.expression(sm["limit"], path + ("start", "limit"))
            if sm["at"] not in ("min", "max"):
                raise r.fail(path + ("start", "at"), f"'at' must be min or max, got {sm['at']!r}")
            d.start = Limit(q, sm["at"])
        else:
            d.start = r.quantity(s, path + ("start",), "length" if linear else "angle")
    if "line" in m:
        a, b = r.names(m["line"], path + ("line",), "point", 2)
        d.line = (a, b)
    if "motion" in m:
        read_motion(r, m["motion"], d, linear, "direction" in m, "speed" in m, "start" in m)
    return d


def read_motion(
    r: Reader, value: Any, d: Driver, linear: bool, has_dir: bool, has_speed: bool, has_start
) -> None:
    """The driver's motion law (see :mod:`mechsolve.model.motion`): ``accelerate`` (with
    ``from``), ``segments`` (with ``from``), ``table`` (with ``end``) or ``law``."""

    from mechsolve.model.motion import ConstantAcceleration

    path: KeyPath = ("driver", "motion")
    m = r.mapping(value, path, keys.MOTION.allowed, "'motion'")
    kinds = [k for k in ("accelerate", "segments", "table", "law") if k in m]
    if len(kinds) != 1:
        raise r.fail(
            path,
            "give one of accelerate (with from), segments, table or law"
            + (f" (got {', '.join(kinds)})" if kinds else ""),
        )
    kind = kinds[0]
    if has_speed:
        raise r.fail(("driver", "speed"), "a driver with a motion law has no constant speed")
    if isinstance(d.start, Limit):
        raise r.fail(("driver", "start"), "a motion law needs a numeric start")
    speed_kind = "speed" if linear else "angular speed"
    acc_kind = "acceleration" if linear else "angular acceleration"
    for key, allowed in (("from", ("accelerate", "segments")), ("end", ("table",))):
        if key in m and kind not in allowed:
            raise r.fail(path + (key,), f"'{key}' goes with {' or '.join(allowed)}")
    if has_dir and kind != "segments":
        raise r.fail(
            ("driver", "direction"),
            "with this motion law the signs of its values give the direction; "
            "'direction' goes with segments",
        )
    sign = d.sense or 1
    w0 = r.quantity(m["from"], path + ("from",), speed_kind) if "from" in m else 0.0
    if kind == "accelerate":
        acc = r.quantity(m["accelerate"], path + ("accelerate",), acc_kind)
        if acc == 0 and w0 == 0:
            raise r.fail(path, "the driver would not move: give a nonzero accelerate or from")
        law = ConstantAcceleration(start=float(d.start), speed0=w0, acceleration=acc)
    elif kind == "segments":
        law = _read_segments(r, m["segments"], path, d, w0, sign, speed_kind)
    elif kind == "table":
        law = _read_table(r, m, path, linear, has_start)
        d.start = law.start
    else:
        law = read_law(r, m["law"], path + ("law",), has_start, linear)
        d.start = law.start
    d.motion = law
    d.speed = law.nominal_speed()
    d.sense = 1 if d.speed > 0 else -1


def _read_segments(
    r: Reader, segs: Any, path: KeyPath, d: Driver, w0: float, sign: int, speed_kind: str
):
    """``segments``: accelerate, run, decelerate and dwell, each for a duration."""
    from mechsolve.model.motion import Segments

    if not isinstance(segs, list) or not segs:
        raise r.fail(path + ("segments",), "'segments' must be a list of segments")
    if w0 < 0:
        raise r.fail(path + ("from",), "segment speeds are magnitudes; 'direction' sets the sense")
    spec = []
    for k, seg in enumerate(segs):
        sp = path + ("segments", k)
        sm = r.mapping(seg, sp, keys.SEGMENT.allowed, "a segment")
        which = [x for x in ("accelerate", "run", "decelerate", "dwell") if x in sm]
        if len(which) != 1:
            raise r.fail(sp, "a segment is one of accelerate, run, decelerate, dwell: its duration")
        sk = which[0]
        length = r.positive(sm[sk], sp + (sk,), "time")
        target = None
        if "to" in sm:
            if sk not in ("accelerate", "decelerate"):
                raise r.fail(sp + ("to",), f"'to' goes with accelerate or decelerate, not {sk}")
            target = sign * r.positive(sm["to"], sp + ("to",), speed_kind, allow_zero=True)
        elif sk == "accelerate":
            raise r.fail(sp, "'accelerate' needs 'to': the speed to reach")
        spec.append((sk, length, target))
    try:
        return Segments.build(float(d.start), sign * w0, spec)
    except ValueError as exc:
        raise r.fail(path + ("segments",), str(exc)) from None


def _read_table(r: Reader, m: dict, path: KeyPath, linear: bool, has_start) -> Any:
    """``table``: points [time, value] through which a spline runs (``end``: its ends)."""
    import numpy as np

    from mechsolve.model.motion import TableMotion

    unit = "length" if linear else "angle"
    rows = m["table"]
    if not isinstance(rows, list) or len(rows) < 2:
        raise r.fail(path + ("table",), "'table' must list at least 2 points [time, value]")
    ts, us = [], []
    for k, row in enumerate(rows):
        rp = path + ("table", k)
        if not isinstance(row, list) or len(row) != 2:
            raise r.fail(rp, f"a table point is [time, {'position' if linear else 'angle'}]")
        ts.append(r.quantity(row[0], rp + (0,), "time"))
        us.append(r.quantity(row[1], rp + (1,), unit))
    for k in range(1, len(ts)):
        if not ts[k] > ts[k - 1]:
            raise r.fail(
                path + ("table", k, 0),
                f"the times must increase: {ts[k]:.6g} s follows {ts[k - 1]:.6g} s",
            )
    if has_start:
        raise r.fail(("driver", "start"), "the table gives the start (its first point)")
    end = m.get("end", "not-a-knot")
    if end not in ("not-a-knot", "natural", "clamped"):
        raise r.fail(path + ("end",), f"end must be not-a-knot, natural or clamped, got {end!r}")
    return TableMotion(times=np.array(ts), values=np.array(us), end=end)


def _law_kind(e: Expression, kind: str, what: str) -> None:
    """An :class:`ExprError` unless law ``e`` gives ``what``, of the kind ``kind`` (a
    law whose coefficients are bare numbers is SI and passes; one written with units
    must come out in the right kind: "5 N - 0.1 * omega" is no torque)."""
    from mechsolve.base.units import dimension

    got, want = e.dimension(), dimension(kind)
    if not compatible(got, want):
        raise ExprError(f"{e.text!r} is {describe_dim(got)}, but {what} is {describe_dim(want)}")


def read_law(r: Reader, value: Any, path: KeyPath, has_start: bool, linear: bool = False):
    """``u(t)`` as an expression of ``t`` (SI: rad or m), differentiated symbolically."""
    import numpy as np

    from mechsolve.model.motion import ExpressionMotion

    if not isinstance(value, str):
        raise r.fail(
            path, f"'law' must be an expression of t, such as \"0.5 * t^2\", got {value!r}"
        )
    if has_start:
        raise r.fail(("driver", "start"), "the law gives the start (its value at t = 0)")
    try:
        e = Expression(value, variables=("t",))
        _law_kind(e, "length" if linear else "angle", "the driver's position")
        e1 = e.derivative("t")
        e2 = e1.derivative("t")
        law = ExpressionMotion(expr=e, first=e1, second=e2)
    except ExprError as exc:
        raise r.fail(path, str(exc)) from None
    if not np.isfinite(law.start):
        raise r.fail(path, "the law is not finite at t = 0")
    return law


def read_sweep(r: Reader, value: Any, driver: Driver | None, linear: bool) -> Sweep:
    path: KeyPath = ("sweep",)
    if value is None:
        value = {}
    m = r.mapping(value, path, keys.SWEEP.allowed, "'sweep'")
    if driver is not None and driver.motion is not None:
        from mechsolve.model.motion import ConstantAcceleration

        if not (isinstance(driver.motion, ConstantAcceleration) and ("range" in m or "to" in m)):
            return read_time_sweep(r, m, path, driver)
        for key in ("duration", "time_step"):
            if key in m:
                raise r.fail(
                    path + (key,),
                    "give only driver positions (range or to, with step or steps) or a sweep "
                    f"in time (duration, time_step), not both: {key!r} with a range",
                )
    sw = Sweep(where=path)
    kind = "length" if linear else "angle"
    speed = abs(driver.speed) if driver is not None else 1.0
    if speed == 0 and ("duration" in m or "time_step" in m):
        key = "duration" if "duration" in m else "time_step"
        raise r.fail(path + (key,), "a driver at rest (speed 0) has no time: give range and step")
    given = [k for k in ("range", "to", "duration") if k in m]
    if len(given) > 1:
        raise r.fail(path, f"give only one of range, to, duration (got {', '.join(given)})")
    if "range" in m:
        sw.travel = r.positive(m["range"], path + ("range",), kind, allow_zero=True)
    elif "duration" in m:
        sw.travel = r.positive(m["duration"], path + ("duration",), "time", allow_zero=True) * speed
    elif "to" in m:
        if driver is None or isinstance(driver.start, Limit):
            raise r.fail(path + ("to",), "'to' needs a driver with a numeric start; use 'range'")
        end = r.quantity(m["to"], path + ("to",), kind)
        travel = (end - driver.start) * driver.direction
        if travel < 0:
            raise r.fail(
                path + ("to",),
                "the end lies behind the start for the driver's direction of motion "
                "(change 'to', the start, or the driver's direction)",
            )
        sw.travel = travel
    steps = [k for k in ("step", "steps", "time_step") if k in m]
    if len(steps) > 1:
        raise r.fail(path, f"give only one of step, steps, time_step (got {', '.join(steps)})")
    if "step" in m:
        sw.step = r.positive(m["step"], path + ("step",), kind)
    elif "time_step" in m:
        sw.step = r.positive(m["time_step"], path + ("time_step",), "time") * speed
    elif "steps" in m:
        n = whole(m["steps"])
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise r.fail(
                path + ("steps",), f"'steps' must be a whole number of at least 1, got {_kind(n)}"
            )
        if n > MAX_POSITIONS:  # a huge whole number would overflow the division below
            shown = f"{n:,}" if n < 10**15 else "over 1e15"
            raise r.fail(
                path + ("steps",),
                f"the sweep has {shown} positions, more than the {MAX_POSITIONS:,} mechsolve "
                "solves in one run: use a larger step or fewer steps",
            )
        if sw.travel is None:
            sw.travel = 2 * math.pi if not linear else None
        if sw.travel is None:
            raise r.fail(path, "a linear driver needs 'range' or 'to' for its sweep")
        sw.step = sw.travel / n if sw.travel > 0 else 1.0
    return sw


def read_time_sweep(r: Reader, m: dict, path: KeyPath, driver: Driver) -> Sweep:
    """The sweep of a driver with a motion law: a duration (default: the law's own) in
    time steps (``time_step``, or ``steps``: intervals; default 200)."""
    law = driver.motion
    sw = Sweep(where=path)
    for key in ("range", "to", "step"):
        if key in m:
            raise r.fail(
                path + (key,),
                f"a driver with a motion law is swept in time: give duration and time_step "
                f"(or steps), not {key!r}",
            )
    if "duration" in m:
        sw.duration = r.positive(m["duration"], path + ("duration",), "time")
    elif law.duration:
        sw.duration = float(law.duration)
    else:
        raise r.fail(path, "this motion law has no end: give the sweep's duration")
    if law.duration and sw.duration > law.duration * (1 + 1e-12):
        raise r.fail(
            path + ("duration",),
            f"the motion law ends at {law.duration:.6g} s; the sweep asks for {sw.duration:.6g} s",
        )
    if "time_step" in m and "steps" in m:
        raise r.fail(path, "give only one of time_step, steps")
    if "time_step" in m:
        sw.time_step = r.positive(m["time_step"], path + ("time_step",), "time")
    else:
        n = m.get("steps", 200)
        if not isinstance(n, int) or isinstance(n, bool) or n < 1 or n > MAX_POSITIONS:
            raise r.fail(
                path + ("steps",), f"'steps' must be a whole number from 1 to {MAX_POSITIONS:,}"
            )
        sw.time_step = sw.duration / n if sw.duration > 0 else 1.0
    if sw.duration / sw.time_step >= MAX_POSITIONS:
        raise r.fail(
            path,
            f"the sweep has more than the {MAX_POSITIONS:,} positions mechsolve solves in one run",
        )
    return sw


def read_assembly(r: Reader, value: Any) -> Assembly:
    path: KeyPath = ("assembly",)
    if isinstance(value, list):
        value = {"conditions": value}
        lines_path = path
    else:
        lines_path = path + ("conditions",)
    m = r.mapping(value, path, keys.ASSEMBLY.allowed, "'assembly'")
    asm = Assembly(where=path)
    conds = m.get("conditions", [])
    if isinstance(conds, str):
        conds = [conds]
    if not isinstance(conds, list):
        raise r.fail(lines_path, "conditions must be a list of texts such as 'B left of O3 -> A'")
    for i, c in enumerate(conds):
        if isinstance(c, dict) and "sketch" in c:
            raise r.fail(
                lines_path + (i,),
                "a sketch is not a condition: write 'assembly: {conditions: [...], "
                "sketch: {B: [80, 50]}}'",
            )
        e = r.expression(c, lines_path + (i,))
        if not e.is_condition():
            raise r.fail(
                lines_path + (i,), f"{c!r} is not a condition (it needs <, >, 'left of'...)"
            )
        asm.conditions.append(e)
        asm.condition_where.append(lines_path + (i,))
    sketch = m.get("sketch", {})
    if not isinstance(sketch, dict):
        raise r.fail(path + ("sketch",), "'sketch' must map point names to approximate [x, y]")
    asm.sketch = {str(p): r.xy(v, path + ("sketch", p)) for p, v in sketch.items()}
    return asm


def read_outputs(r: Reader, value: Any) -> Outputs:
    path: KeyPath = ("outputs",)
    m = r.mapping(value, path, keys.OUTPUTS.allowed, "'outputs'")
    out = Outputs(where=path)
    if "relative" in m:
        out.relative = read_relative(r, m["relative"], path + ("relative",))
    for key in ("points", "links", "sliders"):
        if key in m:
            v = m[key]
            if v == "all":
                continue
            if v in ("none", None) or v == []:
                setattr(out, key, [])
                continue
            setattr(out, key, r.names(v, path + (key,), key[:-1]))
    if "quantities" in m:
        q = m["quantities"]
        allowed = ("position", "velocity", "acceleration")
        if not isinstance(q, list) or any(x not in allowed for x in q):
            raise r.fail(path + ("quantities",), f"'quantities' is a list of {', '.join(allowed)}")
        out.velocity = "velocity" in q or "acceleration" in q
        out.acceleration = "acceleration" in q
    return out


def read_relative(r: Reader, value: Any, path: KeyPath) -> list[tuple[str, str]]:
    """``relative: [[coupler, crank], rocker/coupler]``: pairs of links (``ground`` too)
    whose relative angle, angular velocity and acceleration are reported (first minus
    second)."""
    if not isinstance(value, list):
        raise r.fail(
            path, f"'relative' is a list of link pairs such as [coupler, crank], got {_kind(value)}"
        )
    links = r.src.data.get("links")
    pool = [GROUND] + (list(links) if isinstance(links, dict) else [])
    out: list[tuple[str, str]] = []
    for i, item in enumerate(value):
        here = path + (i,)
        if isinstance(item, str) and item.count("/") == 1:
            item = [x.strip() for x in item.split("/")]
        if not (
            isinstance(item, list) and len(item) == 2 and all(isinstance(x, str) for x in item)
        ):
            raise r.fail(
                here,
                "a relative angle is a pair of links, [coupler, crank] or 'coupler/crank' "
                f"(the first's angle minus the second's), got {_kind(item)}",
            )
        for ln in item:
            if ln not in pool:
                raise r.fail(here, f"no link named {ln!r}" + suggest(ln, pool))
        if item[0] == item[1]:
            raise r.fail(here, f"the angle of {item[0]!r} relative to itself is always zero")
        pair = (item[0], item[1])
        if pair in out:
            raise r.fail(here, f"the relative angle {pair[0]}/{pair[1]} is listed twice")
        out.append(pair)
    return out


def _numba_found() -> bool:
    """Whether numba can be imported (found, not imported: that costs half a second)."""
    import importlib.util  # (here: only a file that asks for it pays the import)

    try:
        return importlib.util.find_spec("numba") is not None
    except (ImportError, ValueError):
        return False


def read_solver(r: Reader, value: Any) -> SolverOptions:
    path: KeyPath = ("solver",)
    m = r.mapping(value, path, keys.SOLVER.allowed, "'solver'")
    opts = SolverOptions(where=path)
    if "method" in m:
        if m["method"] not in METHODS:
            raise r.fail(
                path + ("method",),
                f"method is {', '.join(repr(x) for x in METHODS)}, got {m['method']!r}",
            )
        opts.method = m["method"]
    if "tolerance" in m:
        t = m["tolerance"]
        try:
            t = None if isinstance(t, bool) else plain_float(t) if isinstance(t, str) else float(t)
        except (TypeError, ValueError, OverflowError):  # a huge whole number overflows
            t = None
        if t is None:
            raise r.fail(path + ("tolerance",), f"expected a number, got {_kind(m['tolerance'])}")
        if not (0 < t < 1e-2):
            raise r.fail(path + ("tolerance",), "the tolerance must be between 0 and 0.01")
        opts.tolerance = t
    if "max_iterations" in m:
        n = whole(m["max_iterations"])
        if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= 1000:
            raise r.fail(path + ("max_iterations",), "max_iterations is a whole number 1..1000")
        opts.max_iterations = n
    if "compiled" in m:
        opts.compiled = r.flag(m["compiled"], path + ("compiled",))
        if opts.compiled and not _numba_found():
            raise r.fail(
                path + ("compiled",),
                "the compiled Newton sweep needs numba, which is not installed: "
                "pip install 'mechsolve[fast]', or remove this key",
            )
    return opts
