"""The ranges of the points' coordinates over a sweep, located between the samples.

A coordinate's largest (smallest) value is where its rate along the driver vanishes. From
the extreme sample ``k``, the extreme is found by Newton's method on that rate,
``x <- x - q'(x) / q''(x)`` (``q'``, ``q''`` per unit of the driver coordinate), each
step solving the position there next to sample ``k`` (on the sweep's branches); the first
step starts from the sample's own rates. It stops when the value is settled to 1e-12 of
the mechanism's size (``q'^2 / (2 |q''|)``, its remaining distance from the extreme): two
steps from a 1° sample. The value is then one the coordinate takes, at a driver value
between the neighbouring samples, and at least the sample's.

Where that cannot be had (a rate that does not vanish: a kink, a dwell of the driver;
an extreme at the edge of an unassemblable range; a step out of the neighbours'
interval) the extreme is the sample's, and said to be (``located`` False). A sweep that
is not a full cycle keeps an extreme at its first or last position as it is: there the
coordinate's rate need not vanish.

Why not the requirements' locator (:class:`mechsolve.results.requirements._Reducer`,
which also locates an extreme of a sampled quantity between its neighbouring samples):
the two were weighed for one locator and kept apart. That one narrows a grid of 65
positions, solved there, 32 times a round down to 1e-8 of the driver coordinate: it
needs no rate, so it serves any expression (a reaction, ``abs(..)``, a product), a kink
or a join, and an extreme that grows without bound at the edge of a range that does not
close. Here a point's coordinate has its first and second rates from the solved state,
so Newton's method settles it in two or three steps of one batched solve for all points
and both senses. The same figures by the grid cost 518 ms against 17 ms for the crane's
points, 283 against 2 ms for the four-bar's and 203 against 11 ms for the six-bar's
(one run on a shared 2-core machine; the figures agree to 1e-13 of the mechanism's
size): the summary would be 20 to 150 times slower. Newton in turn cannot serve a
requirement: its quantities have no second rate, and are not smooth at their extremes in
general.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechsolve.core.solution import StateView, full_cycle

_STEPS = 5  # Newton steps at most (two from a 1° sample, three or four from 10°)
_SETTLED = 1e-12  # of the mechanism's size: the value's remaining error


@dataclass
class Range:
    """A coordinate's smallest and largest value over a sweep (m); ``located``: both
    found between the samples (or exactly at one: a constant, an end of the sweep)."""

    low: float
    high: float
    located: bool


@dataclass
class _Job:
    name: str
    attr: str  # "x" or "y"
    sense: float  # +1 the largest, -1 the smallest
    k: int  # the extreme sample
    lo: float  # the neighbours' interval (driver values)
    hi: float
    x: float  # the current driver value
    q: float  # the value there (the sample's to start with)
    best: float
    done: bool = False
    located: bool = False


def point_ranges(res, names: list[str]) -> dict[str, tuple[Range, Range]]:
    """``{point: (x range, y range)}`` over the sweep of ``res`` (a
    :class:`~mechsolve.results.results.Results`), each end located between the samples
    (see the module docstring)."""
    ok = np.asarray(res.ok, bool)
    view = res.view
    size = res.analysis.scale
    jobs: list[_Job] = []
    out: dict[str, list[Range]] = {}
    for p in names:
        for attr in ("x", "y"):
            q = np.where(ok, np.broadcast_to(view.quantity(p, attr), ok.shape), np.nan)
            if not np.any(np.isfinite(q)):
                continue
            lo, hi = float(np.nanmin(q)), float(np.nanmax(q))
            out.setdefault(p, []).append(Range(lo, hi, True))
            if hi - lo <= _SETTLED * size:
                continue  # it does not move along this axis: the samples are its value
            for sense in (1.0, -1.0):
                job = _first_job(res, p, attr, sense, q)
                if job is not None:
                    jobs.append(job)
    _newton(res, jobs, size)
    for job in jobs:
        r = out[job.name][0 if job.attr == "x" else 1]
        if job.sense > 0:
            r.high = max(r.high, job.best) if job.located else r.high
        else:
            r.low = min(r.low, job.best) if job.located else r.low
        r.located = r.located and job.located
    return {p: (rs[0], rs[1]) for p, rs in out.items() if len(rs) == 2}


def _first_job(res, p: str, attr: str, sense: float, q: np.ndarray) -> _Job | None:
    """The extreme sample of ``sense * q`` and the first Newton step from its rates."""
    sol = res.solution
    ok = np.asarray(res.ok, bool)
    n = len(q)
    k = int(np.nanargmax(sense * q))
    u = np.asarray(res.u, float)
    full = full_cycle(res.analysis.linear, u)
    gaps = {e.after for e in sol.events if e.kind == "dead zone"}
    left = k > 0 and ok[k - 1] and k - 1 not in gaps
    right = k < n - 1 and ok[k + 1] and k not in gaps
    job = _Job(p, attr, sense, k, float(u[k]), float(u[k]), float(u[k]), float(q[k]), float(q[k]))
    if left:
        job.lo = float(u[k - 1])
    elif full and k == 0 and n > 1:  # the first position is the last: before it, its step
        job.lo = float(2 * u[0] - u[1])
    if right:
        job.hi = float(u[k + 1])
    elif full and k == n - 1 and n > 1:
        job.hi = float(2 * u[-1] - u[-2])
    job.lo, job.hi = min(job.lo, job.hi), max(job.lo, job.hi)
    at_end = (k in (0, n - 1)) and not full
    job.done = True  # unless a first step can be taken: the sample's, not located
    if (k > 0 and not ok[k - 1]) or (k < n - 1 and not ok[k + 1]):
        return job  # next to an unassemblable range: its edge bounds it
    if not (sol.has_velocity and sol.has_acceleration):
        return job
    ud, udd = (float(a[k]) for a in sol.driver_rates())
    if ud == 0.0:
        return job  # at rest: no rate along the driver from the sample
    v = float(res.view.quantity(p, "v" + attr)[k])
    a = float(res.view.quantity(p, "a" + attr)[k])
    d1 = v / ud
    d2 = (a - d1 * udd) / (ud * ud)
    if np.isfinite(d1) and abs(d1) * (job.hi - job.lo) <= _SETTLED * res.analysis.scale:
        job.located = True  # its rate vanishes at the sample (the start of a dwell, a join)
        return job
    if not (sense * d2 < 0 and np.isfinite(d1)):
        job.located = at_end  # an end of the sweep holds its own extreme
        return job
    if d1 * d1 / (2 * abs(d2)) <= _SETTLED * res.analysis.scale:
        job.located = True  # a sample at the extreme (a limit position's)
        return job
    job.x = float(u[k] - d1 / d2)
    if not _within(job):
        job.located = at_end
        return job
    job.done = False
    return job


def _newton(res, jobs: list[_Job], size: float) -> None:
    """Run the jobs' Newton steps, the positions of one step solved together (one solve
    per sample they are next to)."""
    an, sol = res.analysis, res.solution
    for _ in range(_STEPS):
        todo = [j for j in jobs if not j.done]
        if not todo:
            return
        by_k: dict[int, list[_Job]] = {}
        for j in todo:
            by_k.setdefault(j.k, []).append(j)
        for k, group in by_k.items():
            xs = np.array([j.x for j in group])
            one = an.solve(xs, start=sol.start, near=(sol, k), per_unit_driver=True, limits=False)
            view = StateView(an, one.state)
            for i, j in enumerate(group):
                _step(j, bool(one.ok[i]), view, i, size)
    for j in jobs:
        if not j.done:
            j.located = False


def _step(j: _Job, ok: bool, view: StateView, i: int, size: float) -> None:
    """One Newton step of job ``j`` from its solved position ``i`` of ``view``."""
    n = view.st.n
    q, d1, d2 = (
        float(np.broadcast_to(view.quantity(j.name, a + j.attr), (n,))[i]) for a in ("", "v", "a")
    )
    q = q if ok else np.nan
    if not (np.isfinite(q) and np.isfinite(d1) and j.sense * d2 < 0):
        j.done = True  # not solved there, or no extreme of the rate's kind: the sample's
        return
    if j.sense * q >= j.sense * j.best:
        j.best = q
    if d1 * d1 / (2 * abs(d2)) <= _SETTLED * size:
        j.done = j.located = True
        return
    j.x -= d1 / d2
    if not _within(j):
        j.done = True


def _within(j: _Job) -> bool:
    """Is the job's driver value between the neighbouring samples (to rounding)?"""
    tol = 1e-9 * (j.hi - j.lo)
    return j.lo - tol <= j.x <= j.hi + tol
