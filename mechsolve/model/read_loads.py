"""Reading loads: forces, torques, springs, dampers (see :mod:`mechsolve.model.parse`)."""

from __future__ import annotations

import math
from typing import Any

from mechsolve.model import GROUND, Damper, Load, PointForce, Spring, Torque, keys
from mechsolve.model.reader import Reader
from mechsolve.model.source import KeyPath
from mechsolve.model.validate import suggest

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
    sliders = {j.name for j in joints if j.coordinate == "length"}
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
