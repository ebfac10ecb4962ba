"""Where a Newton group's continuation passes a singular configuration.

A group solved by Newton-Raphson has no discriminant to watch (see :mod:`.branches` for
the two-branch groups), but its square block of Phi_q is singular exactly where the
group's configuration is: the determinant changes sign where the followed motion passes
through a singular configuration smoothly (a change point, where two branches meet and
cross). Between two solved samples whose determinants differ in sign, the crossing is
located by Brent's method on the determinant of the group solved in between (from the
interpolated pose), and reported as a bifurcation, as the branch analysis reports one of
a two-branch group. A sample that is itself singular (to rounding: its reciprocal
condition below :data:`SIGN_RCOND`) between two samples of opposite
signs is the event's position. A limit position (the edge of a range where the group
cannot close) is not crossed, so it is not an event here: the range is reported as such.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from mechsolve.base.numerics import brent_root
from mechsolve.core.conditioning import rcond
from mechsolve.core.solution import Event
from mechsolve.groups import NewtonGroup

# a sample whose block's reciprocal condition is below this is on the singular position
# (its determinant's sign is rounding's: Newton converges to about sqrt(atol) at a limit
# position)
SIGN_RCOND = 1e-6

if TYPE_CHECKING:
    from mechsolve.core.branches import _Context


def newton_events(
    an: Any, gi: int, g: NewtonGroup, ctx: _Context, ok: np.ndarray
) -> tuple[list[Event], list[str]]:
    """The events of the Newton group ``gi`` of analysis ``an`` along the sweep
    ``ctx.u`` (its poses are solved in ``ctx.st``; ``ok`` where it and the groups before
    it closed), and their
    warnings: the intervals its sweep could not follow continuously (``g.gaps``: a
    range where it cannot close, or a singular position, narrower than the finest
    substep; the sweep started again past them), then the bifurcations it passed."""
    events: list[Event] = []
    warnings: list[str] = []
    u = ctx.u
    for k, near in g.gaps:
        a, b = an.format_u(u[k]), an.format_u(u[k + 1])
        events.append(Event("dead zone", g.label, float(near), k, 0.0))
        warnings.append(
            f"between {a} and {b} the {g.label} cannot be followed continuously: it "
            f"cannot close near {an.format_u(near)} (or passes a singular position there) "
            f"in a range narrower than the steps can follow; the sweep starts again at {b} "
            "on the assembly's branches, and the motion between these positions is not "
            "continuous (use a smaller step to see it)"
        )
    return events + _bifurcations(gi, g, ctx, ok), warnings


def _bifurcations(gi: int, g: NewtonGroup, ctx: _Context, ok: np.ndarray) -> list[Event]:
    """The bifurcations the group passed: its determinant's sign changes."""
    st, u = ctx.st, ctx.u
    if st.n < 2:
        return []
    det, good = g.dets(st, ok)  # none for a redundant block: its rank tells, not its sign
    sign = np.sign(det)
    cross = np.flatnonzero(good[:-1] & good[1:] & (sign[:-1] * sign[1:] < 0))
    if cross.size and g.gaps:  # (not crossed continuously: not a bifurcation)
        cross = cross[~np.isin(cross, [k for k, _ in g.gaps])]
    first = _at_continued_start(gi, g, ctx, det, good)
    if not cross.size:
        return first
    ends = np.unique(np.r_[cross, cross + 1])
    singular = np.zeros(st.n, bool)
    singular[ends] = rcond(g.jacobian(st.take(ends))) <= SIGN_RCOND
    events: list[Event] = []
    seen: set[int] = set()
    for a in cross.tolist():
        b = a + 1
        if singular[a] or singular[b]:
            # a sample on the singular position (its sign is rounding's): passed only if
            # the samples on both sides close, regular and of opposite signs (else it is a
            # limit position: the edge of a range where the group cannot close)
            j = a if singular[a] else b
            if j in seen or j == 0 or j == st.n - 1:
                continue  # the sweep's ends: nothing is passed there
            seen.add(j)
            if not (good[j - 1] and good[j + 1] and sign[j - 1] * sign[j + 1] < 0):
                continue
            if rcond(g.jacobian(st.take([j - 1, j + 1]))).min() <= SIGN_RCOND:
                continue
            events.append(Event("bifurcation", g.label, float(u[j]), j - 1, 0.0))
            continue
        events.append(Event("bifurcation", g.label, _crossing(gi, g, ctx, a, det), a, 0.0))
    return first + events


def _at_continued_start(gi: int, g: NewtonGroup, ctx: _Context, det, good) -> list[Event]:
    """A chunk that continues a sweep (``ctx.history``: the previous chunk's poses before
    its first sample) whose first sample is on a singular position: passed when the pose
    before it and the sample after it are regular with determinants of opposite signs,
    as for a sample inside a sweep (the previous chunk, whose last sample it is, cannot
    tell)."""
    hist = getattr(ctx, "history", {}).get(gi)
    st = ctx.st
    if not hist or st.n < 3 or not (good[0] and good[1]):
        return []
    rc = rcond(g.jacobian(st.take([0, 1])))
    if not (rc[0] <= SIGN_RCOND < rc[1]):
        return []
    u_prev, q_prev = float(hist[0][-1]), hist[1][-1]
    st1 = ctx.prefix(gi, [u_prev], 0)
    g.set_q(st1, 0, q_prev)
    d_prev = g._det(st1, np.array([u_prev]), q_prev)
    if d_prev * det[1] >= 0 or rcond(g.jacobian(st1))[0] <= SIGN_RCOND:
        return []
    return [Event("bifurcation", g.label, float(ctx.u[0]), 0, 0.0)]


def _crossing(gi: int, g: NewtonGroup, ctx: _Context, a: int, det: np.ndarray) -> float:
    """The driver value between samples ``a`` and ``a + 1`` where the group's
    determinant vanishes: Brent's method on the group solved there, else (when a solve
    in between fails or lands on a pose whose determinant does not bracket) the linear
    interpolation of the two samples' determinants."""
    u0, u1 = float(ctx.u[a]), float(ctx.u[a + 1])
    q0, q1 = g.get_q(ctx.st, a), g.get_q(ctx.st, a + 1)
    linear = u0 - det[a] * (u1 - u0) / (det[a + 1] - det[a])

    def f(x: float) -> float:
        st1 = ctx.prefix(gi, [x], a)
        t = (x - u0) / (u1 - u0)
        q, stats = g._solve_one(st1, np.array([x]), q0 + t * (q1 - q0))
        if not stats.converged:
            raise ValueError("the group does not close there")
        return g._det(st1, np.array([x]), q)  # as the samples' (see _bifurcations)

    try:
        lo, hi = (u0, u1) if u0 < u1 else (u1, u0)
        # (the ends recomputed as the probes are: on the same, normalised, scale)
        return brent_root(f, lo, hi, xtol=1e-12 * max(1.0, abs(u0)))
    except (ValueError, RuntimeError, FloatingPointError):
        return float(linear)
