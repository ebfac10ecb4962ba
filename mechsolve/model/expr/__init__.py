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

The package: :mod:`.tree` (limits, tokens, nodes, walks), :mod:`.parser`,
:mod:`.evaluate`, :mod:`.printing`, :mod:`.derivative`, :mod:`.dims` (kinds of
quantity) and :mod:`.expression` (:class:`Expression`, which uses them all).
"""

from __future__ import annotations

from mechsolve.model.expr.dims import (
    BARE,
    QUANTITY_DIMS,
    TRUTH,
    UNKNOWN,
    Dim,
    DimensionError,
    compatible,
    condition_dim,
    describe_dim,
    dimension_of,
)
from mechsolve.model.expr.expression import Expression, parse_all
from mechsolve.model.expr.printing import to_text
from mechsolve.model.expr.tree import (
    CONTEXT_FUNCS,
    MAX_DEPTH,
    MAX_LENGTH,
    MAX_NODES,
    REDUCTIONS,
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
    Token,
    Unary,
    Var,
    bottom_up,
    children,
    tokenize,
    walk,
)

__all__ = [
    "BARE",
    "Binary",
    "BoolOp",
    "CONTEXT_FUNCS",
    "Call",
    "Chain",
    "Compare",
    "Context",
    "Dim",
    "DimensionError",
    "ExprError",
    "Expression",
    "MAX_DEPTH",
    "MAX_LENGTH",
    "MAX_NODES",
    "Not",
    "Num",
    "QUANTITY_DIMS",
    "REDUCTIONS",
    "Ref",
    "Side",
    "TRUTH",
    "Token",
    "UNKNOWN",
    "Unary",
    "Var",
    "bottom_up",
    "children",
    "compatible",
    "condition_dim",
    "describe_dim",
    "dimension_of",
    "parse_all",
    "to_text",
    "tokenize",
    "walk",
]
