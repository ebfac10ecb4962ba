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
             | VARIABLE                                       # only where allowed

Numbers are SI unless a unit follows them (``0.5 m``, ``90 deg``). ``P.x`` reads a
quantity of a point, link or slider (see :class:`Context`). Functions: ``abs``, ``sign``,
``sqrt``, ``min``, ``max``, ``sin``, ``cos``, ``tan``, ``atan``, ``exp``, ``log`` (natural),
``deg`` (radians to degrees) and, where the context supports it, ``stroke(q)``: the
fraction (0..1) of ``q`` between its minimum and maximum over the sweep.

Whatever is compared, added or given to ``max(a, b)`` must be of one kind:
:func:`dimension_of` finds the dimension of every value (numbers keep their unit's, a
bare number is SI of what it meets) and raises :class:`DimensionError` for
``"K.vx > 0.1 m"``.

A driver's motion law is an expression of time: ``Expression("0.3 + 2 * t", variables=
("t",))`` accepts the bare name ``t``; :meth:`Expression.derivative` differentiates it
symbolically and :meth:`Expression.evaluate_at` evaluates it for arrays of ``t``.

Expressions are read from files that nobody vetted (CI runs them on pull requests), so
the language is bounded: a text of at most :data:`MAX_LENGTH` characters, nested at most
:data:`MAX_DEPTH` levels (each parenthesis, function call, prefix ``-`` or ``not`` and
``^`` opens one), and only finite numbers. The parser is an operator-precedence parser
with explicit stacks, and every walk of the tree (references, evaluation,
differentiation, printing) is iterative: nothing depends on Python's recursion limit. A
derivative shares sub-trees with its expression (it is a graph, not a tree) and is capped
at :data:`MAX_NODES`.
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
MAX_NODES = 100_000  # nodes plus operand links one derivative may build


class ExprError(ValueError):
    """A condition that does not parse or refers to something unknown."""


