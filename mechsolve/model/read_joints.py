"""Reading joints: each kind reads its own mapping (:meth:`mechsolve.joints.base.Joint.read`);
here, the shorthand ``A: [crank, coupler]`` and pins through three or more links (see
:mod:`mechsolve.model.parse`)."""

from __future__ import annotations

from typing import Any

from mechsolve.joints.registry import KINDS
from mechsolve.model import GROUND, Joint, PinJoint, keys
from mechsolve.model.reader import Reader
from mechsolve.model.source import KeyPath
from mechsolve.model.validate import suggest


def read_joint(r: Reader, name: str, value: Any, mech_points) -> Joint:
    path: KeyPath = ("joints", name)
    if isinstance(value, list):  # shorthand: A: [crank, coupler]
        # one link is "2 or more" short (three or more are read as one pin through all)
        r.names(value, path, "link", least=2)
        a, b = r.names(value, path, "link", 2)
        return PinJoint(name, a, b, name, where=path)
    m = r.mapping(value, path, keys.joint_section().allowed, f"joint {name!r}")
    kinds = [k for k in KINDS if k in m]
    if len(kinds) != 1:
        raise r.fail(
            path,
            f"joint {name!r} needs exactly one of "
            + " or ".join(f"'{k}: [{', '.join(c.roles)}]'" for k, c in KINDS.items()),
        )
    cls = KINDS[kinds[0]]
    for key in m:
        if key in cls.keys or key in KINDS:
            continue
        owners = [c.kind for c in KINDS.values() if key in c.keys]
        if owners:
            raise r.fail(
                path + (key,),
                f"{key!r} applies to a {' or a '.join(owners)} joint, not a {cls.kind} joint",
            )
    return cls.read(r, name, m, path, mech_points)


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


def read_joints(r: Reader, value: Any, ground, links) -> list[Joint]:
    if not isinstance(value, dict) or not value:
        raise r.fail(("joints",), "'joints' must map joint names to their definitions")
    pts = {GROUND: ground}
    pts.update({lk.name: lk.points for lk in links})
    out: list[Joint] = []
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
