"""What a requirement is (the ``requirements:`` section of the mechanism file): its text
parsed to an expression, the kinds of quantity its figures are, and the names it must
refer to. These are part of the model, checked as the file is read; evaluating a
requirement on a run is :mod:`mechsolve.results.requirements`, above the results.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from mechsolve.base.units import UnitError, parse_unit
from mechsolve.model.expr import QUANTITY_DIMS, Call, Compare, ExprError, Expression, Ref, walk

if TYPE_CHECKING:  # (the model's parser imports this module)
    from mechsolve.model import Mechanism

FULL_TURN = "full turn"
_OPS = ("<=", ">=", "==", "!=", "<", ">")


@dataclass
class Requirement:
    """One named requirement as the file gives it."""

    name: str
    text: str
    expr: Expression | None  # None: the assembly requirement ("full turn")
    unit: str = ""  # the unit the limit is written in (for display), "" for SI


def _rewrite(text: str) -> str:
    """``time_ratio(ram)`` is the figure ``ram.time_ratio``; likewise swing and stroke."""
    return re.sub(r"\b(time_ratio|swing|stroke)\(\s*([^\W\d]\w*)\s*\)", r"\2.\1", text)


_FORCE = (1, 1, -2, 0)
_TORQUE = (2, 1, -2, 0)
_ANGLE = (0, 0, 0, 1)
_LENGTH = (1, 0, 0, 0)
_PURE = (0, 0, 0, 0)
# the figures a requirement reads, beyond the quantities of points, links and sliders
_ATTR_DIMS = {
    **QUANTITY_DIMS,
    "Fx": _FORCE,
    "Fy": _FORCE,
    "F": _FORCE,
    "N": _FORCE,
    "M": _TORQUE,
    "swing": _ANGLE,
    "stroke": _LENGTH,
    "time_ratio": _PURE,
}
_NAMED_DIMS = {
    ("input", "torque"): _TORQUE,
    ("input", "force"): _FORCE,
    ("input", "angle"): _ANGLE,
    ("input", "s"): _LENGTH,
    ("cycle", "work"): _TORQUE,
    ("solver", "residual"): _LENGTH,
    ("solver", "iterations"): _PURE,
    ("jacobian", "rcond"): _PURE,
    **{("energy", a): _TORQUE for a in ("kinetic", "potential")},
    **{
        ("power", a): (2, 1, -3, 0)
        for a in ("input", "kinetic_rate", "potential_rate", "loads", "residual")
    },
}


def figure_dim(ref: Ref, linear: bool | None = None) -> tuple[int, int, int, int] | None:
    """The dimension of a figure a requirement reads, from its name alone (``None`` when
    the name does not tell: it is checked again on the run's columns)."""
    if ref.name == "transmission_angle":
        return _ANGLE
    if (ref.name, ref.attr) == ("input", "travel"):
        return None if linear is None else (_LENGTH if linear else _ANGLE)
    return _NAMED_DIMS.get((ref.name, ref.attr), _ATTR_DIMS.get(ref.attr))


def parse_requirement(name: str, text: Any, linear: bool | None = None) -> Requirement:
    """Read one requirement; raises :class:`ExprError` with the reason when it is not a
    comparison of a figure with a limit, and :class:`~mechsolve.model.expr.DimensionError`
    when it compares (or adds) figures of different kinds (``linear``: whether the
    driver is a slider, so that ``at(q, u)`` takes a length rather than an angle)."""
    if not isinstance(text, str):
        raise ExprError(
            "a requirement is a comparison such as 'max(abs(input.torque)) <= 300 kN m', "
            f"or 'full turn'; got {text!r}"
        )
    if text.strip().lower() in (FULL_TURN, "assembles: full turn", "assembles full turn"):
        return Requirement(name, text, None)
    expr = Expression(_rewrite(text))
    expr.text = text  # messages quote what the file says (time_ratio(ram), not ram.time_ratio)
    tree = expr.tree
    if not isinstance(tree, Compare) or len(tree.ops) != 1:
        raise ExprError(
            "a requirement compares one figure with a limit, e.g. "
            "'min(transmission_angle.B) >= 40 deg'"
        )
    reads = [any(isinstance(n, Ref) for n in walk(side)) for side in tree.operands]
    if reads.count(True) != 1:
        raise ExprError(
            "one side of the comparison must read the run (e.g. max(K.y)) and the other "
            "be a limit (e.g. 2 m)"
        )
    for n in walk(tree):
        if isinstance(n, Call) and n.func == "stroke":
            raise ExprError(
                "in a requirement stroke(X) is the stroke of the slider joint X (e.g. "
                "stroke(ram_guide)); the fraction of a stroke, stroke(C.x), belongs in a "
                "load's 'when'"
            )
        if isinstance(n, Call) and n.func == "at":
            if any(isinstance(m, Ref) for m in walk(n.args[1])):
                raise ExprError(
                    "at(q, u) reads q at the driver value u, a number such as 31 deg "
                    f"(got {Expression._derived(n.args[1], '', ()).to_text()!r})"
                )
    driver = None if linear is None else (_LENGTH if linear else _ANGLE)
    expr.dimension(lambda ref: figure_dim(ref, linear), driver)
    limit_text = re.split(r"<=|>=|==|!=|<|>", text)[1 if reads[0] else 0]
    return Requirement(name, text, expr, _unit_of(limit_text))


def _quote(names: list[str]) -> str:
    return ", ".join(names) if names else "none in this mechanism"


def check_names(mech: Mechanism, req: Requirement) -> None:
    """Check that each figure of a limit position names the kind of thing it belongs to:
    ``swing(X)`` a rocker (a link pinned to the ground, not the driven one),
    ``stroke(X)`` a slider joint (not the driven one), ``time_ratio(X)`` a rocker or a
    slider on a ground guide (a ram). Raises :class:`ExprError` with the names that
    would do; a name that is neither a link nor a joint is left to the run (which
    suggests the close ones)."""
    from mechsolve.model import GROUND

    if req.expr is None:
        return
    driven = mech.driver.joint if mech.driver is not None else None
    links = {lk.name for lk in mech.links}
    joints = {j.name: j for j in mech.joints}
    rockers = [
        x
        for j in mech.joints
        if j.coordinate == "angle" and GROUND in j.links and j.name != driven
        for x in j.links
        if x != GROUND
    ]
    sliders = [j for j in mech.sliders if j.name != driven]
    slider_names = [j.name for j in sliders]
    rams = [j.name for j in sliders if GROUND in (j.guide, j.block)]
    driven_links = set(joints[driven].links) - {GROUND} if driven in joints else set()
    for ref in walk(req.expr.tree):
        if not isinstance(ref, Ref) or ref.attr not in ("swing", "stroke", "time_ratio"):
            continue
        x, attr = ref.name, ref.attr
        if x not in links and x not in joints:
            continue
        carried = [j.name for j in sliders if x in (j.guide, j.block)]
        if x in joints:
            what = (
                "the driven joint"
                if x == driven
                else "a slider joint"
                if x in slider_names
                else "a pin joint"
            )
        else:
            what = "the driven link" if x in driven_links else "a link"
        if attr == "swing" and x not in rockers:
            hint = f"stroke({x}) is its figure" if x in slider_names else None
            if hint is None and carried:
                hint = f"it moves along the slider {carried[0]}: stroke({carried[0]})"
            raise ExprError(
                f"swing({x}): {x!r} is {what}, not a rocker"
                + (f" ({hint})" if hint else "")
                + f". swing() is the figure of a rocker, a link pinned to the ground: "
                f"{_quote(rockers)}"
            )
        if attr == "stroke" and x not in slider_names:
            hint = f" (the slider joint that moves it: stroke({carried[0]}))" if carried else ""
            raise ExprError(
                f"stroke({x}): {x!r} is {what}, not a slider joint{hint}. stroke() is the "
                f"figure of a slider joint: {_quote(slider_names)}"
            )
        if attr == "time_ratio" and x not in rockers and x not in rams:
            ram = next((c for c in carried if c in rams), None)
            if ram is not None:
                hint = f" (the slider joint that guides it: time_ratio({ram}))"
            elif x in slider_names:
                hint = " (it slides along a moving link: no return stroke to time)"
            else:
                hint = ""
            raise ExprError(
                f"time_ratio({x}): {x!r} is {what}, not a rocker or a slider joint on a "
                f"ground guide{hint}. A time ratio is the figure of one of these: "
                f"{_quote(rockers + rams)}"
            )


def _unit_of(limit_text: str) -> str:
    m = re.fullmatch(r"\s*[-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?\s*(.*?)\s*", limit_text)
    if not m or not m.group(1):
        return ""
    try:
        parse_unit(m.group(1))
    except UnitError:
        return ""
    return m.group(1)
