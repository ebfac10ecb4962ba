"""``mechsolve bench --case multibody``: the general forward-dynamics path on the IFToMM
planar benchmarks against exudyn, on the same problems in one run.

Problems: the N-four-bar (IFToMM A02, N = 2: five bars, redundant constraints, 10 s,
passing its singular horizontal positions) and Andrews' squeezing mechanism (seven
bodies, a stiff spring, 0.03 s). Both have one degree of freedom, so mechsolve runs each
on its general path (body coordinates, the files as shipped) and on its reduced path
(the driver's one equation of motion; the driving torque given as the motor, see
:data:`REDUCED`). Each solver is run at the benchmark's precision: the
loosest setting of a short list (mechsolve: rtol; exudyn: the fixed step of its implicit
generalized-alpha solver) whose error against the reference is within the precision,
and timed there (median of repetitions; exudyn's model building is not timed, nor
mechsolve's reading of the file). The errors are against references independent of
both: the N-four-bar's closed form (its windows are parallelograms: one pendulum, the
scalar equation solved at rtol 1e-13) for the position of B0 over the whole run, and the
published solution of Andrews' problem at 0.03 s (the seven angles; Test Set for IVP
Solvers, PSIDE at 1e-14).

exudyn is given the same start (every body's pose and rates from mechsolve's assembled,
consistent start), each link as an ``ObjectRigidBody2D`` (node at the centre of mass),
each pin as an ``ObjectJointRevolute2D``, a spring as an ``ObjectConnectorSpringDamper``,
a torque as a constant ``LoadTorqueVector`` and gravity as ``LoadMassProportional``;
redundant constraints with ``ignoreSingularJacobian``.
"""

from __future__ import annotations

import copy
import math
import statistics
import time
from typing import Any

import numpy as np

from mechsolve_bench import Case, Row
from mechsolve_bench.peers import _set_setting

# the published solution of Andrews' problem at t = 0.03 s: beta, Theta, gamma, Phi,
# delta, Omega, epsilon (Test Set for IVP Solvers, Bari: PSIDE, rtol = atol = 1e-14)
ANDREWS_003 = np.array(
    [
        0.1581077119629904e2,
        -0.1575637105984298e2,
        0.4082224013073101e-1,
        -0.5347301163226948,
        0.5244099658805304,
        0.5347301163226948,
        0.1048080741042263e1,
    ]
)
PRECISION = 1e-3  # m (B0's position) and rad (the angles): the benchmark's precision
# each solver's settings, loosest first, in steps of 2 to 3 (exudyn's) or about 3
# (mechsolve's rtol) near where the precision is met, each list starting at a setting
# too loose for it on both problems
RTOLS = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 1e-7, 1e-8, 1e-9)
STEPS = {"nfourbar-2": (1e-2, 5e-3, 2e-3, 1e-3, 5e-4), "andrews": (1e-4, 5e-5, 2e-5, 1e-5, 5e-6)}


def _mechanism(name: str, end: float | None):
    """The benchmark's copy of ``mechanisms/<name>.yaml`` (package data), its run
    shortened to ``end`` if given."""
    from mechsolve_bench import load_case

    mech = load_case(f"{name}.yaml")
    if end is not None:
        mech.simulation.duration = end
        mech.simulation.step = min(mech.simulation.step, end)
    return mech


def _nfourbar_theta(n: int, t: np.ndarray) -> np.ndarray:
    """The N-four-bar's crank angle: one pendulum, I = (N + 1) m l^2 / 3 + N m l^2,
    M_g = g m l ((N + 1) / 2 + N), upright at -1 rad/s (B0 along +x at 1 m/s)."""
    from scipy.integrate import solve_ivp

    inertia, mg = (n + 1) / 3 + n, 9.81 * ((n + 1) / 2 + n)
    sol = solve_ivp(
        lambda _, y: [y[1], -mg / inertia * math.cos(y[0])],
        (0, float(t[-1])),
        [math.pi / 2, -1.0],
        t_eval=t,
        rtol=1e-13,
        atol=1e-13,
        method="DOP853",
    )
    return sol.y[0]


