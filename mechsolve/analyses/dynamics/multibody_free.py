"""``mechsolve simulate`` on the general path for a mechanism of any number of degrees of
freedom: its start pose from ``simulate.pose`` (one joint coordinate per degree of
freedom), its motors from ``motors:``, its table and summary (see :mod:`.multibody`)."""

from __future__ import annotations

import csv
import dataclasses
import math
from collections import deque

import numpy as np

from mechsolve.analyses.dynamics.integrators import energy_check
from mechsolve.analyses.dynamics.model import drive_torque
from mechsolve.analyses.dynamics.multibody import (
    NEWTON_ITERATIONS,
    Multibody,
    Prescribed,
    Source,
    Trajectory,
    coordinate,
    free_context,
    trajectory_state,
)
from mechsolve.analyses.dynamics.multibody_events import stop_condition
from mechsolve.analyses.dynamics.multibody_integrate import integrate
from mechsolve.base.atomic import replacing
from mechsolve.base.units import SI_OUTPUT, OutputUnits
from mechsolve.model import GROUND, Mechanism, as_snapshotted, content_snapshot
from mechsolve.model.expr.poles import first_pole_along

# how far given rates may be from consistent before it is an error: a value written to
# 6 significant digits (5e-6 of its size at most) passes
RATE_RTOL = 1e-5
RATE_ATOL = 1e-9


def motor_sources(mech: Mechanism, system) -> list[Source]:
    """The file's ``motors:``, each a torque (force) on its joint's coordinate."""
    out = []
    for name, (joint, motor) in mech.motors.items():
        c = coordinate(mech, system, joint)
        out.append(
            Source(
                name,
                c,
                lambda w, t, m=motor: float(drive_torque(m, 1, w, t)),
                f"{motor.describe(mech.joint(joint).coordinate == 'length')} on {joint}",
            )
        )
    return out


# the trajectory's rows, one per output time (cut together)
_ROWS = (
    "t", "q", "qd", "qdd", "lam", "kinetic", "potential", "work", "violation",
    "velocity_violation",
)  # fmt: skip


def motors_pole_cut(mech: Mechanism, mb: Multibody, tr: Trajectory) -> Trajectory | None:
    """The trajectory up to the output before the first pole of a ``motors:`` entry's law
    that the motion passed between two outputs (the law finite at both: the integrator
    stepped through infinity, and the motion after it is not the law's), with the file's
    input error at that motor's key; None where every law stays finite along the motion
    (as the driver's ``motor:`` is checked, :func:`.multibody_run._motor_pole_cut`)."""
    if len(tr.t) < 2 or not mech.motors:
        return None
    st, best = None, None
    for src in mb.sources:
        joint, motor = mech.motors.get(src.name, (None, None))
        if motor is None or motor.kind != "law" or not src.text.endswith(f" on {joint}"):
            continue
        st = trajectory_state(mb, tr) if st is None else st
        rows = np.zeros((len(tr.t), mb.nq))
        for body, blk in src.coordinate.jacobian(st).items():
            rows[:, 3 * body : 3 * body + 3] = blk[0].T
        w = np.einsum("ij,ij->i", rows, tr.qd)  # the joint coordinate's rate
        hit = first_pole_along(motor.expr, {"omega": w, "v": w, "t": np.asarray(tr.t)})
        if hit is not None and (best is None or hit[0] < best[0]):
            best = (hit[0], hit[1], src.name, joint)
    if best is None:
        return None
    k, at, name, joint = best
    lin = mech.joint(joint).coordinate == "length"
    speed, unit = ("v", "m/s") if lin else ("omega", "rad/s")
    law = mech.motors[name][1].describe(lin, units=False)
    text = (
        f"the motor {name}'s law {law} grows without bound at {speed} = {at[speed]:.6g} "
        f"{unit}, t = {at['t']:.6g} s: it must give a finite {'force' if lin else 'torque'} "
        "at every speed and time the motion reaches"
    )
    raw = mech.source.data.get("motors") if mech.source is not None else None
    entry = raw.get(name) if isinstance(raw, dict) else None
    keys = [x for x in ("torque", "force") if isinstance(entry, dict) and x in entry]
    error = mech.error(("motors", name, keys[0] if keys else "torque"), text)
    rows = {f: getattr(tr, f)[: k + 1] for f in _ROWS}
    return dataclasses.replace(tr, **rows, stopped=text, early=True, event="", error=error)


