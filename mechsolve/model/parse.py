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
from ..expr import ExprError, Expression, compatible, describe_dim
from ..units import LIMITS, UnitError, parse_quantity, parse_unit
from . import (
    GROUND,
    MAX_POSITIONS,
    NAME_RE,
    STANDARD_G,
    Assembly,
    Damper,
    Driver,
    Limit,
    Link,
    Load,
    Mechanism,
    Outputs,
    PinJoint,
    PointForce,
    SliderJoint,
    SolverOptions,
    Spring,
    Sweep,
    Torque,
    keys,
)
from .source import KeyPath, Source, load_file, load_text
from .validate import suggest

TOP_KEYS = keys.TOP.allowed  # "study" and "cam" are read by their own commands, not run

METHODS = keys.METHODS  # solver.method and --method


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

    def ident(self, name: str, path: KeyPath, what: str) -> str:
        """A name of a point, link or joint: an identifier (checked as soon as it is read)."""
        if not NAME_RE.match(name):
            raise self.fail(
                path,
                f"{what} name {name!r} must start with a letter or '_' and contain only "
                "letters, digits and '_'",
            )
        return name

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
            e = Expression(value)
        except ExprError as exc:
            raise self.fail(path, f"cannot read the condition: {exc}") from None
        if e.reductions():
            raise self.fail(
                path,
                f"{e.reductions()[0]}() reduces a whole run to one number: it belongs in "
                "'requirements', not in a condition that holds position by position",
            )
        return e

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
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


# --- sections ----------------------------------------------------------------------


def read_units(r: Reader, value: Any) -> None:
    m = r.mapping(value, ("units",), keys.UNITS.allowed, "'units'")
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
    return {
        r.ident(str(p), ("ground", p), "point"): r.xy(v, ("ground", p)) for p, v in value.items()
    }


def read_point(
    r: Reader, value: Any, path: KeyPath, known: dict[str, tuple[float, float]]
) -> tuple[float, float] | None:
    """Local coordinates of a point; ``None`` if it refers to a point not read yet."""
    if not isinstance(value, dict):
        return r.xy(value, path)
    m = r.mapping(value, path, keys.POINT.allowed, "a point", keys.POINT.required)
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


LINK_KEYS = keys.LINK.allowed


def read_link(r: Reader, name: str, value: Any, g: float = STANDARD_G) -> Link:
    path: KeyPath = ("links", name)
    m = r.mapping(value, path, LINK_KEYS, f"link {name!r}")
    if "points" not in m:
        raise r.fail(path, f"link {name!r} needs 'points': its named points in its own frame")
    raw = m["points"]
    if not isinstance(raw, dict) or not raw:
        raise r.fail(path + ("points",), "'points' must map point names to coordinates")
    for p in raw:
        r.ident(p, path + ("points", p), "point")
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
    read_mass(r, m, link, path, g)
    return link


def _point_or_xy(r: Reader, value: Any, path: KeyPath, points, what: str):
    if isinstance(value, str) and value in points:
        return points[value]
    if isinstance(value, str) and "," not in value:
        raise r.fail(path, f"{what} has no point {value!r}" + suggest(value, list(points)))
    return r.xy(value, path)


