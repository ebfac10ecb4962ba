"""Issue 28, item 2: the shaking force and moment on the frame.

References, independent of the force analysis:
* the total momentum and angular momentum of the moving links computed from the
  positions alone (link angles and centres of mass), differentiated in time spectrally
  over a full turn at constant speed: F = -dp/dt, M_P = -dH_P/dt;
* a hand Newton-Euler solution of an in-line slider-crank in closed form;
* the joints' own reported reactions (the frame gets the opposite of what its pins give).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve import api

FOURBAR = "mechanisms/fourbar.yaml"


def spectral_dt(f: np.ndarray, period: float) -> np.ndarray:
    """d/dt of a periodic signal sampled uniformly over one period (last sample left
    out), by the FFT: independent of any finite-difference step."""
    n = len(f)
    k = np.fft.fftfreq(n, d=period / n) * 2 * math.pi
    return np.real(np.fft.ifft(1j * k * np.fft.fft(f)))


def momenta(res, about=(0.0, 0.0)):
    """Total momentum (px, py) and angular momentum about ``about`` from positions only."""
    mech, an, st = res.mechanism, res.analysis, res.solution.state
    n = len(res.u) - 1  # the last sample repeats the first
    period = 2 * math.pi / abs(mech.driver.speed)
    sx, sy, H = np.zeros(n), np.zeros(n), np.zeros(n)
    rows = []
    for lk in mech.links:
        b = an.system.index[lk.name]
        x, y = st.point(b, np.asarray(lk.com, float))
        th = np.unwrap(st.th[b][:n])
        drift = (th[-1] - th[0]) * n / (n - 1) if abs(th[-1] - th[0]) > math.pi else 0.0
        # a turning crank: its angle less a uniform ramp is periodic
        ramp = drift * np.arange(n) / n
        w = spectral_dt(th - ramp, period) + drift / period
        vx, vy = spectral_dt(x[:n], period), spectral_dt(y[:n], period)
        rows.append((lk.mass, x[:n], y[:n], vx, vy))
        sx += lk.mass * vx
        sy += lk.mass * vy
        H += lk.inertia * w + lk.mass * ((x[:n] - about[0]) * vy - (y[:n] - about[1]) * vx)
    return sx, sy, H, period


def test_fourbar_shaking_is_minus_the_rate_of_momentum():
    mech = ms.load(FOURBAR)
    sh = api.shaking(mech, inertia=True, step=math.radians(1.0))
    px, py, H, T = momenta(sh.results)
    n = len(px)
    fx, fy = -spectral_dt(px, T), -spectral_dt(py, T)
    scale = np.max(np.hypot(fx, fy))
    assert scale > 1e-3  # a real shaking force
    assert np.max(np.abs(sh.fx[:n] - fx)) < 1e-6 * scale
    assert np.max(np.abs(sh.fy[:n] - fy)) < 1e-6 * scale
    m = -spectral_dt(H, T)  # the motor's reaction included (the motor is on the frame)
    assert np.max(np.abs(sh.moment[:n] - m)) < 1e-6 * np.max(np.abs(m))


def test_moment_about_another_point_and_the_joints_reactions():
    mech = ms.load(FOURBAR)
    about = mech.ground["O4"]
    sh = api.shaking(mech, inertia=True, about=about, step=math.radians(1.0))
    px, py, H, T = momenta(sh.results, about)
    n = len(px)
    m = -spectral_dt(H, T)
    assert np.max(np.abs(sh.moment[:n] - m)) < 1e-6 * np.max(np.abs(m))
    # the frame receives the opposite of what its two pins give the crank and the rocker
    res = sh.results
    for c, f in (("Fx", sh.fx), ("Fy", sh.fy)):
        pins = res.reaction("O2")[c] + res.reaction("O4")[c]
        assert np.allclose(f, -pins, rtol=0, atol=1e-12 * np.max(np.abs(f)))


def test_with_gravity_the_frame_carries_the_weight_too():
    text = open(FOURBAR).read().split("loads:")[0]  # gravity on, no loads
    mech = ms.loads(text)
    sh = api.shaking(mech, step=math.radians(1.0))
    inert = api.shaking(ms.loads(text), inertia=True, step=math.radians(1.0))
    weight = sum(lk.mass for lk in mech.links) * 9.81
    assert np.allclose(sh.fx, inert.fx, atol=1e-12)
    assert np.allclose(sh.fy - inert.fy, -weight, atol=1e-12)


SLIDER_CRANK = """
name: in-line slider-crank
units: {{length: m, angle: deg}}
ground: {{O: [0, 0]}}
links:
  crank:
    points: {{O: [0, 0], A: [{r}, 0], G2: [{e}, 0]}}
    mass: {m2} kg
    com: G2
    inertia: {J2} kg m^2
  rod:
    points: {{A: [0, 0], B: [{l}, 0], G3: [{g}, 0]}}
    mass: {m3} kg
    com: G3
    inertia: {J3} kg m^2
  piston:
    points: {{B: [0, 0]}}
    mass: {m4} kg
    com: B
