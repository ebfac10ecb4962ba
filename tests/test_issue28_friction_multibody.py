"""Issue 28: joint friction in simulate's general (multibody) path.

The references are independent of the multibody code: Coulomb's closed forms for a block
on an incline, the equation of a pendulum with a friction-circle pin written and
integrated by hand (scipy), the energy a pin's friction takes computed from its
reaction, and the same machine on the reduced path (the driver's one equation from the
force analysis). The regularisation (Coulomb's part times tanh(|slip| / v_s), v_s =
1e-3 rad/s for a pin, 1e-3 s^-1 times the mechanism's size for a slider) is checked for
its effect: where it matters (a reversal of the sliding, a joint that Coulomb would
hold) the effect is of order v_s and halves with it, elsewhere halving v_s changes
nothing measurable.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

G = 9.81
ALPHA = math.radians(25.0)


def run(text: str, smoothing: float | None = None):
    import mechsolve as ms
    import mechsolve.analyses.dynamics.multibody_friction as mf
    from mechsolve.analyses.dynamics import simulate

    old = mf.SMOOTHING
    if smoothing is not None:
        mf.SMOOTHING = smoothing
    try:
        return simulate(ms.loads(text))
    finally:
        mf.SMOOTHING = old


# -- a block on an incline ---------------------------------------------------------------
def incline(f: float, speed: float, duration: float) -> str:
    return f"""
name: block on an incline
units: {{length: m, angle: deg}}
ground: {{O: [0, 0]}}
links:
  block: {{points: {{P: [0, 0]}}, mass: 3 kg, com: P}}
joints:
  slope: {{slider: [ground, block], point: P, line: {{through: [0, 0], angle: 25}},
          friction: {{coefficient: {f}}}}}
driver: {{joint: slope, start: 0.1 m}}
gravity: {G} m/s^2
simulate: {{duration: {duration} s, step: 0.01 s, method: DOP853, rtol: 1e-10, atol: 1e-12,
           from: {speed} m/s}}
