"""Issue 26: forward dynamics of any planar mechanism in body coordinates (``mechsolve
simulate``'s general path), against closed forms, conservation of energy, the IFToMM
N-four-bar benchmark (its problem data; its motion in closed form) and the 1-DOF path."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp
from scipy.special import ellipk

import mechsolve as ms
from mechsolve.analyses.dynamics import simulate
from mechsolve.cli.main import main

from conftest import MECH

G = 9.81

PENDULUM = """
name: pendulum
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], P: [1, 0]}, mass: 1 kg, com: P}   # a point mass on a pin
joints:
  O: [ground, bar]
driver: {joint: O, start: 30 deg}      # 120 deg from the bottom
gravity: 9.81 m/s^2
simulate: {duration: 1.5 s, step: 0.005 s, method: DOP853, rtol: 1e-11, atol: 1e-13}
"""

# a parallelogram with a third parallel crank: one redundant constraint (the file of
# tests/test_hard_cases.py), released from rest under gravity
REDUNDANT = """
ground: {O2: [0, 0], O4: [3, 0], O6: [1.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [1, 0]}, mass: 2, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [3, 0], C: [1.5, 0]}, mass: 6, uniform_bar: [A, B]}
  crank2: {points: {O4: [0, 0], B: [1, 0]}, mass: 2, uniform_bar: [O4, B]}
  crank3: {points: {O6: [0, 0], C: [1, 0]}, mass: 3, uniform_bar: [O6, C]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, crank2]
  O4: [ground, crank2]
  C: [coupler, crank3]
  O6: [ground, crank3]
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 20 deg}
gravity: 9.81 m/s^2
simulate: {duration: 1.2 s, step: 0.01 s, method: DOP853, rtol: 1e-10, atol: 1e-12%s}
"""

# a crank-rocker four-bar on a spring, no damping: conservative
SPRUNG = """
units: {length: m, angle: deg}
ground: {O2: [0, 0], O4: [0.8, 0], S: [0.4, 0.9]}
links:
  crank: {points: {O2: [0, 0], A: [0.25, 0]}, mass: 1, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [0.9, 0], P: [0.45, 0.2]}, mass: 3, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [0.6, 0]}, mass: 2, uniform_bar: [O4, B]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 40 deg}
gravity: 9.81 m/s^2
loads:
  lift: {spring: [S, P], stiffness: %s N/m, free_length: 0.3 m}
simulate: {duration: %s s, step: 0.02 s, method: DOP853, rtol: 1e-10, atol: 1e-12,
           from: 3 rad/s%s}
