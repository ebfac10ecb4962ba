"""Results solved before an edit of the model answer for the model as solved (R19 item 3).

A ``Results`` holds the motion and forces of the model as it was solved. The model is a
mutable object: a user may change a mass, a load, gravity, a point or the driver after
solving. The figures the results compute again (a position between two samples, the
plots' finer sweep, the summary's peaks between samples, the work) must still be those of
the model as solved, not a mixture of the old geometry with the new loads. The reference
is independent of the results under test: a fresh load of the original file solved, and
the driving torque at a sample by the power balance (virtual work) worked by hand from the
sample's kinematics.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses.dynamics import simulate
from mechsolve.results.run import for_plots

from conftest import MECH

FOURBAR = """
name: four-bar crank-rocker
units: {length: mm, angle: deg}
ground:
  O2: [0, 0]
  O4: [87.5, 0]
links:
  crank:
    points: {O2: [0, 0], A: [26.5, 0]}
    mass: 0.05 kg
    uniform_bar: [O2, A]
  coupler:
    points:
      A: [0, 0]
      B: [105.6, 0]
      P: {length: 60, angle: 30}
    mass: 0.2 kg
    uniform_bar: [A, B]
  rocker:
    points: {O4: [0, 0], B: [59, 0]}
    mass: 0.11 kg
    uniform_bar: [O4, B]
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 2 deg}
gravity: 9.81 m/s^2
loads:
  pull:
    force: [0, -2 N]
    at: P
    when: P.vx > 0
"""

I = 10  # the sample asked about: crank at 20 deg
# the bars' lengths (m) and each bar's ends (its centre of mass is their middle)
BARS = {"crank": ("O2", "A", 0.0265), "coupler": ("A", "B", 0.1056), "rocker": ("O4", "B", 0.059)}


def hand_torque(res, i: int, masses: dict, force: tuple[float, float]) -> float:
    """The crank torque at sample ``i`` by the power balance: T w = sum(m a.v + J alpha w)
    - sum(m g.v) - F.v_P, with each bar uniform (centre at the middle, J = m0 l^2 / 12 of
    the mass the file gave, which an edit of the mass does not change) and the pull on P
    while P moves right. The kinematics are the sample's; the forces are worked here."""
    g = np.array([0.0, -9.81])
    file_mass = {"crank": 0.05, "coupler": 0.2, "rocker": 0.11}
    power = 0.0
    for name, (a, b, length) in BARS.items():
        pa, pb = res.point(a), res.point(b)
        v = 0.5 * np.array([pa.vx[i] + pb.vx[i], pa.vy[i] + pb.vy[i]])
        acc = 0.5 * np.array([pa.ax[i] + pb.ax[i], pa.ay[i] + pb.ay[i]])
        lk = res.link(name)
        J = file_mass[name] * length**2 / 12
        m = masses[name]
        power += m * acc @ v + J * lk.alpha[i] * lk.omega[i] - m * g @ v
    P = res.point("P")
    if P.vx[i] > 0:
        power -= force[0] * P.vx[i] + force[1] * P.vy[i]
    return power / res.link("crank").omega[i]


OLD = {"crank": 0.05, "coupler": 0.2, "rocker": 0.11}
NEW = {"crank": 0.05, "coupler": 2.0, "rocker": 0.11}


def edited():
    """A model solved, then edited: the coupler's mass and the pull's force."""
    m = ms.loads(FOURBAR)
    r = ms.solve(m)
    m.link("coupler").mass = 2.0
    m.loads[0].force = (0.0, -50.0)
    return m, r


def test_the_hand_value_is_the_solve_s():
    # the reference itself, against the solver's stored effort of a fresh solve
    r0 = ms.solve(ms.loads(FOURBAR))
    assert r0.driving_effort[I] == pytest.approx(hand_torque(r0, I, OLD, (0, -2)), rel=1e-9)


def test_effort_and_reaction_between_samples_are_the_model_as_solved():
    m, r = edited()
    r0 = ms.solve(ms.loads(FOURBAR))  # the original file, loaded afresh
    want = hand_torque(r0, I, OLD, (0, -2))
    assert r.driving_effort[I] == pytest.approx(want, rel=1e-9)  # stored: never changed
    assert r.effort_at([r.u[I]], I)[0] == pytest.approx(want, rel=1e-9)
    x = r.u[I] + math.radians(0.7)  # between two samples
    assert r.effort_at([x], I)[0] == pytest.approx(r0.effort_at([x], I)[0], rel=1e-12)
    for c in ("Fx", "Fy", "F"):
        assert r.reaction_at("O2", r.u[I], I)[c][0] == pytest.approx(
            r0.reaction("O2")[c][I], rel=1e-9, abs=1e-12
        )
    one, one0 = r.solved_near(np.array([x]), I), r0.solved_near(np.array([x]), I)
    assert np.allclose(one.state.th, one0.state.th, rtol=0, atol=1e-13)


