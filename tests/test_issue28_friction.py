"""Friction in the joints: the file's keys, the force analysis with Coulomb friction,
efficiency and self-locking.

References, independent of the solver: hand free-body solutions with friction written
out below (a block on an incline, a slider-crank at one position), the wedge's closed
form eta = tan(lambda) / tan(lambda + phi) and its self-locking condition
lambda + phi >= 90 deg, and the power balance (input = output + losses + dE/dt).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
SLIDER_CRANK = (ROOT / "mechanisms" / "slider-crank.yaml").read_text()
GEARS = (ROOT / "mechanisms" / "gear-train.yaml").read_text()
PIN_O = "  O: [ground, crank]\n"
CYLINDER = "line: {through: [0, 10], angle: 0}}"


def check(tmp_path, text):
    f = tmp_path / "m.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["check", str(f)])
    assert r.exception is None or isinstance(r.exception, SystemExit), r.exception
    assert "Traceback" not in r.output
    return r


def with_pin_friction(text: str) -> str:
    return SLIDER_CRANK.replace(PIN_O, f"  O: {{revolute: [ground, crank], friction: {text}}}\n")


def with_slider_friction(text: str) -> str:
    return SLIDER_CRANK.replace(
        CYLINDER, f"line: {{through: [0, 10], angle: 0}}, friction: {text}}}"
    )


# -- the file's keys ---------------------------------------------------------------------
def test_friction_keys_are_read(tmp_path):
    import mechsolve as ms

    text = with_pin_friction("{coefficient: 0.1, journal radius: 10 mm, viscous: 0.01 N m s/rad}")
    text = text.replace(
        CYLINDER,
        "line: {through: [0, 10], angle: 0}, friction: {coefficient: 0.15, viscous: 2 N s/m}}",
    )
    mech = ms.loads(text)
    pin, cyl = mech.joint("O"), mech.joint("cylinder")
    assert pin.friction.coefficient == 0.1 and pin.friction.radius == pytest.approx(0.01)
    assert pin.friction.viscous == pytest.approx(0.01)
    assert cyl.friction.coefficient == 0.15 and cyl.friction.viscous == pytest.approx(2.0)
    assert check(tmp_path, text).exit_code == 0


@pytest.mark.parametrize(
    "text, fragments",
    [
        (
            with_pin_friction("{coefficient: -0.1, journal radius: 10 mm}"),
            ["joints.O.friction.coefficient", "zero or positive", "-0.1"],
        ),
        (
            with_pin_friction("{coefficient: 0.1, journal radius: -2 mm}"),
            ["joints.O.friction.journal radius", "positive", "-2 mm"],
        ),
        (
            with_pin_friction("{coefficient: 0.1}"),
            ["joints.O.friction", "no 'journal radius'", "rho = f r"],
        ),
        (
            with_pin_friction("{coefficent: 0.1, journal radius: 1 mm}"),
            ["joints.O.friction.coefficent", "did you mean 'coefficient'"],
        ),
        (
            with_pin_friction("{coefficient: 0.1, journal radius: 1 mm, viscous: 3 N s/m}"),
            ["joints.O.friction.viscous"],
        ),
        (
            with_slider_friction("{coefficient: 0.15, journal radius: 3 mm}"),
            ["joints.cylinder.friction.journal radius", "a slider has no journal"],
        ),
        (
            with_slider_friction("{coefficient: 0.15, viscous: -1 N s/m}"),
            ["joints.cylinder.friction.viscous", "zero or positive"],
        ),
        (
            with_slider_friction("{}"),
            ["joints.cylinder.friction", "needs 'coefficient' or 'viscous'"],
        ),
        (
            GEARS.replace("centres: [O1, O2]}", "centres: [O1, O2], friction: {coefficient: 0.1}}"),
            ["joints.mesh.friction", "applies to a revolute or a slider joint, not a gear_pair"],
        ),
    ],
)
def test_bad_friction_is_refused_with_key_and_line(tmp_path, text, fragments):
    r = check(tmp_path, text)
    assert r.exit_code == 2, r.output
    assert "m.yaml:" in r.output  # the file and the line
    for frag in fragments:
        assert frag in r.output, r.output


def test_schema_knows_the_friction_keys():
    from mechsolve.analyses.schema import build as schema

    s = schema.text()
    for key in ("joint friction", "journal radius", "viscous"):
        assert key in s


# -- a block on an incline, pushed by a force --------------------------------------------
ALPHA = 25.0  # the incline's angle, degrees
G = 9.81


def incline(f: float, speed: float, push: tuple[float, float], viscous: float = 0.0) -> str:
    return f"""
