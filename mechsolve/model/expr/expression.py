"""An expression: parsed once, evaluated, differentiated, printed (see
:mod:`mechsolve.model.expr`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from mechsolve.model.expr.derivative import _Builder, _check_differentiable, _differentiate
from mechsolve.model.expr.dims import DimensionError, condition_dim, dimension_of
from mechsolve.model.expr.evaluate import _check_variables, _eval, _leaf
from mechsolve.model.expr.parser import _Parser
from mechsolve.model.expr.printing import to_text
from mechsolve.model.expr.tree import (
    MAX_LENGTH,
    MAX_NODES,
    REDUCTIONS,
    BoolOp,
    Call,
    Compare,
    Context,
    ExprError,
    Not,
    Num,
    Ref,
    Side,
    Var,
    _builtin,
    _show,
    walk,
)


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
        # kept per tree (a load's condition is asked this on every force analysis)
        memo = self.__dict__.get("_uses")
        if memo is None or memo[0] is not self.tree:
            memo = self.__dict__["_uses"] = (self.tree, {})
        found = memo[1].get(func)
        if found is None:
            found = memo[1][func] = any(
                isinstance(n, Call) and n.func == func for n in walk(self.tree)
            )
        return found

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

    def evaluate(
        self,
        ctx: Context,
        functions: dict[str, Callable[..., Any]] | None = None,
        faults: list[tuple[str, int]] | None = None,
    ) -> Any:
        """Evaluate over the arrays the context provides (element-wise).

        With ``faults`` (a list), the first part of the expression that is not finite
        where what it is made of is (a division by zero, ``log(0)``, an overflow) is
        appended to it as (its text, the element where it happens)."""
        funcs = functions or {}

        def leaf(n: Any) -> Any:
            return _leaf(n, ctx)

        found: list[tuple[Any, int]] | None = [] if faults is not None else None
        with np.errstate(all="ignore"):  # inf and nan follow IEEE rules; no warnings
            out = _eval(self.tree, leaf, funcs, found)
        if found:
            node, k = found[0]
            faults.append((to_text(node, 200) or self.text, k))  # type: ignore[union-attr]
        return out

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


def parse_all(texts: Sequence[str]) -> list[Expression]:
    """Parse several conditions."""
    return [Expression(t) for t in texts]