"""


def test_pendulum_period_against_the_elliptic_integral():
    """A link on a pin released 120 deg from the bottom: it turns back after half the
    period T = 4 sqrt(L/g) K(k), k = sin(120 deg / 2)."""
    res = simulate(ms.loads(PENDULUM))
    tr = res.trajectory
    w = tr.ud
    k = int(np.flatnonzero((w[1:] >= 0) & (w[:-1] < 0) & (tr.t[1:] > 0.1))[0])
    # the rate is linear in time at a turning point to O(h^3): linear interpolation
    t_half = tr.t[k] - w[k] * (tr.t[k + 1] - tr.t[k]) / (w[k + 1] - w[k])
    period = 4 * math.sqrt(1.0 / G) * ellipk(math.sin(math.radians(60)) ** 2)
    assert 2 * t_half == pytest.approx(period, abs=2e-7)
    # the first integral at every output: omega^2 = 2 g / L (sin 30 deg - sin theta)
    hand = 2 * G * (0.5 - np.sin(tr.u))
    np.testing.assert_allclose(w**2, hand, rtol=0, atol=1e-9 * np.max(hand))
    assert np.max(tr.violation) <= 1e-10


def test_redundant_parallelogram_released_under_gravity_moves_as_one_pendulum():
    """Every crank turns alike and the coupler translates, so the machine is one
    pendulum: I theta''  = -M_g cos(theta) with I = sum m l^2 / 3 + m_coupler l^2 and
    M_g = g (sum m l / 2 + m_coupler l); its first integral holds at every output."""
    res = simulate(ms.loads(REDUNDANT % ""))
    tr = res.trajectory
    assert tr.redundant and not tr.early
    I = (2 + 2 + 3) / 3 + 6 * 1.0
    Mg = G * ((2 + 2 + 3) * 0.5 + 6 * 1.0)
    th = tr.u
    hand = 2 * Mg / I * (math.sin(math.radians(20)) - np.sin(th))
    np.testing.assert_allclose(tr.ud**2, hand, rtol=0, atol=1e-7 * np.max(hand))
    # and the motion itself against the scalar equation integrated on its own
    ref = solve_ivp(
        lambda t, y: [y[1], -Mg / I * math.cos(y[0])],
        (0, tr.t[-1]),
        [math.radians(20), 0.0],
        t_eval=tr.t,
        rtol=1e-12,
        atol=1e-12,
    )
    np.testing.assert_allclose(th, ref.y[0], atol=1e-7)
    for crank in ("crank2", "crank3"):
        np.testing.assert_allclose(res.link(crank).angle, th, atol=1e-9)
    np.testing.assert_allclose(res.link("coupler").angle, 0.0, atol=1e-9)
    headers = [c.header for c in res.columns()]
    assert "O6(ground->crank3).Fx [N] (minimum-norm)" in headers
    assert "minimum-norm" in res.summary()
    # the force analysis of the motion needs no driving torque: it is free
    assert np.max(np.abs(res.driving_effort)) < 1e-6 * Mg


def test_rates_of_other_joints_are_checked_against_the_constraints():
    res = simulate(ms.loads(REDUNDANT % ", rates: {O4: 2 rad/s}"))
    assert res.trajectory.ud[0] == pytest.approx(2.0, abs=1e-12)  # crank = crank2's rate


def test_conservative_machine_keeps_its_energy_for_10_s():
    """No damping, no motor: T + V (gravity and the spring) stays constant to the
    integrator's tolerance over 10 s; the constraints hold to their tolerance."""
    res = simulate(ms.loads(SPRUNG % (400, 10, "")))
    tr = res.trajectory
    assert tr.t[-1] == pytest.approx(10.0) and not tr.early
    E = tr.kinetic + tr.potential
    assert np.max(np.abs(tr.work)) == 0.0  # nothing non-conservative acts
    assert np.max(np.abs(E - E[0])) < 1e-6 * np.max(np.abs(tr.kinetic))
    assert np.max(tr.violation) <= res.multibody.tol
    assert np.max(tr.velocity_violation) < 1e-12


def _pendulum_reference(n: int, t: np.ndarray) -> np.ndarray:
    """The N-four-bar's crank angle in closed form: its windows are parallelograms, so
    it is one pendulum with I = (N + 1) m l^2 / 3 + N m l^2 and M_g = g m l ((N + 1) / 2
    + N), starting upright at -1 rad/s (B0 along +x at 1 m/s)."""
    inertia = (n + 1) / 3 + n
    mg = G * ((n + 1) / 2 + n)
    sol = solve_ivp(
        lambda _, y: [y[1], -mg / inertia * math.cos(y[0])],
        (0, t[-1]),
        [math.pi / 2, -1.0],
        t_eval=t,
        rtol=1e-13,
        atol=1e-13,
        method="DOP853",
    )
    return sol.y[0]


@pytest.mark.parametrize("n", [1, 2])
def test_iftomm_n_four_bar_through_its_singular_positions(n):
    """The IFToMM benchmark A02 (2N + 1 bars of 1 m and 1 kg, g = 9.81, B0 at 1 m/s
    along +x), 10 s: B0's path within the benchmark's high precision (1e-3 m) of the
    closed form, through the horizontal positions where the equations lose rank."""
    res = simulate(ms.load(MECH / f"nfourbar-{n}.yaml"))
    tr = res.trajectory
    assert tr.t[-1] == pytest.approx(10.0) and not tr.early
    th = _pendulum_reference(n, tr.t)
    b0 = res.point("B0")
    assert np.max(np.abs(b0.x - np.cos(th))) < 1e-3
    assert np.max(np.abs(b0.y - np.sin(th))) < 1e-3
    assert np.max(np.abs(tr.energy_residual)) < 1e-3
    assert np.max(tr.violation) <= res.multibody.tol
    # it turns over: about 4.4 turns clockwise in 10 s
    assert (th[-1] - th[0]) / (2 * math.pi) < -4


