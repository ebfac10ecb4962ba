"""``mechsolve simulate`` on the general path: a file's mechanism integrated in body
coordinates (:mod:`.multibody`), its initial conditions, its results and summary.

The start: the pose the file assembles at the driver's start (with its branch, as every
command does), at rest or with the driver coordinate's rate ``simulate.from``. Rates of
other joint coordinates (``simulate.rates``) are checked against the constraints: the
rates nearest to all that are given (least squares over the constraint's solutions) are
used; values changed by more than 1e-6 of their size (or 1e-9 in absolute terms) are an
input error that names the key and gives the consistent values.
"""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np

from mechsolve.analyses.dynamics.contact_loss import multibody_cut
from mechsolve.analyses.dynamics.cycle import machine_cycle
from mechsolve.analyses.dynamics.integrators import _with_flywheel, energy_check, motor_end
from mechsolve.analyses.dynamics.model import drive_torque
from mechsolve.analyses.dynamics.multibody import (
    Multibody,
    Source,
    Trajectory,
    coordinate,
    trajectory_state,
)
from mechsolve.analyses.dynamics.multibody_events import stop_condition
from mechsolve.analyses.dynamics.multibody_integrate import integrate
from mechsolve.base.units import SI_OUTPUT, OutputUnits
from mechsolve.core import evaluate as core
from mechsolve.core.sweep import Analysis
from mechsolve.model import Mechanism
from mechsolve.model.expr.poles import first_pole_along
from mechsolve.results.results import Column, Results


def uses_multibody(mech: Mechanism) -> bool:
    """Whether ``simulate`` takes the general path: asked for, or no motor (free motion)."""
    sim = mech.simulation
    if sim is None:
        return False
    events = sim.stop is not None or sim.singular != "pass"
    general = mech.motor is None or bool(mech.motors) or bool(sim.pose) or bool(sim.rates) or events
    if sim.formulation == "reduced" and general and mech.motor is not None:
        what = (
            "motors:"
            if mech.motors
            else "simulate.pose"
            if sim.pose
            else "simulate.rates"
            if sim.rates
            else "'stop when'"
            if sim.stop is not None
            else "'singular'"
        )
        raise mech.error(
            ("simulate", "formulation"),
            f"the reduced formulation integrates the driver's one equation under its one "
            f"motor: {what} needs formulation: multibody",
        )
    if sim.formulation is not None:
        return sim.formulation == "multibody"
    return general


def simulate_multibody(mech: Mechanism, *, max_steps: int | None = None) -> MultibodyResults:
    """Integrate the file's mechanism in body coordinates (see :mod:`.multibody`)."""
    sim = mech.simulation
    if sim is None:
        raise mech.error(("simulate",), "a simulation needs a 'simulate' section (duration, step)")
    machine = _with_flywheel(mech)
    if sim.pose or machine.driver is None:
        from mechsolve.analyses.dynamics.multibody_free import simulate_free

        return simulate_free(mech, machine, max_steps=max_steps)
    if machine.driver is None:
        raise mech.error(
            ("driver",),
            "the multibody simulation starts from the pose assembled at the driver's start: "
            "add a 'driver' section (joint and start; with no motor it only places the "
            "mechanism)",
        )
    if machine.driver.motion is not None:
        machine = copy.copy(machine)
        machine.driver = dataclasses.replace(machine.driver, motion=None)
    an = Analysis(machine)
    u0 = an.start_value()
    # 'from' is a speed along the driver's direction, as on the reduced path
    w0 = machine.driver.direction * abs(sim.speed0)
    start = core.states(an, np.array([u0]), np.array([w0]), np.array([0.0]))
    if not start.ok[0]:
        raise mech.error(("driver", "start"), "the mechanism cannot close at the driver's start")
    st = start.state
    q0 = st.q()[0]
    qd0 = np.stack([st.vx[:-1, 0], st.vy[:-1, 0], st.w[:-1, 0]], axis=1).ravel()
    from mechsolve.analyses.dynamics.multibody_free import initial_rates, refuse_singular_start

    d = machine.driver
    drv, sources = _sources(mech, machine, an)
    mb = Multibody(an, sources, tolerance=sim.tolerance)
    refuse_singular_start(mech, mb, q0, ("driver", "start"), f"{an.format_u(u0)}")
    if any(ld.when is not None and ld.when.uses("stroke") for ld in machine.loads):
        # stroke(q) means the extremes over the driver's sweep (the machine's cycle: a
        # turn of a crank, several of a pinion driving a wheel), as for the reduced path:
        # found once, replayed at every state of the motion
        if an.linear:
            u, _ = an.sweep_values(u0)
            ref = core.states(an, u, 1.0, 0.0)
        else:
            cyc = machine_cycle(an)
            if cyc.turns == 0:
                cyc.require("stroke(q) in a load condition (its extremes over the cycle)", mech)
            ref = cyc.sweep
        mb.extremes = list(core.forces(an, ref).stroke_extremes)
    if sim.rates:
        qd0 = initial_rates(mech, mb, q0, qd0, d)
    tr = integrate(
        mb,
        q0,
        qd0,
        sim.duration,
        step=sim.step,
        method=sim.method if sim.method != "rk4" or sim.step else "DOP853",
        rtol=sim.rtol,
        atol=sim.atol,
        max_steps=max_steps,
        stop=stop_condition(an, mb, sim.stop) if sim.stop is not None else None,
        singular=sim.singular,
        branch=branches(an, mb) if sim.singular == "keep branch" else None,
    )
    tr, sol, forces = _motion_and_forces(mech, an, start, mb, drv, tr)
    return MultibodyResults(an, sol, forces, tr, mb, drv)


