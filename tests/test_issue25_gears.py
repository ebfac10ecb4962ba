"""Issue 25, items 1, 2 and 4: the gear pair and the rack and pinion, with their forces.

Each against an independent reference: the speed ratio -r1/r2 (internal +) of the pitch
circles' rolling; Willis' formula for an epicyclic train; hand statics of a gear pair, an
epicyclic train and a rack under load (the tooth force's tangential part is the torque
over the pitch radius, its radial part tan(alpha) of it, and the pivots carry it);
the power balance; rack travel r theta; the equations' Jacobian and acceleration terms
against finite differences; bad inputs refused with file, key path and line (exit 2).
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mechsolve
from mechsolve.base.state import State
from mechsolve.joints.gear import GearConstraint
from mechsolve.joints.rack import RackConstraint

ROOT = Path(__file__).resolve().parent.parent
ALPHA = math.radians(20.0)


def pair(
    r1=20.0, r2=40.0, internal=False, phase="0 deg", start="30 deg", motion="", extra=""
) -> str:
    """A gear pair on two ground pivots on the x axis; the driver turns gear 1."""
    d = r2 - r1 if internal else r1 + r2
    return f"""
name: gear pair
units: {{length: mm, angle: deg}}
ground: {{O1: [0, 0], O2: [{d}, 0]}}
links:
  g1: {{points: {{O1: [0, 0], M1: [{r1}, 0]}}}}
  g2: {{points: {{O2: [0, 0], M2: [{r2}, 0]}}}}
joints:
  O1: [ground, g1]
  O2: [ground, g2]
  mesh: {{gear_pair: [g1, g2], radii: [{r1}, {r2}], internal: {str(internal).lower()},
          phase: {phase}}}
driver: {{joint: O1, start: {start}, {motion or "speed: 10 rad/s"}}}
sweep: {{range: 400 deg, step: 8 deg}}
{extra}
"""


ACCEL = "motion: {accelerate: 7 rad/s^2, from: 3 rad/s}"


@pytest.mark.parametrize("internal", [False, True])
def test_the_speed_ratio_is_that_of_the_pitch_circles(internal):
    r1, r2 = 0.020, 0.050
    res = mechsolve.solve(mechsolve.loads(pair(20, 50, internal, phase="10 deg", motion=ACCEL)))
    assert res.ok.all()
    g1, g2 = res.link("g1"), res.link("g2")
    ratio = (r1 / r2) * (1 if internal else -1)  # omega2 / omega1
    assert np.ptp(g1.omega) > 1.0 and np.ptp(g1.alpha) == pytest.approx(0, abs=1e-9)
    np.testing.assert_allclose(g2.omega, ratio * g1.omega, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(g2.alpha, ratio * g1.alpha, rtol=1e-12, atol=1e-12)
    # the phase: with the line of centres at 0, gear 2 is at phase + ratio * theta1
    th1 = np.unwrap(g1.angle)
    th2 = np.unwrap(g2.angle)
    expect = math.radians(10.0) + ratio * th1
    turns = np.round((th2 - expect) / (2 * np.pi))
    np.testing.assert_allclose(th2 - expect, turns * 2 * np.pi, atol=1e-12)


def test_the_phase_is_gear_2s_angle_when_gear_1_and_the_centre_line_are_at_zero():
    res = mechsolve.solve(mechsolve.loads(pair(20, 40, phase="25 deg", start="0 deg")))
    th2 = float(res.link("g2").angle[0])
    assert math.remainder(th2 - math.radians(25.0), 2 * math.pi) == pytest.approx(0, abs=1e-12)


EPICYCLIC = """
name: epicyclic train
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  sun: {points: {O: [0, 0], S: [20, 0]}}
  carrier: {points: {O: [0, 0], P: [35, 0]}}
  planet: {points: {P: [0, 0], Q: [15, 0]}}
  RING
joints:
  O: [ground, sun, carrier RINGPIN]
  P: [carrier, planet]
  sp: {gear_pair: [SUN, planet], module: 1 mm, teeth: [40, 30], centres: [O, P]}
  pr: {gear_pair: [planet, RINGLINK], module: 1 mm, teeth: [30, 100], centres: [P, O],
       internal: true}