def test_seed_004_multibody_and_reduced_paths_give_the_same_motion():
    """The motor-driven six-link machine of seed 004 on both paths, each to rtol 1e-10."""
    import copy

    mech = ms.load(MECH / "motor-linkage.yaml")
    sim = mech.simulation
    sim.duration, sim.step, sim.method, sim.rtol, sim.atol = 0.3, 0.01, "DOP853", 1e-10, 1e-12
    reduced = simulate(mech, exact=True).trajectory
    mb_mech = copy.copy(mech)
    mb_mech.simulation = copy.copy(sim)
    mb_mech.simulation.formulation = "multibody"
    general = simulate(mb_mech).trajectory
    np.testing.assert_allclose(general.t, reduced.t, atol=1e-12)
    np.testing.assert_allclose(general.u, reduced.phi, atol=1e-8)
    np.testing.assert_allclose(general.ud, reduced.omega, atol=1e-6)


def test_shaper_with_its_switching_cutting_force_on_both_paths():
    """The shaper (sliders, a flywheel, a cutting force that acts between 5 % and 95 %
    of the stroke while the ram moves forward): both paths to rtol 1e-10, 0.3 s."""
    import copy

    mech = ms.load(MECH / "shaper.yaml")
    sim = mech.simulation
    sim.duration, sim.step, sim.method, sim.rtol, sim.atol = 0.3, 0.01, "DOP853", 1e-10, 1e-12
    reduced = simulate(mech, exact=True).trajectory
    mb_mech = copy.copy(mech)
    mb_mech.simulation = copy.copy(sim)
    mb_mech.simulation.formulation = "multibody"
    res = simulate(mb_mech)
    general = res.trajectory
    np.testing.assert_allclose(general.u, reduced.phi, atol=1e-9)
    np.testing.assert_allclose(general.ud, reduced.omega, atol=1e-8)
    assert res.forces.active["cutting"].any() and not res.forces.active["cutting"].all()
    assert np.max(np.abs(general.energy_residual)) < 1e-6


def _invoke(tmp_path, text: str, name: str = "m.yaml", *extra: str):
    f = tmp_path / name
    f.write_text(text)
    return CliRunner().invoke(
        main, ["simulate", str(f), "-o", str(tmp_path / "o"), "--no-plots", *extra]
    )


def test_cli_free_motion_writes_the_energy_balance_and_the_violation(tmp_path):
    r = _invoke(tmp_path, SPRUNG % (400, 0.4, ""), "m.yaml", "--units", "SI")
    assert r.exit_code == 0, r.output
    assert "energy balance: T + V - W changed by at most" in r.output
    assert "largest constraint violation" in r.output and "free motion" in r.output
    header = (tmp_path / "o" / "simulation.csv").read_text().splitlines()[0]
    for col in ("energy.residual [J]", "constraint.violation [m]", "omega [rad/s]"):
        assert col in header


@pytest.mark.parametrize(
    "text, words",
    [
        (SPRUNG % (400, 1, ", rates: {O4: 50 rad/s}"), "not consistent with the constraints"),
        (SPRUNG % (400, 1, ", tolerance: 0 m"), "simulate.tolerance: must be positive"),
        ((SPRUNG % (400, 1, "")).replace("rtol: 1e-10", "rtol: 0"), "rtol must be a number"),
        (SPRUNG % (-400, 1, ""), "loads.lift.stiffness: a spring's stiffness must be zero"),
        (SPRUNG % (400, 1, ", rates: {X: 1 rad/s}"), "no joint 'X'"),
    ],
)
def test_bad_input_is_refused_with_a_clear_message(tmp_path, text, words):
    r = _invoke(tmp_path, text)
    assert r.exit_code == 2, r.output
    assert words in r.output and "Traceback" not in r.output


DOUBLE = """
name: double pendulum
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  upper: {points: {O: [0, 0], A: [1, 0]}, mass: 2 kg, com: A}
  lower: {points: {A: [0, 0], B: [0.7, 0]}, mass: 1 kg, com: B}
joints:
  O: [ground, upper]
  A: [upper, lower]
gravity: 9.81 m/s^2
"""


