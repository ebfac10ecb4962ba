"""Flywheel sizing by the energy method (``mechsolve flywheel``).

Over one steady cycle at the mean speed ``omega_m`` (the prescribed-speed analysis of the
file: driving torque ``T(phi)`` with inertia, gravity and every load), the motor supplies a
constant torque, the mean of ``T`` (or its law at ``omega_m``). The machine's kinetic
energy then changes by the cumulative work

    dE(phi) = integral from phi0 to phi of (M - T) dphi

and its largest excursion ``dE_max = max dE - min dE`` (never the net work per cycle,
which is zero for a steady cycle) must be absorbed with a speed fluctuation
``delta = (omega_max - omega_min) / omega_m``:

    J_F = dE_max / (omega_m^2 delta) - J_mean

(``J_mean``: the mean of the mechanism's own reduced inertia, which already smooths the
motion; the students' form ``J_F = 900 dE_max / (pi^2 n^2 delta)`` with n in rpm is the
first term). The estimate treats the machine's inertia as constant; with a motor and a
``simulate:`` section the flywheel is then checked by simulating the machine with it to
steady state, and the fluctuation actually reached is reported.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mechsolve.analyses.dynamics import MAX_STEPS, _with_flywheel, simulate, steady_fluctuation
from mechsolve.analyses.dynamics.cycle import cycle_cause, machine_cycle
from mechsolve.base.errors import InputError
from mechsolve.base.units import (
    _QUANTITY_RE,
    SI_OUTPUT,
    OutputUnits,
    UnitError,
    parse_unit,
    read_number,
)
from mechsolve.core import evaluate as core
from mechsolve.core.sweep import Analysis
from mechsolve.model import GROUND, Mechanism
from mechsolve.model.expr import ExprError, Expression
from mechsolve.model.expr.poles import first_pole
from mechsolve.model.machine import Flywheel
from mechsolve.model.parse import Reader, read_units

__all__ = ["CHECK_TOLERANCE", "FlywheelSizing", "parse_delta", "size_flywheel"]

# The simulation's check of a flywheel passes when the coefficient of fluctuation it
# reaches is within this factor of the one asked (either way): the energy method takes
# the machine's inertia and the motor's torque as constant, which is good to a few per
# cent for a flywheel that dominates the machine's inertia and a motor whose torque varies
# little over the speed's fluctuation; a larger miss means the estimate does not apply.
CHECK_TOLERANCE = 1.25


_DELTA_HINT = "expected a number such as 0.025 or 1/40"


def parse_delta(text: object, where: str = "--delta") -> float:
    """The coefficient of fluctuation from ``0.025`` or ``1/40``: strictly between 0 and 1.

    Raises :class:`~mechsolve.base.errors.InputError` (naming ``where``) for anything else."""
    num, _, den = str(text).strip().partition("/")
    try:  # each number read as the file's are (no full-width digits, no 1_000)
        value = read_number(num) / read_number(den) if den else read_number(num)
    except ZeroDivisionError:
        raise InputError(f"{where} {text!r}: {_DELTA_HINT} (division by zero)") from None
    except UnitError as exc:  # its reason, where it says more than "cannot read"
        why = "" if str(exc).startswith("cannot read") else f" ({exc})"
        raise InputError(f"{where} {text!r}: {_DELTA_HINT}{why}") from None
    if not (math.isfinite(value) and 0 < value < 1):
        raise InputError(
            f"{where} {text!r}: the coefficient of fluctuation (omega_max - omega_min) / "
            "omega_m is between 0 and 1, e.g. 1/40"
        )
    return value


@dataclass
class FlywheelSizing:
    omega_mean: float  # rad/s
    delta: float
    motor_torque: float  # the constant motor torque over the cycle (N m)
    energy_max: float  # dE_max (J)
    J_mean: float  # the mechanism's mean reduced inertia, with the file's flywheel (kg m^2)
    J_flywheel: float  # kg m^2 (0 when the mechanism's own inertia suffices)
    phi: np.ndarray
    energy: np.ndarray  # dE(phi) (J)
    torque: np.ndarray  # T(phi) (N m)
    delta_reached: float | None = None  # by simulation with the flywheel, when checked
    J_exact: float = float("nan")  # the energy-mass (Wittenbauer) method, J varying
    energy_mass: tuple | None = None  # (J(phi), W(phi)) of that method
    source: str = "mechanism"  # or "torque curve" (a table or law given directly)
    notes: list[str] = field(default_factory=list)  # printed under the figures
    check_note: str | None = None  # why the simulation could not check the flywheel
    none_needed: bool = False  # the driving torque does not fluctuate: J_F = 0 exactly
    power: tuple | None = None  # (driving, resisting, cycle, mean power) of a power diagram
    torque_label: str = "driving torque at the mean speed"  # of ``torque``, for the plot
    constant_label: str = "motor (constant)"  # of ``motor_torque``, for the plot
    # the shaft J_F is sized for: the driver's ("O1, link 'pinion'"; '' for a
    # torque curve), and the shafts geared to it at a constant speed ratio: (joint,
    # link, omega_shaft / omega_driver)
    shaft: str = ""
    geared: list[tuple[str, str, float]] = field(default_factory=list)

    def check_missed(self) -> bool:
        """True when the simulation with the flywheel reached a coefficient of fluctuation
        off the one asked by more than :data:`CHECK_TOLERANCE` (a factor either way)."""
        if self.delta_reached is None:
            return False
        ratio = self.delta_reached / self.delta
        return not (1 / CHECK_TOLERANCE <= ratio <= CHECK_TOLERANCE)

    def text(self, units: OutputUnits | None = None) -> str:
        """The sizing as printed: speeds and torques in ``units`` (default SI: rad/s,
        N*m); energies in J and inertias in kg*m^2 as ``units`` gives no key for them."""
        U = units or SI_OUTPUT
        kw, wu = U.convert("rad/s")
        kt, tu = U.convert("N*m")
        if self.power is not None:
            return self._power_text(U)
        n = self.omega_mean * 30 / math.pi
        on = f" on the driver's shaft ({self.shaft})" if self.shaft else ""
        lines = [
            f"flywheel by the energy method{on}: mean speed "
            f"{self.omega_mean * kw:.6g} {wu} ({n:.6g} rpm), delta = {self.delta:.6g}",
            f"  {'resisting' if self.source == 'torque curve' else 'motor'} torque "
            f"(constant over the cycle): {self.motor_torque * kt:.6g} {tu}",
            f"  largest energy excursion dE_max = {self.energy_max:.6g} J (the range of the "
            "cumulative work of the driving torque's excess over the resisting one over the "
            "cycle, never the net work per cycle)",
            f"  required inertia dE_max / (omega_m^2 delta) = "
            f"{self.energy_max / (self.omega_mean**2 * self.delta):.6g} kg*m^2 "
            f"(students' form 900 dE_max / (pi^2 n^2 delta) = "
            f"{900 * self.energy_max / (math.pi**2 * n * n * self.delta):.6g})",
            f"  mean reduced inertia of the mechanism J_mean = {self.J_mean:.6g} kg*m^2",
            f"  flywheel J_F = {self.J_flywheel:.6g} kg*m^2 (on the driver's shaft, "
            f"{self.shaft}, at {n:.6g} rpm)",
        ]
        if self.source == "torque curve":
            lines[-2:] = [
                f"  flywheel J_F = {self.J_flywheel:.6g} kg*m^2 (with the machine's own "
                "inertia, which a torque curve does not give; the mean speed is "
                "(omega_max + omega_min) / 2)"
            ]
        else:
            lines.append(
                f"  energy-mass (Wittenbauer) method with the varying J(phi): J_F = "
                f"{self.J_exact:.6g} kg*m^2"
            )
            lines += self._geared_lines(n)
        if self.none_needed:
            lines = lines[:3] + [
                "  no flywheel is needed: the driving torque does not fluctuate over the "
                "cycle (dE_max = 0 J), so the speed stays constant without one"
            ]
        lines += [f"  note: {n}" for n in self.notes]
        if self.delta_reached is not None:
            lines.append(
                f"  checked by simulation with this flywheel: delta reached "
                f"{self.delta_reached:.4g} (asked {self.delta:.4g}; the estimate takes the "
                "machine's inertia and the motor's torque as constant)"
            )
            if self.check_missed():
                ratio = self.delta_reached / self.delta
                how = (
                    "the flywheel is too small"
                    if ratio > 1
                    else "the flywheel is larger than needed"
                )
                lines.append(
                    f"  WARNING: the simulation misses the asked delta by a factor "
                    f"{max(ratio, 1 / ratio):.3g} (more than the {CHECK_TOLERANCE:g} "
                    f"allowed): {how}; the energy method does not apply to this machine "
                    "(a motor whose torque changes much with the speed, or an inertia "
                    "that varies much over the turn): size it by simulation"
                )
        elif self.check_note:
            lines.append(f"  not checked by simulation: {self.check_note}")
        return "\n".join(lines)

    def _geared_lines(self, n: float) -> list[str]:
        """The same flywheel on each shaft geared to the driver's (``n``: its rpm): its
        kinetic energy is the same at (omega_driver / omega_shaft)^2 times J_F."""
        lines = []
        for joint, link, ratio in self.geared:
            k = 1.0 / (ratio * ratio)
            lines.append(
                f"  the same flywheel on the shaft of {joint} (link '{link}', at "
                f"{n * abs(ratio):.6g} rpm) is J_F x {k:.6g} = {self.J_flywheel * k:.6g} "
                "kg*m^2 (J_F times the square of the driver's speed over that shaft's)"
            )
        return lines

    def _power_text(self, U: OutputUnits = SI_OUTPUT) -> str:
        assert self.power is not None
        driving, resisting, cycle, mean = self.power
        w = self.omega_mean
        n = w * 30 / math.pi
        kw, wu = U.convert("rad/s")
        kt, tu = U.convert("N*m")
        lines = [
            f"flywheel from a power diagram: mean speed {w * kw:.6g} {wu} ({n:.6g} rpm), "
            f"delta = {self.delta:.6g}",
            f"  driving power: {driving.text(cycle)}",
            f"  resisting power: {resisting.text(cycle)}",
            f"  mean power over the cycle {_kw(mean)}; as torques at the mean speed, "
            f"M = P / omega_m: mean {mean / w * kt:.6g} {tu}",
        ]
        if self.none_needed:
            lines.append(
                "  no flywheel is needed: the driving and resisting powers are equal over "
                "the whole cycle (dE_max = 0 J)"
            )
            return "\n".join(lines)
        lines += [
            f"  largest energy excursion dE_max = {self.energy_max:.6g} J (the range of the "
            "cumulative work of the driving power's excess over the resisting one, "
            "integral of (P_d - P_r) / omega_m dphi)",
            f"  flywheel J_F = dE_max / (omega_m^2 delta) = {self.J_flywheel:.6g} kg*m^2 "
            f"(students' form 900 dE_max / (pi^2 n^2 delta) = "
            f"{900 * self.energy_max / (math.pi**2 * n * n * self.delta):.6g}; with the "
            "machine's own inertia, which a power diagram does not give)",
        ]
        return "\n".join(lines)


def size_flywheel(
    mech: Mechanism, delta: float, *, omega_mean: float | None = None, check: bool = True
) -> FlywheelSizing:
    """Size a flywheel on the driver's shaft for the coefficient of fluctuation ``delta``."""
    if not 0 < delta < 1:
        raise InputError(f"--delta {delta!r}: the coefficient of fluctuation is between 0 and 1")

    an = Analysis(_with_flywheel(mech))  # with the file's own flywheel (or rotor), if any
    if an.linear:
        raise InputError("a flywheel turns: the driver must be a revolute joint")
    d = mech.driver.direction
    u0 = an.start_value()
    # the machine's cycle: one turn of a crank, several of a pinion driving a wheel
    turns = machine_cycle(an, velocity=False, acceleration=False).require("a flywheel", mech)
    span = 2 * math.pi * turns
    grid = np.radians(np.arange(0.0, 360.0 * turns + 0.05, 0.1))

    def cycle(w: float):
        x, T, on_grid = _cycle_torque(an, u0 + d * grid, d, w)
        return (x, T, on_grid), _piecewise_mean(T, x, span)

    w, (x, T, on_grid), M = _speed_and_cycle(mech, omega_mean, cycle)
    u = u0 + d * x
    J, dJ = _reduced_inertia(an, u)
    # the mean over the period: the uniform grid's positions without its repeated end
    J_mean = float(np.mean(J[on_grid][:-1]))
    xe, work, Te = _excess_work(x, T, M)
    dE = float(work.max() - work.min())
    # the machine's energy scale: its kinetic energy and the work its largest torque does
    # over a turn; an excursion below 1e-9 of it is rounding: no fluctuation
    scale = J_mean * w * w + float(np.max(np.abs(T))) * 2 * math.pi
    if not dE > 1e-9 * scale:
        if not mech.has_masses and not mech.loads and mech.flywheel is None:
            raise mech.error(
                ("links",),
                "nothing to size: the file gives no masses and no loads, so the driving "
                "torque is zero over the whole cycle; give the links' 'mass' (and "
                "'inertia') and the loads the machine works against",
            )
        out = FlywheelSizing(w, delta, M, 0.0, J_mean, 0.0, u0 + d * xe, work, Te,
                             none_needed=True, shaft=_shaft_text(mech))  # fmt: skip
        out.J_exact = 0.0
        return out
    need = dE / (w * w * delta)
    out = FlywheelSizing(w, delta, M, dE, J_mean, max(0.0, need - J_mean), u0 + d * xe, work, Te)
    out.shaft = _shaft_text(mech)
    out.geared = _geared_shafts(mech, an, u[on_grid])
    if not mech.has_masses and mech.flywheel is None:
        out.notes.append(
            "the file gives no masses: the machine's own inertia is taken as zero and "
            f"J_F is the whole inertia the driver's shaft ({out.shaft}) needs"
        )
    elif out.J_flywheel == 0.0:
        out.notes.append(
            f"the mechanism's own mean inertia ({J_mean:.6g} kg*m^2) exceeds the "
            f"{need:.6g} kg*m^2 required: no flywheel is needed"
        )
    _energy_mass(out, J, 0.5 * d * dJ * w * w - T, x)
    if turns > 1:
        out.notes.append(
            f"the machine's cycle is {turns} turns of the driver ({360 * turns} deg): it "
            f"comes back to its start only then ({cycle_cause(mech)})"
        )
    if check and mech.motor is not None and mech.simulation is not None and out.J_flywheel > 0:
        _check_by_simulation(out, mech, an)
    elif check and mech.motor is not None and mech.simulation is None:
        out.check_note = "the file has no 'simulate:' section"
    return out


