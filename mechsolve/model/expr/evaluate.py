"""Evaluating a tree over arrays, iteratively (see :mod:`mechsolve.model.expr`)."""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from mechsolve.model.expr.tree import (
    _FUNCS,
    _KEYWORDS,
    CONTEXT_FUNCS,
    Binary,
    BoolOp,
    Call,
    Chain,
    Compare,
    Context,
    ExprError,
    Not,
    Num,
    Ref,
    Side,
    Unary,
    Var,
    _builtin,
    children,
    walk,
)


def _check_variables(variables: Sequence[str]) -> tuple[str, ...]:
    if isinstance(variables, str):
        variables = (variables,)
    out = tuple(variables)
    for v in out:
        if (
            not isinstance(v, str)
            or not re.fullmatch(r"[^\W\d]\w*", v)
            or v in _KEYWORDS
            or v in _FUNCS
            or v in CONTEXT_FUNCS
        ):
            raise ExprError(f"{v!r} cannot be a variable of an expression")
    return out


def _leaf(n: Any, ctx: Context) -> Any:
    if isinstance(n, Num):
        return n.value
    if isinstance(n, Ref):
        return ctx.quantity(n.name, n.attr)
    if isinstance(n, Side):
        px, py = ctx.point_xy(n.point)
        ax, ay = ctx.point_xy(n.start)
        bx, by = ctx.point_xy(n.end)
        cross = (bx - ax) * (py - ay) - (by - ay) * (px - ax)
        return cross > 0 if n.side == "left" else cross < 0
    if isinstance(n, Var):
        raise ExprError(f"the variable {n.name!r} has no value here")
    raise AssertionError(f"unknown node {type(n).__name__}")


_COMPARE = {
    "<": np.less,
    "<=": np.less_equal,
    ">": np.greater,
    ">=": np.greater_equal,
    "==": np.equal,
    "!=": np.not_equal,
}
_ARITH = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide}


def _combine(n: Any, vals: list[Any], funcs: dict[str, Callable[..., Any]]) -> Any:
    if isinstance(n, Unary):
        return np.negative(vals[0])
    if isinstance(n, Not):
        return np.logical_not(vals[0])
    if isinstance(n, Binary):
        return np.power(vals[0], vals[1])
    if isinstance(n, Chain):
        out = vals[0]
        for op, v in zip(n.ops, vals[1:]):
            out = _ARITH[op](out, v)
        return out
    if isinstance(n, Compare):
        result: Any = True
        for op, a, b in zip(n.ops, vals[:-1], vals[1:]):
            result = np.logical_and(result, _COMPARE[op](a, b))
        return result
    if isinstance(n, BoolOp):
        f = np.logical_and if n.op == "and" else np.logical_or
        out = vals[0]
        for v in vals[1:]:
            out = f(out, v)
        return out
    if isinstance(n, Call):
        if _builtin(n.func, len(vals)):
            return _FUNCS[n.func][1](*vals)
        if n.func in funcs:
            return funcs[n.func](*vals)
        raise ExprError(f"{n.func}() is not available here")
    raise AssertionError(f"unknown node {type(n).__name__}")


def _new_not_finite(out: Any, args: list[Any]) -> int | None:
    """The first element where ``out`` is not finite though every operand is (a division
    by zero, an overflow, a function outside its domain), or None."""
    o = np.asarray(out)
    if o.dtype.kind not in "fc":
        return None
    bad = ~np.isfinite(o)
    if not bad.any():
        return None
    for a in args:
        a = np.asarray(a)
        if a.dtype.kind in "fc":
            bad = bad & np.isfinite(a)
    bad = np.asarray(bad)
    return int(np.flatnonzero(bad.ravel())[0]) if bad.any() else None


def _eval(
    tree: Any,
    leaf: Callable[[Any], Any],
    funcs: dict[str, Callable[..., Any]],
    faults: list[tuple[Any, int]] | None = None,
) -> Any:
    """Evaluate a tree bottom-up with an explicit stack (no recursion).

    A node shared by several parents (derivatives share sub-trees) is evaluated once; its
    value is kept only until its last parent has used it. With ``faults`` (a list), the
    first node whose value is not finite where its operands are (``1/0``, ``log(0)``,
    ``1e300 * 1e300``) is appended to it with the element where that happens.
    """
    uses: dict[int, int] = {}  # parents of each node, counted per link
    for n in walk(tree):
        for kid in children(n):
            uses[id(kid)] = uses.get(id(kid), 0) + 1
    kept: dict[int, list[Any]] = {}  # id -> [value, uses left]
    vals: list[Any] = []
    stack: list[tuple[Any, bool]] = [(tree, False)]
    while stack:
        n, ready = stack.pop()
        key = id(n)
        if not ready and key in kept:
            entry = kept[key]
            vals.append(entry[0])
            entry[1] -= 1
            if entry[1] == 0:
                del kept[key]
            continue
        kids = children(n)
        if not kids:
            vals.append(leaf(n))
        elif ready:
            k = len(kids)
            args = vals[-k:]
            del vals[-k:]
            vals.append(_combine(n, args, funcs))
            if faults is not None and not faults and not isinstance(n, (Compare, BoolOp, Not)):
                k = _new_not_finite(vals[-1], args)
                if k is not None:
                    faults.append((n, k))
        else:
            stack.append((n, True))
            stack.extend((kid, False) for kid in reversed(kids))
            continue
        if uses.get(key, 0) > 1:
            kept[key] = [vals[-1], uses[key] - 1]
    assert len(vals) == 1
    return vals[0]