DRIVER
sweep: {range: 1440 deg, step: 16 deg}
"""


def epicyclic(fixed: str, driver: str) -> str:
    """``fixed``: the sun or the ring held by the ground; the driver's joint line."""
    text = EPICYCLIC
    if fixed == "ring":
        text = text.replace("  RING\n", "").replace(" RINGPIN", "")
        text = text.replace("RINGLINK", "ground").replace("SUN", "sun")
    else:  # the sun is held: it is the ground's gear, the ring turns
        text = text.replace("  sun: {points: {O: [0, 0], S: [20, 0]}}\n", "")
        text = text.replace("  RING\n", "  ring: {points: {O: [0, 0], R: [50, 0]}}\n")
        text = text.replace("[ground, sun, carrier RINGPIN]", "[ground, carrier, ring]")
        text = text.replace("RINGLINK", "ring").replace("SUN", "ground")
    return text.replace("DRIVER", driver)


def test_an_epicyclic_train_follows_willis_formula_ring_fixed():
    zs, zr = 40, 100
    mech = mechsolve.loads(epicyclic("ring", "driver: {joint: O, start: 0 deg, " + ACCEL + "}"))
    assert mechsolve.check(mech).grubler == 1  # 3*3 - 2*3 - 2
    res = mechsolve.solve(mech)
    assert res.ok.all()
    ws, wc, wp = (res.link(n).omega for n in ("sun", "carrier", "planet"))
    a_s, a_c, a_p = (res.link(n).alpha for n in ("sun", "carrier", "planet"))
    # Willis: (w_sun - w_c) / (w_ring - w_c) = -z_ring / z_sun, w_ring = 0
    np.testing.assert_allclose(wc, ws * zs / (zs + zr), rtol=1e-12)
    np.testing.assert_allclose(a_c, a_s * zs / (zs + zr), rtol=1e-12)
    # the planet relative to the carrier: (w_p - w_c) / (w_s - w_c) = -z_s / z_p
    np.testing.assert_allclose(wp - wc, -(ws - wc) * 40 / 30, rtol=1e-12)
    np.testing.assert_allclose(a_p - a_c, -(a_s - a_c) * 40 / 30, rtol=1e-12)
    # the carrier goes round (the line of centres turns through +-180 deg) and P stays
    # on its circle
    assert np.ptp(np.unwrap(res.link("carrier").angle)) > 2 * np.pi
    p = res.point("P")
    np.testing.assert_allclose(np.hypot(p.x, p.y), 0.035, rtol=1e-12)


def test_an_epicyclic_train_follows_willis_formula_sun_fixed():
    zs, zr = 40, 100
    res = mechsolve.solve(
        mechsolve.loads(epicyclic("sun", "driver: {joint: O, start: 0 deg, " + ACCEL + "}"))
    )
    assert res.ok.all()
    wc, wr = res.link("carrier").omega, res.link("ring").omega
    ac, ar = res.link("carrier").alpha, res.link("ring").alpha
    # the driver turns the carrier; Willis with w_sun = 0: w_ring = w_c (1 + z_s / z_r)
    np.testing.assert_allclose(wr, wc * (1 + zs / zr), rtol=1e-12)
    np.testing.assert_allclose(ar, ac * (1 + zs / zr), rtol=1e-12)


def test_tooth_force_of_a_gear_pair_by_hand():
    """Gear 1 driven, a load torque on gear 2: Ft = T / r2, Fr = Ft tan 20 deg; the
    pivots carry the whole tooth force; the driver supplies T r1 / r2."""
    t_load = -6.0  # N m on gear 2, against its motion (gear 2 turns clockwise)
    r1, r2 = 0.020, 0.040
    extra = f"loads: {{brake: {{torque: {t_load} N*m, on: g2}}}}\ngravity: 0 m/s^2"
    res = mechsolve.solve(mechsolve.loads(pair(20, 40, extra=extra)))
    f = res.reaction("mesh")
    ft = -t_load / r2  # on gear 2, along the left normal of O1 -> O2 (+y): -r2 ft + T = 0
    np.testing.assert_allclose(f["Ft"], -ft, rtol=1e-12)  # the moment -r2 Ft balances T
    np.testing.assert_allclose(f["Fr"], ft * math.tan(ALPHA), rtol=1e-12)
    np.testing.assert_allclose(f["Fn"], ft / math.cos(ALPHA), rtol=1e-12)
    # on gear 2 the radial part pushes it away from gear 1 (+x)
    np.testing.assert_allclose(f["Fx"], ft * math.tan(ALPHA), rtol=1e-12)
    np.testing.assert_allclose(f["Fy"], -ft, rtol=1e-12)
    # the driver: the tooth force on gear 1 at the pitch point (r1, 0) is (-Fx, -Fy)
    np.testing.assert_allclose(res.driving_effort, -r1 * ft, rtol=1e-12)
    assert np.all(res.driving_effort * res.link("g1").omega < 0)  # it brakes: power out
    # the pivots (force on each gear by the ground) balance the tooth forces, radial too
    o1, o2 = res.reaction("O1"), res.reaction("O2")
    np.testing.assert_allclose(o2["Fx"], -ft * math.tan(ALPHA), rtol=1e-12)
    np.testing.assert_allclose(o2["Fy"], ft, rtol=1e-12)
    np.testing.assert_allclose(o1["Fx"], ft * math.tan(ALPHA), rtol=1e-12)
    np.testing.assert_allclose(o1["Fy"], -ft, rtol=1e-12)
    np.testing.assert_allclose(o1["F"], ft / math.cos(ALPHA), rtol=1e-12)
    scale = res.power_scale()
    assert np.max(np.abs(res.forces.residual)) <= 1e-9 * scale


