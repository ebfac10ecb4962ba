"""Small numerical routines used on every run, kept here so that a run does not
import scipy (half a second of start-up) for them.

:func:`brent_root` is Brent's root bracketing method (R. P. Brent, *Algorithms for
Minimization without Derivatives*, 1973, ch. 4: the ``zeroin`` algorithm), as
``scipy.optimize.brentq``; :func:`illinois_root` is the Illinois regula falsi, for a
function that may fail inside the bracket (a position that does not close), whose
caller then wants the bracket narrowed so far; :func:`bisect_edge` is bisection on a
condition that holds on one side of an edge and not on the other; :func:`simpson` is
the composite Simpson rule on samples with uneven spacing, as
``scipy.integrate.simpson`` (with its treatment of an odd number of intervals).
``tests/test_numerics.py`` checks brent_root and simpson against scipy,
``tests/test_issue30_dedup.py`` illinois_root and bisect_edge against closed forms.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

EPS = np.finfo(float).eps


def brent_root(
    f: Callable[[float], float],
    a: float,
    b: float,
    xtol: float = 2e-12,
    rtol: float = 4 * EPS,
    maxiter: int = 200,
    fa: float | None = None,
    fb: float | None = None,
) -> float:
    """A root of ``f`` in ``[a, b]``, where ``f(a)`` and ``f(b)`` differ in sign.

    Inverse quadratic interpolation or secant steps where they make progress, bisection
    otherwise; converges when the bracket is narrower than ``2 (xtol + rtol |x|)``.

    Raises
    ------
    ValueError
        When ``f(a)`` and ``f(b)`` have the same sign, or ``f`` is not finite.
    RuntimeError
        When the bracket is still wider than the tolerance after ``maxiter`` steps.

    ``fa`` and ``fb``, when given, are ``f(a)`` and ``f(b)`` already evaluated.
    """
    fa = f(a) if fa is None else fa
    fb = f(b) if fb is None else fb
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    if not (np.isfinite(fa) and np.isfinite(fb)):
        raise ValueError("f is not finite at the ends of the bracket")
    if (fa > 0) == (fb > 0):
        raise ValueError("f(a) and f(b) must have different signs")
    c, fc = a, fa
    d = e = b - a
    for _ in range(maxiter):
        if (fb > 0) == (fc > 0):  # keep the root between b and c
            c, fc = a, fa
            d = e = b - a
        if abs(fc) < abs(fb):  # b is the best estimate
            a, b, c = b, c, b
            fa, fb, fc = fb, fc, fb
        tol = 2.0 * rtol * abs(b) + 0.5 * xtol
        m = 0.5 * (c - b)
        if abs(m) <= tol or fb == 0.0:
            return b
        if abs(e) >= tol and abs(fa) > abs(fb):
            s = fb / fa
            if a == c:  # secant
                p = 2.0 * m * s
                q = 1.0 - s
            else:  # inverse quadratic interpolation
                q = fa / fc
                r = fb / fc
                p = s * (2.0 * m * q * (q - r) - (b - a) * (r - 1.0))
                q = (q - 1.0) * (r - 1.0) * (s - 1.0)
            if p > 0:
                q = -q
            else:
                p = -p
            if 2.0 * p < min(3.0 * m * q - abs(tol * q), abs(e * q)):
                e, d = d, p / q  # accept the interpolation
            else:
                d = e = m  # bisect
        else:
            d = e = m
        a, fa = b, fb
        b += d if abs(d) > tol else (tol if m > 0 else -tol)
        fb = f(b)
        if not np.isfinite(fb):
            raise ValueError(f"f is not finite at {b!r}")
    raise RuntimeError(f"Brent's method did not converge in {maxiter} iterations")


class Bracket(NamedTuple):
    """What :func:`illinois_root` found: the root ``x`` (None where it was not reached),
    the last bracket ``lo, hi`` with the values it kept there (``f``, an end kept twice
    running halved), and whether ``f`` stayed finite."""

    x: float | None
    lo: float
    hi: float
    f_lo: float
    f_hi: float
    finite: bool


def illinois_root(
    f: Callable[[float], float],
    lo: float,
    hi: float,
    f_lo: float,
    f_hi: float,
    *,
    ftol: float = 0.0,
    xrel: float = 0.0,
    maxiter: int = 60,
) -> Bracket:
    """A root of ``f`` between ``lo`` and ``hi`` (either order), where ``f_lo = f(lo)``
    and ``f_hi = f(hi)`` differ in sign (an end where it is zero is the root): regula
    falsi with the Illinois modification (the end kept twice running has its value
    halved), so that it converges
    superlinearly from both sides (M. Dowell and P. Jarratt, BIT 11, 1971, 168-174).

    It stops at a point ``x`` where ``|f(x)| <= ftol``, or where the bracket that held
    ``x`` was no wider than ``xrel max(1, |x|)``: ``x`` is the root. It stops without one
    (``x`` None) when the next point would not lie strictly inside the bracket (it is as
    narrow as rounding allows), after ``maxiter`` points, or where ``f`` is not finite
    (``finite`` False: the bracket is the one before that point). ``f`` is evaluated only
    strictly inside the bracket.

    Raises
    ------
    ValueError
        When ``f_lo`` and ``f_hi`` have the same sign or are not finite.
    """
    if f_lo == 0.0 or f_hi == 0.0:
        return Bracket(lo if f_lo == 0.0 else hi, lo, hi, f_lo, f_hi, True)
    if not (np.isfinite(f_lo) and np.isfinite(f_hi)):
        raise ValueError("f is not finite at the ends of the bracket")
    if (f_lo > 0) == (f_hi > 0):
        raise ValueError("f(lo) and f(hi) must have different signs")
    side = 0
    for _ in range(maxiter):
        x = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        if not (min(lo, hi) < x < max(lo, hi)):
            x = 0.5 * (lo + hi)
            if x in (lo, hi):
                break
        fx = f(x)
        if not np.isfinite(fx):
            return Bracket(None, lo, hi, f_lo, f_hi, False)
        if abs(fx) <= ftol or abs(hi - lo) <= xrel * max(1.0, abs(x)):
            return Bracket(x, lo, hi, f_lo, f_hi, True)
        if (fx < 0) == (f_lo < 0):
            lo, f_lo = x, fx
            if side == -1:
                f_hi *= 0.5
            side = -1
        else:
            hi, f_hi = x, fx
            if side == +1:
                f_lo *= 0.5
            side = +1
    return Bracket(None, lo, hi, f_lo, f_hi, True)


def bisect_edge(
    holds: Callable[[float], bool],
    good: float,
    bad: float,
    maxiter: int = 200,
    width: float = 0.0,
) -> tuple[float, float]:
    """``(good, bad)`` narrowed by bisection about the edge where ``holds`` stops holding:
    it holds at ``good`` and not at ``bad`` (either order) and at each step the midpoint
    replaces the end it agrees with. Stops when the two are closer than ``width``, after
    ``maxiter`` steps, or when they are neighbouring floats (the midpoint is one of them).
    For a condition, not a sign: where the edge matters as the last point that holds (a
    pose that still closes) or the first that does not (a load that has switched)."""
    for _ in range(maxiter):
        mid = 0.5 * (good + bad)
        if mid in (good, bad):
            break
        if holds(mid):
            good = mid
        else:
            bad = mid
        if abs(good - bad) < width:
            break
    return good, bad


def limit_from_both_sides(lo1, hi1, lo2, hi2):
    """The value at a point of a function smooth through it, from its values at
    ``-h, +h`` (``lo1``, ``hi1``) and ``-2h, +2h`` (``lo2``, ``hi2``) around it:
    Richardson's extrapolation of the two sides' means, ``(4 m(h) - m(2h)) / 3``, error
    O(h^4). Floats or arrays."""
    return (4.0 * (lo1 + hi1) - (lo2 + hi2)) / 6.0


def simpson(y: np.ndarray, x: np.ndarray) -> float:
    """Integral of samples ``y`` at increasing abscissae ``x`` (composite Simpson).

    Pairs of intervals use Simpson's rule for uneven spacing, exact for quadratics; with
    an odd number of intervals the last one is integrated with the parabola through the
    last three samples (Cartwright's correction, as scipy does).
    """
    y = np.asarray(y, float)
    x = np.asarray(x, float)
    n = len(y)
    if n < 2:
        return 0.0
    if n == 2:
        return float(0.5 * (x[1] - x[0]) * (y[0] + y[1]))
    h = np.diff(x)
    last = (n - 1) % 2 == 1  # an odd number of intervals
    k = n - 2 if last else n - 1  # intervals covered by pairs
    h0, h1 = h[0:k:2], h[1:k:2]
    y0, y1, y2 = y[0:k:2], y[1:k:2], y[2 : k + 1 : 2]
    hs = h0 + h1
    total = float(
        np.sum(hs / 6.0 * ((2.0 - h1 / h0) * y0 + hs * hs / (h0 * h1) * y1 + (2.0 - h0 / h1) * y2))
    )
    if last:
        a, b = h[-2], h[-1]
        total += float(
            y[-1] * (2 * b * b + 3 * a * b) / (6 * (a + b))
            + y[-2] * (b * b + 3 * a * b) / (6 * a)
            - y[-3] * b**3 / (6 * a * (a + b))
        )
    return total