# a start is at a singular position where the constraint equations, at it, have a
# smaller rank than at the poses next to it on the motion. Their rank at the start counts
# the singular values (of Phi_q, its angle columns times the mechanism's size: the
# measure is the same in m, mm or in) above START_SINGULAR of the largest: the pose
# assembled at a singular position is off it by rounding (the closed form's square root
# of a vanishing discriminant leaves ~1.5e-8 rad: measures of 0 to 5e-9 on the
# parallelograms of tests/test_issue30_singularstart.py), a start 1e-6 rad from it
# measures 3.5e-8 (cranks of 0.1 m) to 1.7e-7 (0.9 m) and runs true
START_SINGULAR = 2e-8
# the poses next to the start: closed from it moved by this of the mechanism's size
# along the directions the equations leave free at it (to first order)
NEXT_TO = 1e-2
# the directions taken as free at the start: singular values below this of the largest
# (a start 1e-6 rad next to a singular position has its lost direction's at 1e-7)
FREE = 1e-4


@dataclasses.dataclass
class StartRanks:
    """The constraint equations' rank at the start (``at``) and at the poses next to
    it on the motion (``near``); ``branches``: how many branches of the motion pass
    through the start (0 where it was not counted)."""

    at: int
    near: int
    branches: int
    measure: float


