"""Design figures of a sweep: limit positions, stroke, time ratio, transmission angles.

* **Limit positions** of each rocker (a link pinned to the ground, other than the driven
  one, that does not turn fully) and of each slider: where its angle (displacement) is
  extreme. Each extreme is located exactly, as the root of the angular velocity (sliding
  velocity) found with Brent's method between the two samples that bracket it.
* **Time ratio** (quick-return coefficient) for a crank driven over one full turn: the
  driver travel from one limit to the other, against the travel back; K >= 1 is the
  slower over the faster. Only for a rocker (pivoted to the ground) or a slider on a
  ground guide (a ram): a block sliding along a moving link (the shaper's slot) has
  limit positions too, but the time between them is not a quick-return figure.
* **Minimum transmission angle** of each loop: the angle between the links that transmit
  the force at the loop's inner joint (RRR), between the rod and the guide's normal (RRP);
  90 degrees for a slotted bar whose line passes through its pivot (RPR). It is the arcsine
  of the loop's singularity indicator; 0 is a toggle position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.numerics import brent_root
from mechsolve.core.loads import states_between
from mechsolve.core.solution import full_cycle
from mechsolve.model import GROUND

if TYPE_CHECKING:
    from mechsolve.core.solution import Solution


class _Sweep:
    """What the design figures read of a solved sweep."""

    def __init__(self, sol: Solution) -> None:
        self.solution = sol
        self.analysis = sol.analysis
        self.mechanism = sol.analysis.mech
        self.u = sol.u
        self.ok = sol.ok
        self.events = sol.events

    def is_full_cycle(self) -> bool:
        return full_cycle(self.analysis.linear, self.u)


@dataclass
class LimitPositions:
    """The extremes of a rocker's angle (rad) or a slider's displacement (m)."""

    name: str
    kind: str  # "rocker" or "slider"
    low: float
    u_low: float
    high: float
    u_high: float
    time_ratio: float | None = None
    forward: float | None = None  # driver travel from low to high (rad)
    back: float | None = None
    # every driver value where the extreme is reached, in the order of the sweep (the
    # first is u_low / u_high): a rocker driven through a linkage can reach its extreme
    # twice per turn (the crane's tie, at 27.487 and 355.182 deg of the crank)
    u_lows: tuple[float, ...] = ()
    u_highs: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        self.u_lows = self.u_lows or (self.u_low,)
        self.u_highs = self.u_highs or (self.u_high,)

    @property
    def swing(self) -> float:
        return self.high - self.low

    @property
    def travels(self) -> bool:
        """A travel (a slider's stroke, m) rather than a swing (a rocker's angle, rad)."""
        return self.kind != "rocker"


@dataclass
class Transmission:
    """The smallest transmission angle of a loop over the sweep (rad)."""

    group: str
    angle: float
    u: float


def _rate_root(res: _Sweep, k: int, value_rate):
    """Driver value in (u_k, u_k+1) where the rate changes sign (Brent's method)."""
    an, sol = res.analysis, res.solution

    def f(x: float) -> float:
        one = an.solve(np.array([x]), start=sol.start, near=(sol, k), per_unit_driver=True)
        return float(value_rate(one.state)[1][0])

    lo, hi = float(res.u[k]), float(res.u[k + 1])
    flo, fhi = f(lo), f(hi)
    if not (np.isfinite(flo) and np.isfinite(fhi)) or flo * fhi > 0:
        return None
    if flo == 0.0 or fhi == 0.0:  # a sample exactly at the extreme
        x = lo if flo == 0.0 else hi
        one = an.solve(np.array([x]), start=sol.start, near=(sol, k), per_unit_driver=True)
        return x, float(value_rate(one.state)[0][0])
    try:
        x = brent_root(f, lo, hi, xtol=1e-14, rtol=1e-15, fa=flo, fb=fhi)
    except (ValueError, RuntimeError):  # a position that cannot close, or no convergence
        return None
    one = an.solve(np.array([x]), start=sol.start, near=(sol, k), per_unit_driver=True)
    return x, float(value_rate(one.state)[0][0])


def _edge_value(res: _Sweep, k: int, value_rate, vk: float, angle: bool, x: float = math.nan):
    """(driver value, value) where the motion next to solved sample ``k`` meets an
    unassemblable range: at the range's exact edge when known (``x``, else that of the
    unsolved run next to ``k``), else at the sample."""
    sol = res.solution
    for f in sol.failures if not np.isfinite(x) else ():
        if f.first == k + 1 and np.isfinite(f.edge_in):
            x = f.edge_in
        elif f.last == k - 1 and np.isfinite(f.edge_out):
            x = f.edge_out
    if not np.isfinite(x):
        return float(res.u[k]), vk
    one = res.analysis.solve(
        np.array([x]), start=sol.start, near=(sol, k), per_unit_driver=True, limits=False
    )
    v = float(value_rate(one.state)[0][0])
    if not (one.ok[0] and np.isfinite(v)):
        return float(res.u[k]), vk
    if angle:  # next to the unwrapped samples
        v += 2 * math.pi * round((vk - v) / (2 * math.pi))
    return x, v


def _in_sweep_order(res: _Sweep, us: list[float]) -> tuple[float, ...]:
    """Driver values in the order the sweep meets them, each position once (over a full
    turn, u and u + 2 pi are one position)."""
    u0 = float(res.u[0])
    d = res.mechanism.driver.direction
    full = res.is_full_cycle()
    out: list[float] = []
    for x in sorted(us, key=lambda x: d * (x - u0)):
        same = [
            y for y in out if abs(x - y) < 1e-9 or (full and abs(abs(x - y) - 2 * math.pi) < 1e-9)
        ]
        if not same:
            out.append(x)
    return tuple(out)


def limit_positions(sol: Solution) -> list[LimitPositions]:
    """Limit positions of the rockers and sliders, with the time ratio over a full turn."""
    res = _Sweep(sol)
    mech, an = res.mechanism, res.analysis
    driven = mech.joint(mech.driver.joint)
    items = _outputs(mech, an.system, driven)
    out = []
    ok = res.ok
    full = res.is_full_cycle()
    moving = _moving_state(res)
    for name, kind, vr, grounded in items:
        val, rate = vr(res.solution.state)
        rate = vr(moving)[1]
        val = np.where(ok, val, np.nan)
        if kind == "rocker":
            # unwrapped over the solved samples only (a filler across a gap would add
            # a spurious turn)
            val = val.copy()
            val[ok] = np.unwrap(val[ok])
            if np.nanmax(val) - np.nanmin(val) >= 2 * math.pi - 1e-9:
                continue  # it turns fully: not a rocker
        scale = 1.0 if kind == "rocker" else an.scale
        if not np.nanmax(val) - np.nanmin(val) > 1e-9 * scale:
            # it does not move (a link pinned to the ground twice, a redundant tie): its
            # rate is rounding, whose every change of sign is no limit position
            continue
        sgn = np.sign(rate * res.mechanism.driver.direction * np.sign(an.speed or 1.0))
        # a sample exactly at an extreme (rate 0) takes the sign before it, so that the
        # change of sign is still seen between two samples
        for i in np.flatnonzero(sgn == 0):
            if i > 0 and np.isfinite(sgn[i - 1]):
                sgn[i] = sgn[i - 1]
        extremes = _rate_roots(res, vr, val, sgn, kind == "rocker")
        edges = _edges(res, vr, val, kind == "rocker", extremes)
        if not extremes:
            continue
        hi = max((e for e in extremes if e[2]), key=lambda e: e[1], default=None)
        lo = min((e for e in extremes if not e[2]), key=lambda e: e[1], default=None)
        if hi is None or lo is None:
            continue
        # an extreme reached at several positions (equal but for rounding): all of them,
        # not the one that rounding happens to favour
        tol = 1e-9 * max(hi[1] - lo[1], 1e-12)
        u_highs = _in_sweep_order(res, [e[0] for e in extremes if e[2] and e[1] >= hi[1] - tol])
        u_lows = _in_sweep_order(res, [e[0] for e in extremes if not e[2] and e[1] <= lo[1] + tol])
        lp = LimitPositions(
            name, kind, lo[1], u_lows[0], hi[1], u_highs[0], u_lows=u_lows, u_highs=u_highs
        )
        if grounded and full and len(extremes) == 2 and not edges:
            fwd = (hi[0] - lo[0]) * mech.driver.direction % (2 * math.pi)
            back = 2 * math.pi - fwd
            lp.forward, lp.back = fwd, back
            lp.time_ratio = max(fwd, back) / min(fwd, back)
        out.append(lp)
    return out


def _moving_state(res: _Sweep):
    """A state whose rates tell which way each output moves along the sweep: the sweep's
    own; for a sweep at rest (speed 0, quasi-static: its rates are all zero) the same
    positions with their rates per unit driver coordinate, so that the limit positions
    are the geometry's, as at any speed."""
    sol = res.solution
    ud = sol.driver_rates()[0]
    if sol.analysis.mech.driver.motion is not None or np.any(ud[res.ok] != 0):
        return sol.state
    return states_between(res.analysis, sol, sol.u, 1.0, 0.0)[0]


def _outputs(mech, sys_, driven) -> list:
    """The rockers (links pinned to the ground) and sliders whose limits are sought:
    (name, kind, value and rate of a state, whether it moves against the ground)."""
    items = []
    for j in mech.joints:
        if j.coordinate == "angle" and GROUND in j.links and j is not driven:
            link = j.b if j.a == GROUND else j.a
            b = sys_.index[link]

            def vr(st, b=b):
                return st.th[b], st.w[b]

            items.append((link, "rocker", vr, True))
        elif j.coordinate == "length" and j is not driven:
            sl = sys_.by_joint[j.name]

            def vr(st, sl=sl):
                return sl.displacement(st), sl.velocity(st)

            # a ram on a ground guide has a working and a return stroke; a block on a
            # moving guide (a slotted bar) does not: no time ratio for it
            items.append((j.name, "slider", vr, GROUND in (j.guide, j.block)))
    return items


def _rate_roots(res: _Sweep, vr, val: np.ndarray, sgn: np.ndarray, angle: bool) -> list:
    """The extremes between samples where the rate changes sign, located exactly:
    (driver value, value, is a maximum)."""
    ok = res.ok
    extremes = []  # (u, value, is_max)
    gaps = {e.after for e in res.events if e.kind == "dead zone"}
    for k in np.flatnonzero(ok[:-1] & ok[1:] & (sgn[:-1] * sgn[1:] < 0)):
        if int(k) in gaps:
            continue  # not a continuous motion between these samples
        root = _rate_root(res, int(k), vr)
        if root is None:
            continue
        x, v = root
        if angle:  # bring the angle next to the unwrapped samples
            v = v + 2 * math.pi * round((val[k] - v) / (2 * math.pi))
        extremes.append((x, v, sgn[k] > 0))
    return extremes


def _edges(res: _Sweep, vr, val: np.ndarray, angle: bool, extremes: list) -> list:
    """Where the sweep meets an unassemblable range the motion stops at a toggle position:
    there (located exactly, see Analysis.locate_edges; else at the solved sample next to
    it) the swing is bounded too. The same at a dead zone stepped over between two
    solved samples: the motion stops at its edge after the one and starts again at its
    edge before the other. Adds the edges that bound it to ``extremes``."""
    ok = res.ok
    edges = []
    for k in np.flatnonzero(ok & ~np.r_[ok[1:], True] | ok & ~np.r_[True, ok[:-1]]):
        if 0 < k < len(ok) - 1 or not ok.all():
            if (k > 0 and not ok[k - 1]) or (k < len(ok) - 1 and not ok[k + 1]):
                edges.append(_edge_value(res, int(k), vr, float(val[k]), angle))
    for e in res.events:
        k = e.after
        if e.kind == "dead zone" and 0 <= k < len(ok) - 1 and ok[k] and ok[k + 1]:
            edges.append(_edge_value(res, k, vr, float(val[k]), angle, e.edge_in))
            edges.append(_edge_value(res, k + 1, vr, float(val[k + 1]), angle, e.edge_out))
    if edges and extremes:
        vals = [e[1] for e in extremes] + [e[1] for e in edges]
        top, bottom = max(vals), min(vals)
        for x, v in edges:
            if v == top:
                extremes.append((x, v, True))
            if v == bottom:
                extremes.append((x, v, False))
    elif edges and len(edges) >= 2:
        (x1, v1), (x2, v2) = max(edges, key=lambda e: e[1]), min(edges, key=lambda e: e[1])
        extremes += [(x1, v1, True), (x2, v2, False)]
    return edges


def _exact_minimum(res: _Sweep, gi: int, g, k: int):
    """The transmission angle's minimum next to sample ``k``, located exactly: the root of
    the rate of the loop's discriminant (which is least where the angle is) by Brent's method in an
    interval beside ``k`` where that rate changes sign (over a full turn the last sample
    is the first one's neighbour before it). Returns (angle, driver value) or None."""
    an, sol = res.analysis, res.solution
    n = len(res.u)
    ok = res.ok
    pairs = [(k - 1, k), (k, k + 1)]
    if k == 0 and res.is_full_cycle():
        pairs.append((n - 2, n - 1))
    if k == n - 1 and res.is_full_cycle():
        pairs.append((0, 1))
    gaps = {e.after for e in sol.events if e.kind == "dead zone"}

    def disc(x: float, near: int):
        one = an.solve(
            np.array([x]), start=sol.start, near=(sol, near), per_unit_driver=True, limits=False
        )
        if not one.ok[0]:
            return math.nan, math.nan
        # the discriminant's minimum is the indicator's (both grow with the same distance)
        return float(one.indicator[gi][0]), float(g.disc(one.state)[1][0])

    best = None
    for a, b in pairs:
        if not (0 <= a and b < n and ok[a] and ok[b]) or a in gaps:
            continue
        ua, ub = float(res.u[a]), float(res.u[b])
        fa, fb = disc(ua, a)[1], disc(ub, b)[1]
        if not (np.isfinite(fa) and np.isfinite(fb)) or fa * fb > 0:
            continue
        try:
            x = brent_root(
                lambda x, a=a: disc(x, a)[1], ua, ub, xtol=1e-15, rtol=1e-15, fa=fa, fb=fb
            )
        except (ValueError, RuntimeError):
            continue
        ind = disc(x, a)[0]
        if np.isfinite(ind):
            mu = math.asin(min(max(ind, 0.0), 1.0))
            if best is None or mu < best[0]:
                best = (mu, x)
    return best


def transmission_angles(sol: Solution) -> list[Transmission]:
    """The smallest transmission angle of each two-branch loop over the sweep."""
    res = _Sweep(sol)
    out = []
    sol = res.solution
    for gi, g in enumerate(res.analysis.plan):
        if g.n_modes != 2:
            continue
        ind = np.where(res.ok, sol.indicator[gi], np.nan)
        if not np.any(np.isfinite(ind)):
            continue
        mu = np.arcsin(np.clip(ind, 0.0, 1.0))
        k = int(np.nanargmin(mu))
        best, uk = float(mu[k]), float(res.u[k])
        exact = _exact_minimum(res, gi, g, k)
        if exact is not None:
            if exact[0] < best:
                best, uk = exact
        elif 0 < k < len(mu) - 1 and np.all(np.isfinite(mu[k - 1 : k + 2])):
            a, b, c = mu[k - 1], mu[k], mu[k + 1]
            den = a - 2 * b + c
            if den > 0:  # a parabola through the three samples around the minimum
                t = 0.5 * (a - c) / den
                best = float(b - 0.25 * (a - c) * t)
                uk = float(res.u[k] + t * (res.u[k + 1] - res.u[k]))
        zones = [e for e in sol.events if e.group == g.label and e.kind == "dead zone"]
        for e in sol.events:  # refined minima found by the branch analysis
            if e.group == g.label and e.kind != "dead zone" and e.transmission < best:
                best, uk = e.transmission, e.u
        # where the sweep meets a range in which the loop cannot close (a run of unsolved
        # samples, or a dead zone stepped over between two), it stops closing at a root of
        # its discriminant (located between the samples): its two links are in line
        # there, a transmission angle of 0 (a dead zone not located: at its deepest point)
        edges = [x for f in sol.failures if f.group == g.label for x in (f.edge_in, f.edge_out)]
        edges += [x for e in zones for x in (e.edge_in, e.edge_out)]
        edges = [x for x in edges if math.isfinite(x)]
        edges = edges or [e.u for e in zones]
        if edges and best > 0.0:
            best, uk = 0.0, _in_sweep_order(res, edges)[0]
        out.append(Transmission(g.label, max(best, 0.0), uk))
    return out
