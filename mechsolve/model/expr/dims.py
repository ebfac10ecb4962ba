"""Kinds of quantity: the dimension of every value of an expression (see
:mod:`mechsolve.model.expr`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from mechsolve.model.expr.printing import to_text
from mechsolve.model.expr.tree import (
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
    bottom_up,
    children,
)

# --- dimensions ----------------------------------------------------------------------
# Every value of an expression has a dimension (exponents of length, mass, time, angle,
# as in mechsolve.base.units). Two values that are compared, added, subtracted or given to
# max(a, b) must be of one kind: "max(B.y) <= 1 kg" is an input error, found before
# anything is solved. A number without a unit is SI: it takes the kind of whatever it
# meets ("K.vx < 0", "min(transmission_angle.B) >= 0.5" is 0.5 rad) and is a pure number
# in a product ("2 * 150 kN m" is a torque). An angle counts as a dimension of its own,
# except that a unit without the radian may stand for one with it where more than an
# angle is involved ("2 1/s" for an angular speed, as mechsolve.base.units reads it); a pure
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


_LENGTH_DIM: Dim = (1, 0, 0, 0)


def bare_lengths_and_angles(
    tree: Any, ref_dim: Callable[[Ref], Any], driver: Dim | None = None
) -> list[tuple[float, str]]:
    """The nonzero numbers without a unit that meet a length or an angle (compared with
    it, added to it, or given to ``min``/``max`` with it): ``(value, "length" or
    "angle")`` for each. They are read in SI (metres, radians), which a file whose plain
    lengths are millimetres or whose plain angles are degrees probably did not mean."""
    found: list[tuple[float, str]] = []

    def dim(node: Any) -> Any:
        try:
            return dimension_of(node, ref_dim, driver)
        except DimensionError:
            return UNKNOWN

    def meet(operands: tuple[Any, ...]) -> None:
        dims = [dim(o) for o in operands]
        known = [d for d in dims if d not in (BARE, UNKNOWN, TRUTH)]
        kinds = {d for d in known if d in (_LENGTH_DIM, _ANGLE)}
        if len(kinds) != 1:
            return
        kind = "length" if kinds.pop() == _LENGTH_DIM else "angle"
        for o, d in zip(operands, dims):
            value = _const(o)  # a number, or minus a number, as written
            if d == BARE and value is not None and value != 0:
                found.append((float(value), kind))

    def visit(n: Any) -> None:
        if isinstance(n, Compare) or (isinstance(n, Chain) and n.ops[0] in ("+", "-")):
            meet(n.operands)
        elif isinstance(n, Call) and n.func in ("min", "max") and len(n.args) == 2:
            meet(n.args)
        for child in children(n):
            visit(child)

    visit(tree)
    return found