def test_two_degrees_of_freedom_double_pendulum_against_lagranges_equations():
    """The engine has no limit on the degrees of freedom: a double pendulum of point
    masses (2 DOF, chaotic at this energy) against its textbook equations of motion."""
    from mechsolve.analyses.dynamics.multibody import Multibody, free_context
    from mechsolve.analyses.dynamics.multibody_integrate import integrate

    mech = ms.loads(DOUBLE)
    mb = Multibody(free_context(mech))
    m1, m2, l1, l2 = 2.0, 1.0, 1.0, 0.7
    a1, a2, w1, w2 = math.radians(-20), math.radians(60), 0.5, -1.0
    q0 = np.array([0, 0, a1, l1 * math.cos(a1), l1 * math.sin(a1), a2])
    qd0 = np.array([0, 0, w1, -l1 * w1 * math.sin(a1), l1 * w1 * math.cos(a1), w2])
    tr = integrate(mb, q0, qd0, 3.0, step=0.01, rtol=1e-11, atol=1e-13)
    assert not tr.early and np.max(tr.violation) <= mb.tol

    def lagrange(_, y):  # angles from the x axis, gravity along -y
        t1, t2, u1, u2 = y
        d = t1 - t2
        a = np.array([[(m1 + m2) * l1, m2 * l2 * math.cos(d)], [l1 * math.cos(d), l2]])
        b = np.array(
            [
                -m2 * l2 * u2**2 * math.sin(d) - (m1 + m2) * G * math.cos(t1),
                l1 * u1**2 * math.sin(d) - G * math.cos(t2),
            ]
        )
        return [u1, u2, *np.linalg.solve(a, b)]

    ref = solve_ivp(lagrange, (0, 3), [a1, a2, w1, w2], t_eval=tr.t, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(tr.q[:, 2], ref.y[0], atol=1e-6)
    np.testing.assert_allclose(tr.q[:, 5], ref.y[1], atol=1e-6)
    E = tr.kinetic + tr.potential
    assert np.max(np.abs(E - E[0])) < 1e-8 * np.max(tr.kinetic)


def test_sprung_four_bar_against_exudyn():
    """A second, independent code: exudyn (index-3 generalized-alpha, its own rigid
    bodies, revolute joints, gravity and a spring-damper connector) on the same sprung
    four-bar from the same initial state, 1 s: the rocker's angle agrees to 1e-7 rad."""
    exu = pytest.importorskip("exudyn")
    import exudyn.itemInterface as eii

    res = simulate(ms.loads(SPRUNG % (400, 1, "")))
    tr, mb = res.trajectory, res.multibody
    mech = res.mechanism
    index = mb.system.index
    container = exu.SystemContainer()
    mbs = container.AddSystem()
    ground = mbs.AddObject(eii.ObjectGround())
    markers = {}

    def ground_marker(name):
        x, y = mech.ground[name]
        return mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=ground, localPosition=[x, y, 0]))

    nodes = {}
    for lk in mech.links:
        b = index[lk.name]
        x, y, th = tr.q[0, 3 * b : 3 * b + 3]
        vx, vy, w = tr.qd[0, 3 * b : 3 * b + 3]
        s = np.asarray(lk.com, float)
        c, sn = math.cos(th), math.sin(th)
        r = np.array([c * s[0] - sn * s[1], sn * s[0] + c * s[1]])
        node = mbs.AddNode(
            eii.NodeRigidBody2D(
                referenceCoordinates=[x + r[0], y + r[1], th],
                initialVelocities=[vx - w * r[1], vy + w * r[0], w],
            )
        )
        nodes[lk.name] = node
        body = mbs.AddObject(
            eii.ObjectRigidBody2D(mass=lk.mass, inertia=lk.inertia, nodeNumber=node)
        )
        mbs.AddLoad(
            eii.LoadMassProportional(
                markerNumber=mbs.AddMarker(eii.MarkerBodyMass(bodyNumber=body)),
                loadVector=[0, -G, 0],
            )
        )
        for p, xy in lk.points.items():
            local = [xy[0] - s[0], xy[1] - s[1], 0]
            markers[lk.name, p] = mbs.AddMarker(
                eii.MarkerBodyPosition(bodyNumber=body, localPosition=local)
            )
    for j in mech.joints:
        ends = []
        for link in (j.a, j.b):
            ends.append(ground_marker(j.point) if link == "ground" else markers[link, j.point])
        mbs.AddObject(eii.ObjectJointRevolute2D(markerNumbers=ends))
    mbs.AddObject(
        eii.ObjectConnectorSpringDamper(
            markerNumbers=[ground_marker("S"), markers["coupler", "P"]],
            stiffness=400,
            damping=0,
            referenceLength=0.3,
        )
    )
    sensor = mbs.AddSensor(
        eii.SensorNode(
            nodeNumber=nodes["rocker"],
            outputVariableType=exu.OutputVariableType.Rotation,
            storeInternal=True,
        )
    )
    mbs.Assemble()
    settings = exu.SimulationSettings()
    settings.timeIntegration.endTime = 1.0
    settings.timeIntegration.numberOfSteps = 20000
    settings.timeIntegration.verboseMode = 0
    settings.timeIntegration.generalizedAlpha.spectralRadius = 1.0
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = 0.02
    exu.SolveDynamic(mbs, settings)
    data = mbs.GetSensorStoredData(sensor)
    theirs = np.interp(tr.t, data[:, 0], data[:, -1])  # the rotation about z
    ours = tr.q[:, 3 * index["rocker"] + 2]
    assert np.ptp(ours) > 0.05  # it swings (0.093 rad)
    assert np.max(np.abs(ours - theirs)) < 1e-7  # 1.2e-8 met


