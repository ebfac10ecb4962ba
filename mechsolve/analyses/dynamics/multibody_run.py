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

import numpy as np

from mechsolve.analyses.dynamics.integrators import _with_flywheel
from mechsolve.analyses.dynamics.model import drive_torque
from mechsolve.analyses.dynamics.multibody import (
    Multibody,
    Source,
    Trajectory,
    coordinate,
    integrate,
)
from mechsolve.base.state import State
from mechsolve.core import evaluate as core
from mechsolve.core.sweep import Analysis
from mechsolve.model import Mechanism
from mechsolve.results.results import Column, Results

RATE_RTOL = 1e-6  # how far given rates may be from consistent before it is an error
RATE_ATOL = 1e-9


def uses_multibody(mech: Mechanism) -> bool:
    """Whether ``simulate`` takes the general path: asked for, or no motor (free motion)."""
    sim = mech.simulation
    if sim is not None and sim.formulation is not None:
        return sim.formulation == "multibody"
    return mech.motor is None and sim is not None


def simulate_multibody(mech: Mechanism, *, max_steps: int | None = None) -> MultibodyResults:
    """Integrate the file's mechanism in body coordinates (see :mod:`.multibody`)."""
    sim = mech.simulation
    if sim is None:
        raise mech.error(("simulate",), "a simulation needs a 'simulate' section (duration, step)")
    machine = _with_flywheel(mech)
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
    start = core.states(an, np.array([u0]), np.array([sim.speed0]), np.array([0.0]))
    if not start.ok[0]:
        raise mech.error(("driver", "start"), "the mechanism cannot close at the driver's start")
    st = start.state
    q0 = st.q()[0]
    qd0 = np.stack([st.vx[:-1, 0], st.vy[:-1, 0], st.w[:-1, 0]], axis=1).ravel()
    d = machine.driver
    sources = []
    free = Multibody(an)
    drv = coordinate(machine, free.system, d.joint, d.line)
    if mech.motor is not None:
        motor, sense = mech.motor, d.direction
        sources.append(Source("motor", drv, lambda w, t: float(drive_torque(motor, sense, w, t))))
    mb = Multibody(an, sources, tolerance=sim.tolerance)
    if sim.rates:
        qd0 = _initial_rates(mech, mb, q0, qd0, d)
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
    )
    sol = _solution(an, start, mb, drv, tr)
    forces = core.forces(an, sol)
    return MultibodyResults(an, sol, forces, tr, mb, drv)


def _initial_rates(mech, mb: Multibody, q0, qd0, d) -> np.ndarray:
    """The rates nearest to ``simulate.from`` and ``simulate.rates`` that satisfy the
    constraints; an input error where a given value must change by more than a
    tolerance."""
    sim = mech.simulation
    rows, targets, where = [], [], []
    st = mb.state(q0, qd0)
    given = dict(sim.rates)
    if d.joint not in given and sim.speed0_given:
        given[d.joint] = (sim.speed0, None, ("simulate", "from"))
    for j, (value, kind, path) in given.items():
        try:
            joint = mech.joint(j)
        except (KeyError, ValueError):
            joint = None
        if joint is None or joint.coordinate is None:
            names = [jj.name for jj in mech.joints if jj.coordinate is not None]
            raise mech.error(
                path,
                f"no joint {j!r} with a coordinate to give a rate to (joints: {', '.join(names)})",
            )
        want = "speed" if joint.coordinate == "length" else "angular speed"
        if kind is not None and kind != want:
            raise mech.error(
                path,
                f"the joint {j!r} needs {want}, e.g. 2 {'m/s' if want == 'speed' else 'rad/s'}",
            )
        c = coordinate(mech, mb.system, j, d.line if j == d.joint else None)
        row, _ = mb._coordinate_row(c, st)
        rows.append(row)
        targets.append(value)
        where.append((j, path))
    Jq = mb.jacobian(q0)
    # the constraint's solutions qd = N a (N: its null space), fitted to the given rates
    _, sv, Vt = np.linalg.svd(Jq) if Jq.size else (None, np.zeros(0), np.eye(mb.nq))
    rank = int(np.sum(sv > 1e-10 * (sv[0] if sv.size else 1.0)))
    N = Vt[rank:].T
    C = np.array(rows)
    a, *_ = np.linalg.lstsq(C @ N, np.array(targets), rcond=1e-12)
    qd = N @ a
    got = C @ qd
    for (j, path), x, y in zip(where, targets, got):
        if abs(y - x) > RATE_RTOL * max(abs(x), abs(y)) + RATE_ATOL:
            consistent = ", ".join(f"{jj}: {v:.6g}" for (jj, _), v in zip(where, got))
            raise mech.error(
                path,
                f"the initial rates are not consistent with the constraints: {j}'s rate "
                f"{x:.6g} would have to be {y:.6g} (the nearest consistent rates: "
                f"{consistent}, in rad/s or m/s); give rates that the mechanism allows",
            )
    return qd


def _solution(an: Analysis, start, mb: Multibody, drv, tr: Trajectory):
    """The trajectory as a :class:`Solution` of the analysis (for its columns and the
    force analysis), with the driver coordinate, its rate and acceleration."""
    n = len(tr.t)
    st = State(mb.nb, n)
    nb = mb.nb
    st.x[:nb], st.y[:nb], st.th[:nb] = tr.q[:, 0::3].T, tr.q[:, 1::3].T, tr.q[:, 2::3].T
    np.cos(st.th[:nb], out=st.c[:nb])
    np.sin(st.th[:nb], out=st.s[:nb])
    st.vx[:nb], st.vy[:nb], st.w[:nb] = tr.qd[:, 0::3].T, tr.qd[:, 1::3].T, tr.qd[:, 2::3].T
    st.ax[:nb], st.ay[:nb], st.al[:nb] = tr.qdd[:, 0::3].T, tr.qdd[:, 1::3].T, tr.qdd[:, 2::3].T
    st.token = State.new_token()
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
        flips={},
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

    def summary(self) -> str:
        tr = self.trajectory
        mb = self.multibody
        sim = self.mechanism.simulation
        lines = [super().summary()]
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
        motor = self.mechanism.motor
        lines.append(
            "  sources: "
            + (
                f"motor {motor.describe()} on joint {self.mechanism.driver.joint}"
                if motor is not None
                else "none (free motion)"
            )
        )
        E = np.abs(tr.kinetic) + np.abs(tr.potential - tr.potential[0]) + np.abs(tr.work)
        lines.append(
            f"  energy balance: T + V - W changed by at most "
            f"{np.max(np.abs(tr.energy_residual)):.3g} J (largest of T, |V - V0|, |W|: "
            f"{np.max(E):.6g} J)"
        )
        lines.append(
            f"  largest constraint violation: {np.max(tr.violation):.3g} m (position, "
            f"tolerance {mb.tol:.3g} m), {np.max(tr.velocity_violation):.3g} m/s (velocity)"
        )
        if tr.redundant:
            lines.append(
                "  redundant constraints: the motion is unique, the reactions are the "
                "minimum-norm solution (not unique)"
            )
        if tr.early:
            lines.append(
                f"  stopped early at t = {tr.t[-1]:.6g} s: {tr.stopped}; the motion up to "
                "there is kept"
            )
        return "\n".join(lines)

    def incomplete(self) -> bool:
        return not self.ok.all()
