"""Issue 25, item 3: a cam touching a follower inside a linkage (``cam_contact``).

Each test checks the joint against something independent of it:

* a circular eccentric cam (radius R, eccentricity e) with a flat-faced translating
  follower is a Scotch yoke: s = e (1 - cos theta), v = e w sin theta, a = e w^2 cos theta;
* with a roller (radius r) on a follower guided at an offset d from the cam's centre it is
  an offset slider-crank with crank e and rod R + r: y = e sin phi + sqrt(L^2 - c^2),
  c = d - e cos phi, and its derivatives (written out below); its pressure angle is the
  rod's angle from the guide, asin(|c| / L);
* the same circle given as a profile table gives the same motion, to the table's accuracy;
* a cam made from seed 001's motion program (the shaper's feed cam) swings its rocker as
  table 5-2 says, and its pressure angle is the one ``mechsolve cam`` computes;
* a force-closed follower (a spring and a load) too heavy for the speed leaves the cam
  where the hand calculation N = k (d0 + s) + F0 + m a = 0 says;
* the driver's power balances the kinetic energy's and the spring's rates;
* bad input (a profile table that does not close, a roller that cannot reach the cam)
  exits 2 in a real process with the file, the line and the key path.
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
from mechsolve.analyses.cam.analysis import analyse
from mechsolve.analyses.cam.model import load as load_cam

ROOT = Path(__file__).resolve().parents[1]
W = 30.0  # rad/s

# seed 001, table 5-2 (recomputed: the printed table has four misprints), swing in deg
# every 5 deg of cam angle over the rise (75 deg); the return mirrors it
TABLE_5_2_RISE = [
    0.0, 0.13333333333333333, 0.5333333333333333, 1.2000000000000002, 2.1333333333333333,
    3.333333333333333, 4.800000000000001, 6.533333333333334, 8.466666666666665, 10.2,
    11.666666666666668, 12.866666666666667, 13.8, 14.466666666666667, 14.866666666666667,
    15.0,
]  # fmt: skip


def flat_yoke(extra: str = "", step: str = "5 deg", speed: float = W, spring: str = "") -> str:
    return f"""
name: eccentric cam, flat-faced follower
units: {{length: mm, angle: deg}}
ground: {{O: [0, 0], S: [0, 200]}}
links:
  cam: {{points: {{O: [0, 0]}}}}
  ram: {{points: {{P: [0, 0], T: [0, 60]}}, mass: 2 kg, com: P}}
joints:
  O: [ground, cam]
  guide: {{slider: [ground, ram], point: P, line: {{through: [0, 0], angle: 90 deg}}}}
  contact:
    cam_contact: [cam, ram]
    centre: O
    cam_angle: -90 deg
    eccentric: {{radius: 40 mm, eccentricity: 10 mm}}
    face: {{through: P, normal: 90 deg}}
driver: {{joint: O, speed: {speed} rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: {step}}}
gravity: off
{spring}
{extra}
"""


def roller_crank(profile: str) -> str:
    return f"""
name: eccentric cam, offset roller follower
units: {{length: mm, angle: deg}}
ground: {{O: [0, 0]}}
links:
  cam: {{points: {{O: [0, 0]}}}}
  ram: {{points: {{B: [8, 50]}}, mass: 0.5 kg, com: B}}
joints:
  O: [ground, cam]
  guide: {{slider: [ground, ram], point: B, line: {{through: [8, 0], angle: 90 deg}}}}
  contact:
    cam_contact: [cam, ram]
    centre: O
    {profile}
    roller: {{centre: B, radius: 10 mm}}
driver: {{joint: O, speed: {W} rad/s, start: 20 deg}}
sweep: {{range: 360 deg, step: 5 deg}}
gravity: off
"""


def slider_crank(phi: np.ndarray, e=0.012, L=0.05, d=0.008):
    """The offset slider-crank's slider y, dy/dphi, d2y/dphi2 (crank e, rod L, offset d)."""
    c, c1, c2 = d - e * np.cos(phi), e * np.sin(phi), e * np.cos(phi)
    Q = np.sqrt(L * L - c * c)
    Q1 = -c * c1 / Q
    Q2 = -(c1**2 + c * c2) / Q - c * c * c1**2 / Q**3
    return e * np.sin(phi) + Q, e * np.cos(phi) + Q1, -e * np.sin(phi) + Q2, c


