"""Branch events along a sweep: where a two-branch group meets a singular configuration.

Each group's discriminant vanishes where its branches meet; its minima are located
exactly on a grid no coarser than :data:`EVENT_STEP` (bisection on the exact rate). A
minimum that touches zero is a bifurcation (the smooth motion changes branch there), one
below zero a dead zone stepped over. :class:`_Context` solves the groups before a given
one at new driver values.

:class:`BranchEvents` is a part of :class:`~mechsolve.core.sweep.Analysis`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mechsolve.base.state import State
from mechsolve.core.solution import Event, StartAssembly
from mechsolve.groups import Drive, Group, NewtonGroup

TOUCH = 1e-10  # |discriminant| below this at a minimum: the branches meet (bifurcation)

NO_TOUCH = 1e-6  # a minimum proven above this needs no further refinement

SETTLE_WIDTH = 0.02  # brackets this short (rad, or of the size) are convex about a minimum

EVENT_STEP = math.radians(2.0)  # the branch analysis's coarsest grid (x size: linear driver)

EVENT_CHECK = 0.25  # examine minima whose interpolated discriminant is below this

NEAR_SINGULAR = math.sin(math.radians(3.0))

# a bifurcation this near the sweep's start (rad, or of the size) is at the start: the
# start assembly reads the branch past it, and the sweep does not flip there
START_SNAP = 1e-6


def _coincident_at(g: Group, st: State, i: int) -> bool:
    """Do the outer joints of the group coincide at position ``i`` (see RRR)?"""
    f = getattr(g, "coincident", None)
    c = f(st) if f is not None else None
    return c is not None and bool(c[i])


def _hermite_min(h0, h1, d0, d1):
    """Smallest value of the cubic Hermite interpolant on [0, 1] (values h, slopes d)."""
    if len(h0) == 0:
        return np.zeros(0)
    b00, b10, b01, b11 = _HERMITE_BASIS
    vals = b00 * h0 + b10 * d0 + b01 * h1 + b11 * d1
    return vals.min(axis=0)


def _hermite_basis(k: int = 17):
    t = np.linspace(0.0, 1.0, k)[:, None]
    t2, t3 = t * t, t * t * t
    return (2 * t3 - 3 * t2 + 1, t3 - 2 * t2 + t, -2 * t3 + 3 * t2, t3 - t2)


_HERMITE_BASIS = _hermite_basis()


class _Context:
    """What the groups of one sweep share: the state so far, the branches and the driver
    values; evaluates the groups before a given one at new driver values."""

    def __init__(self, an: Any, st: State, u, start: StartAssembly, flips, q_start):
        self.an = an
        self.st = st
        self.u = u
        self.start = start
        self.flips = flips
        self.q_start = q_start
        self.is_start = True  # u[0] is the sweep's start (not a chunk, nor a single position)
        # the branch analysis's points between samples further apart than its grid step:
        # (driver values of samples and points, which are samples, the sample before each
        # point, the state at the points with the groups solved so far)
        self.grid: tuple | None = None
        self.grid_upto = 0  # the groups before this one are solved on the grid

    def build_grid(self, step: float) -> None:
        """Points between the samples so that the grid is no coarser than ``step``; the
        groups are solved there as the sweep solves them (:meth:`extend_grid`)."""
        u = self.u
        n = len(u)
        if n < 2:
            return
        gaps = np.abs(np.diff(u))
        if not (gaps > step).any():  # every gap is within the step: no point to add
            return
        extra = np.maximum(np.ceil(gaps / step).astype(int) - 1, 0)
        if not extra.any():
            return
        counts = extra + 1
        owner = np.repeat(np.arange(n - 1), counts)
        first = np.cumsum(counts) - counts
        j = np.arange(len(owner)) - np.repeat(first, counts)  # 0: the sample itself
        frac = j / np.repeat(counts, counts)
        ug = np.append(u[owner] + frac * (u[owner + 1] - u[owner]), u[-1])
        at_sample = np.append(j == 0, True)
        near = np.append(owner, n - 1)
        gst = State(self.an.system.nb, int(np.sum(~at_sample)))
        self.grid = (ug, at_sample, near, gst)

    def extend_grid(self, gi: int) -> None:
        """Solve group ``gi`` (positions and rates) at the grid's points between samples."""
        if self.grid is None or gi >= self.grid_upto:
            return  # no group after this one needs it
        ug, at_sample, near, gst = self.grid
        mid = ~at_sample
        with np.errstate(invalid="ignore", divide="ignore"):
            self._solve_group(gi, gst, ug[mid], near[mid])

    def _solve_group(self, gj: int, st: State, u_new: np.ndarray, near_k) -> None:
        """Group ``gj`` at driver values ``u_new`` (the groups before it solved in ``st``),
        each near sample ``near_k`` of the sweep, with its rates per unit driver."""
        an = self.an
        g = an.plan[gj]
        m = len(u_new)
        unit = Drive(u_new, np.ones(m), np.zeros(m))
        if isinstance(g, NewtonGroup):
            for j in range(m):
                k = int(near_k[j])
                q = g.get_q(self.st, k)
                du = u_new[j] - self.u[k]
                qd = g.get_qdot(self.st, k)
                q0 = q + qd * du if np.all(np.isfinite(qd)) else q
                st1 = st.take([j])
                qj, stats = g.solve_at(st1, u_new[j : j + 1], q0)
                g.set_q(st, j, qj if stats.converged else np.full_like(qj, np.nan))
            st.token = State.new_token()
            g.velocity(st, unit)
        else:
            sigma = an.sigma_at(self.start.modes[gj], self.flips[gj], u_new)
            g.position(st, unit, sigma)
            g.velocity(st, unit)

    def prefix(self, gi: int, u_new, near_k) -> State:
        """Solve the groups before ``gi`` (positions and derivatives per unit driver
        coordinate) at driver values ``u_new``, each near sample ``near_k`` of the sweep."""
        an = self.an
        u_new = np.atleast_1d(np.asarray(u_new, float))
        near_k = np.broadcast_to(np.asarray(near_k, int), u_new.shape)
        st = State(an.system.nb, len(u_new))
        with np.errstate(invalid="ignore", divide="ignore"):
            for gj in range(gi):
                self._solve_group(gj, st, u_new, near_k)
        return st


