"""Poles of a law between its samples (see :mod:`mechsolve.model.expr`).

A law of one variable (a driver's ``u(t)``, a torque curve of ``angle``) is sampled at
finitely many values, so a pole between two samples (``t + 1/(t - 1.05)`` sampled every
0.1 s) gives finite samples on both sides and a law that jumps through infinity between
them. It is found where it must come from: a part of a denominator (or the base of a
power, or the cosine of ``tan``'s argument) that changes sign between two samples, or
that touches zero between them without changing sign (``1/(t^2 - 2.1 t + 1.1025)``,
``1/(1 + cos(t))``: a local minimum of its magnitude, located by bounded minimisation).
The zero is located to rounding and the law is evaluated beside it: a pole grows without
bound as the zero is approached (at 1e-4 and 1e-8 of the interval from it, a simple pole
grows 1e4 times), a removable singularity (``sin(t)/t`` at 0, ``(t - 1)/(t - 1)``) or a
jump of a denominator that does not pass through zero (``1/sign(t - 1)``) does not.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mechsolve.base.numerics import brent_root
from mechsolve.model.expr.tree import Binary, Call, Chain, walk

# how much faster than at 1e-4 of the interval the law must be at 1e-8 of it to be a pole
# (a simple pole: 1e4, a double one 1e8; a bounded law: about 1)
POLE_GROWTH = 100.0


def _candidates(tree: Any) -> list[Any]:
    """The parts whose zeros may be poles: every node of a divisor, the bases of powers
    and the cosines of ``tan``'s arguments."""
    roots: list[Any] = []
    for n in walk(tree):
        if isinstance(n, Chain):
            roots += [b for op, b in zip(n.ops, n.operands[1:]) if op == "/"]
        elif isinstance(n, Binary):
            roots.append(n.left)
        elif isinstance(n, Call) and n.func == "tan":
            roots.append(Call("cos", n.args))
    out, seen = [], set()
    for r in roots:
        for n in walk(r):
            if id(n) not in seen and (n.__class__ is not Call or n.func != "tan"):
                seen.add(id(n))
                out.append(n)
    return out


# at most this many local minima of a part's magnitude are examined (the smallest first),
# so that a denominator that oscillates over many samples does not cost a minimisation each
MAX_TOUCHES = 32


def first_pole(expr: Any, var: str, x: np.ndarray) -> float | None:
    """The smallest value of ``var`` between consecutive samples ``x`` (ascending) where
    ``expr`` (an :class:`~mechsolve.model.expr.Expression` of ``var`` alone) grows without
    bound, or None. The samples themselves are not examined (a law that is not finite at
    a sample is found by evaluating it there)."""
    x = np.asarray(x, float)
    return _first_pole(expr, x, lambda v: {var: v})


def first_pole_along(expr: Any, samples: dict[str, np.ndarray]) -> tuple[int, dict] | None:
    """The first pole of ``expr`` (of several variables) along a path given by its
    samples (``{variable: values}``, all the same length), followed straight from one
    sample to the next: ``(k, values)`` with the pole between samples ``k`` and ``k + 1``
    and every variable's value there, or None. A motion that passes continuously from
    one sample to the next passes the zero of a denominator that changes sign between
    them, wherever the motion went in between."""
    names = list(samples)
    cols = [np.asarray(samples[n], float) for n in names]
    idx = np.arange(len(cols[0]), dtype=float)

    def point(v: np.ndarray) -> dict:
        return {n: np.interp(v, idx, c) for n, c in zip(names, cols)}

    z = _first_pole(expr, idx, point)
    if z is None:
        return None
    return min(int(z), len(idx) - 2), {n: float(a) for n, a in point(np.array(z)).items()}


def _first_pole(expr: Any, x: np.ndarray, point: Any) -> float | None:
    """:func:`first_pole` over the parameter ``x`` of the path ``point(v)`` (the variables'
    values at the parameter values ``v``)."""
    if x.size < 2:
        return None

    def at(tree: Any, v: np.ndarray) -> np.ndarray:
        e = type(expr)._derived(tree, "", expr.variables)
        return np.broadcast_to(np.asarray(e.evaluate_at(point(v)), float), v.shape)

    def grows(z: float, step: float) -> bool:
        """The law beside ``z`` (at 1e-4 and 1e-8 of the samples' step from it) grows
        without bound: a pole, not a removable singularity or a bounded jump."""
        h = step * np.array([1e-4, 1e-8])
        near = np.abs(at(expr.tree, np.r_[z - h, z + h]))
        far, close = near[[0, 2]], near[[1, 3]]
        return not np.all(np.isfinite(close)) or np.max(close) > POLE_GROWTH * np.max(far)

    found: list[float] = []
    for part in _candidates(expr.tree):
        d = at(part, x)
        for z, step in _zeros(lambda v, part=part: float(at(part, np.array([v]))[0]), x, d):
            if (not found or z < min(found)) and grows(z, step):
                found.append(z)
    return min(found) if found else None


def _zeros(f: Any, x: np.ndarray, d: np.ndarray) -> list[tuple[float, float]]:
    """Where the part ``f`` (sampled: ``d`` at ``x``) may be zero between two samples, each
    with the step of the samples around it: located to rounding where it changes sign,
    and at the smallest magnitude where it touches zero without changing sign (a local
    minimum of ``|d|`` among the samples: an even-order zero or ``abs``)."""
    out: list[tuple[float, float]] = []
    sign = np.sign(d)
    for k in np.flatnonzero(sign[:-1] * sign[1:] < 0):
        try:  # the zero to rounding (the law is read at 1e-8 of the step from it)
            z = brent_root(
                f, float(x[k]), float(x[k + 1]), xtol=1e-300, fa=float(d[k]), fb=float(d[k + 1])
            )
        except (ValueError, RuntimeError):  # the part is not finite between: no zero
            continue
        out.append((z, float(x[k + 1] - x[k])))
    a = np.abs(d)
    with np.errstate(invalid="ignore"):
        dips = (
            np.flatnonzero(
                (a[1:-1] < a[:-2])
                & (a[1:-1] <= a[2:])
                & (sign[1:-1] * sign[:-2] > 0)
                & (sign[1:-1] * sign[2:] > 0)
            )
            + 1
        )
    if dips.size == 0:
        return out
    from scipy.optimize import minimize_scalar  # only a law whose part dips toward zero

    for k in dips[np.argsort(a[dips] / max(float(np.nanmax(a)), 1e-300))][:MAX_TOUCHES]:
        lo, hi = float(x[k - 1]), float(x[k + 1])
        r = minimize_scalar(
            lambda v: abs(f(v)),
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": 1e-14 * max(abs(lo), abs(hi), hi - lo)},
        )
        if np.isfinite(r.fun) and r.fun < a[k]:
            out.append((float(r.x), 0.5 * (hi - lo)))
    return out
