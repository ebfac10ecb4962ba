"""Driver motion that is not a constant speed: instants (theta, omega, alpha).

References written here, independently of mechsolve: the four-bar's and the slider-crank's
accelerations from the loop equations differentiated twice and solved by Cramer's rule,
with the crank's angular acceleration alpha2 != 0; the driving torque and pin forces from a
free-body solution of every link (tests/refsol.py); the power balance with the crank's own
kinetic energy changing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.analyses.instants import parse_instant, solve_instants
from mechsolve.cli.main import main

from refsol import Body, Rigid, newton_euler

# crank a, coupler b, rocker c, ground d; masses and inertias about the centres
a_, b_, c_, d_ = 0.3, 1.1, 0.8, 1.0
m2, m3, m4 = 2.0, 5.0, 3.0
J2, J3, J4 = 0.02, 0.5, 0.16

FOURBAR = f"""
ground: {{O2: [0, 0], O4: [{d_}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a_}, 0]}}, mass: {m2} kg, com: [{a_ / 2}, 0],
          inertia: {J2} kg m^2}}
  coupler: {{points: {{A: [0, 0], B: [{b_}, 0]}}, mass: {m3} kg, com: [{b_ / 2}, 0],
            inertia: {J3} kg m^2}}
  rocker: {{points: {{O4: [0, 0], B: [{c_}, 0]}}, mass: {m4} kg, com: [{c_ / 2}, 0],
           inertia: {J4} kg m^2}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 10 rad/s}}