def test_eccentric_cam_with_flat_face_is_a_scotch_yoke():
    mech = mechsolve.loads(flat_yoke())
    rep = mechsolve.check(mech)
    assert rep.grubler == 1 and rep.jacobian_dof == 1
    assert "3*2 - 2*2 - 1" in rep.text()
    res = mechsolve.solve(mech)
    th = np.asarray(res.u)
    e, base = 0.010, 0.030  # the face's lowest height: R - e
    ram = res.slider("guide")
    np.testing.assert_allclose(ram.s - base, e * (1 - np.cos(th)), atol=1e-15)
    np.testing.assert_allclose(ram.v, e * W * np.sin(th), atol=1e-13)
    np.testing.assert_allclose(ram.a, e * W * W * np.cos(th), atol=1e-11)
    # a face square to its guide: no pressure angle; the contact carries the inertia
    r = res.reaction("contact")
    np.testing.assert_allclose(r["pressure_angle"], 0.0, atol=1e-12)
    np.testing.assert_allclose(r["N"], 2.0 * e * W * W * np.cos(th), atol=1e-10)


def test_eccentric_cam_with_roller_is_an_offset_slider_crank():
    res = mechsolve.solve(mechsolve.loads(roller_crank(
        "eccentric: {radius: 40 mm, eccentricity: 12 mm}")))  # fmt: skip
    phi = np.asarray(res.u)
    y, y1, y2, c = slider_crank(phi)
    ram = res.slider("guide")
    np.testing.assert_allclose(ram.s, y, atol=1e-15)
    np.testing.assert_allclose(ram.v, y1 * W, atol=1e-13)
    np.testing.assert_allclose(ram.a, y2 * W * W, atol=1e-11)
    pa = res.reaction("contact")["pressure_angle"]
    np.testing.assert_allclose(pa, np.degrees(np.arcsin(np.abs(c) / 0.05)), atol=1e-9)
    # the contact force along the rod carries the ram's inertia: N cos(alpha) = m a
    r = res.reaction("contact")
    np.testing.assert_allclose(r["Fy"], 0.5 * y2 * W * W, atol=1e-10)
    check = mechsolve.check(mechsolve.loads(roller_crank(
        "eccentric: {radius: 40 mm, eccentricity: 12 mm}"))).text()  # fmt: skip
    # the textbooks' count, the roller a link with its spin a local degree of freedom
    assert "3*3 - 2*3 - 1 - 1 = 1" in check


def test_the_circle_as_a_profile_table_gives_the_same_motion():
    ang = np.linspace(0.0, 360.0, 721)
    e, R = 12.0, 40.0
    rho = e * np.cos(np.radians(ang)) + np.sqrt(R * R - (e * np.sin(np.radians(ang))) ** 2)
    rows = ", ".join(f"[{a:.12g}, {r:.15g}]" for a, r in zip(ang, rho))
    res = mechsolve.solve(mechsolve.loads(roller_crank(f"table: {{polar: [{rows}]}}")))
    phi = np.asarray(res.u)
    y, y1, y2, _ = slider_crank(phi)
    ram = res.slider("guide")
    # a cubic spline through 720 points of the radius: its error, and the offset's
    np.testing.assert_allclose(ram.s, y, atol=1e-9)
    np.testing.assert_allclose(ram.v, y1 * W, atol=1e-7)
    np.testing.assert_allclose(ram.a, y2 * W * W, atol=2e-5 * W * W * 0.012)
    # a flat face on the same circle given as points
    xy = ", ".join(
        f"[{R * math.cos(t) + 10 * math.cos(-math.pi / 2):.15g}, "
        f"{R * math.sin(t) + 10 * math.sin(-math.pi / 2):.15g}]"
        for t in np.radians(ang)
    )
    flat = (
        flat_yoke()
        .replace("eccentric: {radius: 40 mm, eccentricity: 10 mm}", f"table: {{points: [{xy}]}}")
        .replace("cam_angle: -90 deg", "cam_angle: 0 deg")
    )
    res = mechsolve.solve(mechsolve.loads(flat))
    th = np.asarray(res.u)
    np.testing.assert_allclose(res.slider("guide").s - 0.03, 0.01 * (1 - np.cos(th)), atol=1e-9)