def read_mass(r: Reader, m: dict, link: Link, path: KeyPath, g: float) -> None:
    """Mass properties: mass (or weight), centre of mass, inertia about it; conveniences
    ``uniform_bar: [P, Q]`` (centre at the middle, J = m l^2 / 12) and
    ``point_masses: {P: m, ...}`` (combined by the parallel-axis theorem).

    A mass without an inertia is a point mass at the centre of mass.
    """
    name, points = link.name, link.points
    if "mass" in m and "weight" in m:
        raise r.fail(path, f"link {name!r}: give 'mass' or 'weight', not both")
    mass = None
    if "mass" in m:
        mass = r.quantity(m["mass"], path + ("mass",), "mass")
    elif "weight" in m:
        mass = r.quantity(m["weight"], path + ("weight",), "force") / g
        if not abs(mass) <= LIMITS["mass"]:  # a tiny gravity makes a huge mass
            raise r.fail(
                path + ("weight",),
                f"the weight {m['weight']!r} under gravity {g:g} m/s^2 is a mass of {mass:g} kg, "
                f"more than the {LIMITS['mass']:g} kg mechsolve accepts (is gravity right?)",
            )
    if mass is not None and not mass >= 0:
        key = "mass" if "mass" in m else "weight"
        raise r.fail(path + (key,), f"{key} must be zero or positive, got {m[key]!r}")
    com = None
    if "com" in m:
        com = _point_or_xy(r, m["com"], path + ("com",), points, f"link {name!r}")
    inertia = None
    if "inertia" in m:
        inertia = r.quantity(m["inertia"], path + ("inertia",), "moment of inertia")
        if not inertia >= 0:
            raise r.fail(
                path + ("inertia",),
                f"moment of inertia must be zero or positive, got {m['inertia']!r}",
            )
    if "uniform_bar" in m:
        ends = r.names(m["uniform_bar"], path + ("uniform_bar",), "point", 2)
        for p in ends:
            if p not in points:
                raise r.fail(
                    path + ("uniform_bar",),
                    f"link {name!r} has no point {p!r}" + suggest(p, list(points)),
                )
        if mass is None:
            raise r.fail(path, f"link {name!r}: 'uniform_bar' needs the bar's 'mass' or 'weight'")
        (x0, y0), (x1, y1) = points[ends[0]], points[ends[1]]
        if com is None:
            com = ((x0 + x1) / 2, (y0 + y1) / 2)
        if inertia is None:
            inertia = mass * ((x1 - x0) ** 2 + (y1 - y0) ** 2) / 12.0
    if mass is not None and com is None:
        raise r.fail(
            path,
            f"link {name!r} has a mass: give its centre of mass 'com' (a point name or [x, y])",
        )
    if "point_masses" in m:
        pm = m["point_masses"]
        if not isinstance(pm, dict) or not pm:
            raise r.fail(path + ("point_masses",), "'point_masses' maps point names to masses")
        bodies = [] if mass is None else [(mass, com, inertia or 0.0)]
        for p, v in pm.items():
            here = path + ("point_masses", p)
            xy = _point_or_xy(r, p, here, points, f"link {name!r}")
            mp = r.quantity(v, here, "mass")
            if not mp >= 0:
                raise r.fail(here, f"mass must be zero or positive, got {v!r}")
            bodies.append((mp, xy, 0.0))
        total = sum(b[0] for b in bodies)
        if total > 0:
            cx = sum(b[0] * b[1][0] for b in bodies) / total
            cy = sum(b[0] * b[1][1] for b in bodies) / total
            inertia = sum(b[2] + b[0] * ((b[1][0] - cx) ** 2 + (b[1][1] - cy) ** 2) for b in bodies)
            mass, com = total, (cx, cy)
    link.mass = mass
    link.com = com
    link.inertia = inertia if inertia is not None else (0.0 if mass is not None else None)


def read_links(r: Reader, value: Any, g: float = STANDARD_G) -> list[Link]:
    if not isinstance(value, dict) or not value:
        raise r.fail(("links",), "'links' must map link names to their points")
    return [read_link(r, r.ident(str(n), ("links", n), "link"), v, g) for n, v in value.items()]


def read_gravity(r: Reader, value: Any) -> tuple[float, float]:
    """``gravity: 9.81 m/s^2`` (downwards), ``{g: ..., direction: -90 deg}``, or ``off``."""
    path: KeyPath = ("gravity",)
    if value is False or value in ("off", "none", 0, 0.0):
        return (0.0, 0.0)
    if isinstance(value, dict):
        m = r.mapping(value, path, keys.GRAVITY.allowed, "'gravity'", keys.GRAVITY.required)
        g = r.quantity(m["g"], path + ("g",), "acceleration")
        ang = r.quantity(m.get("direction", -90.0), path + ("direction",), "angle")
    else:
        g = r.quantity(value, path, "acceleration")
        ang = -math.pi / 2
    if g < 0:
        raise r.fail(path, "the magnitude of gravity must be zero or positive (give a direction)")
    return (g * math.cos(ang), g * math.sin(ang))


LOAD_KINDS = keys.LOAD_KINDS
LOAD_KEYS = keys.LOAD.allowed