def _published_angles(theta: dict[str, float]) -> np.ndarray:
    a = theta
    return np.array(
        [
            a["k1"],
            a["k2"] - a["k1"],
            a["k3"],
            a["k4"] - a["k5"],
            a["k5"],
            a["k6"] - a["k7"],
            a["k7"],
        ]
    )


def _error(name: str, t: np.ndarray, b0: np.ndarray | None, theta: dict | None) -> float:
    """The error against the reference: B0's position over the run (N-four-bar), the
    seven angles at 0.03 s (Andrews; NaN for a shorter run)."""
    if name.startswith("nfourbar"):
        th = _nfourbar_theta(2, t)
        return float(np.max(np.hypot(b0[:, 0] - np.cos(th), b0[:, 1] - np.sin(th))))
    if abs(t[-1] - 0.03) > 1e-12:
        return float("nan")
    d = _published_angles(theta) - ANDREWS_003
    return float(np.max(np.abs(np.angle(np.exp(1j * d)))))  # angles modulo a turn


# the same problems on the 1-DOF reduced path: the driving torque as the file's motor
# (the N-four-bar moves freely: a motor of no torque), replacing the torque load
REDUCED = {
    "nfourbar-2": ("", "motor: {torque: '0'}\n"),
    "andrews": ("  drive: {torque: 0.033 N m, on: k1}\n", "motor: {torque: '0.033'}\n"),
}


def _reduced(name: str, end: float | None):
    """The benchmark's problem posed for the reduced path (one equation of motion in the
    driver's coordinate, its inertia tabulated over the driver's turn)."""
    from mechsolve import api
    from mechsolve_bench import case_file

    load, motor = REDUCED[name]
    text = case_file(f"{name}.yaml").read_text(encoding="utf-8")
    if load not in text:
        raise RuntimeError(f"{name}.yaml has changed: no {load.strip()!r} to replace")
    mech = api.loads(text.replace(load, "") + motor, file=f"{name}.yaml")
    mech.simulation.formulation = "reduced"
    if end is not None:
        mech.simulation.duration = end
        mech.simulation.step = min(mech.simulation.step, end)
    return mech


def reduced_run(name: str, rtol: float, end: float | None, repeats: int) -> dict:
    """mechsolve's reduced path on the problem (see :data:`REDUCED`)."""
    from mechsolve.analyses.dynamics import simulate

    mech = _reduced(name, end)
    mech.simulation.rtol, mech.simulation.atol = rtol, rtol * 1e-3
    times, res = [], None
    for _ in range(repeats):
        m = copy.deepcopy(mech)
        start = time.perf_counter()
        res = simulate(m)
        times.append(time.perf_counter() - start)
    t = res.trajectory.t
    b0 = None
    if name.startswith("nfourbar"):
        p = res.point("B0")
        b0 = np.stack([p.x, p.y], axis=1)
    theta = {lk.name: float(res.link(lk.name).angle[-1]) for lk in mech.links}
    return {
        "seconds": statistics.median(times),
        "error": _error(name, t, b0, theta),
        "nfev": getattr(res.trajectory, "nfev", 0),
    }


def mechsolve_run(name: str, rtol: float, end: float | None, repeats: int) -> dict:
    from mechsolve.analyses.dynamics import simulate

    mech = _mechanism(name, end)
    mech.simulation.rtol, mech.simulation.atol = rtol, rtol * 1e-3
    times, res = [], None
    for _ in range(repeats):
        m = copy.deepcopy(mech)
        start = time.perf_counter()
        res = simulate(m)
        times.append(time.perf_counter() - start)
    tr, idx = res.trajectory, res.multibody.system.index
    b0 = None
    if name.startswith("nfourbar"):
        p = res.point("B0")
        b0 = np.stack([p.x, p.y], axis=1)
    theta = {k: float(tr.q[-1, 3 * b + 2]) for k, b in idx.items() if k != "ground"}
    return {
        "seconds": statistics.median(times),
        "error": _error(name, tr.t, b0, theta),
        "nfev": tr.nfev,
        "result": res,
    }


