"""The design batch asked only for what a study reads: the kinematics-only batch gives
the same kinematics as the full batch and as a hand-written closed form; a study that asks
for a force figure still gets it; the kinematics-only closed form of the benchmark is
checked on its own (loop closure, the branch, rates by central differences)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechsolve.analyses.batch import solve_designs
from mechsolve.analyses.study.designs import make_study
from mechsolve.analyses.study.execute import execute
from mechsolve.model.source import load_text
from mechsolve_bench.fourbar_batch import kinematics, kinematics_only, kinetostatics
from mechsolve_bench.study import _FOURBAR

C, D = 0.059, 0.0875  # rocker and ground (m)
OPTS = ["links.crank.points.A[0]=20, 25, 30 mm", "links.coupler.points.B[0]=96, 110 mm"]


def _study(text: str = _FOURBAR, opts=OPTS, step: str = "4 deg"):
    return make_study(load_text(text.replace("step: 1 deg", f"step: {step}"), "b.yaml"), opts)


def _wrap(x):
    return np.angle(np.exp(1j * x))


def test_kinematics_only_reference_closes_on_its_branch():
    a, b = np.array([0.02, 0.03]), np.array([0.096, 0.11])
    u = np.linspace(0.0, 2 * math.pi, 181)
    k = kinematics_only(a, b, C, D, u)
    A = np.stack([k["A.x"], k["A.y"]])
    B = np.stack([k["B.x"], k["B.y"]])
    assert np.allclose(np.hypot(*(A)), a[:, None], rtol=0, atol=1e-15)
    assert np.allclose(np.hypot(*(B - A)), b[:, None], rtol=0, atol=1e-15)
    assert np.allclose(np.hypot(B[0] - D, B[1]), C, rtol=0, atol=1e-15)
    # B on the left of A -> O4
    assert np.all((D - A[0]) * (B[1] - A[1]) - (-A[1]) * (B[0] - A[0]) > 0)
    assert np.allclose(k["th3"], np.arctan2(B[1] - A[1], B[0] - A[0]), atol=1e-14)
    assert np.allclose(k["sin_mu"], np.abs(np.sin(k["th3"] - k["th4"])), atol=1e-14)


@pytest.mark.parametrize("w2, al2", [(1.0, 0.0), (-2.5, 0.0), (1.5, 3.0)])
def test_kinematics_only_rates_by_central_differences(w2, al2):
    """th(u) along the motion u(t) = w2 t + al2 t^2 / 2 about t = 0."""
    a, b = np.array([0.02, 0.03]), np.array([0.096, 0.11])
    u0 = np.linspace(0.1, 6.0, 40)
    dt = 1e-5

    def at(t):
        return kinematics_only(a, b, C, D, u0 + w2 * t + 0.5 * al2 * t * t, w2=w2 + al2 * t)

    k0, kp, km = kinematics_only(a, b, C, D, u0, w2=w2, al2=al2), at(dt), at(-dt)
    for n in ("3", "4"):
        w = _wrap(kp["th" + n] - km["th" + n]) / (2 * dt)
        assert np.allclose(w, k0["w" + n], rtol=0, atol=1e-8 * abs(w2)), n
        al = (kp["w" + n] - km["w" + n]) / (2 * dt)
        assert np.allclose(al, k0["al" + n], rtol=0, atol=1e-6 * (w2 * w2 + abs(al2))), n
    assert "al3" not in kinematics_only(a, b, C, D, u0, acceleration=False)


def test_kinematics_only_batch_equals_the_full_batch_and_the_closed_form():
    study = _study()
    mechs = [study.mechanism(k) for k in range(len(study))]
    full = solve_designs(mechs)
    kin_b = solve_designs(mechs, forces=False)
    assert full.batched.all() and kin_b.batched.all()
    vals = np.array([study.values(k) for k in range(len(study))]) / 1e3
    ref = kinematics_only(vals[:, 0], vals[:, 1], C, D, kin_b.u)
    for k in range(len(mechs)):
        rf, rk = full.results(k), kin_b.results(k)
        assert rk.forces is None and rf.forces is not None
        for link, n in (("coupler", "3"), ("rocker", "4")):
            lf, lk = rf.link(link), rk.link(link)
            assert np.max(np.abs(lk.angle - lf.angle)) <= 1e-12
            assert np.max(np.abs(lk.omega - lf.omega)) <= 1e-12 * np.max(np.abs(lf.omega))
            assert np.max(np.abs(_wrap(lk.angle - ref["th" + n][k]))) < 1e-12
            assert np.max(np.abs(lk.omega - ref["w" + n][k])) < 1e-12
            if rk.solution.has_acceleration:
                assert np.max(np.abs(lk.alpha - lf.alpha)) <= 1e-12 * np.max(np.abs(lf.alpha))
                assert np.max(np.abs(lk.alpha - ref["al" + n][k])) < 1e-11
        for p in ("A", "B"):
            pk = rk.point(p)
            assert np.max(np.abs(pk.x - ref[p + ".x"][k])) < 1e-15
            assert np.max(np.abs(pk.y - ref[p + ".y"][k])) < 1e-15
        loop = next(i for i, g in enumerate(rk.analysis.plan) if g.n_modes == 2)
        assert np.max(np.abs(rk.solution.indicator[loop] - ref["sin_mu"][k])) < 1e-12


def test_a_study_with_forces_still_gets_its_force_figures():
    """The peak driving torque of each design's row against the hand-written free bodies
    (the pull's condition P.vx > 0 switches between samples: the peak is taken where it
    does not switch)."""
    study = _study(step="1 deg")
    rows = execute(study, jobs=1, chunk=len(study)).rows  # one batch
    vals = np.array([study.values(k) for k in range(len(study))]) / 1e3
    u = np.linspace(0.0, 2 * math.pi, 361)
    kin = kinematics(vals[:, 0], vals[:, 1], C, D, u)
    frc = kinetostatics(kin)
    peak = np.max(np.abs(frc["torque"]), axis=1)
    for k, row in enumerate(rows):
        got = row["max(abs(input.torque)) (samples) [N*m]"]
        assert abs(got - peak[k]) < 1e-9 * peak[k], (k, got, peak[k])
        for j in ("O2", "A", "B", "O4"):
            ref = np.max(np.hypot(frc[j + ".Fx"][k], frc[j + ".Fy"][k]))
            assert abs(row[f"max({j}.F) (samples) [N]"] - ref) < 1e-9 * ref, (k, j)
        assert math.isfinite(row["cycle.work [J]"])


# -- a study without forces: no accelerations where no figure reads them ---------------

KIN_FOURBAR = """
name: kinematics study
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0], P: {length: 60, angle: 30}}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 1 deg}
"""


def _limits(a, b, c=C, d=D):
    """Rocker swing (rad), time ratio and smallest transmission angle (rad) of a Grashof
    crank-rocker, from its triangles: the rocker's extremes are where crank and coupler
    are in line (O2 B = b + a, b - a), the transmission angle is extreme at crank angles
    0 and pi."""
    phi, crank = [], []
    for R, turn in ((b + a, 0.0), (b - a, math.pi)):
        phi.append(math.acos((d * d + c * c - R * R) / (2 * d * c)))  # at O4, from O4->O2
        crank.append(math.acos((d * d + R * R - c * c) / (2 * d * R)) + turn)
    fwd = (crank[0] - crank[1]) % (2 * math.pi)
    ratio = max(fwd, 2 * math.pi - fwd) / min(fwd, 2 * math.pi - fwd)
    mus = [math.acos((b * b + c * c - (d - s * a) ** 2) / (2 * b * c)) for s in (1.0, -1.0)]
    mu = min(min(m, math.pi - m) for m in mus)
    return abs(phi[0] - phi[1]), ratio, mu


def test_kinematics_only_batch_without_accelerations():
    study = _study(KIN_FOURBAR)
    mechs = [study.mechanism(k) for k in range(len(study))]
    full = solve_designs(mechs)
    lean = solve_designs(mechs, acceleration=False)
    assert lean.batched.all()
    for k in range(len(mechs)):
        rf, rl = full.results(k), lean.results(k)
        assert rf.solution.has_acceleration and not rl.solution.has_acceleration
        assert rl.solution.has_velocity
        for link in ("coupler", "rocker"):
            lf, ll = rf.link(link), rl.link(link)
            assert np.array_equal(lf.angle, ll.angle) and np.array_equal(lf.omega, ll.omega)
            assert np.isnan(ll.alpha).all()
        assert np.array_equal(rf.solution.indicator, rl.solution.indicator)
    # with forces the accelerations are computed whatever is asked
    forced = solve_designs(mechs[:2], forces=True, acceleration=False)
    assert forced.results(0).solution.has_acceleration


def test_a_kinematics_study_reads_no_accelerations_and_its_figures_are_right(monkeypatch):
    import mechsolve.analyses.study.execute as ex

    asked = []
    real, real_family = ex.solve_parsed, ex.solve_family

    def spy(mechs, **kw):
        asked.append(kw.get("acceleration"))
        return real(mechs, **kw)

    def spy_family(fam, **kw):  # a study's designs as a design family
        asked.append(kw.get("acceleration"))
        return real_family(fam, **kw)

    monkeypatch.setattr(ex, "solve_parsed", spy)  # (parsed designs: not checked again)
    monkeypatch.setattr(ex, "solve_family", spy_family)
    study = _study(KIN_FOURBAR, step="1 deg")
    rows = execute(study, jobs=1, chunk=len(study)).rows  # one batch
    assert asked and all(a is False for a in asked)
    for k, row in enumerate(rows):
        a, b = (v / 1e3 for v in study.values(k))
        swing, ratio, mu = _limits(a, b)
        assert row["status"] == "ok"
        assert abs(row["rocker.swing [deg]"] - math.degrees(swing)) < 1e-8
        assert abs(row["rocker.time_ratio [-]"] - ratio) < 1e-9
        assert abs(row["min(transmission_angle.B) [deg]"] - math.degrees(mu)) < 1e-8
        assert row == ex.solve_design(study, k)  # the design solved on its own


def test_a_study_whose_figure_reads_an_acceleration_still_gets_it():
    src = load_text(KIN_FOURBAR.replace("step: 1 deg", "step: 4 deg"), "k.yaml")
    study = make_study(src, OPTS, figures=["max(abs(rocker.alpha))"])
    rows = execute(study, jobs=1, chunk=len(study)).rows  # one batch
    vals = np.array([study.values(k) for k in range(len(study))]) / 1e3
    # the figure's extreme is located between the samples: against a fine grid
    ref = kinematics_only(vals[:, 0], vals[:, 1], C, D, np.linspace(0, 2 * math.pi, 720001))
    for k, row in enumerate(rows):
        (key,) = [c for c in row if c.startswith("max(abs(rocker.alpha))")]
        top = np.max(np.abs(ref["al4"][k]))
        assert abs(row[key] - top) < 1e-8 * top, (k, row[key], top)


# -- no recomputed trigonometry: the driver's angle repeats from design to design ------


def test_set_angle_over_one_period_equals_the_whole():
    from mechsolve.base.state import State

    u = np.linspace(-7.0, 7.0, 91)
    th = np.tile(u, 13)
    a, b = State(2, th.size), State(2, th.size)
    a.set_angle(0, th)
    b.set_angle(0, th, period=u.size)
    assert np.array_equal(a.block, b.block)
    assert np.array_equal(b.c[0], np.cos(th)) and np.array_equal(b.s[0], np.sin(th))
    c = State(2, 10)
    c.set_angle(0, np.arange(10.0), period=3)  # not a whole number of periods: all of it
    assert np.array_equal(c.c[0], np.cos(np.arange(10.0)))


def test_the_batch_turns_the_driver_angle_once_per_period(monkeypatch):
    """The crank on the ground turns through the same angles in every design: its cosine
    and sine are computed over one design's positions and repeated (the results equal
    the separate solves: tests/test_batch.py)."""
    from mechsolve.base.state import State

    calls = []
    real = State.set_angle

    def spy(self, i, th, idx=slice(None), period=0):
        calls.append((self.n, period))
        return real(self, i, th, idx, period)

    monkeypatch.setattr(State, "set_angle", spy)
    study = _study()
    mechs = [study.mechanism(k) for k in range(len(study))]
    # (with forces: the general pass; the kinematics-only program turns it once as a row,
    # tests/test_issue30_batchprogram.py)
    batch = solve_designs(mechs, forces=True)
    P = len(batch.u)
    assert (len(mechs) * P, P) in calls