def _driver_link(mech: Mechanism) -> str | None:
    """The link the driver turns about the ground (None: a driver between two moving
    links)."""
    moving = [ln for ln in mech.joint(mech.driver.joint).links if ln != GROUND]
    return moving[0] if len(moving) == 1 else None


def _shaft_text(mech: Mechanism) -> str:
    """The shaft a flywheel is sized for, in words: ``O1, link 'pinion'``."""
    link = _driver_link(mech)
    joint = mech.driver.joint
    if link is None:
        a, b = mech.joint(joint).links
        return f"{joint}, between links '{a}' and '{b}'"
    return f"{joint}, link '{link}'"


def _geared_shafts(mech: Mechanism, an: Analysis, u: np.ndarray) -> list[tuple[str, str, float]]:
    """The other links turning about a ground pin at a constant ratio of the driver's
    speed over the cycle (a gear wheel, not a rocker): (joint, link, ratio), the ratio
    omega_link / omega_driver from the velocity analysis at the positions ``u``."""
    driver = _driver_link(mech)
    if driver is None:
        return []
    sol = core.states(an, u, float(mech.driver.direction), 0.0, acceleration=False)
    w = sol.state.w
    w0 = w[an.system.index[driver]]
    out = []
    for j in mech.joints:
        if getattr(j, "kind", "") != "revolute" or GROUND not in j.links:
            continue
        link = next(ln for ln in j.links if ln != GROUND)
        if link == driver:
            continue
        r = w[an.system.index[link]] / w0
        if np.all(np.isfinite(r)) and abs(r[0]) > 1e-9 and np.ptp(r) <= 1e-9 * abs(r[0]):
            out.append((j.name, link, float(np.mean(r))))
    return out