def test_an_internal_pair_pushes_the_ring_outwards():
    t_load = 3.0
    extra = f"loads: {{brake: {{torque: {t_load} N*m, on: g2}}}}\ngravity: 0 m/s^2"
    res = mechsolve.solve(mechsolve.loads(pair(20, 50, internal=True, extra=extra)))
    # the pitch point is at x = -r1 (O2 at +30 mm): tooth force on the ring at (-0.02, 0)
    # relative to O2 (0.03, 0): arm -0.05 along x; moment -0.05 Fy + T = 0
    fy = t_load / 0.05
    f = res.reaction("mesh")
    np.testing.assert_allclose(f["Fy"], fy, rtol=1e-12)
    np.testing.assert_allclose(f["Fx"], -abs(fy) * math.tan(ALPHA), rtol=1e-12)  # outwards
    np.testing.assert_allclose(res.reaction("O2")["Fx"], abs(fy) * math.tan(ALPHA), rtol=1e-12)
    # the pinion gets (-Fx, -Fy) at arm (-0.02, 0): moment 0.02 Fy, which the driver balances
    np.testing.assert_allclose(res.driving_effort, -0.02 * fy, rtol=1e-12)


def test_the_pivots_of_an_epicyclic_train_carry_the_separating_forces():
    """Ring fixed, sun driven, a load torque T on the carrier, no masses. By hand: the
    planet's tooth forces are equal, Ft = T / (2 (rs + rp)), their radial parts cancel on
    the planet; the sun's pivot carries Ft / cos(alpha), of which Ft tan(alpha) radial."""
    t_c = -7.0
    rs, rp = 0.020, 0.015
    text = epicyclic("ring", "driver: {joint: O, speed: 10 rad/s, start: 0 deg}")
    text += f"loads: {{out: {{torque: {t_c} N*m, on: carrier}}}}\ngravity: 0 m/s^2\n"
    res = mechsolve.solve(mechsolve.loads(text))
    ft = abs(t_c) / (2 * (rs + rp))
    np.testing.assert_allclose(np.abs(res.reaction("sp")["Ft"]), ft, rtol=1e-10)
    np.testing.assert_allclose(np.abs(res.reaction("pr")["Ft"]), ft, rtol=1e-10)
    np.testing.assert_allclose(res.driving_effort, -t_c * rs / (2 * (rs + rp)), rtol=1e-10)
    # the planet's pin: 2 Ft, tangential only
    pin = res.reaction("P")
    np.testing.assert_allclose(pin["F"], 2 * ft, rtol=1e-10)
    p = res.point("P")
    ex, ey = p.x / 0.035, p.y / 0.035
    np.testing.assert_allclose(pin["Fx"] * ex + pin["Fy"] * ey, 0, atol=1e-9 * ft)
    # the sun's pivot (O: ground -> sun): the tooth force with its radial part, towards P
    sun = res.reaction("O")
    np.testing.assert_allclose(sun["F"], ft / math.cos(ALPHA), rtol=1e-10)
    np.testing.assert_allclose(sun["Fx"] * ex + sun["Fy"] * ey, ft * math.tan(ALPHA), rtol=1e-10)
    # the carrier's pivot carries the planet's pin force: 2 Ft
    np.testing.assert_allclose(res.reaction("O_2")["F"], 2 * ft, rtol=1e-10)


