"""Where the mechanism cannot close: runs of failed positions with their reasons, the
exact edges of each range, a sweep that starts inside one (skips ahead), and the
Newton polish of positions whose residual is too large.

:class:`FailureReports` is a part of :class:`~mechsolve.core.sweep.Analysis`.
"""

from __future__ import annotations

import dataclasses
import math
from functools import partial
from typing import Any

import numpy as np

from mechsolve.base.errors import AssemblyError, CannotCloseAtStart
from mechsolve.base.newton import solve as newton_solve
from mechsolve.base.numerics import bisect_edge
from mechsolve.base.state import State
from mechsolve.core.branches import TOUCH, _Context
from mechsolve.core.solution import Failure, Solution
from mechsolve.groups import Drive, NewtonGroup

SKIP_PROBES = 36  # start searches spent finding where a sweep that starts dead can begin


def _probed(an: Any) -> str:
    s = getattr(an, "probe_stride", 1)
    if s <= 1:
        return ""
    return (
        f" (positions probed every {s} samples, then one by one back from the first that "
        "closes: a shorter range that closes inside this one would not be seen)"
    )


def _prepend_gap(an: Any, sol: Solution, u: np.ndarray, k: int, exc) -> Solution:
    """The sweep's solution with its first ``k`` positions, where the mechanism could not
    close, put back in front of ``sol`` (solved from position ``k``) as failures."""
    n = len(u)
    nb = an.system.nb
    st = State(nb, n)
    st.block[:, :, k:] = sol.state.block
    st.block[:, :nb, :k] = np.nan
    st.block[:, nb, :k] = sol.state.block[:, nb, :1]  # the ground stays where it is
    ok = np.zeros(n, bool)
    ok[k:] = sol.ok
    fails = [Failure(0, k - 1, exc.group, exc.reason, float(u[0]), float(u[k - 1]))]
    for f in sol.failures:
        fails.append(Failure(f.first + k, f.last + k, f.group, f.reason, f.u_first, f.u_last))
    ind = np.zeros((sol.indicator.shape[0], n))
    ind[:, k:] = sol.indicator
    iters = np.zeros(n, int)
    iters[k:] = sol.iterations
    methods = None
    if sol.methods is not None:
        methods = np.full(n, "failed", dtype=object)
        methods[k:] = sol.methods
    res = None
    if sol.residual_ is not None:
        res = np.full(n, np.nan)
        res[k:] = sol.residual_
    for e in sol.events:
        e.after += k
    warnings = [
        f"the mechanism cannot close at the start of the sweep: from {an.format_u(u[0])} to "
        f"{an.format_u(u[k - 1])} the {exc.reason}; the sweep starts at "
        f"{an.format_u(u[k])}, the first position that closes, on the branches chosen there"
        + _probed(an)
    ] + sol.warnings
    speed = an.speed
    out = Solution(
        an,
        u,
        (u - u[0]) / speed if speed else np.zeros(n),
        st,
        ok,
        fails,
        ind,
        iters,
        methods,
        res,
        dataclasses.replace(sol.start, u0=float(u[0])),  # the sweep still starts at u[0]
        warnings,
        sol.has_velocity,
        sol.has_acceleration,
        sol.events,
        sol.flips,
        [i + k for i in sol.rates_by_limit],
        [i + k for i in sol.rates_undetermined],
    )
    out.skipped_start = k
    return out


