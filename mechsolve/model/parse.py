"""Turn the plain data of a mechanism file into a validated :class:`Mechanism`.

The file format is documented in the README. Each section is read by one function;
every mistake raises :class:`~mechsolve.errors.InputError` with the file, the key path
and the line. Unknown keys get a did-you-mean suggestion.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..expr import ExprError, Expression
from ..units import UnitError, parse_quantity, parse_unit
from . import (
    GROUND,
    Assembly,
    Driver,
    Limit,
    Link,
    Mechanism,
    Outputs,
    PinJoint,
    SliderJoint,
    SolverOptions,
    Sweep,
)
from .source import KeyPath, Source, load_file, load_text
from .validate import suggest

TOP_KEYS = (
    "name",
    "description",
    "units",
    "ground",
    "links",
    "joints",
    "driver",
    "sweep",
    "assembly",
    "outputs",
    "solver",
    "variants",
)


class Reader:
    """Reads values out of a :class:`Source` with unit conversion and located errors."""

    def __init__(self, source: Source) -> None:
        self.src = source
        self.length_unit = "m"
        self.angle_unit = "deg"

    def fail(self, path: KeyPath, message: str) -> InputError:
        return self.src.error(path, message)

    def mapping(
        self,
        value: Any,
        path: KeyPath,
        allowed: tuple[str, ...],
        what: str,
        required: tuple[str, ...] = (),
    ) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(path, f"{what} must be a mapping (key: value), got {_kind(value)}")
        for key in value:
            if key not in allowed:
                raise self.fail(
                    path + (key,),
                    f"unknown key {key!r} in {what}"
                    + suggest(key, list(allowed))
                    + f"; allowed: {', '.join(allowed)}",
                )
        for key in required:
            if key not in value:
                raise self.fail(path, f"{what} needs the key {key!r}")
        return value

    def quantity(self, value: Any, path: KeyPath, kind: str) -> float:
        default = {"length": self.length_unit, "angle": self.angle_unit}.get(kind)
        try:
            return parse_quantity(value, kind, default)
        except UnitError as exc:
            raise self.fail(path, str(exc)) from None

    def positive(self, value: Any, path: KeyPath, kind: str, allow_zero: bool = False) -> float:
        x = self.quantity(value, path, kind)
        if x < 0 or (x == 0 and not allow_zero):
            raise self.fail(
                path, f"must be {'zero or ' if allow_zero else ''}positive, got {value!r}"
            )
        return x

    def xy(self, value: Any, path: KeyPath) -> tuple[float, float]:
        if isinstance(value, str) and "," in value:  # "(1, 2) mm" or "1, 2"
            text = value.strip()
            unit = ""
            if ")" in text:
                text, unit = text.rsplit(")", 1)
                text = text.lstrip("(")
            parts = [
                p.strip() + (" " + unit.strip() if unit.strip() else "") for p in text.split(",")
            ]
            value = parts
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(path, f"expected coordinates [x, y], got {_kind(value)}")
        return (
            self.quantity(value[0], path + (0,), "length"),
            self.quantity(value[1], path + (1,), "length"),
        )

    def name(self, value: Any, path: KeyPath, what: str) -> str:
        if not isinstance(value, str):
            raise self.fail(path, f"expected the name of a {what}, got {_kind(value)}")
        return value

    def names(self, value: Any, path: KeyPath, what: str, count: int | None = None) -> list[str]:
        if not isinstance(value, list) or (count is not None and len(value) != count):
            n = f"{count} " if count else ""
            raise self.fail(path, f"expected a list of {n}{what} names, got {_kind(value)}")
        return [self.name(v, path + (i,), what) for i, v in enumerate(value)]

    def expression(self, value: Any, path: KeyPath) -> Expression:
        try:
            return Expression(value)
        except ExprError as exc:
            raise self.fail(path, f"cannot read the condition: {exc}") from None

    def flag(self, value: Any, path: KeyPath) -> bool:
        if not isinstance(value, bool):
            raise self.fail(path, f"expected true or false, got {_kind(value)}")
        return value


def _kind(value: Any) -> str:
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if value is None:
        return "nothing (null)"
    return repr(value)


# --- sections ----------------------------------------------------------------------


def read_units(r: Reader, value: Any) -> None:
    m = r.mapping(value, ("units",), ("length", "angle"), "'units'")
    for key, kind in (("length", "length"), ("angle", "angle")):
        if key in m:
            text = m[key]
            try:
                u = parse_unit(str(text))
            except UnitError as exc:
                raise r.fail(("units", key), str(exc)) from None
            want = (1, 0, 0, 0) if kind == "length" else (0, 0, 0, 1)
            if u.dim != want:
                raise r.fail(("units", key), f"{text!r} is not a unit of {kind}")
            setattr(r, f"{key}_unit", str(text))


def read_ground(r: Reader, value: Any) -> dict[str, tuple[float, float]]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise r.fail(("ground",), "'ground' must map point names to coordinates [x, y]")
    return {str(p): r.xy(v, ("ground", p)) for p, v in value.items()}


def read_point(
    r: Reader, value: Any, path: KeyPath, known: dict[str, tuple[float, float]]
) -> tuple[float, float] | None:
    """Local coordinates of a point; ``None`` if it refers to a point not read yet."""
    if not isinstance(value, dict):
        return r.xy(value, path)
    m = r.mapping(value, path, ("length", "angle", "from", "ref"), "a point", ("length", "angle"))
    length = r.positive(m["length"], path + ("length",), "length", allow_zero=False)
    angle = r.quantity(m["angle"], path + ("angle",), "angle")
    origin = (0.0, 0.0)
    if "from" in m:
        f = r.name(m["from"], path + ("from",), "point")
        if f not in known:
            return None
        origin = known[f]
    ref_angle = 0.0
    if "ref" in m:
        ref = r.names(m["ref"], path + ("ref",), "point", 2)
        if any(p not in known for p in ref):
            return None
        (x0, y0), (x1, y1) = known[ref[0]], known[ref[1]]
        if x0 == x1 and y0 == y1:
            raise r.fail(
                path + ("ref",), f"the reference line {ref[0]} -> {ref[1]} has zero length"
            )
        ref_angle = math.atan2(y1 - y0, x1 - x0)
    a = ref_angle + angle
    return (origin[0] + length * math.cos(a), origin[1] + length * math.sin(a))


def read_link(r: Reader, name: str, value: Any) -> Link:
    path: KeyPath = ("links", name)
    m = r.mapping(
        value, path, ("points", "mass", "com", "inertia", "description"), f"link {name!r}"
    )
    if "points" not in m:
        raise r.fail(path, f"link {name!r} needs 'points': its named points in its own frame")
    raw = m["points"]
    if not isinstance(raw, dict) or not raw:
        raise r.fail(path + ("points",), "'points' must map point names to coordinates")
    points: dict[str, tuple[float, float]] = {}
    pending = dict(raw)
    while pending:
        progress = False
        for p, v in list(pending.items()):
            xy = read_point(r, v, path + ("points", p), points)
            if xy is not None:
                points[p] = xy
                del pending[p]
                progress = True
        if not progress:
            p = next(iter(pending))
            v = pending[p]
            refs = [v.get("from")] + list(v.get("ref") or [])
            missing = [x for x in refs if x is not None and x not in raw]
            if missing:
                raise r.fail(
                    path + ("points", p),
                    f"point {p!r} is placed from point {missing[0]!r}, which link {name!r} does "
                    "not have" + suggest(str(missing[0]), list(raw)),
                )
            raise r.fail(path + ("points", p), "points are placed from each other in a circle")
    # keep the file's order
    points = {p: points[p] for p in raw}
    link = Link(name, points, where=path)
    if "mass" in m:
        link.mass = r.quantity(m["mass"], path + ("mass",), "mass")
    if "inertia" in m:
        link.inertia = r.quantity(m["inertia"], path + ("inertia",), "moment of inertia")
    if "com" in m:
        c = m["com"]
        if isinstance(c, str) and c in points:
            link.com = points[c]
        elif isinstance(c, str) and not any(ch.isdigit() for ch in c.split()[0][:1]):
            raise r.fail(
                path + ("com",),
                f"link {name!r} has no point {c!r} for its centre of mass"
                + suggest(c, list(points)),
            )
        else:
            link.com = r.xy(c, path + ("com",))
    return link


def read_links(r: Reader, value: Any) -> list[Link]:
    if not isinstance(value, dict) or not value:
        raise r.fail(("links",), "'links' must map link names to their points")
    return [read_link(r, str(n), v) for n, v in value.items()]


def read_line(
    r: Reader, value: Any, path: KeyPath, guide: str, points: dict[str, tuple[float, float]]
) -> tuple[tuple[float, float], float]:
    """A guide line: ``[P, Q]`` (two points of the guide), ``{through, angle}`` or
    ``{offset, angle}``."""
    where = "the ground" if guide == GROUND else f"link {guide!r}"
    if isinstance(value, list) and len(value) == 2 and all(isinstance(v, str) for v in value):
        if not any("," in v for v in value) and all(v in points for v in value):
            (x0, y0), (x1, y1) = points[value[0]], points[value[1]]
            if x0 == x1 and y0 == y1:
                raise r.fail(path, f"the line {value[0]} -> {value[1]} has zero length")
            return (x0, y0), math.atan2(y1 - y0, x1 - x0)
        bad = [v for v in value if v not in points]
        if bad and not any(ch.isdigit() for ch in bad[0][:1]) and " " not in bad[0]:
            raise r.fail(path, f"{where} has no point {bad[0]!r}" + suggest(bad[0], list(points)))
    m = r.mapping(
        value, path, ("through", "angle", "offset"), "a guide line ([P, Q] or {through, angle})"
    )
    angle = r.quantity(m.get("angle", 0.0), path + ("angle",), "angle")
    if "through" in m and "offset" in m:
        raise r.fail(path, "give either 'through' or 'offset', not both")
    if "through" in m:
        t = m["through"]
        if isinstance(t, str) and t in points:
            origin = points[t]
        elif isinstance(t, str) and "," not in t:
            raise r.fail(
                path + ("through",), f"{where} has no point {t!r}" + suggest(t, list(points))
            )
        else:
            origin = r.xy(t, path + ("through",))
    else:
        e = r.quantity(m.get("offset", 0.0), path + ("offset",), "length")
        origin = (-e * math.sin(angle), e * math.cos(angle))
    return origin, angle


def read_joint(r: Reader, name: str, value: Any, mech_points) -> PinJoint | SliderJoint:
    path: KeyPath = ("joints", name)
    if isinstance(value, list):  # shorthand: A: [crank, coupler]
        a, b = r.names(value, path, "link", 2)
        return PinJoint(name, a, b, name, where=path)
    m = r.mapping(
        value,
        path,
        ("revolute", "slider", "point", "line", "block_angle", "description"),
        f"joint {name!r}",
    )
    kinds = [k for k in ("revolute", "slider") if k in m]
    if len(kinds) != 1:
        raise r.fail(
            path,
            f"joint {name!r} needs exactly one of 'revolute: [link, link]' or "
            "'slider: [guide, block]'",
        )
    kind = kinds[0]
    a, b = r.names(m[kind], path + (kind,), "link", 2)
    point = r.name(m.get("point", name), path + ("point",), "point")
    if kind == "revolute":
        for key in ("line", "block_angle"):
            if key in m:
                raise r.fail(path + (key,), f"{key!r} applies to a slider, not a revolute joint")
        return PinJoint(name, a, b, point, where=path)
    if "line" not in m:
        raise r.fail(path, f"slider {name!r} needs 'line': the guide line on {a!r}")
    guide_points = mech_points.get(a)
    if guide_points is None:
        raise r.fail(path + ("slider",), f"no link named {a!r}" + suggest(a, list(mech_points)))
    origin, angle = read_line(r, m["line"], path + ("line",), a, guide_points)
    block_angle = r.quantity(m.get("block_angle", 0.0), path + ("block_angle",), "angle")
    return SliderJoint(name, a, b, point, origin, angle, block_angle, where=path)


def read_joints(r: Reader, value: Any, ground, links) -> list[PinJoint | SliderJoint]:
    if not isinstance(value, dict) or not value:
        raise r.fail(("joints",), "'joints' must map joint names to their definitions")
    pts = {GROUND: ground}
    pts.update({lk.name: lk.points for lk in links})
    return [read_joint(r, str(n), v, pts) for n, v in value.items()]


def read_driver(r: Reader, value: Any, joints) -> Driver:
    path: KeyPath = ("driver",)
    m = r.mapping(
        value,
        path,
        ("joint", "speed", "direction", "start", "line", "description"),
        "'driver'",
        ("joint",),
    )
    jname = r.name(m["joint"], path + ("joint",), "joint")
    joint = next((j for j in joints if j.name == jname), None)
    linear = isinstance(joint, SliderJoint)
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
    if "start" in m:
        s = m["start"]
        if isinstance(s, dict):
            sm = r.mapping(s, path + ("start",), ("limit", "at"), "a limit start", ("limit", "at"))
            q = r.expression(sm["limit"], path + ("start", "limit"))
            if sm["at"] not in ("min", "max"):
                raise r.fail(path + ("start", "at"), f"'at' must be min or max, got {sm['at']!r}")
            d.start = Limit(q, sm["at"])
        else:
            d.start = r.quantity(s, path + ("start",), "length" if linear else "angle")
    if "line" in m:
        a, b = r.names(m["line"], path + ("line",), "point", 2)
        d.line = (a, b)
    return d


def read_sweep(r: Reader, value: Any, driver: Driver | None, linear: bool) -> Sweep:
    path: KeyPath = ("sweep",)
    if value is None:
        value = {}
    m = r.mapping(value, path, ("range", "to", "step", "steps", "duration", "time_step"), "'sweep'")
    sw = Sweep(where=path)
    kind = "length" if linear else "angle"
    speed = abs(driver.speed) if driver is not None else 1.0
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
        travel = (end - driver.start) * (1 if driver.speed > 0 else -1)
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
        n = m["steps"]
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise r.fail(
                path + ("steps",), f"'steps' must be a whole number of at least 1, got {n!r}"
            )
        if sw.travel is None:
            sw.travel = 2 * math.pi if not linear else None
        if sw.travel is None:
            raise r.fail(path, "a linear driver needs 'range' or 'to' for its sweep")
        sw.step = sw.travel / n if sw.travel > 0 else 1.0
    return sw


def read_assembly(r: Reader, value: Any) -> Assembly:
    path: KeyPath = ("assembly",)
    if isinstance(value, list):
        value = {"conditions": value}
        lines_path = path
    else:
        lines_path = path + ("conditions",)
    m = r.mapping(value, path, ("conditions", "sketch"), "'assembly'")
    asm = Assembly(where=path)
    conds = m.get("conditions", [])
    if isinstance(conds, str):
        conds = [conds]
    if not isinstance(conds, list):
        raise r.fail(lines_path, "conditions must be a list of texts such as 'B left of O3 -> A'")
    for i, c in enumerate(conds):
        e = r.expression(c, lines_path + (i,))
        if not e.is_condition():
            raise r.fail(
                lines_path + (i,), f"{c!r} is not a condition (it needs <, >, 'left of'...)"
            )
        asm.conditions.append(e)
    sketch = m.get("sketch", {})
    if not isinstance(sketch, dict):
        raise r.fail(path + ("sketch",), "'sketch' must map point names to approximate [x, y]")
    asm.sketch = {str(p): r.xy(v, path + ("sketch", p)) for p, v in sketch.items()}
    return asm


def read_outputs(r: Reader, value: Any) -> Outputs:
    path: KeyPath = ("outputs",)
    m = r.mapping(value, path, ("points", "links", "sliders", "quantities"), "'outputs'")
    out = Outputs(where=path)
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


def read_solver(r: Reader, value: Any) -> SolverOptions:
    path: KeyPath = ("solver",)
    m = r.mapping(value, path, ("method", "tolerance", "max_iterations"), "'solver'")
    opts = SolverOptions(where=path)
    if "method" in m:
        if m["method"] not in ("auto", "newton"):
            raise r.fail(path + ("method",), f"method is 'auto' or 'newton', got {m['method']!r}")
        opts.method = m["method"]
    if "tolerance" in m:
        t = m["tolerance"]
        try:
            t = float(t)
        except (TypeError, ValueError):
            raise r.fail(path + ("tolerance",), f"expected a number, got {t!r}") from None
        if not (0 < t < 1e-2):
            raise r.fail(path + ("tolerance",), "the tolerance must be between 0 and 0.01")
        opts.tolerance = t
    if "max_iterations" in m:
        n = m["max_iterations"]
        if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= 1000:
            raise r.fail(path + ("max_iterations",), "max_iterations is a whole number 1..1000")
        opts.max_iterations = n
    return opts


def from_source(src: Source, variant: str | None = None) -> Mechanism:
    """Build and validate a :class:`Mechanism` from a parsed file."""
    if variant is not None:
        src = src.with_variant(variant)
    r = Reader(src)
    data = src.data
    for key in data:
        if key not in TOP_KEYS:
            raise src.error(
                (key,),
                f"unknown section {key!r}"
                + suggest(key, list(TOP_KEYS))
                + f"; sections are: {', '.join(TOP_KEYS)}",
            )
    if "variants" in data and variant is None and not isinstance(data["variants"], dict):
        raise src.error(("variants",), "'variants' must map variant names to overrides")
    if "units" in data:
        read_units(r, data["units"])
    for key in ("links", "joints"):
        if key not in data:
            raise src.error((), f"the file has no '{key}' section")
    ground = read_ground(r, data.get("ground"))
    links = read_links(r, data["links"])
    joints = read_joints(r, data["joints"], ground, links)
    driver = read_driver(r, data["driver"], joints) if "driver" in data else None
    linear = driver is not None and any(
        isinstance(j, SliderJoint) and j.name == driver.joint for j in joints
    )
    name = data.get("name", Path(src.file).stem if src.file else "mechanism")
    if not isinstance(name, str):
        raise src.error(("name",), "the name must be text")
    mech = Mechanism(
        name=name,
        ground=ground,
        links=links,
        joints=joints,
        driver=driver,
        sweep=read_sweep(r, data.get("sweep"), driver, linear),
        assembly=read_assembly(r, data["assembly"]) if "assembly" in data else Assembly(),
        outputs=read_outputs(r, data["outputs"]) if "outputs" in data else Outputs(),
        solver=read_solver(r, data["solver"]) if "solver" in data else SolverOptions(),
        length_unit=r.length_unit,
        source=src,
    )
    return mech.validate()


def load(path: str | Path, variant: str | None = None) -> Mechanism:
    """Read a mechanism file and return the validated :class:`Mechanism`.

    Parameters
    ----------
    path
        The YAML file.
    variant
        The name of an entry of the file's ``variants`` section to apply.
    """
    return from_source(load_file(path), variant)


def loads(text: str, variant: str | None = None, file: str | None = None) -> Mechanism:
    """Like :func:`load`, from YAML text."""
    return from_source(load_text(text, file), variant)


def variants(path: str | Path) -> list[str]:
    """Names of the variants a mechanism file defines."""
    src = load_file(path)
    v = src.data.get("variants")
    return list(v) if isinstance(v, dict) else []