name: incline
units: {{length: m, angle: deg}}
ground: {{O: [0, 0]}}
links:
  block: {{points: {{P: [0, 0]}}, mass: 3 kg, com: P}}
joints:
  slope: {{slider: [ground, block], point: P, line: {{through: [0, 0], angle: {ALPHA}}},
          friction: {{coefficient: {f}, viscous: {viscous} N s/m}}}}
driver: {{joint: slope, speed: {speed} m/s, start: 0.1 m}}
sweep: {{range: 0.2 m, step: 0.05 m}}
gravity: {G} m/s^2
loads:
  push: {{force: [{push[0]} N, {push[1]} N], at: P, on: block}}
"""


@pytest.mark.parametrize("speed", [0.3, -0.3])
@pytest.mark.parametrize("push", [(5.0, -10.0), (0.0, 60.0), (-20.0, 45.0)])
def test_block_on_an_incline_matches_its_free_body(speed, push):
    """The block's free body: weight m g, the push P, the normal force N (either sign: the
    guide holds the block on both sides), Coulomb's f |N| and the viscous c v against the
    sliding, and the driving force T along the incline. Along the normal
    N = -(W + P) . n; along the incline T = -(W + P) . u + (f |N| + c |v|) sign(v)."""
    import mechsolve as ms

    f, c = 0.3, 2.0
    res = ms.solve(ms.loads(incline(f, speed, push, c)))
    a = math.radians(ALPHA)
    u = np.array([math.cos(a), math.sin(a)])
    n = np.array([-math.sin(a), math.cos(a)])
    load = np.array([push[0], push[1] - 3.0 * G])
    N = -load @ n
    T = -load @ u + (f * abs(N) + c * abs(speed)) * math.copysign(1.0, speed)
    fr = res.forces
    assert np.allclose(fr.effort, T, rtol=1e-12, atol=1e-12)
    assert np.allclose(fr.reactions["slope"]["N"], N, rtol=1e-12)
    assert np.allclose(fr.friction.friction["slope"], f * abs(N) + c * abs(speed), rtol=1e-12)
    assert np.allclose(fr.friction.loss["slope"], (f * abs(N) + c * abs(speed)) * abs(speed))
    assert np.allclose(fr.friction.ideal_effort, -load @ u, rtol=1e-12)


@pytest.mark.parametrize("speed", [0.3, -0.3])
@pytest.mark.parametrize("push", [(5.0, -10.0), (-20.0, 45.0)])
def test_guide_force_components_include_the_friction(speed, push):
    """The guide's force on the block (its Fx, Fy) is the normal force N n and the
    friction -(f |N| + c |v|) sign(v) u: with it the block's free body balances,
    weight + push + guide force = 0 (it slides at a constant speed). The components
    were the normal force alone."""
    import mechsolve as ms

    f, c = 0.3, 2.0
    res = ms.solve(ms.loads(incline(f, speed, push, c)))
    a = math.radians(ALPHA)
    u = np.array([math.cos(a), math.sin(a)])
    n = np.array([-math.sin(a), math.cos(a)])
    load = np.array([push[0], push[1] - 3.0 * G])
    N = -load @ n
    friction = -(f * abs(N) + c * abs(speed)) * math.copysign(1.0, speed) * u
    guide = N * n + friction
    r = res.forces.reactions["slope"]
    assert np.allclose(r["Fx"], guide[0], rtol=1e-12, atol=1e-12)
    assert np.allclose(r["Fy"], guide[1], rtol=1e-12, atol=1e-12)
    assert np.allclose(r["N"], N, rtol=1e-12)  # N stays the normal force alone
    # the driving force along the incline completes the free body
    drive = res.forces.effort * u[:, None]
    assert np.allclose(load[:, None] + np.array([r["Fx"], r["Fy"]]) + drive, 0.0, atol=1e-10)


# -- a wedge (a screw unrolled): efficiency and self-locking ---------------------------
def wedge(lam: float, f: float, speed: float = 0.1, weight: float = 1000.0) -> str:
    """A wedge driven along the bed lifts a block (on the wedge's face at ``lam`` to the
    bed, with friction f) pinned to a ram guided vertically; the weight on the ram. The
    bed and the column have no friction."""
    return f"""
