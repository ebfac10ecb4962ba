"""Issue 25: seed 001's schemes 1 and 2 of the shaper's main motion, as mechanism files.

Both are sized to the shaper's stroke and time ratio (shaper.yaml: crank 110 mm, frame
380 mm, bar 540 mm: stroke 2 * 540 * 110 / 380 mm, swing theta = 2 asin(110 / 380),
K = (180 + theta) / (180 - theta)). Checked here against closed forms written in the
tests, independently of the solver:

* scheme 2 (guide bar, sector gear R, rack under the ram): the bar's angle is that of the
  crank pin A seen from O4, theta4 = atan2(380 + 110 sin(phi), 110 cos(phi)), and the ram
  rolls with the sector: x_C = -R (theta4 - 90 deg), v_C = -R dtheta4/dt;
* scheme 1 (a cam driving a rocker, the rocker driving the ram by a rod): the rocker turns
  by the cam's program, the equal acceleration law written out below, and the ram follows
  the rocker's long arm through the rod: x_C = x_E + sqrt(135^2 - (528.44 - y_E)^2);
* Grübler's count as the seed's, F = 1 (scheme 1 with the roller's local freedom).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mechsolve import api
from mechsolve.analyses.compare import compare

MECH = Path(__file__).resolve().parent.parent / "mechanisms"
SWING = 2 * math.asin(110 / 380)  # rad, the guide bar's
STROKE = 2 * 0.540 * 110 / 380  # m, the guide bar's
K = (math.pi + SWING) / (math.pi - SWING)
OMEGA = 2 * math.pi  # rad/s, 60 rpm
R = 0.5322713  # m, scheme 2's sector: STROKE / SWING


# -- scheme 2 ----------------------------------------------------------------------------
def test_scheme2_ram_rolls_with_the_sector():
    res = api.solve(api.load(MECH / "shaper-scheme2.yaml"))
    phi = np.radians(res.driver_value)  # the crank's angle (driven, clockwise)
    # the ram's left limit: the crank square to the bar, at 180 deg + asin(110/380)
    start = math.remainder(phi[0] - (math.pi + math.asin(110 / 380)), 2 * math.pi)
    assert start == pytest.approx(0, abs=1e-9)
    r, d = 0.110, 0.380
    th4 = np.arctan2(d + r * np.sin(phi), r * np.cos(phi))
    dth4 = (r * r + d * r * np.sin(phi)) / (r * r + d * d + 2 * d * r * np.sin(phi))
    c = res.point("C")
    np.testing.assert_allclose(c.x, -R * (th4 - math.pi / 2), rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.vx, -R * dth4 * (-OMEGA), rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.y, R, rtol=0, atol=1e-12)
    assert R * SWING == pytest.approx(STROKE, abs=1e-7)
    # the tooth force: the ram on a horizontal frictionless guide is pushed along x only by
    # the rack and the cutting force, so |Ft| = |m a_x - F_cut| and Fn = |Ft| / cos(20 deg)
    frac = (c.x + R * SWING / 2) / (R * SWING)
    cut = np.where((c.vx > 0) & (frac >= 0.05) & (frac <= 0.95), -7000.0, 0.0)
    ft = np.abs(700 / 9.81 * c.ax - cut)
    rack = res.reaction("rack")
    np.testing.assert_allclose(np.abs(rack["Ft"]), ft, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(rack["Fn"], ft / math.cos(math.radians(20)), rtol=1e-9)


def test_scheme2_stroke_time_ratio_and_count():
    mech = api.load(MECH / "shaper-scheme2.yaml")
    rep = api.check(mech)
    assert rep.pair_counts() == (4, 5, 1)  # crank, block, bar, ram; O2, A, slot, O4, guide; rack
    assert (rep.grubler, rep.jacobian_dof) == (1, 1)  # the seed's F = 1
    (s,) = compare([MECH / "shaper-scheme2.yaml"]).schemes
    assert s.stroke == pytest.approx(R * SWING, abs=1e-9)
    assert s.stroke == pytest.approx(0.3126316, abs=1e-7)
    assert s.time_ratio == pytest.approx(K, rel=1e-7)
    assert s.time_ratio == pytest.approx(1.4599, abs=1e-4)
    # the peak reaction takes each joint's own magnitude (the rack's Fn: before, compare
    # looked for F or N and failed with KeyError 'N' on a rack or a gear pair)
    assert s.reaction_peak >= 7000 / math.cos(math.radians(20))


# -- scheme 1 ----------------------------------------------------------------------------
# the file's program: the guide bar's swing and crank angles, rounded to 1e-4 deg
H1 = math.radians(33.6529)  # rad, the rocker's swing
RISE, RET = math.radians(213.6529), math.radians(146.3471)  # cam angles, rad


def equal_acceleration(th: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rocker's swing (rad) and its first two derivatives in the cam angle for the
    program rise H1 over RISE, return over RET, no dwell, each half of each move at a
    constant acceleration: d = 2 h (t/b)^2, then h - 2 h (1 - t/b)^2 (rise; mirrored on
    the return)."""
    h = H1
    d, d1, d2 = (np.zeros_like(th) for _ in range(3))
    up = th < RISE
    u = th[up] / RISE
    first = u < 0.5
    d[up] = np.where(first, 2 * h * u**2, h - 2 * h * (1 - u) ** 2)
    d1[up] = np.where(first, 4 * h * u, 4 * h * (1 - u)) / RISE
    d2[up] = np.where(first, 4 * h, -4 * h) / RISE**2
    w = (th[~up] - RISE) / RET
    first = w < 0.5
    d[~up] = np.where(first, h - 2 * h * w**2, 2 * h * (1 - w) ** 2)
    d1[~up] = np.where(first, -4 * h * w, -4 * h * (1 - w)) / RET
    d2[~up] = np.where(first, -4 * h, 4 * h) / RET**2
    return d, d1, d2