def _sources(mech: Mechanism, machine: Mechanism, an: Analysis):
    """The driver's coordinate and the motors acting: the driver's ``motor:`` on it and
    every ``motors:`` entry on its joint."""
    from mechsolve.analyses.dynamics.multibody_free import motor_sources

    d = machine.driver
    free = Multibody(an)
    drv = coordinate(machine, free.system, d.joint, d.line)
    sources = []
    if mech.motor is not None:
        motor, sense = mech.motor, d.direction
        sources.append(
            Source(
                "motor",
                drv,
                lambda w, t: float(drive_torque(motor, sense, w, t)),
                f"{motor.describe(an.linear)} on {d.joint}",
            )
        )
    return drv, sources + motor_sources(machine, free.system)


def _motion_and_forces(mech: Mechanism, an: Analysis, start, mb: Multibody, drv, tr):
    """The trajectory, its :class:`Solution` and forces; the trajectory cut where the
    motor law's pole is passed, and at the first loss of contact of a force-closed cam
    (which cannot pull its follower: the motion past it is not the machine's)."""
    tr, sol = _solved_motion(mech, an, start, mb, drv, tr)
    forces = core.forces(an, sol, mb.extremes if mb.extremes else None)
    cut = multibody_cut(mech, an, tr, forces, (*_ALONG, "velocity_violation", "u", "ud", "udd"))
    if cut is not None:
        sol = _solution(an, start, mb, drv, cut)
        return cut, sol, core.forces(an, sol, mb.extremes if mb.extremes else None)
    return tr, sol, forces


def _solved_motion(mech: Mechanism, an: Analysis, start, mb: Multibody, drv, tr: Trajectory):
    """The trajectory and its :class:`Solution`; cut at the motor law's pole where the
    motion passed one (kept up to there, as the reduced path keeps it)."""
    from mechsolve.analyses.dynamics.multibody_free import motors_pole_cut

    sol = _solution(an, start, mb, drv, tr)
    cut = _motor_pole_cut(mech, an, tr)
    cut = motors_pole_cut(mech, mb, cut or tr) or cut  # the earlier pole of any motor
    if cut is None:
        return tr, sol
    return cut, _solution(an, start, mb, drv, cut)


# the trajectory's rows, one per output time
_ALONG = ("t", "q", "qd", "qdd", "lam", "kinetic", "potential", "work", "violation")


def _motor_pole_cut(mech: Mechanism, an: Analysis, tr: Trajectory) -> Trajectory | None:
    """The trajectory up to the output before the motor law's pole, where the motion
    passed one between two outputs (the law finite at both: the integrator stepped
    through infinity, and the motion after it is not the law's), with the file's error;
    None where the law stays finite along the motion."""
    motor = mech.motor
    if motor is None or motor.kind != "law" or len(tr.t) < 2 or tr.ud is None:
        return None
    w = mech.driver.direction * tr.ud  # the law is written along the driver's direction
    hit = first_pole_along(motor.expr, {"omega": w, "v": w, "t": tr.t})
    if hit is None:
        return None
    k, at = hit
    end = motor_end(mech, an.linear, at["omega"], at["t"], math.inf, pole=True)
    rows = {f: getattr(tr, f)[: k + 1] for f in (*_ALONG, "velocity_violation")}
    return dataclasses.replace(
        tr, **rows, stopped=end.reason, early=True, event="", error=end.error
    )


