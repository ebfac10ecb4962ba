"""The text summary of a run: what was solved, the ranges, the design figures, the
forces, anything unusual (a part of :class:`mechsolve.results.results.Results`)."""

from __future__ import annotations

import functools
import math

import numpy as np

from mechsolve.base.units import SI_OUTPUT, OutputUnits, pretty_unit
from mechsolve.core.solution import gap_sides
from mechsolve.core.sweep import angle_deg
from mechsolve.model.motion import describe
from mechsolve.results.ranges import point_ranges


def shown(res) -> OutputUnits:
    """The units ``res``'s summary shows its figures in (set by :meth:`Summary.summary`)."""
    return getattr(res, "_shown", SI_OUTPUT)


def print_scale(values, unit: str, U: OutputUnits) -> tuple[float, str]:
    """``(divisor, unit)`` that ``values`` (SI, in ``unit``) are printed with: the shown
    unit's factor, and kN or kN*m for SI forces and torques of 1e4 and more."""
    k, target = U.convert(unit)
    big = np.nanmax(np.abs(values)) * k if np.any(np.isfinite(values)) else 0.0
    if target in ("N", "N*m") and big >= 1e4:
        return 1e3 / k, "k" + target
    return 1.0 / k, target


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

    def idle_driver(self) -> str:
        """Why nothing acts at the driver's joint (its effort is zero), or ``""``: a
        sweep's driver always drives; a simulated free motion's does not."""
        return ""

    def work_text(self, units: OutputUnits | None = None) -> str:
        """``work of the driver per cycle: 31.74 kJ``, or why it is not defined; in
        ``units`` (default: the summary's)."""
        per = "per cycle" if self.is_full_cycle() else "over the sweep"
        work, why = self._work_why()
        if not math.isfinite(work):
            return f"work of the driver {per}: not defined ({why or 'not enough positions'})"
        U = units or shown(self)
        if U.energy == "J":
            wscale, wsym = (1e3, "k") if abs(work) >= 1e4 else (1.0, "")
            return f"work of the driver {per}: {work / wscale:.6g} {wsym}J"
        return f"work of the driver {per}: {U.text(work, 'J')}"

    def format_u(self, u: float) -> str:
        """A driver value in words in the shown units: ``driver angle 246.8°``; on a sweep
        longer than one turn, also which turn (``driver angle 180° after 1 turn``, see
        :meth:`turn_words`)."""
        U = shown(self)
        if self.linear:
            return f"driver position {U.text(u, 'm')}"
        angle, _, where = self.turn_words(u)
        return angle + where

    def multi_turn(self) -> bool:
        """Does the sweep go beyond one turn of a crank (so that a driver angle alone
        does not say where)?"""
        if self.linear or len(self.u) < 2:
            return False
        return float(np.nanmax(np.abs(self.u - self.u[0]))) > 2 * math.pi + 1e-9

    def turn_words(self, u: float) -> tuple[str, int, str]:
        """``(angle, turns, where)``: driver value ``u`` (unwrapped, as :attr:`u`) in
        words, the whole turns made from the start before it, and the words that place it
        in the sweep. A sweep of one turn or less: ``('driver angle 180°', 0, '')``.
        Longer, from 0 counter-clockwise (the angle is the turn's part):
        ``('driver angle 180°', 1, ' after 1 turn')`` for 540°; the end of the sweep at a
        whole number of turns is the end of the last turn (``360° after 2 turns``, as a
        single turn ends at 360°). From elsewhere or clockwise, the travel:
        ``('driver angle 30°', 1, ' (540° from the start)')``."""
        U = shown(self)
        deg = angle_deg(u)
        if not self.multi_turn():
            return f"driver angle {U.text(deg, 'deg')}", 0, ""
        d = self.mechanism.driver.direction
        travel = round(math.degrees(d * (u - float(self.u[0]))), 9)
        turns, part = divmod(abs(travel), 360.0)
        end = round(math.degrees(float(np.nanmax(np.abs(self.u - self.u[0])))), 9)
        if turns and not part and abs(travel) >= end:
            turns, part = turns - 1, 360.0  # the end of the sweep's last turn
        back = " backwards" if travel < 0 else ""
        if float(self.u[0]) == 0 and d > 0 and not back:
            n = f" after {int(turns)} turn{'s' if turns > 1 else ''}" if turns else ""
            return f"driver angle {U.text(part, 'deg')}", int(turns), n
        where = f" ({U.text(abs(travel), 'deg')}{back} from the start)"
        return f"driver angle {U.text(deg, 'deg')}", int(turns), where

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
        U = shown(self)
        if math.isfinite(w_f):
            parts = []
            for name, p in fr.loss.items():
                w = friction_work(self.solution, _Only(self.forces, p))[0]
                parts.append(f"{name} {U.text(w, 'J', '.4g')}")
            lines.append(f"  friction losses {per}: {U.text(w_f, 'J')} ({', '.join(parts)})")
            work = self.work()
            if self.is_full_cycle() and math.isfinite(work) and work > 0:
                lines.append(
                    f"  efficiency per cycle: {(work - w_f) / work:.4g} (output: the work "
                    f"done on the loads, {U.text(work - w_f, 'J')}, over the driver's "
                    f"{U.text(work, 'J')}; the kinetic and potential energy return over the "
                    "cycle)"
                )
            elif self.is_full_cycle() and math.isfinite(work) and work < 0:
                lines.append(
                    f"  efficiency per cycle: {-work / (w_f - work):.4g} (the loads drive: "
                    f"output the work the driver takes, {U.text(-work, 'J')}, over the loads' "
                    f"{U.text(w_f - work, 'J')})"
                )
        else:
            lines.append(f"  friction losses {per}: not defined ({why})")
        eta = self.efficiency
        if np.any(np.isfinite(eta)):
            i = int(np.nanargmin(eta))
            lines.append(
                f"  instantaneous efficiency (the driving {self.effort_name[0]} without "
                f"friction over the {self.effort_name[0]} with it, where the driver delivers "
                f"power): smallest of the {self.samples()} "
                f"{or_zero(eta[i], 1.0):.4g} at "
                f"{self.describe_u(i)}"
            )
        locked = np.flatnonzero(fr.locked)
        if locked.size:
            where = f"{self.describe_u(int(locked[0]))}"
            if locked.size > 1:
                where += f" to {self.describe_u(int(locked[-1]))}"
            lines.append(
                f"  self-locking at {locked.size} of {len(self.u)} positions "
                f"({self.samples()}), {where}: no finite driving effort "
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
        if self.linear or self.multi_turn():
            return self.format_u(u)
        U = shown(self)
        deg = angle_deg(u)
        if i != 0 and deg == 0 and u != self.u[0] and i == len(self.u) - 1:
            deg = 360.0  # the end of a full turn, not its start again
        text = f"driver angle {U.text(deg, 'deg')}"
        if self.u[0] != 0 or self.mechanism.driver.direction < 0:
            away = math.degrees(abs(u - float(self.solution.start.u0)))  # not the way back
            text += f" ({U.text(away, 'deg')} from the start)"
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

        U = shown(self)
        k, unit = U.convert("m/s^2" if self.linear else "rad/s^2")
        unit = pretty_unit(unit)
        lines = [f"  driver motion: {describe(law)}"]
        jumps = self.motion_events()
        if jumps:
            lines.append(
                "  driver acceleration jumps (position and speed continuous) at "
                + ", ".join(
                    f"t = {U.text(t, 's')} ({a * k:.6g} -> {b * k:.6g} {unit})" for t, a, b in jumps
                )
            )
        return lines

    def summary(self, figures: Summary | None = None, units: OutputUnits | None = None) -> str:
        """A short text summary: positions solved, ranges of the outputs, anything unusual.

        ``figures``: a finer sweep of the same motion (:func:`mechsolve.api.for_plots`) to
        take the figures from (limit positions, transmission angles, the driving effort's
        extremes, mean and work, peak reactions, power balance), so that they are the
        numbers the plots and the report's figures show, from one computation.

        ``units``: the units the figures are printed in (SI when not given; see
        :class:`~mechsolve.base.units.OutputUnits`)."""
        self._shown = units or SI_OUTPUT
        if figures is not None:
            figures._shown = self._shown
        n = len(self.u)
        lines = []
        mech = self.mechanism
        U = self._shown
        unit = "m" if self.linear else "deg"
        dv = self.driver_value
        if n:  # an end that is rounding (sin(2 pi) = -2.4e-16 rad) is 0, not -1.4e-14 deg
            top = float(np.nanmax(np.abs(dv))) if np.isfinite(dv).any() else 0.0
            dv = np.r_[or_zero(float(dv[0]), top), dv[1:-1], or_zero(float(dv[-1]), top)][:n]
        span = f"from {dv[0]:.6g} to {dv[-1]:.6g} {unit}"
        if not U.is_si and n:
            span = f"from {U.text(dv[0], unit)} to {U.text(dv[-1], unit)}"
        lines.append(
            f"{mech.name}: {int(np.sum(self.ok))} of {n} positions solved, "
            f"driver {mech.driver.joint} "
            + span
            + (f" over {U.text(self.t[-1], 's')}" if n else "")
        )
        lines += self.motion_summary()
        lines += _start_and_failure_lines(self)
        lines += _point_lines(self, figures)
        lines += _solver_lines(self)
        lines += self.design_summary(figures)
        if self.forces is not None:
            lines += self.force_summary(figures)
        for w in self.warnings:
            lines.append("  warning: " + w)
        return "\n".join(lines)

    def samples(self) -> str:
        """``'2° samples'``, ``'0.05 s samples'``, or ``'1 sample'`` for a single one."""
        return "1 sample" if len(self.u) < 2 else f"{self.sample_spacing()} samples"

    def sample_spacing(self) -> str:
        """The spacing of the sweep's samples, as text ('1°', '2 mm'); a motion law's
        samples are even in time, not along the driver: their time step ('0.05 s')."""
        timed = self.mechanism.driver.motion is not None and len(self.t) > 1
        du = np.abs(np.diff(self.t if timed else self.u))
        if du.size == 0:
            return "1"
        # the median without np.median, whose first call imports numpy.ma (~10 ms)
        du.sort()
        m = du.size // 2
        step = float(du[m]) if du.size % 2 else float(0.5 * (du[m - 1] + du[m]))
        U = shown(self)
        if timed:
            return U.text(step, "s", ".4g")
        if self.linear:
            if U.is_si:
                return f"{step * 1e3:.4g} mm" if step < 1 else f"{step:.4g} m"
            return U.text(step, "m", ".4g")
        return U.text(math.degrees(step), "deg", ".4g")

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
        U = shown(self)
        scale, unit = print_scale(e, unit, U)
        # the reactions in kN when the effort is printed in kN or kN*m (SI forces)
        kf = U.convert("N")[0]
        kilo = unit in ("kN", "kN*m") and U.force == "N"
        fscale, funit = (1e3 / kf, "kN") if kilo else (1.0 / kf, U.force)
        unit, funit = pretty_unit(unit), pretty_unit(funit)
        imax, imin = int(np.nanargmax(e)), int(np.nanargmin(e))
        # over the motion: in time for a motion law (a dwell counts), else along the
        # driver (at a constant speed the same)
        timed = self.mechanism.driver.motion is not None
        rms = rms_over(src.solution.t if timed else src.u, e)
        mean, what = src.mean_effort()
        mean += 0.0  # no "-0"
        # the extremes are the largest and smallest samples (the requirements locate
        # them between the samples: max(input.torque) in requirements:)
        idle = self.idle_driver()
        if idle:  # nothing acts at the driver's joint: its effort is zero, not a figure
            lines.append(f"  driving {kind}: none ({idle})")
        else:
            lines.append(
                f"  driving {kind} ({src.samples()}): "
                + _effort_figures(src, e, (imax, imin), scale, unit, rms, (mean, what))
            )
        lines.append("  " + src.work_text())
        lines += src.friction_lines()
        lines.append(_peak_reactions(src, self.mechanism.joints, fscale, funit))
        for j in self.mechanism.joints:  # what a joint's own reaction tells (a cam's contact)
            # located between the samples by solving there (not along a motion law of
            # time, whose samples are in time)
            solve = None
            if not timed:
                solve = functools.partial(src.reaction_at, j.name)
            more, warn = j.findings(g.reactions[j.name], g.ok, src.u, self.format_u, solve)
            lines += ["  " + t for t in more]
            self.warnings += [w for w in warn if w not in self.warnings]
        res = np.nanmax(np.abs(np.where(g.ok, g.residual, np.nan)))
        ps = src.power_scale()
        rel = res / ps if ps > 0 else 0.0
        lines.append(
            f"  power balance: max residual {U.text(res, 'W', '.3g')} "
            f"({rel:.2g} of the largest power term)"
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
        where = res.format_u(e.u)
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
                f"{shown(res).text(math.degrees(e.transmission), 'deg', '.3g')})"
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
            rates = "velocities and accelerations"
            if idx is sol.rates_undetermined:  # near, not at, a singular position: may be
                vel = np.isfinite(sol.state.block[5:8, :, idx]).all(axis=(0, 1))  # only some
                if vel.any():
                    rates = "accelerations" if vel.all() else "velocities or accelerations"
                    what = what[:-1] + ": the pose's rounding would show)"
            lines.append(f"  {rates} at {len(idx)} singular position(s) {what}: {where}{more}")
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
    U = shown(res)

    def deg(x: float, fmt: str = ".6g") -> str:
        return U.text(math.degrees(x), "deg", fmt)

    for lp in lim:
        a, b = places(res, lp.u_lows), places(res, lp.u_highs)
        if lp.kind == "rocker":
            parts.append(
                f"rocker {lp.name} {deg(lp.low)} at {a} to "
                f"{deg(lp.high)} at {b} (swing {deg(lp.swing)})"
            )
        else:
            parts.append(
                f"slider {lp.name} {U.text(lp.low, 'm')} at {a} to {U.text(lp.high, 'm')} "
                f"at {b} (stroke {U.text(lp.swing, 'm')})"
            )
        if lp.time_ratio is not None:
            ratios.append(
                f"{lp.name} K = {lp.time_ratio:.4g} "
                f"({deg(max(lp.forward, lp.back), '.5g')} "
                f"/ {deg(min(lp.forward, lp.back), '.5g')} of the driver)"
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
            f"{t.group} {shown(res).text(math.degrees(t.angle), 'deg', '.4g')} at "
            f"{res.format_u(t.u)}"
            for t in tr
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
            + (f"; it stops closing at {res.format_u(f.edge_in)}" if np.isfinite(f.edge_in) else "")
            + (
                f"; it closes again from {res.format_u(f.edge_out)}"
                if np.isfinite(f.edge_out)
                else ""
            )
        )
    return lines


def _point_lines(res, figures=None) -> list[str]:
    """The ranges of the first twelve points, each end located between the samples of
    ``figures`` (the finer sweep of the same motion; else of ``res``: see
    :func:`~mechsolve.results.ranges.point_ranges`; an end that is a sample's says so),
    and their largest speed (of the samples, said so)."""
    lines = []
    U = shown(res)
    k, unit = U.convert("m")
    unit = pretty_unit(unit)
    src = res if figures is None or len(figures.u) < 2 else figures
    names = res.point_names()[:12]
    ranges = point_ranges(src, names)
    for p in names:
        m = res.point(p)
        if p in ranges:
            rx, ry = ranges[p]
            speed = np.hypot(m.vx, m.vy) if res.view.has_velocity else None
            # no speed where none was determined (a singular start: its rates are not)
            known = speed is not None and bool(np.any(np.isfinite(speed)))
            sampled = "" if rx.located and ry.located else f" ({src.sample_spacing()} samples)"
            lines.append(
                f"  {p}: x {rx.low * k:.6g} .. {rx.high * k:.6g} {unit}, "
                f"y {ry.low * k:.6g} .. {ry.high * k:.6g} {unit}"
                + sampled
                + (
                    f", |v| max {U.text(np.nanmax(speed), 'm/s', '.4g')} (of the {res.samples()})"
                    if known
                    else ""
                )
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
            "; max constraint residual "
            + shown(res).text(np.nanmax(res.solution.residual), "m", ".2g")
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


def rms_over(u: np.ndarray, e: np.ndarray) -> float:
    """The RMS of ``e`` over the motion: ``sqrt(integral of e^2 du / travel)`` by the
    trapezoidal rule on the samples (a figures sweep's samples are uneven: its limit
    positions, load switches and a cam's joins are inserted), over the runs of solved samples; the
    plain mean of the squares where ``u`` does not change. ``u``: the driver coordinate,
    or the time (a motion law: its dwells count)."""
    u = np.asarray(u, float)
    e2 = np.asarray(e, float) ** 2
    ok = np.isfinite(e2)
    both = ok[1:] & ok[:-1]
    du = np.abs(np.diff(u))[both]
    travel = float(np.sum(du))
    if travel <= 0:
        return float(np.sqrt(np.mean(e2[ok]))) if ok.any() else float("nan")
    area = float(np.sum(0.5 * (e2[1:][both] + e2[:-1][both]) * du))
    return float(np.sqrt(area / travel))


def places(res, us) -> str:
    """Where an extreme is reached, in words: ``res.format_u(u)`` of each driver value
    ``u``, joined by "and at" (an extreme reached twice in a turn). The same angle reached
    in consecutive turns from the first is said once, with their number
    (``driver angle 164.193° (in each of 11 turns)``), from a later turn with the first
    and last (``driver angle 164.193° after each of 1 to 10 turns``); hits in turns that
    do not follow each other are named one by one, each with its turn."""
    if res.linear:
        return " and at ".join(res.format_u(u) for u in us)
    groups: dict[str, list[tuple[int, str]]] = {}
    for u in us:
        angle, turns, where = res.turn_words(u)
        groups.setdefault(angle, []).append((turns, angle + where))
    texts = []
    for angle, hits in groups.items():
        ks = sorted(k for k, _ in hits)
        if len(ks) > 1 and ks == list(range(ks[0], ks[0] + len(ks))):
            if ks[0] == 0:
                texts.append(f"{angle} (in each of {len(ks)} turns)")
            else:
                texts.append(f"{angle} after each of {ks[0]} to {ks[-1]} turns")
        else:
            texts += [t for _, t in hits]
    return " and at ".join(dict.fromkeys(texts))


def _peak_reactions(src, joints, fscale: float, funit: str) -> str:
    """The summary's line of each joint's largest reaction sample (the requirements
    locate a peak between samples), its magnitude named where it is not the resultant
    (a slider's normal force); a peak that is rounding beside the others is 0."""
    g = src.forces
    found = []
    for j in joints:
        mag = np.where(g.ok, np.abs(g.reactions[j.name][j.magnitude]), np.nan)
        if np.any(np.isfinite(mag)):
            i = int(np.nanargmax(mag))
            found.append((j, i, float(mag[i])))
    top = max((m for _, _, m in found), default=0.0)
    peaks = []
    unbounded: dict[str, list[str]] = {}
    for j, i, m in found:
        note = f" ({j.magnitude_note.strip()})" if j.magnitude_note else ""
        mag = np.where(g.ok, np.abs(g.reactions[j.name][j.magnitude]), np.nan)
        toward = unbounded_towards(src, mag, i)
        if toward is None:  # towards the edge of a range where it cannot close
            toward = edge_growth(
                src, lambda x, k, j=j: np.abs(src.reaction_at(j.name, x, k)[j.magnitude])
            )
        if toward is not None:  # no peak: the largest sample is only the nearest one
            unbounded.setdefault(toward, []).append(j.name + note)
            continue
        m = or_zero(m, top)
        where = f" at {src.describe_u(i)}" if m else ""  # zero throughout: no place
        peaks.append(f"{j.name} {m / fscale:.4g} {funit}{note}{where}")
    for toward, names in unbounded.items():
        grow = "grows" if len(names) == 1 else "grow"
        peaks.append(f"{', '.join(names)} {grow} without bound towards {toward}")
    return f"  peak reactions ({src.samples()}): " + "; ".join(peaks)


def _effort_figures(src, e: np.ndarray, at: tuple[int, int], scale, unit, rms, mean) -> str:
    """The driving effort's max, min, RMS and mean; where it grows without bound towards
    a singular position (a rocker driven through a dead centre), that instead of the
    sample nearest it, and the RMS and a mean over time, which it makes infinite, blank."""
    imax, imin = at
    parts, unbounded = [], False
    for name, i, sign in (("max", imax, 1.0), ("min", imin, -1.0)):
        toward = unbounded_towards(src, sign * e, i)
        if toward is None:  # towards the edge of a range where it cannot close
            toward = edge_growth(src, lambda x, k, sign=sign: sign * src.effort_at(x, k))
        if toward is not None:
            parts.append(f"{name}: grows without bound towards {toward}")
            unbounded = True
        else:
            parts.append(f"{name} {e[i] / scale:.6g} {unit} at {src.describe_u(i)}")
    value, what = mean
    value = or_zero(value, float(np.nanmax(np.abs(e))))  # rounding of a zero mean is 0
    if unbounded:
        parts.append("RMS not determined (unbounded)")
        if what != "mean":  # the work over the travel stays exact (the energy method)
            value, what = math.nan, what
    else:
        parts.append(f"RMS {rms / scale:.6g} {unit}")
    parts.append(
        f"{what} {value / scale:.6g} {unit}" if math.isfinite(value) else f"{what} not determined"
    )
    return ", ".join(parts)


def unbounded_towards(src, values: np.ndarray, i: int) -> str | None:
    """Where ``values`` (a reaction's magnitude, NaN where not determined) grow without
    bound, in words, if their largest sample ``i`` is only the sample nearest a singular
    position (a toggle); else None.

    Next to a singular position the constraint Jacobian's reciprocal condition ``s``
    vanishes linearly along the motion, and a force that the singular pose cannot carry
    grows as ``1/s``: its largest sample is set by how close a sample lands (119 N at 1
    deg from a four-bar's change point, 1193 N at 0.1 deg, 1.19e5 N at 0.001 deg), not a
    figure. It is said to grow without bound where, from a sample ``j`` at least twice as
    far from singular (``s_j >= 2 s_i``, the nearest such), the value grows at least as
    ``s^-1/2`` (a bounded force does not grow as ``s`` halves), and the singular position
    (where ``s``, linear between ``j`` and ``i``, reaches zero, or a sample whose forces
    are indeterminate) is next to ``i``, between it and a neighbouring sample or past a
    neighbour whose reactions are not determined. A sweep that stops short of it has its
    largest value at its end: that is a figure of the sweep, and given."""
    rc = np.where(src.ok, src.jacobian_rcond(), np.nan)
    s_i = float(rc[i])
    if not (0 < s_i < NEAR_SINGULAR_TOGGLE) or not values[i] > 0:  # (at 0: its limit)
        return None
    far = np.flatnonzero((rc >= 2.0 * s_i) & np.isfinite(values) & (values > 0))
    if not far.size:
        return None
    j = int(far[np.argmin(np.abs(far - i))])
    growth = math.log(values[i] / values[j]) / math.log(rc[j] / s_i)
    if growth < 0.5:
        return None
    u_i, u_j = float(src.u[i]), float(src.u[j])
    u_s = u_i - s_i * (u_j - u_i) / (float(rc[j]) - s_i)
    singular = {k for k, _ in src.forces.singular}
    for k in (i - 1, i + 1):
        if not 0 <= k < len(values):
            continue
        if k in singular:  # the singular sample itself, its forces indeterminate
            return f"the singular position at {src.format_u(float(src.u[k]))} (no peak)"
        if not np.isfinite(values[k]):  # the next sample's reactions are not determined
            edge = _located_edge(src, float(src.u[i]), float(src.u[k]))
            if edge is not None:  # the edge of a range that cannot close, located
                return (
                    "the edge of a range where the mechanism cannot close, at "
                    f"{src.format_u(edge)} (no peak)"
                )
            return (
                f"the singular position at about {src.format_u(u_s)}, past the last sample "
                f"with reactions, {src.describe_u(i)} (no peak)"
            )
        u_k = float(src.u[k])
        if min(u_i, u_k) < u_s < max(u_i, u_k) and _reaches_singular(src, i, u_k, u_s):
            return f"the singular position at about {src.format_u(u_s)} (no peak)"
    return None  # the largest value over the sweep (at its end, short of the position)


def _located_edge(src, u_i: float, u_k: float) -> float | None:
    """The located edge of a range where the mechanism cannot close (see
    :attr:`~mechsolve.results.results.Results.failures`) between the driver values
    ``u_i`` (solved) and ``u_k`` (not), or None: the singular position the values grow
    towards, exactly, rather than extrapolated from two samples."""
    lo, hi = min(u_i, u_k), max(u_i, u_k)
    for f in getattr(src, "failures", None) or ():
        for x in (f.edge_in, f.edge_out):
            if np.isfinite(x) and lo <= x <= hi:
                return float(x)
    return None


def edge_growth(src, probe) -> str | None:
    """Where a quantity grows without bound towards the edge of a range where the
    mechanism cannot close (a dead zone, also one stepped over between two samples), in
    words; else None. ``probe(x, k)``: its values at driver values ``x`` solved next to
    sample ``k``. Its growth over the last decades of the distance from the edge (1e-4,
    1e-6, 1e-8 of the driver coordinate) does not die out, as a rate through a toggle
    (like 1/sqrt(d)) does (the test of the requirements' extremes): its largest sample
    is then not a peak, wherever it is."""
    if src.mechanism.driver.motion is not None or src.forces is None:
        return None
    scale = src.analysis.scale if src.analysis.linear else 1.0
    d = np.array([1e-4, 1e-6, 1e-8]) * scale
    for k, edge, away in gap_sides(src.solution):
        if abs(float(src.u[k]) - edge) <= 1e-8 * scale:  # a sample at the edge itself
            k += away
            if not (0 <= k < len(src.u) and src.ok[k]):
                continue
        side = 1.0 if float(src.u[k]) > edge else -1.0
        if not np.all(d < abs(float(src.u[k]) - edge)):
            continue
        with np.errstate(all="ignore"):
            v = np.asarray(probe(edge + side * d, k), float)
        if np.all(np.isfinite(v)) and v[2] - v[1] > 2.0 * (v[1] - v[0]) > 0.0:
            where = src.format_u(edge)
            return f"the edge of a range where the mechanism cannot close, at {where} (no peak)"
    return None


def _reaches_singular(src, i: int, u_k: float, u_s: float) -> bool:
    """Whether the constraints do become singular between sample ``i`` and the driver
    value ``u_k`` (at about ``u_s``, extrapolated): solved at 31 points between them and
    at ``u_s``, the reciprocal condition falls below an eighth of sample ``i``'s (a
    position that does not solve counts). A sharp but nonzero minimum (a four-bar a
    micrometre off its change point, a transmission angle of 0.2 deg) does not: there
    the values are bounded, and the largest sample is a figure (said to be a sample's)."""
    from mechsolve.core.conditioning import jacobian_rcond

    if src.mechanism.driver.motion is not None:
        return True  # (samples in time: nothing to solve between them)
    x = np.append(np.linspace(float(src.u[i]), u_k, 33)[1:-1], u_s)
    try:
        one = src.solved_near(x, i)
    except Exception:  # noqa: BLE001 - a position that cannot be solved: singular there
        return True
    if not np.all(one.ok):
        return True
    with np.errstate(invalid="ignore", divide="ignore"):
        rc = jacobian_rcond(src.analysis.plan, one.state, one.indicator)
    s_i = float(src.jacobian_rcond()[i])
    return not bool(np.nanmin(rc) >= s_i / 8) if np.size(rc) else True


# the reciprocal condition below which a largest sample may be one next to a toggle
NEAR_SINGULAR_TOGGLE = 0.1


def or_zero(x: float, scale: float) -> float:
    """``x``, or 0 where it is rounding against ``scale`` (a reaction of 6e-15 N beside
    forces of 100 N, an efficiency of 6e-15): such a figure is zero, not a value."""
    return 0.0 if abs(x) <= 1e-12 * abs(scale) else x
