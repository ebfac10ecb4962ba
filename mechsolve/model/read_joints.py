"""Reading joints: pins and sliders (see :mod:`mechsolve.model.parse`)."""

from __future__ import annotations

from typing import Any

from mechsolve.model import GROUND, PinJoint, SliderJoint, keys
from mechsolve.model.read_loads import read_line
from mechsolve.model.reader import Reader
from mechsolve.model.source import KeyPath
from mechsolve.model.validate import suggest


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