class _Owners:
    """Which links carry each point, to find the link a load acts on."""

    def __init__(self, r: Reader, ground, links_list) -> None:
        self.r = r
        self.owners: dict[str, list[str]] = {p: [GROUND] for p in ground}
        for lk in links_list:
            for p in lk.points:
                self.owners.setdefault(p, []).append(lk.name)
        self.links = {lk.name for lk in links_list}

    def link(self, path: KeyPath, key: str, point: str, on: Any, allow_ground=False) -> str:
        r = self.r
        if on is not None:
            ln = r.name(on, path + ("on",), "link")
            pool = self.links | ({GROUND} if allow_ground else set())
            if ln not in pool:
                raise r.fail(path + ("on",), f"no link named {ln!r}" + suggest(ln, sorted(pool)))
            if ln not in self.owners.get(point, []):
                raise r.fail(path + ("on",), f"link {ln!r} has no point {point!r}")
            return ln
        if point not in self.owners:
            raise r.fail(
                path + (key,),
                f"no link has a point {point!r}" + suggest(point, list(self.owners)),
            )
        moving = [ln for ln in self.owners[point] if ln != GROUND]
        if not moving:
            if allow_ground:
                return GROUND
            raise r.fail(
                path + (key,), f"point {point!r} is on the ground only: a load there does nothing"
            )
        if len(moving) > 1:
            raise r.fail(
                path,
                f"point {point!r} is on links {', '.join(moving)}: say which one the load acts "
                "on with 'on:'",
            )
        return moving[0]


def read_loads(r: Reader, value: Any, ground, links_list, joints) -> list[Load]:
    """The ``loads`` section: forces, torques, springs, dampers, each optionally ``when``."""
    path0: KeyPath = ("loads",)
    if not isinstance(value, dict):
        raise r.fail(path0, "'loads' must map load names to their definitions")
    owners = _Owners(r, ground, links_list)
    sliders = {j.name for j in joints if isinstance(j, SliderJoint)}
    out: list[Load] = []
    for name, spec in value.items():
        path = path0 + (name,)
        m = r.mapping(spec, path, LOAD_KEYS, f"load {name!r}")
        kinds = [k for k in LOAD_KINDS if k in m]
        if len(kinds) != 1:
            raise r.fail(
                path, f"load {name!r} needs exactly one of force, torque, spring, damper, drag"
            )
        kind = kinds[0]
        for key in m:
            if key not in LOAD_KINDS[kind] | {"when", "description"}:
                raise r.fail(path + (key,), f"{key!r} does not apply to a {kind} load")
        when = r.expression(m["when"], path + ("when",)) if "when" in m else None
        if when is not None and not when.is_condition():
            raise r.fail(path + ("when",), f"{m['when']!r} is not a condition (use <, >, and...)")
        if kind == "force":
            out.append(_read_force(r, m, path, name, when, owners))
        elif kind == "torque":
            if "on" not in m:
                raise r.fail(path, f"torque {name!r} needs 'on': the link it acts on")
            ln = r.name(m["on"], path + ("on",), "link")
            if ln not in owners.links:
                raise r.fail(
                    path + ("on",), f"no link named {ln!r}" + suggest(ln, sorted(owners.links))
                )
            torque = r.quantity(m["torque"], path + ("torque",), "torque")
            out.append(Torque(name, when, path, ln, torque))
        elif kind == "drag":
            point = r.name(m["drag"], path + ("drag",), "point")
            link = owners.link(path, "drag", point, m.get("on"))
            c = _coefficient(r, m, path, name)
            out.append(Damper(name, when, path, drag=(link, point), coefficient=c))
        elif kind == "damper" and isinstance(m["damper"], str):  # along a slider
            sl = m["damper"]
            if sl not in sliders:
                raise r.fail(
                    path + ("damper",), f"no slider named {sl!r}" + suggest(sl, sorted(sliders))
                )
            c = _coefficient(r, m, path, name)
            out.append(Damper(name, when, path, slider=sl, coefficient=c))
        else:  # spring or damper between two points
            pts = r.names(m[kind], path + (kind,), "point", 2)
            ons = r.names(m["on"], path + ("on",), "link", 2) if "on" in m else [None, None]
            ends = tuple(
                (owners.link(path, kind, p, on, allow_ground=True), p) for p, on in zip(pts, ons)
            )
            if kind == "spring":
                for key in ("stiffness", "free_length"):
                    if key not in m:
                        raise r.fail(path, f"spring {name!r} needs '{key}'")
                k = r.quantity(m["stiffness"], path + ("stiffness",), "stiffness")
                l0 = r.positive(m["free_length"], path + ("free_length",), "length", True)
                out.append(Spring(name, when, path, ends, k, l0))
            else:
                c = _coefficient(r, m, path, name)
                out.append(Damper(name, when, path, ends=ends, coefficient=c))
    return out