name: wedge
units: {{length: m, angle: deg}}
ground: {{O: [0, 0]}}
links:
  wedge: {{points: {{W: [0, 0]}}}}
  block: {{points: {{C: [0, 0]}}}}
  ram: {{points: {{C: [0, 0]}}}}
joints:
  bed: {{slider: [ground, wedge], point: W, line: {{through: [0, 0], angle: 0}}}}
  face: {{slider: [wedge, block], point: C, line: {{through: [0, 0], angle: {180 - lam}}},
         friction: {{coefficient: {f}}}}}
  C: [block, ram]
  column: {{slider: [ground, ram], point: C, line: {{through: [0.5, 0], angle: 90}}}}
assembly:
  sketch: {{C: [0.5, 0.3]}}
driver: {{joint: bed, speed: {speed} m/s, start: 0 m}}
sweep: {{range: 0.1 m, step: 0.05 m}}
loads:
  weight: {{force: [0, -{weight} N], at: C, on: ram}}
"""


@pytest.mark.parametrize("lam, f", [(30.0, 0.2), (10.0, 0.2), (45.0, 0.05), (75.0, 0.2)])
def test_wedge_efficiency_is_the_closed_form(lam, f):
    """Raising: F = Q tan(lambda + phi), eta = tan(lambda) / tan(lambda + phi); lowering
    (the drive reversed): F = Q tan(lambda - phi), negative (the driver pushes the load
    down) when lambda < phi."""
    import mechsolve as ms

    L, phi, Q = math.radians(lam), math.atan(f), 1000.0
    up = ms.solve(ms.loads(wedge(lam, f, 0.1)))
    assert np.allclose(up.forces.effort, Q * math.tan(L + phi), rtol=1e-11)
    assert np.allclose(up.forces.friction.ideal_effort, Q * math.tan(L), rtol=1e-11)
    assert np.allclose(up.efficiency, math.tan(L) / math.tan(L + phi), rtol=1e-11)
    down = ms.solve(ms.loads(wedge(lam, f, -0.1)))
    assert np.allclose(down.forces.effort, Q * math.tan(L - phi), rtol=1e-11, atol=1e-9)
    assert not up.forces.friction.locked.any() and not down.forces.friction.locked.any()


@pytest.mark.parametrize("f", [0.2, 0.6])
@pytest.mark.parametrize("side", [-1, 1])
def test_wedge_self_locks_exactly_where_lambda_plus_phi_reaches_90_deg(f, side):
    """The closed form: raising locks when lambda + phi >= 90 deg (no finite driving force);
    a hundredth of a degree either side decides it."""
    import mechsolve as ms

    lam = 90.0 - math.degrees(math.atan(f)) + side * 0.01
    res = ms.solve(ms.loads(wedge(lam, f, 0.1)))
    fr = res.forces
    if side > 0:
        assert fr.friction.locked.all()
        assert np.isnan(fr.effort).all()
        assert all(s.startswith("self-locking") for s in res.status())
        assert "self-locking at 3 of 3 positions" in res.summary()
    else:
        assert not fr.friction.locked.any()
        L, phi = math.radians(lam), math.atan(f)
        assert np.allclose(fr.effort, 1000.0 * math.tan(L + phi), rtol=1e-8)
        # lowering never locks this way (lambda > phi here)
    down = ms.solve(ms.loads(wedge(lam, f, -0.1)))
    assert not down.forces.friction.locked.any()


# -- a slider-crank at one position against its hand free bodies ------------------------
R, L_ROD, E = 0.05, 0.2, 0.01  # crank, rod, offset (m)
RHO = {"O": 0.1 * 0.012, "A": 0.08 * 0.01, "C": 0.12 * 0.008}  # f r of each pin (m)
F_CYL = 0.15


def slider_crank(theta_deg: float, omega: float, gas: tuple[float, float]) -> str:
    return f"""
