"""Forward dynamics (``mechsolve simulate``) against the seed's printed start-up, its
recomputed reference data, conservation of energy and independently written ODEs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp

import mechsolve as ms
from mechsolve.analyses.dynamics import ReducedModel, simulate
from mechsolve.cli.main import main

from conftest import MECH, ref


@pytest.fixture(scope="module")
def seed004():
    return simulate(ms.load(MECH / "motor-linkage.yaml"))


def test_seed_004_startup_to_every_printed_digit(seed004):
    """Start from rest, M = 50 - 1.25 omega, RK4 with h = 0.002 s to 2.2 s: the seed's
    printed extremes are values on that grid (Бертяев et al., pp. 275-281)."""
    tr = seed004.trajectory
    printed = ref("004_mathcad_startup.json")["printed_in_seed"]
    assert round(float(np.max(tr.omega)), 4) == printed["max_omega"]
    assert round(float(np.min(tr.eps)), 4) == printed["min_eps"]
    assert round(float(np.max(tr.eps)), 4) == printed["max_eps"]
    assert tr.t[int(np.argmax(tr.omega))] == pytest.approx(1.682)
    assert len(tr.t) == 1101 and seed004.ok.all()


def test_seed_004_trajectory_and_reactions_against_the_re_solution(seed004):
    data = ref("004_mathcad_startup.json")
    rows = np.array(data["values_every_10th_step"])
    cols = data["columns"]
    tr = seed004.trajectory
    k = np.arange(0, len(tr.t), 10)
    np.testing.assert_allclose(tr.t[k], rows[:, cols.index("t")], atol=1e-12)
    np.testing.assert_allclose(tr.phi[k], rows[:, cols.index("phi")], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(tr.omega[k], rows[:, cols.index("omega")], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(tr.eps[k], rows[:, cols.index("eps")], rtol=1e-7, atol=1e-6)
    O, O1 = seed004.reaction("O"), seed004.reaction("O1")
    for name, r in (("R_Ox", O["Fx"]), ("R_Oy", O["Fy"]), ("R_O1x", O1["Fx"]), ("R_O1y", O1["Fy"])):
        np.testing.assert_allclose(r[k], rows[:, cols.index(name)], rtol=1e-6, atol=1e-5)
    s = data["recomputed_summary"]
    assert np.max(O["F"]) == pytest.approx(s["max_abs_R_O_N"], rel=1e-6)
    assert np.max(O1["F"]) == pytest.approx(s["max_abs_R_O1_N"], rel=1e-6)


def test_seed_004_reduced_inertia_curve(seed004):
    data = ref("004_mathcad_reduced_inertia.json")
    phi, J, dJ = seed004.model.inertia_curve()
    want = np.asarray(data["phi"])
    got_J = np.interp(want, phi - phi[0], J)
    got_dJ = np.interp(want, phi - phi[0], dJ)
    # the reference is tabulated every 2 deg; the model every 1 deg (interpolated here)
    np.testing.assert_allclose(got_J[::2], np.asarray(data["J"])[::2], rtol=1e-9)
    np.testing.assert_allclose(got_dJ[::2], np.asarray(data["dJ"])[::2], atol=1e-9)


def test_the_motor_law_is_the_driving_torque_of_the_force_analysis(seed004):
    """Along the simulated motion, the driver torque that the kinetostatic analysis needs
    is the motor's torque: the dynamics and the force analysis agree."""
    M = seed004.motor_torque()
    np.testing.assert_allclose(seed004.driving_effort, M, rtol=0, atol=1e-8 * np.max(np.abs(M)))


def test_the_states_along_the_motion_are_a_sweep_over_its_turns(seed004):
    """The states along the motion are solved within the reference turn and carried on
    by whole turns: they must equal the sweep's own continuation over the many turns of
    the start-up (angles running on, not wrapped), and close the constraints."""
    from mechsolve.core import evaluate as core

    tr, sol = seed004.trajectory, seed004.solution
    assert tr.phi[-1] - tr.phi[0] > 10 * 2 * np.pi
    full = core.states(seed004.model.an, tr.phi, tr.omega, tr.eps, t=tr.t)
    for k in range(11):  # x, y, angle, cos, sin, and the rates
        a, b = sol.state.block[k], full.state.block[k]
        assert np.max(np.abs(a - b)) <= 1e-9 * (1 + np.max(np.abs(b))), k
    assert np.nanmax(sol.residual) < 1e-12
    np.testing.assert_array_equal(sol.u, tr.phi)