class BranchEvents:
    """Methods of :class:`~mechsolve.core.sweep.Analysis`: see the module docstring."""

    # -- the sweep ------------------------------------------------------------------
    def sigma_at(self, sigma0: float, flips: list[float], u: np.ndarray) -> np.ndarray:
        """A two-branch group's branch at driver values ``u``, given its start branch and the
        driver values where the sweep followed it through a bifurcation."""
        u = np.asarray(u, float)
        out = np.full(u.shape, float(sigma0))
        d = self.mech.driver.direction
        for uf in flips:
            out = np.where(d * (u - uf) > 0, -out, out)
        return out

    def _refine_minima(self, gi: int, g: Group, ctx: _Context, cand, u, H, Hs, near):
        """Locate the minima of the discriminant between points ``cand`` and ``cand + 1``
        of the analysis grid ``u`` (with values ``H``, rates along the sweep ``Hs``, and
        the sweep sample ``near`` each grid point lies next to).

        Bisection on its rate H' = 0, evaluating the groups before this one at the
        midpoints (all candidates at once), until the bracket closes in on the minimum
        (to rounding), where H is evaluated. A candidate is settled early only when the
        minimum is proven above zero: once the bracket is short (:data:`SETTLE_WIDTH`),
        H is convex on it, so H lies above both end tangents, and their intersection is a
        lower bound of the minimum; if that bound is above :data:`NO_TOUCH`, the motion
        does not pass through a singular configuration there.
        """
        d = self.mech.driver.direction
        lo, hi = u[cand].copy(), u[cand + 1].copy()
        hlo, hhi = H[cand].copy(), H[cand + 1].copy()
        slo, shi = Hs[cand].copy(), Hs[cand + 1].copy()  # rates along the sweep
        nk = near[cand]
        est = np.full(len(cand), np.nan)
        open_ = np.ones(len(cand), bool)
        settle_w = SETTLE_WIDTH * (self.scale if self.linear else 1.0)
        for _ in range(80):
            w = np.abs(hi - lo)
            with np.errstate(invalid="ignore", divide="ignore"):
                x = (hhi - hlo - shi * w) / (slo - shi)  # where the end tangents meet
                bound = hlo + slo * np.clip(x, 0.0, w)
            settled = (w <= settle_w) & (bound > NO_TOUCH)
            tiny = w <= 4e-16 * (1 + np.abs(lo))
            est = np.where(
                open_ & settled, np.maximum(bound, _hermite_min(hlo, hhi, slo * w, shi * w)), est
            )
            open_ &= ~(settled | tiny)
            if not open_.any():
                break
            k = np.flatnonzero(open_)
            mid = 0.5 * (lo[k] + hi[k])
            hm, dm = g.disc(ctx.prefix(gi, mid, nk[k]))
            sm = dm * d
            down = sm < 0
            lo[k] = np.where(down, mid, lo[k])
            hlo[k] = np.where(down, hm, hlo[k])
            slo[k] = np.where(down, sm, slo[k])
            hi[k] = np.where(down, hi[k], mid)
            hhi[k] = np.where(down, hhi[k], hm)
            shi[k] = np.where(down, shi[k], sm)
        ustar = 0.5 * (lo + hi)
        # where the bracket closed in on the minimum, the discriminant there
        exact = np.isnan(est)
        if exact.any():
            k = np.flatnonzero(exact)
            est[k] = np.asarray(g.disc(ctx.prefix(gi, ustar[k], nk[k]))[0])
        return ustar, est

    def _analysis_grid(self, gi: int, g: Group, ctx: _Context, ok_prev: np.ndarray):
        """The discriminant on the sweep's samples and, where the samples are further
        apart than :data:`EVENT_STEP`, on points in between (evaluating the groups before
        this one there), so that no minimum hides between two samples.

        Returns ``u, H, Hs, good, near, at_sample, known``: the grid's driver values, H
        and its rate along the sweep, where both are known, the sweep sample each point
        lies next to (the interval it is in), which grid points are samples, and where H
        alone is known (at a sample where an earlier group is singular too, as in a chain
        of parallelograms at its collinear position, H is known but not its rate).
        """
        H, dH = g.disc(ctx.st)
        d = self.mech.driver.direction
        u = ctx.u
        n = len(u)
        known = ok_prev & np.isfinite(H)
        good = known & np.isfinite(dH)
        if ctx.grid is None:
            return u, H, dH * d, good, np.arange(n), np.ones(n, bool), known
        ug, at_sample, near, gst = ctx.grid
        Hg = np.empty(len(ug))
        dHg = np.empty(len(ug))
        idx = np.flatnonzero(at_sample)
        Hg[idx], dHg[idx] = H, dH
        mid = np.flatnonzero(~at_sample)
        hm, dm = g.disc(gst)  # the groups before this one are solved there
        Hg[mid], dHg[mid] = hm, dm
        goodg = np.empty(len(ug), bool)
        goodg[idx] = good
        k = near[mid]
        between = np.isfinite(hm) & known[k] & known[k + 1]
        goodg[mid] = between & np.isfinite(dm)
        knowng = goodg.copy()
        knowng[idx] = known
        knowng[mid] = between
        return ug, Hg, dHg * d, goodg, near, at_sample, knowng

    def _branch_events(self, gi: int, g: Group, ctx: _Context, ok_prev: np.ndarray):
        """Find where a two-branch group meets a singular configuration along the sweep.

        The group's discriminant H (zero where its branches meet) depends only on earlier
        groups; with its exact rate H' it locates each local minimum of H on a grid no
        coarser than :data:`EVENT_STEP`: between two grid points where H' changes sign,
        refined by bisection on H' = 0 (see :meth:`_refine_minima`). At a minimum where H
        touches zero (to rounding) the motion passes through a bifurcation point: the
        smooth continuation is on the other branch, so the branch flips there. A minimum
        below zero means the sweep stepped over a dead zone. A minimum at the sweep's
        first position does not flip anything: the start's branch is the one the motion
        takes from there (see :meth:`assemble`).
        """
        d = self.mech.driver.direction
        u, H, Hs, good, near, at_sample, known = self._analysis_grid(gi, g, ctx, ok_prev)
        found = self._minima_between_samples(gi, g, ctx, u, H, Hs, good, near, at_sample)
        # both add only grid points inside with H below NEAR_SINGULAR^2 (> TOUCH): one
        # test over the grid when there are none (most sweeps)
        if np.any(H[1:-1] < NEAR_SINGULAR**2):
            _minima_at_grid_points(found, u, H, known, near)
            _near_singular_at_grid_points(found, u, H, good, near)
        found.sort(key=lambda f: d * f[1])
        return self._events_at(gi, g, ctx, _merge_minima(found))

    def _minima_between_samples(
        self, gi: int, g: Group, ctx: _Context, u, H, Hs, good, near, at_sample
    ) -> list[tuple[int, float, float]]:
        """The minima of H between two grid points where H' changes sign, refined, in
        intervals between two samples where the group closes: (sample before, u*, H*)."""
        # intervals between two samples where the group closes (a minimum elsewhere is
        # part of a range where it cannot close, reported as such)
        if len(u) == len(ctx.u):  # no points between the samples: the grid is the sweep
            closes = good & (H >= -TOUCH)
            pair = closes[:-1] & closes[1:]  # good at both ends, and both close
        else:
            hs_ = H[at_sample]
            closes = good[at_sample] & (hs_ >= -TOUCH)
            both = closes[:-1] & closes[1:]
            owner = np.minimum(near[:-1], len(closes) - 2) if len(closes) > 1 else near[:-1]
            pair = good[:-1] & good[1:] & (both[owner] if len(closes) > 1 else False)
        inside = np.flatnonzero(pair & (Hs[:-1] < 0) & (Hs[1:] > 0))
        h = np.abs(u[inside + 1] - u[inside])
        est = _hermite_min(H[inside], H[inside + 1], Hs[inside] * h, Hs[inside + 1] * h)
        cand = inside[est < EVENT_CHECK]
        found: list[tuple[int, float, float]] = []  # (sample before, u*, H*)
        if cand.size:
            us, hs = self._refine_minima(gi, g, ctx, cand, u, H, Hs, near)
            found += list(zip(near[cand].tolist(), us.tolist(), hs.tolist()))
        return found

    def _events_at(
        self, gi: int, g: Group, ctx: _Context, merged: list[tuple[int, float, float]]
    ) -> tuple[list[Event], list[str]]:
        """The events at the minima of H (in the sweep's order): a dead zone below zero, a
        bifurcation (the branch flips) at zero, a near-singular position close to it."""
        u_s = ctx.u
        events: list[Event] = []
        warnings: list[str] = []
        for k, us, hs in merged:
            # a minimum on a sample (to rounding) is that sample: the sample keeps the
            # branch it comes in on, and the flip applies after it
            j = int(np.argmin(np.abs(u_s - us)))
            # (a sample where the group's outer joints coincide, to within the
            # tolerance its pose treats as coincident, is at the minimum too: its pose
            # is the limit from the side it is reached from)
            at_start = (
                j == 0
                and ctx.is_start
                and abs(u_s[0] - us) <= START_SNAP * (self.scale if self.linear else 1.0)
            )
            if (
                abs(u_s[j] - us) <= 1e-12 * (1.0 + abs(us))
                or _coincident_at(g, ctx.st, j)
                or at_start
            ):
                us = float(u_s[j])
                if j == 0 and ctx.is_start:
                    continue  # the start's branch is the one taken from the start
            mu = float(np.arcsin(np.sqrt(max(min(hs, 1.0), 0.0))))
            if hs < -TOUCH:
                events.append(Event("dead zone", g.label, us, k, 0.0))
                warnings.append(
                    f"between {self.format_u(u_s[k])} and {self.format_u(u_s[k + 1])} the "
                    f"{g.label} cannot close (near {self.format_u(us)}): the sweep steps over "
                    "this dead zone; the motion between these positions is not continuous "
                    "(use a smaller step to see it)"
                )
            elif hs <= TOUCH:
                events.append(Event("bifurcation", g.label, us, k, mu))
                ctx.flips[gi].append(us)
            elif mu < math.radians(3.0):
                events.append(Event("near-singular", g.label, us, k, mu))
        return events, warnings