def start_ranks(mb: Multibody, q0: np.ndarray) -> StartRanks:
    """The rank of ``Phi_q`` at ``q0`` against its rank at the poses next to it.

    The poses next to ``q0``: closed (minimum-norm Newton) from ``q0`` moved by
    :data:`NEXT_TO` of the mechanism's size along each direction of a circle in the
    space the equations leave free at ``q0`` (their right singular vectors past the
    rank). A rank deficient there as at ``q0`` is redundant equations (the run's rank);
    a rank lost only at ``q0`` is a singular position. The directions from ``q0`` to
    the closed poses, one pair per branch through ``q0``, count its branches where the
    motion next to it has one degree of freedom (a parallelogram's two branches cross
    at its collinear pose: four directions; with a third crank at the coupler's middle
    one branch passes: two)."""
    w = np.ones(mb.nq)
    w[2::3] = 1.0 / mb.scale
    if mb.nc == 0:
        return StartRanks(0, 0, 0, 1.0)
    rel, Vt = _relative_singular_values(mb, q0, w)
    at = int(np.sum(rel > START_SINGULAR))
    free = Vt[int(np.sum(rel > FREE)) :]  # (free to first order, or nearly)
    if len(free) == 0:
        return StartRanks(at, at, 0, float(rel[at - 1]))
    if len(free) == 1:
        dirs = [free[0], -free[0]]
    else:
        phi = np.linspace(0.0, 2.0 * math.pi, 48, endpoint=False)
        basis = free[:2] if len(free) == 2 else free
        dirs = [math.cos(a) * basis[0] + math.sin(a) * basis[1] for a in phi]
        dirs += [s * v for v in free[2:] for s in (1.0, -1.0)]
    near, seen = [], []
    for d in dirs:
        q = _close_next_to(mb, q0 + NEXT_TO * mb.scale * (w * d), w)
        e = (q - q0) / w if q is not None else np.zeros(1)
        n = float(np.linalg.norm(e))
        if n < 0.1 * NEXT_TO * mb.scale:
            continue  # not closed, or back at the start
        near.append(int(np.sum(_relative_singular_values(mb, q, w)[0] > START_SINGULAR)))
        if not any(float(e @ f) > 0.98 * n for f in seen):
            seen.append(e / n)
    near = max(near, default=at)  # (none closed: taken as the start's)
    one_dof = mb.nq - near == 1 and len(free) <= 2
    measure = abs(float(rel[near - 1])) if near else 1.0
    return StartRanks(at, near, len(seen) // 2 if one_dof else 0, measure)


def _relative_singular_values(mb: Multibody, q: np.ndarray, w: np.ndarray):
    """The singular values of ``Phi_q`` with its columns weighed by ``w``, over the
    largest, and its right singular vectors."""
    _, S, Vt = np.linalg.svd(mb.jacobian(q) * w)
    return (S / S[0] if S[0] > 0 else np.zeros_like(S)), Vt


def _close_next_to(mb: Multibody, q: np.ndarray, w: np.ndarray) -> np.ndarray | None:
    """``q`` closed onto ``Phi = 0`` by Newton steps of minimum norm that set aside the
    directions whose singular value is below 1e-4 of the largest (the redundant
    equations' direction, whose singular value off the constraints is about the
    distance to them: inverted, it threw the steps far off); None where it does not
    close to 1e-12 of the mechanism's size in 40 steps."""
    for _ in range(40):
        phi = mb.residual(q, 0.0)
        if not np.all(np.isfinite(phi)):
            return None
        if np.abs(phi).max() <= 1e-12 * mb.scale:
            return q
        q = q - w * np.linalg.lstsq(mb.jacobian(q) * w, phi, rcond=FREE)[0]
    return None


def refuse_singular_start(mech: Mechanism, mb: Multibody, q0: np.ndarray, key, where: str):
    """An input error at ``key`` where the start ``q0`` is a singular position: the
    constraint equations have a smaller rank at it than at the poses next to it on the
    motion (:func:`start_ranks`; a rank deficient next to it as well is redundant
    equations, which run).

    Where branches of the mechanism meet there, the position and the rates do not
    determine the motion: each branch through it has its own acceleration (a
    parallelogram from rest at its collinear pose under gravity: theta'' = -27.6
    rad/s^2 on the parallel branch, +10.0 on the crossed one). Unrefused, such a start
    ran on neither (cranks of 0.1 m: -7.835 and -7.965 deg at 0.05 s where the parallel
    branch has both at -7.899 deg) or stayed put. Where one branch passes (a third crank
    at the coupler's middle) the motion is determined, but the run integrates on the
    equations' rank next to it, which the start lacks (it ended in an internal error)."""
    ranks = start_ranks(mb, q0)
    if ranks.at == ranks.near:
        return  # a regular start, or redundant equations: their rank is the run's
    if ranks.at > ranks.near:
        raise mech.error(
            key,
            f"the start ({where}) is too close to a singular position of the mechanism "
            f"for its pose to be found to rounding: the constraint equations have rank "
            f"{ranks.at} at the pose assembled there (it closes them to rounding) and "
            f"{ranks.near} at the poses on the motion next to it (redundant equations), so "
            "that pose is off the motion by more than rounding; start farther from the "
            "singular position (1e-4 rad is enough for a four-bar)",
        )
    head = (
        f"the start ({where}) is a singular position: the constraint equations have rank "
        f"{ranks.at} there and {ranks.near} at the poses next to it on the motion (their "
        f"{ranks.near}th singular value is {ranks.measure:.1e} of the largest at it)"
    )
    if ranks.branches == 1:
        tail = (
            "; one branch of the mechanism passes through it, so the motion is "
            "determined, but the simulation integrates on the equations independent next "
            "to it, which are singular at it: start next to it (1e-6 rad away is enough "
            "for a four-bar)"
        )
    else:
        meet = (
            f"{ranks.branches} branches of the mechanism meet"
            if ranks.branches > 1
            else "branches of the mechanism can meet"
        )
        tail = (
            f", where {meet}, so the position and the rates do not determine the motion "
            "(each branch has its own acceleration from it); start next to it, on the "
            "branch the motion is to follow (1e-6 rad away is enough for a four-bar)"
        )
    raise mech.error(key, head + tail)


def simulate_free(mech: Mechanism, machine: Mechanism, *, max_steps: int | None = None):
    """Integrate a mechanism placed by ``simulate.pose`` (no sweep analysis: any number
    of degrees of freedom)."""
    sim = mech.simulation
    for ld in mech.loads:
        if ld.when is not None and ld.when.uses("stroke"):
            raise mech.error(
                ld.where + ("when",),
                "stroke() is a fraction of the stroke over a turn of the driver, which a "
                "mechanism placed by simulate.pose has not: give a 'driver' (one degree "
                "of freedom) instead of simulate.pose, or a condition without stroke()",
            )
    if mech.motor is not None:
        raise mech.error(("motor",), "with simulate.pose give the motors in 'motors:'")
    if sim.singular == "keep branch":
        raise mech.error(
            ("simulate", "singular"),
            "'singular: keep branch' reads the loops' branches through the sweep's "
            "analysis, which places the mechanism by its driver: give a 'driver' (one "
            "degree of freedom) instead of simulate.pose",
        )
    if sim.stop is not None and sim.stop.uses("stroke"):
        raise mech.error(
            ("simulate", "stop when"),
            "stroke() is a fraction of the stroke over a turn of the driver, which a "
            "mechanism placed by simulate.pose has not",
        )
    ctx = free_context(machine)
    prescribed = _prescribed(machine, ctx.system)
    mb = Multibody(ctx, motor_sources(machine, ctx.system), prescribed, tolerance=sim.tolerance)
    q0 = assemble_pose(mech, mb)
    refuse_singular_start(mech, mb, q0, ("simulate", "pose"), "the pose")
    qd0 = initial_rates(mech, mb, q0, np.zeros(mb.nq), None)
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
        singular=sim.singular,
        stop=stop_condition(ctx, mb, sim.stop) if sim.stop is not None else None,
    )
    return FreeResults(mech, mb, motors_pole_cut(mech, mb, tr) or tr)