name: slider-crank
units: {{length: m, angle: deg}}
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [{R}, 0]}}}}
  rod: {{points: {{A: [0, 0], C: [{L_ROD}, 0]}}}}
  piston: {{points: {{C: [0, 0]}}}}
joints:
  O: {{revolute: [ground, crank], friction: {{coefficient: 0.1, journal radius: 12 mm}}}}
  A: {{revolute: [crank, rod], friction: {{coefficient: 0.08, journal radius: 10 mm}}}}
  C: {{revolute: [rod, piston], friction: {{coefficient: 0.12, journal radius: 8 mm}}}}
  cylinder: {{slider: [ground, piston], point: C, line: {{through: [0, {E}], angle: 0}},
             friction: {{coefficient: {F_CYL}}}}}
assembly:
  - C.x > A.x
driver: {{joint: O, speed: {omega} rad/s, start: {theta_deg} deg}}
sweep: {{range: 0 deg}}
loads:
  gas: {{force: [{gas[0]} N, {gas[1]} N], at: C, on: piston}}
  brake: {{torque: 3 N m, on: rod}}
"""


def hand_kinematics(theta: float, omega: float):
    """The offset slider-crank by hand: A, C, the rod's angular speed, the piston's speed."""
    ax, ay = R * math.cos(theta), R * math.sin(theta)
    cx = ax + math.sqrt(L_ROD**2 - (E - ay) ** 2)
    phi = math.atan2(E - ay, cx - ax)
    w_rod = -R * omega * math.cos(theta) / (L_ROD * math.cos(phi))
    v_c = -R * omega * math.sin(theta) - L_ROD * math.sin(phi) * w_rod
    return (ax, ay), (cx, E), w_rod, v_c


def free_body_residuals(x, theta, omega, gas):
    """Every free-body equation with friction, by hand. Unknowns: the force on the crank
    by the ground at O, on the rod by the crank at A, on the piston by the rod at C
    (each (x, y)), the normal force N on the piston (along +y), the guide's moment M on
    it, the driving torque T. Each pin's friction moment rho |F| opposes its relative
    rotation (on the second link by the first), the cylinder's f |N| the sliding."""
    ox, oy, ax_, ay_, cx_, cy_, N, M, T = x
    (pax, pay), (pcx, pcy), w_rod, v_c = hand_kinematics(theta, omega)
    s_o = math.copysign(1.0, omega)  # crank on ground
    s_a = math.copysign(1.0, w_rod - omega)  # rod on crank
    s_c = math.copysign(1.0, 0.0 - w_rod)  # piston on rod
    m_o = -RHO["O"] * math.hypot(ox, oy) * s_o  # on the crank
    m_a = -RHO["A"] * math.hypot(ax_, ay_) * s_a  # on the rod (the crank gets -m_a)
    m_c = -RHO["C"] * math.hypot(cx_, cy_) * s_c  # on the piston (the rod gets -m_c)
    fric = -F_CYL * abs(N) * math.copysign(1.0, v_c)  # on the piston, along x
    return np.array(
        [
            # crank: forces, moments about O
            ox - ax_,
            oy - ay_,
            T + m_o - m_a + (pax * -ay_ - pay * -ax_),
            # rod: forces, moments about A (the brake's 3 N m on it)
            ax_ - cx_,
            ay_ - cy_,
            3.0 + m_a - m_c + ((pcx - pax) * -cy_ - (pcy - pay) * -cx_),
            # piston: forces, moment
            cx_ + gas[0] + fric,
            cy_ + gas[1] + N,
            M + m_c,
        ]
    )


def hand_solve(theta, omega, gas):
    """The free-body equations solved by Newton's method (a central-difference Jacobian)
    from a small nonzero start, independent of the solver."""
    x = np.ones(9)
    for _ in range(100):
        r = free_body_residuals(x, theta, omega, gas)
        h = 1e-7 * max(1.0, np.max(np.abs(x)))
        J = np.empty((9, 9))
        for k in range(9):
            d = np.zeros(9)
            d[k] = h
            J[:, k] = (
                free_body_residuals(x + d, theta, omega, gas)
                - free_body_residuals(x - d, theta, omega, gas)
            ) / (2 * h)
        dx = np.linalg.solve(J, -r)
        x = x + dx
        if np.max(np.abs(dx)) < 1e-13 * np.max(np.abs(x)):
            return x
    raise AssertionError("the hand solution did not converge")