def test_the_plots_sweep_summary_and_work_are_the_model_as_solved():
    m, r = edited()
    r0 = ms.solve(ms.loads(FOURBAR))
    fine, fine0 = for_plots(m, r), for_plots(r0.mechanism, r0)
    assert len(fine.u) == len(fine0.u) > len(r.u)
    assert np.allclose(fine.driving_effort, fine0.driving_effort, rtol=1e-12, atol=1e-15)
    j = int(np.argmin(abs(fine.u - r.u[I])))
    assert fine.driving_effort[j] == pytest.approx(hand_torque(r0, I, OLD, (0, -2)), rel=1e-9)
    assert r.work() == pytest.approx(r0.work(), rel=1e-12)
    assert r.summary(figures=fine) == r0.summary(figures=fine0)


def test_a_geometry_or_driver_edit_after_solving(tmp_path):
    m = ms.loads(FOURBAR)
    r = ms.solve(m)
    r0 = ms.solve(ms.loads(FOURBAR))
    m.ground["O4"] = (0.095, 0.0)  # a ground point moved
    m.driver.speed = -2.0  # and the driver reversed, faster
    m.gravity = (0.0, -20.0)
    x = r.u[I] + math.radians(0.5)
    assert r.effort_at([x], I)[0] == pytest.approx(r0.effort_at([x], I)[0], rel=1e-12)
    lim, lim0 = r.limit_positions(), r0.limit_positions()
    assert len(lim) == len(lim0) == 1
    assert (lim[0].u_low, lim[0].u_high) == pytest.approx((lim0[0].u_low, lim0[0].u_high))
    # the table of the results as solved (driver travel, columns), the edited model untouched
    a, b = r.to_csv(tmp_path / "r.csv"), r0.to_csv(tmp_path / "r0.csv")
    assert a.read_text() == b.read_text()
    assert m.ground["O4"] == (0.095, 0.0) and m.driver.speed == -2.0
    assert r.mechanism is not m and r.mechanism.driver.speed == 1.0


def test_a_new_solve_of_the_edited_model_gives_the_new_answer():
    m, r = edited()
    r1 = ms.solve(m)
    new = hand_torque(r1, I, NEW, (0, -50))
    assert r1.driving_effort[I] == pytest.approx(new, rel=1e-9)
    assert r1.effort_at([r1.u[I]], I)[0] == pytest.approx(new, rel=1e-9)
    assert abs(new - r.driving_effort[I]) > 0.5  # (a different answer: 1.00 against 0.06)
    assert r.effort_at([r.u[I]], I)[0] == pytest.approx(r.driving_effort[I], rel=1e-9)


def test_unchanged_model_is_used_as_it_is():
    m = ms.loads(FOURBAR)
    r = ms.solve(m)
    an = r.analysis
    r.effort_at([r.u[I]], I)
    assert r.model_as_solved() is m and r.mechanism is m and r.analysis is an


def test_designs_solved_together_then_edited():
    # solve_designs builds each design's results when asked: a design edited since is
    # still the design as solved (its points and its effort between samples)
    m1 = ms.loads(FOURBAR)
    m2 = ms.loads(FOURBAR.replace("O4: [87.5, 0]", "O4: [90, 0]"))
    batch = ms.solve_designs([m1, m2])
    m1.link("coupler").mass = 2.0
    m1.link("coupler").points["P"] = np.array([0.0, 0.05])
    m1.ground["O4"] = (0.095, 0.0)
    r, r0 = batch.results(0), ms.solve(ms.loads(FOURBAR))
    assert np.allclose(r.point("P").x, r0.point("P").x, rtol=0, atol=1e-15)
    # P at 60 mm from A at 30 deg from A -> B, A at 26.5 mm from O2 at 20 deg: by hand
    A = 0.0265 * np.array([math.cos(math.radians(20)), math.sin(math.radians(20))])
    th = r0.link("coupler").angle[I] + math.radians(30)
    assert r.point("P").x[I] == pytest.approx(A[0] + 0.06 * math.cos(th), abs=1e-15)
    want = hand_torque(r0, I, OLD, (0, -2))
    assert r.effort_at([r.u[I]], I)[0] == pytest.approx(want, rel=1e-9)
    assert batch.results(1).mechanism is m2  # (unchanged: the design itself)