def test_power_balance_with_masses_on_a_moving_carrier():
    text = epicyclic("ring", "driver: {joint: O, start: 0 deg, " + ACCEL + "}")
    text = text.replace(
        "planet: {points: {P: [0, 0], Q: [15, 0]}}",
        "planet: {points: {P: [0, 0], Q: [15, 0]}, mass: 0.3 kg, com: Q, inertia: 1e-4 kg*m^2}",
    ).replace(
        "carrier: {points: {O: [0, 0], P: [35, 0]}}",
        "carrier: {points: {O: [0, 0], P: [35, 0]}, mass: 0.5 kg, com: P, inertia: 2e-4 kg*m^2}",
    )
    res = mechsolve.solve(mechsolve.loads(text + "gravity: 9.81 m/s^2\n"))
    assert res.forces.ok.all()
    # the kinetic energy's rate is the driver's power (gravity is in the balance too)
    scale = res.power_scale()
    assert scale > 1.0
    assert np.max(np.abs(res.forces.residual)) <= 1e-9 * scale


RACK = """
name: rack and pinion
units: {length: mm, angle: deg}
ground: {C: [0, 30]}
links:
  pinion: {points: {C: [0, 0], M: [30, 0]}, mass: 1 kg, com: C, inertia: 0.002 kg*m^2}
  ram: {points: {R: [0, 0], T: [100, 0]}, mass: 5 kg, com: R}
joints:
  C: [ground, pinion]
  guide: {slider: [ground, ram], point: R, line: {through: [0, 0], angle: 0 deg}}
  mesh: {rack: [ram, pinion], pitch_line: {through: [0, 0], angle: 0 deg}, MESH}
driver: {joint: C, start: 0 deg, motion: {accelerate: 10 rad/s^2, from: 5 rad/s}}
sweep: {range: 180 deg, step: 10 deg}
gravity: 9.81 m/s^2
loads:
  cut: {force: [-200 N, 0], at: T, on: ram}
"""


def test_rack_travel_is_r_theta_and_its_tooth_force_by_hand():
    mech = mechsolve.loads(RACK.replace("MESH", "module: 3 mm, teeth: 20"))
    assert mechsolve.check(mech).grubler == 1  # 3*2 - 2*2 - 1
    res = mechsolve.solve(mech)
    r, m_ram, j_pin = 0.030, 5.0, 0.002
    pin = res.link("pinion")
    ram = res.slider("guide")
    # a pinion above the rack turning counter-clockwise drives the rack to the right
    np.testing.assert_allclose(ram.s, r * pin.angle, atol=1e-15)
    np.testing.assert_allclose(ram.v, r * pin.omega, atol=1e-15)
    np.testing.assert_allclose(ram.a, r * pin.alpha, atol=1e-15)
    # the ram: Ft (tooth force on the ram) - 200 N = m a; on the pinion -Ft along x
    ft_ram = 200.0 + m_ram * ram.a
    f = res.reaction("mesh")
    np.testing.assert_allclose(f["Ft"], -ft_ram, rtol=1e-12)
    np.testing.assert_allclose(f["Fr"], ft_ram * math.tan(ALPHA), rtol=1e-12)
    np.testing.assert_allclose(f["Fy"], ft_ram * math.tan(ALPHA), rtol=1e-12)  # lifts the pinion
    # the guide carries the ram's weight and the separating force
    np.testing.assert_allclose(
        res.reaction("guide")["N"], m_ram * 9.81 + ft_ram * math.tan(ALPHA), rtol=1e-12
    )
    # the pinion's pivot: its weight and the separating force; the driver: J alpha + Ft r
    np.testing.assert_allclose(res.reaction("C")["Fy"], 9.81 - ft_ram * math.tan(ALPHA), rtol=1e-12)
    np.testing.assert_allclose(res.driving_effort, j_pin * pin.alpha + ft_ram * r, rtol=1e-12)
    assert np.max(np.abs(res.forces.residual)) <= 1e-9 * res.power_scale()


def test_a_pinion_below_the_rack_turns_the_other_way():
    text = RACK.replace("MESH", "radius: 30 mm").replace("C: [0, 30]}", "C: [0, -30]}")
    res = mechsolve.solve(mechsolve.loads(text))
    np.testing.assert_allclose(res.slider("guide").s, -0.030 * res.link("pinion").angle, atol=1e-15)


