"""Reading units, ground, links, points and masses (see :mod:`mechsolve.model.parse`)."""

from __future__ import annotations

import math
from typing import Any

from mechsolve.base.units import LIMITS, UnitError, parse_unit
from mechsolve.model import STANDARD_G, Link, keys
from mechsolve.model.reader import Reader, _kind
from mechsolve.model.source import KeyPath
from mechsolve.model.validate import suggest


def read_units(r: Reader, value: Any) -> None:
    m = r.mapping(value, ("units",), keys.UNITS.allowed, "'units'")
    for key, kind in (("length", "length"), ("angle", "angle")):
        if key in m:
            text = m[key]
            if not isinstance(text, str) or not text.strip():
                example = "mm, m or in" if kind == "length" else "deg or rad"
                raise r.fail(
                    ("units", key),
                    f"expected the unit of plain {kind}s, e.g. {example}, got {_kind(text)}",
                )
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
