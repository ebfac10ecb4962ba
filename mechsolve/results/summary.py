"""The text summary of a run: what was solved, the ranges, the design figures, the
forces, anything unusual (a part of :class:`mechsolve.results.results.Results`)."""

from __future__ import annotations

import math

import numpy as np

from mechsolve.core.sweep import angle_deg
from mechsolve.model.motion import describe


class Summary:
    """Methods of :class:`~mechsolve.results.results.Results`: see the module docstring."""

    def design_summary(self, figures: Summary | None = None) -> list[str]:
        """The summary's lines about singular positions, conditioning and the design
        figures; ``figures``: a finer sweep of the same motion to take the limit positions
        and transmission angles from (see :meth:`summary`)."""
        src = self if figures is None else figures
        if len(self.u) < 2:
            return []
        lines = _event_lines(self)
        lines += _singular_rate_lines(self)
        lines += _limit_lines(self, src)
        lines += _transmission_lines(self, src)
        return lines

    def work_text(self) -> str:
        """``work of the driver per cycle: 31.74 kJ``, or why it is not defined."""
        per = "per cycle" if self.is_full_cycle() else "over the sweep"
        work, why = self._work_why()
        if not math.isfinite(work):
            return f"work of the driver {per}: not defined ({why or 'not enough positions'})"
        wscale, wsym = (1e3, "k") if abs(work) >= 1e4 else (1.0, "")
        return f"work of the driver {per}: {work / wscale:.6g} {wsym}J"

    def friction_lines(self) -> list[str]:
        """With friction in the joints: the losses per joint over the sweep, the
        efficiency per cycle and its instantaneous minimum, and the self-locking
        positions (a warning)."""
        from mechsolve.core.work import friction_work

        fr = self.forces.friction
        if fr is None:
            return []
        lines = []
        per = "per cycle" if self.is_full_cycle() else "over the sweep"
        w_f, why = friction_work(self.solution, self.forces)
        if math.isfinite(w_f):
            parts = []
            for name, p in fr.loss.items():
                w = friction_work(self.solution, _Only(self.forces, p))[0]
                parts.append(f"{name} {w:.4g} J")
            lines.append(f"  friction losses {per}: {w_f:.6g} J ({', '.join(parts)})")
            work = self.work()
            if self.is_full_cycle() and math.isfinite(work) and work > 0:
                lines.append(
                    f"  efficiency per cycle: {(work - w_f) / work:.4g} (output: the work "
                    f"done on the loads, {work - w_f:.6g} J, over the driver's {work:.6g} J; "
                    "the kinetic and potential energy return over the cycle)"
                )
            elif self.is_full_cycle() and math.isfinite(work) and work < 0:
                lines.append(
                    f"  efficiency per cycle: {-work / (w_f - work):.4g} (the loads drive: "
                    f"output the work the driver takes, {-work:.6g} J, over the loads' "
                    f"{w_f - work:.6g} J)"
                )
        else:
            lines.append(f"  friction losses {per}: not defined ({why})")
        eta = self.efficiency
        if np.any(np.isfinite(eta)):
            i = int(np.nanargmin(eta))
            lines.append(
                f"  instantaneous efficiency (the driving {self.effort_name[0]} without "
                f"friction over the {self.effort_name[0]} with it, where the driver delivers "
                f"power): min {eta[i]:.4g} at {self.describe_u(i)}"
            )
        locked = np.flatnonzero(fr.locked)
        if locked.size:
            where = f"{self.describe_u(int(locked[0]))}"
            if locked.size > 1:
                where += f" to {self.describe_u(int(locked[-1]))}"
            lines.append(
                f"  self-locking at {locked.size} of {len(self.u)} positions "
                f"({self.sample_spacing()} samples), {where}: no finite driving effort "
                "moves the mechanism in the drive direction there"
            )
            self.warnings.append(
                f"self-locking at {locked.size} position(s): the driving effort and the "
                "reactions there are left empty"
            )
        return lines

    # -- summary ------------------------------------------------------------------------
    def describe_u(self, i: int) -> str:
        """The driver position of sample ``i`` in words, e.g. ``driver angle 246.8°``."""
        u = float(self.u[i])
        if self.linear:
            return self.analysis.format_u(u)
        deg = angle_deg(u)
        if i != 0 and deg == 0 and u != self.u[0] and i == len(self.u) - 1:
            deg = 360.0  # the end of a full turn, not its start again
        text = f"driver angle {deg:.6g}°"
        if self.u[0] != 0 or self.mechanism.driver.direction < 0:
            text += f" ({float(self.driver_travel[i]):.6g}° from the start)"
        return text

    def motion_events(self) -> list[tuple[float, float, float]]:
        """(time, acceleration before, after) where the driver's acceleration jumps (the
        joins of a segmented motion law), within the sweep."""
        law = self.mechanism.driver.motion
        jumps = getattr(law, "jumps", None)
        if jumps is None or not len(self.t):
            return []
        end = float(np.max(self.t))
        return [j for j in jumps() if j[0] <= end]

    def motion_summary(self) -> list[str]:
        """The driver's motion law and where its acceleration jumps (summary lines)."""
        law = self.mechanism.driver.motion
        if law is None:
            return []

        unit = "m/s^2" if self.linear else "rad/s^2"
        lines = [f"  driver motion: {describe(law)}"]
        jumps = self.motion_events()
        if jumps:
            lines.append(
                "  driver acceleration jumps (position and speed continuous) at "
                + ", ".join(f"t = {t:.6g} s ({a:.6g} -> {b:.6g} {unit})" for t, a, b in jumps)
            )
        return lines

    def summary(self, figures: Summary | None = None) -> str:
        """A short text summary: positions solved, ranges of the outputs, anything unusual.

        ``figures``: a finer sweep of the same motion (:func:`mechsolve.api.for_plots`) to
        take the figures from (limit positions, transmission angles, the driving effort's
        extremes, mean and work, peak reactions, power balance), so that they are the
        numbers the plots and the report's figures show, from one computation."""
        n = len(self.u)
        lines = []
        mech = self.mechanism
        unit = "m" if self.linear else "deg"
        dv = self.driver_value
        lines.append(
            f"{mech.name}: {int(np.sum(self.ok))} of {n} positions solved, "
            f"driver {mech.driver.joint} "
            f"from {dv[0]:.6g} to {dv[-1]:.6g} {unit}" + (f" over {self.t[-1]:.6g} s" if n else "")
        )
        lines += self.motion_summary()
        lines += _start_and_failure_lines(self)
        lines += _point_lines(self)
        lines += _solver_lines(self)
        lines += self.design_summary(figures)
        if self.forces is not None:
            lines += self.force_summary(figures)
        for w in self.warnings:
            lines.append("  warning: " + w)
        return "\n".join(lines)

    def sample_spacing(self) -> str:
        """The spacing of the sweep's samples, as text ('1°', '2 mm'; 'uneven')."""
        du = np.abs(np.diff(self.u))
        if du.size == 0:
            return "1"
        # the median without np.median, whose first call imports numpy.ma (~10 ms)
        du.sort()
        m = du.size // 2
        step = float(du[m]) if du.size % 2 else float(0.5 * (du[m - 1] + du[m]))
        if self.linear:
            return f"{step * 1e3:.4g} mm" if step < 1 else f"{step:.4g} m"
        return f"{math.degrees(step):.4g}°"

    def force_summary(self, figures: Summary | None = None) -> list[str]:
        """The summary's lines about the forces; ``figures``: a finer sweep of the same
        motion to take the figures from (see :meth:`summary`), the driving effort as
        :attr:`driving_effort` gives it (at a singular position its limit)."""
        f = self.forces
        lines = []
        if not np.any(f.ok):
            return ["  forces: no position could be solved"] + self.friction_lines()
        src = self if figures is None or figures.forces is None else figures
        g = src.forces
        kind, unit = self.effort_name
        e = src.driving_effort  # at a singular position its limit along the motion
        scale, sym = (1e3, "k") if np.nanmax(np.abs(e)) >= 1e4 else (1.0, "")
        imax, imin = int(np.nanargmax(e)), int(np.nanargmin(e))
        rms = float(np.sqrt(np.nanmean(e**2)))
        mean, what = src.mean_effort()
        # the extremes are the largest and smallest samples (the requirements locate
        # them between the samples: max(input.torque) in requirements:)
        lines.append(
            f"  driving {kind} ({src.sample_spacing()} samples): "
            f"max {e[imax] / scale:.6g} {sym}{unit} at {src.describe_u(imax)}, "
            f"min {e[imin] / scale:.6g} {sym}{unit} at {src.describe_u(imin)}, "
            f"RMS {rms / scale:.6g} {sym}{unit}, {what} {mean / scale:.6g} {sym}{unit}"
        )
        lines.append("  " + src.work_text())
        lines += src.friction_lines()
        peaks = []
        for j in self.mechanism.joints:
            r = g.reactions[j.name]
            mag = np.abs(r[j.magnitude])  # the joint's magnitude: F, N, Fn...
            mag = np.where(g.ok, mag, np.nan)
            if np.any(np.isfinite(mag)):
                i = int(np.nanargmax(mag))
                peaks.append(f"{j.name} {mag[i] / scale:.4g} {sym}N at {src.describe_u(i)}")
        lines.append("  peak reactions: " + "; ".join(peaks))
        for j in self.mechanism.joints:  # what a joint's own reaction tells (a cam's contact)
            more, warn = j.findings(g.reactions[j.name], g.ok, src.u, self.analysis.format_u)
            lines += ["  " + t for t in more]
            self.warnings += warn
        res = np.nanmax(np.abs(np.where(g.ok, g.residual, np.nan)))
        ps = src.power_scale()
        rel = res / ps if ps > 0 else 0.0
        lines.append(
            f"  power balance: max residual {res:.3g} W ({rel:.2g} of the largest power term)"
        )
        if rel > 1e-6:
            self.warnings.append(
                f"the power balance residual reaches {rel:.2g} of the largest power term "
                "(above 1e-6): check the results"
            )
        lines += _indeterminate_lines(self, f, kind)
        return lines