joints:
  O: [ground, crank]
  A: [crank, rod]
  B: [rod, piston]
  cylinder: {{slider: [ground, piston], point: B, line: {{through: [0, 0], angle: 0}}}}
assembly:
  - B.x > A.x
driver: {{joint: O, speed: {w} rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: 5 deg}}
gravity: 0 m/s^2
"""
P = dict(r=0.05, e=0.01, m2=1.3, J2=0.002, l=0.2, g=0.07, m3=0.9, J3=0.004, m4=0.6, w=100.0)


def hand_newton_euler(th, p, about=(0.0, 0.0)):
    """The in-line slider-crank at constant crank speed, by hand: closed-form kinematics
    and F = -sum m a_G, M = -sum (J alpha + m (r_G - P) x a_G) (the crank's alpha = 0)."""
    r, l, e, g, w = p["r"], p["l"], p["e"], p["g"], p["w"]
    s, c = np.sin(th), np.cos(th)
    phi = np.arcsin(-r * s / l)
    dphi = -r * w * c / (l * np.cos(phi))
    ddphi = (r * s * w * w + l * np.sin(phi) * dphi**2) / (l * np.cos(phi))
    A = np.array([r * c, r * s])
    aA = -w * w * A
    G2, a2 = e * np.array([c, s]), -w * w * e * np.array([c, s])
    u = np.array([np.cos(phi), np.sin(phi)])
    du = np.array([-np.sin(phi), np.cos(phi)])
    G3 = A + g * u
    a3 = aA + g * (ddphi * du - dphi**2 * u)
    B = A + l * u
    aB = aA + l * (ddphi * du - dphi**2 * u)
    F = -(p["m2"] * a2 + p["m3"] * a3 + p["m4"] * aB)
    M = -p["J3"] * ddphi
    for m, R, a in ((p["m2"], G2, a2), (p["m3"], G3, a3), (p["m4"], B, aB)):
        M -= m * ((R[0] - about[0]) * a[1] - (R[1] - about[1]) * a[0])
    return F, M


@pytest.mark.parametrize("about", [(0.0, 0.0), (0.3, -0.1)])
def test_slider_crank_against_a_hand_newton_euler_solution(about):
    mech = ms.loads(SLIDER_CRANK.format(**P))
    sh = api.shaking(mech, about=about)
    th = sh.results.u
    F, M = hand_newton_euler(th, P, about)
    scale = np.max(np.hypot(*F))
    assert np.max(np.abs(sh.fx - F[0])) < 1e-9 * scale
    assert np.max(np.abs(sh.fy - F[1])) < 1e-9 * scale
    assert np.max(np.abs(sh.moment - M)) < 1e-9 * np.max(np.abs(M))


def test_figures_and_columns_have_units():
    sh = api.shaking(ms.load(FOURBAR), inertia=True)
    f = np.hypot(sh.fx, sh.fy)
    figs = sh.figures()
    assert figs["peak force"][0] == pytest.approx(np.max(f))
    assert figs["peak force"][2] == "largest sample"
    # the RMS over the turn: the last sample repeats the first and is counted once
    assert figs["RMS force"][0] == pytest.approx(math.sqrt(np.mean(f[:-1] ** 2)), rel=1e-12)
    # a step that does not divide the turn (a shorter last step): still the turn's mean
    coarse = api.shaking(ms.load(FOURBAR), inertia=True, step=math.radians(7.0))
    fine = api.shaking(ms.load(FOURBAR), inertia=True, step=math.radians(0.25))
    rms = fine.figures()["RMS force"][0]
    assert coarse.figures()["RMS force"][0] == pytest.approx(rms, rel=1e-3)
    heads = [c.header for c in sh.columns()]
    assert "shaking.Fx [N] (on the frame)" in heads
    assert any(h.startswith("shaking.M [N*m]") for h in heads)
    text = "\n".join(sh.summary_lines())
    assert " N at " in text and " N*m " in text


def test_the_command_writes_the_table_and_the_plot(tmp_path):
    from click.testing import CliRunner

    from mechsolve.cli.main import main

    out = tmp_path / "out"
    r = CliRunner().invoke(
        main, ["shaking", FOURBAR, "--about", "O4", "--inertia-only", "-o", str(out)]
    )
    assert r.exit_code == 0, r.output
    assert "about ground point O4" in r.output and "peak force" in r.output
    rows = (out / "shaking.csv").read_text().splitlines()
    head = rows[0].split(",")
    assert head[3] == "shaking.Fx [N] (on the frame)"
    mech = ms.load(FOURBAR)
    sh = api.shaking(mech, inertia=True, about=mech.ground["O4"])
    first = rows[1].split(",")
    assert float(first[3]) == pytest.approx(sh.fx[0], rel=1e-11)
    assert (out / "shaking.png").stat().st_size > 0


def minus_rate_of_momenta(res):
    """-sum m a_G and -sum (J alpha + m r_G x a_G) about the origin, from the sweep's
    kinematics (positions, velocities, accelerations: no force analysis)."""
    mech, an, st = res.mechanism, res.analysis, res.solution.state
    n = len(res.u)
    fx, fy, m = np.zeros(n), np.zeros(n), np.zeros(n)
    for lk in mech.links:
        if not lk.mass and not lk.inertia:
            continue
        b = an.system.index[lk.name]
        s = np.asarray(lk.com if lk.com is not None else (0.0, 0.0), float)
        ax, ay = st.point_acceleration(b, s)
        x, y = st.point(b, s)
        fx -= lk.mass * ax
        fy -= lk.mass * ay
        m -= lk.inertia * st.al[b] + lk.mass * (x * ay - y * ax)
    return fx, fy, m


@pytest.mark.parametrize(
    "file",
    [
        "gear-train.yaml",  # a gear pair: the tooth forces' radial part
        "cam-linkage.yaml",  # a cam contact
        "shaper.yaml",  # a slider on a moving guide
        "crane.yaml",
        "motor-linkage.yaml",
    ],
)
def test_every_joint_kind_answers_for_the_frame(file):
    """Whatever the joints, the frame's load is -dp/dt and -dH/dt (inertia only)."""
    sh = api.shaking(ms.load("mechanisms/" + file), inertia=True)
    fx, fy, m = minus_rate_of_momenta(sh.results)
    scale, mscale = np.max(np.hypot(fx, fy)), np.max(np.abs(m))
    assert scale > 0 and mscale > 0
    assert np.max(np.hypot(sh.fx - fx, sh.fy - fy)) < 1e-12 * scale
    assert np.max(np.abs(sh.moment - m)) < 1e-12 * mscale


RACK_ON_FRAME = """
name: pinion on a fixed rack
units: {length: mm, angle: deg}
ground: {R0: [0, 0], R1: [100, 0]}
links:
  carriage: {points: {C: [0, 0], D: [50, 0]}, mass: 2 kg, com: D, inertia: 0.01 kg m^2}
  pinion: {points: {C: [0, 0], M: [25, 0]}, mass: 0.5 kg, com: M, inertia: 0.002 kg m^2}
joints:
  rail: {slider: [ground, carriage], point: C, line: {through: [0, 25], angle: 0}}
  C: [carriage, pinion]
  mesh: {rack: [ground, pinion], pitch_line: [R0, R1], radius: 25 mm}
driver: {joint: C, speed: 4 rad/s, start: 0 deg}
sweep: {range: 400 deg, step: 10 deg}
"""


def test_a_rack_on_the_frame_and_a_motor_off_it():
    """The rack's separating force acts on the frame directly; the motor between the
    carriage and the pinion is not on the frame, its torque is internal."""
    sh = api.shaking(ms.loads(RACK_ON_FRAME), inertia=True)
    fx, fy, m = minus_rate_of_momenta(sh.results)
    scale = np.max(np.hypot(fx, fy))
    assert np.max(np.hypot(sh.fx - fx, sh.fy - fy)) < 1e-12 * scale
    assert np.max(np.abs(sh.moment - m)) < 1e-12 * np.max(np.abs(m))