def _read_force(r: Reader, m: dict, path: KeyPath, name: str, when, owners: _Owners) -> PointForce:
    if "at" not in m:
        raise r.fail(path, f"force {name!r} needs 'at': the point it acts at")
    point = r.name(m["at"], path + ("at",), "point")
    link = owners.link(path, "at", point, m.get("on"))
    f = m["force"]
    if isinstance(f, list):
        if len(f) != 2:
            raise r.fail(path + ("force",), "expected [Fx, Fy] or a magnitude")
        if "direction" in m:
            raise r.fail(path + ("direction",), "give [Fx, Fy], or a magnitude and a direction")
        force = (
            r.quantity(f[0], path + ("force", 0), "force"),
            r.quantity(f[1], path + ("force", 1), "force"),
        )
    else:
        mag = r.quantity(f, path + ("force",), "force")
        ang = r.quantity(m.get("direction", 0.0), path + ("direction",), "angle")
        force = (mag * math.cos(ang), mag * math.sin(ang))
    frame = m.get("frame", "global")
    if frame not in ("global", "link"):
        raise r.fail(path + ("frame",), f"frame is 'global' or 'link', got {frame!r}")
    return PointForce(name, when, path, link, point, force, frame)


def _coefficient(r: Reader, m: dict, path: KeyPath, name: str) -> float:
    if "coefficient" not in m:
        raise r.fail(path, f"damper {name!r} needs 'coefficient' (e.g. 15 N s/m)")
    c = r.quantity(m["coefficient"], path + ("coefficient",), "damping")
    if c < 0:
        raise r.fail(path + ("coefficient",), "a damping coefficient must be zero or positive")
    return c


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
    m = r.mapping(value, path, keys.GUIDE_LINE.allowed, "a guide line ([P, Q] or {through, angle})")
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
    m = r.mapping(value, path, keys.JOINT.allowed, f"joint {name!r}")
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


def pin_names(name: str, count: int) -> list[str]:
    """Names of the revolute joints a pin through ``count`` links stands for: ``E``,
    ``E_2``, ``E_3``... (the first listed link with each other one)."""
    return [name] + [f"{name}_{k}" for k in range(2, count)]


def _pin_links(value: Any) -> list[Any] | None:
    """The links of an entry that pins three or more links at one point, else ``None``."""
    if isinstance(value, list) and len(value) > 2:
        return value
    if isinstance(value, dict) and isinstance(value.get("revolute"), list):
        if len(value["revolute"]) > 2:
            return value["revolute"]
    return None


def read_pin(r: Reader, name: str, value: Any, mech_points) -> list[PinJoint]:
    """A pin joining three or more links at one point: ``E: [K2, K3, K4]`` or ``E:
    {revolute: [K2, K3, K4], point: E}``; revolute joints between the first link and each
    other one, named as :func:`pin_names` says (reactions on each by the first)."""
    path: KeyPath = ("joints", name)
    lpath = path
    point = name
    if isinstance(value, dict):
        m = r.mapping(value, path, keys.PIN.allowed, f"joint {name!r}")
        lpath = path + ("revolute",)
        point = r.name(m.get("point", name), path + ("point",), "point")
        value = m["revolute"]
    names = r.names(value, lpath, "link")
    for i, ln in enumerate(names):
        here = lpath + (i,)
        if ln not in mech_points:
            raise r.fail(here, f"no link named {ln!r}" + suggest(ln, list(mech_points)))
        if ln in names[:i]:
            raise r.fail(here, f"joint {name!r} lists the link {ln!r} twice")
        if point not in mech_points[ln]:
            what = "the ground" if ln == GROUND else f"link {ln!r}"
            raise r.fail(
                here,
                f"joint {name!r} pins {', '.join(names)} at point {point!r}, but {what} has "
                f"no point {point!r}" + suggest(point, list(mech_points[ln])),
            )
    first = names[0]
    return [
        PinJoint(jn, first, other, point, where=path)
        for jn, other in zip(pin_names(name, len(names)), names[1:])
    ]