TWO = """
name: two pendulums, two motors
units: {length: m, angle: deg}
ground: {O: [0, 0], Q: [3, 0]}
links:
  one: {points: {O: [0, 0], P: [1, 0]}, mass: 2 kg, com: P}
  two: {points: {Q: [0, 0], R: [0.5, 0]}, mass: 1 kg, com: R}
joints:
  O: [ground, one]
  Q: [ground, two]
gravity: 9.81 m/s^2
motors:
  first: {joint: O, stall: 30 N m, slope: 4 N m s}
  second: {joint: Q, torque: "-2 - 0.5 * omega"}
simulate: {duration: 2 s, step: 0.02 s, method: DOP853, rtol: 1e-11, atol: 1e-13,
           pose: {O: 10 deg, Q: -30 deg}%s}
"""


def test_two_uncoupled_pendulums_each_driven_by_its_motor():
    """Two degrees of freedom placed by ``pose``, two motors with their own laws: each
    pendulum follows its own scalar equation m L^2 theta'' = M(omega) - m g L cos theta."""
    res = simulate(ms.loads(TWO % ", rates: {Q: 1 rad/s}"))
    tr, mb = res.trajectory, res.multibody
    assert not tr.early and np.max(tr.violation) <= mb.tol
    for link, m, L, law, th0, w0 in (
        ("one", 2.0, 1.0, lambda w: 30 - 4 * w, 10, 0.0),
        ("two", 1.0, 0.5, lambda w: -2 - 0.5 * w, -30, 1.0),
    ):
        ref = solve_ivp(
            lambda _, y, m=m, L=L, law=law: [
                y[1],
                (law(y[1]) - m * G * L * math.cos(y[0])) / (m * L * L),
            ],
            (0, 2),
            [math.radians(th0), w0],
            t_eval=tr.t,
            rtol=1e-12,
            atol=1e-12,
        )
        k = 3 * mb.system.index[link] + 2
        np.testing.assert_allclose(tr.q[:, k], ref.y[0], atol=1e-7)
    # the motors' work is in the balance
    assert np.max(np.abs(tr.energy_residual)) < 1e-6 * np.max(np.abs(tr.work))


def test_cli_pose_placed_machine_with_two_motors(tmp_path):
    r = _invoke(tmp_path, TWO % "")
    assert r.exit_code == 0, r.output
    assert (
        "2 degree(s) of freedom" in r.output
        and "first (M = 30 N·m - 4 N·m·s * omega on O)" in r.output
    )
    header = (tmp_path / "o" / "simulation.csv").read_text().splitlines()[0]
    assert "first.effort [N*m]" in header and "O.Fx [N]" in header


@pytest.mark.parametrize(
    "extra, words",
    [
        ("pose: {O: 10 deg}", "2 degree(s) of freedom here: give one joint coordinate"),
        ("pose: {O: 10 deg, Q: 3 m}", "the joint 'Q' needs an angle"),
    ],
)
def test_a_pose_must_give_one_coordinate_per_degree_of_freedom(tmp_path, extra, words):
    text = (TWO % "").replace("pose: {O: 10 deg, Q: -30 deg}", extra)
    r = _invoke(tmp_path, text)
    assert r.exit_code == 2, r.output
    assert words in r.output


DRIVEN = """
name: a driven crank with a free pendulum on it
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [0.3, 0]}, mass: 5 kg, uniform_bar: [O, A]}
  bob: {points: {A: [0, 0], P: [0.8, 0]}, mass: 1.5 kg, com: P}
joints:
  O: [ground, crank]
  A: [crank, bob]
driver: {joint: O, speed: 4 rad/s, start: 20 deg}   # prescribed
gravity: 9.81 m/s^2
simulate: {duration: 3 s, step: 0.02 s, method: DOP853, rtol: 1e-11, atol: 1e-13,
           pose: {A: -70 deg}}
"""