class FailureReports:
    """Methods of :class:`~mechsolve.core.sweep.Analysis`: see the module docstring."""

    def solve_sweep(
        self,
        u: np.ndarray,
        velocity: bool = True,
        acceleration: bool = True,
        per_unit_driver: bool = False,
    ):
        """Solve a sweep from its start, as :meth:`solve`; where the mechanism cannot close
        at the start (a dead zone there), skip ahead to the first position where it
        closes, assemble there (on the branches the conditions and sketch ask for), and
        keep the positions skipped as unassemblable rows."""
        u = np.asarray(u, float)
        k = 0
        first: CannotCloseAtStart | None = None
        while True:
            try:
                sol = self.solve(
                    u[k:],
                    velocity=velocity,
                    acceleration=acceleration,
                    per_unit_driver=per_unit_driver,
                )
                break
            except CannotCloseAtStart as exc:
                if first is None:
                    first = exc
                nxt = k + exc.first_ok if exc.first_ok else self._next_closing(u, k)
                if nxt >= len(u) or nxt <= k:
                    raise first from None
                k = nxt
        if k:
            sol = _prepend_gap(self, sol, u, k, first)
        self.locate_edges(sol)
        return sol

    def _next_closing(self, u: np.ndarray, k: int) -> int:
        """The first position after ``k`` where the mechanism closes at the start (its
        index; ``len(u)`` if none): positions probed every ``stride`` (about
        :data:`SKIP_PROBES` probes over the rest of the sweep), then one by one back from
        the first that closes. A probe that fails is a whole start search (every guess,
        Newton and scipy: up to a second for a six-bar's triad), so probing each of 360
        positions of a mechanism that never closes took minutes; this takes about
        SKIP_PROBES. A closing range narrower than the stride inside a range that does
        not close can be missed (the warning says the positions were probed)."""
        n = len(u)
        stride = max(1, math.ceil((n - 1 - k) / SKIP_PROBES))
        self.probe_stride = max(stride, getattr(self, "probe_stride", 1))  # for the warning
        j = k + stride
        while j < n + stride - 1:
            j = min(j, n - 1)
            if self._closes_at(float(u[j])):
                while j - 1 > k and self._closes_at(float(u[j - 1])):
                    j -= 1
                return j
            if j == n - 1:
                break
            j += stride
        return n

    def _closes_at(self, u0: float) -> bool:
        """Whether the start search closes every group at ``u0`` (an assembly condition it
        cannot meet there counts as closing: the sweep started there says so)."""
        try:
            self.assemble(u0)
        except CannotCloseAtStart:
            return False
        except AssemblyError:
            return True
        return True

    def locate_edges(self, sol: Solution) -> None:
        """Where each unassemblable range truly begins and ends: the root of the failing
        loop's discriminant between the last position that closes and the first that does
        not (bisection to rounding, the end kept on the side that closes); and those of
        each dead zone the sweep stepped over between two solved samples (from the
        zone's deepest point, ``Event.u``, to the samples on either side)."""
        zones = [e for e in sol.events if e.kind == "dead zone"]
        if not sol.failures and not zones:
            return
        ctx = _Context(self, sol.state, sol.u, sol.start, sol.flips, {})
        ctx.is_start = False
        labels = {g.label: gi for gi, g in enumerate(self.plan)}
        n = len(sol.u)
        with np.errstate(invalid="ignore", divide="ignore"):
            for f in sol.failures:
                gi = labels.get(f.group)
                if gi is not None and isinstance(self.plan[gi], NewtonGroup):
                    if f.first > 0 and sol.ok[f.first - 1]:
                        f.edge_in = self._newton_edge(sol, gi, f.first - 1, f.u_first)
                    if f.last < n - 1 and sol.ok[f.last + 1]:
                        f.edge_out = self._newton_edge(sol, gi, f.last + 1, f.u_last)
                    continue
                if gi is None or self.plan[gi].n_modes != 2:
                    continue
                if f.first > 0 and sol.ok[f.first - 1]:
                    f.edge_in = self._edge(ctx, gi, f.first - 1, f.first)
                if f.last < n - 1 and sol.ok[f.last + 1]:
                    f.edge_out = self._edge(ctx, gi, f.last + 1, f.last)
            for e in zones:  # stepped over between two samples: from its deepest point
                gi = labels.get(e.group)
                if gi is not None and isinstance(self.plan[gi], NewtonGroup):
                    self._newton_zone_edges(sol, gi, e)
                    continue
                if gi is None or self.plan[gi].n_modes != 2:
                    continue
                k = e.after
                j = next((i for i in range(k + 1, n) if sol.ok[i]), None)
                if 0 <= k < n and sol.ok[k]:
                    e.edge_in = self._edge(ctx, gi, k, k, bad_u=e.u)
                if j is not None:
                    e.edge_out = self._edge(ctx, gi, j, k, bad_u=e.u)

    def _edge(
        self, ctx: _Context, gi: int, good: int, bad: int, bad_u: float | None = None
    ) -> float:
        """The root of group ``gi``'s discriminant between sample ``good`` (where it
        closes) and sample ``bad`` (or the driver value ``bad_u``, where it does not),
        kept on the side that closes; NaN where they do not bracket it."""
        g = self.plan[gi]
        near = min(good, bad)

        def H(x: float) -> float:
            return float(g.disc(ctx.prefix(gi, np.array([x]), near))[0][0])

        a, b = float(ctx.u[good]), float(ctx.u[bad] if bad_u is None else bad_u)
        if not (H(a) >= -TOUCH and H(b) < -TOUCH):
            return math.nan
        return bisect_edge(lambda m: H(m) >= 0.0, a, b)[0]

    def _newton_zone_edges(self, sol: Solution, gi: int, e) -> None:
        """The edges of a dead zone of Newton group ``gi`` that the sweep stepped over
        between samples ``e.after`` and the next solved one (see :meth:`_newton_edge`)."""
        n = len(sol.u)
        k = e.after
        j = next((i for i in range(k + 1, n) if sol.ok[i]), None)
        if 0 <= k < n and sol.ok[k]:
            e.edge_in = self._newton_edge(sol, gi, k, e.u)
        if j is not None:
            e.edge_out = self._newton_edge(sol, gi, j, e.u)

    def _newton_edge(self, sol: Solution, gi: int, good: int, bad_u: float) -> float:
        """Where Newton group ``gi`` stops closing between sample ``good`` and the driver
        value ``bad_u`` (where it does not close), or NaN.

        The group's motion ends there at a fold: its block is singular, and along the
        motion its determinant vanishes as the square root of the distance to the edge,
        so the square of the determinant is smooth and linear in the driver there. The
        edge is bracketed by marching from the sample towards ``bad_u`` on grids of 9
        points (the last that closes and the first that does not, twice: each point past
        the edge costs a failed continuation), then refined as the root of the parabola
        through the squared determinant at ``d``, ``2d`` and ``3d`` before the estimate,
        ``d`` from a quarter of the distance to the sample down tenfold a round to 1e-6
        rad (or of the size): the parabola's error goes as ``d^3``, and a Newton solve
        that accepts a pose just past a shallow fold does not enter. A round whose
        parabola has no single root within ``3d`` leaves the estimate (the fold is
        sharper than ``d``)."""
        lo, hi = float(sol.u[good]), float(bad_u)
        if not self._closes_on(sol, good, np.array([lo]))[0]:
            return math.nan
        for _ in range(2):
            x = np.linspace(lo, hi, 9)[1:]
            ok = self._closes_on(sol, good, x)
            if ok.all():
                return math.nan  # it closes at bad_u: no edge in between
            first = int(np.argmin(ok))
            lo, hi = (x[first - 1] if first else lo), x[first]
        return self._fold_root(sol, gi, good, lo)

    def _fold_root(self, sol: Solution, gi: int, good: int, est: float) -> float:
        """The edge of :meth:`_newton_edge` refined from its bracket's end ``est``."""
        g = self.plan[gi]
        u0 = float(sol.u[good])
        toward = math.copysign(1.0, est - u0)
        d = abs(est - u0) / 4.0
        floor = 1e-6 * (self.scale if self.linear else 1.0)  # (the error then ~ d^3)
        while d > floor:
            x = est - toward * d * np.array([3.0, 2.0, 1.0])  # from the sample's side
            one = self.solve(np.r_[u0, x], start=sol.start, near=(sol, good),
                             velocity=False, acceleration=False, limits=False)  # fmt: skip
            det, known = g.dets(one.state, one.ok)
            if not (known[1:].all() and one.ok.all()):
                break
            c = np.polyfit(x - est, det[1:] ** 2, 2)
            roots = [r.real for r in np.roots(c) if abs(r.imag) <= 1e-9 * d]
            roots = [r for r in roots if abs(r) <= 3.0 * d]
            if len(roots) == 1:  # (else the fold is sharper than d: closer)
                est += roots[0]
            d /= 10.0
        return float(est)

    def _closes_on(self, sol: Solution, good: int, x: np.ndarray) -> np.ndarray:
        """Where the motion marched from sample ``good`` through the driver values ``x``
        (in order) closes: True up to the first that does not."""
        one = self.solve(np.r_[sol.u[good], x], start=sol.start, near=(sol, good),
                         velocity=False, acceleration=False, limits=False)  # fmt: skip
        ok = np.asarray(one.ok, bool)[1:]
        return np.cumprod(ok).astype(bool)

    def _failures(self, st: State, oks, ok, st_u) -> list[Failure]:
        out: list[Failure] = []
        if ok.all():
            return out
        bad = np.concatenate(([False], ~ok, [False]))
        edges = np.flatnonzero(bad[1:] != bad[:-1])  # starts and ends of runs of failures
        for i, j in zip(edges[0::2], edges[1::2] - 1):
            i, j = int(i), int(j)
            gi = next((k for k, o in enumerate(oks) if not o[i]), None)
            if gi is None:
                group, reason = "the whole system", "the constraint residual stays above tolerance"
            else:
                g = self.plan[gi]
                group = g.label
                if not isinstance(g, NewtonGroup):
                    words = partial(self.mech.output_units().text, unit="m")  # the file's unit
                    reason = g.fail_reason(st, i, words)
                elif g.stopped is not None and i >= g.stopped[0] and i > 0:
                    k, near, before = g.stopped
                    reason = (
                        f"{g.label}: cannot be followed continuously from "
                        f"{self.format_u(st_u[k - 1])}: the solution jumps near "
                        f"{self.format_u(near)} even in the finest substeps "
                        + (
                            f"(and it broke off {before} times before), "
                            if before
                            else "(a singular position it turns through faster than a "
                            "substep, or a range where it cannot close after a bifurcation "
                            "has changed its branch), "
                        )
                        + "so its branch past there is not known; the sweep stops there: "
                        "use a smaller step"
                    )
                else:
                    reason = f"{g.label}: Newton-Raphson and scipy found no closed position"

            out.append(Failure(i, j, group, reason, float(st_u[i]), float(st_u[j])))
        return out

    def _polish(self, st: State, drive: Drive, i: int):
        """Newton on the whole system at position ``i`` from the closed-form answer."""
        st1 = st.take([i])
        sys_ = self.system
        u1 = drive.u[i : i + 1]

        def setq(q):
            for b in range(sys_.nb):
                st1.x[b, 0], st1.y[b, 0] = q[3 * b], q[3 * b + 1]
                st1.set_angle(b, q[3 * b + 2], 0)

        def fun(q):
            setq(q)
            return sys_.residual(st1, u1)[:, 0]

        def jac(q):
            setq(q)
            return sys_.jacobian(st1)[0]

        q0 = st1.q()[0]
        if not np.all(np.isfinite(q0)):
            return False, np.nan, 0
        q, stats = newton_solve(fun, jac, q0, self.atol, self.mech.solver.max_iterations)
        if stats.converged:
            setq(q)
            st.put([i], st1)
        return stats.converged, stats.residual, stats.iterations