@pytest.mark.parametrize(
    "theta_deg, omega, gas",
    [
        (40.0, 100.0, (-2000.0, 0.0)),
        (130.0, 100.0, (1500.0, 300.0)),
        (250.0, -80.0, (-900.0, -50.0)),
    ],
)
def test_slider_crank_at_one_position_matches_its_hand_free_bodies(theta_deg, omega, gas):
    """The solver's reactions satisfy every hand free-body equation and the friction law
    to 1e-9 (relative to the largest force), and equal the hand solution (the same
    equations solved by Newton's method from the frictionless solution, in the test)."""

    import mechsolve as ms

    theta = math.radians(theta_deg)
    res = ms.solve(ms.loads(slider_crank(theta_deg, omega, gas)))
    fr = res.forces
    rx = {k: fr.reactions[k] for k in ("O", "A", "C")}
    cyl = fr.reactions["cylinder"]
    x = np.array(
        [
            rx["O"]["Fx"][0], rx["O"]["Fy"][0], rx["A"]["Fx"][0], rx["A"]["Fy"][0],
            rx["C"]["Fx"][0], rx["C"]["Fy"][0], cyl["N"][0], cyl["M"][0], fr.effort[0],
        ]
    )  # fmt: skip
    scale = np.max(np.abs(x))
    assert np.max(np.abs(free_body_residuals(x, theta, omega, gas))) < 1e-9 * scale
    hand = hand_solve(theta, omega, gas)
    assert np.allclose(x, hand, rtol=1e-9, atol=1e-9 * scale)
    # the friction the solver reports is the law's
    assert fr.friction.friction["O"][0] == pytest.approx(RHO["O"] * math.hypot(*x[:2]), rel=1e-12)
    assert fr.friction.friction["cylinder"][0] == pytest.approx(F_CYL * abs(x[6]), rel=1e-12)


# -- the power balance, f = 0 ------------------------------------------------------------
def engine(pin: str, cylinder: str, step: str = "2 deg") -> str:
    text = SLIDER_CRANK.replace(PIN_O, f"  O: {{revolute: [ground, crank], friction: {pin}}}\n")
    text = text.replace(
        "  A: [crank, rod]\n", f"  A: {{revolute: [crank, rod], friction: {pin}}}\n"
    )
    text = text.replace(CYLINDER, f"line: {{through: [0, 10], angle: 0}}, friction: {cylinder}}}")
    return text.replace("step: 5 deg", f"step: {step}")


def test_power_balance_with_friction_at_every_position():
    """input = output (the loads' power, absorbed) + the sum of the joints' friction
    losses + dT/dt + dV/dt at every position; every loss >= 0."""
    import mechsolve as ms

    res = ms.solve(
        ms.loads(
            engine(
                "{coefficient: 0.1, journal radius: 15 mm, viscous: 0.002 N m s/rad}",
                "{coefficient: 0.15, viscous: 3 N s/m}",
            )
        )
    )
    f = res.forces
    assert f.ok.all() and not f.friction.locked.any()
    losses = sum(f.friction.loss.values())
    assert all(np.all(p >= 0) for p in f.friction.loss.values())
    assert np.all(losses > 0)
    p_out = -f.power_loads
    balance = f.power_input - (p_out + losses + f.kinetic_rate + f.potential_rate)
    scale = np.max(np.abs(f.power_input))
    assert np.max(np.abs(balance)) < 1e-9 * scale
    assert np.max(np.abs(f.residual)) < 1e-9 * scale
    # friction makes the driver pay: input with friction = input without + losses
    ideal_input = f.friction.ideal_effort * f.speed
    assert np.allclose(f.power_input, ideal_input + losses, rtol=0, atol=1e-9 * scale)