def branches(an: Analysis, mb: Multibody):
    """The branch (+1 or -1) of every loop with two assembly modes at a configuration:
    the mode whose closed-form position reproduces the configuration's poses."""
    from mechsolve.base.state import State
    from mechsolve.groups import Drive

    two = [g for g in an.plan if g.n_modes == 2]
    unit = Drive(np.zeros(1), np.ones(1), np.zeros(1))

    def signs(q: np.ndarray) -> tuple:
        out = []
        for g in two:
            errs = []
            for mode in (1.0, -1.0):
                st = mb.state(q)
                st.token = State.new_token()
                g.position(st, unit, mode)
                errs.append(
                    sum(
                        abs(st.x[b, 0] - q[3 * b])
                        + abs(st.y[b, 0] - q[3 * b + 1])
                        + abs(np.angle(np.exp(1j * (st.th[b, 0] - q[3 * b + 2]))))
                        for b in g.bodies
                    )
                )
            out.append(1 if errs[0] <= errs[1] else -1)
        return tuple(out)

    return signs


def _solution(an: Analysis, start, mb: Multibody, drv, tr: Trajectory):
    """The trajectory as a :class:`Solution` of the analysis (for its columns and the
    force analysis), with the driver coordinate, its rate and acceleration."""
    n = len(tr.t)
    st = trajectory_state(mb, tr)
    u = drv.value(st)
    rows = np.zeros((n, mb.nq))
    for body, blk in drv.jacobian(st).items():
        rows[:, 3 * body : 3 * body + 3] = blk[0].T
    ud = np.einsum("ij,ij->i", rows, tr.qd)
    # c_q q'' = u'' + g(q, q'), g from the coordinate's gamma at u'' = 0
    udd = np.einsum("ij,ij->i", rows, tr.qdd) - drv.gamma(st, 0.0)[0]
    tr.u, tr.ud, tr.udd = u, ud, udd
    return dataclasses.replace(
        start,
        u=u,
        t=tr.t,
        state=st,
        ok=np.ones(n, bool),
        failures=[],
        indicator=np.ones((len(an.plan), n)),
        iterations=np.zeros(n, int),
        methods=None,
        residual_=tr.violation,
        warnings=[],
        events=[],
        flips=start.flips,  # the start's branches, for positions solved again
        rates_by_limit=[],
        rates_undetermined=[],
        ud=ud,
        udd=udd,
    )