def exudyn_run(name: str, res: Any, h: float, end: float, repeats: int) -> dict | None:
    """exudyn on the problem of ``res`` (a mechsolve result: its mechanism and start)."""
    try:
        import exudyn as exu
    except ImportError:
        return None
    times, out = [], None
    for _ in range(repeats):
        model = _exudyn_model(exu, res, h, end)
        start = time.perf_counter()
        ok = model["mbs"].SolveDynamic(model["settings"])
        times.append(time.perf_counter() - start)
        out = model
        if ok is False:
            return {"error": float("nan"), "seconds": times[-1], "failed": True}
    mbs, ovt = out["mbs"], exu.OutputVariableType
    t = None
    b0 = None
    if name.startswith("nfourbar"):
        data = np.asarray(mbs.GetSensorStoredData(out["sensor"]))
        t, b0 = data[:, 0], data[:, 1:3]
    theta = {k: float(mbs.GetNodeOutput(node, ovt.Rotation)[2]) for k, node in out["nodes"].items()}
    if t is None:
        t = np.array([0.0, out["end"]])
    return {
        "seconds": statistics.median(times),
        "error": _error(name, t, b0, theta),
        "failed": False,
    }


def _exudyn_model(exu: Any, res: Any, h: float, end: float) -> dict:
    """Every link a rigid body at mechsolve's start (pose and rates), every pin a
    revolute joint, the loads as compiled elements."""
    import exudyn.itemInterface as eii

    from mechsolve.model import PinJoint, Spring, Torque

    mech, mb, tr = res.mechanism, res.multibody, res.trajectory
    idx = mb.system.index
    q0, qd0 = tr.q[0], tr.qd[0]
    gx, gy = mech.gravity_vector()
    mbs_container = exu.SystemContainer()
    mbs = mbs_container.AddSystem()
    ground = mbs.AddObject(eii.ObjectGround())
    bodies, nodes = {}, {}
    links = {lk.name: lk for lk in mech.links}
    for lk in mech.links:
        b = idx[lk.name]
        x, y, th = q0[3 * b : 3 * b + 3]
        vx, vy, w = qd0[3 * b : 3 * b + 3]
        c, s = math.cos(th), math.sin(th)
        sx, sy = np.asarray(lk.com, float)
        rx, ry = c * sx - s * sy, s * sx + c * sy
        node = mbs.AddNode(
            eii.NodeRigidBody2D(
                referenceCoordinates=[x + rx, y + ry, th],
                initialVelocities=[vx - w * ry, vy + w * rx, w],
            )
        )
        body = mbs.AddObject(
            eii.ObjectRigidBody2D(mass=lk.mass, inertia=lk.inertia or 0.0, nodeNumber=node)
        )
        if gx or gy:
            mm = mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=body))
            mbs.AddLoad(eii.LoadMassProportional(markerNumber=mm, loadVector=[gx, gy, 0]))
        bodies[lk.name], nodes[lk.name] = body, node

    def marker(link: str, point: str, kind: Any = eii.MarkerBodyPosition) -> Any:
        if link == "ground":
            x, y = mech.ground[point]
            return mbs.AddMarker(kind(bodyNumber=ground, localPosition=[x, y, 0]))
        lk = links[link]
        loc = np.asarray(lk.points[point], float) - np.asarray(lk.com, float)
        return mbs.AddMarker(kind(bodyNumber=bodies[link], localPosition=[loc[0], loc[1], 0]))

    for joint in mech.joints:
        if not isinstance(joint, PinJoint):
            raise NotImplementedError(f"joint {joint.name!r}: only pins are translated")
        pair = [marker(joint.a, joint.point), marker(joint.b, joint.point)]
        mbs.AddObject(eii.ObjectJointRevolute2D(markerNumbers=pair))
    for load in mech.loads:
        if isinstance(load, Torque):
            m = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=bodies[load.link]))
            mbs.AddLoad(eii.LoadTorqueVector(markerNumber=m, loadVector=[0, 0, load.torque]))
        elif isinstance(load, Spring):
            (la, pa), (lb, pb) = load.ends
            mbs.AddObject(
                eii.ObjectConnectorSpringDamper(
                    markerNumbers=[marker(la, pa), marker(lb, pb)],
                    stiffness=load.stiffness,
                    referenceLength=load.free_length,
                )
            )
        else:
            raise NotImplementedError(f"load {load.name!r} ({type(load).__name__})")
    sensor = None
    if "crank0" in links:
        loc = np.asarray(links["crank0"].points["B0"], float) - np.asarray(
            links["crank0"].com, float
        )
        sensor = mbs.AddSensor(
            eii.SensorBody(
                bodyNumber=bodies["crank0"],
                localPosition=[loc[0], loc[1], 0],
                outputVariableType=exu.OutputVariableType.Position,
                storeInternal=True,
                writeToFile=False,
            )
        )
    mbs.Assemble()
    steps = int(round(end / h))
    settings = exu.SimulationSettings()
    integ = settings.timeIntegration
    integ.endTime, integ.numberOfSteps, integ.verboseMode = steps * h, steps, 0
    integ.generalizedAlpha.spectralRadius = 0.9
    integ.generalizedAlpha.computeInitialAccelerations = True
    integ.newton.useModifiedNewton = False
    integ.adaptiveStep = False
    for paths, value in (
        (("solution.file.write", "solutionSettings.writeSolutionToFile"), False),
        (("solution.sensors.writePeriod", "solutionSettings.sensorsWritePeriod"), h),
        (("show.computationTime", "displayComputationTime"), False),
        (("show.statistics", "displayStatistics"), False),
        (
            ("linearSolver.ignoreSingularJacobian", "linearSolverSettings.ignoreSingularJacobian"),
            True,
        ),
    ):
        _set_setting(settings, paths, value)
    return {
        "mbs": mbs,
        "container": mbs_container,
        "settings": settings,
        "sensor": sensor,
        "nodes": nodes,
        "end": steps * h,
    }