def test_tabulated_and_exact_equations_of_motion_agree():
    mech = ms.load(MECH / "motor-linkage.yaml")
    mech.simulation.duration = 0.2
    a = simulate(mech).trajectory
    b = simulate(mech, exact=True).trajectory
    # the table is the trigonometric interpolant of the force analysis's samples, to
    # 1e-11 of the largest effort: the motion agrees with the exact one to about that
    scale_w, scale_e = np.max(np.abs(b.omega)), np.max(np.abs(b.eps))
    np.testing.assert_allclose(a.omega, b.omega, rtol=0, atol=1e-10 * scale_w)
    np.testing.assert_allclose(a.eps, b.eps, rtol=0, atol=3e-10 * scale_e)


def test_the_tables_interpolant_against_closed_forms():
    """A smooth periodic function is found to rounding from a few hundred samples
    (exp(cos x): its harmonics fall faster than geometrically), and the integrator's
    Hermite table reproduces it and its slope between the grid points; a function with a
    kink in its third derivative (|sin x|^3) never converges and is returned unconverged
    at the largest grid."""
    from mechsolve.analyses.dynamics import _harmonics, _spectral_samples, _Table

    def smooth(x):
        return np.array([np.exp(np.cos(x)), 3.0 + np.sin(2 * x)])

    calls = []

    def sample(x):
        calls.append(len(x))
        return smooth(x)

    n0 = 360
    V, converged = _spectral_samples(sample, smooth(2 * np.pi * np.arange(n0) / n0), 1e-11)
    assert converged and V.shape == (2, n0) and calls == []
    tab = _Table.trigonometric(_harmonics(V), 1e-11)
    assert tab.intervals % 24 == 0
    x = np.random.default_rng(1).uniform(0, 2 * np.pi, 2000)
    size = np.array([[np.e], [4.0]])  # each column to 1e-11 of its own size
    assert np.all(np.abs(tab.evaluate(x) - smooth(x)) <= 1e-11 * size)
    x1 = np.r_[x[:50], 0.0, 2 * np.pi, np.nextafter(2 * np.pi, 0)]  # the turn's ends too
    one = np.array([tab(float(xi)) for xi in x1]).T
    assert np.all(np.abs(one - smooth(x1)) <= 1e-11 * size)
    # the minima of exp(cos x) (at pi) found between the grid points
    xm = tab.minima(0)
    assert np.min(tab.evaluate(xm)[0]) == pytest.approx(np.exp(-1), abs=1e-12)

    def rough(x):
        return np.abs(np.sin(x))[None] ** 3

    V, converged = _spectral_samples(rough, rough(2 * np.pi * np.arange(n0) / n0), 1e-11)
    assert not converged and V.shape == (1, 5760)
    np.testing.assert_allclose(V[0], rough(2 * np.pi * np.arange(5760) / 5760)[0], atol=1e-15)


@pytest.mark.parametrize("e", [0.05, 0.003, 0.0003])
def test_a_sharp_peak_gets_a_finer_table_or_none(e):
    """1 / (1 + e - cos x) peaks sharply as e falls (a J next to a toggle): the samples
    need more angles and the table more intervals to keep its tolerance; where that would
    take more than TABLE_MAX intervals (and the splines through the samples are not good
    enough either) there is no table, and the equation is solved at every stage."""
    from mechsolve.analyses.dynamics import TABLE_MAX, _harmonics, _spectral_samples, _Table

    def f(x):
        return np.array([1.0 / (1.0 + e - np.cos(x))])

    V, converged = _spectral_samples(f, f(2 * np.pi * np.arange(360) / 360), 1e-11)
    tab = _Table.trigonometric(_harmonics(V), 1e-11) if converged else None
    if e < 0.001:
        assert tab is None and _Table.spline(V, 1e-11) is None
        return
    assert converged and tab is not None and tab.intervals <= TABLE_MAX
    x = np.random.default_rng(0).uniform(0, 2 * np.pi, 20000)
    top = 1.0 / e
    np.testing.assert_allclose(tab.evaluate(x)[0], f(x)[0], rtol=0, atol=1e-11 * top)


def test_a_linkage_that_does_not_come_back_after_a_turn_is_not_periodic():
    """A crank's motion is tabulated over one turn only if the whole linkage comes back
    as it started (poses and rates per unit angle); otherwise it is solved at every
    stage."""
    from mechsolve.analyses.dynamics import _repeats
    from mechsolve.base.state import State

    st = State(2, 3)
    st.x[0] = [0.1, 0.5, 0.1]
    st.w[1] = [1.0, 2.0, 1.0]
    assert _repeats(st, 1.0)
    st.y[1, -1] = 1e-6  # a body elsewhere at the end of the turn
    assert not _repeats(st, 1.0)


