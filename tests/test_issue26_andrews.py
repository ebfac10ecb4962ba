"""Issue 26: Andrews' squeezing mechanism (the seven body mechanism of the IFToMM and
IVP test sets), posed as mechanisms/andrews.yaml with the published data, against the
published reference solution at t = 0.03 s and the published consistent start.

Reference: Test Set for IVP Solvers (F. Mazzia, F. Iavernaro, C. Magherini, University
of Bari), problem 'andrews', computed by PSIDE with rtol = atol = 1e-14; the problem as
in Hairer & Wanner, Solving Ordinary Differential Equations II, section VII.7."""

from __future__ import annotations

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses.dynamics import simulate

from conftest import MECH

# beta, Theta, gamma, Phi, delta, Omega, epsilon at t = 0.03 s, and their rates
ANGLES_003 = [
    0.1581077119629904e2,
    -0.1575637105984298e2,
    0.4082224013073101e-1,
    -0.5347301163226948,
    0.5244099658805304,
    0.5347301163226948,
    0.1048080741042263e1,
]
RATES_003 = [
    0.1139920302151208e4,
    -0.1424379294994111e4,
    0.1103291221937134e2,
    0.1929337464421385e2,
    0.5735699284790808,
    -0.1929337464421385e2,
    0.3231791658026955,
]
# the consistent start: beta'' and Theta'' (the other accelerations are zero)
ACCELERATIONS_0 = [14222.4439199541138705911625887, -10666.8329399655854029433719415]


def _published(values: np.ndarray, idx: dict) -> np.ndarray:
    """The links' absolute angles (or rates) as the published coordinates: k1 beta,
    k2 beta + Theta, k3 gamma, k4 Phi + delta, k5 delta, k6 Omega + epsilon, k7 epsilon."""
    a = {k: values[..., 3 * idx[k] + 2] for k in idx if k.startswith("k")}
    return np.stack(
        [
            a["k1"],
            a["k2"] - a["k1"],
            a["k3"],
            a["k4"] - a["k5"],
            a["k5"],
            a["k6"] - a["k7"],
            a["k7"],
        ],
        axis=-1,
    )


@pytest.fixture(scope="module")
def andrews():
    return simulate(ms.load(MECH / "andrews.yaml"))


def test_andrews_against_the_published_solution_at_0_03_s(andrews):
    """Every angle to 1e-8 rad (beta has turned 2.5 times: 15.8 rad) and every rate to
    1e-6 of its size, at the file's rtol 1e-10."""
    tr = andrews.trajectory
    idx = andrews.multibody.system.index
    assert tr.t[-1] == pytest.approx(0.03) and not tr.early
    np.testing.assert_allclose(_published(tr.q[-1], idx), ANGLES_003, rtol=0, atol=1e-8)
    np.testing.assert_allclose(_published(tr.qd[-1], idx), RATES_003, rtol=1e-6)


def test_andrews_starts_from_the_published_consistent_state(andrews):
    """The file's start (its driver angle, the side each loop closes on) is the
    published position at rest, and the first accelerations are the published ones."""
    tr = andrews.trajectory
    idx = andrews.multibody.system.index
    start = [
        -0.0617138900142764496358948458001,
        0.0,
        0.455279819163070380255912382449,
        0.222668390165885884674473185609,
        0.487364979543842550225598953530,
        -0.222668390165885884674473185609,
        1.23054744454982119249735015568,
    ]
    np.testing.assert_allclose(_published(tr.q[0], idx), start, rtol=0, atol=1e-12)
    np.testing.assert_allclose(_published(tr.qd[0], idx), 0.0, atol=1e-12)
    acc = _published(tr.qdd[0], idx)
    np.testing.assert_allclose(acc[:2], ACCELERATIONS_0, rtol=1e-9)
    np.testing.assert_allclose(acc[2:], 0.0, atol=1e-6)


def test_andrews_keeps_its_energy_and_its_constraints(andrews):
    """The torque's work goes into kinetic energy and the spring: T + V - W stays
    constant to the integrator's tolerance; the ten pins close to their tolerance."""
    tr = andrews.trajectory
    assert np.max(np.abs(tr.energy_residual)) < 1e-8 * np.max(np.abs(tr.work))
    k1 = 3 * andrews.multibody.system.index["k1"] + 2
    assert tr.work[-1] == pytest.approx(0.033 * (tr.q[-1, k1] - tr.q[0, k1]), rel=1e-9)
    assert np.max(tr.violation) <= andrews.multibody.tol


