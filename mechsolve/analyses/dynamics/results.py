"""The results of a simulation: states and forces along the motion, and its summary
(see :mod:`mechsolve.analyses.dynamics`)."""

from __future__ import annotations

import math
import re

import numpy as np

from mechsolve.analyses.dynamics.constants import REST_BAND, REST_BAND_LINEAR, REST_SPAN
from mechsolve.analyses.dynamics.integrators import _STOPS, ENERGY_TOLERANCE, Trajectory
from mechsolve.analyses.dynamics.model import drive_torque
from mechsolve.base.units import SI_OUTPUT, OutputUnits, pretty_unit
from mechsolve.core.solution import angle_deg
from mechsolve.core.work import hermite5
from mechsolve.results.results import Column, Results
from mechsolve.results.summary import print_scale, shown


class SimulationResults(Results):
    """Results along a simulated motion: the sweep's columns, with the driver's speed,
    acceleration, reduced inertia and the motor's torque and power first."""

    def __init__(self, an, sol, forces, traj: Trajectory, motor) -> None:
        super().__init__(an, sol, forces)
        self.trajectory = traj
        self.motor = motor

    def motor_torque(self) -> np.ndarray:
        """The motor's torque on the driver (counter-clockwise positive, as the driving
        torque of the force analysis)."""
        d = self.mechanism.driver.direction
        return drive_torque(self.motor, d, self.trajectory.omega, self.trajectory.t)

    def columns(self) -> list[Column]:
        tr = self.trajectory
        lin = self.linear
        cols = super().columns()
        extra = [
            Column("omega" if not lin else "v", "m/s" if lin else "rad/s", tr.omega),
            Column("epsilon" if not lin else "a", "m/s^2" if lin else "rad/s^2", tr.eps),
            Column("J", "kg" if lin else "kg*m^2", tr.J),
            Column(
                "motor.torque" if not lin else "motor.force",
                "N" if lin else "N*m",
                self.motor_torque(),
            ),
            Column("motor.power", "W", self.motor_torque() * tr.omega),
            Column("energy.residual", "J", self.energy_residual()),
        ]
        return cols[:3] + extra + cols[3:]

    def energy_residual(self) -> np.ndarray:
        """The energy balance along the motion: the work of the motor and the loads less
        the joints' friction losses since the start (the trapezoid rule over the time
        steps) minus the change of kinetic and potential energy (J). It measures the
        integration: zero to the step's accuracy."""
        f = self.forces
        if f is None:
            return np.full(len(self.t), np.nan)
        P = self.motor_torque() * self.trajectory.omega + f.power_loads - f.power_friction
        t = self.trajectory.t
        work = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))])
        E = f.kinetic + f.potential
        return work - (E - E[0])

    def motor_work(self) -> float:
        """The motor's work along the motion (J), ``integral of M(omega, t) omega dt``:
        5-point Gauss-Legendre between the rows on the quintic Hermite interpolant of the
        driver's angle through its angle, speed and acceleration at both rows (its speed
        a quartic: a constant torque gives M times the travel to rounding; a law of the
        speed carries the interpolant's error, O(h^5) in the speed, see
        :meth:`motor_work_error`); NaN where the motion is not finite."""
        return self._motor_work()[0]

    def motor_work_error(self) -> float:
        """An estimate of :meth:`motor_work`'s error (J): its difference from the same
        rule on the cubic Hermite interpolant through the angles and speeds alone (a
        lower order: an upper estimate; zero to rounding for a constant torque)."""
        return self._motor_work()[1]

    def _motor_work(self) -> tuple[float, float]:
        if hasattr(self, "_motor_work_cache"):
            return self._motor_work_cache
        tr = self.trajectory
        t, phi, w, eps = tr.t, tr.phi, tr.omega, tr.eps
        out = (math.nan, math.nan)
        if len(t) >= 2 and all(np.all(np.isfinite(a)) for a in (t, phi, w, eps)):
            h = np.diff(t)
            ks = np.flatnonzero(h > 0)
            x, wt = np.polynomial.legendre.leggauss(5)
            s = np.tile(0.5 * (x + 1.0), len(ks))
            kk = np.repeat(ks, len(x))
            tau = t[kk] + h[kk] * s
            v5 = hermite5(t, phi, w, eps, tau, kk)[1]
            # the cubic Hermite's speed through (phi, omega) at both rows
            dp = (phi[kk + 1] - phi[kk]) / h[kk]
            v3 = (
                6 * (s - s * s) * dp
                + (3 * s * s - 4 * s + 1) * w[kk]
                + (3 * s * s - 2 * s) * w[kk + 1]
            )
            d = self.mechanism.driver.direction
            work = []
            for v in (v5, v3):
                with np.errstate(all="ignore"):
                    P = drive_torque(self.motor, d, v, tau) * v
                work.append(float(np.sum((P.reshape(-1, len(x)) @ wt) * 0.5 * h[ks])))
            if all(math.isfinite(a) for a in work):
                out = (work[0], abs(work[0] - work[1]))
        self._motor_work_cache = out
        return out

    def work_text(self, units: OutputUnits | None = None) -> str:
        """With joint friction, the motor's work (:meth:`_work_why`) to the digits its
        error estimate allows (at most 6)."""
        text = super().work_text(units)
        err = self.motor_work_error()
        work = self.work()
        if getattr(self.forces, "friction", None) is None or not err > 0 or "not" in text:
            return text
        fmt = _digits(work, err, 6)
        if fmt == ".6g":
            return text
        U = units or shown(self)
        per = "per cycle" if self.is_full_cycle() else "over the sweep"
        return (
            f"work of the driver {per}: {U.text(work, 'J', fmt)} (the motor's, to the "
            "digits its output rows allow)"
        )

    def _work_why(self) -> tuple[float, str]:
        """The driver's work. With joint friction the motor's (:meth:`motor_work`; the
        driver's effort is the motor's along the motion), not the energy method's, whose
        friction part is a rule on the rows; without, the energy method's (exact on the
        rows: a difference of energies and the loads' work)."""
        fr = getattr(self.forces, "friction", None)
        if not hasattr(self, "_work") and fr is not None:
            w = self.motor_work()
            if math.isfinite(w):
                self._work = (w, "")
        return super()._work_why()

    def friction_lines(self) -> list[str]:
        """The friction losses from the energy balance, the motor's work (exact along the
        motion) less the change of energy and the loads' work; the split by joint is the
        trapezoid rule on the rows, said so, to the digits that rule's error allows (its
        total's difference from the balance)."""
        lines = super().friction_lines()
        head = "  friction losses over the sweep: "
        if not lines or not lines[0].startswith(head) or self.forces.friction is None:
            return lines
        from mechsolve.core.work import driver_work_why, friction_work
        from mechsolve.results.summary import _Only

        sol, f = self.solution, self.forces
        rule, why = friction_work(sol, f)
        energy, why2 = driver_work_why(self.analysis, sol, f)  # dE - W_loads + rule
        motor = self.motor_work()
        loss = motor - (energy - rule)
        if why or why2 or not math.isfinite(loss):
            return lines
        U = shown(self)
        err = abs(loss - rule) + self.motor_work_error()
        parts = []
        for name, p in f.friction.loss.items():
            w = friction_work(sol, _Only(f, p))[0]
            parts.append(f"{name} {U.text(w, 'J', _digits(w, err))}")
        total = U.text(loss, "J", _digits(loss, self.motor_work_error(), 6))
        if abs(loss - rule) > ENERGY_TOLERANCE * abs(loss):
            warning = (
                f"the friction losses by joint (the trapezoid rule on the rows: "
                f"{U.text(rule, 'J', '.3g')} in all) differ from their total from the energy "
                f"balance ({U.text(loss, 'J', '.3g')}) by more than {ENERGY_TOLERANCE:g} of "
                "it: the rows do not follow the motion (a fixed step chattering about a "
                "standstill, or rows too far apart), and the results fail this check; give "
                "a smaller step, or an adaptive or stiff method (method: RK45, Radau or BDF)"
            )
            if warning not in self.warnings:
                self.warnings.append(warning)
        lines[0] = (
            f"{head}{total} (the motor's work less the change of energy and the "
            f"loads' work; by joint, the trapezoid rule on the {len(self.t)} rows: "
            f"{', '.join(parts)})"
        )
        return lines

    def summary(self, figures=None, units: OutputUnits | None = None) -> str:
        """The sweep's summary and the simulation's figures, in ``units`` (default SI)."""
        tr = self.trajectory
        lines = [super().summary(figures, units=units)]
        U = units or SI_OUTPUT
        lin = self.linear
        kw, wu = U.convert("m/s" if lin else "rad/s")
        ka, au = U.convert("m/s^2" if lin else "rad/s^2")
        sim = self.mechanism.simulation
        how = (
            f"rk4, {len(tr.t) - 1} steps of {U.text(sim.step, 's')}"
            if sim.method == "rk4"
            else f"{sim.method}, {len(tr.t)} output rows"
        )
        lines.append(
            f"  simulation: {how} to t = {U.text(tr.t[-1], 's')}; motor {self._motor_text()}"
        )
        parts = []
        if np.any(np.isfinite(tr.omega)):
            k = int(np.nanargmax(np.abs(tr.omega)))  # the fastest, either way
            parts.append(
                f"fastest |{'v' if lin else 'omega'}| = {abs(tr.omega[k]) * kw:.6g} {wu} at "
                f"t = {U.text(tr.t[k], 's')}"
                + (f", {self._sense(tr.omega[k])}" if tr.omega[k] else "")
            )
        if np.any(np.isfinite(tr.eps)):
            parts.append(
                f"{'a' if lin else 'epsilon'} from {np.nanmin(tr.eps) * ka:.8g} to "
                f"{np.nanmax(tr.eps) * ka:.8g} {au}"
            )
        if np.any(np.isfinite(tr.J)):
            what, unit = ("reduced mass", "kg") if lin else ("reduced inertia J", "kg*m^2")
            parts.append(f"{what} from {np.nanmin(tr.J):.6g} to {np.nanmax(tr.J):.6g} {unit}")
        if parts:
            lines.append("  " + "; ".join(parts))
        M = self.motor_torque()
        kind, unit = self.effort_name
        km, unit = U.convert(unit)
        if f"  driving {kind} (" not in lines[0]:  # else that line gives the same
            lines.append(
                f"  motor {kind}: from {np.nanmin(M) * km:.6g} to {np.nanmax(M) * km:.6g} "
                f"{unit}, time mean {self.time_mean(M) * km:.6g} {unit}"
            )
        rest = self.stall()
        # a machine come to rest has no cycle to speak of
        turns = getattr(getattr(self, "model", None), "turns", None) or 1
        dl = steady_fluctuation(tr, turns) if not (lin or rest.startswith("stalled")) else None
        if dl is not None:
            mean, delta = dl
            over = "revolution" if turns == 1 else f"cycle ({turns} revolutions)"
            lines.append(
                f"  last full {over}: time mean of |omega| {mean * kw:.6g} {wu}, coefficient "
                f"of fluctuation delta = (max - min) / mean = {delta:.4g}"
            )
        if rest:
            lines.append("  " + rest)
        if tr.early:
            lines.append(
                f"  stopped early at t = {tr.t[-1]:.6g} s: {tr.stopped}; the motion up to "
                "there is kept"
            )
        elif tr.stopped:
            lines.append(f"  ended {tr.stopped}")
        return "\n".join(lines)

    def _motor_text(self) -> str:
        """The motor's law with its units (``M = 50 N*m - 1.25 N*m*s * omega``)."""
        return self.motor.describe(self.linear)

    def _sense(self, omega: float) -> str:
        """The sense of a signed driver speed in words, against the driver's direction."""
        d = self.mechanism.driver.direction
        with_driver = omega * d > 0
        if self.linear:
            return (
                "along the driver's direction"
                if with_driver
                else ("against the driver's direction (backwards)")
            )
        turn = "counter-clockwise" if omega > 0 else "clockwise"
        return (
            f"{turn} (the driver's direction)"
            if with_driver
            else (f"{turn}: backwards, against the driver's direction")
        )

    def time_mean(self, y: np.ndarray) -> float:
        """The mean of ``y`` over the time of the motion (trapezoid rule over the rows):
        the mean that the summary and the plots give."""
        t = self.trajectory.t
        ok = np.isfinite(y)
        if ok.sum() < 2 or t[ok][-1] <= t[ok][0]:
            return float(np.nanmean(y)) if ok.any() else math.nan
        return float(np.trapezoid(y[ok], t[ok]) / (t[ok][-1] - t[ok][0]))

    def mean_effort(self) -> tuple[float, str]:
        """The driver's mean effort over the time of the motion (the summary's and the
        plot's), said so."""
        e = np.where(self.forces.ok, self.forces.effort, np.nan)
        return self.time_mean(e), "time mean"

    def sample_spacing(self) -> str:
        return f"{len(self.t)} time"  # "driving torque (1101 time samples)"

    def force_summary(self, figures: Results | None = None) -> list[str]:
        lines = super().force_summary(figures)
        e = np.where(self.forces.ok, self.forces.effort, np.nan)
        if lines and lines[0].startswith("  driving ") and np.any(np.isfinite(e)):
            # the RMS over time too (the rows of an adaptive method are not evenly spaced)
            rms = math.sqrt(self.time_mean(e * e))
            kind, unit = self.effort_name
            scale, unit = print_scale(e, unit, shown(self))  # as super's
            lines[0] = re.sub(
                r", RMS [^,]*, time mean",
                f", RMS over time {rms / scale:.6g} {pretty_unit(unit)}, time mean",
                lines[0],
            )
        return lines

    def describe_u(self, i: int) -> str:
        """Where along the motion row ``i`` is: its time, and the driver's angle with the
        turns made from the start (``t = 1.682 s (driver angle 113.5°, 11 turns + 113.5°
        from the start)``)."""
        t = float(self.trajectory.t[i])
        u = float(self.u[i])
        at = f"t = {shown(self).text(t, 's')}"  # in the summary's time unit
        if self.linear:
            return f"{at} ({self.analysis.format_u(u)})"
        d = self.mechanism.driver.direction
        travel = math.degrees(d * (u - float(self.u[0])))
        turns, part = divmod(abs(travel), 360.0)
        back = " backwards" if travel < 0 else ""
        where = f"driver angle {angle_deg(u):.6g}°"
        plain = float(self.u[0]) == 0 and d > 0 and not back  # the angle is the turn's part
        n = f"{int(turns)} turn{'s' if turns > 1 else ''}"
        if turns and plain:
            where += f" after {n}"
        elif turns:
            where += f", {n} + {part:.6g}°{back} from the start"
        elif travel and not plain:
            where += f", {abs(travel):.6g}°{back} from the start"
        return f"{at} ({where})"

    def stall(self) -> str:
        """``stalled at …`` when the machine comes to rest and stays (a motor too weak to
        start it, or one that stops it): the driver stays within :data:`REST_BAND` (a linear
        driver: :data:`REST_BAND_LINEAR`) of its last position for the last
        :data:`REST_SPAN` of the run (at least 10 rows). The position given is where the
        motor's effort at standstill balances the static load (``M(0, t) = E0(phi, 0)``,
        solved next to the last position), if found there; else the last position.
        ``does not turn …`` for a crank that swings to and fro without completing a
        revolution. '' otherwise."""
        tr = self.trajectory
        n = len(tr.t)
        if n < 12 or tr.early:
            return ""
        phi, t = tr.phi, tr.t
        band = REST_BAND_LINEAR if self.linear else REST_BAND
        off = np.abs(phi - phi[-1]) > band
        k = int(np.flatnonzero(off)[-1]) + 1 if off.any() else 0
        if n - k >= 10 and t[-1] - t[k] >= REST_SPAN * t[-1]:
            u, balance = self._balance(float(phi[-1]), float(t[-1]), band)
            where = self.describe_u(n - 1).split("(", 1)[1].rstrip(")")
            if u is not None:
                where = self._with_u(u)
            kind, unit = self.effort_name
            within = f"{band * 1e3:g} mm" if self.linear else f"{math.degrees(band):.2g}°"
            text = f"stalled at {where} after t = {t[k]:.6g} s (at rest from then on, to {within})"
            if balance is not None and u is not None:
                text += (
                    f": the motor's {kind} at standstill, {balance:.6g} {unit}, balances the "
                    "static load there"
                )
            return text
        if not self.linear and np.max(np.abs(phi - phi[0])) < 2 * math.pi:
            moving = tr.omega[np.abs(tr.omega) > 0]
            if moving.size and np.any(np.sign(moving[1:]) != np.sign(moving[:-1])):
                lo, hi = np.argmin(phi), np.argmax(phi)
                return (
                    f"does not turn: no full revolution in {t[-1]:.6g} s; the driver swings "
                    f"between {self._with_u(float(phi[lo]))} and {self._with_u(float(phi[hi]))}"
                )
        return ""

    def _with_u(self, u: float) -> str:
        """A driver position in words, with the travel from the start."""
        if self.linear:
            return self.analysis.format_u(u)
        d = self.mechanism.driver.direction
        travel = math.degrees(d * (u - float(self.u[0])))
        back = " backwards" if travel < 0 else ""
        if not travel:
            return f"driver angle {angle_deg(u):.6g}° (the start)"
        return f"driver angle {angle_deg(u):.6g}° ({abs(travel):.6g}°{back} from the start)"

    def _balance(self, u: float, t: float, band: float):
        """``(u*, M)``: the driver position next to ``u`` where the motor's effort at
        standstill ``M = M(0, t)`` balances the static load ``E0(u*, 0)`` (secant
        iterations on the equation of motion; None if they leave ``band`` of ``u`` or
        fail), and ``M``."""
        model = getattr(self, "model", None)
        d = self.mechanism.driver.direction
        M = float(drive_torque(self.motor, d, np.array([0.0]), t)[0])
        if model is None or not math.isfinite(M):
            return None, (M if math.isfinite(M) else None)

        def g(x: float) -> float:
            return M - model.terms(x, 0.0, t)[1]

        try:
            x0, x1 = u + 1e-3 * band, u
            g0, g1 = g(x0), g(x1)
            for _ in range(50 if abs(g1) > 1e-9 * max(1.0, abs(M)) else 0):
                if g1 == g0:
                    break
                x0, x1, g0 = x1, x1 - g1 * (x1 - x0) / (g1 - g0), g1
                g1 = g(x1)
                if abs(x1 - x0) <= 1e-13 * max(1.0, abs(x1)):
                    break
        except _STOPS:
            return None, M
        if not (math.isfinite(x1) and abs(x1 - u) <= band and abs(g1) <= 1e-9 * max(1.0, abs(M))):
            return None, M
        return x1, M

    def incomplete(self) -> bool:
        """Also when the motion stopped before what was asked (see :class:`Trajectory`)."""
        return super().incomplete() or self.trajectory.early


def _digits(value: float, err: float, most: int = 4) -> str:
    """A format with the significant digits of ``value`` that an error ``err`` leaves
    (its last digit's unit at least twice the error; ``most`` at most, 1 at least)."""
    if not (err > 0 and value):
        return f".{most}g"
    last = math.ceil(math.log10(2 * err))  # the last digit's decimal place
    return f".{min(most, max(1, math.floor(math.log10(abs(value))) - last + 1))}g"


def steady_fluctuation(tr: Trajectory, turns: int = 1):
    """(mean speed, delta = (max - min) / mean) over the last full cycle of ``turns``
    revolutions of the driver (the machine's cycle: several for a pinion driving a
    wheel), or None."""
    if len(tr.phi) < 3:
        return None
    turn = 2 * math.pi * max(1, turns)
    end = tr.phi[-1]
    k = np.flatnonzero(np.abs(tr.phi - end) >= turn)
    if not k.size:
        return None
    w = np.abs(tr.omega[k[-1] :])  # speeds along the motion (a clockwise crank too)
    t = tr.t[k[-1] :]
    mean = float(np.trapezoid(w, t) / (t[-1] - t[0])) if t[-1] > t[0] else float(np.mean(w))
    return mean, float((np.max(w) - np.min(w)) / mean)