def _indeterminate_lines(res, f, kind: str) -> list[str]:
    """Where the reactions are not unique (redundant constraints) or not determined
    (singular positions), and where the driving effort is its limit instead."""
    lines = []
    if f.nonunique:
        parts = [f"{j} ({', '.join(sorted(c))})" for j, c in f.nonunique.items()]
        unique = "driver" not in f.nonunique
        lines.append(
            "  statically indeterminate (redundant constraints): the reactions "
            + "; ".join(parts)
            + " are not unique; the CSV gives the minimum-norm solution, labelled so"
            + (f"; the driving {kind} is unique" if unique else "")
        )
    if f.singular:
        at = sorted({i for i, _ in f.singular})
        where = ", ".join(res.describe_u(i) for i in at[:5])
        more = f" and {len(at) - 5} more" if len(at) > 5 else ""
        groups = list(dict.fromkeys(label for _, label in f.singular))
        lines.append(
            f"  forces indeterminate at {len(at)} singular position(s): {where}{more} "
            f"({'; '.join(groups)})"
        )
        if f.effort_by_limit:
            kind = res.effort_name[0]
            lines.append(
                f"  the driving {kind} at {len(f.effort_by_limit)} of them is its limit "
                "along the motion (smooth through the position); the reactions stay empty"
            )
    if f.effort_near_limit:
        kind = res.effort_name[0]
        lines.append(
            f"  the driving {kind} at {len(f.effort_near_limit)} position(s) next to a "
            "singular one is its limit along the motion (computed there, it would carry "
            "the pose's rounding amplified by the near-singular loop)"
        )
    return lines