SHAPER = """
name: shaper feed cam in a linkage
units: {length: mm, angle: deg}
ground: {O: [0, 0], A: [135, 0], S: [135, 90]}
links:
  cam: {points: {O: [0, 0]}, mass: 3 kg, com: O, inertia: 0.004 kg*m^2}
  rocker:
    points: {A: [135, 0], B: {from: A, length: 125, angle: 167.5}, K: [60, 40]}
    mass: 1.2 kg
    com: K
    inertia: 0.002 kg*m^2
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
driver: {joint: O, speed: 60 rpm, direction: cw, start: 0 deg}
sweep: {range: 360 deg, step: 2.5 deg}
gravity: off
loads:
  hold: {spring: [K, S], stiffness: 3000 N/m, free_length: 120 mm}
"""


def test_a_cam_from_a_motion_program_reproduces_the_program():
    mech = mechsolve.loads(SHAPER)
    res = mechsolve.solve(mech)
    travel = np.asarray(res.driver_travel)  # deg of cam angle from the start (cw)
    swing = np.degrees(np.mod(-np.asarray(res.link("rocker").angle) + math.pi, 2 * math.pi))
    swing = swing[::2] - 180.0  # every 5 deg, as table 5-2
    rise = swing[:16]
    ret = swing[17:33]  # from 85 deg of cam angle
    assert np.allclose(travel[:32:2], np.arange(0, 80, 5))
    # the pitch curve is the program's to rounding (checked against the inversion)
    acc = mech.joint("contact").curve.accuracy
    assert acc < 1e-14
    np.testing.assert_allclose(rise, TABLE_5_2_RISE, atol=1e-10)
    np.testing.assert_allclose(ret, TABLE_5_2_RISE[::-1], atol=1e-10)
    np.testing.assert_allclose(swing[33:], 0.0, atol=1e-10)  # the near dwell
    # the pressure angle is the one 'mechsolve cam' gives for the same cam (its table)
    cam = analyse(load_cam(ROOT / "mechanisms" / "shaper-cam.yaml"))
    ref = np.degrees(cam.table.pressure)  # every 5 deg of cam angle, clockwise
    pa = res.reaction("contact")["pressure_angle"]
    np.testing.assert_allclose(pa[::2], ref, atol=1e-9)
    # README: the adopted cam reaches 48.32 deg at mid-rise (37.5 deg of cam angle)
    assert abs(pa[15] - 48.32) < 0.005 and np.argmax(pa) == 15


def test_the_power_balance_holds_through_the_cam():
    res = mechsolve.solve(mechsolve.loads(SHAPER))
    f = res.forces
    scale = max(np.max(np.abs(f.power_input)), np.max(np.abs(f.kinetic_rate)))
    assert scale > 1.0  # the cam does work on the rocker and the spring
    assert np.max(np.abs(f.residual)) < 1e-9 * scale
    # the spring keeps the roller on the cam at this speed
    assert np.all(res.reaction("contact")["N"] > 0)
    assert "LOSS OF CONTACT" not in res.summary()


def test_a_weak_spring_loses_contact_where_the_hand_calculation_says():
    # N = k (d0 + s) + F0 + m a = 1000 (0.02 + 0.01 (1 - cos)) + 5 + 2 * 0.01 * 60^2 cos
    #   = 35 + 62 cos(theta): zero at cos(theta) = -35/62
    spring = """
loads:
  hold: {spring: [T, S], stiffness: 1000 N/m, free_length: 130 mm}
  weight: {force: [0, -5 N], at: P}
"""
    res = mechsolve.solve(mechsolve.loads(flat_yoke(step="1 deg", speed=60, spring=spring)))
    th = np.asarray(res.u)
    N = res.reaction("contact")["N"]
    np.testing.assert_allclose(N, 35 + 62 * np.cos(th), atol=1e-9)
    text = res.summary()
    assert "LOSS OF CONTACT" in text and "warning: the follower leaves the cam" in text
    line = next(t for t in text.splitlines() if "LOSS OF CONTACT" in t)
    spans = line.rsplit("): ", 1)[1]  # after the least force and where it is
    found = [float(x) for x in re.findall(r"driver angle ([0-9.]+)°", spans)]
    hand = math.degrees(math.acos(-35 / 62))
    assert len(found) == 2
    np.testing.assert_allclose(found, [hand, 360 - hand], atol=2e-3)
    # a stronger spring keeps contact: no warning
    strong = spring.replace("1000 N/m", "4000 N/m")
    res = mechsolve.solve(mechsolve.loads(flat_yoke(step="1 deg", speed=60, spring=strong)))
    assert np.all(res.reaction("contact")["N"] > 0) and "LOSS" not in res.summary()


