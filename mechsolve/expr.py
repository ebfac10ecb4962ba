"""A small, safe expression language for conditions in mechanism files.

Conditions choose the assembly branch (``"B left of O3 -> A"``) and switch loads on and
off (``"K.vx < 0"``, ``"C.vx > 0 and 0.05 <= stroke(C.x) <= 0.95"``). User text is never
passed to :func:`eval`: it is tokenised and parsed here into a small tree that can only
read the quantities a context offers and call the functions listed below.

Grammar (lowest precedence first)::

    expr    := and ('or' and)*
    and     := not ('and' not)*
    not     := 'not' not | compare
    compare := NAME ('left' | 'right') 'of' NAME '->' NAME
             | sum (('<' | '<=' | '>' | '>=' | '==' | '!=') sum)*     # chains allowed
    sum     := product (('+' | '-') product)*
    product := unary (('*' | '/') unary)*
    unary   := ('-' | '+') unary | power
    power   := atom ('^' unary)?
    atom    := NUMBER [UNIT] | NAME '.' NAME | NAME '(' [expr (',' expr)*] ')' | '(' expr ')'

Numbers are SI unless a unit follows them (``0.5 m``, ``90 deg``). ``P.x`` reads a
quantity of a point, link or slider (see :class:`Context`). Functions: ``abs``, ``sqrt``,
``min``, ``max``, ``sin``, ``cos``, ``deg`` (radians to degrees) and, where the context
supports it, ``stroke(q)``: the fraction (0..1) of ``q`` between its minimum and maximum
over the sweep.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from .units import UnitError, parse_unit


class ExprError(ValueError):
    """A condition that does not parse or refers to something unknown."""


_TOKEN_RE = re.compile(
    r"\s*(?:"
    r"(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"
    r"|(?P<op>->|<=|>=|==|!=|\*\*|[-+*/^<>().,])"
    r")"
)

_KEYWORDS = {"and", "or", "not", "left", "right", "of"}
_CMP = {"<", "<=", ">", ">=", "==", "!="}


@dataclass(frozen=True)
class Token:
    kind: str  # num, name, op, end
    text: str
    pos: int


def tokenize(text: str) -> list[Token]:
    """Split ``text`` into tokens; raise :class:`ExprError` at the first bad character."""
    tokens: list[Token] = []
    pos = 0
    while pos < len(text):
        if text[pos:].strip() == "":
            break
        m = _TOKEN_RE.match(text, pos)
        if not m or m.end() == pos:
            col = pos + len(text[pos:]) - len(text[pos:].lstrip())
            raise ExprError(f"unexpected character {text[col]!r} at column {col + 1} in {text!r}")
        kind = m.lastgroup or "op"
        value = m.group(kind)
        start = m.start(kind)
        if value == "**":
            value = "^"
        tokens.append(Token(kind, value, start))
        pos = m.end()
    tokens.append(Token("end", "", len(text)))
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


@dataclass(frozen=True)
class Num:
    value: float


@dataclass(frozen=True)
class Ref:
    name: str
    attr: str


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
    op: str
    left: Any
    right: Any


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


_FUNCS: dict[str, tuple[int, Callable[..., Any]]] = {
    "abs": (1, np.abs),
    "sqrt": (1, np.sqrt),
    "sin": (1, np.sin),
    "cos": (1, np.cos),
    "deg": (1, np.degrees),
    "min": (2, np.minimum),
    "max": (2, np.maximum),
}
CONTEXT_FUNCS = {"stroke": 1}


class _Parser:
    def __init__(self, text: str) -> None:
        self.text = text
        self.tokens = tokenize(text)
        self.i = 0

    @property
    def tok(self) -> Token:
        return self.tokens[self.i]

    def peek(self, k: int = 1) -> Token:
        return self.tokens[min(self.i + k, len(self.tokens) - 1)]

    def fail(self, message: str, tok: Token | None = None) -> ExprError:
        tok = tok or self.tok
        where = "at the end" if tok.kind == "end" else f"at column {tok.pos + 1}"
        return ExprError(f"{message} {where} of {self.text!r}")

    def take(self, text: str) -> Token:
        if self.tok.text != text or self.tok.kind == "num":
            found = repr(self.tok.text) if self.tok.kind != "end" else "the end"
            raise self.fail(f"expected {text!r} but found {found}")
        tok = self.tok
        self.i += 1
        return tok

    def is_word(self, word: str) -> bool:
        return self.tok.kind == "name" and self.tok.text == word

    def parse(self) -> Any:
        if self.tok.kind == "end":
            raise ExprError("the condition is empty")
        node = self.or_()
        if self.tok.kind != "end":
            raise self.fail(f"unexpected {self.tok.text!r}")
        return node

    def or_(self) -> Any:
        args = [self.and_()]
        while self.is_word("or"):
            self.i += 1
            args.append(self.and_())
        return args[0] if len(args) == 1 else BoolOp("or", tuple(args))

    def and_(self) -> Any:
        args = [self.not_()]
        while self.is_word("and"):
            self.i += 1
            args.append(self.not_())
        return args[0] if len(args) == 1 else BoolOp("and", tuple(args))

    def not_(self) -> Any:
        if self.is_word("not"):
            self.i += 1
            return Not(self.not_())
        return self.compare()

    def name(self) -> str:
        if self.tok.kind != "name" or self.tok.text in _KEYWORDS:
            raise self.fail("expected a point name")
        t = self.tok.text
        self.i += 1
        return t

    def compare(self) -> Any:
        if self.tok.kind == "name" and self.peek().text in ("left", "right"):
            point = self.name()
            side = self.tok.text
            self.i += 1
            self.take("of")
            start = self.name()
            self.take("->")
            end = self.name()
            return Side(point, side, start, end)
        operands = [self.sum()]
        ops = []
        while self.tok.kind == "op" and self.tok.text in _CMP:
            ops.append(self.tok.text)
            self.i += 1
            operands.append(self.sum())
        if not ops:
            return operands[0]
        return Compare(tuple(ops), tuple(operands))

    def sum(self) -> Any:
        node = self.product()
        while self.tok.kind == "op" and self.tok.text in ("+", "-"):
            op = self.tok.text
            self.i += 1
            node = Binary(op, node, self.product())
        return node

    def product(self) -> Any:
        node = self.unary()
        while self.tok.kind == "op" and self.tok.text in ("*", "/"):
            op = self.tok.text
            self.i += 1
            node = Binary(op, node, self.unary())
        return node

    def unary(self) -> Any:
        if self.tok.kind == "op" and self.tok.text in ("-", "+"):
            op = self.tok.text
            self.i += 1
            arg = self.unary()
            return Unary(op, arg) if op == "-" else arg
        return self.power()

    def power(self) -> Any:
        node = self.atom()
        if self.tok.kind == "op" and self.tok.text == "^":
            self.i += 1
            node = Binary("^", node, self.unary())
        return node

    def atom(self) -> Any:
        tok = self.tok
        if tok.kind == "num":
            self.i += 1
            value = float(tok.text)
            if (
                self.tok.kind == "name"
                and self.tok.text not in _KEYWORDS
                and (self.peek().text not in (".", "("))
            ):
                unit_tok = self.tok
                self.i += 1
                try:
                    value *= parse_unit(unit_tok.text).factor
                except UnitError as exc:
                    raise self.fail(str(exc), unit_tok) from None
            return Num(value)
        if tok.kind == "op" and tok.text == "(":
            self.i += 1
            node = self.or_()
            self.take(")")
            return node
        if tok.kind == "name" and tok.text not in _KEYWORDS:
            self.i += 1
            if self.tok.text == "(":
                func = tok.text
                if func not in _FUNCS and func not in CONTEXT_FUNCS:
                    known = ", ".join(sorted(list(_FUNCS) + list(CONTEXT_FUNCS)))
                    raise self.fail(f"unknown function {func!r} (known: {known})", tok)
                self.i += 1
                args = []
                if self.tok.text != ")":
                    args.append(self.or_())
                    while self.tok.text == ",":
                        self.i += 1
                        args.append(self.or_())
                self.take(")")
                want = _FUNCS[func][0] if func in _FUNCS else CONTEXT_FUNCS[func]
                if len(args) != want:
                    raise self.fail(f"{func}() takes {want} argument(s), got {len(args)}", tok)
                return Call(func, tuple(args))
            if self.tok.text == ".":
                self.i += 1
                if self.tok.kind != "name":
                    raise self.fail(f"expected a quantity name after '{tok.text}.'")
                attr = self.tok.text
                self.i += 1
                return Ref(tok.text, attr)
            raise self.fail(
                f"{tok.text!r} needs a quantity, e.g. '{tok.text}.x' or '{tok.text}.vx'", tok
            )
        found = "the end" if tok.kind == "end" else repr(tok.text)
        raise self.fail(f"expected a number, a quantity or '(' but found {found}")


class Expression:
    """A parsed condition or formula.

    Parameters
    ----------
    text
        The source text, e.g. ``"K.vx < 0"``.
    """

    def __init__(self, text: str) -> None:
        if not isinstance(text, str):
            raise ExprError(f"a condition must be text, got {text!r}")
        self.text = text
        self.tree = _Parser(text).parse()

    def __repr__(self) -> str:
        return f"Expression({self.text!r})"

    def refs(self) -> list[Ref | Side]:
        """Every quantity reference and side predicate in the expression."""
        out: list[Ref | Side] = []

        def walk(n: Any) -> None:
            if isinstance(n, (Ref, Side)):
                out.append(n)
            elif isinstance(n, (Call, BoolOp)):
                for a in n.args:
                    walk(a)
            elif isinstance(n, Compare):
                for a in n.operands:
                    walk(a)
            elif isinstance(n, Binary):
                walk(n.left)
                walk(n.right)
            elif isinstance(n, (Unary, Not)):
                walk(n.arg)

        walk(self.tree)
        return out

    def points(self) -> set[str]:
        """Names of the points, links and sliders the expression reads."""
        names: set[str] = set()
        for r in self.refs():
            if isinstance(r, Ref):
                names.add(r.name)
            else:
                names.update((r.point, r.start, r.end))
        return names

    def uses(self, func: str) -> bool:
        found = False

        def walk(n: Any) -> None:
            nonlocal found
            if isinstance(n, Call):
                found = found or n.func == func
                for a in n.args:
                    walk(a)
            elif isinstance(n, BoolOp):
                for a in n.args:
                    walk(a)
            elif isinstance(n, Compare):
                for a in n.operands:
                    walk(a)
            elif isinstance(n, Binary):
                walk(n.left)
                walk(n.right)
            elif isinstance(n, (Unary, Not)):
                walk(n.arg)

        walk(self.tree)
        return found

    def evaluate(self, ctx: Context, functions: dict[str, Callable[..., Any]] | None = None) -> Any:
        """Evaluate over the arrays the context provides (element-wise)."""
        funcs = functions or {}
        return _eval(self.tree, ctx, funcs)

    def is_condition(self) -> bool:
        """True if the expression yields true/false (a comparison or logic)."""
        return isinstance(self.tree, (Compare, Side, BoolOp, Not))


def _eval(n: Any, ctx: Context, funcs: dict[str, Callable[..., Any]]) -> Any:
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
    if isinstance(n, Unary):
        return -_eval(n.arg, ctx, funcs)
    if isinstance(n, Not):
        return np.logical_not(_eval(n.arg, ctx, funcs))
    if isinstance(n, Binary):
        a = _eval(n.left, ctx, funcs)
        b = _eval(n.right, ctx, funcs)
        with np.errstate(divide="ignore", invalid="ignore"):
            if n.op == "+":
                return a + b
            if n.op == "-":
                return a - b
            if n.op == "*":
                return a * b
            if n.op == "/":
                return np.divide(a, b)
            return np.power(a, b)
    if isinstance(n, Compare):
        vals = [_eval(o, ctx, funcs) for o in n.operands]
        result: Any = True
        for op, a, b in zip(n.ops, vals[:-1], vals[1:]):
            if op == "<":
                r = np.less(a, b)
            elif op == "<=":
                r = np.less_equal(a, b)
            elif op == ">":
                r = np.greater(a, b)
            elif op == ">=":
                r = np.greater_equal(a, b)
            elif op == "==":
                r = np.equal(a, b)
            else:
                r = np.not_equal(a, b)
            result = np.logical_and(result, r)
        return result
    if isinstance(n, BoolOp):
        vals = [_eval(a, ctx, funcs) for a in n.args]
        f = np.logical_and if n.op == "and" else np.logical_or
        out = vals[0]
        for v in vals[1:]:
            out = f(out, v)
        return out
    if isinstance(n, Call):
        args = [_eval(a, ctx, funcs) for a in n.args]
        if n.func in _FUNCS:
            return _FUNCS[n.func][1](*args)
        if n.func in funcs:
            return funcs[n.func](*args)
        raise ExprError(f"{n.func}() is not available here")
    raise AssertionError(f"unknown node {n!r}")


def parse_all(texts: Sequence[str]) -> list[Expression]:
    """Parse several conditions."""
    return [Expression(t) for t in texts]
