"""The expression tree: limits, tokens, nodes and the walks over them (see
:mod:`mechsolve.model.expr`)."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

MAX_LENGTH = 4000  # characters of one expression
MAX_DEPTH = 64  # nesting levels: parentheses, function calls, prefix '-' and 'not', '^'
MAX_NODES = 100_000  # nodes plus operand links one derivative may build


class ExprError(ValueError):
    """A condition that does not parse or refers to something unknown."""


_SPACE_RE = re.compile(r"\s*")
_TOKEN_RE = re.compile(
    # ASCII digits, as in a file's quantities (mechsolve.base.units.NUMBER_PATTERN)
    r"(?P<num>(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?)"
    r"|(?P<name>[^\W\d]\w*)"  # letters of any script: 曲柄.angle, кривошип.omega
    r"|(?P<op>->|<=|>=|==|!=|\*\*|[-+*/^<>().,])"
)

_KEYWORDS = {"and", "or", "not", "left", "right", "of"}
_CMP = {"<", "<=", ">", ">=", "==", "!="}


def _show(text: str, limit: int = 80) -> str:
    """``text`` quoted for a message, shortened in the middle when it is long."""
    if len(text) <= limit:
        return repr(text)
    half = limit // 2
    return repr(text[:half]) + " ... " + repr(text[-half:]) + f" ({len(text)} characters)"


@dataclass(frozen=True)
class Token:
    kind: str  # num, name, op, end
    text: str
    pos: int


def tokenize(text: str) -> list[Token]:
    """Split ``text`` into tokens; raise :class:`ExprError` at the first bad character."""
    if len(text) > MAX_LENGTH:
        raise ExprError(
            f"the expression is {len(text)} characters long; an expression is limited to "
            f"{MAX_LENGTH} characters"
        )
    tokens: list[Token] = []
    pos = 0
    n = len(text)
    while True:
        pos = _SPACE_RE.match(text, pos).end()  # type: ignore[union-attr]
        if pos >= n:
            break
        m = _TOKEN_RE.match(text, pos)
        if not m:
            if text[pos].isdecimal():  # full-width digits from an input method, say
                raise ExprError(
                    f"the digit {text[pos]!r} at column {pos + 1} in {_show(text)} is not "
                    "ASCII 0-9: write numbers with 0-9"
                )
            raise ExprError(
                f"unexpected character {text[pos]!r} at column {pos + 1} in {_show(text)}"
            )
        kind = m.lastgroup or "op"
        run_on = text[m.end() : m.end() + 2]
        if kind == "num" and len(run_on) == 2 and run_on[0] in "_:" and run_on[1] in "0123456789":
            what = "digits grouped with '_'" if run_on[0] == "_" else "'a:b' values (base 60)"
            raise ExprError(
                f"the number at column {pos + 1} in {_show(text)} runs on with {run_on[0]!r}: "
                f"{what} are not read; write one decimal number"
            )
        value = m.group(kind)
        tokens.append(Token(kind, "^" if value == "**" else value, pos))
        pos = m.end()
    tokens.append(Token("end", "", n))
    return tokens


class Context(Protocol):
    """What an expression may read. Implemented by the solver's result objects."""

    def quantity(self, name: str, attr: str) -> Any:
        """The value of ``name.attr`` (an array over positions, or a number)."""
        ...

    def point_xy(self, name: str) -> tuple[Any, Any]:
        """The x and y coordinates of a point."""
        ...


# --- the tree ------------------------------------------------------------------------
# Flat chains ("a + b - c + ...", "a < b <= c", "a and b and ...") are one node each, so
# the depth of a tree is bounded by the nesting the parser allows.


@dataclass(frozen=True)
class Num:
    """A number (SI). ``dim`` is the dimension of the unit it was written with, ``None``
    for a bare number; ``text`` is how it was written (``"300 kN m"``), for messages."""

    value: float
    dim: tuple[int, int, int, int] | None = field(default=None, compare=False)
    text: str = field(default="", compare=False)


@dataclass(frozen=True)
class Ref:
    name: str
    attr: str