def initial_rates(mech, mb: Multibody, q0, qd0, d) -> np.ndarray:
    """The rates nearest to ``simulate.from`` and ``simulate.rates`` that satisfy the
    constraints; an input error where a given value must change by more than a
    tolerance."""
    sim = mech.simulation
    rows, targets, where = [], [], []
    st = mb.state(q0, qd0)
    given = dict(sim.rates)
    for j, (_, kind, path) in sim.pose.items():  # a joint placed by the pose starts at rest
        given.setdefault(j, (0.0, "speed" if kind == "length" else "angular speed", path))
    if d is not None and d.joint not in given and sim.speed0_given:
        given[d.joint] = (d.direction * abs(sim.speed0), None, ("simulate", "from"))
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
        c = coordinate(mech, mb.system, j, d.line if d is not None and j == d.joint else None)
        row, _ = mb._coordinate_row(c, st)
        rows.append(row)
        targets.append(value)
        where.append((j, path))
    Jq = mb.jacobian(q0)
    # the constraint's solutions qd = N a (N: its null space), fitted to the given rates
    _, sv, Vt = np.linalg.svd(Jq) if Jq.size else (None, np.zeros(0), np.eye(mb.nq))
    rank = int(np.sum(sv > 1e-10 * (sv[0] if sv.size else 1.0)))
    N = Vt[rank:].T
    nu = mb._nu_gamma(st, 0.0, gamma=False)
    qd_p = np.linalg.lstsq(Jq, nu, rcond=1e-12)[0] if Jq.size else np.zeros(mb.nq)
    if not rows:
        return qd_p
    # a particular solution of Phi_q q' = nu (the prescribed motions' rates), then the
    # free part fitted to the given rates, the driver's `from` held as given
    fixed = np.array([path == ("simulate", "from") for _, path in where])
    qd = qd_p + N @ _fit(np.array(rows) @ N, np.array(targets) - np.array(rows) @ qd_p, fixed)
    got = np.array(rows) @ qd
    for (j, path), x, y in zip(where, targets, got):
        if abs(y - x) > RATE_RTOL * max(abs(x), abs(y)) + RATE_ATOL:
            unit = {jj: _rate_unit(mech, jj) for jj, _ in where}
            consistent = ", ".join(f"{jj}: {v:.10g} {unit[jj]}" for (jj, _), v in zip(where, got))
            k = int(np.argmax(fixed))
            held = (
                f" with the driver's from {targets[k]:.10g} {unit[where[k][0]]}"
                if fixed.any() and not fixed[where.index((j, path))]
                else ""
            )
            raise mech.error(
                path,
                f"the initial rates are not consistent with the constraints: {j}'s rate "
                f"{x:.10g} {unit[j]} would have to be {y:.10g} {unit[j]}{held} (the "
                f"consistent rates: {consistent}); give rates that the mechanism allows",
            )
    return qd


def _rate_unit(mech: Mechanism, joint: str) -> str:
    return "m/s" if mech.joint(joint).coordinate == "length" else "rad/s"


