"""Issue 30 (reviews 13 and 14, the trust defects they left).

1. A requirement on a quantity that grows without bound inside the sweep (a pin force at a
   four-bar's change point, s + l = p + q) was a finite located figure that could pass;
   it is now unbounded and fails, while a quantity with a limit there (the driving
   torque, a point's acceleration) keeps its located value. Checked against the free
   bodies written by hand.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.results.requirements import check_requirements

# ground O2-O4, crank, coupler, rocker (mm): 32 + 114.5 = 87.5 + 59, a change point at
# theta = 0, where coupler and rocker lie folded along the line of centres
D, A_, B_, C_ = 87.5, 32.0, 114.5, 59.0
LOAD = 10.0  # N, downwards at the rocker's middle M; the links carry no mass

CHANGE_POINT = """
name: change point
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [32, 0]}}
  coupler: {points: {A: [0, 0], B: [114.5, 0]}}
  rocker: {points: {O4: [0, 0], B: [59, 0], M: [29.5, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 2 deg}
gravity: off
loads:
  push: {force: [0, -10 N], at: M, on: rocker}
requirements:
"""


def _pose(theta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors of the crank O2->A, the coupler A->B and the rocker O4->B, B on the
    left of A -> O4 (the file's branch). The angle at O4 by the half-angle formula, with
    r - (b - c) = 4 a d sin^2(theta/2) / (r + b - c) (D - a = b - c): exact to rounding
    next to the fold, where the law of cosines loses half the digits."""
    a = np.array([math.cos(theta), math.sin(theta)])
    to_o4 = np.array([D, 0.0]) - A_ * a  # A -> O4
    r = float(np.hypot(*to_o4))
    near = 4 * A_ * D * math.sin(theta / 2) ** 2 / (r + B_ - C_)  # r - (b - c)
    s = (r + B_ + C_) / 2
    gamma = 2 * math.atan2(math.sqrt((s - r) * (s - C_)), math.sqrt(s * near / 2))
    phi4 = math.atan2(-to_o4[1], -to_o4[0]) - gamma  # O4 -> B
    u4 = np.array([math.cos(phi4), math.sin(phi4)])
    u3 = to_o4 + C_ * u4
    return a, u3 / np.hypot(*u3), u4


def _cross(p: np.ndarray, q: np.ndarray) -> float:
    return float(p[0] * q[1] - p[1] * q[0])


def pin_force(theta: float) -> float:
    """|O2.F| by free bodies: the massless coupler is a two-force member, so the rocker's
    moments about O4 give F (c/2) cos(phi4) = c F_B sin(phi3 - phi4), and the massless
    crank passes F_B on to O2. As theta -> 0, phi3 - phi4 -> 0 and cos(phi4) -> 1."""
    _, u3, u4 = _pose(theta)
    return LOAD * 0.5 * abs(u4[0]) / abs(_cross(u4, u3))


def torque(theta: float) -> float:
    """|driving torque| (N m) by virtual work at 1 rad/s: the load's power, 10 N times
    the downward speed of M, (c/2) cos(phi4) omega4, with the loop's velocity closure
    omega4 = a sin(theta - phi3) / (c sin(phi4 - phi3))."""
    u2, u3, u4 = _pose(theta)
    omega4 = A_ * _cross(u3, u2) / (C_ * _cross(u3, u4))
    return abs(LOAD * 0.5 * C_ * 1e-3 * u4[0] * omega4)


def _verdicts(reqs: str) -> dict:
    mech = ms.loads(CHANGE_POINT + reqs)
    res = ms.solve(mech)
    return res, {v.name: v for v in check_requirements(mech, res)}


def test_pin_force_at_a_change_point_is_unbounded_and_fails():
    res, v = _verdicts(
        "  pin: max(O2.F) <= 1e9 N\n  pinx: max(abs(A.Fx)) <= 1e9 N\n"
        "  spread: range(B.F) <= 1e9 N\n  fx: min(O2.Fx) >= -1e9 N\n"
    )
    # the model agrees with the free bodies away from the change point
    k = int(np.argmin(np.abs(np.degrees(res.u) - 40.0)))
    col = [c for c in res.columns() if c.name.startswith("O2(") and c.name.endswith(".F")][0]
    assert abs(col.values[k] - pin_force(math.radians(40.0))) < 1e-9 * pin_force(0.7)
    # the free bodies: it grows as 1/theta towards the change point, without bound
    f = [pin_force(t) for t in (1e-2, 1e-4, 1e-6)]
    assert f[1] > 90 * f[0] and f[2] > 90 * f[1]
    for name in ("pin", "pinx", "spread"):
        assert math.isinf(v[name].value) and v[name].value > 0, v[name].message
        assert not v[name].passed and "unbounded" in v[name].message
        assert "grows without bound" in v[name].message, v[name].message
    # the force's x component grows towards -inf at O2 (F_B points along the line)
    assert v["fx"].value == -math.inf and not v["fx"].passed


def test_quantities_with_a_limit_at_the_change_point_keep_their_located_value():
    _, v = _verdicts("  torque: max(abs(input.torque)) <= 1 N m\n")
    # the hand sup: the limit towards 360 deg (the torque's jump is at the change point)
    t = np.radians(np.r_[np.linspace(1, 359, 3581), 360 - np.logspace(-1, -4, 13)])
    hand = max(torque(x) for x in t)
    assert math.isfinite(v["torque"].value) and v["torque"].passed
    assert abs(v["torque"].value - hand) < 1e-4 * hand


# 2. A force-closed cam's follower leaves the cam in a simulation: the motion ends there.
# The cam-linkage's cam and rocker alone, the cam a flywheel (1000 kg m^2) that keeps its
# 600 rpm (the follower's reactions change it by 1e-6), the rocker 0.01 kg m^2 about its
# pivot A. The program's rise is equal acceleration: the rocker's angular acceleration
# jumps from +4 s / beta^2 omega^2 to minus that half way (37.5 deg of cam angle), where
# the spring's moment about A cannot hold it: the contact is lost at the join, at
# t = 37.5 deg / omega (closed form).
CAM = """
name: cam and rocker
units: {length: mm, angle: deg}
ground: {O: [0, 0], A: [135, 0], H: [35, 100]}
links:
  cam: {points: {O: [0, 0]}, mass: 2 kg, com: O, inertia: 1000 kg*m^2}
  rocker:
    points:
      A: [135, 0]
      B: {from: A, length: 125, angle: 167.5}
      C: {from: A, length: 100, angle: 90}
    mass: 0.8 kg
    com: A
    inertia: 0.01 kg*m^2
joints:
  O: [ground, cam]
  A: [ground, rocker]
  contact:
    cam_contact: [cam, rocker]
    centre: O
    roller: {centre: B, radius: 15 mm}
    program:
      follower: {type: oscillating roller, arm: 125 mm, roller_radius: 15 mm}
      pivot_distance: 135 mm
      start_angle: 12.5 deg
      base_radius: 30 mm
      rotation: cw
      law: equal acceleration
      motion: [{rise: 75 deg, swing: 15 deg}, {dwell: 10 deg}, {return: 75 deg},
               {dwell: 200 deg}]
    closure: force
driver: {joint: O, speed: 600 rpm, direction: cw, start: 0 deg}
sweep: {range: 360 deg, step: 1 deg}
gravity: off
loads:
  hold: {spring: [C, H], stiffness: 2000 N/m, free_length: 60 mm, on: [rocker, ground]}
motor: {stall: 0 N m, slope: 0 N m s}
simulate: {duration: 0.012 s, step: 0.001 s, method: rk4, from: 600 rpm}
"""


def _spring_moment(turn: float) -> float:
    """|moment about A| (N m) of the spring C-H (2000 N/m, free 60 mm) with the rocker
    turned by ``turn`` (rad) from its drawn pose (C 100 mm above A)."""
    cx, cy = 135 - 100 * math.sin(turn), 100 * math.cos(turn)
    hx, hy = 35.0, 100.0
    L = math.hypot(hx - cx, hy - cy)
    f = 2000 * (L - 60) * 1e-3  # N, pulling C towards H
    ux, uy = (hx - cx) / L, (hy - cy) / L
    return abs(((cx - 135) * uy - cy * ux) * 1e-3 * f)


def test_simulate_stops_where_the_follower_leaves_the_cam(tmp_path):
    from click.testing import CliRunner

    from mechsolve.cli.main import main

    omega = 600 * 2 * math.pi / 60
    swing, beta = math.radians(15), math.radians(75)
    # by hand: past the join the rocker must decelerate at 4 s / beta^2 omega^2, which
    # the spring cannot give at the join (the rocker turned 7.5 deg either way)
    need = 0.01 * 4 * swing / beta**2 * omega**2
    assert need > 2 * max(_spring_moment(math.radians(a)) for a in (-7.5, 7.5))
    t_sep = math.radians(37.5) / omega
    f = tmp_path / "cam.yaml"
    f.write_text(CAM)
    out = tmp_path / "o"
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(out), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert "the motion stopped early" in r.output  # the warning of singular: stop
    text = r.output
    assert "leaves the cam at contact at t = " in text and "driver angle 322.5°" in text
    assert "LOSS OF CONTACT" not in text  # no row past it: nothing to warn of
    rows = (out / "simulation.csv").read_text().splitlines()
    head = rows[0].split(",")
    t = np.array([float(x.split(",")[head.index("t [s]")]) for x in rows[1:]])
    N = np.array([float(x.split(",")[head.index("contact(cam->rocker).N [N]")]) for x in rows[1:]])
    # every row before the separation, then the located state; none after it
    assert np.allclose(t[:-1], 0.001 * np.arange(len(t) - 1), atol=1e-15)
    assert len(t) == math.floor(t_sep / 0.001) + 2
    assert abs(t[-1] - t_sep) < 2e-5 * t_sep  # the cam's speed varies by 1e-6
    assert np.all(N >= 0)


def test_multibody_simulate_stops_before_the_follower_leaves_the_cam():
    omega = 600 * 2 * math.pi / 60
    t_sep = math.radians(37.5) / omega  # the join, as above
    text = CAM.replace("method: rk4,", "method: rk4, formulation: multibody,")
    from mechsolve.analyses.dynamics import simulate

    res = simulate(ms.loads(text))
    tr = res.trajectory
    assert tr.early and "leaves the cam at contact at about t = " in tr.stopped
    # every row before the separation is kept, none after it
    assert np.allclose(tr.t, 0.001 * np.arange(len(tr.t)), atol=1e-15)
    assert tr.t[-1] < t_sep < tr.t[-1] + 0.001
    said = float(tr.stopped.split("about t = ")[1].split(" s")[0])
    assert tr.t[-1] < said <= tr.t[-1] + 0.001
    assert np.all(res.forces.reactions["contact"]["N"] >= 0)


# 5. compare's table: the columns line up where a cell's unit prints shorter than it is
# written (kg*m^2 prints as kg·m², N*m as N·m).
SLIDER = """
name: NAME
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [0.1, 0]}, mass: 1 kg, uniform_bar: [O, A]}
  rod: {points: {A: [0, 0], B: [ROD, 0]}, mass: 2 kg, uniform_bar: [A, B]}
  slider: {points: {B: [0, 0]}, mass: 3 kg, com: B}
joints:
  O: [ground, crank]
  A: [crank, rod]
  B: [rod, slider]
  guide: {slider: [ground, slider], point: B, line: {through: [0, 0.04], angle: 0}}
assembly: ["B.x > A.x"]
driver: {joint: O, speed: 10 rad/s, start: 30 deg}
sweep: {range: 360 deg, step: 5 deg}
loads:
  push: {force: [-1000 N, 0], at: B, on: slider}
outputs: {points: [B]}
"""


def test_compare_table_rows_have_one_display_width(tmp_path):
    from mechsolve.analyses.compare import compare
    from mechsolve.base.units import pretty_text

    files = []
    for name, rod in (("short rod", 0.35), ("a scheme with a long rod", 0.5)):
        f = tmp_path / f"{rod}.yaml"
        f.write_text(SLIDER.replace("NAME", name).replace("ROD", repr(rod)))
        files.append(f)
    c = compare(files, outputs=["B.x", "B.x"])
    text = pretty_text(c.text())  # as the command prints it
    lines = text.splitlines()
    table = lines[1 : lines.index(next(x for x in lines if x.startswith("requirements"))) + 1]
    assert any("kg·m²" in row for row in table) and any("N·m" in row for row in table)
    # characters, not bytes: "·" and "²" are one character each on the screen
    assert len({len(row) for row in table}) == 1, [len(row) for row in table]
    # and each scheme's cells start under its name
    head = table[0]
    starts = [head.index(s.name) for s in c.schemes]
    for row in table[1:]:
        for k in starts:
            assert row[k - 1] == " " and row[k - 2] == " ", row


# 3. A law of a `motors:` entry with a pole the motion passes between two steps: refused
# at its key, the motion kept up to the step before, as the driver's `motor:` is.
ROTOR = """
name: rotor
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  rotor: {points: {O: [0, 0], P: [0.1, 0]}, mass: 1 kg, com: O, inertia: 1 kg*m^2}
joints:
  O: [ground, rotor]
gravity: off
motors:
  spin: {joint: O, torque: "50 - 1.25 * omega - 1/(omega - 30)"}
"""


@pytest.mark.parametrize(
    "placed",
    [
        "driver: {joint: O, speed: 1 rad/s, start: 0 deg}\n"
        "simulate: {duration: 1.5 s, step: 0.01 s, method: rk4, from: rest}\n",
        "simulate: {duration: 1.5 s, step: 0.01 s, method: rk4, pose: {O: 0 deg}}\n",
    ],
    ids=["driver", "pose"],
)
def test_a_pole_of_a_motors_law_is_refused_at_its_key(tmp_path, placed):
    from click.testing import CliRunner
    from scipy.integrate import solve_ivp

    from mechsolve.cli.main import main

    f = tmp_path / "rotor.yaml"
    f.write_text(ROTOR + placed)
    out = tmp_path / "o"
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(out), "--no-plots"])
    assert r.exit_code == 2, r.output
    assert "motors.spin.torque:" in r.output, r.output
    assert "grows without bound at omega = 30 rad/s" in r.output and "Traceback" not in r.output
    rows = (out / "simulation.csv").read_text().splitlines()
    head = rows[0].split(",")
    t = np.array([float(x.split(",")[head.index("t [s]")]) for x in rows[1:]])
    iw = next(i for i, h in enumerate(head) if h.startswith("rotor.omega"))
    scale = math.pi / 180 if head[iw].endswith("[deg/s]") else 1.0
    w = np.array([float(x.split(",")[iw]) for x in rows[1:]]) * scale
    # by hand: 1 kg m^2 * omega' = the law, from rest, up to the pole at 30 rad/s
    ref = solve_ivp(
        lambda _, y: [50 - 1.25 * y[0] - 1 / (y[0] - 30)],
        (0, t[-1]),
        [0.0],
        t_eval=t,
        rtol=1e-10,
        atol=1e-12,
    )
    far = w < 29.0  # (next to the pole RK4's error grows as the law's derivatives do)
    assert np.max(np.abs(ref.y[0] - w)[far]) < 1e-6
    # kept up to the last step before the pole, none past it (0.3 rad/s a step there)
    assert w.max() < 30 < w.max() + 1.0 and t[-1] < 1.5


