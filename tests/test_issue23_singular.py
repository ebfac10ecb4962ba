"""Singular positions decided with the rounding of the pose (issue 23, 1.1 and 1.2).

A pose that rounding alone puts 4e-8 off an exact bifurcation used to pass for a regular
position, with rates of 1e16 and the driving torque of a redundant parallelogram off by
25 N m; a chain of two parallelograms folded at its collinear position. Every value here
is checked against the closed form of a parallelogram: each crank turns with the driver,
each coupler translates, and the driving torque balances gravity alone (the kinetic
energy is constant): T = g cos(theta) sum(m l_c)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs
from test_hard_cases import REDUNDANT

import mechsolve as ms
from mechsolve.cli.main import main


def wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


ISSUE_PARALLELOGRAM = """
name: parallelogram
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [100, 0]}
links:
  crank: {points: {O2: [0, 0], A: [40, 0]}}
  coupler: {points: {A: [0, 0], B: [100, 0]}}
  rocker: {points: {O4: [0, 0], B: [40, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 10 deg}
"""


def test_rates_at_a_collinear_position_reached_to_rounding(tmp_path):
    """The issue's parallelogram: at 180 deg the rocker turned at -1.45e16 rad/s."""
    res = ms.solve(ms.loads(ISSUE_PARALLELOGRAM))
    assert res.ok.all()
    rock, coup, B = res.link("rocker"), res.link("coupler"), res.point("B")
    np.testing.assert_allclose(rock.omega, 1.0, atol=1e-8)
    np.testing.assert_allclose(coup.omega, 0.0, atol=1e-8)
    np.testing.assert_allclose(rock.alpha, 0.0, atol=1e-6)
    # B moves on a circle of 40 mm about O4 at 1 rad/s
    np.testing.assert_allclose(B.vx, -0.04 * np.sin(res.u), atol=1e-9)
    np.testing.assert_allclose(B.vy, 0.04 * np.cos(res.u), atol=1e-9)
    np.testing.assert_allclose(B.ay, -0.04 * np.sin(res.u), atol=1e-8)
    f = tmp_path / "p.yaml"
    f.write_text(ISSUE_PARALLELOGRAM)
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 0, r.output
    # the summary in the file's units (mm)
    assert "B: x 60 .. 140 mm, y -40 .. 40 mm, |v| max 40 mm/s (of the" in r.output
    assert "e+1" not in r.output  # no huge number anywhere in the summary


def _parallelogram(a: float, d: float, start: float, step: float, sweep: float, speed: float):
    return f"""
ground: {{O2: [0, 0], O4: [{d!r}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a!r}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{d!r}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{a!r}, 0]}}}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
driver: {{joint: O2, speed: {speed!r} rad/s, start: {start!r} deg}}
sweep: {{range: {sweep!r} deg, step: {step!r} deg}}
"""


@settings(
    max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(
    a=hs.sampled_from([0.3, 1.0, 2.5]),
    ratio=hs.sampled_from([1.0, 1.3, 1.7, 4.0]),  # ratio 1: a rhombus
    start=hs.one_of(
        hs.sampled_from([0.0, 180.0, -180.0, 360.0]),  # exactly at a bifurcation
        hs.floats(-360.0, 360.0, allow_nan=False).map(lambda x: round(x, 7)),
    ),
    step=hs.one_of(
        hs.sampled_from([1.0, 0.5, 10.0, 360.0 / 7, 45.0]),
        hs.floats(0.3, 50.0).map(lambda x: round(x, 5)),
    ),
    speed=hs.sampled_from([1.0, -2.0]),
)
def test_parallelograms_stay_parallelograms_with_bounded_rates(a, ratio, start, step, speed):
    """Property: drawn as a parallelogram (every link along its x axis), swept from any
    start (exact bifurcations included) at any step, the mechanism stays a parallelogram
    and no rate exceeds what its geometry allows (|v| <= a |w|, |omega| = |w|)."""
    d = a * ratio
    # the sketch: the parallelogram's B at the start; where the start is a bifurcation
    # (both branches meet there), a little past it, on the side the motion goes to
    s = math.radians(start)
    if abs(math.sin(s)) < 1e-6:  # (a start this near is the bifurcation, see branches)
        s += math.radians(5.0) * math.copysign(1.0, speed)
    sketch = f"assembly: {{sketch: {{B: [{d + a * math.cos(s)!r}, {a * math.sin(s)!r}]}}}}\n"
    res = ms.solve(ms.loads(_parallelogram(a, d, start, step, 360.0, speed) + sketch))
    assert res.ok.all()
    crank, rock, coup = res.link("crank"), res.link("rocker"), res.link("coupler")
    assert np.max(np.abs(wrap(coup.angle))) < 1e-7
    assert np.max(np.abs(wrap(rock.angle - crank.angle))) < 1e-7
    w = abs(speed)
    for m in (rock, coup):
        assert np.all(np.isfinite(m.omega)) and np.all(np.isfinite(m.alpha))
    assert np.max(np.abs(rock.omega - speed)) < 1e-6 * w
    assert np.max(np.abs(coup.omega)) < 1e-6 * w
    assert np.max(np.abs(rock.alpha)) < 1e-5 * w * w
    for p in ("A", "B"):
        P = res.point(p)
        assert np.max(np.hypot(P.vx, P.vy)) <= a * w * (1 + 1e-6)
        assert np.max(np.hypot(P.ax, P.ay)) <= a * w * w * (1 + 1e-5)


# a chain of two parallelograms sharing the middle crank (the N-four-bar of the
# multibody benchmarks with N = 2): pivots at x = 0, 1, 2 m, unit cranks and couplers
CHAIN = """
name: two-parallelogram chain
ground: {{O1: [0, 0], O2: [1, 0], O3: [2, 0]}}
links:
  crank1: {{points: {{O1: [0, 0], A: [1, 0]}}, mass: 1, uniform_bar: [O1, A]}}
  crank2: {{points: {{O2: [0, 0], B: [1, 0]}}, mass: 1, uniform_bar: [O2, B]}}
  crank3: {{points: {{O3: [0, 0], C: [1, 0]}}, mass: 1, uniform_bar: [O3, C]}}
  bar1: {{points: {{A: [0, 0], B: [1, 0]}}, mass: 1, uniform_bar: [A, B]}}
  bar2: {{points: {{B: [0, 0], C: [1, 0]}}, mass: 1, uniform_bar: [B, C]}}
joints:
  O1: [ground, crank1]
  O2: [ground, crank2]
  O3: [ground, crank3]
  A: [crank1, bar1]
  B: [crank2, bar1, bar2]
  C: [bar2, crank3]
{assembly}driver: {{joint: O1, speed: -1 rad/s, start: {start} deg}}
sweep: {{range: 360 deg, step: {step} deg}}
gravity: 9.81 m/s^2
"""


@pytest.mark.parametrize(
    "start, step",
    [(90, 1), (90, 0.5), (90, 360 / 7), (90, 10), (0, 1), (0, 360 / 7), (37.5, 2)],
)
def test_chain_of_two_parallelograms_stays_on_the_parallelogram(start, step):
    """Driven clockwise, the second loop used to fold at the collinear position (its
    discriminant's rate there depends on the first loop's, which is undetermined)."""
    c, s = math.cos(math.radians(start)), math.sin(math.radians(start))
    sketch = f"assembly: {{sketch: {{B: [{1 + c!r}, {s!r}], C: [{2 + c!r}, {s!r}]}}}}\n"
    res = ms.solve(ms.loads(CHAIN.format(assembly=sketch, start=start, step=step)))
    assert res.ok.all()
    th = res.link("crank1").angle
    for c in ("crank2", "crank3"):
        assert np.max(np.abs(wrap(res.link(c).angle - th))) < 1e-9
        np.testing.assert_allclose(res.link(c).omega, -1.0, atol=1e-8)
    for b in ("bar1", "bar2"):
        assert np.max(np.abs(wrap(res.link(b).angle))) < 1e-9
        np.testing.assert_allclose(res.link(b).omega, 0.0, atol=1e-8)
    # T w = dV/dt with V = g sin(theta) (3 m l/2 + 2 m l)
    hand = 9.81 * np.cos(th) * 3.5
    np.testing.assert_allclose(res.driving_effort, hand, rtol=0, atol=1e-6)


def test_chain_started_collinear_runs_from_the_command_line(tmp_path):
    """`mechsolve run` crashed (exit 4, NaN in the limit positions) on this start."""
    f = tmp_path / "chain.yaml"
    f.write_text(CHAIN.format(assembly="", start=0, step=1))
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    # exit 0, warned: the reactions at the collinear positions are not determined (blank)
    assert r.exit_code == 0, r.output
    assert "forces indeterminate at 3 singular position(s)" in r.output
    assert "361 of 361 positions solved" in r.output
    # the summary says what it chose at the singular start
    assert "start: loop B (crank2 O2-B, bar1 B-A): the branch nearest to the drawn pose" in r.output
    assert "the start is singular" in r.output
    # the torque's extremes are at the collinear positions, where it is its limit
    assert "driving torque (1° samples): max 34.335 N·m at driver angle" in r.output


@pytest.mark.parametrize("start", [30, 0])
@pytest.mark.parametrize("step", [1, 0.5, 2, 7, 15])
def test_redundant_parallelogram_torque_at_every_step(start, step):
    """At 1 deg the pose at 360 deg is 3.5e-8 off collinear: T = 8.58 N m was printed for
    34.335; started at 0 deg it exited 3 ('the constraints leave 1 coordinate free')."""
    text = REDUNDANT.replace("start: 20 deg", f"start: {start} deg").replace(
        "range: 140 deg, step: 10 deg", f"range: 360 deg, step: {step} deg"
    )
    res = ms.solve(ms.loads(text))
    assert res.ok.all()
    hand = 9.81 * np.cos(res.u) * (2 * 0.5 + 2 * 0.5 + 3 * 0.5 + 6 * 1.0)
    np.testing.assert_allclose(res.driving_effort, hand, rtol=0, atol=1e-6)
    for crank in ("crank", "crank2", "crank3"):
        np.testing.assert_allclose(res.link(crank).omega, 2.0, atol=1e-8)
    np.testing.assert_allclose(wrap(res.link("coupler").angle), 0.0, atol=1e-7)


@pytest.mark.parametrize("offset_deg", [1e-2, 1e-3, 1e-4, 1e-6, 0.0])
def test_values_next_to_a_bifurcation_are_right(offset_deg):
    """Next to a collinear position (1e-2 to 1e-6 deg) the computed accelerations were off
    by 2e-4 to 2e5 of omega^2 and the torque by up to 3e2 of its size: they are its limit
    along the motion there."""
    rng = 10 + offset_deg
    text = REDUNDANT.replace("start: 20 deg", "start: 170 deg").replace(
        "range: 140 deg, step: 10 deg", f"range: {rng!r} deg, step: {rng!r} deg"
    )
    res = ms.solve(ms.loads(text))
    hand = 9.81 * np.cos(res.u) * (2 * 0.5 + 2 * 0.5 + 3 * 0.5 + 6 * 1.0)
    np.testing.assert_allclose(res.driving_effort, hand, rtol=0, atol=1e-6)
    np.testing.assert_allclose(res.link("crank3").alpha, 0.0, atol=1e-6)
    np.testing.assert_allclose(res.link("crank3").omega, 2.0, atol=1e-8)


@pytest.mark.parametrize("method", ["rk4", "RK45", "DOP853"])
def test_a_motor_drives_the_chain_through_its_collinear_positions(method):
    """simulate on the chain used to stop ('the motion left the range where the mechanism
    closes') with every method but split-newton. Independent reference: its reduced
    inertia is constant, J = 3 (m l^2 / 3) + 2 m l^2 = 3 kg m^2, so the crank angle obeys
    J theta'' = d M(d theta') - dV/dtheta, V = g sin(theta) sum(m l_c), with the motor
    M(w) = 50 - 1.25 w acting in the driver's direction d = -1; integrated by scipy."""
    from scipy.integrate import solve_ivp

    from mechsolve.analyses.dynamics import simulate

    text = CHAIN.format(
        assembly="assembly: {sketch: {B: [1, 1], C: [2, 1]}}\n", start=90, step=1
    ) + (
        "motor: {stall: 50 N m, slope: 1.25 N m s}\n"
        f"simulate: {{duration: 2 s, step: 0.002 s, from: rest, method: {method}}}\n"
    )
    tr = simulate(ms.loads(text)).trajectory
    assert not tr.early and tr.t[-1] == pytest.approx(2.0)
    # (next to a collinear position J is the rates' limit along the motion, O(h^4))
    np.testing.assert_allclose(tr.J, 3.0, rtol=1e-8)

    def rhs(t, y):
        th, w = y
        return [w, (-(50 - 1.25 * -w) - 9.81 * 3.5 * np.cos(th)) / 3.0]

    ref = solve_ivp(rhs, (0, 2), [math.pi / 2, 0.0], t_eval=tr.t, rtol=1e-11, atol=1e-12)
    assert abs(tr.phi[-1] - tr.phi[0]) > 4 * math.pi  # through collinear positions
    np.testing.assert_allclose(tr.phi, ref.y[0], atol=1e-6)
    np.testing.assert_allclose(tr.omega, ref.y[1], atol=1e-5)


def _kite_B(a: float, b: float, th, sign: float):
    """A kite (crank = frame = a, coupler = rocker = b > a): both solutions for B lie on
    the perpendicular bisector of A-O4, which passes through O2 at the angle th/2, at
    a cos(th/2) +- sqrt(b^2 - a^2 sin^2(th/2)) from O2: two smooth motions, each
    closing after two turns of the crank."""
    th = np.asarray(th, float)
    h = np.sqrt(b * b - (a * np.sin(th / 2)) ** 2)
    r = a * np.cos(th / 2) + sign * h
    return r * np.cos(th / 2), r * np.sin(th / 2)


@settings(
    max_examples=30, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(
    b_over_a=hs.sampled_from([1.2, 2.0, 3.5]),
    start=hs.one_of(
        hs.sampled_from([0.0, 360.0, -360.0, 180.0]),  # 0, 360: A meets O4
        hs.floats(-400.0, 400.0, allow_nan=False).map(lambda x: round(x, 6)),
    ),
    step=hs.one_of(hs.sampled_from([1.0, 7.5, 360.0 / 7]), hs.floats(0.5, 30.0)),
    speed=hs.sampled_from([1.0, -1.5]),
    sign=hs.sampled_from([1.0, -1.0]),
)
def test_kites_follow_their_sketched_smooth_motion(b_over_a, start, step, speed, sign):
    """Property: a kite sketched on one of its two smooth motions follows it over two
    turns (through the positions where A meets O4, where any B closes the loop), with
    B's velocity that of the closed form and no rate above the geometry's bound."""
    a, b = 1.0, b_over_a
    s = math.radians(start)
    if abs(math.sin(s / 2)) < 1e-6 or abs(math.cos(s / 2)) < 1e-6 or abs(math.sin(s)) < 1e-6:
        s += math.radians(5.0) * math.copysign(1.0, speed)  # sketched a little past
    bx, by = _kite_B(a, b, s, sign)
    text = f"""
ground: {{O2: [0, 0], O4: [{a!r}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a!r}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b!r}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{b!r}, 0]}}}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: {{sketch: {{B: [{float(bx)!r}, {float(by)!r}]}}}}
driver: {{joint: O2, speed: {speed!r} rad/s, start: {start!r} deg}}
sweep: {{range: 720 deg, step: {step!r} deg}}
"""
    res = ms.solve(ms.loads(text))
    assert res.ok.all()
    th = res.u  # the driver's angle as the file counts it (th / 2 tells the turns apart)
    np.testing.assert_allclose(wrap(res.link("crank").angle - th), 0.0, atol=1e-12)
    B = res.point("B")
    x, y = _kite_B(a, b, th, sign)
    np.testing.assert_allclose(B.x, x, atol=1e-7)
    np.testing.assert_allclose(B.y, y, atol=1e-7)
    e = 1e-6
    xp, yp = _kite_B(a, b, th + e, sign)
    xm, ym = _kite_B(a, b, th - e, sign)
    w = speed
    np.testing.assert_allclose(B.vx, (xp - xm) / (2 * e) * w, atol=1e-5)
    np.testing.assert_allclose(B.vy, (yp - ym) / (2 * e) * w, atol=1e-5)
    # |dB/dth| <= |d r/dth| + r/2 <= a/2 + a^2/(4 sqrt(b^2 - a^2)) + (a + b)/2
    bound = abs(w) * (a / 2 + a * a / (4 * math.sqrt(b * b - a * a)) + (a + b) / 2)
    assert np.max(np.hypot(B.vx, B.vy)) <= bound * (1 + 1e-9)
