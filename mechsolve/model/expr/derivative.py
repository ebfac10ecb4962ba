"""Symbolic derivatives of a law (see :mod:`mechsolve.model.expr`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from mechsolve.model.expr.tree import (
    _FUNCS,
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
    Unary,
    Var,
    _builtin,
    _show,
    bottom_up,
    children,
)

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