# 4. A multibody simulate that starts at a singular position: a parallelogram (cranks
# 0.4 m, 1 kg bars; coupler 1 m, 2 kg) from rest at its collinear pose under gravity.
PARALLELOGRAM = """
name: parallelogram
units: {length: m, angle: deg}
ground: {O1: [0, 0], O2: [1, 0]}
links:
  c1: {points: {O1: [0, 0], A: [0.4, 0]}, mass: 1 kg, uniform_bar: [O1, A]}
  cp: {points: {A: [0, 0], B: [1, 0]}, mass: 2 kg, uniform_bar: [A, B]}
  c2: {points: {O2: [0, 0], B: [0.4, 0]}, mass: 1 kg, uniform_bar: [O2, B]}
joints:
  O1: [ground, c1]
  A: [c1, cp]
  B: [cp, c2]
  O2: [ground, c2]
assembly: ["B.y >= A.y - 1e-9"]
driver: {joint: O1, speed: 1 rad/s, start: START deg}
gravity: 9.81 m/s^2
simulate: {duration: 0.05 s, step: 0.01 s, method: DOP853, rtol: 1e-11, atol: 1e-13,
           formulation: multibody}
"""


def test_a_start_at_a_singular_position_is_refused_and_one_next_to_it_runs(tmp_path):
    from click.testing import CliRunner

    from mechsolve.analyses.dynamics import simulate
    from mechsolve.cli.main import main

    # by hand, from rest at the collinear pose: on the parallel branch (the cranks turn
    # together, the coupler translates) I = 2 m l^2 / 3 + m_c l^2 = 0.42667 kg m^2 and
    # V = 1.2 g sin(theta) J: theta'' = -1.2 g / I = -27.59 rad/s^2; on the crossed branch
    # (phi = -7/3 theta to first order) I = 0.7822, dV/dtheta = -0.8 g: +10.03 rad/s^2.
    # The pose and the rates do not say which: refused, naming the start.
    f = tmp_path / "p.yaml"
    f.write_text(PARALLELOGRAM.replace("START", "0"))
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 2, r.output
    assert "driver.start:" in r.output and "driver angle 0°" in r.output
    assert "singular position" in r.output and "Traceback" not in r.output
    # 1e-6 rad along the parallel branch: the branch's motion, energy conserved
    res = simulate(ms.loads(PARALLELOGRAM.replace("START", repr(math.degrees(1e-6)))))
    tr = res.trajectory
    I, g = 2 * 1.0 * 0.4**2 / 3 + 2.0 * 0.4**2, 9.81
    from scipy.integrate import solve_ivp

    ref = solve_ivp(
        lambda _, y: [y[1], -1.2 * g * math.cos(y[0]) / I],
        (0, 0.05),
        [1e-6, 0.0],
        t_eval=tr.t,
        rtol=1e-12,
        atol=1e-14,
    )
    assert np.max(np.abs(np.asarray(tr.u) - ref.y[0])) < 1e-8
    E = np.asarray(tr.kinetic) + np.asarray(tr.potential)
    assert np.max(np.abs(E - E[0])) < 1e-9 * 1.2 * g * 0.4