def _minima_at_grid_points(found: list, u, H, known, near) -> None:
    """Add the minima exactly at a grid point where H touches zero (one that a refined
    minimum next to it already is, a sample 1e-5 past a bifurcation that touches zero to
    rounding, is not a second event: two would flip the branch twice)."""
    refined = list(found)
    for k in np.flatnonzero(known[1:-1] & (np.abs(H[1:-1]) <= TOUCH)) + 1:
        if known[k - 1] and known[k + 1] and H[k - 1] > H[k] < H[k + 1]:
            span = abs(u[k + 1] - u[k - 1])
            if any(1e-9 * (1.0 + abs(f[1])) < abs(f[1] - u[k]) <= span for f in refined):
                continue
            found.append((int(near[k - 1]), float(u[k]), float(H[k])))


def _near_singular_at_grid_points(found: list, u, H, good, near) -> None:
    """Add the near-singular minima seen at the grid points themselves (where the group
    closes) that no minimum found so far is next to."""
    closable = good & (H >= -TOUCH)
    for k in np.flatnonzero(closable[1:-1] & (H[1:-1] < NEAR_SINGULAR**2)) + 1:
        if not (closable[k - 1] and closable[k + 1]):
            continue
        if H[k - 1] >= H[k] <= H[k + 1] and not any(
            abs(f[1] - u[k]) <= abs(u[k + 1] - u[k - 1]) for f in found
        ):
            found.append((int(near[k - 1]), float(u[k]), float(H[k])))


def _merge_minima(found: list[tuple[int, float, float]]) -> list[tuple[int, float, float]]:
    """One minimum seen from both sides of a point is one event (the lower H kept);
    ``found`` is in the sweep's order."""
    merged: list[tuple[int, float, float]] = []
    for f in found:
        if merged and abs(f[1] - merged[-1][1]) <= 1e-9 * (1.0 + abs(f[1])):
            if f[2] < merged[-1][2]:
                merged[-1] = (merged[-1][0], merged[-1][1], f[2])
            continue
        merged.append(f)
    return merged