def test_the_csv_has_the_contact_force_and_the_pressure_angle(tmp_path):
    res = mechsolve.solve(mechsolve.loads(roller_crank(
        "eccentric: {radius: 40 mm, eccentricity: 12 mm}")))  # fmt: skip
    heads = [c.header for c in res.columns()]
    assert "contact(cam->ram).N [N]" in heads
    assert "contact(cam->ram).pressure_angle [deg]" in heads


def _run(path: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-m", "mechsolve", "check", str(path)],
                       capture_output=True, text=True, env=env, timeout=300)  # fmt: skip
    assert "Traceback" not in p.stdout + p.stderr
    return p


@pytest.mark.parametrize(
    ("profile", "where", "says"),
    [
        ("table: {polar: [[0, 50], [90, 50], [180, 50], [270, 50], [300, 50], [310, 50],\n"
         "      [320, 50], [330, 50], [340, 49]]}", "joints.contact.table.polar",
         "not closed"),
        ("eccentric: {radius: 5 mm, eccentricity: 2 mm}", "joints.contact.roller",
         "cannot touch the cam"),
    ],
)  # fmt: skip
def test_bad_cam_input_exits_2_with_file_line_and_key(tmp_path, profile, where, says):
    text = (
        roller_crank(profile)
        .replace("through: [8, 0]", "through: [80, 0]")
        .replace("[8, 50]", "[80, 50]")
    )
    f = tmp_path / "cam.yaml"
    f.write_text(text)
    p = _run(f)
    assert p.returncode == 2, p.stdout + p.stderr
    m = re.search(r"cam\.yaml:(\d+): (\S+): (.*)", p.stderr)
    assert m, p.stderr
    line = text.splitlines()[int(m.group(1)) - 1]
    assert m.group(2) == where and says in m.group(3)
    assert where.split(".")[-1] + ":" in line


def test_a_flat_faced_cam_from_a_program_moves_its_follower_as_the_program_says():
    from mechsolve.base.cam.laws import LAWS
    from mechsolve.base.cam.program import build_program

    src = """
name: flat-faced program cam
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  cam: {points: {O: [0, 0]}}
  ram: {points: {P: [0, 40]}, mass: 1 kg, com: P}
joints:
  O: [ground, cam]
  guide: {slider: [ground, ram], point: P, line: {through: [0, 0], angle: 90 deg}}
  contact:
    cam_contact: [cam, ram]
    centre: O
    face: {through: P, normal: 90 deg}
    program:
      follower: {type: translating flat-faced}
      base_radius: 40 mm
      rotation: ccw
      law: cycloidal
      motion: [{rise: 120 deg, lift: 20 mm}, {dwell: 30 deg}, {return: 120 deg},
               {dwell: 90 deg}]
driver: {joint: O, speed: 10 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 5 deg}
gravity: off
"""
    res = mechsolve.solve(mechsolve.loads(src))
    d, law = math.radians, LAWS["cycloidal"]
    prog = build_program(
        [("rise", d(120), 0.02, law), ("dwell", d(30), None, None),
         ("return", d(120), None, law), ("dwell", d(90), None, None)],
        False,
    )  # fmt: skip
    s, s1, s2, _ = prog.eval(np.radians(np.asarray(res.driver_travel)))
    ram = res.slider("guide")
    np.testing.assert_allclose(ram.s - 0.04, s, atol=1e-15)
    np.testing.assert_allclose(ram.v, 10 * s1, atol=1e-14)
    np.testing.assert_allclose(ram.a, 100 * s2, atol=1e-12)
    # a face square to its guide: the pressure angle is 0 throughout
    np.testing.assert_allclose(res.reaction("contact")["pressure_angle"], 0.0, atol=1e-12)


def test_the_example_counts_as_the_seed_and_loses_contact_when_fast():
    path = ROOT / "mechanisms" / "cam-linkage.yaml"
    text = mechsolve.check(mechsolve.load(path)).text()
    # seed 001, scheme 1: Pl = 6, Ph = 1 and one local degree of freedom in the roller
    assert "3*4 - 2*5 - 1" in text and "3*5 - 2*6 - 1 - 1 = 1" in text
    res = mechsolve.solve(mechsolve.load(path))
    assert np.all(res.reaction("contact")["N"] > 0) and "LOSS" not in res.summary()
    fast = mechsolve.solve(mechsolve.load(path, "fast"))
    assert np.any(fast.reaction("contact")["N"] < 0)
    assert "LOSS OF CONTACT" in fast.summary()


