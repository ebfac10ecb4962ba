"""Results of a sweep: named quantities as arrays, the CSV table, and a summary.

:class:`Results` is what the Python API returns and what the writers read. Arrays run
over the positions of the sweep; unsolved positions hold NaN and are listed in
:attr:`Results.failures`.

Conventions: SI units (m, m/s, m/s^2, rad/s, rad/s^2); angles are reported in degrees,
unwrapped along the sweep so that they change continuously, with the first value in
[0, 360). Angles are counter-clockwise from +x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .model import GROUND, Mechanism
from .sweep import Analysis, Failure, Solution, StateView, angle_deg


@dataclass
class PointMotion:
    """Position, velocity and acceleration of a point (arrays over positions)."""

    name: str
    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    ax: np.ndarray
    ay: np.ndarray


@dataclass
class LinkMotion:
    """Angle (rad, unwrapped), angular velocity and angular acceleration of a link."""

    name: str
    angle: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray


@dataclass
class SliderMotion:
    """Displacement, velocity and acceleration of a slider along its guide."""

    name: str
    s: np.ndarray
    v: np.ndarray
    a: np.ndarray


@dataclass
class Column:
    """One CSV column: a quantity name, its unit, its values and an optional note."""

    name: str
    unit: str
    values: np.ndarray
    note: str = ""

    @property
    def header(self) -> str:
        head = f"{self.name} [{self.unit}]" if self.unit else self.name
        return f"{head} ({self.note})" if self.note else head


def unwrap_angle(th: np.ndarray, near: float | None = None) -> np.ndarray:
    """Unwrap an angle along the sweep: the first finite value in [0, 2 pi), or within
    half a turn of ``near`` (to continue a previous chunk of the sweep)."""
    out = np.array(th, dtype=float)
    good = np.isfinite(out)
    if not np.any(good):
        return out
    out[good] = np.unwrap(out[good])
    first = out[good][0]
    if near is None or not math.isfinite(near):
        out[good] -= 2 * math.pi * math.floor(first / (2 * math.pi))
    else:
        out[good] -= 2 * math.pi * round((first - near) / (2 * math.pi))
    return out


class Results:
    """The solved sweep of a mechanism.

    Attributes
    ----------
    mechanism
        The model that was solved.
    u
        Driver coordinate at each position (rad or m).
    t
        Time at each position (s), from the start of the sweep.
    ok
        True where the position was solved.
    failures
        Runs of positions where the mechanism cannot close, with the loop and reason.
    """

    def __init__(self, analysis: Analysis, solution: Solution, forces=None) -> None:
        self.analysis = analysis
        self.solution = solution
        self.forces = forces  # a ForceResult, or None when no force analysis was asked
        self.mechanism: Mechanism = analysis.mech
        self.u = solution.u
        self.t = solution.t
        self.ok = solution.ok
        self.failures: list[Failure] = solution.failures
        self.view = StateView(analysis, solution.state)
        self.view.has_velocity = solution.has_velocity
        self.view.has_acceleration = solution.has_acceleration
        self.warnings: list[str] = list(solution.warnings)
        self.angle_origin: dict[str, float] = {}  # a previous chunk's last link angles

    # -- sizes and names ----------------------------------------------------------------
    def __len__(self) -> int:
        return len(self.u)

    @property
    def linear(self) -> bool:
        return self.analysis.linear

    @property
    def driver_value(self) -> np.ndarray:
        """Driver coordinate in report units: degrees for a revolute driver, m for a slider."""
        return self.u if self.linear else np.degrees(self.u)

    @property
    def driver_travel(self) -> np.ndarray:
        """Distance travelled by the driver from the start (deg or m), always increasing."""
        d = np.abs(self.u - self.solution.start.u0)
        return d if self.linear else np.degrees(d)

    def point_names(self) -> list[str]:
        """Named points reported (the file's ``outputs.points``, default all moving ones)."""
        mech = self.mechanism
        if mech.outputs.points is not None:
            return list(mech.outputs.points)
        nb = self.analysis.system.nb
        return [p for p, ref in self.analysis.points.items() if ref.body != nb]

    def link_names(self) -> list[str]:
        mech = self.mechanism
        return list(mech.outputs.links) if mech.outputs.links is not None else mech.link_names

    def slider_names(self) -> list[str]:
        mech = self.mechanism
        if mech.outputs.sliders is not None:
            return list(mech.outputs.sliders)
        return [j.name for j in mech.sliders]

    # -- quantities ---------------------------------------------------------------------
    def _nan(self) -> np.ndarray:
        return np.full(len(self.u), np.nan)

    def point(self, name: str) -> PointMotion:
        """Kinematics of a named point."""
        if name not in self.analysis.points:
            raise KeyError(f"no point named {name!r}")
        v = self.view
        x, y = v.quantity(name, "x"), v.quantity(name, "y")
        if v.has_velocity:
            vx, vy = v.quantity(name, "vx"), v.quantity(name, "vy")
        else:
            vx = vy = self._nan()
        if v.has_acceleration:
            ax, ay = v.quantity(name, "ax"), v.quantity(name, "ay")
        else:
            ax = ay = self._nan()
        b = np.broadcast_to
        n = len(self.u)
        return PointMotion(name, *(np.array(b(a, (n,)), float) for a in (x, y, vx, vy, ax, ay)))

    def link(self, name: str) -> LinkMotion:
        """Kinematics of a link (its frame's x axis)."""
        if name == GROUND or name not in self.analysis.system.index:
            raise KeyError(f"no link named {name!r}")
        b = self.analysis.system.index[name]
        st = self.solution.state
        om = st.w[b] if self.view.has_velocity else self._nan()
        al = st.al[b] if self.view.has_acceleration else self._nan()
        return LinkMotion(
            name, unwrap_angle(st.th[b], self.angle_origin.get(name)), om.copy(), al.copy()
        )

    def slider(self, name: str) -> SliderMotion:
        """Relative motion of a slider along its guide."""
        if name not in [j.name for j in self.mechanism.sliders]:
            raise KeyError(f"no slider named {name!r}")
        v = self.view
        s = v.quantity(name, "s")
        sv = v.quantity(name, "v") if v.has_velocity else self._nan()
        sa = v.quantity(name, "a") if v.has_acceleration else self._nan()
        return SliderMotion(name, s, sv, sa)

    # -- the table ----------------------------------------------------------------------
    def columns(self) -> list[Column]:
        """All reported quantities as CSV columns, in a stable order."""
        cols: list[Column] = [Column("t", "s", self.t)]
        if self.linear:
            cols += [
                Column("input.s", "m", self.u),
                Column("input.travel", "m", self.driver_travel),
            ]
        else:
            cols += [
                Column("input.angle", "deg", self.driver_value),
                Column("input.travel", "deg", self.driver_travel),
            ]
        vel, acc = self.view.has_velocity, self.view.has_acceleration
        for p in self.point_names():
            m = self.point(p)
            cols += [Column(f"{p}.x", "m", m.x), Column(f"{p}.y", "m", m.y)]
            if vel:
                cols += [Column(f"{p}.vx", "m/s", m.vx), Column(f"{p}.vy", "m/s", m.vy)]
            if acc:
                cols += [Column(f"{p}.ax", "m/s^2", m.ax), Column(f"{p}.ay", "m/s^2", m.ay)]
        for ln in self.link_names():
            m = self.link(ln)
            cols.append(Column(f"{ln}.angle", "deg", np.degrees(m.angle)))
            if vel:
                cols.append(Column(f"{ln}.omega", "rad/s", m.omega))
            if acc:
                cols.append(Column(f"{ln}.alpha", "rad/s^2", m.alpha))
        for a, b in self.mechanism.outputs.relative:
            m = self.relative(a, b)
            cols.append(Column(f"{m.name}.angle", "deg", np.degrees(m.angle)))
            if vel:
                cols.append(Column(f"{m.name}.omega", "rad/s", m.omega))
            if acc:
                cols.append(Column(f"{m.name}.alpha", "rad/s^2", m.alpha))
        for sn in self.slider_names():
            m = self.slider(sn)
            cols.append(Column(f"{sn}.s", "m", m.s))
            if vel:
                cols.append(Column(f"{sn}.v", "m/s", m.v))
            if acc:
                cols.append(Column(f"{sn}.a", "m/s^2", m.a))
        if self.forces is not None:
            cols += self.force_columns()
        sol = self.solution
        cols += [
            Column("jacobian.rcond", "-", np.where(self.ok, self.jacobian_rcond(), np.nan)),
            Column("solver.iterations", "-", sol.iterations.astype(float)),
            Column("solver.residual", "m", sol.residual),
        ]
        return cols

    def relative(self, a: str, b: str) -> LinkMotion:
        """Motion of link ``a`` relative to link ``b`` (either may be ``ground``), named
        ``a/b``: the angle of a's frame minus b's (rad, unwrapped like a link's angle, the
        first value in [0, 2 pi)), and the differences of their angular velocities and
        accelerations."""
        name = f"{a}/{b}"
        zero = np.zeros(len(self.u))
        rows = []
        for ln in (a, b):
            if ln == GROUND:
                rows.append((zero, zero, zero))
                continue
            if ln not in self.analysis.system.index:
                raise KeyError(f"no link named {ln!r}")
            k = self.analysis.system.index[ln]
            st = self.solution.state
            om = st.w[k] if self.view.has_velocity else self._nan()
            al = st.al[k] if self.view.has_acceleration else self._nan()
            rows.append((st.th[k], om, al))
        (tha, wa, ala), (thb, wb, alb) = rows
        th = unwrap_angle(np.asarray(tha, float) - thb, self.angle_origin.get(name))
        return LinkMotion(name, th, np.asarray(wa - wb, float), np.asarray(ala - alb, float))

    # -- conditioning and design figures --------------------------------------------------
    def jacobian_rcond(self) -> np.ndarray:
        """Reciprocal condition number of the constraint equations at each position (the
        smallest over the groups, see :func:`mechsolve.conditioning.jacobian_rcond`):
        1 well conditioned, 0 singular."""
        if not hasattr(self, "_rcond"):
            from .conditioning import jacobian_rcond

            with np.errstate(invalid="ignore", divide="ignore"):
                sol = self.solution
                self._rcond = jacobian_rcond(self.analysis.plan, sol.state, sol.indicator)
        return self._rcond

    def limit_positions(self):
        """Limit positions of the rockers and sliders (see :mod:`mechsolve.limits`)."""
        if not hasattr(self, "_limits"):
            from .limits import limit_positions

            self._limits = limit_positions(self.solution)
        return self._limits

    def transmission_angles(self):
        """The smallest transmission angle of each loop (see :mod:`mechsolve.limits`)."""
        if not hasattr(self, "_transmission"):
            from .limits import transmission_angles

            self._transmission = transmission_angles(self.solution)
        return self._transmission

    @property
    def events(self):
        """Bifurcations, dead zones stepped over, near-singular minima met by the sweep."""
        return self.solution.events

    def design_summary(self, figures: Results | None = None) -> list[str]:
        """The summary's lines about singular positions, conditioning and the design
        figures; ``figures``: a finer sweep of the same motion to take the limit positions
        and transmission angles from (see :meth:`summary`)."""
        src = self if figures is None else figures
        lines = []
        if len(self.u) < 2:
            return lines
        ev = self.events
        if ev:
            parts = []
            for e in ev[:8]:
                where = self.analysis.format_u(e.u)
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
            lines.append("  singular positions: " + "; ".join(parts) + more)
        sol = self.solution
        for idx, what in (
            (sol.rates_by_limit, "are their limits along the motion"),
            (sol.rates_undetermined, "are not determined (left blank)"),
        ):
            if idx:
                where = ", ".join(self.describe_u(i) for i in idx[:5])
                more = f" and {len(idx) - 5} more" if len(idx) > 5 else ""
                lines.append(
                    f"  velocities and accelerations at {len(idx)} singular position(s) "
                    f"{what}: {where}{more}"
                )
        rc = np.where(self.ok, self.jacobian_rcond(), np.nan)
        if np.any(np.isfinite(rc)):
            i = int(np.nanargmin(rc))
            lines.append(
                f"  conditioning: smallest reciprocal condition of the constraint Jacobian "
                f"{rc[i]:.3g} at {self.describe_u(i)}"
            )
        lim = src.limit_positions()
        if lim:
            parts = []
            ratios = []
            for lp in lim:
                fmt = self.analysis.format_u
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
            lines.append("  limit positions: " + "; ".join(parts))
            if ratios:
                lines.append("  time ratio: " + "; ".join(ratios))
        tr = src.transmission_angles()
        if tr:
            lines.append(
                "  minimum transmission angle: "
                + "; ".join(
                    f"{t.group} {math.degrees(t.angle):.4g}° at {self.analysis.format_u(t.u)}"
                    for t in tr
                )
            )
        return lines

    # -- forces -------------------------------------------------------------------------
    @property
    def effort_name(self) -> tuple[str, str]:
        """("torque", "N*m") for a revolute driver, ("force", "N") for a linear one."""
        return ("force", "N") if self.linear else ("torque", "N*m")

    def joint_label(self, name: str) -> str:
        """``O1(ground->crank)``: the reaction is the force on the second link by the first."""
        j = self.mechanism.joint(name)
        return f"{name}({j.links[0]}->{j.links[1]})"

    def reaction(self, name: str) -> dict[str, np.ndarray]:
        """Reaction components of a joint: Fx, Fy, F (revolute) or N, M, Fx, Fy (slider)."""
        if self.forces is None:
            raise KeyError("no force analysis was run (the model has no masses or loads)")
        return self.forces.reactions[name]

    @property
    def driving_effort(self) -> np.ndarray:
        """The driving torque (N m) or force (N) the driver applies to the driven link."""
        if self.forces is None:
            raise KeyError("no force analysis was run (the model has no masses or loads)")
        f = self.forces
        ok = f.ok.copy()
        ok[f.effort_by_limit] = True  # its limit along the motion at a singular position
        return np.where(ok, f.effort, np.nan)

    def force_columns(self) -> list[Column]:
        f = self.forces
        ok = f.ok

        def m(a):
            return np.where(ok, a, np.nan)

        kind, unit = self.effort_name
        cols = [Column(f"input.{kind}", unit, self.driving_effort, self._note("driver", "effort"))]
        for j in self.mechanism.joints:
            lab = self.joint_label(j.name)
            r = f.reactions[j.name]
            comps = (
                [("Fx", "N"), ("Fy", "N"), ("F", "N")]
                if "F" in r
                else [("N", "N"), ("M", "N*m"), ("Fx", "N"), ("Fy", "N")]
            )
            cols += [Column(f"{lab}.{c}", un, m(r[c]), self._note(j.name, c)) for c, un in comps]
        for name, on in f.active.items():
            cols.append(Column(f"load.{name}.active", "-", on.astype(float)))
        cols += [
            Column("energy.kinetic", "J", m(f.kinetic)),
            Column("energy.potential", "J", m(f.potential)),
            Column("power.input", "W", m(f.power_input)),
            Column("power.kinetic_rate", "W", m(f.kinetic_rate)),
            Column("power.potential_rate", "W", m(f.potential_rate)),
            Column("power.loads", "W", m(f.power_loads)),
            Column("power.residual", "W", m(f.residual)),
        ]
        return cols

    def _note(self, joint: str, component: str) -> str:
        """``minimum-norm`` for a reaction component that redundant constraints leave
        indeterminate."""
        return "minimum-norm" if component in self.forces.nonunique.get(joint, ()) else ""

    def power_scale(self) -> float:
        """The largest power term over the sweep: the scale of the power-balance check."""
        f = self.forces
        terms = [f.power_input, f.kinetic_rate, f.potential_rate, f.power_loads]
        vals = [np.nanmax(np.abs(np.where(f.ok, t, np.nan))) for t in terms if np.any(f.ok)]
        return float(max(vals)) if vals else 0.0

    def work(self) -> float:
        """Work done by the driver over the sweep (J); for a full turn, the work per cycle.
        See :func:`mechsolve.solvers.forces.driver_work`."""
        return self._work_why()[0]

    def _work_why(self) -> tuple[float, str]:
        """The driver's work and why it is not defined (see
        :func:`mechsolve.solvers.forces.driver_work_why`), computed once."""
        from .solvers.forces import driver_work_why

        if not hasattr(self, "_work"):
            self._work = driver_work_why(self.analysis, self.solution, self.forces)
        return self._work

    def incomplete(self) -> bool:
        """Whether anything asked for was left out or is doubtful: positions not solved,
        rates or forces not determined at singular positions, or a warning (call after
        :meth:`summary`, which runs the checks). The command line warns then (exit 0)."""
        sol = self.solution
        return bool(
            self.failures
            or sol.rates_undetermined
            or (self.forces is not None and self.forces.singular)
            or self.warnings
        )

    def mean_effort(self) -> tuple[float, str]:
        """The driver's mean effort and what it is: the work over the travel when the
        motion has no gaps (the exact mean over the sweep, between samples too), else
        the average of the solved samples, said so."""
        work = self.work()
        travel = self.u[-1] - self.u[0]
        if math.isfinite(work) and travel != 0:
            return work / travel, "mean"
        e = np.where(self.forces.ok, self.forces.effort, np.nan)
        if not np.any(np.isfinite(e)):
            return float("nan"), "mean"
        return float(np.nanmean(e)), "mean of the solved positions"

    def work_text(self) -> str:
        """``work of the driver per cycle: 31.74 kJ``, or why it is not defined."""
        per = "per cycle" if self.is_full_cycle() else "over the sweep"
        work, why = self._work_why()
        if not math.isfinite(work):
            return f"work of the driver {per}: not defined ({why or 'not enough positions'})"
        wscale, wsym = (1e3, "k") if abs(work) >= 1e4 else (1.0, "")
        return f"work of the driver {per}: {work / wscale:.6g} {wsym}J"

    def is_full_cycle(self) -> bool:
        from .limits import full_cycle

        return full_cycle(self.linear, self.u)

    def status(self) -> list[str]:
        """Per position: ``ok`` or why it was not solved."""
        out = ["ok"] * len(self.u)
        for f in self.failures:
            for i in range(f.first, f.last + 1):
                out[i] = "unassemblable: " + f.group
        if self.forces is not None:
            for i, label in self.forces.singular:
                if out[i] == "ok":
                    out[i] = f"singular: forces indeterminate in {label}"
        return out

    def methods(self) -> list[str]:
        """How each position was solved (``closed form``, ``newton``, ``scipy-hybr``...)."""
        m = self.solution.methods
        if m is None:
            return ["closed form" if ok else "" for ok in self.ok]
        return [str(x) if ok else "" for x, ok in zip(m, self.ok)]

    def to_csv(self, path) -> Path:
        """Write the table as CSV (see :mod:`mechsolve.writers.csv`); return the path."""
        from .writers.csv import write_csv

        return write_csv(self, path)

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
        from .model.motion import describe

        unit = "m/s^2" if self.linear else "rad/s^2"
        lines = [f"  driver motion: {describe(law)}"]
        jumps = self.motion_events()
        if jumps:
            lines.append(
                "  driver acceleration jumps (position and speed continuous) at "
                + ", ".join(f"t = {t:.6g} s ({a:.6g} -> {b:.6g} {unit})" for t, a, b in jumps)
            )
        return lines

    def summary(self, figures: Results | None = None) -> str:
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
        start = self.solution.start
        for g, why in zip(self.analysis.groups, getattr(start, "reasons", []) or []):
            if "the start is singular" in why:
                lines.append(f"  start: {g.label}: the branch {why}")
        for f in self.failures:
            lines.append(
                f"  unassemblable at {self.describe_u(f.first)}"
                + (f" to {self.describe_u(f.last)}" if f.last != f.first else "")
                + f" ({f.last - f.first + 1} position(s)): {f.reason}"
                + (
                    f"; it stops closing at {self.analysis.format_u(f.edge_in)}"
                    if np.isfinite(f.edge_in)
                    else ""
                )
                + (
                    f"; it closes again from {self.analysis.format_u(f.edge_out)}"
                    if np.isfinite(f.edge_out)
                    else ""
                )
            )
        for p in self.point_names()[:12]:
            m = self.point(p)
            if np.any(np.isfinite(m.x)):
                lines.append(
                    f"  {p}: x {np.nanmin(m.x):.6g} .. {np.nanmax(m.x):.6g} m, "
                    f"y {np.nanmin(m.y):.6g} .. {np.nanmax(m.y):.6g} m"
                    + (
                        f", |v| max {np.nanmax(np.hypot(m.vx, m.vy)):.4g} m/s"
                        if self.view.has_velocity
                        else ""
                    )
                )
        if len(self.point_names()) > 12:
            lines.append(f"  ... and {len(self.point_names()) - 12} more points in the CSV")
        methods = self.methods()
        meth = {m for m, ok in zip(methods, self.ok) if ok}
        fallback = sum(1 for m in methods if "scipy" in m)
        its = self.solution.iterations[self.ok]
        lines.append(
            "  solver: "
            + ", ".join(sorted(meth))
            + (f"; Newton iterations max {int(its.max())}" if its.size and its.max() > 0 else "")
            + (f"; scipy fallback at {fallback} position(s)" if fallback else "")
            + (
                f"; max constraint residual {np.nanmax(self.solution.residual):.2g} m"
                if np.any(self.ok)
                else ""
            )
        )
        red = self.analysis.redundancy
        if red is not None:
            lines.append(
                f"  redundant constraints: {red.count} equation(s) repeat the others "
                f"(the constraint Jacobian has rank {red.rank} for {self.analysis.system.nc} "
                f"equations), among: {', '.join(red.equations)}; solved by least squares on "
                "all of them"
            )
            if red.removable:
                lines.append("  " + red.suggestion())
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
        step = float(np.median(du))
        if self.linear:
            return f"{step * 1e3:.4g} mm" if step < 1 else f"{step:.4g} m"
        return f"{math.degrees(step):.4g}°"

    def force_summary(self, figures: Results | None = None) -> list[str]:
        """The summary's lines about the forces; ``figures``: a finer sweep of the same
        motion to take the figures from (see :meth:`summary`), the driving effort as
        :attr:`driving_effort` gives it (at a singular position its limit)."""
        f = self.forces
        lines = []
        if not np.any(f.ok):
            return ["  forces: no position could be solved"]
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
        peaks = []
        for j in self.mechanism.joints:
            r = g.reactions[j.name]
            mag = np.abs(r["F"] if "F" in r else r["N"])
            mag = np.where(g.ok, mag, np.nan)
            if np.any(np.isfinite(mag)):
                i = int(np.nanargmax(mag))
                peaks.append(f"{j.name} {mag[i] / scale:.4g} {sym}N at {src.describe_u(i)}")
        lines.append("  peak reactions: " + "; ".join(peaks))
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
            where = ", ".join(self.describe_u(i) for i in at[:5])
            more = f" and {len(at) - 5} more" if len(at) > 5 else ""
            groups = list(dict.fromkeys(label for _, label in f.singular))
            lines.append(
                f"  forces indeterminate at {len(at)} singular position(s): {where}{more} "
                f"({'; '.join(groups)})"
            )
            if f.effort_by_limit:
                kind = self.effort_name[0]
                lines.append(
                    f"  the driving {kind} at {len(f.effort_by_limit)} of them is its limit "
                    "along the motion (smooth through the position); the reactions stay empty"
                )
        if f.effort_near_limit:
            kind = self.effort_name[0]
            lines.append(
                f"  the driving {kind} at {len(f.effort_near_limit)} position(s) next to a "
                "singular one is its limit along the motion (computed there, it would carry "
                "the pose's rounding amplified by the near-singular loop)"
            )
        return lines