@dataclass(frozen=True)
class Var:
    """A bare variable name (``t`` in a motion law)."""

    name: str


@dataclass(frozen=True)
class Call:
    func: str
    args: tuple[Any, ...]


@dataclass(frozen=True)
class Unary:
    op: str
    arg: Any


@dataclass(frozen=True)
class Binary:
    """``left ^ right`` (the only binary operator that nests: it is right-associative)."""

    op: str
    left: Any
    right: Any


@dataclass(frozen=True)
class Chain:
    """``operands[0] ops[0] operands[1] ops[1] ...``, evaluated left to right; the
    operators are all ``+``/``-`` or all ``*``/``/``."""

    ops: tuple[str, ...]
    operands: tuple[Any, ...]


@dataclass(frozen=True)
class Compare:
    ops: tuple[str, ...]
    operands: tuple[Any, ...]


@dataclass(frozen=True)
class Side:
    point: str
    side: str  # "left" or "right"
    start: str
    end: str


@dataclass(frozen=True)
class BoolOp:
    op: str  # and, or
    args: tuple[Any, ...]


@dataclass(frozen=True)
class Not:
    arg: Any


def children(node: Any) -> tuple[Any, ...]:
    """The sub-expressions of a node (none for a number, a reference or a side test)."""
    if isinstance(node, (Unary, Not)):
        return (node.arg,)
    if isinstance(node, Binary):
        return (node.left, node.right)
    if isinstance(node, (Chain, Compare)):
        return node.operands
    if isinstance(node, (Call, BoolOp)):
        return node.args
    return ()


def bottom_up(tree: Any, rule: Callable[[Any, list[Any]], Any]) -> Any:
    """``rule(node, values of its children)`` over a tree, children first, with an
    explicit stack (no recursion limit); each distinct node (shared sub-trees of a
    derivative's graph) is visited once."""
    done: dict[int, Any] = {}
    stack: list[tuple[Any, bool]] = [(tree, False)]
    while stack:
        n, ready = stack.pop()
        if id(n) in done:
            continue
        kids = children(n)
        if kids and not ready:
            stack.append((n, True))
            stack.extend((k, False) for k in reversed(kids) if id(k) not in done)
            continue
        done[id(n)] = rule(n, [done[id(k)] for k in kids])
    return done[id(tree)]


def walk(tree: Any) -> Iterator[Any]:
    """Every node of a tree, parents before children, left to right (no recursion).

    A derivative shares sub-trees; a node reached twice is yielded once.
    """
    seen: set[int] = set()
    stack = [tree]
    while stack:
        node = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        yield node
        stack.extend(reversed(children(node)))


_FUNCS: dict[str, tuple[int, Callable[..., Any]]] = {
    "abs": (1, np.abs),
    "sign": (1, np.sign),
    "sqrt": (1, np.sqrt),
    "sin": (1, np.sin),
    "cos": (1, np.cos),
    "tan": (1, np.tan),
    "atan": (1, np.arctan),
    "exp": (1, np.exp),
    "log": (1, np.log),
    "deg": (1, np.degrees),
    "min": (2, np.minimum),
    "max": (2, np.maximum),
}
# functions that only some contexts provide, with their number of arguments: stroke() in
# load conditions; the reductions over a run (one argument: min, max; mean, rms, range;
# at(q, u): q at a driver value) in requirements
CONTEXT_FUNCS = {"stroke": 1, "min": 1, "max": 1, "mean": 1, "rms": 1, "range": 1, "at": 2}
REDUCTIONS = ("min", "max", "mean", "rms", "range", "at")


def _builtin(func: str, nargs: int) -> bool:
    """Whether ``func`` with ``nargs`` arguments is an element-wise built-in function."""
    return func in _FUNCS and _FUNCS[func][0] == nargs


def _arities(func: str) -> list[int]:
    out = set()
    if func in _FUNCS:
        out.add(_FUNCS[func][0])
    if func in CONTEXT_FUNCS:
        out.add(CONTEXT_FUNCS[func])
    return sorted(out)


# binding power of the infix operators, lowest first; prefix 'not' binds at 3, '-' at 7
