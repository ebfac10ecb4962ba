"""Where a joint's own motion law is not smooth, as driver values.

A cam's program joins its segments (and an equal-acceleration law its halves) where the
follower's acceleration, or its velocity, jumps: the driving effort and the reactions
jump there too. Each joint says where in its own coordinate
(:meth:`~mechsolve.joints.base.Constraint.law_breaks`); :func:`break_points` finds the
driver values of these places along a solved sweep, to rounding, so that the sweep the
figures are drawn from can take a sample on either side of each (as it does for the
switching of loads) instead of joining the samples around a jump.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.base.numerics import illinois_root
from mechsolve.core.sweep import Analysis, Solution


def break_points(an: Analysis, sol: Solution) -> list[float]:
    """The driver values, to rounding, where the motion of ``sol`` passes a place at which
    a joint's motion law is not smooth, between two solved samples (or at one)."""
    out: list[float] = []
    st = sol.state
    ok = np.asarray(sol.ok, bool)
    u = np.asarray(sol.u, float)
    for ri, row in enumerate(an.system.rows):
        g = row.constraint.law_breaks(st)
        if g is None:
            continue
        for k_row, gk in enumerate(np.asarray(g, float)):
            good = ok & np.isfinite(gk)
            out += [float(u[i]) for i in np.flatnonzero(good & (gk == 0.0))]
            # a change of sign between neighbours, not the wrap through +-pi
            a, b = gk[:-1], gk[1:]
            cross = good[:-1] & good[1:] & (a * b < 0) & (np.abs(a - b) < math.pi)
            for k in np.flatnonzero(cross):
                out.append(_locate(an, sol, ri, k_row, int(k)))
    return sorted(set(out))


def _locate(an: Analysis, sol: Solution, ri: int, k_row: int, k: int) -> float:
    """The driver value between samples k and k+1 where row ``k_row`` of constraint
    ``ri``'s breaks changes sign, to rounding: regula falsi (Illinois,
    :func:`~mechsolve.base.numerics.illinois_root`) on positions solved one at a time next
    to sample k (the distance is smooth in the driver: a few solves); where one does not
    close, the end of the bracket so far nearer the break."""
    c = an.system.rows[ri].constraint
    g0 = c.law_breaks(sol.state)[k_row]

    def g(x: float) -> float:
        one = an.solve(np.array([x]), start=sol.start, near=(sol, k), velocity=False,
                       acceleration=False)  # fmt: skip
        return float(c.law_breaks(one.state)[k_row, 0]) if one.ok[0] else math.nan

    lo, hi = float(sol.u[k]), float(sol.u[k + 1])
    r = illinois_root(g, lo, hi, float(g0[k]), float(g0[k + 1]), ftol=_EXACT, maxiter=_ROUNDS)
    if r.x is not None:
        return r.x
    return r.lo if abs(r.f_lo) < abs(r.f_hi) else r.hi


_ROUNDS = 60
_EXACT = 1e-14  # rad: the joint's coordinate is this close to its break (to rounding)