def test_the_pins_on_arrays_are_the_joints_equations():
    """The all-pins kernel evaluates the same equations, in the same rows, as the
    joints' constraints one by one, at an arbitrary configuration and rates."""

    mech = ms.load(MECH / "andrews.yaml")
    mech.simulation.duration = mech.simulation.step = 1e-4
    mb = simulate(mech).multibody
    assert mb.pins is not None
    rng = np.random.default_rng(26)
    q, qd = rng.normal(size=mb.nq), rng.normal(size=mb.nq)
    st = mb.state(q, qd)
    one_by_one = mb.system.constraints
    phi = np.concatenate([c.residual(st, 0.0)[:, 0] for c in one_by_one])
    gamma = np.concatenate([c.gamma(st, 0.0)[:, 0] for c in one_by_one])
    np.testing.assert_allclose(mb.residual(q, 0.0), phi, rtol=0, atol=1e-15)
    np.testing.assert_allclose(mb.jacobian(q), mb.system.jacobian(st)[0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(mb._nu_gamma(st, 0.0, True), gamma, rtol=0, atol=1e-15)


@pytest.mark.parametrize("name", ["andrews.yaml", "nfourbar-2.yaml"])
def test_bench_data_matches_the_examples(name):
    """The bench's copies are the files of mechanisms/ (update both together)."""
    import mechsolve_bench as bench

    assert bench.case_file(name).read_text(encoding="utf-8") == (MECH / name).read_text(
        encoding="utf-8"
    ), f"mechsolve_bench/data/{name} differs from mechanisms/{name}: copy it over"


def test_bench_multibody_case_runs_both_solvers_on_both_problems():
    """`mechsolve bench --quick --case multibody`: both problems over a short time,
    mechsolve and exudyn, each with its time, error column and the ratio."""
    from click.testing import CliRunner

    from mechsolve.cli.main import main

    pytest.importorskip("exudyn")
    r = CliRunner().invoke(main, ["bench", "--quick", "--case", "multibody"])
    assert r.exit_code == 0, r.output
    for name in ("nfourbar-2", "andrews"):
        assert f"{name}: mechsolve DOP853" in r.output
        assert f"{name}: exudyn generalized-alpha" in r.output
        assert f"{name}: mechsolve reduced (1 DOF)" in r.output
        assert "time exudyn / mechsolve reduced = " in r.output
        assert f"{name} (" in r.output and "time exudyn / mechsolve = " in r.output


def test_andrews_meets_no_singular_position():
    """``singular: stop`` watches the constraint equations' conditioning with angles
    weighed by the mechanism's size (7 cm here): Andrews' mechanism is never near a
    singular position, so the run is the same, with no step taken on all coordinates
    (with unweighted angles it looked singular throughout and bridged every step)."""
    mech = ms.load(MECH / "andrews.yaml")
    mech.simulation.singular = "stop"
    res = simulate(mech)
    tr = res.trajectory
    assert not tr.early and tr.bridges == 0
    idx = res.multibody.system.index
    np.testing.assert_allclose(_published(tr.q[-1], idx), ANGLES_003, rtol=0, atol=1e-8)


def test_andrews_on_the_reduced_path_against_the_published_solution():
    """Andrews' mechanism has one degree of freedom: with its torque given as the motor
    (as the bench poses it) the reduced path (the driver's one equation, the inertia
    tabulated over the turn) reaches the published angles at 0.03 s too."""
    from mechsolve_bench.multibody import _reduced

    mech = _reduced("andrews", None)
    mech.simulation.rtol, mech.simulation.atol = 1e-10, 1e-12
    res = simulate(mech)
    assert res.model is not None  # the reduced path's model of J(phi)
    a = {lk.name: res.link(lk.name).angle[-1] for lk in mech.links}
    got = np.array(
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
    d = np.angle(np.exp(1j * (got - np.array(ANGLES_003))))  # modulo a turn
    np.testing.assert_allclose(d, 0.0, atol=1e-7)
    assert res.trajectory.phi[-1] == pytest.approx(ANGLES_003[0], abs=1e-7)