def test_zero_friction_gives_exactly_todays_results(tmp_path):
    """A coefficient of zero is no friction: the same numbers, bit for bit, and the
    same table; a vanishing coefficient tends to the ideal joints' results."""
    import mechsolve as ms

    plain = ms.solve(ms.loads(SLIDER_CRANK))
    zero = ms.solve(
        ms.loads(engine("{coefficient: 0, journal radius: 15 mm}", "{coefficient: 0}", "5 deg"))
    )
    assert np.array_equal(plain.forces.effort, zero.forces.effort)
    assert np.array_equal(plain.forces.lam, zero.forces.lam)
    assert zero.forces.friction is None
    plain.to_csv(tmp_path / "a.csv")
    zero.to_csv(tmp_path / "b.csv")
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()
    tiny = ms.solve(
        ms.loads(
            engine("{coefficient: 1e-9, journal radius: 15 mm}", "{coefficient: 1e-9}", "5 deg")
        )
    )
    scale = np.max(np.abs(plain.forces.effort))
    assert np.allclose(tiny.forces.effort, plain.forces.effort, rtol=0, atol=1e-7 * scale)


def test_cycle_efficiency_is_output_work_over_input_work():
    """The summary's efficiency per cycle against the works integrated from the table:
    the gas drives this engine, so the input is the loads' work and the output the
    driver's; both by the trapezoidal rule over a fine sweep."""
    import mechsolve as ms

    res = ms.solve(
        ms.loads(
            engine("{coefficient: 0.1, journal radius: 15 mm}", "{coefficient: 0.2}", "0.25 deg")
        )
    )
    f = res.forces
    text = res.summary()
    line = next(ln for ln in text.splitlines() if "efficiency per cycle" in ln)
    eta = float(line.split(":")[1].split()[0])
    t = res.t
    w_loads = np.trapezoid(f.power_loads, t)
    w_driver = np.trapezoid(f.power_input, t)
    assert w_driver < 0 < w_loads
    assert eta == pytest.approx(-w_driver / w_loads, rel=2e-3)
    w_lost = np.trapezoid(sum(f.friction.loss.values()), t)
    # over the cycle the energies return: what the loads put in is lost or taken out
    assert w_lost == pytest.approx(w_loads + w_driver, rel=1e-3)
    line = next(ln for ln in text.splitlines() if "friction losses per cycle" in ln)
    assert float(line.split(":")[1].split()[0]) == pytest.approx(w_lost, rel=1e-5)


MOTOR_LINKAGE = (ROOT / "mechanisms" / "motor-linkage.yaml").read_text()
GUIDE = "guide: {slider: [ground, slider], point: D, line: {through: [0.5, 0], angle: 90}}"


def six_bar() -> str:
    text = MOTOR_LINKAGE.replace(
        GUIDE, GUIDE[:-1] + ", friction: {coefficient: 0.2, viscous: 5 N s/m}}"
    )
    return text.replace(
        "  K: [rocker, rod]\n",
        "  K: {revolute: [rocker, rod], friction: {coefficient: 0.15, journal radius: 20 mm}}\n",
    )


def test_six_bar_with_friction_keeps_its_power_balance():
    """A six-link machine (two groups, a slider at the end of the chain): friction at a
    pin of the second group and at the slider; the balance holds at every position."""
    import mechsolve as ms

    res = ms.solve(ms.loads(six_bar()))
    f = res.forces
    assert f.ok.all()
    losses = f.power_friction
    assert np.all(losses >= 0) and np.max(losses) > 0
    scale = np.max(np.abs(f.power_input))
    assert np.max(np.abs(f.residual)) < 1e-9 * scale
    # the pin K's friction moment is rho |F| of its own reaction
    K = f.reactions["K"]["F"]
    assert np.allclose(f.friction.friction["K"], 0.15 * 0.02 * K, rtol=1e-12)


def test_multibody_simulation_models_the_friction(tmp_path):
    """The general path simulates joint friction too (issue 28, see
    tests/test_issue28_friction_multibody.py): the run ends normally and its energy
    balance, which counts the friction's work, holds."""
    f = tmp_path / "m.yaml"
    text = six_bar().replace("method: rk4,", "method: rk4, formulation: multibody,")
    f.write_text(text.replace("duration: 2.2 s", "duration: 0.1 s"))
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(tmp_path / "out")])
    assert r.exit_code == 0, r.output
    assert "Traceback" not in r.output
    import csv

    rows = list(csv.DictReader(open(tmp_path / "out" / "simulation.csv")))
    lost = [float(row["power.friction [W]"]) for row in rows]
    assert max(lost) > 0 and min(lost) >= 0
    residual = max(abs(float(row["energy.residual [J]"])) for row in rows)
    work = max(abs(float(row["energy.work [J]"])) for row in rows)
    assert residual < 1e-3 * work