def _speed_and_cycle(mech: Mechanism, omega_mean: float | None, cycle):
    """The mean speed (the one given, else the steady speed with the file's motor, else
    the driver's), and the driving torque along the motion and its mean there (``cycle``
    gives both at a speed)."""
    motor = mech.motor
    if omega_mean is None and motor is not None:
        # the steady speed with the motor: its torque equals the cycle's mean torque, which
        # is affine in the speed (inertia terms average out over a cycle, dampers do not)

        def mismatch(w: float):
            T, M = cycle(w)  # one sweep and force analysis per speed tried
            return float(motor.torque(np.array([w]))[0]) - M, T, M

        w1, w2 = 1.0, 2.0
        m1 = mismatch(w1)[0]
        m2, T, M = mismatch(w2)
        for _ in range(30):  # secant (exact in one step for a linear motor)
            if m2 == m1:
                break
            w1, w2, m1 = w2, w2 - m2 * (w2 - w1) / (m2 - m1), m2
            m2, T, M = mismatch(w2)
            if abs(m2) < 1e-12 * (1 + abs(M)):
                break
        w = abs(w2)
        if not w > 0:
            raise InputError("the steady speed with this motor is zero: check its law")
        if w != w2:  # reached turning the other way: solve the cycle there
            T, M = cycle(w)
    else:
        w = abs(omega_mean if omega_mean is not None else mech.driver.speed)
        if not w > 0:
            raise InputError("the mean speed is zero: give the driver's speed or --speed")
        T, M = cycle(w)
    return w, T, M