class MultibodyResults(Results):
    """Results along a motion integrated in body coordinates: the sweep's columns, with
    the driver coordinate's rates, the motor, the energy balance and the constraint
    violation."""

    def __init__(self, an, sol, forces, traj: Trajectory, mb: Multibody, drv) -> None:
        super().__init__(an, sol, forces)
        self.trajectory = traj
        self.multibody = mb
        self.coordinate = drv
        self.model = None

    def _work_why(self) -> tuple[float, str]:
        """The driver's work: zero where nothing drives the driver's joint (free motion,
        or motors on other joints: the driver only places the mechanism, and its effort
        is zero but for rounding), else by the energy method as for a sweep."""
        if not hasattr(self, "_work"):
            self._work = (0.0, "") if self.idle_driver() else super()._work_why()
        return self._work

    def idle_driver(self) -> str:
        """Why the driver's joint has no effort: no motor acts there (free motion, or
        motors on other joints); ``""`` when one does."""
        mech = self.mechanism
        joint = mech.driver.joint
        if mech.motor is not None or any(j == joint for j, _ in mech.motors.values()):
            return ""
        return "free motion" if not mech.motors else f"no motor acts at joint {joint}"

    @property
    def driving_effort(self) -> np.ndarray:
        """Zero where no motor acts at the driver's joint (the inverse dynamics of the
        integrated motion gives only its integration error there), else as for a sweep."""
        e = super().driving_effort
        return np.where(np.isfinite(e), 0.0, np.nan) if self.idle_driver() else e

    def status(self) -> list[str]:
        """Per row: ``ok`` or why not; a row at a singular position (an event that ends
        the run there) has no accelerations or forces: the equations do not fix them."""
        out = super().status()
        qdd = self.trajectory.qdd
        for i in np.flatnonzero(~np.all(np.isfinite(qdd), axis=1)):
            if out[i] == "ok":
                out[i] = "singular: accelerations and forces not determined"
        return out

    def limit_positions(self):
        """Not reported: a rocker's extremes over a sweep of the driver are not the
        extremes of a motion in time (the CSV has every position)."""
        return []

    def transmission_angles(self):
        return []

    def motor_torque(self) -> np.ndarray | None:
        mech = self.mechanism
        if mech.motor is None:
            return None
        tr = self.trajectory
        return drive_torque(mech.motor, mech.driver.direction, tr.ud, tr.t)

    def columns(self) -> list[Column]:
        tr = self.trajectory
        lin = self.linear
        cols = super().columns()
        extra = [
            Column("omega" if not lin else "v", "m/s" if lin else "rad/s", tr.ud),
            Column("epsilon" if not lin else "a", "m/s^2" if lin else "rad/s^2", tr.udd),
        ]
        M = self.motor_torque()
        if M is not None:
            extra += [
                Column("motor.torque" if not lin else "motor.force", "N" if lin else "N*m", M),
                Column("motor.power", "W", M * tr.ud),
            ]
        extra += [
            Column("energy.kinetic", "J", tr.kinetic),
            Column("energy.potential", "J", tr.potential),
            Column("energy.work", "J", tr.work),
            Column("energy.residual", "J", tr.energy_residual),
            Column("constraint.violation", "m", tr.violation),
            Column("constraint.velocity_violation", "m/s", tr.velocity_violation),
        ]
        return cols[:3] + extra + cols[3:]

    def energy_residual(self) -> np.ndarray:
        """T + V - W - (T0 + V0) along the motion (J): the integrator's error."""
        return self.trajectory.energy_residual

    def summary(self, figures=None, units: OutputUnits | None = None) -> str:
        """The sweep's summary and the simulation's figures, in ``units`` (default SI)."""
        tr = self.trajectory
        mb = self.multibody
        sim = self.mechanism.simulation
        lines = [super().summary(figures, units=units)]
        kl, L = (units or SI_OUTPUT).convert("m")
        kv, V = (units or SI_OUTPUT).convert("m/s")
        how = (
            f"rk4, {len(tr.t) - 1} fixed steps of {sim.step:.6g} s"
            if sim.method == "rk4" and sim.step
            else f"{sim.method if sim.method != 'rk4' else 'DOP853'} with rtol {sim.rtol:g}, "
            f"atol {sim.atol:g}, {len(tr.t)} output rows"
        )
        dof = mb.nq - len(mb.partition(tr.q[0]).rows)
        red = mb.nc - len(mb.partition(tr.q[0]).rows)
        lines.append(
            f"  simulation (multibody: {mb.nb} bodies, {mb.nq} coordinates, {mb.nc} constraint "
            f"equations{f' ({red} redundant)' if red else ''}, {dof} degree(s) of freedom): "
            f"{how} to t = {tr.t[-1]:.6g} s, {tr.nfev} evaluations"
            + (f", {tr.partitions} partitions" if tr.partitions > 1 else "")
        )
        names = ", ".join(f"{src.name} ({src.text})" for src in mb.sources)
        lines.append("  sources: " + (names or "none (free motion)"))
        E = max(
            np.max(np.abs(tr.kinetic)),
            np.max(np.abs(tr.potential - tr.potential[0])),
            np.max(np.abs(tr.work)),
        )
        line, self.energy_warning = energy_check(tr.energy_residual, E, sim.method)
        lines.append("  " + line)
        if self.energy_warning:
            lines.append("  warning: " + self.energy_warning)
        lines.append(
            f"  largest constraint violation: {np.max(tr.violation) * kl:.3g} {L} (position, "
            f"tolerance {mb.tol * kl:.3g} {L}), {np.max(tr.velocity_violation) * kv:.3g} {V} "
            "(velocity)"
        )
        if mb.friction is not None:
            lines.append("  " + mb.friction.describe())
        if tr.redundant:
            lines.append(
                "  redundant constraints: the motion is unique, the reactions are the "
                "minimum-norm solution (not unique)"
            )
        if tr.bridges:
            lines.append(
                f"  {tr.bridges} output step(s) bridged across singular positions (RK4 on "
                "all coordinates, each step projected onto the constraints)"
            )
        if tr.undetermined_text():
            lines.append(tr.undetermined_text())
        if tr.early:
            lines.append(
                f"  stopped early at t = {tr.t[-1]:.9g} s: {tr.stopped}; the motion up to "
                "there is kept"
            )
        elif tr.stopped:
            lines.append(f"  stopped at t = {tr.t[-1]:.9g} s (stop when): {tr.stopped}")
        return "\n".join(lines)

    def incomplete(self) -> bool:
        """Also where the energy balance fails its check (after :meth:`summary`)."""
        return (
            not self.ok.all()
            or bool(self.trajectory.undetermined.size)
            or bool(getattr(self, "energy_warning", ""))
        )