# -- friction in a simulation (the one-degree-of-freedom path) ----------------------------
ROTOR = """
name: rotor
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  rotor: {points: {O: [0, 0], A: [0.1, 0]}, mass: 5 kg, com: O, inertia: 0.02 kg m^2}
joints:
  O: {revolute: [ground, rotor], friction: {coefficient: 0.2, journal radius: 20 mm}}
driver: {joint: O, speed: 10 rad/s, start: 0 deg}
gravity: 9.81 m/s^2
motor: {stall: 10 N m, slope: 0.5 N m s}
simulate: {duration: 0.24 s, step: STEP s, method: rk4, from: rest}
"""


def rotor_start(step: float, smoothing: float | None = None):
    import mechsolve as ms
    import mechsolve.analyses.dynamics.model as model
    from mechsolve.analyses.dynamics import simulate

    old = model.FRICTION_SMOOTHING
    if smoothing is not None:
        model.FRICTION_SMOOTHING = smoothing
    try:
        return simulate(ms.loads(ROTOR.replace("STEP", str(step))))
    finally:
        model.FRICTION_SMOOTHING = old


@pytest.mark.slow
def test_start_up_with_pin_friction_matches_the_closed_form():
    """A rotor balanced on its pin: the pin carries its weight, so the friction moment is
    rho m g, constant while it turns. J w' = M0 - k w - rho m g gives
    w(t) = w_inf (1 - exp(-k t / J)), w_inf = (M0 - rho m g) / k: the start-up includes
    its losses. The Coulomb moment is regularised through the standstill (tanh(w / w_s));
    the standstill is crossed within the first step, whose error (first order there, the
    moment jumping from zero) decays with exp(-k t / J): halving the step halves it, and
    halving w_s changes nothing measurable."""
    rho_mg = 0.2 * 0.02 * 5.0 * 9.81
    w_inf, tau = (10.0 - rho_mg) / 0.5, 0.02 / 0.5
    errs = []
    for h in (0.004, 0.002):
        res = rotor_start(h)
        tr = res.trajectory
        w = w_inf * (1 - np.exp(-tr.t / tau))
        assert abs(tr.omega[-1] - w[-1]) < 1e-4 * w_inf
        ideal = (10.0 / 0.5) * (1 - math.exp(-tr.t[-1] / tau))  # without the losses
        assert abs(tr.omega[-1] - ideal) > 0.3
        errs.append(np.max(np.abs(tr.omega - w)))
        assert np.allclose(res.forces.friction.friction["O"][1:], rho_mg, rtol=1e-3)
        assert np.max(np.abs(res.energy_residual())) < 1e-2 * (0.5 * 0.02 * w_inf**2)
    assert errs[1] < 0.6 * errs[0]  # the first step's error: first order
    assert errs[0] < rho_mg / 0.02 * 0.004  # at most the lost moment over one step
    fine = rotor_start(0.004, smoothing=5e-4).trajectory.omega
    coarse = rotor_start(0.004).trajectory.omega
    assert np.max(np.abs(fine - coarse)) < 1e-6 * w_inf


def test_designs_solved_as_one_batch_keep_their_friction():
    """A design batch (studies, synthesis) gives each design the friction a separate
    solve gives it, and its power balance still closes."""
    import mechsolve as ms
    from mechsolve.analyses.batch import solve_designs

    texts = [
        engine(
            "{coefficient: 0.1, journal radius: 15 mm}", "{coefficient: 0.15}", "10 deg"
        ).replace("A: [50, 0]", f"A: [{a}, 0]")
        for a in (45, 50, 55)
    ]
    mechs = [ms.loads(t) for t in texts]
    batch = solve_designs(mechs)
    for k, m in enumerate(mechs):
        one, alone = batch.results(k).forces, ms.solve(m).forces
        assert one.friction is not None
        assert np.allclose(one.effort, alone.effort, rtol=1e-9, atol=1e-9)
        for j in ("O", "A", "cylinder"):
            assert np.allclose(one.friction.loss[j], alone.friction.loss[j], rtol=1e-9, atol=1e-9)
        assert np.max(np.abs(one.residual)) < 1e-9 * np.max(np.abs(one.power_input))