def _energy_mass(out: FlywheelSizing, J: np.ndarray, Q: np.ndarray, x: np.ndarray) -> None:
    """The energy-mass (Wittenbauer) method, exact for a varying J: the kinetic energy is
    T0 + W(phi), W the work of the motor and the external loads ``Q`` (the driving torque
    at constant speed less its inertia part 1/2 J' omega^2); with a flywheel J_F the speed
    omega^2 = 2 (T0 + W) / (J + J_F) must stay between omega_min and omega_max."""
    w, delta = out.omega_mean, out.delta
    W = _hermite_work(out.motor_torque + Q, x)[0]
    wmax2, wmin2 = (w * (1 + delta / 2)) ** 2, (w * (1 - delta / 2)) ** 2
    jf = (np.max(0.5 * wmin2 * J - W) - np.min(0.5 * wmax2 * J - W)) / (0.5 * (wmax2 - wmin2))
    out.J_exact = max(0.0, float(jf))
    out.energy_mass = (J, W)


def _check_by_simulation(out: FlywheelSizing, mech: Mechanism, an: Analysis) -> None:
    """Simulate the machine with the flywheel added, from the mean speed to steady state,
    and record the fluctuation it reaches (or why the check fell short)."""

    w = out.omega_mean
    # J_F on the driver's shaft, for which it is sized; the file's own flywheel stays on
    # its link (another shaft maybe, at another speed)
    shaft = _driver_link(mech) or an.system.body_names[an.plan[0].bodies[0]]
    machine = copy.copy(_with_flywheel(mech))
    machine.flywheel = Flywheel(shaft, out.J_flywheel)
    # to steady state: many time constants J / (-dM/domega) of the machine
    lo, hi = mech.motor.torque(np.array([w - 1e-3, w + 1e-3]))
    slope = float(lo - hi) / 2e-3  # -dM/domega along the motion
    tau = (out.J_mean + out.J_flywheel) / slope if slope > 0 else 0.0
    sim = copy.copy(mech.simulation)
    sim.duration = min(max(sim.duration, 10 * tau), 120.0)
    # within the integrator's step budget (simulate refuses more, naming the file's
    # simulate.step, which the file did not ask for here)
    if sim.step and sim.duration / sim.step > MAX_STEPS - 1:
        sim.duration = (MAX_STEPS - 1) * sim.step
        short = f"the check ran {sim.duration:.4g} s ({MAX_STEPS - 1} steps of the file's step)"
    else:
        short = ""
    # from the steady mean speed, so that only the periodic part has to settle
    sim.speed0 = w
    sim.revolutions = None
    sim.steady = None
    sim.formulation = "reduced"  # its revolutions and fluctuation: the reduced path's
    machine.simulation = sim
    res = simulate(machine)
    # the machine's cycle, in revolutions (several for a pinion driving a wheel)
    turns = getattr(getattr(res, "model", None), "turns", None) or 1
    fl = steady_fluctuation(res.trajectory, turns)
    if fl is None:
        what = "a revolution" if turns == 1 else f"a cycle ({turns} revolutions)"
        out.check_note = f"the simulation ({sim.duration:.4g} s) did not complete {what}"
    else:
        out.delta_reached = fl[1]
        if short and 10 * tau > sim.duration:
            out.check_note = f"{short}, less than 10 time constants J/(-dM/domega)"


