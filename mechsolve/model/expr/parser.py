"""The operator-precedence parser, with explicit stacks (see :mod:`mechsolve.model.expr`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from mechsolve.base.units import UnitError, parse_unit
from mechsolve.model.expr.tree import (
    _CMP,
    _FUNCS,
    _KEYWORDS,
    CONTEXT_FUNCS,
    MAX_DEPTH,
    Binary,
    BoolOp,
    Call,
    Chain,
    Compare,
    ExprError,
    Not,
    Num,
    Ref,
    Side,
    Token,
    Unary,
    Var,
    _arities,
    _show,
    tokenize,
)

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
        """The tree of the whole text: operands go to ``_out``, operators and open
        parentheses wait on ``_ops`` until one of lower precedence (or a closing
        parenthesis, or the end) reduces them."""
        if self.tok.kind == "end":
            raise ExprError("the condition is empty")
        self._out: list[Any] = []  # operands, and the nodes built from them
        self._ops: list[_Frame] = []
        self._depth = 0
        self._expect_operand = True
        self._logic_ok = True  # 'not' and 'P left of A -> B' may stand here
        self._after_side = False
        while True:
            tok = self.tok
            if self._expect_operand:
                self._prefix_or_operand(tok)
            elif tok.kind == "end":
                break
            else:
                self._after_operand(tok)
        self._reduce_above(0)
        if self._ops:
            raise self.fail("expected ')' but found the end")
        assert len(self._out) == 1
        return self._out[0]

    def _push(self, frame: _Frame) -> None:
        """Put an operator or an open parenthesis on the stack (refusing too deep a nest)."""
        if frame.kind in _NESTING:
            self._depth += 1
            if self._depth > MAX_DEPTH:
                raise self.fail(
                    f"the expression nests deeper than {MAX_DEPTH} levels (each '(', "
                    "function call, '-', 'not' and '^' opens one)"
                )
        self._ops.append(frame)

    def _reduce(self) -> None:
        """Apply the operator on top of the stack to the operands it takes."""
        out = self._out
        fr = self._ops.pop()
        if fr.kind in _NESTING:
            self._depth -= 1
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

    def _reduce_above(self, prec: int) -> None:
        """Reduce the operators above ``prec`` back to the innermost open parenthesis."""
        ops = self._ops
        while ops and ops[-1].kind not in ("paren", "call") and ops[-1].prec > prec:
            self._reduce()

    def _prefix_or_operand(self, tok: Token) -> None:
        """Where an operand is expected: '(', 'not', a sign, or the operand itself (a
        function call only opens, its arguments follow)."""
        if tok.kind == "op" and tok.text == "(":
            self._push(_Frame("paren", tok=tok))
            self.i += 1
            self._logic_ok = True
        elif tok.kind == "name" and tok.text == "not" and self._logic_ok:
            self._push(_Frame("not", _NOT_PREC, tok=tok))
            self.i += 1
        elif tok.kind == "op" and tok.text in ("-", "+"):
            if tok.text == "-":
                self._push(_Frame("neg", _NEG_PREC, tok=tok))
            self.i += 1
            self._logic_ok = False
        else:
            self._out.append(self.operand(self._logic_ok, self._push))
            if self._out[-1] is None:  # a function call opened: its arguments follow
                self._out.pop()
                self._logic_ok = True
                return
            self._after_side = isinstance(self._out[-1], Side)
            self._expect_operand = False

    def _after_operand(self, tok: Token) -> None:
        """After an operand: a binary operator, a comma or a closing parenthesis."""
        t = tok.text
        is_logic = tok.kind == "name" and t in ("and", "or")
        if self._after_side and not is_logic and t not in (")", ","):
            raise self.fail(f"unexpected {t!r}")
        self._after_side = False
        if is_logic or (tok.kind == "op" and t in _PREC):
            self._binary(tok, is_logic)
        elif tok.kind == "op" and t in (",", ")"):
            self._comma_or_close(tok)
        else:
            raise self.fail(f"unexpected {t!r}")

    def _binary(self, tok: Token, is_logic: bool) -> None:
        """A binary operator: '^' nests (right to left); others of the same precedence
        join one chain (``a < b < c``, ``a - b + c``)."""
        ops, t = self._ops, tok.text
        prec = _PREC[t]
        self._reduce_above(prec)
        if t == "^":
            self._push(_Frame("pow", prec, tok=tok))
        elif ops and ops[-1].kind == "chain" and ops[-1].prec == prec:
            ops[-1].ops.append(t)
        else:
            self._push(_Frame("chain", prec, ops=[t], tok=tok))
        self.i += 1
        self._expect_operand = True
        self._logic_ok = is_logic

    def _comma_or_close(self, tok: Token) -> None:
        """A comma between a call's arguments, or a ')' that closes a parenthesis or a
        call (which is then built from its arguments)."""
        t = tok.text
        self._reduce_above(0)
        ops = self._ops
        if not ops or (t == "," and ops[-1].kind != "call"):
            raise self.fail(f"unexpected {t!r}")
        self.i += 1
        if t == ",":
            ops[-1].args += 1
            self._expect_operand = True
            self._logic_ok = True
            return
        fr = ops.pop()
        self._depth -= 1
        if fr.kind == "call":
            assert fr.tok is not None
            k = fr.args + 1
            args = tuple(self._out[-k:])
            del self._out[-k:]
            self._out.append(self.call(fr.tok, args))

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
