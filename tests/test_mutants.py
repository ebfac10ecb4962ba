"""Tests written to kill the mutants that survived a mutation-testing run (issue 11).

Each test names the mutation it kills (module:line, cosmic-ray operator) and checks
mechsolve against an independent reference: a hand free-body solution, a closed form
(law of cosines, Freudenstein), never mechsolve's own earlier output. README's section on
testing gives the command that measured the suite and the list of equivalent survivors.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms

from handcalc import fourbar_forces

G = 9.81


def fourbar(a, b, c, d, *, start=0.0, step=30.0, extra=""):
    """Crank O2-A (a), coupler A-B (b), rocker O4-B (c), ground O2-O4 (d) along +x."""
    return f"""
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
driver: {{joint: O2, speed: 1 rad/s, start: {start} deg}}
sweep: {{range: 360 deg, step: {step} deg}}
{extra}
"""


# -- closed.py ------------------------------------------------------------------------------


@pytest.mark.parametrize("angle", [30.0, -50.0])
def test_linear_actuator_force_on_an_inclined_guide(angle):
    """closed.py:151 ReplaceUnaryOperator_USub_UAdd (DrivenSlider.forces: the driving force
    with the wrong sign). A block of 2 kg pushed at constant speed along a guide at
    ``angle`` with a load (3, 4) N: along the guide ``F_d + F.u + m g.u = 0`` and across
    it ``N + F.n + m g.n = 0`` (a free body of the block; no acceleration)."""
    m, F = 2.0, np.array([3.0, 4.0])
    mech = ms.loads(f"""
units: {{length: m, angle: deg}}
ground: {{O: [0, 0]}}
links:
  block: {{points: {{C: [0, 0]}}, mass: {m} kg, com: C}}
joints:
  ram: {{slider: [ground, block], point: C, line: {{through: [0, 0], angle: {angle}}}}}
driver: {{joint: ram, speed: 0.5, start: 0.1}}
sweep: {{range: 0.2, step: 0.05}}
gravity: {G} m/s^2
loads:
  push: {{force: [{F[0]} N, {F[1]} N], at: C}}
""")
    res = ms.solve(mech)
    th = math.radians(angle)
    u, n = np.array([math.cos(th), math.sin(th)]), np.array([-math.sin(th), math.cos(th)])
    W = np.array([0.0, -m * G])
    assert res.effort_name == ("force", "N")
    np.testing.assert_allclose(res.driving_effort, -(F + W) @ u, rtol=1e-10)
    np.testing.assert_allclose(res.reaction("ram")["N"], -(F + W) @ n, rtol=1e-10)


@pytest.mark.parametrize(
    "abcd, first_bad, op",
    [
        # |A O4| grows from 3 (0 deg) to 7 (180 deg): too far apart for 3 + 2 from 90 deg
        ((2.0, 3.0, 2.0, 5.0), 90.0, ">"),
        # |A O4| = 1 at 0 deg: nearer than |4 - 1|
        ((2.0, 4.0, 1.0, 3.0), 0.0, "<"),
    ],
)
def test_unassemblable_reason_names_the_violated_inequality(abcd, first_bad, op):
    """closed.py:387 ReplaceComparisonOperator_Gt_Eq (RRR.fail_reason: the wrong one of
    ``D > L1 + L2`` and ``D < |L1 - L2|`` reported). D by the law of cosines."""
    a, b, c, d = abcd
    res = ms.solve(ms.loads(fourbar(a, b, c, d)))
    f = res.failures[0]
    assert math.degrees(f.u_first) == pytest.approx(first_bad)
    th = math.radians(first_bad)
    D = math.sqrt(a * a + d * d - 2 * a * d * math.cos(th))
    assert (D > b + c) if op == ">" else (D < abs(b - c))
    assert f"|AO4| = {D:.6g} m {op} " in f.reason, f.reason


def test_slider_moment_about_a_slider_point_away_from_the_pin():
    """closed.py:517 ReplaceBinaryOperator_Sub_Mul (RRP.forces: the guide's moment on the
    block taken about the wrong point). A quasi-static slider-crank whose piston slides at
    S, d ahead of the pin C; a force (-P, 0) on the piston at C. The massless rod is a
    two-force member, force f e_r on the piston (e_r along A -> C): f e_rx = P,
    N = -f e_ry, moment about S: M = d f e_ry; the crank: T = f (A x e_r)."""
    r, L, d, P = 0.1, 0.3, 0.08, 100.0
    mech = ms.loads(f"""
