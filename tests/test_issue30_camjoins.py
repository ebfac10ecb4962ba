"""A cam inside a linkage: its program's joins, where the follower's acceleration jumps
(a review's findings on ``mechanisms/cam-linkage.yaml``).

The references are independent of the solver:

* the joins of the equal-acceleration program (rise 75 deg, dwell 10, return 75, dwell
  200) are at 0, 37.5, 75, 85, 122.5 and 160 deg of cam travel, and the rocker follows the
  law's closed form, s = 2 h (theta/beta)^2 on the first half of the rise;
* at a join the contact force and the driving torque come from a hand free body of the
  rocker, the link and the slide (:func:`hand`), with the rocker's motion from the law's
  closed form on the chosen side of the join: N = -88.1011 N just after 37.5 deg of
  travel at 250 rpm (driver angle 322.5 deg), the torque 5.39609 N m just after 122.5 deg
  at 60 rpm (driver angle 237.5 deg);
* a smooth loss of contact (the flat-faced yoke of issue 25) is where N = 35 + 62 cos
  theta is zero.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

import mechsolve
from mechsolve.base.units import SI_OUTPUT
from mechsolve.report.build import figures_table
from mechsolve.results.run import for_plots

ROOT = Path(__file__).resolve().parents[1]
CAM = ROOT / "mechanisms" / "cam-linkage.yaml"
DEG = math.pi / 180
H, BETA = 15 * DEG, 75 * DEG  # the program's swing and rise (= return) angle
A, HOOK = np.array([0.135, 0.0]), np.array([0.035, 0.100])  # the rocker's pivot, spring


def _cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _J(v):
    return np.array([-v[1], v[0]])


def law(theta: float, after: bool) -> tuple[float, float, float]:
    """The rocker's swing s (rad) and its derivatives in the cam's travel theta, from the
    equal-acceleration law's closed form on the half before (``after`` False) or after
    the join at mid-rise or mid-return."""
    if theta < 85 * DEG:
        u, sg, base = theta / BETA, 1.0, 0.0
    else:
        u, sg, base = (theta - 85 * DEG) / BETA, -1.0, H
    if not after:
        s, s1, s2 = 2 * H * u**2, 4 * H * u / BETA, 4 * H / BETA**2
    else:
        w = 1 - u
        s, s1, s2 = H - 2 * H * w**2, 4 * H * w / BETA, -4 * H / BETA**2
    return base + sg * s, sg * s1, sg * s2


def hand(theta: float, after: bool, rpm: float) -> tuple[float, float, float]:
    """The contact force N (N), the cam's driving torque (N m) and the pressure angle
    (deg) at cam travel theta, by hand: the rocker (pinned at A, its centre of mass
    there, 0.0025 kg m^2) swings as the law says, cw as the roller rises; the link CD
    (0.4 kg uniform bar) and the slide (4 kg, a 20 N resistance) from their free bodies;
    the spring (2000 N/m, 60 mm free) on the rocker at C; the roller's force along the
    pitch curve's normal, through B."""
    w = rpm * 2 * math.pi / 60
    s, s1, s2 = law(theta, after)
    d, d1, d2 = -s, -s1 * w, -s2 * w**2

    def on_rocker(length: float, angle: float):
        r = length * np.array([math.cos(angle + d), math.sin(angle + d)])
        return A + r, d1 * _J(r), d2 * _J(r) - d1**2 * r

    B, vB, _ = on_rocker(0.125, 167.5 * DEG)
    C, vC, aC = on_rocker(0.100, 90 * DEG)
    L = math.hypot(0.313885 - 0.135, 0.020)
    sp = (0.120 - C[1]) / L
    cp = math.sqrt(1 - sp**2)
    p1 = -vC[1] / (L * cp)
    p2 = (-aC[1] + L * sp * p1**2) / (L * cp)
    D = np.array([C[0] + L * cp, 0.120])
    aD = np.array([aC[0] - L * sp * p2 - L * cp * p1**2, 0.0])
    G, aG = 0.5 * (C + D), 0.5 * (aC + aD)
    ml, Il = 0.4, 0.4 * L**2 / 12
    FDx = 4.0 * aD[0] + 20.0  # on the slide by the link
    # the link: ml aG = FC - FD, Il p2 = (C - G) x FC - (D - G) x FD; FC, FDy unknown
    M = np.array([[1.0, 0, 0], [0, 1, -1], [-(C - G)[1], (C - G)[0], -(D - G)[0]]])
    rhs = np.array([ml * aG[0] + FDx, ml * aG[1], Il * p2 - (D - G)[1] * FDx])
    FCx, FCy, _ = np.linalg.solve(M, rhs)
    FC = np.array([FCx, FCy])  # on the link by the rocker
    e = HOOK - C
    Fs = 2000 * (np.hypot(*e) - 0.060) * e / np.hypot(*e)
    vrel = vB + w * _J(B)  # the roller centre relative to the cam (cw about O)
    n = _J(vrel) / np.hypot(*vrel)
    n = n if n @ B > 0 else -n  # from the cam to the follower
    N = (0.0025 * d2 - _cross(C - A, Fs - FC)) / _cross(B - A, n)
    t = _J(B - A) / np.hypot(*(B - A))  # where B moves
    pa = math.degrees(math.acos(min(1.0, abs(float(n @ t)))))
    return N, _cross(B, N * n), pa