def test_a_pinion_rolling_on_a_fixed_rack_draws_a_cycloid():
    text = """
name: pinion on a fixed rack
units: {length: mm, angle: deg}
ground: {R0: [0, 0], R1: [100, 0]}
links:
  carriage: {points: {C: [0, 0], D: [50, 0]}}
  pinion: {points: {C: [0, 0], M: [25, 0]}}
joints:
  rail: {slider: [ground, carriage], point: C, line: {through: [0, 25], angle: 0}}
  C: [carriage, pinion]
  mesh: {rack: [ground, pinion], pitch_line: [R0, R1], radius: 25 mm}
driver: {joint: C, speed: 4 rad/s, start: 0 deg}
sweep: {range: 400 deg, step: 10 deg}
"""
    res = mechsolve.solve(mechsolve.loads(text))
    r, th = 0.025, np.asarray(res.u)
    np.testing.assert_allclose(res.slider("rail").s, -r * th, atol=1e-15)
    m = res.point("M")  # a point of the pitch circle: x = -r th + r cos th, y = r + r sin th
    np.testing.assert_allclose(m.x, -r * th + r * np.cos(th), atol=1e-15)
    np.testing.assert_allclose(m.y, r + r * np.sin(th), atol=1e-15)
    # the contact point is at rest: M's speed vanishes where it touches the rack
    touch = np.isclose(m.y, 0.0, atol=1e-12)
    assert touch.any()
    np.testing.assert_allclose(np.hypot(m.vx, m.vy)[touch], 0.0, atol=1e-12)


# -- the equations against finite differences -----------------------------------------


def _state(rng, n_bodies: int, q, v) -> State:
    st = State(n_bodies, 1)
    for i in range(n_bodies):
        st.x[i], st.y[i] = q[3 * i], q[3 * i + 1]
        st.set_angle(i, np.array([q[3 * i + 2]]))
        st.vx[i], st.vy[i], st.w[i] = v[3 * i], v[3 * i + 1], v[3 * i + 2]
    return st


def _check_terms(c, rng, nb: int = 2) -> None:
    """Phi_q v = d Phi/dt and Phi_q a - gamma = d2 Phi/dt2 along q + v t + a t^2 / 2."""
    q = rng.uniform(-1, 1, 3 * nb)
    v = rng.uniform(-1, 1, 3 * nb)
    a = rng.uniform(-1, 1, 3 * nb)
    st = _state(rng, nb, q, v)
    jac = c.jacobian(st)
    jv = sum(float(blk[0, :, 0] @ v[3 * b : 3 * b + 3]) for b, blk in jac.items())
    ja = sum(float(blk[0, :, 0] @ a[3 * b : 3 * b + 3]) for b, blk in jac.items())
    g = float(c.gamma(st)[0, 0])

    def phi(t: float) -> float:
        s = _state(rng, nb, q + v * t + 0.5 * a * t * t, v)
        return float(c.residual(s)[0, 0])

    h = 1e-4
    d1 = (phi(h) - phi(-h)) / (2 * h)
    d2 = (phi(h) - 2 * phi(0.0) + phi(-h)) / h**2
    assert jv == pytest.approx(d1, rel=1e-6, abs=1e-8)
    assert ja - g == pytest.approx(d2, rel=1e-4, abs=1e-5)


@pytest.mark.parametrize("sigma", [1.0, -1.0])
def test_the_gear_equation_terms_match_finite_differences(sigma):
    rng = np.random.default_rng(25)
    for _ in range(20):
        c = GearConstraint(
            "g", 0, 1, rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2), 0.3, 0.8, sigma, ALPHA, 0.2
        )
        _check_terms(c, rng)
        ground = GearConstraint(
            "g", 0, 2, rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2), 0.3, 0.8, sigma, ALPHA, 0
        )
        _check_terms(ground, rng)


def test_the_rack_equation_terms_match_finite_differences():
    rng = np.random.default_rng(52)
    for _ in range(20):
        c = RackConstraint(
            "k",
            0,
            1,
            rng.uniform(-1, 1, 2),
            rng.uniform(-3, 3),
            rng.uniform(-1, 1, 2),
            0.4,
            ALPHA,
            0.1,
        )
        _check_terms(c, rng)


def test_the_drawing_shows_the_pitch_circles():
    res = mechsolve.solve(mechsolve.loads(pair(20, 40, start="40 deg")))
    c = next(c for c in res.analysis.system.constraints if c.name == "mesh")
    lines = c.drawing(res.solution.state, 3)
    circles = [ln for ln in lines if len(ln) > 2]
    assert len(circles) == 2
    for ln, (cx, r) in zip(circles, ((0.0, 0.020), (0.060, 0.040))):
        np.testing.assert_allclose(np.hypot(ln[:, 0] - cx, ln[:, 1]), r, rtol=1e-12)