def test_streamed_results_then_edited(tmp_path):
    m = ms.loads(FOURBAR)
    _, coarse = ms.stream(m, tmp_path / "s.csv", chunk=50)
    m.link("coupler").mass = 2.0
    m.loads[0].force = (0.0, -50.0)
    r0 = ms.solve(ms.loads(FOURBAR))
    k = int(np.argmin(abs(coarse.u - r0.u[I])))  # the coarse sample nearest 20 deg
    want = hand_torque(coarse, k, OLD, (0, -2))  # its stored motion, the original loads
    assert coarse.driving_effort[k] == pytest.approx(want, rel=1e-9)
    assert coarse.effort_at([coarse.u[k]], k)[0] == pytest.approx(want, rel=1e-9)
    x = coarse.u[k]
    assert r0.effort_at([x], I)[0] == pytest.approx(want, rel=1e-9)


def test_a_simulated_motion_then_edited():
    # the forces of a simulated motion computed again at one of its samples, after the
    # model's masses and gravity were edited: those of the machine as simulated (the
    # effort stored at that sample, computed before the edit)
    m = ms.load(MECH / "motor-linkage.yaml")
    r = simulate(m)
    before = r.summary()
    for lk in m.links:
        lk.mass = (lk.mass or 0.0) + 5.0
    m.gravity = (0.0, -30.0)
    i = len(r.u) // 3
    assert r.effort_at([r.u[i]], i)[0] == pytest.approx(r.driving_effort[i], rel=1e-9)
    assert r.summary() == before


def test_a_peak_located_between_samples_after_an_edit():
    # the requirements' extremes are located between the samples of the plots' sweep
    from mechsolve.results.requirements import evaluate_figure

    m, r = edited()
    r0 = ms.solve(ms.loads(FOURBAR))
    fig = "max(abs(input.torque))"
    want = evaluate_figure(fig, r0.mechanism, r0)
    top = float(np.nanmax(np.abs(for_plots(r0.mechanism, r0).driving_effort)))
    assert top <= want < top * (1 + 1e-3)  # at or just above the largest sample
    assert evaluate_figure(fig, m, r) == pytest.approx(want, rel=1e-12)


def test_the_plots_sweep_made_before_the_edit():
    from mechsolve.results.requirements import evaluate_figure

    m = ms.loads(FOURBAR)
    r = ms.solve(m)
    fine = for_plots(m, r)  # made (and kept) before the edit
    m.link("coupler").mass = 2.0
    m.loads[0].force = (0.0, -50.0)
    r0 = ms.solve(ms.loads(FOURBAR))
    fig = "max(abs(input.torque))"
    assert evaluate_figure(fig, m, r) == pytest.approx(evaluate_figure(fig, r0.mechanism, r0))
    x = fine.u[7] + 1e-3
    assert fine.effort_at([x], 7)[0] == pytest.approx(r0.effort_at([x], 3)[0], rel=1e-12)
    assert for_plots(m, r) is fine and fine.mechanism is not m


POSED = """
name: pendulum placed by its pose
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], P: [1, 0]}, mass: 1 kg, com: P}
joints:
  O: [ground, bar]
gravity: 9.81 m/s^2
simulate: {duration: 0.5 s, step: 0.01 s, pose: {O: 0 deg}}
"""


def test_a_posed_simulation_then_edited():
    # a mechanism placed by its pose (no driver): its table of points after the bar's
    # point P was moved is still the bar as simulated, P 1 m from O at the bar's angle
    m = ms.loads(POSED)
    r = simulate(m)
    m.links[0].points["P"] = (2.0, 0.0)
    m.links[0].mass = 3.0
    cols = {name: v for name, v in r.columns()}
    th = np.radians(cols["bar.angle [deg]"])
    assert len(th) > 10 and np.ptp(th) > 0.1
    assert np.allclose(cols["bar.P.x [m]"], np.cos(th), rtol=0, atol=1e-12)
    assert np.allclose(cols["bar.P.y [m]"], np.sin(th), rtol=0, atol=1e-12)
    assert m.links[0].points["P"] == (2.0, 0.0)  # (the model itself as edited)