def _event_lines(res) -> list[str]:
    """The singular positions met along the sweep (the first eight)."""
    ev = res.events
    if not ev:
        return []
    parts = []
    for e in ev[:8]:
        where = res.analysis.format_u(e.u)
        if e.kind == "bifurcation":
            parts.append(
                f"{e.group} passes a bifurcation at {where}: followed the smooth motion "
                "onto its other branch"
            )
        elif e.kind == "dead zone":
            parts.append(f"{e.group} cannot close near {where} (between two samples)")
        else:
            parts.append(
                f"{e.group} near-singular at {where} (transmission angle "
                f"{math.degrees(e.transmission):.3g}°)"
            )
    more = f"; and {len(ev) - 8} more" if len(ev) > 8 else ""
    return ["  singular positions: " + "; ".join(parts) + more]


def _singular_rate_lines(res) -> list[str]:
    """Where the rates are limits or undetermined, and the worst conditioning."""
    lines = []
    sol = res.solution
    for idx, what in (
        (sol.rates_by_limit, "are their limits along the motion"),
        (sol.rates_undetermined, "are not determined (left blank)"),
    ):
        if idx:
            where = ", ".join(res.describe_u(i) for i in idx[:5])
            more = f" and {len(idx) - 5} more" if len(idx) > 5 else ""
            lines.append(
                f"  velocities and accelerations at {len(idx)} singular position(s) "
                f"{what}: {where}{more}"
            )
    rc = np.where(res.ok, res.jacobian_rcond(), np.nan)
    if np.any(np.isfinite(rc)):
        i = int(np.nanargmin(rc))
        lines.append(
            f"  conditioning: smallest reciprocal condition of the constraint Jacobian "
            f"{rc[i]:.3g} at {res.describe_u(i)}"
        )
    return lines