"""


def test_block_thrown_up_an_incline_follows_coulomb():
    """Thrown up the incline at v0 with f < tan(alpha): it decelerates at
    g (sin a + f cos a), stops at t1 = v0 / that, and slides back at g (sin a - f cos a)
    (closed form). The friction's work is f m g cos a times the distance travelled. The
    regularisation smooths the reversal: the velocity after it is off by a few v_s at
    most (here v_s = 1e-3 m/s: the mechanism's size is 1 m); the same regularised law
    integrated by hand agrees to the integrator's tolerance."""
    f, v0, m = 0.2, 2.0, 3.0
    res = run(incline(f, v0, 1.0))
    tr = res.trajectory
    assert res.multibody.scale == 1.0  # so v_s = 1e-3 m/s
    vs = 1e-3
    a1 = -G * (math.sin(ALPHA) + f * math.cos(ALPHA))
    a2 = -G * (math.sin(ALPHA) - f * math.cos(ALPHA))
    t1 = v0 / -a1
    t = tr.t
    v = np.where(t < t1, v0 + a1 * t, a2 * (t - t1))
    s_top = 0.1 + v0 * t1 + 0.5 * a1 * t1**2
    s = np.where(t < t1, 0.1 + v0 * t + 0.5 * a1 * t * t, s_top + 0.5 * a2 * (t - t1) ** 2)
    assert np.max(np.abs(tr.ud - v)) < 0.5 * vs
    assert np.max(np.abs(tr.u - s)) < 0.5 * vs * 1.0  # over 1 s
    assert np.max(np.abs(tr.ud[t < t1 - 0.01] - v[t < t1 - 0.01])) < 1e-9  # exact sliding
    # the work of the friction: f N times the path, N = m g cos a
    path = (s_top - 0.1) + (s_top - s[-1])
    assert -tr.work[-1] == pytest.approx(f * m * G * math.cos(ALPHA) * path, rel=1e-3)
    assert np.max(np.abs(tr.energy_residual)) < 1e-9 * abs(tr.work[-1])
    # the regularised law by hand: v' = -g sin a - f g cos a tanh(v / v_s)
    ref = solve_ivp(
        lambda _, y: [y[1], -G * math.sin(ALPHA) - f * G * math.cos(ALPHA) * math.tanh(y[1] / vs)],
        (0.0, 1.0),
        [0.1, v0],
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
        t_eval=t,
    )
    assert np.max(np.abs(tr.ud - ref.y[1])) < 1e-7
    assert np.max(np.abs(tr.u - ref.y[0])) < 1e-8
    # the reversal's offset is the regularisation's: it halves with v_s
    offset = tr.ud[-1] - v[-1]
    half = run(incline(f, v0, 1.0), smoothing=vs / 2).trajectory
    assert (half.ud[-1] - v[-1]) / offset == pytest.approx(0.5, rel=0.05)
    # the friction column (the free path lists it too): f |N| while it slides
    fr = res.forces.friction.friction["slope"]
    assert np.allclose(fr[t < t1 - 0.01], f * m * G * math.cos(ALPHA), rtol=1e-9)


@pytest.mark.slow  # 5-11 s on the shared machine
def test_a_block_coulomb_would_hold_creeps_at_the_stated_speed():
    """f > tan(alpha): thrown up, the block stops and Coulomb's law holds it there. The
    regularised law cannot hold it: it creeps down at the speed where the regularised
    friction balances the weight, v = v_s atanh(tan a / f) — the stated effect of the
    regularisation, proportional to v_s (halving v_s halves it)."""
    f, v0 = 0.6, 1.0
    creep = []
    for vs in (1e-3, 5e-4):
        tr = run(incline(f, v0, 0.6), smoothing=vs).trajectory
        t_stop = v0 / (G * (math.sin(ALPHA) + f * math.cos(ALPHA)))
        late = tr.t > t_stop + 0.2
        expect = -vs * math.atanh(math.tan(ALPHA) / f)
        assert np.allclose(tr.ud[late], expect, rtol=1e-6)
        creep.append(tr.ud[-1])
        # where it stops: the closed form, to the creep over the run
        s_top = 0.1 + v0**2 / (2 * G * (math.sin(ALPHA) + f * math.cos(ALPHA)))
        assert abs(tr.u[-1] - s_top) < 0.6 * abs(expect)
    assert creep[1] / creep[0] == pytest.approx(0.5, rel=1e-6)


# -- a pendulum with a journal-friction pin -------------------------------------------
PENDULUM = """
name: pendulum with a journal-friction pin
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], G: [0.5, 0]}, mass: 2 kg, com: G, inertia: 0.04 kg m^2}
joints:
  O: {revolute: [ground, bar], friction: {coefficient: 0.2, journal radius: 25 mm}}
driver: {joint: O, start: 0 deg}
gravity: 9.81 m/s^2
simulate: {duration: 3 s, step: 0.005 s, method: DOP853, rtol: 1e-10, atol: 1e-12}
"""
M, L, JG, RHO = 2.0, 0.5, 0.04, 0.2 * 0.025


def pendulum_by_hand(t_eval: np.ndarray, ws: float = 1e-3):
    """The pendulum released from the horizontal: J_O a = -m g l cos(th) - rho |F|
    tanh(w / w_s), with the pin's force on the bar F = m (a_G - g) (radial
    m (g sin th - l w^2), tangential m (l a + g cos th)): implicit in a, solved by
    Newton's method at every evaluation."""
    jo = JG + M * L * L

    def alpha(th, w):
        a = -M * G * L * math.cos(th) / jo
        for _ in range(50):
            fr, ft = M * (G * math.sin(th) - L * w * w), M * (L * a + G * math.cos(th))
            F = math.hypot(fr, ft)
            sg = math.tanh(w / ws)
            r = jo * a + M * G * L * math.cos(th) + RHO * F * sg
            dr = jo + RHO * sg * (ft * M * L / F if F > 0 else 0.0)
            step = r / dr
            a -= step
            if abs(step) < 1e-15 * (1 + abs(a)):
                break
        return a

    sol = solve_ivp(
        lambda _, y: [y[1], alpha(y[0], y[1])],
        (0.0, t_eval[-1]),
        [0.0, 0.0],
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
        t_eval=t_eval,
    )
    return sol.y[0], sol.y[1]


@pytest.mark.slow  # 5-11 s on the shared machine
def test_pendulum_with_pin_friction_matches_its_equation_by_hand():
    """The general path (free motion: the driver only places the bar) against the
    pendulum's equation with the friction circle written and integrated by hand."""
    res = run(PENDULUM)
    tr = res.trajectory
    th, w = pendulum_by_hand(tr.t)
    assert np.max(np.abs(tr.u - th)) < 1e-7
    assert np.max(np.abs(tr.ud - w)) < 1e-6
    # it decays: each swing reaches less far than the last
    assert th.min() > -math.pi and np.min(tr.u[tr.t > 1.5]) > np.min(tr.u[tr.t < 1.5])
    # without friction it would swing back to the horizontal
    ideal = run(PENDULUM.replace(", friction: {coefficient: 0.2, journal radius: 25 mm}", ""))
    assert np.max(ideal.trajectory.u) == pytest.approx(0.0, abs=1e-6)
    assert np.max(tr.u[tr.t > 0.5]) < -0.05


@pytest.mark.slow  # 5-11 s on the shared machine
def test_pendulum_loses_the_work_of_its_pin_friction_from_the_reaction():
    """The energy lost, (T + V)(0) - (T + V)(t), equals the friction's work computed
    from the pin's reaction: the integral of rho |F| |w| over time (Simpson's rule on
    the outputs). The force analysis of the simulated motion needs no driving effort
    (nothing drives the pendulum) and its pin friction is rho |F| of its own reaction."""
    from scipy.integrate import cumulative_simpson

    res = run(PENDULUM)
    tr = res.trajectory
    fx = res.forces.reactions["O"]["Fx"]
    fy = res.forces.reactions["O"]["Fy"]
    F = np.hypot(fx, fy)
    loss_rate = RHO * F * np.abs(tr.ud)
    lost = cumulative_simpson(loss_rate, x=tr.t, initial=0.0)
    drop = (tr.kinetic[0] + tr.potential[0]) - (tr.kinetic + tr.potential)
    assert drop[-1] > 0.1 * M * G * L  # a large part of the energy is lost
    assert np.max(np.abs(drop - lost)) < 1e-4 * drop[-1]
    assert np.max(np.abs(res.forces.effort)) < 1e-6 * M * G * L
    assert np.allclose(res.forces.friction.friction["O"][1:], RHO * F[1:], rtol=1e-6)
    # the multipliers of the general path give the same pin force
    mb = res.multibody
    row = next(r for r in mb.system.rows if r.constraint.name == "O")
    lam = tr.lam[:, row.start : row.start + 2]
    assert np.allclose(np.hypot(lam[:, 0], lam[:, 1]), F, rtol=1e-6, atol=1e-9)


@pytest.mark.slow  # 5-11 s on the shared machine
def test_halving_the_smoothing_speed_leaves_the_pendulum_alone():
    """The pin's slip leaves zero at the release and at each turning point at a finite
    rate, so the regularisation acts over a few v_s / |w'| seconds: halving v_s changes
    the motion by less than 1e-6 rad (the statement of the guide)."""
    a = run(PENDULUM.replace("duration: 3 s", "duration: 1.5 s")).trajectory
    b = run(PENDULUM.replace("duration: 3 s", "duration: 1.5 s"), smoothing=5e-4).trajectory
    assert np.max(np.abs(a.u - b.u)) < 1e-6
    assert np.max(np.abs(a.u - b.u)) > 0  # the law is the regularised one


# -- the same machine on both paths ------------------------------------------------------
SLIDER_CRANK = """
name: slider-crank with friction in every joint
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [0.1, 0]}, mass: 1 kg, com: [0.05, 0], inertia: 0.002 kg m^2}
  rod: {points: {A: [0, 0], B: [0.3, 0]}, mass: 2 kg, com: [0.15, 0], inertia: 0.015 kg m^2}
  piston: {points: {B: [0, 0]}, mass: 1.5 kg, com: B}
joints:
  O: {revolute: [ground, crank], friction: {coefficient: 0.1, journal radius: 20 mm}}
  A: {revolute: [crank, rod], friction: {coefficient: 0.1, journal radius: 15 mm}}
  B: {revolute: [rod, piston], friction: {coefficient: 0.1, journal radius: 10 mm}}
  cylinder: {slider: [ground, piston], point: B, line: {through: [0, 0], angle: 0},
             friction: {coefficient: 0.15, viscous: 2 N s/m}}
driver: {joint: O, start: 30 deg}
gravity: 9.81 m/s^2
motor: {stall: 10 N m, slope: 0.5 N m s}
simulate: {duration: 0.1 s, step: 0.005 s, method: DOP853, rtol: 1e-9, atol: 1e-11,
           from: 5 rad/s FORM}
"""


@pytest.mark.slow
def test_slider_crank_moves_alike_on_the_reduced_and_the_general_path():
    """A motor-driven slider-crank with friction in its three pins and its cylinder: the
    reduced path (the driver's equation from the force analysis with friction) and the
    general path (the bodies' equations with the multipliers) give the same motion.
    The crank keeps turning, so the two regularisations (by the driver's speed, by each
    joint's slip) differ only while a pin or the piston reverses: over a window of a
    few v_s, which moves the crank by less than 1e-6 rad/s."""
    reduced = run(SLIDER_CRANK.replace(" FORM", ""))
    general = run(SLIDER_CRANK.replace(" FORM", ", formulation: multibody"))
    assert type(reduced).__name__ == "SimulationResults"
    assert type(general).__name__ == "MultibodyResults"
    a, b = reduced.trajectory, general.trajectory
    assert np.allclose(a.t, b.t)
    assert np.max(np.abs(a.phi - b.u)) < 1e-7
    assert np.max(np.abs(a.omega - b.ud)) < 1e-6 * np.max(np.abs(a.omega))
    # friction matters here: without it the crank runs differently
    ideal = run(
        SLIDER_CRANK.replace(" FORM", ", formulation: multibody")
        .replace(", friction: {coefficient: 0.1, journal radius: 20 mm}", "")
        .replace(", friction: {coefficient: 0.1, journal radius: 15 mm}", "")
        .replace(", friction: {coefficient: 0.1, journal radius: 10 mm}", "")
        .replace(",\n             friction: {coefficient: 0.15, viscous: 2 N s/m}", "")
    ).trajectory
    assert np.max(np.abs(ideal.ud - b.ud)) > 1e3 * np.max(np.abs(a.omega - b.ud))
    # both count the losses in the energy balance
    assert np.max(np.abs(b.energy_residual)) < 1e-7 * np.max(np.abs(b.work))
    assert np.max(np.abs(general.forces.power_friction)) > 0


@pytest.mark.slow  # 5-11 s on the shared machine
def test_two_degrees_of_freedom_with_friction_keep_their_energy_balance():
    """A double pendulum (two degrees of freedom, only the general path) with friction at
    both pins, placed by simulate.pose: the energy lost equals the friction work of the
    two pins from their reactions (the CSV's friction columns), T + V - W stays constant."""
    from scipy.integrate import cumulative_simpson

    text = """
name: double pendulum with pin friction
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  upper: {points: {O: [0, 0], A: [0.4, 0]}, mass: 1 kg, com: [0.2, 0], inertia: 0.013 kg m^2}
  lower: {points: {A: [0, 0], B: [0.3, 0]}, mass: 0.8 kg, com: [0.15, 0], inertia: 0.006 kg m^2}
joints:
  O: {revolute: [ground, upper], friction: {coefficient: 0.2, journal radius: 20 mm}}
  A: {revolute: [upper, lower], friction: {coefficient: 0.2, journal radius: 15 mm}}
gravity: 9.81 m/s^2
simulate: {duration: 1 s, step: 0.002 s, method: DOP853, rtol: 1e-10, atol: 1e-12,
           pose: {O: 0 deg, A: 30 deg}}
"""
    res = run(text)
    assert "v_s = 0.001 rad/s in the pins" in res.summary()
    cols = dict(res.columns())
    t = cols["t [s]"]
    lost = cols["power.friction [W]"]
    assert np.all(lost >= 0) and lost.max() > 0
    tv = cols["energy.kinetic [J]"] + cols["energy.potential [J]"]
    drop = tv[0] - tv
    work = cumulative_simpson(lost, x=t, initial=0.0)
    assert drop[-1] > 0.05
    assert np.max(np.abs(drop - work)) < 1e-3 * drop[-1]
    assert np.max(np.abs(cols["energy.residual [J]"])) < 1e-7 * drop[-1]  # rtol 1e-10
    # each pin's friction is rho |F| of its reported reaction (turning: tanh = 1)
    F = cols["O.F [N]"]
    fo = cols["O.friction [N*m]"]
    turning = np.abs(cols["upper.omega [rad/s]"]) > 0.05
    assert np.allclose(fo[turning], 0.2 * 0.02 * F[turning], rtol=1e-9)


def test_a_friction_with_no_solution_stops_the_motion_with_a_warning(tmp_path):
    """A pin whose friction circle (rho = 0.8 m) exceeds J_O / (m l) = 0.54 m: the
    friction the pendulum's acceleration causes grows faster than the acceleration
    (det(I - G) < 0, no solution connected to the frictionless one) as soon as the bar
    turns faster than a few v_s. The run stops there (exit 0, a warning, the rows up to
    there kept), naming the instant; it does not integrate a non-physical motion."""
    from click.testing import CliRunner

    from mechsolve.cli.main import main

    f = tmp_path / "p.yaml"
    f.write_text(
        PENDULUM.replace("journal radius: 25 mm", "journal radius: 4000 mm").replace(
            "duration: 3 s", "duration: 1 s"
        )
    )
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(tmp_path / "out")])
    assert r.exit_code == 0, r.output
    assert "Traceback" not in r.output
    assert "stopped early" in r.output and "the joints' friction has no solution" in r.output
    lines = (tmp_path / "out" / "simulation.csv").read_text().splitlines()
    assert 2 <= len(lines) < 202  # the rows up to there (the start), not the whole second
    # a sensible friction (rho = 5 mm) runs to the end
    f.write_text(PENDULUM.replace("duration: 3 s", "duration: 0.2 s"))
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(tmp_path / "ok")])
    assert r.exit_code == 0 and "stopped early" not in r.output