def test_scheme1_rocker_follows_its_cam_program():
    res = api.solve(api.load(MECH / "shaper-scheme1.yaml"))
    th = np.radians(res.driver_travel)  # cam angle travelled (clockwise) from the rise's start
    jumps = np.array([0, RISE / 2, RISE, RISE + RET / 2, RISE + RET])  # the law's a jumps
    keep = np.min(np.abs(th[:, None] - jumps), axis=1) > 1e-6
    d, d1, d2 = equal_acceleration(th)
    rocker = res.link("rocker")  # the rise turns it clockwise: its angle is -d
    np.testing.assert_allclose(rocker.angle, -d, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rocker.omega[keep], -d1[keep] * OMEGA, rtol=0, atol=1e-8)
    np.testing.assert_allclose(rocker.alpha[keep], -d2[keep] * OMEGA**2, rtol=0, atol=1e-6)
    # the ram follows the long arm (540 mm, from 106.82645 deg = 90 + 33.6529 / 2) by the rod
    arm = math.radians(106.82645) - d
    ex, ey = 0.540 * np.cos(arm), 0.540 * np.sin(arm)
    np.testing.assert_allclose(
        res.point("C").x, ex + np.sqrt(0.135**2 - (0.52844 - ey) ** 2), rtol=0, atol=1e-9
    )