def _limit_lines(res, src) -> list[str]:
    """The limit positions of rockers and sliders (from ``src``, the figures' sweep) and
    their time ratios."""
    lim = src.limit_positions()
    if not lim:
        return []
    parts = []
    ratios = []
    for lp in lim:
        fmt = res.analysis.format_u
        a = " and at ".join(fmt(u) for u in lp.u_lows)  # an extreme reached twice
        b = " and at ".join(fmt(u) for u in lp.u_highs)
        if lp.kind == "rocker":
            parts.append(
                f"rocker {lp.name} {math.degrees(lp.low):.6g}° at {a} to "
                f"{math.degrees(lp.high):.6g}° at {b} (swing {math.degrees(lp.swing):.6g}°)"
            )
        else:
            parts.append(
                f"slider {lp.name} {lp.low:.6g} m at {a} to {lp.high:.6g} m at {b} "
                f"(stroke {lp.swing:.6g} m)"
            )
        if lp.time_ratio is not None:
            ratios.append(
                f"{lp.name} K = {lp.time_ratio:.4g} "
                f"({math.degrees(max(lp.forward, lp.back)):.5g}° "
                f"/ {math.degrees(min(lp.forward, lp.back)):.5g}° of the driver)"
            )
    lines = ["  limit positions: " + "; ".join(parts)]
    if ratios:
        lines.append("  time ratio: " + "; ".join(ratios))
    return lines


def _transmission_lines(res, src) -> list[str]:
    """Each group's minimum transmission angle (from ``src``, the figures' sweep)."""
    tr = src.transmission_angles()
    if not tr:
        return []
    return [
        "  minimum transmission angle: "
        + "; ".join(
            f"{t.group} {math.degrees(t.angle):.4g}° at {res.analysis.format_u(t.u)}" for t in tr
        )
    ]


def _start_and_failure_lines(res) -> list[str]:
    """A start that is singular, and the ranges of positions that cannot be assembled."""
    lines = []
    start = res.solution.start
    for g, why in zip(res.analysis.groups, getattr(start, "reasons", []) or []):
        if "the start is singular" in why:
            lines.append(f"  start: {g.label}: the branch {why}")
    for f in res.failures:
        # (a sweep that stopped following a branch: not known to be unassemblable there)
        what = "not solved" if "cannot be followed" in f.reason else "unassemblable"
        lines.append(
            f"  {what} at {res.describe_u(f.first)}"
            + (f" to {res.describe_u(f.last)}" if f.last != f.first else "")
            + f" ({f.last - f.first + 1} position(s)): {f.reason}"
            + (
                f"; it stops closing at {res.analysis.format_u(f.edge_in)}"
                if np.isfinite(f.edge_in)
                else ""
            )
            + (
                f"; it closes again from {res.analysis.format_u(f.edge_out)}"
                if np.isfinite(f.edge_out)
                else ""
            )
        )
    return lines


def _point_lines(res) -> list[str]:
    """The ranges of the first twelve points (and their largest speed)."""
    lines = []
    for p in res.point_names()[:12]:
        m = res.point(p)
        if np.any(np.isfinite(m.x)):
            speed = np.hypot(m.vx, m.vy) if res.view.has_velocity else None
            # no speed where none was determined (a singular start: its rates are not)
            known = speed is not None and bool(np.any(np.isfinite(speed)))
            lines.append(
                f"  {p}: x {np.nanmin(m.x):.6g} .. {np.nanmax(m.x):.6g} m, "
                f"y {np.nanmin(m.y):.6g} .. {np.nanmax(m.y):.6g} m"
                + (f", |v| max {np.nanmax(speed):.4g} m/s" if known else "")
            )
    if len(res.point_names()) > 12:
        lines.append(f"  ... and {len(res.point_names()) - 12} more points in the CSV")
    return lines


def _solver_lines(res) -> list[str]:
    """The methods used, Newton iterations, fallbacks, residual, and redundant constraints."""
    methods = res.methods()
    meth = {m for m, ok in zip(methods, res.ok) if ok}
    fallback = sum(1 for m in methods if "scipy" in m)
    its = res.solution.iterations[res.ok]
    lines = [
        "  solver: "
        + ", ".join(sorted(meth))
        + (f"; Newton iterations max {int(its.max())}" if its.size and its.max() > 0 else "")
        + (f"; scipy fallback at {fallback} position(s)" if fallback else "")
        + (
            f"; max constraint residual {np.nanmax(res.solution.residual):.2g} m"
            if np.any(res.ok)
            else ""
        )
    ]
    red = res.analysis.redundancy
    if red is not None:
        lines.append(
            f"  redundant constraints: {red.count} equation(s) repeat the others "
            f"(the constraint Jacobian has rank {red.rank} for {res.analysis.system.nc} "
            f"equations), among: {', '.join(red.equations)}; solved by least squares on "
            "all of them"
        )
        if red.removable:
            lines.append("  " + red.suggestion())
    return lines


class _Only:
    """A force result whose friction loss is one joint's (for its share of the work)."""

    def __init__(self, forces, loss: np.ndarray) -> None:
        self.ok, self.speed, self.power_friction = forces.ok, forces.speed, loss
