"""A tree as text, with the fewest parentheses (see :mod:`mechsolve.model.expr`)."""

from __future__ import annotations

import math
from typing import Any

from mechsolve.model.expr.tree import (
    Binary,
    BoolOp,
    Call,
    Chain,
    Compare,
    Not,
    Num,
    Ref,
    Side,
    Unary,
    Var,
)

# --- printing ------------------------------------------------------------------------
# Binding power of each node as the parser reads it; a child that binds less tightly than
# its place needs is put in parentheses.

_ATOM = 9


def _prec(n: Any) -> int:
    if isinstance(n, Num):
        return 7 if math.copysign(1.0, n.value) < 0 else _ATOM  # "-2" reads as '-' 2
    if isinstance(n, Binary):
        return 8
    if isinstance(n, Unary):
        return 7
    if isinstance(n, Chain):
        return 6 if n.ops[0] in ("*", "/") else 5
    if isinstance(n, Compare):
        return 4
    if isinstance(n, (Not, Side)):
        return 3
    if isinstance(n, BoolOp):
        return 2 if n.op == "and" else 1
    return _ATOM  # Var, Ref, Call


def _number(v: float) -> str:
    if v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    return repr(v)  # the shortest text that reads back to the same float


def to_text(tree: Any, limit: int | None = None, as_written: bool = False) -> str | None:
    """Render a tree as text of this language that parses back to the same values.

    Iterative; parentheses only where precedence needs them. Returns ``None`` as soon as
    the text would be longer than ``limit`` characters (a derivative shares sub-trees,
    so its text can be much longer than its tree is large). ``as_written``: numbers with
    a unit as the source wrote them (``300 kN m``), for messages.
    """
    out: list[str] = []
    length = 0
    # items: a string to emit, or (node, the binding power its place needs)
    stack: list[Any] = [(tree, 0)]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            out.append(item)
            length += len(item)
            if limit is not None and length > limit:
                return None
            continue
        n, need = item
        parts: list[Any] = []
        if _prec(n) < need:
            parts.append("(")
        if isinstance(n, Num):
            parts.append(n.text if as_written and n.text else _number(n.value))
        elif isinstance(n, Var):
            parts.append(n.name)
        elif isinstance(n, Ref):
            parts.append(f"{n.name}.{n.attr}")
        elif isinstance(n, Side):
            parts.append(f"{n.point} {n.side} of {n.start} -> {n.end}")
        elif isinstance(n, Call):
            parts.append(n.func + "(")
            for i, a in enumerate(n.args):
                if i:
                    parts.append(", ")
                parts.append((a, 0))
            parts.append(")")
        elif isinstance(n, Unary):
            parts += ["-", (n.arg, 7)]
        elif isinstance(n, Not):
            parts += ["not ", (n.arg, 3)]
        elif isinstance(n, Binary):  # right-associative: the base must be an atom
            parts += [(n.left, _ATOM), " ^ ", (n.right, 7)]
        elif isinstance(n, (Chain, Compare)):
            # a - (b + c), a / (b * c); (a < b) < c
            first = _prec(n) if isinstance(n, Chain) else 5
            later = first + 1
            parts.append((n.operands[0], first))
            for op, a in zip(n.ops, n.operands[1:]):
                parts += [f" {op} ", (a, later)]
        elif isinstance(n, BoolOp):
            for i, a in enumerate(n.args):
                if i:
                    parts.append(f" {n.op} ")
                parts.append((a, 3 if n.op == "and" else 2))
        else:
            raise AssertionError(f"unknown node {type(n).__name__}")
        if _prec(n) < need:
            parts.append(")")
        stack.extend(reversed(parts))
    return "".join(out)
