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

Expressions are read from files that nobody vetted (CI runs them on pull requests), so
the language is bounded: a text of at most :data:`MAX_LENGTH` characters, nested at most
:data:`MAX_DEPTH` levels (each parenthesis, function call, prefix ``-`` or ``not`` and
``^`` opens one), and only finite numbers. The parser is an operator-precedence parser
with explicit stacks, and every walk of the tree (references, evaluation) is iterative:
nothing depends on Python's recursion limit.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from .units import UnitError, parse_unit

MAX_LENGTH = 4000  # characters of one expression
MAX_DEPTH = 64  # nesting levels: parentheses, function calls, prefix '-' and 'not', '^'


class ExprError(ValueError):
    """A condition that does not parse or refers to something unknown."""


_SPACE_RE = re.compile(r"\s*")
_TOKEN_RE = re.compile(
    r"(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"
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
            raise ExprError(
                f"unexpected character {text[pos]!r} at column {pos + 1} in {_show(text)}"
            )
        kind = m.lastgroup or "op"
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


def walk(tree: Any) -> Iterator[Any]:
    """Every node of a tree, parents before children, left to right (no recursion)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(reversed(children(node)))


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

# binding power of the infix operators, lowest first; prefix 'not' binds at 3, '-' at 7
_PREC = {"or": 1, "and": 2, **dict.fromkeys(_CMP, 4), "+": 5, "-": 5, "*": 6, "/": 6, "^": 8}
_NOT_PREC = 3
_NEG_PREC = 7
_NESTING = ("paren", "call", "not", "neg", "pow")  # frames that open a nesting level


@dataclass
class _Frame:
    """An operator or an open parenthesis waiting on the operator stack."""

    kind: str  # paren, call, not, neg, pow, chain
    prec: int = 0
    ops: list[str] = field(default_factory=list)
    tok: Token | None = None
    args: int = 0  # a call's arguments before the current one


class _Parser:
    """An operator-precedence (shunting-yard) parser with explicit stacks."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.tokens = tokenize(text)
        self.i = 0

    @property
    def tok(self) -> Token:
        return self.tokens[self.i]

    def fail(self, message: str, tok: Token | None = None) -> ExprError:
        tok = tok or self.tok
        where = "at the end" if tok.kind == "end" else f"at column {tok.pos + 1}"
        return ExprError(f"{message} {where} of {_show(self.text)}")

    def take(self, text: str) -> Token:
        if self.tok.text != text or self.tok.kind == "num":
            found = repr(self.tok.text) if self.tok.kind != "end" else "the end"
            raise self.fail(f"expected {text!r} but found {found}")
        tok = self.tok
        self.i += 1
        return tok

    def name(self) -> str:
        if self.tok.kind != "name" or self.tok.text in _KEYWORDS:
            raise self.fail("expected a point name")
        t = self.tok.text
        self.i += 1
        return t

    def parse(self) -> Any:
        if self.tok.kind == "end":
            raise ExprError("the condition is empty")
        out: list[Any] = []  # operands, and the nodes built from them
        ops: list[_Frame] = []
        depth = 0
        expect_operand = True
        logic_ok = True  # 'not' and 'P left of A -> B' may stand here
        after_side = False

        def push(frame: _Frame) -> None:
            nonlocal depth
            if frame.kind in _NESTING:
                depth += 1
                if depth > MAX_DEPTH:
                    raise self.fail(
                        f"the expression nests deeper than {MAX_DEPTH} levels (each '(', "
                        "function call, '-', 'not' and '^' opens one)"
                    )
            ops.append(frame)

        def reduce() -> None:
            nonlocal depth
            fr = ops.pop()
            if fr.kind in _NESTING:
                depth -= 1
            if fr.kind == "neg":
                out[-1] = Unary("-", out[-1])
            elif fr.kind == "not":
                out[-1] = Not(out[-1])
            elif fr.kind == "pow":
                right = out.pop()
                out[-1] = Binary("^", out[-1], right)
            else:  # chain
                k = len(fr.ops) + 1
                args = tuple(out[-k:])
                del out[-k:]
                op = fr.ops[0]
                if op in ("and", "or"):
                    out.append(BoolOp(op, args))
                elif op in _CMP:
                    out.append(Compare(tuple(fr.ops), args))
                else:
                    out.append(Chain(tuple(fr.ops), args))

        def reduce_above(prec: int) -> None:
            while ops and ops[-1].kind not in ("paren", "call") and ops[-1].prec > prec:
                reduce()

        while True:
            tok = self.tok
            if expect_operand:
                if tok.kind == "op" and tok.text == "(":
                    push(_Frame("paren", tok=tok))
                    self.i += 1
                    logic_ok = True
                elif tok.kind == "name" and tok.text == "not" and logic_ok:
                    push(_Frame("not", _NOT_PREC, tok=tok))
                    self.i += 1
                elif tok.kind == "op" and tok.text in ("-", "+"):
                    if tok.text == "-":
                        push(_Frame("neg", _NEG_PREC, tok=tok))
                    self.i += 1
                    logic_ok = False
                else:
                    out.append(self.operand(logic_ok, push))
                    if out[-1] is None:  # a function call opened: its arguments follow
                        out.pop()
                        logic_ok = True
                        continue
                    after_side = isinstance(out[-1], Side)
                    expect_operand = False
                continue
            t = tok.text
            is_logic = tok.kind == "name" and t in ("and", "or")
            if tok.kind == "end":
                break
            if after_side and not is_logic and t not in (")", ","):
                raise self.fail(f"unexpected {t!r}")
            after_side = False
            if is_logic or (tok.kind == "op" and t in _PREC):
                prec = _PREC[t]
                reduce_above(prec)
                if t == "^":
                    push(_Frame("pow", prec, tok=tok))
                elif ops and ops[-1].kind == "chain" and ops[-1].prec == prec:
                    ops[-1].ops.append(t)
                else:
                    push(_Frame("chain", prec, ops=[t], tok=tok))
                self.i += 1
                expect_operand = True
                logic_ok = is_logic
            elif tok.kind == "op" and t in (",", ")"):
                reduce_above(0)
                if not ops or (t == "," and ops[-1].kind != "call"):
                    raise self.fail(f"unexpected {t!r}")
                self.i += 1
                if t == ",":
                    ops[-1].args += 1
                    expect_operand = True
                    logic_ok = True
                    continue
                fr = ops.pop()
                depth -= 1
                if fr.kind == "call":
                    assert fr.tok is not None
                    k = fr.args + 1
                    args = tuple(out[-k:])
                    del out[-k:]
                    out.append(self.call(fr.tok, args))
            else:
                raise self.fail(f"unexpected {t!r}")
        reduce_above(0)
        if ops:
            raise self.fail("expected ')' but found the end")
        assert len(out) == 1
        return out[0]

    def call(self, tok: Token, args: tuple[Any, ...]) -> Call:
        func = tok.text
        want = _FUNCS[func][0] if func in _FUNCS else CONTEXT_FUNCS[func]
        if len(args) != want:
            raise self.fail(f"{func}() takes {want} argument(s), got {len(args)}", tok)
        return Call(func, args)

    def operand(self, logic_ok: bool, push: Callable[[_Frame], None]) -> Any:
        """Read a number, a quantity or a side test; or open a function call (``None``)."""
        tok = self.tok
        if tok.kind == "num":
            self.i += 1
            value = float(tok.text)
            shown = tok.text
            nxt = self.tokens[min(self.i + 1, len(self.tokens) - 1)]
            if (
                self.tok.kind == "name"
                and self.tok.text not in _KEYWORDS
                and nxt.text not in (".", "(")
            ):
                unit_tok = self.tok
                shown += " " + unit_tok.text
                self.i += 1
                try:
                    value *= parse_unit(unit_tok.text).factor
                except UnitError as exc:
                    raise self.fail(str(exc), unit_tok) from None
            if not math.isfinite(value):
                if len(shown) > 30:
                    shown = shown[:20] + "..."
                raise self.fail(f"{shown} is not a finite number (too large)", tok)
            return Num(value)
        if tok.kind == "name" and tok.text not in _KEYWORDS:
            nxt = self.tokens[self.i + 1]
            if logic_ok and nxt.kind == "name" and nxt.text in ("left", "right"):
                point = self.name()
                self.i += 1
                self.take("of")
                start = self.name()
                self.take("->")
                return Side(point, nxt.text, start, self.name())
            self.i += 1
            if nxt.text == "(":
                func = tok.text
                if func not in _FUNCS and func not in CONTEXT_FUNCS:
                    known = ", ".join(sorted(list(_FUNCS) + list(CONTEXT_FUNCS)))
                    raise self.fail(f"unknown function {func!r} (known: {known})", tok)
                push(_Frame("call", tok=tok))
                self.i += 1
                if self.tok.text == ")":
                    raise self.fail(
                        f"{func}() takes {_FUNCS.get(func, (1,))[0]} argument(s), got 0", tok
                    )
                return None
            if nxt.text == ".":
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
        The source text, e.g. ``"K.vx < 0"``; at most :data:`MAX_LENGTH` characters,
        nested at most :data:`MAX_DEPTH` levels.
    """

    def __init__(self, text: str) -> None:
        if not isinstance(text, str):
            shown = repr(text)
            if len(shown) > 60:
                shown = shown[:57] + "..."
            raise ExprError(f"a condition must be text, got {shown}")
        self.text = text
        self.tree = _Parser(text).parse()

    def __repr__(self) -> str:
        return f"Expression({self.text!r})"

    def refs(self) -> list[Ref | Side]:
        """Every quantity reference and side predicate in the expression."""
        return [n for n in walk(self.tree) if isinstance(n, (Ref, Side))]

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
        """True if the expression calls the function ``func``."""
        return any(isinstance(n, Call) and n.func == func for n in walk(self.tree))

    def evaluate(self, ctx: Context, functions: dict[str, Callable[..., Any]] | None = None) -> Any:
        """Evaluate over the arrays the context provides (element-wise)."""
        funcs = functions or {}
        with np.errstate(all="ignore"):  # inf and nan follow IEEE rules; no warnings
            return _eval(self.tree, ctx, funcs)

    def is_condition(self) -> bool:
        """True if the expression yields true/false (a comparison or logic)."""
        return isinstance(self.tree, (Compare, Side, BoolOp, Not))


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
    raise AssertionError(f"unknown node {n!r}")


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
        if n.func in _FUNCS:
            return _FUNCS[n.func][1](*vals)
        if n.func in funcs:
            return funcs[n.func](*vals)
        raise ExprError(f"{n.func}() is not available here")
    raise AssertionError(f"unknown node {n!r}")


def _eval(tree: Any, ctx: Context, funcs: dict[str, Callable[..., Any]]) -> Any:
    """Evaluate a tree bottom-up with an explicit stack (no recursion)."""
    vals: list[Any] = []
    stack: list[tuple[Any, bool]] = [(tree, False)]
    while stack:
        n, ready = stack.pop()
        kids = children(n)
        if not kids:
            vals.append(_leaf(n, ctx))
        elif ready:
            k = len(kids)
            args = vals[-k:]
            del vals[-k:]
            vals.append(_combine(n, args, funcs))
        else:
            stack.append((n, True))
            stack.extend((kid, False) for kid in reversed(kids))
    assert len(vals) == 1
    return vals[0]


def parse_all(texts: Sequence[str]) -> list[Expression]:
    """Parse several conditions."""
    return [Expression(t) for t in texts]