_SPACE_RE = re.compile(r"\s*")
_TOKEN_RE = re.compile(
    r"(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
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

    def __init__(self, text: str, variables: tuple[str, ...] = ()) -> None:
        self.text = text
        self.variables = variables
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
        want = _arities(func)
        if len(args) not in want:
            counts = " or ".join(str(w) for w in sorted(want))
            raise self.fail(f"{func}() takes {counts} argument(s), got {len(args)}", tok)
        return Call(func, args)

    def unit_run(self) -> tuple[str, int]:
        """The longest unit after a number, as textbooks write it (``kN m``, ``kg m^2``,
        ``m/s^2``, ``N*m``), from the current token; ``(text, index after it)``. When no
        longer run is a unit, the single name (whose error the caller reports)."""
        toks = self.tokens

        def unit_name(k: int) -> bool:
            t = toks[k]
            return (
                t.kind == "name"
                and t.text not in _KEYWORDS
                and t.text not in self.variables
                and toks[min(k + 1, len(toks) - 1)].text not in (".", "(")
            )

        j = self.i
        text = toks[j].text
        best = (text, j + 1)
        j += 1
        while True:
            t = toks[j]
            if t.text == "^" and toks[j + 1].kind == "num":
                text, j = text + "^" + toks[j + 1].text, j + 2
            elif t.text in ("*", "/") and unit_name(j + 1):
                text, j = text + t.text + toks[j + 1].text, j + 2
            elif unit_name(j):
                text, j = text + " " + t.text, j + 1
            else:
                break
            try:
                parse_unit(text)
            except UnitError:
                continue
            best = (text, j)
        return best

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
                if unit_tok.text in self.variables:  # "2 t" is not 2 tonnes here
                    raise self.fail(
                        f"a number followed by the variable {unit_tok.text!r} (write "
                        f"'{tok.text} * {unit_tok.text}')",
                        unit_tok,
                    )
                text, end = self.unit_run()
                shown += " " + text
                try:
                    unit = parse_unit(text)
                except UnitError as exc:
                    raise self.fail(str(exc), unit_tok) from None
                value *= unit.factor
                self.i = end
                if math.isfinite(value):
                    return Num(value, unit.dim, shown)
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
                    counts = " or ".join(str(w) for w in _arities(func))
                    raise self.fail(f"{func}() takes {counts} argument(s), got 0", tok)
                return None
            if nxt.text == ".":
                self.i += 1
                if self.tok.kind != "name":
                    raise self.fail(f"expected a quantity name after '{tok.text}.'")
                attr = self.tok.text
                self.i += 1
                return Ref(tok.text, attr)
            if tok.text in self.variables:
                return Var(tok.text)
            if self.variables:
                v = self.variables
                which = (
                    f"a variable here is {v[0]}"
                    if len(v) == 1
                    else ("the variables here are " + ", ".join(v))
                )
                raise self.fail(f"unknown name {tok.text!r} ({which})", tok)
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
    variables
        Bare names allowed as atoms, e.g. ``("t",)`` for a motion law of time; any other
        bare name is an error. Variables get their values from :meth:`evaluate_at`.
    """

    def __init__(self, text: str, variables: Sequence[str] = ()) -> None:
        if not isinstance(text, str):
            shown = repr(text)
            if len(shown) > 60:
                shown = shown[:57] + "..."
            raise ExprError(f"a condition must be text, got {shown}")
        self.variables = _check_variables(variables)
        self.text = text
        self.tree = _Parser(text, self.variables).parse()

    @classmethod
    def _derived(cls, tree: Any, text: str, variables: tuple[str, ...]) -> Expression:
        """An expression built from a tree (a derivative) rather than parsed."""
        e = cls.__new__(cls)
        e.variables = variables
        e.text = text
        e.tree = tree
        return e

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

    def reductions(self) -> list[str]:
        """The reductions over a run it calls (``max(q)``, ``mean(q)``, ``at(q, u)``...;
        not the element-wise ``max(a, b)``)."""
        return sorted(
            {
                n.func
                for n in walk(self.tree)
                if isinstance(n, Call)
                and n.func in REDUCTIONS
                and not _builtin(n.func, len(n.args))
            }
        )

    def evaluate(self, ctx: Context, functions: dict[str, Callable[..., Any]] | None = None) -> Any:
        """Evaluate over the arrays the context provides (element-wise)."""
        funcs = functions or {}

        def leaf(n: Any) -> Any:
            return _leaf(n, ctx)

        with np.errstate(all="ignore"):  # inf and nan follow IEEE rules; no warnings
            return _eval(self.tree, leaf, funcs)

    def evaluate_at(self, values: dict[str, Any]) -> np.ndarray:
        """Evaluate with the variables bound to arrays (element-wise, no context).

        Parameters
        ----------
        values
            An array (or number) for each variable the expression uses, e.g.
            ``{"t": np.linspace(0, 1, 11)}``.

        Returns
        -------
        numpy.ndarray
            The value at each element, with the shape the arrays broadcast to (also when
            the expression is a constant). Numbers with units are SI (``30 deg`` is
            radians). Quantities (``P.x``), side tests and ``stroke()`` are errors here.
        """
        arrays = {k: np.asarray(v) for k, v in values.items()}

        def leaf(n: Any) -> Any:
            if isinstance(n, Num):
                return n.value
            if isinstance(n, Var):
                if n.name not in arrays:
                    raise ExprError(f"no value is given for the variable {n.name!r}")
                return arrays[n.name]
            if isinstance(n, Ref):
                raise ExprError(
                    f"'{n.name}.{n.attr}' is a quantity of the mechanism; it cannot be read "
                    f"in {_show(self.text)}"
                )
            raise ExprError(f"'{n.point} {n.side} of ...' cannot be tested in {_show(self.text)}")

        with np.errstate(all="ignore"):
            out = np.asarray(_eval(self.tree, leaf, {}))
        shape = np.broadcast_shapes(out.shape, *(a.shape for a in arrays.values()))
        if out.shape != shape:
            out = np.array(np.broadcast_to(out, shape))
        return out

    def derivative(self, var: str) -> Expression:
        """The symbolic derivative with respect to the variable ``var``.

        Sums, products, quotients, powers (``u^n``, ``a^u`` and ``u^v`` as
        ``exp(v log u)``), unary minus and the chain rule for every function of the
        language. ``abs(u)' = sign(u) u'``; ``sign`` is piecewise constant (derivative
        0); ``min`` and ``max`` are differentiated piecewise,
        ``min(a, b)' = (a' + b') / 2 - sign(a - b) (a' - b') / 2`` (the mean at a tie).
        Constants are folded and ``0 * x``, ``1 * x``, ``x + 0``, ``x ^ 1`` simplified.

        Returns
        -------
        Expression
            With the same variables; its :attr:`text` is a rendering of the new tree
            (which parses back to the same values) or, when that would be longer than
            :data:`MAX_LENGTH` characters, ``"d/dt (<text of this expression>)"``.

        Raises
        ------
        ExprError
            If ``var`` is not a variable of the expression; if the expression reads a
            quantity (``P.x``), calls ``stroke()`` or is a condition (comparisons,
            ``and``/``or``/``not``, ``left of``); or if the derivative would need more
            than :data:`MAX_NODES` nodes and links ("the law is too long to
            differentiate").
        """
        if var not in self.variables:
            have = ", ".join(self.variables) if self.variables else "none"
            raise ExprError(
                f"cannot differentiate with respect to {var!r}: it is not a variable of "
                f"{_show(self.text)} (its variables: {have})"
            )
        for n in walk(self.tree):
            _check_differentiable(n, var, self.text)
        tree = _differentiate(self.tree, var, _Builder(MAX_NODES))
        text = to_text(tree, MAX_LENGTH)
        if text is None:
            text = f"d/d{var} ({self.text})"
        return Expression._derived(tree, text, self.variables)

    def to_text(self, limit: int | None = None) -> str | None:
        """The tree rendered as text of this language (``None`` if over ``limit``)."""
        return to_text(self.tree, limit)

    def dimension(
        self,
        ref_dim: Callable[[Ref], Any] | None = None,
        driver: tuple[int, int, int, int] | None = None,
    ) -> Any:
        """The dimension of the expression's value (see :func:`dimension_of`); the
        quantities it reads by their attribute (``P.vx`` a speed) unless ``ref_dim``
        says otherwise. Raises :class:`DimensionError` naming the expression where two
        values of different kinds meet."""
        try:
            return dimension_of(self.tree, ref_dim or condition_dim, driver)
        except DimensionError as exc:
            raise DimensionError(f"{_show(self.text)}: {exc}") from None

    def is_condition(self) -> bool:
        """True if the expression yields true/false (a comparison or logic)."""
        return isinstance(self.tree, (Compare, Side, BoolOp, Not))


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


def _eval(tree: Any, leaf: Callable[[Any], Any], funcs: dict[str, Callable[..., Any]]) -> Any:
    """Evaluate a tree bottom-up with an explicit stack (no recursion).

    A node shared by several parents (derivatives share sub-trees) is evaluated once; its
    value is kept only until its last parent has used it.
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
        else:
            stack.append((n, True))
            stack.extend((kid, False) for kid in reversed(kids))
            continue
        if uses.get(key, 0) > 1:
            kept[key] = [vals[-1], uses[key] - 1]
    assert len(vals) == 1
    return vals[0]


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


# --- differentiation -----------------------------------------------------------------

_ZERO = Num(0.0)
_ONE = Num(1.0)
_TWO = Num(2.0)
_HALF = Num(0.5)
_TOO_LONG = "the law is too long to differentiate"
_CONDITION_WORDS = {Compare: "a comparison", BoolOp: "'and'/'or'", Not: "'not'", Side: "'left of'"}


def _check_differentiable(n: Any, var: str, text: str) -> None:
    """Raise :class:`ExprError` for a node that has no derivative."""
    where = _show(text)
    if isinstance(n, Ref):
        raise ExprError(
            f"'{n.name}.{n.attr}' is a quantity of the mechanism, not a function of {var}: "
            f"{where} cannot be differentiated"
        )
    if isinstance(n, (Compare, BoolOp, Not, Side)):
        what = _CONDITION_WORDS[type(n)]
        if isinstance(n, Side):
            what = f"'{n.point} {n.side} of {n.start} -> {n.end}'"
        raise ExprError(
            f"{where} contains a condition ({what}): it is true or false and has no "
            f"derivative; a law must give a number for each {var}"
        )
    if isinstance(n, Call) and not _builtin(n.func, len(n.args)):
        raise ExprError(f"{n.func}() cannot be differentiated (in {where})")


def _is_num(n: Any, value: float | None = None) -> bool:
    return isinstance(n, Num) and (value is None or n.value == value)


def _var_power(n: Any) -> tuple[Var, float] | None:
    """``(t, e)`` if ``n`` is a variable ``t`` or a power ``t ^ e`` with a modest number
    ``e`` (so that sums of exponents stay finite), else ``None``."""
    if isinstance(n, Var):
        return n, 1.0
    if (
        isinstance(n, Binary)
        and isinstance(n.left, Var)
        and isinstance(n.right, Num)
        and abs(n.right.value) <= 1e6
    ):
        return n.left, n.right.value
    return None


def _fold(value: Any) -> Num | None:
    """A number node for a folded constant, or ``None`` if it is not finite."""
    v = float(value)
    return Num(v) if math.isfinite(v) else None


class _Builder:
    """Makes nodes for a derivative, simplifying as it goes and counting their size.

    Every node made costs one plus its number of operands; past ``limit`` it raises
    :class:`ExprError` ("the law is too long to differentiate").
    """

    def __init__(self, limit: int) -> None:
        self.cost = 0
        self.limit = limit

    def made(self, node: Any) -> Any:
        self.cost += 1 + len(children(node))
        if self.cost > self.limit:
            raise ExprError(_TOO_LONG)
        return node

    # sign handling: a node is a sign and a positive-looking rest
    def split_sign(self, n: Any) -> tuple[bool, Any]:
        """``(negative, rest)`` with ``n == -rest`` if negative, else ``n == rest``."""
        if isinstance(n, Num) and math.copysign(1.0, n.value) < 0:
            return True, Num(-n.value)
        if isinstance(n, Unary):
            return True, n.arg
        if isinstance(n, Chain) and n.ops[0] in ("*", "/"):
            first = n.operands[0]
            neg, rest = self.split_sign(first) if isinstance(first, (Num, Unary)) else (False, n)
            if neg:
                if _is_num(rest, 1.0) and n.ops[0] == "*":
                    if len(n.operands) == 2:
                        return True, n.operands[1]
                    return True, self.made(Chain(n.ops[1:], n.operands[1:]))
                return True, self.made(Chain(n.ops, (rest,) + n.operands[1:]))
        return False, n

    def neg(self, n: Any) -> Any:
        negative, rest = self.split_sign(n)
        if negative:
            return rest
        if isinstance(n, Num):
            return Num(-n.value) if n.value != 0 else _ZERO
        return self.mul([Num(-1.0), n])

    def add(self, terms: list[tuple[bool, Any]]) -> Any:
        """The sum of ``terms``, each ``(negative, node)``; nested sums are flattened."""
        flat: list[tuple[bool, Any]] = []
        const = 0.0
        consts: list[tuple[bool, Any]] = []  # kept apart if folding overflows
        for negative, t in terms:
            if isinstance(t, Chain) and t.ops[0] in ("+", "-"):
                parts = [(negative, t.operands[0])]
                parts += [(negative != (op == "-"), a) for op, a in zip(t.ops, t.operands[1:])]
            else:
                parts = [(negative, t)]
            for ng, a in parts:
                sign_neg, rest = self.split_sign(a)
                ng = ng != sign_neg
                if isinstance(rest, Num):
                    folded = _fold(const - rest.value if ng else const + rest.value)
                    if folded is None:
                        consts.append((ng, rest))
                    else:
                        const = folded.value
                else:
                    flat.append((ng, rest))
        if const != 0.0:
            flat.append((const < 0, Num(abs(const))))
        flat += consts
        if not flat:
            return _ZERO
        first = next((i for i, (ng, _) in enumerate(flat) if not ng), 0)
        flat.insert(0, flat.pop(first))  # start with a positive term if there is one
        ng, head = flat[0]
        if ng:
            head = self.neg(head)
        if len(flat) == 1:
            return head
        ops = tuple("-" if ng else "+" for ng, _ in flat[1:])
        return self.made(Chain(ops, (head,) + tuple(a for _, a in flat[1:])))

    def sub(self, a: Any, b: Any) -> Any:
        return self.add([(False, a), (True, b)])

    def mul(self, num: list[Any], den: list[Any] | None = None) -> Any:
        """``num[0] * num[1] * ... / den[0] / den[1] ...``, flattened and folded."""
        top: list[Any] = []
        bottom: list[Any] = []
        coef = 1.0
        work = [(False, f) for f in num] + [(True, f) for f in den or ()]
        for below, f in work:
            if isinstance(f, Chain) and f.ops[0] in ("*", "/"):
                parts = [(below, f.operands[0])]
                parts += [(below != (op == "/"), a) for op, a in zip(f.ops, f.operands[1:])]
            else:
                parts = [(below, f)]
            for bl, a in parts:
                negative, rest = self.split_sign(a)
                if negative:
                    coef = -coef
                if isinstance(rest, Num):
                    if rest.value == 0.0 and not bl:
                        return _ZERO  # 0 * x -> 0 (symbolically, whatever x is)
                    if rest.value == 1.0:
                        continue
                    if rest.value != 0.0:  # x / 0 stays as it is
                        folded = _fold(coef / rest.value if bl else coef * rest.value)
                        if folded is not None:
                            coef = folded.value
                            continue
                (bottom if bl else top).append(rest)
        if sum(_var_power(f) is not None for f in top + bottom) > 1:  # t * t -> t ^ 2
            both = top + bottom
            below = [False] * len(top) + [True] * len(bottom)
            grouped, _ = self.group_powers(both, below, [_ZERO] * len(both), "")
            top = [f for bl, f in grouped if not bl]
            bottom = [f for bl, f in grouped if bl]
        if not top and not bottom:
            return Num(coef)
        factors: list[Any] = list(top)
        if abs(coef) != 1.0 or not top:
            factors.insert(0, Num(abs(coef)))
        if coef < 0:
            factors[0] = (
                Num(-factors[0].value)
                if isinstance(factors[0], Num)
                else (self.made(Unary("-", factors[0])))
            )
        if not bottom and len(factors) == 1:
            return factors[0]
        ops = ("*",) * (len(factors) - 1) + ("/",) * len(bottom)
        return self.made(Chain(ops, tuple(factors) + tuple(bottom)))

    def group_powers(
        self, operands: Sequence[Any], below: list[bool], d: list[Any], var: str
    ) -> tuple[list[tuple[bool, Any]], list[Any]]:
        """The factors of a product, ``(divides, factor)``, and their derivatives, with
        the powers of each variable gathered into one: ``t * t / t ^ 3 -> t ^ -1``.

        Without this the product rule on ``t * t * ... * t`` (n factors) would build n
        terms of n - 1 factors each.
        """
        factors: list[tuple[bool, Any]] = []
        derivs: list[Any] = []
        total: dict[str, list[Any]] = {}  # name -> [Var node, exponent, index in factors]
        for bl, a, da in zip(below, operands, d):
            vp = _var_power(a)
            if vp is None:
                factors.append((bl, a))
                derivs.append(da)
                continue
            v, e = vp
            if v.name not in total:
                total[v.name] = [v, 0.0, len(factors)]
                factors.append((False, v))  # replaced below
                derivs.append(_ZERO)
            total[v.name][1] += -e if bl else e
        drop: set[int] = set()
        for v, e, i in total.values():
            if e == 0.0:  # t / t: gone (symbolically)
                drop.add(i)
                continue
            factors[i] = (False, self.power(v, Num(e)))
            if v.name == var:  # (t^e)' = e t^(e-1)
                derivs[i] = self.mul([Num(e), self.power(v, Num(e - 1.0))])
        if drop:
            factors = [f for i, f in enumerate(factors) if i not in drop]
            derivs = [x for i, x in enumerate(derivs) if i not in drop]
        self.cost += len(factors)
        return factors, derivs

    def power(self, base: Any, exponent: Any) -> Any:
        if _is_num(exponent, 0.0):
            return _ONE
        if _is_num(exponent, 1.0):
            return base
        if isinstance(base, Num) and isinstance(exponent, Num):
            with np.errstate(all="ignore"):
                folded = _fold(np.power(base.value, exponent.value))
            if folded is not None:
                return folded
        return self.made(Binary("^", base, exponent))

    def call(self, func: str, *args: Any) -> Any:
        if all(isinstance(a, Num) for a in args):
            with np.errstate(all="ignore"):
                folded = _fold(_FUNCS[func][1](*(a.value for a in args)))
            if folded is not None:
                return folded
        return self.made(Call(func, args))

    def rule(self, n: Any, d: list[Any], var: str) -> Any:
        """The derivative of node ``n`` given the derivatives ``d`` of its operands."""
        if isinstance(n, Num):
            return _ZERO
        if isinstance(n, Var):
            return _ONE if n.name == var else _ZERO
        if isinstance(n, Unary):
            return self.neg(d[0])
        if isinstance(n, Chain) and n.ops[0] in ("+", "-"):
            return self.add([(False, d[0])] + [(op == "-", x) for op, x in zip(n.ops, d[1:])])
        if isinstance(n, Chain):  # product rule; a divisor v contributes -v'/v^2
            below = [False] + [op == "/" for op in n.ops]
            factors, derivs = self.group_powers(n.operands, below, d, var)
            terms: list[tuple[bool, Any]] = []
            for i, di in enumerate(derivs):
                if _is_num(di, 0.0):
                    continue
                num = [a for j, (bl, a) in enumerate(factors) if not bl and j != i]
                den = [a for j, (bl, a) in enumerate(factors) if bl and j != i]
                if factors[i][0]:
                    den.append(self.power(factors[i][1], _TWO))
                terms.append((factors[i][0], self.mul([di, *num], den)))
            return self.add(terms)
        if isinstance(n, Binary):  # u ^ v
            u, v = n.left, n.right
            du, dv = d
            terms = []
            if not _is_num(du, 0.0):  # v u^(v-1) u'
                terms.append((False, self.mul([v, self.power(u, self.sub(v, _ONE)), du])))
            if not _is_num(dv, 0.0):  # u^v log(u) v'
                terms.append((False, self.mul([n, self.call("log", u), dv])))
            return self.add(terms)
        if isinstance(n, Call):
            return self.chain_rule(n, d)
        raise AssertionError(f"no derivative for {type(n).__name__}")

    def chain_rule(self, n: Call, d: list[Any]) -> Any:
        f = n.func
        if f in ("min", "max"):
            a, b = n.args
            da, db = d
            if _is_num(da, 0.0) and _is_num(db, 0.0):
                return _ZERO
            # min(a,b)' = (a'+b')/2 - sign(a-b) (a'-b')/2; max: + instead of -
            mean = self.mul([_HALF, self.add([(False, da), (False, db)])])
            jump = self.mul([_HALF, self.call("sign", self.sub(a, b)), self.sub(da, db)])
            return self.add([(False, mean), (f == "min", jump)])
        u, du = n.args[0], d[0]
        if _is_num(du, 0.0) or f == "sign":
            return _ZERO
        if f == "deg":  # linear
            return self.call("deg", du)
        if f == "abs":
            return self.mul([self.call("sign", u), du])
        if f == "sqrt":
            return self.mul([_HALF, du], [n])
        if f == "sin":
            return self.mul([self.call("cos", u), du])
        if f == "cos":
            return self.neg(self.mul([self.call("sin", u), du]))
        if f == "tan":
            return self.mul([du], [self.power(self.call("cos", u), _TWO)])
        if f == "atan":
            return self.mul([du], [self.add([(False, _ONE), (False, self.power(u, _TWO))])])
        if f == "exp":
            return self.mul([n, du])
        if f == "log":
            return self.mul([du], [u])
        raise AssertionError(f"no derivative for {f}()")


def _differentiate(tree: Any, var: str, b: _Builder) -> Any:
    """The derivative of ``tree`` by ``var``, bottom-up with an explicit stack.

    Each distinct node is differentiated once (second derivatives differentiate a graph
    whose sub-trees are shared).
    """
    return bottom_up(tree, lambda n, kids: b.rule(n, kids, var))


# --- dimensions ----------------------------------------------------------------------
# Every value of an expression has a dimension (exponents of length, mass, time, angle,
# as in mechsolve.units). Two values that are compared, added, subtracted or given to
# max(a, b) must be of one kind: "max(B.y) <= 1 kg" is an input error, found before
# anything is solved. A number without a unit is SI: it takes the kind of whatever it
# meets ("K.vx < 0", "min(transmission_angle.B) >= 0.5" is 0.5 rad) and is a pure number
# in a product ("2 * 150 kN m" is a torque). An angle counts as a dimension of its own,
# except that a unit without the radian may stand for one with it where more than an
# angle is involved ("2 1/s" for an angular speed, as mechsolve.units reads it); a pure
# angle and a pure number are of two kinds ("deg(q) <= 100 deg" mixes degrees with
# radians). The variables of a law (t, omega, angle) and what is computed from them are
# of no known kind: a law's bare coefficients carry its units ("0.3 + 2 * t" rad), so
# only the kinds of its numbers with units are checked ("5 N - 0.1 * omega" is a force).

Dim = tuple[int, int, int, int]
BARE = "bare"  # numbers without units: SI of whatever they meet
UNKNOWN = "unknown"  # a quantity whose kind is not known here: not checked
TRUTH = "truth"  # a condition
_PURE: Dim = (0, 0, 0, 0)
_ANGLE: Dim = (0, 0, 0, 1)

# the kind of each quantity a condition reads (P.x, crank.omega, ram_guide.s ...)
QUANTITY_DIMS: dict[str, Dim] = {
    "x": (1, 0, 0, 0),
    "y": (1, 0, 0, 0),
    "s": (1, 0, 0, 0),
    "vx": (1, 0, -1, 0),
    "vy": (1, 0, -1, 0),
    "v": (1, 0, -1, 0),
    "ax": (1, 0, -2, 0),
    "ay": (1, 0, -2, 0),
    "a": (1, 0, -2, 0),
    "angle": (0, 0, 0, 1),
    "omega": (0, 0, -1, 1),
    "alpha": (0, 0, -2, 1),
}

_DIM_WORDS: dict[Dim, tuple[str, str]] = {
    (0, 0, 0, 0): ("dimensionless", ""),
    (1, 0, 0, 0): ("a length", "m, mm"),
    (0, 1, 0, 0): ("a mass", "kg"),
    (0, 0, 1, 0): ("a time", "s"),
    (0, 0, 0, 1): ("an angle", "deg, rad"),
    (1, 0, -1, 0): ("a speed", "m/s"),
    (1, 0, -2, 0): ("an acceleration", "m/s^2"),
    (0, 0, -1, 1): ("an angular speed", "rad/s, rpm"),
    (0, 0, -1, 0): ("an angular speed", "1/s"),
    (0, 0, -2, 1): ("an angular acceleration", "rad/s^2"),
    (1, 1, -2, 0): ("a force", "N, kN"),
    (2, 1, -2, 0): ("a torque or an energy", "N m, J"),
    (2, 1, -3, 0): ("a power", "W, kW"),
    (2, 1, 0, 0): ("a moment of inertia", "kg m^2"),
    (-1, 1, -2, 0): ("a pressure", "Pa"),
    (0, 1, -2, 0): ("a stiffness", "N/m"),
    (0, 1, -1, 0): ("a damping coefficient", "N s/m"),
}


class DimensionError(ExprError):
    """Two values of different kinds meet in an expression (compared, added...)."""


def describe_dim(dim: Any) -> str:
    """``"a length (m, mm)"``, ``"dimensionless"``: a dimension in words, for messages."""
    if dim in (BARE, UNKNOWN):
        return "a number"
    if dim == TRUTH:
        return "a condition (true or false)"
    words = _DIM_WORDS.get(dim)
    if words is None:
        unit = " ".join(
            sym if e == 1 else f"{sym}^{e}" for sym, e in zip(("m", "kg", "s", "rad"), dim) if e
        )
        return f"a quantity in {unit}"
    name, units = words
    return f"{name} ({units})" if units else name


def compatible(a: Any, b: Any) -> bool:
    """Whether values of dimensions ``a`` and ``b`` may be compared or added."""
    if a in (BARE, UNKNOWN) or b in (BARE, UNKNOWN) or a == b:
        return True
    if a == TRUTH or b == TRUTH:
        return False
    return a[:3] == b[:3] and a[:3] != (0, 0, 0) and 0 in (a[3], b[3])


def _shown(node: Any) -> str:
    text = to_text(node, 60, as_written=True)
    return repr(text) if text is not None else "a long expression"


def _one_kind(items: list[tuple[Any, Any]], what: str) -> Any:
    """The common dimension of ``items`` ((dimension, node) pairs that meet as ``what``),
    or :class:`DimensionError` naming the first two of different kinds."""
    known = [(d, n) for d, n in items if d not in (BARE, UNKNOWN)]
    for (d0, n0), (d1, n1) in zip(known, known[1:]):
        if not compatible(d0, d1):
            raise DimensionError(
                f"{_shown(n0)} is {describe_dim(d0)} but {_shown(n1)} is "
                f"{describe_dim(d1)}: {what} must be of one kind (a number without a unit "
                "is read in SI units of the other side)"
            )
    if known:  # the fullest of the known ones (an angular speed rather than 1/s)
        return max((d for d, _ in known), key=lambda d: d[3] != 0)
    return UNKNOWN if any(d == UNKNOWN for d, _ in items) else BARE


def _const(node: Any) -> float | None:
    if isinstance(node, Num):
        return node.value
    if isinstance(node, Unary) and isinstance(node.arg, Num):
        return -node.arg.value
    return None


def _needs(func: str, d: Any, node: Any, allowed: tuple[Dim, ...], what: str) -> None:
    if d in (BARE, UNKNOWN) or d in allowed:
        return
    raise DimensionError(f"{func}() takes {what}, but {_shown(node)} is {describe_dim(d)}")


def _dim_rule(n: Any, d: list[Any], ref_dim: Callable[[Ref], Any], driver: Any) -> Any:
    """The dimension of node ``n`` given those ``d`` of its operands."""
    if isinstance(n, Num):
        return BARE if n.dim is None else tuple(n.dim)
    if isinstance(n, Ref):
        got = ref_dim(n)
        return UNKNOWN if got is None else tuple(got)
    if isinstance(n, Var):
        return UNKNOWN  # laws of t, omega, angle: their coefficients carry the units
    if isinstance(n, (Side, Compare, BoolOp, Not)):
        if isinstance(n, Compare):
            for a, b, na, nb in zip(d, d[1:], n.operands, n.operands[1:]):
                _one_kind([(a, na), (b, nb)], "the two sides of a comparison")
        return TRUTH
    d = [BARE if x == TRUTH else x for x in d]  # true and false count as 1 and 0
    if isinstance(n, Unary):
        return d[0]
    if isinstance(n, Chain) and n.ops[0] in ("+", "-"):
        return _one_kind(list(zip(d, n.operands)), "the terms of a sum or difference")
    if isinstance(n, Chain):
        if UNKNOWN in d:
            return UNKNOWN
        below = [False] + [op == "/" for op in n.ops]
        known = [(x, bl) for x, bl in zip(d, below) if x != BARE]
        if not known:
            return BARE
        out = [0, 0, 0, 0]
        for x, bl in known:
            for i in range(4):
                out[i] += -x[i] if bl else x[i]
        return tuple(out)
    if isinstance(n, Binary):
        base, exp = d
        if exp not in (BARE, UNKNOWN, _PURE):
            raise DimensionError(
                f"the exponent {_shown(n.right)} is {describe_dim(exp)}: an exponent is a "
                "plain number"
            )
        if base in (BARE, UNKNOWN, _PURE):
            return base
        e = _const(n.right)
        if e is not None and float(e).is_integer() and abs(e) <= 12:
            return tuple(int(x * e) for x in base)
        return UNKNOWN
    if isinstance(n, Call):
        f, x = n.func, d[0]
        if len(d) == 2 and f in ("min", "max"):
            return _one_kind(list(zip(d, n.args)), f"the two arguments of {f}()")
        if f == "at":
            if driver is not None:
                _needs("at", d[1], n.args[1], (driver,), f"a driver value, {describe_dim(driver)}")
            return x
        if f in ("min", "max", "mean", "rms", "range", "abs"):
            return x
        if f == "stroke":
            return _PURE
        if x == UNKNOWN:  # sin(3 * t) in a law: its coefficient may carry the unit
            return UNKNOWN
        if f == "sign":
            return BARE if x == BARE else _PURE
        if f == "sqrt":
            if x in (BARE, UNKNOWN, _PURE):
                return x
            return tuple(e // 2 for e in x) if all(e % 2 == 0 for e in x) else UNKNOWN
        if f in ("sin", "cos", "tan"):
            _needs(f, x, n.args[0], (_ANGLE, _PURE), "an angle or a plain number")
            return BARE if x == BARE else _PURE
        if f == "deg":
            _needs(f, x, n.args[0], (_ANGLE, _PURE), "an angle")
            return BARE if x == BARE else _PURE
        if f in ("exp", "log", "atan"):
            _needs(f, x, n.args[0], (_PURE,), "a plain number")
            if x == BARE:
                return BARE
            return _ANGLE if f == "atan" else _PURE
        return UNKNOWN
    raise AssertionError(f"unknown node {type(n).__name__}")


def dimension_of(tree: Any, ref_dim: Callable[[Ref], Any], driver: Dim | None = None) -> Any:
    """The dimension of an expression's value, checking that whatever meets is of one
    kind (see the section's comment above).

    Parameters
    ----------
    tree
        A parsed tree (:attr:`Expression.tree`).
    ref_dim
        The dimension of each quantity ``P.x`` it reads, ``None`` where not known (not
        checked).
    driver
        The dimension of the driver's coordinate (an angle or a length), which
        ``at(q, u)`` takes as ``u``; ``None``: not checked.

    Returns
    -------
    tuple or str
        A dimension (exponents of length, mass, time, angle), :data:`BARE` (numbers
        without units), :data:`UNKNOWN` or :data:`TRUTH` (a condition).

    Raises
    ------
    DimensionError
        Where two values of different kinds meet.
    """
    return bottom_up(tree, lambda n, kids: _dim_rule(n, kids, ref_dim, driver))


def condition_dim(ref: Ref) -> Dim | None:
    """The dimension of a quantity a condition reads (by its attribute)."""
    return QUANTITY_DIMS.get(ref.attr)


def parse_all(texts: Sequence[str]) -> list[Expression]:
    """Parse several conditions."""
    return [Expression(t) for t in texts]