"""

STATES = [(30.0, 10.0, 5.0), (123.0, -4.0, 60.0), (250.0, 2.5, -30.0), (0.0, 0.0, 12.0)]


def fourbar_reference(th2, w2, al2):
    """th3, th4, w3, w4, al3, al4 of the four-bar (B left of A -> O4)."""
    A = np.array([a_ * math.cos(th2), a_ * math.sin(th2)])
    D = np.array([d_, 0.0]) - A
    f = math.hypot(*D)
    psi = math.acos((b_ * b_ + f * f - c_ * c_) / (2 * b_ * f))
    th3 = math.atan2(D[1], D[0]) + psi
    B = A + b_ * np.array([math.cos(th3), math.sin(th3)])
    th4 = math.atan2(B[1], B[0] - d_)
    # a e^{i th2} + b e^{i th3} - c e^{i th4} - d = 0; differentiated: the 2x2 system
    # [-b sin3, c sin4; b cos3, -c cos4] [w3, w4] = [a w2 sin2, -a w2 cos2]
    M = np.array(
        [[-b_ * math.sin(th3), c_ * math.sin(th4)], [b_ * math.cos(th3), -c_ * math.cos(th4)]]
    )
    det = np.linalg.det(M)

    def cramer(r):
        return (
            (r[0] * M[1, 1] - M[0, 1] * r[1]) / det,
            (M[0, 0] * r[1] - r[0] * M[1, 0]) / det,
        )

    w3, w4 = cramer([a_ * w2 * math.sin(th2), -a_ * w2 * math.cos(th2)])
    r = [
        a_ * al2 * math.sin(th2)
        + a_ * w2**2 * math.cos(th2)
        + b_ * w3**2 * math.cos(th3)
        - c_ * w4**2 * math.cos(th4),
        -a_ * al2 * math.cos(th2)
        + a_ * w2**2 * math.sin(th2)
        + b_ * w3**2 * math.sin(th3)
        - c_ * w4**2 * math.sin(th4),
    ]
    al3, al4 = cramer(r)
    return th3, th4, w3, w4, al3, al4


def instants(states):
    mech = ms.loads(FOURBAR)
    at = [f"theta={t} deg, omega={w} rad/s, alpha={al} rad/s^2" for t, w, al in states]
    return solve_instants(mech, [parse_instant(mech, s) for s in at])


def test_fourbar_kinematics_at_instants():
    res = instants(STATES)
    for k, (t, w, al) in enumerate(STATES):
        th3, th4, w3, w4, al3, al4 = fourbar_reference(math.radians(t), w, al)
        cp, rk = res.link("coupler"), res.link("rocker")
        assert math.sin(cp.angle[k] - th3) == pytest.approx(0, abs=1e-12)
        assert math.sin(rk.angle[k] - th4) == pytest.approx(0, abs=1e-12)
        scale_w = abs(w) + 1
        scale_a = abs(al) + w * w + 1
        assert cp.omega[k] == pytest.approx(w3, rel=1e-10, abs=1e-12 * scale_w)
        assert rk.omega[k] == pytest.approx(w4, rel=1e-10, abs=1e-12 * scale_w)
        assert cp.alpha[k] == pytest.approx(al3, rel=1e-10, abs=1e-12 * scale_a)
        assert rk.alpha[k] == pytest.approx(al4, rel=1e-10, abs=1e-12 * scale_a)
        assert res.link("crank").alpha[k] == pytest.approx(al)


def test_fourbar_forces_at_instants_against_free_bodies():
    res = instants(STATES)
    th2 = np.radians([s[0] for s in STATES])
    w2 = np.array([s[1] for s in STATES])
    al2 = np.array([s[2] for s in STATES])
    ref = np.array([fourbar_reference(*s) for s in zip(th2, w2, al2)]).T
    th3, th4, w3, w4, al3, al4 = ref
    A = np.array([a_ * np.cos(th2), a_ * np.sin(th2)])
    zero = np.zeros((2, len(th2)))
    crank = Rigid(zero, zero, zero, th2, w2, al2)
    vA = crank.vel((a_, 0.0))
    aA = crank.acc((a_, 0.0))
    coupler = Rigid(A, vA, aA, th3, w3, al3)
    rocker = Rigid(np.array([[d_], [0.0]]), zero, zero, th4, w4, al4)
    bodies = {
        "crank": Body(crank).mass(m2, (a_ / 2, 0), J2),
        "coupler": Body(coupler).mass(m3, (b_ / 2, 0), J3),
        "rocker": Body(rocker).mass(m4, (c_ / 2, 0), J4),
    }
    B = coupler.pos((b_, 0.0))
    joints = [
        ("pin", "O2", "ground", "crank", np.zeros((2, len(th2)))),
        ("pin", "A", "crank", "coupler", A),
        ("pin", "B", "coupler", "rocker", B),
        ("pin", "O4", "ground", "rocker", rocker.O),
        ("driver", "T", "crank"),
    ]
    hand = newton_euler(bodies, joints)
    scale = np.max(np.abs(hand["T"])) + 1
    np.testing.assert_allclose(res.driving_effort, hand["T"], rtol=0, atol=1e-9 * scale)
    for j in ("O2", "A", "B", "O4"):
        r = res.reaction(j)
        fscale = np.max(np.abs(hand[j])) + 1
        np.testing.assert_allclose(r["Fx"], hand[j][0], rtol=0, atol=1e-9 * fscale)
        np.testing.assert_allclose(r["Fy"], hand[j][1], rtol=0, atol=1e-9 * fscale)
    # the power balance, with the crank's own kinetic energy changing (J2 w2 al2)
    f = res.forces
    assert np.all(
        np.abs(f.power_input - f.kinetic_rate - f.potential_rate + f.power_loads)
        <= 1e-12 * (np.abs(f.power_input) + np.abs(f.kinetic_rate) + 1)
    )
    assert np.all(np.abs(f.residual) <= 1e-9 * (np.abs(f.kinetic_rate) + 1))
    # the angular acceleration matters: against alpha = 0 the torque differs
    res0 = instants([(t, w, 0.0) for t, w, _ in STATES])
    assert np.max(np.abs(res0.driving_effort - res.driving_effort)) > 0.1


R_, L_, E_ = 0.12, 0.45, 0.03
SLIDER = f"""
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [{R_}, 0]}}}}
  rod: {{points: {{A: [0, 0], C: [{L_}, 0]}}}}
  piston: {{points: {{C: [0, 0]}}}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cyl: {{slider: [ground, piston], point: C, line: {{through: [0, {E_}], angle: 0}}}}
assembly: ["C.x > A.x"]
driver: {{joint: O, speed: 100 rad/s}}
"""


@pytest.mark.parametrize("state", [(40.0, 150.0, 900.0), (200.0, -80.0, -2500.0)])
def test_slider_crank_at_an_instant(state):
    t, w, al = state
    mech = ms.loads(SLIDER)
    res = solve_instants(
        mech, [parse_instant(mech, f"theta={t} deg, omega={w} rad/s, alpha={al} rad/s^2")]
    )
    th = math.radians(t)
    # r sin th + l sin phi = e, x = r cos th + l cos phi; differentiated twice
    phi = math.asin((E_ - R_ * math.sin(th)) / L_)
    wphi = -R_ * w * math.cos(th) / (L_ * math.cos(phi))
    alphi = (R_ * w * w * math.sin(th) - R_ * al * math.cos(th) + L_ * wphi**2 * math.sin(phi)) / (
        L_ * math.cos(phi)
    )
    vx = -R_ * w * math.sin(th) - L_ * wphi * math.sin(phi)
    ax = (
        -R_ * al * math.sin(th)
        - R_ * w * w * math.cos(th)
        - L_ * alphi * math.sin(phi)
        - L_ * wphi**2 * math.cos(phi)
    )
    rod, C = res.link("rod"), res.point("C")
    assert rod.omega[0] == pytest.approx(wphi, rel=1e-10)
    assert rod.alpha[0] == pytest.approx(alphi, rel=1e-10)
    assert C.vx[0] == pytest.approx(vx, rel=1e-10)
    assert C.ax[0] == pytest.approx(ax, rel=1e-10)
    assert C.ay[0] == pytest.approx(0.0, abs=1e-9 * abs(ax))


def test_cli_at_prints_a_table_and_writes_csv(tmp_path):
    f = tmp_path / "fb.yaml"
    f.write_text(FOURBAR)
    r = CliRunner().invoke(
        main,
        [
            "run",
            str(f),
            "-o",
            str(tmp_path / "o"),
            "--at",
            "theta=30 deg, omega=10 rad/s, alpha=5 rad/s^2",
        ],
    )
    assert r.exit_code == 0, r.output
    assert "instant 1: theta=30 deg" in r.output and "input.torque [N·m]" in r.output
    rows = (tmp_path / "o" / "instants.csv").read_text().splitlines()
    assert len(rows) == 2 and "crank.alpha [rad/s^2]" in rows[0]


@pytest.mark.parametrize(
    "spec, message",
    [
        ("omega=10 rad/s, alpha=5 rad/s^2", "has no 'theta'"),  # omega, alpha: the file's
        ("theta=30 deg, omega=10 m/s", "omega"),
        ("theta=30 deg; omega=1", "is not 'name=value'"),
        ("theta=30 deg, omega=1 rad/s, jerk=2", "unknown name 'jerk'"),
    ],
)
def test_bad_instants(tmp_path, spec, message):
    f = tmp_path / "fb.yaml"
    f.write_text(FOURBAR)
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--at", spec])
    assert r.exit_code == 2, r.output
    assert message in r.output and "Traceback" not in r.output


# --- motion laws of time -------------------------------------------------------------------


def with_motion(motion: str, sweep: str) -> str:
    return FOURBAR.replace("driver: {joint: O2, speed: 10 rad/s}", motion) + sweep + "\n"


def test_constant_acceleration_against_closed_form_and_free_bodies():
    """theta = 20 deg + 1.5 t + 4 t^2 / 2: every kinematic quantity against the closed
    form at (theta(t), omega(t), 4), the torque against free bodies, the power balance with
    the crank's own kinetic energy growing."""
    text = with_motion(
        "driver: {joint: O2, start: 20 deg, motion: {accelerate: 4 rad/s^2, from: 1.5 rad/s}}",
        "sweep: {duration: 2 s, time_step: 0.05 s}",
    )
    res = ms.solve(ms.loads(text))
    t = np.arange(41) * 0.05
    np.testing.assert_allclose(res.t, t, atol=1e-15)
    th2 = math.radians(20) + 1.5 * t + 2.0 * t * t
    w2 = 1.5 + 4.0 * t
    np.testing.assert_allclose(res.u, th2, rtol=1e-14)
    ref = np.array([fourbar_reference(*s) for s in zip(th2, w2, np.full_like(t, 4.0))]).T
    th3, th4, w3, w4, al3, al4 = ref
    cp, rk = res.link("coupler"), res.link("rocker")
    np.testing.assert_allclose(np.sin(cp.angle - th3), 0, atol=1e-12)
    np.testing.assert_allclose(cp.omega, w3, rtol=1e-10, atol=1e-12 * np.max(np.abs(w3)))
    np.testing.assert_allclose(rk.alpha, al4, rtol=1e-10, atol=1e-12 * np.max(np.abs(al4)))
    np.testing.assert_allclose(res.link("crank").alpha, 4.0)
    # the same positions as instants give the same forces
    mech = ms.loads(FOURBAR)
    inst = solve_instants(
        mech,
        [
            parse_instant(mech, f"theta={math.degrees(a)} deg, omega={w} rad/s, alpha=4 rad/s^2")
            for a, w in zip(th2[::10], w2[::10])
        ],
    )
    np.testing.assert_allclose(inst.driving_effort, res.driving_effort[::10], rtol=1e-9)
    f = res.forces
    assert np.max(np.abs(f.residual)) <= 1e-9 * np.max(np.abs(f.power_input))
    assert "driver motion: constant acceleration 4" in res.summary()


def test_segments_are_continuous_and_their_jumps_reported():
    """Started from rest: accelerate to 60 rpm in 0.5 s, run 1 s, decelerate to rest in
    0.5 s, dwell 0.5 s. Position and speed are continuous at the joins, the acceleration
    jumps there and the summary says where."""
    text = with_motion(
        "driver: {joint: O2, start: 0 deg, motion: {segments: [{accelerate: 0.5 s, to: 60 rpm}, "
        "{run: 1 s}, {decelerate: 0.5 s}, {dwell: 0.5 s}]}}",
        "sweep: {time_step: 0.01 s}",
    )
    res = ms.solve(ms.loads(text))
    assert res.ok.all() and res.t[-1] == pytest.approx(2.5)
    law = res.mechanism.driver.motion
    eps = 1e-9
    for tj in (0.5, 1.5, 2.0):
        before, after = law.at(np.array([tj - eps])), law.at(np.array([tj + eps]))
        # over 2 eps the position moves 2 eps w and the speed 2 eps a: no jump beyond
        assert after[0][0] == pytest.approx(before[0][0], abs=3 * eps * 2 * math.pi)
        assert after[1][0] == pytest.approx(before[1][0], abs=3 * eps * 4 * math.pi)
    w = 2 * math.pi  # 60 rpm
    # closed form: 1/2 a t^2 with a = w / 0.5, then w t, then symmetric braking
    total = 0.5 * w * 0.5 + w * 1.0 + 0.5 * w * 0.5
    assert res.u[-1] == pytest.approx(total, rel=1e-12)
    crank = res.link("crank")
    np.testing.assert_allclose(crank.omega[res.t <= 0.5], w / 0.5 * res.t[res.t <= 0.5], atol=1e-12)
    assert np.all(crank.omega[(res.t >= 2.0)] == 0)
    jumps = [round(j[0], 9) for j in res.motion_events()]
    assert jumps == [0.5, 1.5, 2.0]
    assert "driver acceleration jumps (position and speed continuous) at t = 0.5 s" in res.summary()
    f = res.forces
    assert np.nanmax(np.abs(f.residual)) <= 1e-9 * np.nanmax(np.abs(f.power_input))


def test_table_follows_the_same_law_to_the_splines_accuracy():
    """A dense table of the constant-acceleration law through a cubic spline (clamped at
    the given end speeds is not what 'clamped' means here: the law does not start at
    rest, so 'not-a-knot', exact for a quadratic): the kinematics agrees with the law."""
    ts = np.linspace(0.0, 1.0, 21)
    th = 0.3 + 1.0 * ts + 1.5 * ts**2
    rows = ", ".join(f"[{float(t)!r}, {math.degrees(x)!r} deg]" for t, x in zip(ts, th))
    table = with_motion(
        f"driver: {{joint: O2, motion: {{table: [{rows}]}}}}", "sweep: {time_step: 0.02 s}"
    )
    law = with_motion(
        "driver: {joint: O2, start: 0.3 rad, motion: {accelerate: 3 rad/s^2, from: 1 rad/s}}",
        "sweep: {duration: 1 s, time_step: 0.02 s}",
    )
    a, b = ms.solve(ms.loads(table), forces=False), ms.solve(ms.loads(law), forces=False)
    # not-a-knot cubic splines reproduce a quadratic exactly (to rounding)
    for q in ("angle", "omega", "alpha"):
        np.testing.assert_allclose(
            getattr(a.link("rocker"), q), getattr(b.link("rocker"), q), rtol=1e-9, atol=1e-9
        )


def test_a_law_that_leaves_the_assemblable_range_keeps_what_it_solved(tmp_path):
    """A non-Grashof four-bar whose crank accelerates past where the loop closes: the
    positions beyond are unassemblable rows, the summary says where (exit 0, warned)."""
    text = """
ground: {O2: [0, 0], O4: [1.0, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.6, 0]}}
  coupler: {points: {A: [0, 0], B: [0.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [0.5, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 0 deg, motion: {accelerate: 2 rad/s^2}}
sweep: {duration: 1.5 s, time_step: 0.01 s}
"""
    f = tmp_path / "ng.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 0, r.output
    res = ms.run(str(f), forces=False)
    closes = np.cos(res.u) >= 0.125  # |A O4| <= b + c
    np.testing.assert_array_equal(res.ok, closes)
    assert "it stops closing at driver angle 82.8192" in res.summary()


@pytest.mark.parametrize(
    "motion, sweep, message",
    [
        (
            "motion: {table: [[0, 0], [0.5, 10], [0.5, 20]]}",
            "sweep: {steps: 10}",
            "the times must increase",
        ),
        ("motion: {accelerate: 0, from: 0}", "sweep: {duration: 1 s}", "would not move"),
        (
            "motion: {accelerate: 1 rad/s^2}",
            "sweep: {range: 90 deg, time_step: 0.1 s}",
            "give only",
        ),
        (
            "speed: 1 rad/s, motion: {accelerate: 1 rad/s^2}",
            "sweep: {duration: 1 s}",
            "no constant speed",
        ),
        ("motion: {accelerate: 1 rad/s^2}", "sweep: {step: 1 deg}", "swept in time"),
        (
            "motion: {segments: [{accelerate: 1 s, to: 1 rad/s}, {dwell: 1 s}]}",
            "sweep: {steps: 10}",
            "a dwell needs the driver at rest",
        ),
        (
            "motion: {accelerate: 1 rad/s^2}",
            "sweep: {steps: 10}",
            "has no end: give the sweep's duration",
        ),
    ],
)
def test_bad_motion_laws(tmp_path, motion, sweep, message):
    text = with_motion(f"driver: {{joint: O2, {motion}}}", sweep)
    f = tmp_path / "bad.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 2, r.output
    assert message in r.output and "Traceback" not in r.output and "bad.yaml:" in r.output


def test_instants_listed_in_the_file_are_solved_beside_the_sweep(tmp_path):
    f = tmp_path / "fb.yaml"
    f.write_text(
        FOURBAR
        + "sweep: {range: 360 deg, step: 10 deg}\n"
        + "instants: [{theta: 30 deg, omega: 10 rad/s, alpha: 5 rad/s^2},\n"
        + "           {theta: 123 deg, omega: -4 rad/s}]\n"
    )
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert "instant 2: theta=123 deg, omega=-4 rad/s" in r.output
    assert (tmp_path / "o" / "results.csv").exists()
    rows = (tmp_path / "o" / "instants.csv").read_text().splitlines()
    assert len(rows) == 3
    # the same numbers as --at
    res = instants([(30.0, 10.0, 5.0), (123.0, -4.0, 0.0)])
    head = rows[0].split(",")
    k = head.index("input.torque [N*m]")
    for i in (0, 1):
        assert float(rows[i + 1].split(",")[k]) == pytest.approx(res.driving_effort[i], rel=1e-11)


def test_expression_law_exact_and_against_a_dense_table():
    """u(t) = 0.3 + 2 t + 0.5 sin(3 t): the driver's rates are the law's symbolic
    derivatives (exact), the rocker's motion is the closed form at those rates, and a
    dense table of the same law through a cubic spline agrees to the spline's accuracy."""
    law = with_motion(
        'driver: {joint: O2, motion: {law: "0.3 + 2 * t + 0.5 * sin(3 * t)"}}',
        "sweep: {duration: 2 s, time_step: 0.05 s}",
    )
    res = ms.solve(ms.loads(law), forces=False)
    t = res.t
    th2, w2, al2 = 0.3 + 2 * t + 0.5 * np.sin(3 * t), 2 + 1.5 * np.cos(3 * t), -4.5 * np.sin(3 * t)
    np.testing.assert_allclose(res.u, th2, rtol=1e-15)
    np.testing.assert_allclose(res.link("crank").omega, w2, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(res.link("crank").alpha, al2, rtol=1e-14, atol=1e-14)
    ref = np.array([fourbar_reference(*s) for s in zip(th2, w2, al2)]).T
    np.testing.assert_allclose(res.link("rocker").alpha, ref[5], rtol=1e-10, atol=1e-10)
    ts = np.linspace(0.0, 2.0, 801)
    rows = ", ".join(
        f"[{float(x)!r}, {float(0.3 + 2 * x + 0.5 * np.sin(3 * x))!r} rad]" for x in ts
    )
    table = with_motion(
        f"driver: {{joint: O2, motion: {{table: [{rows}]}}}}",
        "sweep: {duration: 2 s, time_step: 0.05 s}",
    )
    tab = ms.solve(ms.loads(table), forces=False)
    # a cubic spline with h = 2.5 ms: errors of order h^4 u'''' (u) to h^2 u'''' (u'')
    np.testing.assert_allclose(tab.u, res.u, atol=1e-9)
    np.testing.assert_allclose(tab.link("rocker").omega, res.link("rocker").omega, atol=1e-6)
    np.testing.assert_allclose(tab.link("rocker").alpha, res.link("rocker").alpha, atol=2e-3)


@pytest.mark.parametrize(
    "law, message",
    [("2 * t +", "law"), ("2 * x", "unknown name 'x'"), ("B.x * t", "law")],
)
def test_bad_expression_laws(tmp_path, law, message):
    f = tmp_path / "bad.yaml"
    f.write_text(
        with_motion(f'driver: {{joint: O2, motion: {{law: "{law}"}}}}', "sweep: {duration: 1 s}")
    )
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 2, r.output
    assert message in r.output and "bad.yaml:" in r.output and "Traceback" not in r.output