def case_multibody(quick: bool) -> Case | None:
    """Both problems, each solver at the loosest setting within :data:`PRECISION`."""
    case = Case("multibody", "forward dynamics, IFToMM planar benchmarks, against exudyn")
    problems = (("nfourbar-2", 10.0), ("andrews", 0.03))
    repeats = 1 if quick else 3
    for name, end in problems:
        end = min(end, 0.001 if name == "andrews" else 0.05) if quick else end
        ours = None
        for rtol in RTOLS[:1] if quick else RTOLS:
            ours = mechsolve_run(name, rtol, end, 1)
            if quick or ours["error"] <= PRECISION:
                ours = mechsolve_run(name, rtol, end, repeats)
                break
        case.rows.append(
            Row(
                f"{name}: mechsolve DOP853, rtol {rtol:g} ({ours['nfev']} evaluations)",
                ours["seconds"],
                {"angle/position": ours["error"]},
            )
        )
        fast = None
        for rtol_r in RTOLS[:1] if quick else RTOLS:
            fast = reduced_run(name, rtol_r, end, 1)
            if quick or fast["error"] <= PRECISION:
                fast = reduced_run(name, rtol_r, end, repeats)
                break
        case.rows.append(
            Row(
                f"{name}: mechsolve reduced (1 DOF), DOP853, rtol {rtol_r:g}",
                fast["seconds"],
                {"angle/position": fast["error"]},
            )
        )
        theirs, used = None, None
        for h in STEPS[name][:1] if quick else STEPS[name]:
            theirs = exudyn_run(name, ours["result"], min(h, end), end, 1)
            if theirs is None:
                break
            used = min(h, end)
            if quick or (not theirs["failed"] and theirs["error"] <= PRECISION):
                theirs = exudyn_run(name, ours["result"], used, end, repeats)
                break
        if theirs is None:
            case.lines.append(f"{name}: exudyn not installed (pip install 'mechsolve[bench]')")
            continue
        case.rows.append(
            Row(
                f"{name}: exudyn generalized-alpha, h = {used:g} s",
                theirs["seconds"],
                {"angle/position": theirs["error"]},
                "failed" if theirs["failed"] else "",
            )
        )
        for label, mine in (("mechsolve", ours), ("mechsolve reduced", fast)):
            ratio = theirs["seconds"] / mine["seconds"]
            case.lines.append(
                f"{name} ({end:g} s): time exudyn / {label} = {ratio:.2f} "
                f"({'mechsolve faster' if ratio >= 1 else 'mechsolve SLOWER'}); errors: "
                f"{label} {mine['error']:.1e}, exudyn {theirs['error']:.1e} "
                f"(precision {PRECISION:g} m or rad)"
            )
    return case