def test_an_oscillating_flat_face_swings_as_its_program_says():
    from mechsolve.base.cam.laws import LAWS
    from mechsolve.base.cam.profile import Follower, solve
    from mechsolve.base.cam.program import build_program

    a, r0 = 100.0, 30.0
    ph = math.asin(r0 / a)  # the face touches the base circle: a sin(phi0) = r0
    px, py = a - 50 * math.cos(ph), 50 * math.sin(ph)  # a point of the face
    src = f"""
name: oscillating flat face
units: {{length: mm, angle: deg}}
ground: {{O: [0, 0], A: [{a}, 0]}}
links:
  cam: {{points: {{O: [0, 0]}}}}
  rocker: {{points: {{A: [{a}, 0], P: [{px}, {py}]}}, mass: 1 kg, com: P,
           inertia: 0.001 kg*m^2}}
joints:
  O: [ground, cam]
  A: [ground, rocker]
  contact:
    cam_contact: [cam, rocker]
    centre: O
    face: {{through: P, normal: {90 - math.degrees(ph)} deg}}
    program:
      follower: {{type: oscillating flat-faced, arm: 150 mm}}
      pivot_distance: {a} mm
      base_radius: {r0} mm
      rotation: ccw
      law: cycloidal
      motion: [{{rise: 120 deg, swing: 15 deg}}, {{dwell: 30 deg}}, {{return: 120 deg}},
               {{dwell: 90 deg}}]
driver: {{joint: O, speed: 10 rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: 5 deg}}
gravity: off
"""
    res = mechsolve.solve(mechsolve.loads(src))
    d, law = math.radians, LAWS["cycloidal"]
    prog = build_program(
        [("rise", d(120), d(15), law), ("dwell", d(30), None, None),
         ("return", d(120), None, law), ("dwell", d(90), None, None)],
        True,
    )  # fmt: skip
    th = np.radians(np.asarray(res.driver_travel))
    s, s1, s2, _ = prog.eval(th)
    rocker = res.link("rocker")
    swing = np.mod(-np.asarray(rocker.angle) + math.pi, 2 * math.pi) - math.pi
    np.testing.assert_allclose(swing, s, atol=1e-14)
    np.testing.assert_allclose(-rocker.omega, 10 * s1, atol=1e-13)
    np.testing.assert_allclose(-rocker.alpha, 100 * s2, atol=1e-11)
    f = Follower("oscillating", "flat-faced", r0 * 1e-3, pivot=a * 1e-3, start_angle=ph)
    ref = np.degrees(solve(prog, f, 1, th).pressure)
    np.testing.assert_allclose(res.reaction("contact")["pressure_angle"], ref, atol=1e-10)


def test_a_follower_that_cannot_touch_the_cam_at_the_start_exits_2(tmp_path):
    # crank e = 12, rod 50 (circle 40 + roller 10), guide at x = 45: the roller centre
    # reaches the pitch circle for most cam angles, but not at 180 deg, where the circle's
    # centre is at x = -12, 57 mm from the guide: 7 mm beyond the rod. A start there is
    # refused at the joint's key (not as a Newton group that fails to close)
    text = roller_crank("eccentric: {radius: 40 mm, eccentricity: 12 mm}")
    text = text.replace("through: [8, 0]", "through: [45, 0]").replace("[8, 50]", "[45, 20]")
    f = tmp_path / "start.yaml"
    f.write_text(text.replace("start: 20 deg", "start: 180 deg"))
    p = _run(f)
    assert p.returncode == 2, p.stdout + p.stderr
    m = re.search(r"start\.yaml:(\d+): joints\.contact\.roller: (.*)", p.stderr)
    assert m and "does not touch the cam at the start" in m.group(2), p.stderr
    assert "roller:" in text.splitlines()[int(m.group(1)) - 1]
    assert "7 mm" in m.group(2)  # 45 + 12 - 50
    # from 20 deg it assembles and runs
    f.write_text(text)
    assert _run(f).returncode == 0