def test_the_integrators_inline_equation_equals_the_models_terms():
    """The RK4 inner loop evaluates the table in line; it must be the equation of
    motion (M(omega) - E0(phi, omega)) / J(phi) that ReducedModel.terms gives."""
    from mechsolve.analyses.dynamics import _acceleration, _with_flywheel, drive_torque

    mech = ms.load(MECH / "motor-linkage.yaml")
    model = ReducedModel(_with_flywheel(mech))
    assert model.tabulate()
    d = mech.driver.direction
    fast = _acceleration(model, mech.motor, d)
    assert fast.__name__ == "fast"
    rng = np.random.default_rng(7)
    for p, w in zip(rng.uniform(-20, 20, 30), rng.uniform(-80, 80, 30)):
        J, e0 = model.terms(float(p), float(w))
        want = (float(drive_torque(mech.motor, d, w)) - e0) / J
        assert fast(0.0, float(p), float(w)) == pytest.approx(want, rel=1e-13, abs=1e-12)


PENDULUM = """
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], A: [0.8, 0]}, mass: 3 kg, uniform_bar: [O, A]}
joints: {O: [ground, bar]}
driver: {joint: O, start: 10 deg}
gravity: 9.81 m/s^2
motor: {stall: 0 N m, slope: 0 N m s}
simulate: {duration: 3 s, step: 0.01 s, method: DOP853, rtol: 1e-12, atol: 1e-12, from: 0 rad/s}
"""