def _cycle_torque(an: Analysis, u: np.ndarray, d: int, w: float):
    """``(x, T, on_grid)``: the driving torque along the motion at the speed ``w`` over the
    driver values ``u`` (travel ``x`` from the first), with each angle where a conditional
    load switches added on both sides of it (1e-9 rad apart, located to rounding as the
    run's summary locates them) and each join of a cam program, so that the torque's
    jumps fall between samples;
    ``on_grid`` marks the samples of ``u``."""
    from mechsolve.core.loads import switch_points

    sol = core.states(an, u, d * w, 0.0)
    if not sol.ok.all():
        raise InputError("the mechanism does not turn fully: a flywheel needs a full cycle")
    f = core.forces(an, sol)
    jumps = switch_points(an, sol, f)
    if any(r.constraint.law_breaks(sol.state) is not None for r in an.system.rows):
        from mechsolve.core.breaks import break_points

        jumps += break_points(an, sol)  # a cam program's joins: the torque jumps there too
    extra = [s + h for s in jumps for h in (-1e-9, 1e-9)]
    lo, hi = (u[0], u[-1]) if d > 0 else (u[-1], u[0])
    extra = [v for v in extra if lo < v < hi]
    on_grid = np.ones(len(u), bool)
    if extra:
        uu = np.concatenate([u, extra])
        order = np.argsort(d * (uu - u[0]), kind="stable")
        uu = uu[order]
        on_grid = np.r_[on_grid, np.zeros(len(extra), bool)][order]
        sol = core.states(an, uu, d * w, 0.0)
        if not sol.ok.all():
            raise InputError("the mechanism does not turn fully: a flywheel needs a full cycle")
        f = core.forces(an, sol, f.stroke_extremes)
        u = uu
    return d * (u - u[0]), d * f.effort, on_grid  # the torque along the motion


def _piecewise_mean(T: np.ndarray, x: np.ndarray, span: float) -> float:
    """The mean of ``T`` over the cycle ``span``, integrated piecewise between the angles
    where it jumps (:func:`_hermite_work`)."""
    return float(_hermite_work(T, x)[0][-1] / span)


# an interval this short (rad) holds a jump of the torque: the two samples either side of
# a switch angle (:func:`_cycle_torque`)
_JUMP = 1e-6


