"""Sweeps too long to hold in memory: solved chunk by chunk, written as they go.

Each chunk starts at the previous chunk's last position and continues on its branches
(the bifurcations followed so far, the Newton groups' last solutions), so the result is
the same as one long sweep; the CSV is streamed to disk and only summary figures are
kept. Loads whose conditions use ``stroke(q)`` get the stroke's extremes from a coarse
sweep of the same range (1 degree or 1/1000 of the range), refined by parabolas, so
that every chunk uses the same extremes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mechsolve.base.errors import CannotCloseAtStart
from mechsolve.base.units import SI_OUTPUT, OutputUnits, pretty_unit
from mechsolve.core.evaluate import forces as solve_forces
from mechsolve.core.sweep import Analysis, Failure, Solution
from mechsolve.model import Mechanism
from mechsolve.results.csv import CsvStream, in_units
from mechsolve.results.results import Results
from mechsolve.results.run import checked_mechanism, checked_method, checked_step
from mechsolve.results.summary import rms_over

CHUNK = 50_000


@dataclass
class StreamSummary:
    """What a streamed sweep found: counts, ranges, failures, peaks and the work."""

    name: str
    positions: int = 0
    solved: int = 0
    failures: list[Failure] = field(default_factory=list)
    ranges: dict[str, list[float]] = field(default_factory=dict)  # point -> [xmin,xmax,ymin,ymax]
    max_residual: float = 0.0
    effort_peak: tuple[float, float] = (math.inf, -math.inf)
    effort_sq: float = 0.0
    effort_count: int = 0
    effort_area: float = 0.0  # integral of effort^2 over the driver travel (trapezoidal)
    effort_travel: float = 0.0  # the driver travel of that integral
    work: float = 0.0
    power_residual: float = 0.0
    power_scale: float = 0.0  # the largest power term: the scale of the balance check
    undetermined: int = 0  # positions whose rates are not determined (left blank)
    forces_singular: int = 0  # positions whose reactions are indeterminate (left blank)
    effort_by_limit: int = 0  # of them, where the driving effort is its limit
    effort_near_limit: int = 0  # positions next to one where the effort is its limit
    events: int = 0
    warnings: list[str] = field(default_factory=list)
    design: list[str] = field(default_factory=list)
    chunks: int = 0
    path: Path | None = None
    units: OutputUnits = SI_OUTPUT  # the units the CSV and this summary show

    def text(self, res: Results) -> str:
        U = self.units
        k, lu = U.convert("m")
        lu = pretty_unit(lu)
        lines = [
            f"{self.name}: {self.solved} of {self.positions} positions solved, streamed in "
            f"{self.chunks} chunk(s)"
        ]
        for f in self.failures:
            what = "not solved" if "cannot be followed" in f.reason else "unassemblable"
            lines.append(
                f"  {what} at {res.format_u(f.u_first)} to "
                f"{res.format_u(f.u_last)} ({f.last - f.first + 1} position(s)): "
                f"{f.reason}"
                + (
                    f"; it stops closing at {res.format_u(f.edge_in)}"
                    if f.edge_in == f.edge_in
                    else ""
                )
                + (
                    f"; it closes again from {res.format_u(f.edge_out)}"
                    if f.edge_out == f.edge_out
                    else ""
                )
            )
        for p, (x0, x1, y0, y1) in list(self.ranges.items())[:12]:
            lines.append(
                f"  {p}: x {x0 * k:.6g} .. {x1 * k:.6g} {lu}, y {y0 * k:.6g} .. {y1 * k:.6g} {lu}"
            )
        lines.append(f"  max constraint residual {U.text(self.max_residual, 'm', '.2g')}")
        if self.effort_count:
            kind, unit = res.effort_name
            rms = self.rms_effort()
            lo, hi = self.effort_peak
            lines.append(
                f"  driving {kind}: min {U.text(lo, unit)}, max {U.text(hi, unit)}, "
                f"RMS {U.text(rms, unit)}; work of the driver {U.text(self.work, 'J')}; "
                f"power balance residual up to {U.text(self.power_residual, 'W', '.3g')}"
            )
        lines += self.design
        if self.undetermined:
            lines.append(
                f"  velocities and accelerations at {self.undetermined} singular position(s) "
                "are not determined (left blank)"
            )
        if self.forces_singular:
            lines.append(
                f"  forces indeterminate at {self.forces_singular} singular position(s) "
                "(reactions left blank)"
            )
        if self.effort_by_limit:
            lines.append(
                f"  the driving {res.effort_name[0]} at {self.effort_by_limit} of them is its "
                "limit along the motion (smooth through the position)"
            )
        if self.effort_near_limit:
            lines.append(
                f"  the driving {res.effort_name[0]} at {self.effort_near_limit} position(s) "
                "next to a singular one is its limit along the motion (computed there, it "
                "would carry the pose's rounding amplified by the near-singular loop)"
            )
        for w in self.all_warnings():
            lines.append("  warning: " + w)
        return "\n".join(lines)

    def rms_effort(self) -> float:
        """The RMS of the driving effort over the motion, as the one-piece summary's
        (:func:`~mechsolve.results.summary.rms_over`: trapezoidal over the driver travel;
        the plain mean of the squares where the driver does not move)."""
        if self.effort_travel > 0:
            return math.sqrt(self.effort_area / self.effort_travel)
        return math.sqrt(self.effort_sq / self.effort_count) if self.effort_count else math.nan

    def all_warnings(self) -> list[str]:
        """The chunks' warnings, and the power balance checked against the largest power
        term of the whole sweep (as the one-piece summary does)."""
        out = list(self.warnings)
        if self.effort_count and self.power_scale > 0:
            rel = self.power_residual / self.power_scale
            if rel > 1e-6:
                out.append(
                    f"the power balance residual reaches {rel:.2g} of the largest power term "
                    "(above 1e-6): check the results"
                )
        return out

    def incomplete(self) -> bool:
        """Whether the command line warns (exit 0), as for :meth:`Results.incomplete`:
        positions not solved, values not determined at singular positions, a warning."""
        return bool(
            self.failures or self.undetermined or self.forces_singular or self.all_warnings()
        )


def stream(
    mech: Mechanism,
    csv_path: str | Path,
    *,
    step: float | None = None,
    method: str | None = None,
    chunk: int = CHUNK,
    forces: bool | None = None,
    progress: Callable[[int], object] | None = None,
    units: OutputUnits | None = None,
) -> tuple[StreamSummary, Results]:
    """Solve a long sweep chunk by chunk, streaming the CSV to ``csv_path``.

    ``progress``, if given, is called after each chunk with the number of positions it
    added (a progress bar's ``update``). ``units``: the units of the CSV and the summary
    (SI when not given). Returns the summary and the Results of a coarse
    sweep of the same range (for plots and the design figures).
    """

    checked_mechanism(mech).ensure_valid()  # built in code, or edited since: check it
    step, method = checked_step(mech, step), checked_method(method)
    an = Analysis(mech, method)
    u0 = an.start_value()
    u_all, _ = an.sweep_values(u0, step=step)
    forces = mech.needs_forces if forces is None else forces
    vel = mech.outputs.velocity or mech.outputs.acceleration or forces
    acc = mech.outputs.acceleration or forces
    # a coarse sweep of the same range: design figures, plots, stroke extremes
    travel = abs(u_all[-1] - u_all[0])
    coarse_step = min(math.radians(1.0), travel / 1000) if not an.linear else travel / 1000
    uc, _ = an.sweep_values(u0, step=coarse_step or None, travel=travel)
    coarse_sol = an.solve_sweep(uc, velocity=vel, acceleration=acc)
    coarse_forces = solve_forces(an, coarse_sol) if forces else None
    coarse = Results(an, coarse_sol, coarse_forces)
    extremes = coarse_forces.stroke_extremes if coarse_forces is not None else None

    summary = StreamSummary(mech.name, positions=len(u_all), units=units or SI_OUTPUT)
    coarse._shown = summary.units
    summary.design = coarse.design_summary()
    out = CsvStream(csv_path)
    prev = None
    prev_res: Results | None = None
    offset = 0  # index in u_all of the current chunk's first position
    try:
        while offset < len(u_all):
            first = offset if prev is None else offset - 1  # overlap one position
            u = u_all[first : offset + chunk]
            if prev is None:
                sol = _first_chunk(an, u_all, chunk, vel, acc)
                u, start = sol.u, sol.start
            else:
                sol = an.solve(u, start=start, velocity=vel, acceleration=acc, follow=prev)
                an.locate_edges(sol)  # where its unassemblable ranges begin and end
            fr = solve_forces(an, sol, stroke_extremes=extremes) if forces else None
            res = Results(an, sol, fr)
            if prev_res is not None:  # continue the link angles' unwrapping
                for ln in res.link_names():
                    res.angle_origin[ln] = float(prev_res.link(ln).angle[-1])
                for a, b in mech.outputs.relative:
                    res.angle_origin[f"{a}/{b}"] = float(prev_res.relative(a, b).angle[-1])
            skip = 0 if prev is None else 1
            out.write(in_units(res, units), skip=skip)
            _accumulate(summary, res, first, skip)
            prev, prev_res = sol, res
            offset = first + len(u)
            summary.chunks += 1
            if progress is not None:
                progress(len(u) - skip)
            if getattr(sol, "stopped", None) and offset < len(u_all):
                _stopped(summary, res, u_all, offset)
                break
        path = out.close()
    except BaseException:
        out.abort()
        raise
    summary.failures = _merge(summary.failures)
    summary.path = path
    return summary, coarse


def _first_chunk(an: Analysis, u_all: np.ndarray, chunk: int, vel: bool, acc: bool) -> Solution:
    """The first chunk, solved as the one-piece sweep is
    (:meth:`~mechsolve.core.failures.FailureReports.solve_sweep`): where the mechanism
    cannot close at the start, from the first position that closes, the positions
    skipped kept as unassemblable rows; the chunk is lengthened (doubled) until it holds
    a position that closes (none in the whole sweep: the error, as the one-piece's)."""
    end = min(chunk, len(u_all))
    while True:
        try:
            return an.solve_sweep(u_all[:end], velocity=vel, acceleration=acc)
        except CannotCloseAtStart:
            if end >= len(u_all):
                raise
            end = min(len(u_all), 2 * end)


def _stopped(s: StreamSummary, res: Results, u_all: np.ndarray, offset: int) -> None:
    """A chunk whose branch could not be followed: the next one would start from a pose
    before the break, on a branch not known; the rest (from ``offset``) is not solved
    (its rows are not written), and the summary says so with the chunk's reason."""
    last = res.failures[-1]
    s.failures.append(
        Failure(
            offset, len(u_all) - 1, last.group, last.reason, float(u_all[offset]), float(u_all[-1])
        )
    )


def _accumulate(s: StreamSummary, res: Results, first: int, skip: int) -> None:
    ok = res.ok[skip:]
    s.solved += int(np.sum(ok))
    s.events += len(res.events)
    for f in res.failures:
        if f.last < skip:
            continue
        a = max(f.first, skip)
        s.failures.append(
            Failure(
                a + first, f.last + first, f.group, f.reason, float(res.u[a]), float(res.u[f.last])
            )
        )
        s.failures[-1].edge_in = f.edge_in if f.first >= skip else math.nan
        s.failures[-1].edge_out = f.edge_out
    for p in res.point_names():
        m = res.point(p)
        x, y = m.x[skip:], m.y[skip:]
        if not np.any(np.isfinite(x)):
            continue
        r = [np.nanmin(x), np.nanmax(x), np.nanmin(y), np.nanmax(y)]
        old = s.ranges.get(p)
        s.ranges[p] = (
            r
            if old is None
            else [min(old[0], r[0]), max(old[1], r[1]), min(old[2], r[2]), max(old[3], r[3])]
        )
    resid = res.solution.residual[skip:]
    if np.any(np.isfinite(resid)):
        s.max_residual = max(s.max_residual, float(np.nanmax(resid)))
    s.undetermined += sum(1 for i in res.solution.rates_undetermined if i >= skip)
    if res.forces is not None:
        s.forces_singular += len({i for i, _ in res.forces.singular if i >= skip})
        s.effort_by_limit += sum(1 for i in res.forces.effort_by_limit if i >= skip)
        s.effort_near_limit += sum(1 for i in res.forces.effort_near_limit if i >= skip)
    for w in res.warnings:
        if w not in s.warnings:
            s.warnings.append(w)
    f = res.forces
    if f is not None and np.any(f.ok[skip:]):
        ea = res.driving_effort  # at a singular position its limit along the motion
        e = ea[skip:][np.isfinite(ea[skip:])]
        s.effort_peak = (min(s.effort_peak[0], e.min()), max(s.effort_peak[1], e.max()))
        s.effort_sq += float(np.sum(e * e))
        s.effort_count += e.size
        # the intervals of this chunk (from the previous chunk's last position on)
        both = np.isfinite(ea[1:]) & np.isfinite(ea[:-1])
        travel = float(np.sum(np.abs(np.diff(res.u))[both]))
        if travel > 0:
            s.effort_area += rms_over(res.u, ea) ** 2 * travel
            s.effort_travel += travel
        s.work += res.work()
        pr = np.abs(f.residual[skip:][f.ok[skip:]])
        s.power_residual = max(s.power_residual, float(pr.max()))
        s.power_scale = max(s.power_scale, res.power_scale())


def _merge(failures: list[Failure]) -> list[Failure]:
    """Join failure runs that continue across a chunk boundary."""
    out: list[Failure] = []
    for f in failures:
        if out and out[-1].last + 1 >= f.first and out[-1].group == f.group:
            out[-1].last = max(out[-1].last, f.last)
            out[-1].u_last = f.u_last
            out[-1].edge_out = f.edge_out
        else:
            out.append(f)
    return out