def test_a_pendulum_against_its_own_equation():
    """A uniform bar pivoted at one end, released at rest 10 deg above the horizontal:
    (m l^2 / 3) theta'' = -m g (l / 2) cos theta, integrated here independently."""
    res = simulate(ms.loads(PENDULUM))
    tr = res.trajectory
    m, l, g = 3.0, 0.8, 9.81

    def f(t, y):
        return [y[1], -(m * g * l / 2) * math.cos(y[0]) / (m * l * l / 3)]

    sol = solve_ivp(f, (0, 3), [math.radians(10), 0.0], t_eval=tr.t, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(tr.phi, sol.y[0], atol=1e-8)
    np.testing.assert_allclose(tr.omega, sol.y[1], atol=1e-8)


FOURBAR_FREE = """
ground: {O2: [0, 0], O4: [1.0, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.3, 0]}, mass: 2 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [1.1, 0]}, mass: 5 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [0.8, 0]}, mass: 3 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 0 deg}
gravity: 9.81 m/s^2
motor: {stall: 0 N m, slope: 0 N m s}
simulate: {duration: 4 s, step: 0.01 s, method: DOP853, rtol: 1e-10, atol: 1e-12, from: 12 rad/s}
"""


def test_energy_is_conserved_without_motor_or_damping():
    """No motor, no damping, gravity only: kinetic plus potential energy stays constant
    over many revolutions (adaptive at rtol 1e-10: relative drift under 1e-8)."""
    res = simulate(ms.loads(FOURBAR_FREE))
    f = res.forces
    E = f.kinetic + f.potential
    turns = abs(res.trajectory.phi[-1] - res.trajectory.phi[0]) / (2 * math.pi)
    assert turns > 5
    assert np.max(np.abs(E - E[0])) <= 1e-8 * abs(E[0])


def test_simulate_command(tmp_path):
    r = CliRunner().invoke(
        main,
        ["simulate", str(MECH / "motor-linkage.yaml"), "-o", str(tmp_path), "-q", "--units", "SI"],
    )
    assert r.exit_code == 0, r.output
    names = sorted(p.name for p in tmp_path.iterdir() if p.name != ".mechsolve-outputs.json")
    assert names == [
        "simulation-inertia.png",
        "simulation-motion.png",
        "simulation-reactions.png",
        "simulation.csv",
    ]
    head = (tmp_path / "simulation.csv").read_text().splitlines()[0].split(",")
    for col in ("t [s]", "omega [rad/s]", "epsilon [rad/s^2]", "J [kg*m^2]", "motor.torque [N*m]"):
        assert col in head


@pytest.mark.parametrize(
    "edit, message",
    [
        ("motor: {joint: A, stall: 1 N m, slope: 0}", "drives the driver joint"),
        ("simulate: {duration: 1 s, step: 0.01 s, method: Euler}", "unknown integrator"),
        ("simulate: {duration: -1 s, step: 0.01 s}", "positive"),
        ("simulate: {duration: 1 s, step: 2 s}", "longer than the duration"),
        ('motor: {torque: "50 - 1.25 * "}', "motor.torque"),
        ("motor: {stall: 50 N m}", "give stall and slope"),
    ],
)
def test_bad_simulation_input(tmp_path, edit, message):
    text = (MECH / "motor-linkage.yaml").read_text()
    key = edit.split(":")[0]
    lines = [ln for ln in text.splitlines() if not ln.startswith(key + ":")]
    f = tmp_path / "bad.yaml"
    f.write_text("\n".join(lines) + "\n" + edit + "\n")
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 2, r.output
    assert message in r.output and "Traceback" not in r.output


def test_a_motor_given_as_an_expression():
    text = (
        (MECH / "motor-linkage.yaml")
        .read_text()
        .replace(
            "motor: {stall: 50 N m, slope: 1.25 N m s}", 'motor: {torque: "50 - 1.25 * omega"}'
        )
    )
    mech = ms.loads(text)
    mech.simulation.duration = 0.1
    law = simulate(mech).trajectory
    mech2 = ms.load(MECH / "motor-linkage.yaml")
    mech2.simulation.duration = 0.1
    lin = simulate(mech2).trajectory
    np.testing.assert_allclose(law.omega, lin.omega, rtol=1e-14, atol=1e-14)


def test_reduced_model_needs_a_full_turn_for_its_table():
    model = ReducedModel(ms.load(MECH / "motor-linkage.yaml"))
    assert model.full_turn and model.tabulate()


def test_a_flywheel_adds_its_inertia_and_smooths_the_speed():
    base = ms.load(MECH / "motor-linkage.yaml")
    with_fw = ms.loads(
        (MECH / "motor-linkage.yaml").read_text() + "flywheel: {on: crank, inertia: 2 kg m^2}\n"
    )
    a = simulate(base)
    b = simulate(with_fw)
    phi, Ja, _ = a.model.inertia_curve()
    _, Jb, _ = b.model.inertia_curve()
    np.testing.assert_allclose(Jb - Ja, 2.0, atol=1e-9)  # on the crank: theta' = 1
    from mechsolve.analyses.dynamics import steady_fluctuation

    assert steady_fluctuation(b.trajectory)[1] < 0.25 * steady_fluctuation(a.trajectory)[1]


CRANK = """
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], A: [0.8, 0]}, mass: 3 kg, uniform_bar: [O, A]}
joints: {O: [ground, bar]}
driver: {joint: O, speed: 10 rad/s, start: 0 deg}
gravity: 9.81 m/s^2
"""


def test_flywheel_for_a_pure_sine_torque_against_the_hand_formula(tmp_path):
    """A uniform crank under gravity at constant speed needs T = m g (l/2) cos(phi): mean
    zero, so dE(phi) = -m g (l/2) sin(phi) and dE_max = m g l; J_F = m g l / (w^2 delta)
    minus the crank's own m l^2 / 3."""
    from mechsolve.analyses.flywheel import size_flywheel

    m, g, l, w, delta = 3.0, 9.81, 0.8, 10.0, 1 / 40
    fw = size_flywheel(ms.loads(CRANK), delta)
    assert fw.motor_torque == pytest.approx(0.0, abs=1e-9)
    assert fw.energy_max == pytest.approx(m * g * l, rel=1e-6)
    assert fw.J_mean == pytest.approx(m * l * l / 3, rel=1e-12)
    assert fw.J_flywheel == pytest.approx(m * g * l / (w * w * delta) - m * l * l / 3, rel=1e-6)
    f = tmp_path / "crank.yaml"
    f.write_text(CRANK)
    r = CliRunner().invoke(main, ["flywheel", str(f), "--delta", "1/40", "-o", str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert "ΔEₘₐₓ = 23.544 J" in r.output and (tmp_path / "flywheel.png").exists()


def test_flywheel_checked_by_simulation_on_seed_004():
    """The energy method takes the machine's inertia as constant; simulating the machine
    with the flywheel it gives, to steady state, reaches nearly the fluctuation asked."""
    from mechsolve.analyses.flywheel import size_flywheel

    fw = size_flywheel(ms.load(MECH / "motor-linkage.yaml"), 1 / 20)
    assert fw.J_flywheel > 1.0
    assert fw.delta_reached == pytest.approx(1 / 20, rel=0.1)


PARALLELOGRAM_FREE = """
ground: {O2: [0, 0], O4: [2, 0]}
links:
  crank: {points: {O2: [0, 0], A: [1, 0]}, mass: 2 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [2, 0]}, mass: 4 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [1, 0]}, mass: 2 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: {sketch: {B: [2.7, 0.7]}}
driver: {joint: O2, start: 30 deg}
gravity: 9.81 m/s^2
motor: {stall: 0 N m, slope: 0 N m s}
simulate: {duration: 10 s, step: 0.01 s, method: DOP853, rtol: 1e-10, atol: 1e-12, from: 8 rad/s}
"""


def test_energy_is_conserved_through_bifurcations():
    """A parallelogram turning freely under gravity passes its collinear (bifurcation)
    positions twice a turn: it stays a parallelogram and its energy is conserved."""
    res = simulate(ms.loads(PARALLELOGRAM_FREE))
    tr = res.trajectory
    assert abs(tr.phi[-1] - tr.phi[0]) / (2 * math.pi) > 10 and not tr.stopped
    f = res.forces
    E = f.kinetic + f.potential
    assert np.max(np.abs(E - E[0])) <= 1e-8 * abs(E[0])
    th2, th4 = res.link("crank").angle, res.link("rocker").angle
    np.testing.assert_allclose(np.sin(th4 - th2), 0, atol=1e-9)


def test_energy_balance_column_is_small_and_converges(seed004):
    """The motor's and the loads' work since the start minus the change of energy: the
    trapezoid rule over the steps makes it O(h^2), so it shrinks as the step does."""
    r = seed004.energy_residual()
    E = seed004.forces.kinetic + seed004.forces.potential
    assert np.max(np.abs(r)) < 2e-2 * np.max(np.abs(E))
    mech = ms.load(MECH / "motor-linkage.yaml")
    mech.simulation.step = 0.0005
    fine = simulate(mech)
    ratio = np.max(np.abs(fine.energy_residual())) / np.max(np.abs(r))
    assert ratio < 0.1  # 16 times smaller for O(h^2), allowing for the sampling of the peaks


def test_simulate_shows_progress_on_a_terminal(monkeypatch, tmp_path):
    import mechsolve.cli.commands.simulate as simulate_cmd

    calls = []

    class Bar:
        def update(self, k):
            calls.append(k)

        def close(self):
            calls.append("closed")

    monkeypatch.setattr(simulate_cmd, "_progress_bar", lambda total, quiet: Bar())
    r = CliRunner().invoke(
        main,
        ["simulate", str(MECH / "motor-linkage.yaml"), "--no-plots", "-q", "-o", str(tmp_path)],
    )
    assert r.exit_code == 0, r.output
    assert sum(c for c in calls if c != "closed") == 1100 and calls[-1] == "closed"


def test_shaper_flywheel_with_its_conditional_cutting_force():
    """The shaper's cutting force switches with the ram's stroke and direction; the
    flywheel by the energy method needs the cycle's mean torque (its work per cycle over
    2 pi)."""
    from mechsolve.analyses.flywheel import size_flywheel

    mech = ms.load(MECH / "shaper.yaml")
    mech.simulation.duration = 0.1
    tr = simulate(mech).trajectory
    assert len(tr.t) == 21 and np.all(tr.omega < 0)  # clockwise, never stalling
    fw = size_flywheel(ms.load(MECH / "shaper.yaml"), 1 / 40, check=False)
    work = ms.solve(ms.load(MECH / "shaper.yaml"), step=np.radians(0.1)).work()
    assert fw.motor_torque == pytest.approx(abs(work) / (2 * math.pi), rel=1e-4)
    assert fw.J_flywheel > 1000


def test_switching_loads_are_tabulated_with_exact_switch_angles():
    """The cutting force acts while the ram moves right (C.vx > 0) between 5 % and 95 % of
    its stroke. Tabulated, it must switch exactly there: at the switch angles, the ram's
    position (solved here by the sweep, not by the table) is at 5 % and 95 % of the
    stroke's ends (the ram's limit positions, from the closed-form stroke 2 l r / d), and
    the tabulated motion equals the one solved at every stage."""
    from mechsolve.analyses.dynamics import ReducedModel, _with_flywheel

    mech = ms.load(MECH / "shaper.yaml")
    model = ReducedModel(_with_flywheel(mech))  # the rotor's inertia, as simulate adds it
    assert model.tabulate()
    d = mech.driver.direction
    on0, switches = model._masks["cutting", float(d)]  # the crank's own sense
    assert not on0 and len(switches) == 2
    angles = model.u0 + d * switches
    from mechsolve.core import evaluate as core

    an = model.an
    ram, c = an.system.index["ram"], mech.local_point("ram", "C")

    def ram_x(u):
        st = core.states(an, u, np.full(len(u), float(d)), np.zeros(len(u))).state
        return st.point(ram, c)[0]

    xs = ram_x(model.u0 + d * np.radians(np.arange(0.0, 360.0, 0.01)))
    lo, hi = xs.min(), xs.max()
    assert hi - lo == pytest.approx(2 * 0.540 * 0.110 / 0.380, abs=1e-8)  # the stroke
    frac = (ram_x(angles) - lo) / (hi - lo)
    np.testing.assert_allclose(np.sort(frac), [0.05, 0.95], atol=1e-7)

    mech.simulation.duration = 0.4
    a = simulate(mech).trajectory
    b = simulate(ms.load(MECH / "shaper.yaml"), exact=True).trajectory
    b_t = b.t <= 0.4 + 1e-12
    np.testing.assert_allclose(a.omega, b.omega[b_t], rtol=1e-9)
    np.testing.assert_allclose(a.eps, b.eps[b_t], rtol=1e-7, atol=1e-6)


def test_a_condition_on_the_size_of_a_speed_is_solved_at_every_stage():
    """Whether ``C.vx > 0.3`` holds depends on how fast the crank turns, not only on its
    angle: such a load cannot be tabulated over the angle, and the simulation solves it at
    every stage (the same motion as --exact)."""
    from mechsolve.analyses.dynamics import ReducedModel

    text = (MECH / "shaper.yaml").read_text().replace("when: C.vx > 0 and", "when: C.vx > 0.3 and")
    assert "C.vx > 0.3" in text
    mech = ms.loads(text)
    assert not ReducedModel(mech).tabulate()
    mech.simulation.duration = 0.05
    a = simulate(mech).trajectory
    mech2 = ms.loads(text)
    mech2.simulation.duration = 0.05
    b = simulate(mech2, exact=True).trajectory
    np.testing.assert_array_equal(a.omega, b.omega)


def test_a_machine_without_inertia_where_it_stops_is_refused(tmp_path):
    """Without the rotor's inertia the shaper's massless crank drives links that all stop
    at the ram's limits: the reduced inertia vanishes there, and the message says so."""
    text = (MECH / "shaper.yaml").read_text()
    text = "\n".join(ln for ln in text.splitlines() if not ln.startswith("flywheel:"))
    f = tmp_path / "shaper.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 2, r.output
    assert "reduced moment of inertia" in r.output and "Traceback" not in r.output


def test_energy_mass_method_reduces_to_the_classic_one_for_a_constant_inertia():
    from mechsolve.analyses.flywheel import size_flywheel

    fw = size_flywheel(ms.loads(CRANK), 1 / 40, check=False)  # J = m l^2 / 3 everywhere
    assert fw.J_exact == pytest.approx(fw.J_flywheel, rel=1e-9)


def test_energy_mass_method_on_seed_004_reaches_the_fluctuation_asked():
    """With the varying J(phi) accounted for, the flywheel of the energy-mass method gives
    (in simulation to steady state) the fluctuation asked within 2 % (the classic
    constant-J estimate is off by about 2 %; the motor's torque also varies with speed)."""
    import copy

    from mechsolve.analyses.dynamics import steady_fluctuation
    from mechsolve.analyses.flywheel import size_flywheel
    from mechsolve.model.machine import Flywheel

    mech = ms.load(MECH / "motor-linkage.yaml")
    fw = size_flywheel(mech, 1 / 20, check=False)
    assert fw.J_exact < fw.J_flywheel
    machine = copy.copy(mech)
    machine.flywheel = Flywheel("crank", fw.J_exact)
    machine.simulation = copy.copy(mech.simulation)
    machine.simulation.duration = 60.0
    delta = steady_fluctuation(simulate(machine).trajectory)[1]
    assert delta == pytest.approx(1 / 20, rel=0.02)


def test_flywheel_from_a_torque_curve_as_textbooks_state_it(tmp_path):
    """T = 200 + 150 sin(2 phi) at 1500 rpm, delta = 1/80: dE_max = 150 J (the range of
    -75 cos(2 phi)), J_F = dE_max / (omega^2 delta); the same from a table over an engine's
    720 deg cycle (torque only in one half-turn of four), by the trapezoid rule by hand."""
    f = tmp_path / "engine.yaml"
    f.write_text(
        'torque: {law: "200 + 150 * sin(2 * angle)", cycle: 360 deg}\n'
        "speed: 1500 rpm\ndelta: 1/80\n"
    )
    r = CliRunner().invoke(main, ["flywheel", str(f), "-o", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    w = 1500 * math.pi / 30
    want = 150 / (w * w / 80)
    assert f"flywheel J_F = {want:.6g} kg·m²" in r.output
    # a four-stroke cycle: 2000 N m over the power stroke, nothing else
    rows = [[0, 0], [45, 2000], [135, 2000], [180, 0], [720, 0]]
    table = ", ".join(f"[{a} deg, {t} N m]" for a, t in rows)
    g = tmp_path / "four-stroke.yaml"
    g.write_text(f"torque: {{table: [{table}], cycle: 720 deg}}\nspeed: 3000 rpm\n")
    r = CliRunner().invoke(main, ["flywheel", str(g), "--delta", "0.02", "-o", str(tmp_path)])
    assert r.exit_code == 0, r.output
    x = np.radians([0, 45, 135, 180, 720])
    T = np.array([0, 2000, 2000, 0, 0.0])
    mean = np.trapezoid(T, x) / (4 * math.pi)
    # the excess's running integral: piecewise quadratic, extremes at the table's points
    xs = np.linspace(0, 4 * math.pi, 400001)
    run = np.concatenate(
        [
            [0.0],
            np.cumsum(
                np.diff(xs) * (np.interp(xs[1:], x, T) + np.interp(xs[:-1], x, T)) / 2
                - mean * np.diff(xs)
            ),
        ]
    )
    dE = run.max() - run.min()
    wm = 3000 * math.pi / 30
    assert f"ΔEₘₐₓ = {dE:.6g} J" in r.output
    assert f"flywheel J_F = {dE / (wm * wm * 0.02):.6g}" in r.output


@pytest.mark.parametrize(
    "text, message",
    [
        ("torque: {table: [[0, 1], [90, 2], [45, 3]]}\nspeed: 10 rad/s\n", "must increase"),
        ('torque: {law: "2 * x"}\nspeed: 10 rad/s\n', "unknown name 'x'"),
        ("torque: {table: [[0, 1], [90, 2], [180, 3]]}\n", "speed"),
    ],
)
def test_bad_torque_curves(tmp_path, text, message):
    f = tmp_path / "bad.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["flywheel", str(f), "-o", str(tmp_path / "o")])
    assert r.exit_code == 2, r.output
    assert message in r.output and "Traceback" not in r.output


FLYWHEEL_SPINUP = """
ground: {O: [0, 0]}
links:
  disk: {points: {O: [0, 0], A: [0.3, 0]}, mass: 5 kg, com: O, inertia: 0.4 kg m^2}
joints: {O: [ground, disk]}
driver: {joint: O, start: 0 deg}
motor: {stall: 2 N m, slope: 0.05 N m s}
simulate: {duration: 200 s, step: 0.05 s, method: METHOD, rtol: 1e-11, atol: 1e-11,
           steady: 1e-4}
"""


@pytest.mark.parametrize("method", ["DOP853", "rk4"])
def test_stop_when_steady_against_the_closed_form_spin_up(method):
    """A disk of inertia J spun up by M = M0 - nu omega: omega = (M0/nu)(1 - exp(-nu t/J)),
    so the angle is (M0/nu)(t - (J/nu)(1 - exp(-nu t/J))). The revolutions end where it
    reaches 2 pi k (solved here by brentq); the simulation must stop at the first
    revolution whose mean speed differs from the one before by at most 1e-4, at its time."""
    from scipy.optimize import brentq

    M0, nu, J = 2.0, 0.05, 0.4
    w_inf = M0 / nu

    def angle(t):
        return w_inf * (t - J / nu * (1 - math.exp(-nu * t / J)))

    times = [0.0]
    while True:
        k = len(times)
        times.append(brentq(lambda t, k=k: angle(t) - 2 * math.pi * k, times[-1], 1e4, xtol=1e-14))
        if k >= 2:
            w1 = 2 * math.pi / (times[-1] - times[-2])
            w0 = 2 * math.pi / (times[-2] - times[-3])
            if abs(w1 - w0) <= 1e-4 * w1:
                break
    tr = simulate(ms.loads(FLYWHEEL_SPINUP.replace("METHOD", method))).trajectory
    assert tr.stopped.startswith(f"steady after {len(times) - 1} revolutions"), tr.stopped
    assert tr.t[-1] == pytest.approx(times[-1], abs=0.05 if method == "rk4" else 1e-6)
    assert abs(tr.phi[-1] - tr.phi[0]) >= 2 * math.pi * (len(times) - 1) - 1e-6


def test_bad_steady_tolerance(tmp_path):
    text = FLYWHEEL_SPINUP.replace("METHOD", "rk4").replace("steady: 1e-4", "steady: fast")
    f = tmp_path / "spin.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(tmp_path / "o")])
    assert r.exit_code == 2 and "spin.yaml:9: simulate.steady" in r.output, r.output


def test_a_machine_of_two_degrees_of_freedom_is_refused_saying_what_is_supported(tmp_path):
    """A crank with a free arm hanging from it: two independent motions, one motor."""
    f = tmp_path / "two.yaml"
    f.write_text(
        "ground: {O: [0, 0]}\n"
        "links:\n"
        "  crank: {points: {O: [0, 0], A: [0.2, 0]}, mass: 1 kg, uniform_bar: [O, A]}\n"
        "  arm: {points: {A: [0, 0], B: [0.5, 0]}, mass: 1 kg, uniform_bar: [A, B]}\n"
        "joints: {O: [ground, crank], A: [crank, arm]}\n"
        "driver: {joint: O, start: 0 deg}\n"
        "motor: {stall: 2 N m, slope: 0.05 N m s}\n"
        "simulate: {duration: 1 s, step: 0.01 s}\n"
    )
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(tmp_path / "o")])
    assert r.exit_code == 2, r.output
    assert "2 degrees of freedom" in r.output and "'arm'" in r.output
    assert "one degree of freedom" in r.output and "Traceback" not in r.output


KITE = """
ground: {O2: [0, 0], O4: [0.3, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.3, 0]}, mass: 2 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [1.0, 0]}, mass: 5 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [1.0, 0]}, mass: 3 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 30 deg}
gravity: 9.81 m/s^2
motor: {stall: 200 N m, slope: 2 N m s}
simulate: {duration: 0.8 s, step: 0.002 s, method: rk4, from: rest}
"""


@pytest.mark.parametrize(
    "variant",
    [
        "ahead",
        "behind",  # the motor turns it backward from its start: reached by the reversed driver
    ],
)
def test_a_kite_that_changes_branch_each_turn_is_followed_over_many_turns(variant):
    """A kite four-bar (ground = crank, coupler = rocker) passes a bifurcation each turn
    and comes back only after two: it is not tabulated over one turn, and its equation
    of motion must be solved on the branches the sweep follows over every turn. Check:
    the driving torque that the force analysis needs along the motion (its states
    solved by the sweep's own continuation over all the turns) is the motor's torque."""
    text = KITE if variant == "ahead" else KITE.replace("stall: 200 N m", "stall: -200 N m")
    res = simulate(ms.loads(text))
    tr = res.trajectory
    assert not res.model.full_turn
    if variant == "behind":  # the same machine as a clockwise driver with the law mirrored
        assert tr.phi[-1] < tr.phi[0]
        cw = KITE.replace("start: 30 deg}", "start: 30 deg, direction: cw}")
        np.testing.assert_allclose(tr.phi, simulate(ms.loads(cw)).trajectory.phi, atol=1e-9)
    assert abs(tr.phi[-1] - tr.phi[0]) > 3 * 2 * np.pi  # several turns, both branches
    M = res.motor_torque()
    # the bifurcation samples themselves: the effort there is a limit along the motion
    # (O(h^4)) or indeterminate
    ok = np.isfinite(res.forces.effort)
    ok[res.forces.effort_by_limit] = False
    assert ok.mean() > 0.99
    np.testing.assert_allclose(res.forces.effort[ok], M[ok], rtol=0, atol=1e-8 * np.max(np.abs(M)))


PARALLELOGRAM_MOTOR = """
ground: {O2: [0, 0], O4: [1.0, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.3, 0]}, mass: 2 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [1.0, 0]}, mass: 5 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [0.3, 0]}, mass: 3 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 30 deg}
gravity: 9.81 m/s^2
motor: {stall: 20 N m, slope: 0.5 N m s}
simulate: {duration: 1.2 s, step: 0.002 s, method: rk4, from: rest}
"""


@pytest.mark.parametrize("exact", [False, True])
def test_a_motor_driven_parallelogram_against_its_closed_form(exact):
    """Through its bifurcations (0 and 180 deg) a parallelogram's equation is that of a
    rigid pendulum: J = m1 l^2 / 3 + m3 l^2 / 3 + m2 l^2 = 0.6 kg m^2 (the coupler
    translates with A) and gravity's moment 2.25 g cos(phi) (centres at l/2, l/2 and
    with A). Both the table and the path solved at every stage (which takes its limit
    from both sides next to a singular position) must follow that equation's own RK4."""
    g, J, h = 9.81, 0.6, 0.002

    def f(p, w):
        return (20.0 - 0.5 * w - 2.25 * g * math.cos(p)) / J

    p, w, ps = math.radians(30), 0.0, [math.radians(30)]
    for _ in range(600):
        k1 = f(p, w)
        k2 = f(p + h / 2 * w, w + h / 2 * k1)
        k3 = f(p + h / 2 * (w + h / 2 * k1), w + h / 2 * k2)
        k4 = f(p + h * (w + h / 2 * k2), w + h * k3)
        p, w = p + h / 6 * (6 * w + h * (k1 + k2 + k3)), w + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        ps.append(p)
    tr = simulate(ms.loads(PARALLELOGRAM_MOTOR), exact=exact).trajectory
    assert tr.phi[-1] > 2 * math.pi + math.radians(30)  # both singular positions passed
    np.testing.assert_allclose(tr.phi, ps, rtol=0, atol=1e-6)
    np.testing.assert_allclose(tr.J, J, rtol=1e-8)


@pytest.mark.parametrize("start", ["30 deg", "30.37 deg", "100 deg"])
def test_a_parallelogram_is_tabulated_whatever_its_start(start):
    """Samples next to the parallelogram's singular positions (where the force analysis
    loses accuracy) are taken as the limit from both sides, as the path solved at every
    stage takes them: its equation is tabulated from any start (it had fallen back to
    solving every stage, a hundred times slower, unless a sample hit the singular angle
    exactly), with J at its closed-form 0.6 kg m^2."""
    from mechsolve.analyses.dynamics import _with_flywheel

    mech = ms.loads(PARALLELOGRAM_MOTOR.replace("start: 30 deg", f"start: {start}"))
    model = ReducedModel(_with_flywheel(mech))
    assert model.tabulate()
    x = np.linspace(0.0, 2 * np.pi, 1001)
    # (samples next to the collinear positions are the rates' limit along the motion,
    # Richardson at 5 mrad: O(h^4), within a few 1e-9)
    np.testing.assert_allclose(model._table.evaluate(x)[0], 0.6, rtol=5e-9)