def read_joints(r: Reader, value: Any, ground, links) -> list[PinJoint | SliderJoint]:
    if not isinstance(value, dict) or not value:
        raise r.fail(("joints",), "'joints' must map joint names to their definitions")
    pts = {GROUND: ground}
    pts.update({lk.name: lk.points for lk in links})
    out: list[PinJoint | SliderJoint] = []
    for n, v in value.items():
        name = r.ident(str(n), ("joints", n), "joint")
        many = _pin_links(v)
        if many is None:
            out.append(read_joint(r, name, v, pts))
            continue
        extra = pin_names(name, len(many))[1:]
        for jn in extra:
            if jn in value:
                raise r.fail(
                    ("joints", n),
                    f"joint {name!r} pins {len(many)} links: its pairs are named "
                    f"{', '.join(pin_names(name, len(many)))}, but the file has a joint "
                    f"{jn!r} too; rename one",
                )
        out += read_pin(r, name, v, pts)
    return out


def read_driver(r: Reader, value: Any, joints) -> Driver:
    path: KeyPath = ("driver",)
    m = r.mapping(value, path, keys.DRIVER.allowed, "'driver'", keys.DRIVER.required)
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
    import numpy as np

    from .motion import ConstantAcceleration, Segments, TableMotion

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
    unit = "length" if linear else "angle"
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
        segs = m["segments"]
        if not isinstance(segs, list) or not segs:
            raise r.fail(path + ("segments",), "'segments' must be a list of segments")
        if w0 < 0:
            raise r.fail(
                path + ("from",), "segment speeds are magnitudes; 'direction' sets the sense"
            )
        spec = []
        for k, seg in enumerate(segs):
            sp = path + ("segments", k)
            sm = r.mapping(seg, sp, keys.SEGMENT.allowed, "a segment")
            which = [x for x in ("accelerate", "run", "decelerate", "dwell") if x in sm]
            if len(which) != 1:
                raise r.fail(
                    sp, "a segment is one of accelerate, run, decelerate, dwell: its duration"
                )
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
            law = Segments.build(float(d.start), sign * w0, spec)
        except ValueError as exc:
            raise r.fail(path + ("segments",), str(exc)) from None
    elif kind == "table":
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
            raise r.fail(
                path + ("end",), f"end must be not-a-knot, natural or clamped, got {end!r}"
            )
        law = TableMotion(times=np.array(ts), values=np.array(us), end=end)
        d.start = law.start
    else:
        law = read_law(r, m["law"], path + ("law",), has_start, linear)
        d.start = law.start
    d.motion = law
    d.speed = law.nominal_speed()
    d.sense = 1 if d.speed > 0 else -1


def _law_kind(e: Expression, kind: str, what: str) -> None:
    """An :class:`ExprError` unless law ``e`` gives ``what``, of the kind ``kind`` (a
    law whose coefficients are bare numbers is SI and passes; one written with units
    must come out in the right kind: "5 N - 0.1 * omega" is no torque)."""
    from ..units import dimension

    got, want = e.dimension(), dimension(kind)
    if not compatible(got, want):
        raise ExprError(f"{e.text!r} is {describe_dim(got)}, but {what} is {describe_dim(want)}")