def _slopes(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    """df/dx at the samples, second order, on each smooth piece between the jumps (zero
    on a piece too short for it)."""
    df = np.zeros_like(f)
    cuts = np.flatnonzero(np.diff(x) < _JUMP) + 1
    for lo, hi in zip(np.r_[0, cuts], np.r_[cuts, len(x)]):
        if hi - lo >= 3:
            df[lo:hi] = np.gradient(f[lo:hi], x[lo:hi], edge_order=2)
    return df


def _hermite_work(f: np.ndarray, x: np.ndarray):
    """``(W, df)``: the running integral of ``f`` over ``x`` from 0 by the cubic Hermite
    interpolant through the samples and their slopes (:func:`_slopes`) on each smooth
    piece, h (f0 + f1) / 2 + h^2 (f0' - f1') / 12 an interval (error O(h^5), the
    trapezoid's O(h^3)); across a jump, the trapezoid over its 2e-9 rad."""
    df = _slopes(f, x)
    h = np.diff(x)
    inc = 0.5 * h * (f[:-1] + f[1:]) + h * h / 12 * (df[:-1] - df[1:])
    return np.r_[0.0, np.cumsum(inc)], df


def _excess_work(x: np.ndarray, T: np.ndarray, M: float):
    """``(x', W, T')``: the running integral W of the excess ``M - T`` over ``x``
    (:func:`_hermite_work`), with the points where the excess changes sign inside an
    interval added (where W has its extremes; T' is M there): the root of the interval's
    Hermite cubic, and W there its integral up to it."""
    e = M - T
    W, de = _hermite_work(e, x)
    k = np.flatnonzero(e[:-1] * e[1:] < 0)
    h = x[k + 1] - x[k]
    e0, e1, m0, m1 = e[k], e[k + 1], h * de[k], h * de[k + 1]
    s = e0 / (e0 - e1)  # the chord's root, then Newton on the cubic (monotone there)
    for _ in range(8):
        s2, s3 = s * s, s * s * s
        p = (2 * s3 - 3 * s2 + 1) * e0 + (s3 - 2 * s2 + s) * m0 + (3 * s2 - 2 * s3) * e1
        p += (s3 - s2) * m1
        dp = (6 * s2 - 6 * s) * (e0 - e1) + (3 * s2 - 4 * s + 1) * m0 + (3 * s2 - 2 * s) * m1
        s = np.clip(s - p / np.where(dp != 0, dp, 1.0), 0.0, 1.0)
    s2, s3, s4 = s * s, s * s * s, s**4
    Wc = W[k] + h * (
        (s4 / 2 - s3 + s) * e0
        + (s4 / 4 - 2 * s3 / 3 + s2 / 2) * m0
        + (s3 - s4 / 2) * e1
        + (s4 / 4 - s3 / 3) * m1
    )
    order = np.argsort(np.r_[x, x[k] + s * h], kind="stable")
    return np.r_[x, x[k] + s * h][order], np.r_[W, Wc][order], np.r_[T, np.full(len(k), M)][order]


def _cumulative(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The running integral of ``f`` over ``x`` (trapezoid rule), from 0."""
    return np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(x))])


def _reduced_inertia(an: Analysis, u: np.ndarray):
    """J(phi) and dJ/dphi (per unit of the driver coordinate) from the force analysis:
    J is the effort per unit driver acceleration, J' twice dT/dt at unit speed."""
    n = len(u)
    sol = core.states(
        an,
        np.r_[u, u, u],
        np.r_[np.zeros(2 * n), np.ones(n)],
        np.r_[np.zeros(n), np.ones(n), np.zeros(n)],
    )
    f = core.forces(an, sol)
    e = f.effort
    return e[n : 2 * n] - e[:n], 2.0 * f.kinetic_rate[2 * n :]


def size_from_torque(
    angles: np.ndarray,
    torque: np.ndarray,
    *,
    speed: float,
    delta: float,
    resisting: float | None = None,
) -> FlywheelSizing:
    """A flywheel from a torque curve over one cycle, as textbook problems state it.

    Parameters
    ----------
    angles, torque
        The driving torque (N m) over one cycle of the shaft (rad, increasing, the cycle
        from the first angle to the last: 2 pi, or an engine's 4 pi); integrated exactly
        as the piecewise-linear curve through the points.
    speed
        The mean speed omega_m = (omega_max + omega_min) / 2 (rad/s), the arithmetic mean
        the texts use (to first order in delta the time mean too).
    resisting
        The constant resisting torque; its mean over the cycle when None (a steady cycle).
    """
    x = np.asarray(angles, float)
    T = np.asarray(torque, float)
    if x.ndim != 1 or len(x) < 2 or np.any(np.diff(x) <= 0):
        raise InputError("the torque table's angles must increase")
    if not 0 < delta < 1:
        raise InputError(f"delta {delta!r}: the coefficient of fluctuation is between 0 and 1")
    span = x[-1] - x[0]
    mean = float(np.trapezoid(T, x) / span)
    Mr = mean if resisting is None else float(resisting)
    # the running integral of the excess, exact for the piecewise-linear curve: its
    # extremes lie where the excess changes sign, inside a segment too, so those points
    # are added first
    e = T - Mr
    k = np.flatnonzero(e[:-1] * e[1:] < 0)
    xc = x[k] - e[k] * (x[k + 1] - x[k]) / (e[k + 1] - e[k])
    order = np.argsort(np.r_[x, xc], kind="stable")
    x = np.r_[x, xc][order]
    T = np.r_[T, np.full(len(xc), Mr)][order]
    work = _cumulative(T - Mr, x)  # the driving torque's excess over the resisting one
    dE = float(work.max() - work.min())
    w = abs(float(speed))
    need = dE / (w * w * delta)
    out = FlywheelSizing(w, delta, Mr, dE, 0.0, need, x, work, T)
    out.J_exact = need
    out.energy_mass = None
    out.source = "torque curve"
    out.torque_label = "driving torque"
    out.constant_label = "resisting torque (constant)"
    return out


# --- a flywheel from a power diagram ------------------------------------------------

POWER_KEYS = ("name", "description", "units", "power", "speed", "delta")
POWER_SIDE_KEYS = ("steps", "table", "law")
_POWER_DIM = (2, 1, -3, 0)


def is_power_problem(data: object) -> bool:
    """A file that states a flywheel problem by its power diagram (no links)."""
    return isinstance(data, dict) and "power" in data and "links" not in data


@dataclass
class PowerCurve:
    """One side of a power diagram over a cycle of ``span`` (rad from 0): a constant
    (``value``), the other side's mean (``mean``), or a curve: piecewise constant
    (``steps``: each value holds from its angle to the next, the last to the cycle's end)
    or piecewise linear through ``x``, ``y`` (a table, or a law sampled finely)."""

    kind: str  # "constant", "mean", "steps", "linear"
    value: float = 0.0  # W (constant)
    x: np.ndarray | None = None  # rad
    y: np.ndarray | None = None  # W

    def breaks(self) -> np.ndarray:
        return np.empty(0) if self.x is None else self.x

    def on(self, lo: np.ndarray, hi: np.ndarray, mean: float) -> tuple[np.ndarray, np.ndarray]:
        """Its values at the ends of intervals [lo, hi] holding no break inside: (just
        after lo, just before hi), in W."""
        if self.kind == "constant":
            return np.full(lo.shape, self.value), np.full(lo.shape, self.value)
        if self.kind == "mean":
            return np.full(lo.shape, mean), np.full(lo.shape, mean)
        assert self.x is not None and self.y is not None
        if self.kind == "steps":
            k = np.searchsorted(self.x, 0.5 * (lo + hi), side="right") - 1
            v = self.y[np.clip(k, 0, len(self.y) - 1)]
            return v, v
        return np.interp(lo, self.x, self.y), np.interp(hi, self.x, self.y)

    def mean(self, span: float) -> float | None:
        """The mean power over the cycle (W); None for 'mean'."""
        if self.kind == "constant":
            return self.value
        if self.kind == "mean":
            return None
        assert self.x is not None and self.y is not None
        if self.kind == "steps":
            ends = np.r_[self.x[1:], span]
            return float(np.sum(self.y * (ends - self.x)) / span)
        return float(np.trapezoid(self.y, self.x) / span)

    def text(self, span: float) -> str:
        if self.kind == "constant":
            return f"constant {_kw(self.value)}"
        if self.kind == "mean":
            return "constant, the other side's mean (a steady cycle)"
        assert self.x is not None and self.y is not None
        if self.kind == "steps":
            ends = np.r_[self.x[1:], span]
            return ", ".join(
                f"{_kw(p)} from {math.degrees(a):g} to {math.degrees(b):g} deg"
                for a, b, p in zip(self.x, ends, self.y)
            )
        return (
            f"piecewise linear through {len(self.x)} points, from {_kw(self.y.min())} to "
            f"{_kw(self.y.max())}"
        )


def _kw(p: float) -> str:
    return f"{p / 1e3:.6g} kW"


def _power(r, value: object, path: tuple) -> float:
    """A power in W from a number (W) or '3.5 kW', 'ft*lbf/s' ...; a located error."""

    if isinstance(value, bool) or value is None or not isinstance(value, (int, float, str)):
        raise r.fail(path, f"expected a power such as '3.5 kW', got {value!r}")
    if isinstance(value, str):
        m = _QUANTITY_RE.match(value)
        if not m:
            raise r.fail(path, f"cannot read {value!r} as a power: write e.g. '3.5 kW'")
        try:
            unit = parse_unit(m.group(2)) if m.group(2) else None
            if unit is not None and unit.dim != _POWER_DIM:
                unit = parse_unit(m.group(2), pound="lbf")
        except UnitError as exc:
            raise r.fail(path, str(exc)) from None
        if unit is not None and unit.dim != _POWER_DIM:
            raise r.fail(path, f"{value!r} is not a power (W, kW, ft*lbf/s ...)")
        x = float(m.group(1)) * (unit.factor if unit is not None else 1.0)
    else:
        x = float(value)
    if not math.isfinite(x):
        raise r.fail(path, f"{value!r} is not a finite number")
    return x


def read_power_problem(src) -> dict:
    """A flywheel problem stated by its power diagram, as course books pose the shaper::

        name: shaper, power diagram
        power:
          resisting: {steps: [[0 deg, 3.5 kW], [220 deg, 0.5 kW]]}  # working, then idle
          driving: mean          # a motor of constant power (the steady cycle's mean)
          cycle: 360 deg         # optional
        speed: 60 rpm            # the mean speed omega_m
        delta: 1/40              # optional: --delta on the command line wins

    Each side is ``mean`` (at most one), a constant power, or a curve: ``steps`` (each
    power holds from its angle to the next, the last to the end of the cycle), ``table``
    ([angle, power] points, piecewise linear, closed with its first point) or ``law`` (an
    expression of ``angle`` in rad, giving W)."""

    r = Reader(src)
    data = src.data
    m = r.mapping(data, (), POWER_KEYS, "a power-diagram problem", ("power", "speed"))
    if "units" in data:
        read_units(r, data["units"])
    p = r.mapping(m["power"], ("power",), ("resisting", "driving", "cycle"), "'power'",
                  ("resisting", "driving"))  # fmt: skip
    span = r.positive(p.get("cycle", "360 deg"), ("power", "cycle"), "angle")
    sides = {side: _power_side(r, p[side], side, span) for side in ("driving", "resisting")}
    if sides["driving"].kind == "mean" and sides["resisting"].kind == "mean":
        raise r.fail(("power",), "only one side can be 'mean': give the other's power")
    delta = None
    if "delta" in m:
        try:
            delta = parse_delta(m["delta"], "delta")
        except InputError as exc:
            raise r.fail(("delta",), exc.message) from None
    return {
        "name": m.get("name", Path(src.file).stem if src.file else "power diagram"),
        "driving": sides["driving"],
        "resisting": sides["resisting"],
        "cycle": span,
        "speed": r.positive(m["speed"], ("speed",), "angular speed"),
        "delta": delta,
        "reader": r,
    }


def _power_side(r, v, side: str, span: float) -> PowerCurve:
    """One side of the power diagram (``power.<side>``): mean, a constant, or a curve
    (steps, table or law) over the cycle ``span``."""
    path = ("power", side)
    if v == "mean":
        return PowerCurve("mean")
    if not isinstance(v, dict):
        return PowerCurve("constant", _power(r, v, path))
    c = r.mapping(v, path, POWER_SIDE_KEYS, f"'power.{side}'")
    if len(c) != 1:
        raise r.fail(path, "give the power as one of: steps, table, law (or mean, or a "
                     "constant such as 2 kW)")  # fmt: skip
    kind = next(iter(c))
    if kind == "law":
        return _power_law(r, c["law"], path + ("law",), span)
    return _power_points(r, c[kind], kind, path + (kind,), span)


def _power_law(r, law, q: tuple, span: float) -> PowerCurve:
    """A power given as an expression of ``angle`` (rad), in W, sampled at 36001 points
    of the cycle."""

    if not isinstance(law, str):
        raise r.fail(q, "'law' is an expression of angle (rad), in W")
    try:
        e = Expression(law, variables=("angle",))
        x = np.linspace(0.0, span, 36001)
        y = np.broadcast_to(np.asarray(e.evaluate_at({"angle": x}), float), x.shape)
    except ExprError as exc:
        raise r.fail(q, str(exc)) from None
    if not np.all(np.isfinite(y)):
        raise r.fail(q, "the law is not finite over the cycle")
    pole = first_pole(e, "angle", x)
    if pole is not None:  # finite samples on both sides of a pole
        raise r.fail(q, f"the law grows without bound at angle = {pole:.6g} rad")
    return PowerCurve("linear", x=x, y=np.array(y, float))


def _power_points(r, rows, kind: str, q: tuple, span: float) -> PowerCurve:
    """A power given by [angle, power] points: ``steps`` (each holds to the next, the last
    round the cycle) or ``table`` (piecewise linear, closed with its first point)."""
    least = 1 if kind == "steps" else 2
    if not isinstance(rows, list) or len(rows) < least:
        raise r.fail(q, f"'{kind}' lists at least {least} point(s) [angle, power]")
    xs, ys = [], []
    for k, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != 2:
            raise r.fail(q + (k,), "a point is [angle, power]")
        xs.append(r.quantity(row[0], q + (k, 0), "angle"))
        ys.append(_power(r, row[1], q + (k, 1)))
    x, y = np.array(xs), np.array(ys)
    if np.any(np.diff(x) <= 0):
        raise r.fail(q, "the angles must increase")
    if x[0] < 0 or x[-1] > span * (1 + 1e-12) or (kind == "steps" and x[-1] >= span):
        raise r.fail(q, f"the angles must lie in the cycle, 0 to {math.degrees(span):g} deg")
    if kind == "steps":
        if x[0] > 0:  # before the first angle: the last power, round the cycle
            x, y = np.r_[0.0, x], np.r_[y[-1], y]
        return PowerCurve("steps", x=x, y=y)
    # periodic: closed round the cycle from the last point to the first
    xe, ye = np.r_[x[-1] - span, x, x[0] + span], np.r_[y[-1], y, y[0]]
    x = np.unique(np.r_[0.0, x, span])
    return PowerCurve("linear", x=x, y=np.interp(x, xe, ye))


def size_from_power(
    driving: PowerCurve,
    resisting: PowerCurve,
    *,
    cycle: float,
    speed: float,
    delta: float,
    steady_tolerance: float = 1e-3,
) -> FlywheelSizing:
    """A flywheel from a power diagram over one cycle of the shaft.

    At the mean speed ``omega_m`` a power P is the torque M = P / omega_m, so the
    energy excursion is dE(phi) = integral from 0 to phi of (P_d - P_r) / omega_m dphi
    (equally the integral of P_d - P_r over time at that speed), and
    J_F = dE_max / (omega_m^2 delta) as for a torque curve. The integral is exact: the
    excess is linear between the breaks of both curves, and its running integral's
    extremes where the excess changes sign inside an interval are included.

    Raises InputError when the two sides' means differ by more than
    ``steady_tolerance`` (relative): the cycle would not be steady.
    """
    if not 0 < delta < 1:
        raise InputError(f"delta {delta!r}: the coefficient of fluctuation is between 0 and 1")
    w = abs(float(speed))
    md, mr = driving.mean(cycle), resisting.mean(cycle)
    if md is None:
        md = mr
    if mr is None:
        mr = md
    assert md is not None and mr is not None
    if abs(md - mr) > steady_tolerance * max(abs(md), abs(mr)):
        raise InputError(
            f"the driving power's mean over the cycle ({_kw(md)}) is not the resisting "
            f"power's ({_kw(mr)}): the machine would speed up or slow down every cycle; "
            "give one side as 'mean' (a motor of constant power) or make them agree"
        )
    grid = np.unique(np.r_[0.0, cycle, driving.breaks(), resisting.breaks()])
    grid = grid[(grid >= 0) & (grid <= cycle)]
    lo, hi = grid[:-1], grid[1:]
    d0, d1 = driving.on(lo, hi, md)
    r0, r1 = resisting.on(lo, hi, mr)
    e0, e1 = (d0 - r0) / w, (d1 - r1) / w  # the excess torque (N m) at the ends
    # points: each interval's start and end values (jumps at the breaks), and the
    # zero crossings inside; the running integral is exact for a linear excess
    xs, work = [0.0], [0.0]
    torque = [(r0[0] if driving.kind in ("mean", "constant") else d0[0]) / w]
    acc = 0.0
    var_is_driving = driving.kind not in ("mean", "constant")
    for k in range(len(lo)):
        a, b, ea, eb = lo[k], hi[k], e0[k], e1[k]
        if ea * eb < 0:  # the extreme of the running integral lies inside
            c = a + ea * (b - a) / (ea - eb)
            acc_c = acc + 0.5 * ea * (c - a)
            xs.append(c)
            work.append(acc_c)
            torque.append(((d0[k] + (d1[k] - d0[k]) * (c - a) / (b - a)) if var_is_driving
                           else (r0[k] + (r1[k] - r0[k]) * (c - a) / (b - a))) / w)  # fmt: skip
        acc += 0.5 * (ea + eb) * (b - a)
        xs.append(b)
        work.append(acc)
        torque.append((d1[k] if var_is_driving else r1[k]) / w)
    work_a = np.array(work)
    dE = float(work_a.max() - work_a.min())
    need = dE / (w * w * delta)
    const = (mr if var_is_driving else md) / w
    out = FlywheelSizing(w, delta, const, dE, 0.0, need, np.array(xs), work_a, np.array(torque))
    out.J_exact = need
    out.source = "power diagram"
    out.power = (driving, resisting, cycle, md)
    if var_is_driving:
        out.torque_label = "driving torque P_d / omega_m"
        out.constant_label = "resisting torque P_r / omega_m (its mean, if it varies)"
    else:
        out.torque_label = "resisting torque P_r / omega_m"
        out.constant_label = "motor torque P_d / omega_m (constant)"
    if dE == 0.0:
        out.none_needed = True
    return out