def test_scheme1_stroke_time_ratio_and_count():
    mech = api.load(MECH / "shaper-scheme1.yaml")
    rep = api.check(mech)
    assert rep.pair_counts() == (4, 5, 1)  # cam, rocker, rod, ram; O2, O4, E, C, guide; cam
    assert (rep.grubler, rep.jacobian_dof) == (1, 1)
    # the seed's count: n = 5, Pl = 6, Ph = 1, one local freedom (the roller on its pin)
    assert sum(j.local_dof for j in mech.joints) == 1
    assert "3*5 - 2*6 - 1 - 1 = 1" in rep.text()
    # the ram's stroke is the chord of E's arc at the rocker's limits (same y there)
    chord = 2 * 0.540 * math.sin(H1 / 2)
    assert chord == pytest.approx(STROKE, abs=1e-7)  # the swing rounded to 1e-4 deg
    (s,) = compare([MECH / "shaper-scheme1.yaml"]).schemes
    assert s.stroke == pytest.approx(chord, abs=2e-9)
    assert s.time_ratio == pytest.approx(RISE / RET, rel=1e-7)
    # the mean driving torque: the cutting force's work over 90 % of the stroke per turn
    # (weights and kinetic energy come back each turn); before, the trapezoid over the
    # 0.1 deg samples across the cam law's acceleration jumps gave 313.49 N m
    assert s.torque_mean == pytest.approx(7000 * 0.9 * chord / (2 * math.pi), rel=2e-6)
    assert s.time_ratio == pytest.approx(K, rel=1e-6)
    assert s.time_ratio == pytest.approx(1.4599, abs=1e-4)


def test_scheme1_pressure_angle_at_the_cam_by_instant_centres():
    """compare reports the cam's pressure angle (before, only the loops' transmission angle:
    4.9 deg for scheme 1, at the rod). Independently: the cam and the rocker share their
    relative instant centre P on the line of centres O4-O2, where w_cam (p - a) = w_rocker p;
    the common normal at the roller runs through P and the roller centre B, which moves
    square to O4-B: the pressure angle is the angle between B - P and that motion."""
    th = np.radians(np.arange(0, 360, 0.01))
    d, d1, _ = equal_acceleration(th)
    w_cam, w_rocker = -OMEGA, -d1 * OMEGA  # counter-clockwise positive
    a, arm = 0.380, 0.300
    beta = np.radians(-14.0) - d
    bx, by = arm * np.cos(beta), arm * np.sin(beta)
    p = w_cam * a / (w_cam - w_rocker)
    nx, ny = bx - p, by
    cos_alpha = np.abs(nx * -by + ny * bx) / (np.hypot(nx, ny) * arm)
    alpha = np.degrees(np.arccos(np.clip(cos_alpha, 0, 1)))
    i = int(np.argmax(alpha))
    assert alpha[i] == pytest.approx(43.06, abs=0.005)  # mechsolve cam's figure, in the file
    (s,) = compare([MECH / "shaper-scheme1.yaml"]).schemes
    assert math.degrees(s.contact_pressure) == pytest.approx(alpha[i], abs=1e-4)
    assert s.contact_pressure_joint == "contact"
    assert math.degrees(s.contact_pressure_at) == pytest.approx(math.degrees(th[i]), abs=0.1)
    (g,) = compare([MECH / "shaper.yaml"]).schemes  # no cam: no figure
    assert math.isnan(g.contact_pressure) and g.contact_pressure_joint == ""


def test_a_sector_that_turns_fully_stops_where_its_angle_wraps(tmp_path):
    """Known limit: a rack meshing with a link whose angle a loop solves (here the guide
    bar, made to turn fully by putting the crank's pivot 50 mm from O4: a Whitworth
    quick-return) breaks off where that angle wraps at 180 deg (the rolling condition
    takes the angle as solved, so the ram would jump by 2 pi R). The sweep stops there,
    keeping the positions it solved, and says so (before: exit 2, nothing kept)."""
    src = (MECH / "shaper-scheme2.yaml").read_text()
    src = src.replace("O2: [0, 380]", "O2: [0, 50]").replace(
        "start: {limit: C.x, at: min}", "start: 0 deg"
    )
    f = tmp_path / "whitworth.yaml"
    f.write_text(src)
    from click.testing import CliRunner

    from mechsolve.cli.main import main

    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "out"), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert "group of ram" in r.output and "cannot be followed continuously" in r.output
    assert "results are incomplete" in r.output
    rows = (tmp_path / "out" / "results.csv").read_text().splitlines()
    assert len(rows) > 30  # the positions before the wrap, and the ones not solved