def test_check_reports_lower_and_higher_pairs_and_csv_has_the_tooth_force():
    mech = mechsolve.loads(epicyclic("ring", "driver: {joint: O, speed: 1 rad/s}"))
    text = mechsolve.check(mech).text()
    assert "3n - 2Pl - Ph = 3*3 - 2*3 - 2" in text
    assert "Pl = 3 lower (revolute), Ph = 2 higher (gear_pair)" in text
    extra = "loads: {brake: {torque: -1 N*m, on: g2}}\ngravity: 0 m/s^2"
    res = mechsolve.solve(mechsolve.loads(pair(extra=extra)))
    names = [c.name for c in res.force_columns()]
    for comp in ("Ft", "Fr", "Fn", "Fx", "Fy"):
        assert f"mesh(g1->g2).{comp}" in names


# -- bad inputs: a clear message with file, key path and line, exit 2 -----------------

GOOD = pair(20, 40)


def _bad_cases() -> dict[str, tuple[str, str]]:
    mesh = "mesh: {gear_pair: [g1, g2], radii: [20, 40], internal: false,\n          phase: 0 deg}"
    assert mesh in GOOD
    return {
        "distance": (
            GOOD.replace("radii: [20, 40]", "radii: [20, 45]"),
            r"joints\.mesh\.radii: gear pair 'mesh': the centres O1 and O2 are 60 mm apart "
            r"on the ground, but the pitch circles need r1 \+ r2 = 20 \+ 45 = 65 mm",
        ),
        "internal distance": (
            GOOD.replace("internal: false", "internal: true"),
            r"joints\.mesh\.radii: .*need r2 - r1 = 40 - 20 = 20 mm",
        ),
        "centres not held": (
            GOOD.replace("M1: [20, 0]", "G1: [0, 0]").replace(
                "radii: [20, 40]", "radii: [20, 40], centres: [G1, O2]"
            ),
            r"joints\.mesh\.centres: gear pair 'mesh': no link \(nor the ground\) carries both "
            r"centres 'G1' and 'O2', so nothing holds the centre distance",
        ),
        "both": (
            GOOD.replace("radii: [20, 40]", "radii: [20, 40], module: 2 mm, teeth: [20, 40]"),
            r"joints\.mesh\.module: gear pair 'mesh': give either 'radii' or 'module'",
        ),
        "teeth fraction": (
            GOOD.replace("radii: [20, 40]", "module: 2 mm, teeth: [20, 40.5]"),
            r"joints\.mesh\.teeth\[1\]: a tooth count must be a positive whole number, got 40\.5",
        ),
        "teeth zero": (
            GOOD.replace("radii: [20, 40]", "module: 2 mm, teeth: [0, 40]"),
            r"joints\.mesh\.teeth\[0\]: a tooth count must be a positive whole number, got 0",
        ),
        "driven": (
            GOOD.replace("driver: {joint: O1", "driver: {joint: mesh"),
            r"driver\.joint: the driver names the joint 'mesh', a gear_pair, which has no "
            r"coordinate",
        ),
        "rack distance": (
            RACK.replace("MESH", "radius: 25 mm"),
            r"joints\.mesh\.radius: rack 'mesh': the pinion's centre C is 30 mm from the pitch "
            r"line at the start position, but its pitch radius is 25 mm",
        ),
        "rack module and radius": (
            RACK.replace("MESH", "radius: 30 mm, teeth: 20"),
            r"joints\.mesh\.teeth: rack 'mesh': give either 'radius' or 'module'",
        ),
    }


@pytest.mark.parametrize("case", list(_bad_cases()))
def test_bad_gear_input_is_refused_with_its_place(tmp_path, case):
    text, pattern = _bad_cases()[case]
    f = tmp_path / "bad.yaml"
    f.write_text(text)
    env = {k: v for k, v in os.environ.items() if k != "MECHSOLVE_DEBUG"}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    p = subprocess.run(
        [sys.executable, "-m", "mechsolve", "check", str(f)],
        capture_output=True,
        text=True,
        timeout=180,
        env=env,
    )
    out = p.stdout + p.stderr
    assert p.returncode == 2, out
    assert "Traceback" not in out
    line = re.search(r"bad\.yaml:(\d+): ", p.stderr)
    assert line, out
    assert re.search(pattern, p.stderr), out
    key = re.search(r"bad\.yaml:\d+: ([\w.\[\]]+):", p.stderr).group(1)
    # the line named is the one that holds the key
    top = key.split(".")[0 if key.startswith("driver") else 1].split("[")[0]
    assert top in text.splitlines()[int(line.group(1)) - 1], out