def test_a_joint_that_does_not_slip_has_no_coulomb_friction():
    """An in-line slider-crank at crank angles 90 and 270 deg: the rod does not turn, so
    the piston pin C does not slip and carries no Coulomb moment there (its direction is
    undefined); elsewhere it does. There the results are those of an ideal pin C."""
    import mechsolve as ms

    def text(pin_c: str) -> str:
        return (
            slider_crank(0.0, 100.0, (-800.0, 0.0))
            .replace(
                "C: {revolute: [rod, piston], friction: {coefficient: 0.12, journal radius: 8 mm}}",
                pin_c,
            )
            .replace("sweep: {range: 0 deg}", "sweep: {range: 360 deg, step: 90 deg}")
        )

    with_c = ms.solve(
        ms.loads(
            text(
                "C: {revolute: [rod, piston], friction: {coefficient: 0.12, journal radius: 8 mm}}"
            ).replace(f"through: [0, {E}]", "through: [0, 0]")
        )
    )
    ideal_c = ms.solve(
        ms.loads(text("C: [rod, piston]").replace(f"through: [0, {E}]", "through: [0, 0]"))
    )
    fc = with_c.forces.friction.friction["C"]
    assert fc[1] == 0.0 and fc[3] == 0.0  # 90 and 270 deg: the rod at rest
    assert fc[0] > 0 and fc[2] > 0
    for i in (1, 3):
        assert with_c.forces.effort[i] == pytest.approx(ideal_c.forces.effort[i], rel=1e-12)


def piston_driven(M0: float) -> str:
    """A slider-crank driven by its piston towards the crank from next to the outer dead
    centre, a torque M0 on the crank; friction only in the crank's pivot (rho = 4 mm)."""
    return f"""
name: piston-driven
units: {{length: mm, angle: deg}}
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [50, 0]}}}}
  rod: {{points: {{A: [0, 0], C: [200, 0]}}}}
  piston: {{points: {{C: [0, 0]}}}}
joints:
  O: {{revolute: [ground, crank], friction: {{coefficient: 0.5, journal radius: 8 mm}}}}
  A: [crank, rod]
  C: [rod, piston]
  cylinder: {{slider: [ground, piston], point: C, line: {{through: [0, 0], angle: 0}}}}
assembly:
  - C.x > A.x
  - A.y > 0
driver: {{joint: cylinder, speed: -0.1 m/s, start: 249.995 mm}}
sweep: {{range: 0.5 mm, step: 0.01 mm}}
loads:
  work: {{torque: {M0} N m, on: crank}}
"""


def test_piston_driven_crank_locks_where_the_rod_passes_inside_the_friction_circle():
    """The rod, with ideal pins at both ends, pushes along its own line; the crank turns
    against the load only if that line passes outside the friction circle of its pivot
    (radius rho): it locks where the line's distance h from O is below rho, and only
    there (the closed form's boundary h = rho, the samples either side of it). With the
    load turning the crank the same way, nothing locks (the driver holds back)."""
    import mechsolve as ms

    res = ms.solve(ms.loads(piston_driven(-20.0)))
    A, C = res.point("A"), res.point("C")
    ux, uy = C.x - A.x, C.y - A.y
    h = np.abs(A.x * uy - A.y * ux) / np.hypot(ux, uy)
    rho = 0.5 * 0.008
    clear = np.abs(h - rho) > 1e-9 * rho
    locked = res.forces.friction.locked
    assert 5 < locked.sum() < len(h) - 5  # the boundary is inside the sweep
    assert np.array_equal(locked[clear], (h < rho)[clear])
    assert np.all(np.isfinite(res.forces.effort[~locked]))
    helped = ms.solve(ms.loads(piston_driven(20.0)))
    assert not helped.forces.friction.locked.any()