def read_law(r: Reader, value: Any, path: KeyPath, has_start: bool, linear: bool = False):
    """``u(t)`` as an expression of ``t`` (SI: rad or m), differentiated symbolically."""
    import numpy as np

    from .motion import ExpressionMotion

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
        from .motion import ConstantAcceleration

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
        n = m["steps"]
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
            t = float(t) if not isinstance(t, bool) else None
        except (TypeError, ValueError, OverflowError):  # a huge whole number overflows
            t = None
        if t is None:
            raise r.fail(path + ("tolerance",), f"expected a number, got {_kind(m['tolerance'])}")
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
            other = [
                f"a {what} (mechsolve {cmd} FILE)"
                for sec, what, cmd in (
                    ("cam", "cam design", "cam"),
                    ("torque", "torque curve", "flywheel"),
                )
                if sec in data
            ]
            raise src.error(
                (),
                f"the file has no '{key}' section"
                + (f": it is {other[0]}, not a mechanism" if other else ""),
            )
    gravity = read_gravity(r, data["gravity"]) if "gravity" in data else None
    g = math.hypot(*gravity) if gravity is not None and any(gravity) else STANDARD_G
    ground = read_ground(r, data.get("ground"))
    links = read_links(r, data["links"], g)
    joints = read_joints(r, data["joints"], ground, links)
    loads = read_loads(r, data["loads"], ground, links, joints) if "loads" in data else []
    driver = read_driver(r, data["driver"], joints) if "driver" in data else None
    linear = driver is not None and any(
        isinstance(j, SliderJoint) and j.name == driver.joint for j in joints
    )
    name = data.get("name", Path(src.file).stem if src.file else "mechanism")
    if not isinstance(name, str):
        raise src.error(("name",), "the name must be text")
    if "description" in data and not isinstance(data["description"], (str, type(None))):
        raise src.error(("description",), "the description must be text")
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
        gravity=gravity,
        loads=loads,
        length_unit=r.length_unit,
        source=src,
    )
    if "instants" in data:
        mech.instants = read_instants(r, data["instants"], linear)
    if "motor" in data:
        mech.motor = read_motor(r, data["motor"], driver, linear)
    if "flywheel" in data:
        mech.flywheel = read_flywheel(r, data["flywheel"], links)
    if "simulate" in data:
        mech.simulation = read_simulation(r, data["simulate"], linear)
    if "requirements" in data:
        mech.requirements = read_requirements(r, data["requirements"], linear)
    return mech.validate()


def read_requirements(r: Reader, value: Any, linear: bool | None = None) -> list:
    """``requirements: {name: "max(abs(input.torque)) <= 300 kN m", ...}`` (see
    :mod:`mechsolve.requirements`); ``linear``: the driver is a slider."""
    from ..expr import DimensionError
    from .requirement import parse_requirement

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


def read_motor(r: Reader, value: Any, driver: Driver | None, linear: bool):
    """``motor: {stall: 50 N m, slope: 1.25 N m s}``, ``{table: [[speed, torque], ...]}``
    or ``{torque: "50 - 1.25 * omega"}`` (an expression of omega (or v) and t)."""
    import numpy as np

    from .machine import Motor

    path: KeyPath = ("motor",)
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


def read_flywheel(r: Reader, value: Any, links):
    from .machine import Flywheel

    path: KeyPath = ("flywheel",)
    m = r.mapping(value, path, keys.FLYWHEEL.allowed, "'flywheel'", keys.FLYWHEEL.required)
    name = r.name(m["on"], path + ("on",), "link")
    if name not in {lk.name for lk in links}:
        raise r.fail(
            path + ("on",), f"no link named {name!r}" + suggest(name, [lk.name for lk in links])
        )
    return Flywheel(name, r.positive(m["inertia"], path + ("inertia",), "moment of inertia"))


def read_simulation(r: Reader, value: Any, linear: bool):
    from .machine import INTEGRATORS, Simulation

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
    for key in ("rtol", "atol"):
        if key in m:
            x = m[key]
            if isinstance(x, str):  # YAML reads 1e-10 (no dot) as text
                try:
                    x = float(x)
                except ValueError:
                    pass
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not 0 < x < 1:
                raise r.fail(path + (key,), f"{key} must be a number between 0 and 1")
            setattr(sim, key, float(x))
    if "from" in m:
        f = m["from"]
        sim.speed0 = (
            0.0
            if f == "rest"
            else r.quantity(f, path + ("from",), "speed" if linear else "angular speed")
        )
    if "revolutions" in m:
        sim.revolutions = r.positive(m["revolutions"], path + ("revolutions",), "dimensionless")
    if "steady" in m:
        x = m["steady"]
        if isinstance(x, str):
            try:
                x = float(x.strip().rstrip("%")) / (100 if x.strip().endswith("%") else 1)
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
    res = m.get("resisting", "mean")
    resisting = None if res == "mean" else r.quantity(res, ("resisting",), "torque")
    delta = None
    if "delta" in m:
        d = m["delta"]
        try:
            num, _, den = str(d).partition("/")
            delta = float(num) / float(den) if den else float(num)
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