units: {{length: m, angle: deg}}
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [{r}, 0]}}}}
  rod: {{points: {{A: [0, 0], C: [{L}, 0]}}}}
  piston: {{points: {{C: [0, 0], S: [{d}, 0]}}}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cyl: {{slider: [ground, piston], point: S, line: {{through: [0, 0], angle: 0}}}}
assembly: ["C.x > A.x"]
driver: {{joint: O, speed: 0, start: 40 deg}}
sweep: {{range: 60 deg, step: 20 deg}}
loads:
  P: {{force: [-{P} N, 0 N], at: C, on: piston}}
""")
    res = ms.solve(mech)
    th = np.radians(40.0 + 20.0 * np.arange(4))
    ax, ay = r * np.cos(th), r * np.sin(th)
    erx, ery = np.sqrt(L * L - ay * ay) / L, -ay / L
    f = P / erx
    cyl = res.reaction("cyl")
    np.testing.assert_allclose(cyl["N"], -f * ery, rtol=1e-10)
    np.testing.assert_allclose(cyl["M"], d * f * ery, rtol=1e-10)
    np.testing.assert_allclose(res.driving_effort, f * (ax * ery - ay * erx), rtol=1e-10)


# -- results.py -----------------------------------------------------------------------------


def test_summary_lists_eight_singular_positions_and_counts_the_rest():
    """results.py:300 ReplaceComparisonOperator_Gt_Eq and results.py:301
    ReplaceBinaryOperator_Add_Mod (design_summary: the list of singular positions). A
    parallelogram (crank = rocker, coupler = ground) is collinear, a bifurcation point,
    wherever the crank is at 0 or 180 deg: five turns pass ten of them."""
    y = fourbar(1.0, 3.0, 1.0, 3.0, start=10, step=15).replace("360 deg", "1800 deg")
    res = ms.solve(ms.loads(y + 'assembly: ["B left of A -> O4"]\n'))
    ev = res.events
    assert [e.kind for e in ev] == ["bifurcation"] * 10
    np.testing.assert_allclose([e.u for e in ev], np.pi * np.arange(1, 11), atol=1e-9)
    line = next(s for s in res.design_summary() if s.startswith("  singular positions: "))
    assert line.count("passes a bifurcation at driver angle") == 8
    assert line.count("angle 180°") == 4 and line.count("angle 0°") == 4
    assert line.endswith("; and 2 more")


# -- forces.py ------------------------------------------------------------------------------


@pytest.mark.parametrize("method", ["split-newton"])
def test_fourbar_reactions_with_newton_groups_against_hand_kinetostatics(method):
    """forces.py:409 ReplaceComparisonOperator_Eq_IsNot (_solve_groups: the reactions of a
    group solved by its constraint block not passed on to the bodies it rests on). With
    split-newton the dyad is a Newton group and the crank's torque needs its pin force at
    A. Reference: tests/handcalc.py's link-by-link hand elimination."""
    a, b, c, d = 0.04, 0.12, 0.09, 0.10
    m, J = (0.3, 0.8, 0.6), (2e-4, 1.5e-3, 9e-4)
    Gc = ((0.02, 0.0), (0.05, 0.01), (0.045, -0.005))
    F, P, T4, w2 = (12.0, -7.0), (0.06, 0.03), 0.8, 6.0
    y = fourbar(a, b, c, d, start=15, step=15).replace("speed: 1 rad/s", f"speed: {w2} rad/s")
    for name, k in (("crank", 0), ("coupler", 1), ("rocker", 2)):
        y = y.replace(
            f"  {name}: {{points: {{",
            f"  {name}: {{mass: {m[k]} kg, com: {list(Gc[k])}, inertia: {J[k]} kg m^2, points: {{",
        )
    y = y.replace("B: [0.12, 0]}", f"B: [0.12, 0], P: {list(P)}}}")
    y += f"""assembly: ["B left of A -> O4"]
gravity: {G} m/s^2
loads:
  F: {{force: [{F[0]} N, {F[1]} N], at: P}}
  T4: {{torque: {T4} N m, on: rocker}}
solver: {{method: {method}}}
"""
    res = ms.solve(ms.loads(y))
    assert res.ok.all() and res.forces.ok.all()
    h = fourbar_forces(a, b, c, d, res.u, w2, 1, m, Gc, J, G, F, P, T4)
    scale = np.max(np.abs(h["Td"]))
    np.testing.assert_allclose(res.driving_effort, h["Td"], rtol=0, atol=1e-9 * scale)
    for joint in ("O2", "A", "B", "O4"):
        s = np.max(np.abs(h[joint]))
        np.testing.assert_allclose(res.reaction(joint)["Fx"], h[joint][0], atol=1e-9 * s)
        np.testing.assert_allclose(res.reaction(joint)["Fy"], h[joint][1], atol=1e-9 * s)


@pytest.mark.parametrize(
    "start, speed, last, suffix",
    [
        (0.0, 1.0, "driver angle 360°", ""),
        (30.0, 1.0, "driver angle 30°", " (360° from the start)"),
        (0.0, -1.0, "driver angle 360°", " (360° from the start)"),
    ],
)
def test_positions_in_words_at_the_end_of_a_full_turn(start, speed, last, suffix):
    """results.py:505 NumberReplacer and results.py:507 ReplaceComparisonOperator_NotEq_LtE
    (describe_u): a full turn from 0 ends at 360°, not at 0° again; a turn from elsewhere,
    or clockwise, also says how far the driver has travelled from the start."""
    y = fourbar(2.0, 5.0, 4.0, 6.0, start=start, step=45)
    res = ms.solve(ms.loads(y.replace("speed: 1 rad/s", f"speed: {speed} rad/s")))
    assert res.ok.all() and len(res.u) == 9
    assert res.describe_u(8) == last + suffix
    mid = (start + 180.0 * speed) % 360.0
    assert res.describe_u(4) == f"driver angle {mid:g}°" + suffix.replace("360", "180")


@pytest.mark.parametrize("turns, more", [(2.0, ""), (2.5, " and 1 more")])
def test_summary_lists_five_positions_whose_rates_are_limits(turns, more):
    """results.py:309 ReplaceComparisonOperator_Gt_GtE (design_summary: five positions are
    listed in full, only a sixth and more are counted). The parallelogram's samples at
    crank angles k 180° are its collinear (singular) positions."""
    y = fourbar(1.0, 3.0, 1.0, 3.0, start=0, step=45).replace("360 deg", f"{360 * turns} deg")
    res = ms.solve(ms.loads(y + 'assembly: ["B left of A -> O4"]\n'))
    idx = res.solution.rates_by_limit
    n = int(2 * turns) + 1
    np.testing.assert_allclose(res.u[idx], np.pi * np.arange(n), atol=1e-12)
    line = next(s for s in res.design_summary() if "velocities and accelerations" in s)
    assert line.startswith(f"  velocities and accelerations at {n} singular position(s) ")
    assert line.count("driver angle") == 5
    assert line.endswith(more) if more else "more" not in line


def test_summary_gives_the_first_and_last_unassemblable_position():
    """results.py:526 ReplaceBinaryOperator_Add_FloorDiv (summary: a run of unassemblable
    positions). Crank 2, coupler 3, rocker 2, ground 5: |A O4|^2 = 29 - 20 cos(th) exceeds
    (3 + 2)^2 for cos(th) < 0.2, i.e. between 78.46° and 281.54°: the samples 90° to 270°."""
    res = ms.solve(ms.loads(fourbar(2.0, 3.0, 2.0, 5.0)))
    edge = math.degrees(math.acos(0.2))
    assert [(f.first, f.last) for f in res.failures] == [(3, 9)]
    f = res.failures[0]
    assert math.degrees(f.edge_in) == pytest.approx(edge, abs=1e-6)
    assert math.degrees(f.edge_out) == pytest.approx(360 - edge, abs=1e-6)
    text = res.summary()
    assert "unassemblable at driver angle 90° to driver angle 270° (7 position(s)): " in text


# -- limits.py ------------------------------------------------------------------------------


@pytest.mark.parametrize("start", [0.0, 200.0])
def test_rocker_limits_at_a_folded_crank_and_at_a_dead_zone_edge(start):
    """limits.py:100 ReplaceBinaryOperator_Mul_Add / Mul_Sub (_edge_value: the rocker angle
    at the edge of an unassemblable range brought next to the unwrapped samples). Crank 2,
    coupler 3, rocker 2, ground 5 (B left of A -> O4). One extreme is where crank and coupler
    are in line (|O2 B| = 5, |O4 B| = 2: the crank at acos(0.92)); the other is the dead
    zone's edge, where coupler and rocker are in line (|A O4| = 5: the crank at
    -acos(0.2)) and the rocker points from O4 towards A. The rocker angle there is past
    180°, where a single position's angle wraps to -157°."""
    res = ms.solve(ms.loads(fourbar(2.0, 3.0, 2.0, 5.0, start=start)))
    (lp,) = res.limit_positions()
    th_lo = math.acos(0.92)
    bx, by = 5 * math.cos(th_lo), 5 * math.sin(th_lo)
    low = math.degrees(math.atan2(by, bx - 5.0))
    th_hi = -math.acos(0.2)
    ax, ay = 2 * math.cos(th_hi), 2 * math.sin(th_hi)
    high = math.degrees(math.atan2(ay, ax - 5.0)) + 360.0
    assert (lp.name, lp.kind) == ("rocker", "rocker")
    assert math.degrees(lp.low) == pytest.approx(low, abs=1e-7)
    # at a toggle the angle goes as the square root of the distance to the edge: 1e-5°
    assert math.degrees(lp.high) == pytest.approx(high, abs=1e-5)
    assert math.degrees(lp.u_low) % 360 == pytest.approx(math.degrees(th_lo), abs=1e-7)
    assert math.degrees(lp.u_high) % 360 == pytest.approx(360 + math.degrees(th_hi), abs=1e-7)


def test_transmission_minimum_between_samples_by_a_parabola(monkeypatch):
    """limits.py:253 ReplaceBinaryOperator_Sub_Pow (transmission_angles: the fallback when
    the minimum cannot be located exactly is a parabola through the three samples around
    it). With the exact search switched off, the result must be the vertex of the parabola
    through the closed-form transmission angles at those samples: for crank 2, coupler 5,
    rocker 4, ground 6, cos(gamma) = (b^2 + c^2 - |A O4|^2) / (2 b c), least at 0°."""
    import mechsolve.results.limits as limits

    a, b, c, d = 2.0, 5.0, 4.0, 6.0
    res = ms.solve(ms.loads(fourbar(a, b, c, d, start=-30, step=20)))
    monkeypatch.setattr(limits, "_exact_minimum", lambda *args: None)
    (t,) = res.transmission_angles()
    th = res.u
    gam = np.arccos((b * b + c * c - (a * a + d * d - 2 * a * d * np.cos(th))) / (2 * b * c))
    mu = np.minimum(gam, np.pi - gam)
    k = int(np.argmin(mu))
    assert 0 < k < len(mu) - 1
    m0, m1, m2 = mu[k - 1 : k + 2]
    s = 0.5 * (m0 - m2) / (m0 - 2 * m1 + m2)
    assert t.angle == pytest.approx(m1 - 0.25 * (m0 - m2) * s, abs=1e-12)
    assert t.u == pytest.approx(th[k] + s * (th[k + 1] - th[k]), abs=1e-12)