def test_prescribed_crank_with_a_free_pendulum_on_it():
    """The crank turns at 4 rad/s (prescribed), the pendulum on its tip is free: its
    angle phi (from x) obeys L phi'' = a_x sin(phi) - (g + a_y) cos(phi), with the tip's
    acceleration a = -w^2 r (a point mass); the energy balance holds with the work the
    prescribed motion puts in."""
    res = simulate(ms.loads(DRIVEN))
    tr, mb = res.trajectory, res.multibody
    assert not tr.early and np.max(tr.violation) <= mb.tol
    w, r, L = 4.0, 0.3, 0.8
    th0 = math.radians(20)
    np.testing.assert_allclose(tr.q[:, 2], th0 + w * tr.t, atol=1e-9)

    def pend(t, y):
        ax, ay = -(w**2) * r * math.cos(th0 + w * t), -(w**2) * r * math.sin(th0 + w * t)
        return [y[1], (ax * math.sin(y[0]) - (G + ay) * math.cos(y[0])) / L]

    phi0 = th0 + math.radians(-70)
    ref = solve_ivp(pend, (0, 3), [phi0, w], t_eval=tr.t, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(tr.q[:, 5], ref.y[0], atol=1e-7)
    assert np.max(np.abs(tr.energy_residual)) < 1e-7 * np.max(np.abs(tr.work))


def test_flywheel_check_keeps_the_reduced_path_under_formulation_multibody(tmp_path):
    """`mechsolve flywheel` checks its flywheel by simulating the driver's motion: a file
    that asks simulate for the multibody formulation still gets that check."""
    text = (MECH / "shaper.yaml").read_text()
    text = text.replace(
        "method: rk4, from: 60 rpm}", "method: rk4, from: 60 rpm, formulation: multibody}"
    )
    assert "formulation: multibody" in text
    f = tmp_path / "shaper.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["flywheel", str(f), "-o", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert "checked by simulation with this flywheel: delta reached" in r.output


def test_motors_or_a_pose_take_the_general_path_and_the_reduced_one_refuses_them(tmp_path):
    text = (MECH / "motor-linkage.yaml").read_text()
    extra = "motors:\n  second: {joint: O1, stall: 1 N m, slope: 0.1 N m s}\n"
    mech = ms.loads(
        text.replace("simulate: {duration: 2.2 s", "simulate: {duration: 0.02 s") + extra
    )
    res = simulate(mech)  # two motors: the general path, not the driver's one equation
    assert (
        res.multibody is not None
        and "second (M = 1 N*m - 0.1 N*m*s * omega on O1)" in res.summary()
    )
    bad = text.replace("from: rest}", "from: rest, formulation: reduced}") + extra
    r = _invoke(tmp_path, bad)
    assert r.exit_code == 2 and "motors: needs formulation: multibody" in r.output, r.output


def test_the_bridge_across_a_singular_position_keeps_the_motion():
    """At rtol 1e-11 the N-four-bar's first pass through the horizontal position is met
    where no partition closes: that output step is bridged on all coordinates and
    projected, and the motion stays on its closed form to 1e-7 m."""
    mech = ms.load(MECH / "nfourbar-1.yaml")
    sim = mech.simulation
    sim.duration, sim.rtol, sim.atol = 3.0, 1e-11, 1e-13
    res = simulate(mech)
    tr = res.trajectory
    assert tr.bridges >= 1 and not tr.early
    th = _pendulum_reference(1, tr.t)
    b0 = res.point("B0")
    assert np.max(np.abs(b0.x - np.cos(th))) < 1e-7
    assert np.max(np.abs(b0.y - np.sin(th))) < 1e-7
    assert "bridged across singular positions" in res.summary()


def test_run_from_the_singular_horizontal_position_prints_no_nan(tmp_path):
    """`run` of the N-four-bar from its singular horizontal position: the rates at the
    start are not determined, so no speed is printed for a point that has none (it
    printed '|v| max nan m/s' and warned on an all-NaN slice)."""
    text = (MECH / "nfourbar-2.yaml").read_text().replace("start: 90 deg", "start: 0 deg")
    f = tmp_path / "n2.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert "nan" not in r.output