def test_the_joins_are_the_programs_and_the_rocker_follows_the_law():
    from mechsolve.core.breaks import break_points

    res = mechsolve.solve(mechsolve.load(CAM, "fast"))
    found = sorted(-math.degrees(u) for u in break_points(res.analysis, res.solution))
    np.testing.assert_allclose(found, [0, 37.5, 75, 85, 122.5, 160, 360], atol=1e-9)
    # the rise's closed form: the rocker turns cw by s = 2 h (theta / beta)^2 ...
    travel = -np.asarray(res.u)
    ang = np.unwrap(res.link("rocker").angle)
    swing = -(ang - ang[0])
    for k in (10, 20, 37, 38, 60, 75, 80, 100, 140, 200):
        theta = travel[k]
        expect = law(theta, theta >= 37.5 * DEG if theta < 85 * DEG else theta >= 122.5 * DEG)
        want = expect[0] if theta < 160 * DEG else 0.0
        if 75 * DEG <= theta <= 85 * DEG:
            want = H
        assert abs(swing[k] - want) < 1e-9, (k, swing[k], want)


def test_the_figures_sweep_samples_both_sides_of_each_join():
    # the driving torque jumps at the joins: its largest value is just after 122.5 deg of
    # travel (driver angle 237.5 deg), by hand 5.39609 N m at 60 rpm
    res = mechsolve.solve(mechsolve.load(CAM))
    fine = for_plots(res.mechanism, res)
    _, torque, _ = hand(122.5 * DEG, True, 60)
    assert abs(torque - 5.39609) < 5e-6
    e = fine.driving_effort
    i = int(np.nanargmax(e))
    assert abs(e[i] - torque) < 1e-7 * torque
    assert abs(math.degrees(fine.u[i]) + 122.5) < 1e-6
    # the report's figures table reads that sweep
    row = next(r for r in figures_table(fine, SI_OUTPUT).rows if r[0] == "largest driving torque")
    assert row[1] == "5.39609 N m" and "driver angle 237.5°" in row[2]


def test_loss_of_contact_is_at_the_joins_with_the_least_force_by_hand():
    res = mechsolve.solve(mechsolve.load(CAM, "fast"))
    text = res.summary(figures=for_plots(res.mechanism, res))
    N, _, pa = hand(37.5 * DEG, True, 250)
    assert abs(N - -88.1011) < 5e-5
    line = next(t for t in text.splitlines() if "LOSS OF CONTACT" in t)
    least = re.search(r"least (-?[0-9.]+) N at driver angle ([0-9.]+)°", line)
    assert least is not None, line
    assert abs(float(least.group(1)) - N) < 1e-4 and float(least.group(2)) == 322.5
    spans = re.findall(r"from driver angle ([0-9.]+)° to driver angle ([0-9.]+)°", line)
    assert [(float(a), float(b)) for a, b in spans] == [(322.5, 285.0), (275.0, 237.5)]
    # the spans are printed once: the warning points at the line
    assert (
        text.count("to driver angle 285°") == 1
        and text.count("warning: the follower leaves the cam") == 1
    )
    # the largest pressure angle is at the same join (the follower's fastest), by hand
    big = re.search(r"largest pressure angle ([0-9.]+)° at driver angle ([0-9.]+)°", text)
    assert big is not None
    assert abs(float(big.group(1)) - pa) < 1e-4 and float(big.group(2)) == 322.5
    assert abs(pa - 48.3194) < 5e-5


YOKE = """
name: eccentric cam, flat-faced follower
units: {length: mm, angle: deg}
ground: {O: [0, 0], S: [0, 200]}
links:
  cam: {points: {O: [0, 0]}}
  ram: {points: {P: [0, 0], T: [0, 60]}, mass: 2 kg, com: P}
joints:
  O: [ground, cam]
  guide: {slider: [ground, ram], point: P, line: {through: [0, 0], angle: 90 deg}}
  contact:
    cam_contact: [cam, ram]
    centre: O
    cam_angle: -90 deg
    eccentric: {radius: 40 mm, eccentricity: 10 mm}
    face: {through: P, normal: 90 deg}
driver: {joint: O, speed: 60 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 1 deg}
gravity: off
loads:
  hold: {spring: [T, S], stiffness: 1000 N/m, free_length: 130 mm}
  weight: {force: [0, -5 N], at: P}
"""


def test_a_smooth_loss_of_contact_is_located_to_the_digits_printed():
    # N = 35 + 62 cos(theta) (issue 25's hand calculation): zero at cos = -35/62
    res = mechsolve.solve(mechsolve.loads(YOKE))
    line = next(t for t in res.summary().splitlines() if "LOSS OF CONTACT" in t)
    found = [float(x) for x in re.findall(r"driver angle ([0-9.]+)°", line.rsplit("): ", 1)[1])]
    hand_ = math.degrees(math.acos(-35 / 62))
    # printed to 0.001 deg: right to its last digit (linear interpolation between the
    # 1 deg samples is 0.0015 deg off)
    np.testing.assert_allclose(found, [hand_, 360 - hand_], atol=5.1e-4)
    least = re.search(r"least (-?[0-9.]+) N at driver angle ([0-9.]+)°", line)
    assert least is not None and abs(float(least.group(1)) - (35 - 62)) < 1e-6
    assert abs(float(least.group(2)) - 180) < 1e-3