def _fit(C: np.ndarray, r: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """The free part ``a`` of the rates: ``C[fixed] a = r[fixed]`` exactly where it can
    be met (the driver's ``from``, as given), the other rows by least squares in what
    it leaves free; all rows by least squares where the fixed ones cannot be met."""
    a, *_ = np.linalg.lstsq(C, r, rcond=1e-12)
    if not fixed.any() or fixed.all():
        return a
    Cf = C[fixed]
    a0 = np.linalg.lstsq(Cf, r[fixed], rcond=1e-12)[0]
    if np.abs(Cf @ a0 - r[fixed]).max() > 1e-12 * max(1.0, float(np.abs(r[fixed]).max())):
        return a  # the driver's rate alone is not allowed here: the nearest rates
    _, sv, Vt = np.linalg.svd(Cf)
    K = Vt[int(np.sum(sv > 1e-12 * sv[0])) :].T  # what the fixed rows leave free
    if K.shape[1] == 0:
        return a0
    b, *_ = np.linalg.lstsq(C[~fixed] @ K, r[~fixed] - C[~fixed] @ a0, rcond=1e-12)
    return a0 + K @ b


def _prescribed(mech: Mechanism, system) -> list[Prescribed]:
    """With ``simulate.pose``, a ``driver:`` prescribes its joint's motion: its constant
    speed from its start, or its motion law (the other freedoms move freely)."""
    d = mech.driver
    if d is None:
        return []
    if not isinstance(d.start, (int, float)):
        raise mech.error(d.where + ("start",), "a prescribed driver starts at a number")
    u0, w = float(d.start), float(d.speed)
    if d.motion is not None:
        law = d.motion

        def at(t):
            u, ud, udd = law.at(np.array([t]))
            return float(u[0]), float(ud[0]), float(udd[0])
    else:

        def at(t):
            return u0 + w * t, w, 0.0

    c = coordinate(mech, system, d.joint, d.line)
    return [Prescribed(f"driver {d.joint}", c, at)]


def _guess(mech: Mechanism, mb: Multibody) -> np.ndarray:
    """Every body placed along a spanning tree from the ground: a body's angle from the
    pose where its joint has one (else 0), its frame so that the joint's point meets."""
    sim = mech.simulation
    index = mb.system.index
    q = np.zeros(mb.nq)
    placed = {GROUND}
    todo = deque([GROUND])

    def frame(link):
        if link == GROUND:
            return np.zeros(2), 0.0
        b = index[link]
        return q[3 * b : 3 * b + 2], q[3 * b + 2]

    while todo:
        here = todo.popleft()
        for j in mech.joints:
            if here not in (j.a, j.b):
                continue
            other = j.b if j.a == here else j.a
            if other in placed:
                continue
            o, th = frame(here)
            rel = sim.pose.get(j.name, (0.0, None, None))[0] if j.coordinate == "angle" else 0.0
            th_o = th + rel if other == j.b else th - rel
            s_here = np.asarray(mech.local_point(here, j.point), float)
            s_other = np.asarray(mech.local_point(other, j.point), float)
            p = o + _rot(th) @ s_here if here != GROUND else s_here
            b = index[other]
            q[3 * b : 3 * b + 2] = p - _rot(th_o) @ s_other
            q[3 * b + 2] = th_o
            placed.add(other)
            todo.append(other)
    return q


def _rot(th: float) -> np.ndarray:
    c, s = math.cos(th), math.sin(th)
    return np.array([[c, -s], [s, c]])


def assemble_pose(mech: Mechanism, mb: Multibody) -> np.ndarray:
    """The configuration with the joint coordinates of ``simulate.pose``: Gauss-Newton on
    the constraints and those coordinates from :func:`_guess`; an input error where the
    pose does not give one coordinate per degree of freedom or cannot be reached."""
    sim = mech.simulation
    coords, values = [], []
    for j, (value, kind, path) in sim.pose.items():
        joint = next((jj for jj in mech.joints if jj.name == j), None)
        if joint is None or joint.coordinate is None:
            names = [jj.name for jj in mech.joints if jj.coordinate is not None]
            raise mech.error(path, f"no joint {j!r} with a coordinate (joints: {', '.join(names)})")
        if kind != joint.coordinate:
            raise mech.error(
                path, f"the joint {j!r} needs a{'n angle' if kind == 'length' else ' length'}"
            )
        coords.append(coordinate(mech, mb.system, j))
        values.append(value)
    q = _guess(mech, mb)  # the prescribed coordinates are in the residual, at t = 0
    path = ("simulate", "pose")
    for _ in range(4 * NEWTON_ITERATIONS):
        st = mb.state(q)
        F = np.concatenate(
            [mb.residual(q, 0.0), [c.value(st)[0] - v for c, v in zip(coords, values)]]
        )
        J = np.vstack([mb.jacobian(q)] + [mb._coordinate_row(c, st)[0] for c in coords])
        if np.max(np.abs(F)) <= mb.tol:
            break
        q -= np.linalg.lstsq(J, F, rcond=1e-12)[0]
    else:
        raise mech.error(path, "the mechanism cannot be assembled with these joint coordinates")
    rank = np.linalg.matrix_rank(J, tol=1e-9 * np.max(np.abs(J)))
    Jq = mb.jacobian(q)
    dof = mb.nq - (np.linalg.matrix_rank(Jq, tol=1e-9 * np.max(np.abs(Jq))) if Jq.size else 0)
    if rank < mb.nq or len(coords) != dof:
        raise mech.error(
            path,
            f"the mechanism has {dof} degree(s) of freedom here"
            + (" besides its prescribed driver" if mb.prescribed else "")
            + ": give one joint coordinate "
            f"for each (got {len(coords)}{', not independent' if rank < mb.nq else ''})",
        )
    return q


class FreeResults:
    """The motion of a mechanism placed by its pose: every body's pose and rates, every
    point, the motors, the energies, the violation and the joints' reactions."""

    def __init__(self, mech: Mechanism, mb: Multibody, tr: Trajectory) -> None:
        self._solved = (mech, content_snapshot(mech))
        self.multibody = mb
        self.trajectory = tr
        self.model = None

    @property
    def mechanism(self) -> Mechanism:
        """The model as simulated: itself, or after an edit of it, a copy as it was (see
        :func:`mechsolve.model.as_snapshotted`)."""
        self._solved = as_snapshotted(*self._solved)
        return self._solved[0]

    def columns(self) -> list[tuple[str, np.ndarray]]:
        tr, mb, mech = self.trajectory, self.multibody, self.mechanism
        cols = [("t [s]", tr.t)]
        for lk in mech.links:
            b = mb.system.index[lk.name]
            cols += [
                (f"{lk.name}.x [m]", tr.q[:, 3 * b]),
                (f"{lk.name}.y [m]", tr.q[:, 3 * b + 1]),
                (f"{lk.name}.angle [deg]", np.degrees(tr.q[:, 3 * b + 2])),
                (f"{lk.name}.vx [m/s]", tr.qd[:, 3 * b]),
                (f"{lk.name}.vy [m/s]", tr.qd[:, 3 * b + 1]),
                (f"{lk.name}.omega [rad/s]", tr.qd[:, 3 * b + 2]),
                (f"{lk.name}.alpha [rad/s^2]", tr.qdd[:, 3 * b + 2]),
            ]
            for p, s in lk.points.items():
                c, sn = np.cos(tr.q[:, 3 * b + 2]), np.sin(tr.q[:, 3 * b + 2])
                rx, ry = c * s[0] - sn * s[1], sn * s[0] + c * s[1]
                w = tr.qd[:, 3 * b + 2]
                cols += [
                    (f"{lk.name}.{p}.x [m]", tr.q[:, 3 * b] + rx),
                    (f"{lk.name}.{p}.y [m]", tr.q[:, 3 * b + 1] + ry),
                    (f"{lk.name}.{p}.vx [m/s]", tr.qd[:, 3 * b] - w * ry),
                    (f"{lk.name}.{p}.vy [m/s]", tr.qd[:, 3 * b + 1] + w * rx),
                ]
        st = trajectory_state(mb, tr)
        for src in mb.sources:
            row = np.zeros((len(tr.t), mb.nq))
            for body, blk in src.coordinate.jacobian(st).items():
                row[:, 3 * body : 3 * body + 3] = blk[0].T
            rate = np.einsum("ij,ij->i", row, tr.qd)
            effort = np.array([src.law(w, t) for w, t in zip(rate, tr.t)])
            unit = (
                "m/s"
                if src.coordinate.kind == "driver" and hasattr(src.coordinate, "slider")
                else "rad/s"
            )
            cols += [
                (f"{src.name}.rate [{unit}]", rate),
                (f"{src.name}.effort [{'N' if unit == 'm/s' else 'N*m'}]", effort),
            ]
        cols += [
            ("energy.kinetic [J]", tr.kinetic),
            ("energy.potential [J]", tr.potential),
            ("energy.work [J]", tr.work),
            ("energy.residual [J]", tr.energy_residual),
            ("constraint.violation [m]", tr.violation),
            ("constraint.velocity_violation [m/s]", tr.velocity_violation),
        ]
        mark = " (minimum-norm)" if tr.redundant else ""
        for row in mb.system.rows:
            c = row.constraint
            r = c.reaction(st, tr.lam[:, row.start : row.start + c.m])
            for k, v in (r or {}).items():
                cols.append((f"{c.name}.{k} [N]{mark}", np.asarray(v, float)))
        if mb.friction is not None:  # each joint's friction and the power it loses
            cols += [(f"{n} [{u}]", v) for n, u, v in mb.friction.columns(st, tr.lam)]
        return cols

    def to_csv(self, path, units: OutputUnits | None = None):
        """Write the table as CSV in ``units`` (default SI; each header names its unit)."""
        cols = self.columns()
        if units is not None and not units.is_si:
            shown_cols = []
            for name, v in cols:
                head, sep, rest = name.partition(" [")
                unit, _, note = rest.partition("]")
                k, unit_shown = units.convert(unit) if sep else (1.0, unit)
                if sep and (k != 1.0 or unit_shown != unit):
                    name, v = f"{head} [{unit_shown}]{note}", np.asarray(v, float) * k
                shown_cols.append((name, v))
            cols = shown_cols
        with replacing(path, ".csv") as tmp, open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([name for name, _ in cols])
            for i in range(len(self.trajectory.t)):
                w.writerow([f"{v[i]:.10g}" for _, v in cols])
        return path

    def summary(self, figures=None, units: OutputUnits | None = None) -> str:
        """What the motion did, in ``units`` (default SI)."""
        tr, mb = self.trajectory, self.multibody
        kl, L = (units or SI_OUTPUT).convert("m")
        kv, V = (units or SI_OUTPUT).convert("m/s")
        dof = mb.nq - len(mb.partition(tr.q[0]).rows)
        red = mb.nc - len(mb.partition(tr.q[0]).rows)
        scale = max(
            np.max(np.abs(tr.kinetic)),
            np.max(np.abs(tr.potential - tr.potential[0])),
            np.max(np.abs(tr.work)),
        )
        energy, self.energy_warning = energy_check(
            tr.energy_residual, scale, self.mechanism.simulation.method
        )
        lines = [
            f"{self.mechanism.name or 'mechanism'}: multibody simulation, {mb.nb} bodies, "
            f"{mb.nc} constraint equations{f' ({red} redundant)' if red else ''}, {dof} "
            f"degree(s) of freedom, {len(tr.t)} output rows to t = {tr.t[-1]:.6g} s, "
            f"{tr.nfev} evaluations",
            "  sources: "
            + (", ".join(f"{s.name} ({s.text})" for s in mb.sources) or "none (free motion)"),
            "  " + energy,
            f"  largest constraint violation: {np.max(tr.violation) * kl:.3g} {L} (position, "
            f"tolerance {mb.tol * kl:.3g} {L}), {np.max(tr.velocity_violation) * kv:.3g} {V} "
            "(velocity)",
        ]
        if mb.friction is not None:
            lost = dict((n, v) for n, _, v in mb.friction.columns(trajectory_state(mb, tr), tr.lam))
            W = {n: float(np.trapezoid(v, tr.t)) for n, v in lost.items() if n.endswith("_power")}
            each = ", ".join(f"{n[: -len('.friction_power')]} {w:.4g} J" for n, w in W.items())
            lines.append(
                f"  friction losses: {float(np.trapezoid(lost['power.friction'], tr.t)):.4g} J "
                f"({each}; the trapezoidal rule on the output rows)"
            )
            lines.append("  " + mb.friction.describe())
        if tr.bridges:
            lines.append(
                f"  {tr.bridges} output step(s) bridged across singular positions (RK4 on "
                "all coordinates, each step projected onto the constraints)"
            )
        if tr.undetermined_text():
            lines.append(tr.undetermined_text())
        if self.energy_warning:
            lines.append("  warning: " + self.energy_warning)
        if tr.early:
            lines.append(f"  stopped early at t = {tr.t[-1]:.9g} s: {tr.stopped}")
        elif tr.stopped:
            lines.append(f"  stopped at t = {tr.t[-1]:.9g} s (stop when): {tr.stopped}")
        return "\n".join(lines)

    def incomplete(self) -> bool:
        """Also where the energy balance fails its check (after :meth:`summary`)."""
        return bool(self.trajectory.undetermined.size) or bool(getattr(self, "energy_warning", ""))
