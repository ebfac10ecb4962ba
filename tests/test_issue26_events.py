"""Issue 26, item 6: the events that end a multibody run cleanly, keeping and writing
what it computed: ``stop when`` (a condition of the condition language, located to the
integrator's accuracy), a singular position the motion reaches (``singular: stop``) and
a branch change (``singular: keep branch``). Checked against closed forms: the
pendulum's elliptic integrals and the N-four-bar's motion as one pendulum."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import quad, solve_ivp
from scipy.special import ellipk

import mechsolve as ms
from mechsolve.analyses.dynamics import simulate
from mechsolve.cli.main import main

from conftest import MECH

G = 9.81

# a point mass on a massless bar of 1 m, released at rest from the horizontal (90 deg
# from the bottom)
PENDULUM = """
name: pendulum
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], P: [1, 0]}, mass: 1 kg, com: P}
joints:
  O: [ground, bar]
driver: {joint: O, start: 0 deg}
gravity: 9.81 m/s^2
simulate: {duration: 2 s, step: 0.01 s, method: %s, rtol: 1e-11, atol: 1e-13,
           'stop when': '%s'%s}
"""

QUARTER = math.sqrt(1.0 / G) * ellipk(math.sin(math.radians(45)) ** 2)


def _fall_time(phi: float) -> float:
    """Time to fall from the horizontal to ``phi`` below it: the first integral
    omega^2 = 2 g sin(phi) / L, integrated (t = int dphi / omega)."""
    return quad(lambda p: 1.0 / math.sqrt(2 * G * math.sin(p)), 0.0, phi, epsabs=1e-14)[0]


@pytest.mark.parametrize("method, tol", [("DOP853", 1e-10), ("rk4", 1e-7)])
def test_pendulum_stops_at_the_quarter_period(method, tol):
    """``stop when: bar.angle <= -90 deg`` from the horizontal: the bottom is reached
    after a quarter period, sqrt(L / g) K(sin 45 deg), located to the integrator's
    accuracy (the adaptive method's event finder, Brent's method in the RK4 step)."""
    res = simulate(ms.loads(PENDULUM % (method, "bar.angle <= -90 deg", "")))
    tr = res.trajectory
    assert tr.event == "stop when" and not tr.early
    assert tr.t[-1] == pytest.approx(QUARTER, abs=tol)
    assert tr.u[-1] == pytest.approx(-math.pi / 2, abs=10 * tol)
    assert np.all(np.diff(tr.t) > 0) and tr.t[-2] < tr.t[-1]  # every output before it
    assert "stopped at t = 0.5919604" in res.summary()


def test_a_compound_condition_is_located_by_its_switch():
    """``P.x <= 0.5 m and P.vy < 0``: not one comparison, so the switch of the condition
    itself is located; P.x = 0.5 m is 60 deg below the horizontal."""
    res = simulate(ms.loads(PENDULUM % ("DOP853", "P.x <= 0.5 m and P.vy < 0", "")))
    tr = res.trajectory
    assert tr.event == "stop when"
    assert tr.t[-1] == pytest.approx(_fall_time(math.radians(60)), abs=1e-9)


def test_a_condition_true_at_the_start_stops_there():
    res = simulate(ms.loads(PENDULUM % ("DOP853", "P.y <= 0", "")))
    tr = res.trajectory
    assert len(tr.t) == 1 and tr.t[0] == 0.0
    assert "holds at the start" in tr.stopped


def _invoke(tmp_path, text: str):
    f = tmp_path / "m.yaml"
    f.write_text(text)
    out = tmp_path / "o"
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(out), "--no-plots"])
    return r, out


def _times(out) -> np.ndarray:
    rows = list(csv.reader((out / "simulation.csv").open()))
    k = next(i for i, h in enumerate(rows[0]) if h.startswith("t ["))
    return np.array([float(row[k]) for row in rows[1:] if row and not row[0].startswith("#")])


def test_cli_stop_when_exits_0_with_the_reason_and_writes_the_rows(tmp_path):
    r, out = _invoke(tmp_path, PENDULUM % ("DOP853", "bar.angle <= -90 deg", ""))
    assert r.exit_code == 0, r.output
    assert "stopped at t = 0.591960487 s (stop when): 'bar.angle <= -90 deg' was met" in r.output
    assert "warning" not in r.output
    t = _times(out)
    assert t[-1] == pytest.approx(QUARTER, abs=1e-9) and len(t) == 61


def _singular_time(n: int) -> float:
    """The N-four-bar as one pendulum (closed form, see test_issue26_multibody): the
    first time its cranks are horizontal (theta = 0), where the equations lose rank."""
    inertia = (n + 1) / 3 + n
    mg = G * ((n + 1) / 2 + n)

    def flat(_, y):
        return y[0]

    flat.terminal = True
    sol = solve_ivp(
        lambda _, y: [y[1], -mg / inertia * math.cos(y[0])],
        (0, 3),
        [math.pi / 2, -1.0],
        events=flat,
        rtol=1e-13,
        atol=1e-13,
        method="DOP853",
    )
    return float(sol.t_events[0][0])


@pytest.mark.parametrize("n", [1, 2])
def test_n_four_bar_stops_at_its_singular_position(n):
    """``singular: stop``: the run ends where the cranks first lie horizontal (the
    closed form's instant), with the motion up to there."""
    mech = ms.load(MECH / f"nfourbar-{n}.yaml")
    mech.simulation.singular = "stop"
    res = simulate(mech)
    tr = res.trajectory
    assert tr.event == "singular" and tr.early
    assert tr.t[-1] == pytest.approx(_singular_time(n), abs=1e-7)
    b0 = res.point("B0")
    assert abs(b0.y[-1]) < 1e-7 and b0.x[-1] == pytest.approx(1.0, abs=1e-7)
    assert np.max(tr.violation) <= res.multibody.tol
    assert "a singular position at t = " in res.summary()


def test_keep_branch_stops_where_the_parallelogram_would_change_branch(tmp_path):
    """The parallelogram's loop B0-B1-A1 closes on the other side of B0 -> A1 once the
    cranks pass the horizontal: ``keep branch`` ends the run at that singular position;
    the CLI writes the rows, warns and exits 0 (the results are valid up to there)."""
    text = (MECH / "nfourbar-1.yaml").read_text()
    text = text.replace("atol: 1e-11,", "atol: 1e-11, singular: keep branch,")
    r, out = _invoke(tmp_path, text)
    assert r.exit_code == 0, r.output
    assert "the branch would change at the singular position at t = " in r.output
    assert "warning: the motion stopped early" in r.output
    assert _times(out)[-1] == pytest.approx(_singular_time(1), abs=1e-7)


def test_singular_pass_is_the_default_and_goes_through():
    mech = ms.load(MECH / "nfourbar-1.yaml")
    mech.simulation.duration = 1.0
    tr = simulate(mech).trajectory
    assert not tr.early and tr.t[-1] == pytest.approx(1.0) and tr.event == ""


@pytest.mark.parametrize(
    "old, new, words",
    [
        ("'stop when': 'bar.angle <= -90 deg'", "'stop when': 'bar.angle + 1'", "not a condition"),
        ("'stop when': 'bar.angle <= -90 deg'", "'stop when': 'Q.x < 0'", "Q"),
        ("rtol: 1e-11", "rtol: 1e-11, singular: maybe", "unknown choice 'maybe'"),
        (
            "driver: {joint: O, start: 0 deg}",
            "",
            "'singular: keep branch' reads the loops' branches through the sweep's analysis",
        ),
    ],
)
def test_bad_events_are_refused_with_a_clear_message(tmp_path, old, new, words):
    text = PENDULUM % ("DOP853", "bar.angle <= -90 deg", "")
    if not new:  # placed by a pose instead of a driver
        text = text.replace(old, "").replace(
            "rtol: 1e-11", "rtol: 1e-11, pose: {O: 0 deg}, singular: keep branch"
        )
    else:
        text = text.replace(old, new)
    r, _ = _invoke(tmp_path, text)
    assert r.exit_code == 2, r.output
    assert words in r.output and "Traceback" not in r.output


def test_reduced_formulation_refuses_stop_when(tmp_path):
    text = (MECH / "motor-linkage.yaml").read_text()
    text = text.replace("from: rest}", "from: rest, formulation: reduced, 'stop when': 'B.x < 0'}")
    r, _ = _invoke(tmp_path, text)
    assert r.exit_code == 2 and "'stop when' needs formulation: multibody" in r.output, r.output


POSED = """
name: pendulum placed by its pose
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], P: [1, 0]}, mass: 1 kg, com: P}
joints:
  O: [ground, bar]
gravity: 9.81 m/s^2
loads:
  brake: {torque: 2 N m, on: bar, when: P.y < -0.5 m}
simulate: {duration: 2 s, step: 0.005 s, method: DOP853, rtol: 1e-11, atol: 1e-13,
           pose: {O: 0 deg}, 'stop when': 'bar.angle <= -90 deg'}
"""


def test_pose_placed_mechanism_with_a_conditional_load_and_a_stop_condition():
    """A mechanism placed by simulate.pose reads conditions as one placed by its
    driver: a braking torque of 2 N m acts once P is 0.5 m below O (30 deg below the
    horizontal), and the run stops at the bottom. Below 30 deg the first integral is
    (1/2) m L^2 omega^2 = -m g L sin(theta) + T (theta - theta_1), theta_1 = -30 deg."""
    res = simulate(ms.loads(POSED))
    tr = res.trajectory
    assert tr.event == "stop when" and "stopped at t = " in res.summary()
    th, w = tr.q[:, 2], tr.qd[:, 2]
    assert th[-1] == pytest.approx(-math.pi / 2, abs=1e-9)
    th1 = -math.pi / 6
    free = th > th1
    np.testing.assert_allclose(w[free] ** 2, -2 * G * np.sin(th[free]), rtol=0, atol=1e-8)
    braked = ~free
    hand = -2 * G * np.sin(th[braked]) + 2 * 2.0 * (th[braked] - th1)
    np.testing.assert_allclose(w[braked] ** 2, hand, rtol=0, atol=1e-6)
    # the brake's work is in the energy balance
    assert tr.work[-1] == pytest.approx(2.0 * (-math.pi / 2 - th1), rel=1e-6)
    assert np.max(np.abs(tr.energy_residual)) < 1e-6


def test_pose_placed_mechanism_refuses_stroke_in_a_condition(tmp_path):
    text = POSED.replace("when: P.y < -0.5 m", "when: stroke(P.x) > 0.5")
    r, _ = _invoke(tmp_path, text)
    assert r.exit_code == 2 and "stroke() is a fraction of the stroke" in r.output, r.output


def test_stop_condition_met_next_to_a_singular_position():
    """Next to a singular position (``singular: stop``) the output steps are taken on all
    coordinates; a stop condition met there is located within that step: B0 5 mm above
    the cranks' horizontal position, at the closed form's instant."""
    mech = ms.loads(
        (MECH / "nfourbar-1.yaml")
        .read_text()
        .replace("atol: 1e-11,", "atol: 1e-11, singular: stop, 'stop when': 'B0.y <= 0.005 m',")
    )
    res = simulate(mech)
    tr = res.trajectory
    assert tr.event == "stop when", tr.stopped
    inertia, mg = 2 / 3 + 1, G * (1 + 1)

    def low(_, y):
        return math.sin(y[0]) - 0.005

    low.terminal = True
    sol = solve_ivp(
        lambda _, y: [y[1], -mg / inertia * math.cos(y[0])],
        (0, 3),
        [math.pi / 2, -1.0],
        events=low,
        rtol=1e-13,
        atol=1e-13,
        method="DOP853",
    )
    assert tr.t[-1] == pytest.approx(sol.t_events[0][0], abs=1e-7)
    assert res.point("B0").y[-1] == pytest.approx(0.005, abs=1e-8)
