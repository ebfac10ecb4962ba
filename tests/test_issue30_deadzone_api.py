"""A dead zone stepped over between two samples, a sweep at rest, and the driver's travel.

The four-bar below (crank a = 40, coupler b = 69.999, rocker c = 50, ground d = 80 mm)
cannot close where |O4 A| > b + c, i.e. for crank angles within 0.496 deg of 180 deg;
sampled every 5 deg from 2.5 deg, no sample lands in that range. Every figure is checked
against the four-bar's closed form:

* the dead zone's edges, |O4 A| = b + c: ``cos(theta) = (a^2 + d^2 - (b + c)^2) / (2 a d)``;
  there B lies on the segment A O4, so the rocker points from O4 to A;
* the rocker's other extreme, where crank and coupler are in line (|O2 B| = a + b): B is
  where the circles of radius a + b about O2 and c about O4 meet;
* the rocker at any crank angle from the vector loop (two circles, B left of A -> O4).
"""

from __future__ import annotations

import math

import numpy as np
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.cli.main import main

A, B, C, D = 40.0, 69.999, 50.0, 80.0  # mm

DZ = f"""
name: gap four-bar
units: {{length: mm, angle: deg}}
ground:
  O2: [0, 0]
  O4: [{D}, 0]
links:
  crank:
    points: {{O2: [0, 0], A: [{A}, 0]}}
    mass: 0.05 kg
    uniform_bar: [O2, A]
  coupler:
    points: {{A: [0, 0], B: [{B}, 0]}}
    mass: 0.2 kg
    uniform_bar: [A, B]
  rocker:
    points: {{O4: [0, 0], B: [{C}, 0]}}
    mass: 0.11 kg
    uniform_bar: [O4, B]
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {{joint: O2, speed: 2 rad/s, start: 2.5 deg}}
sweep: {{range: 360 deg, step: 5 deg}}
"""


def _edges() -> tuple[float, float]:
    """The crank angles (rad) where the loop stops closing and closes again."""
    th = math.acos((A * A + D * D - (B + C) ** 2) / (2 * A * D))
    return th, 2 * math.pi - th


def _rocker(theta: float) -> float:
    """The rocker's angle (rad, in (-pi, pi]) at crank angle ``theta``, B left of A -> O4."""
    ax, ay = A * math.cos(theta), A * math.sin(theta)
    ex, ey = D - ax, -ay  # A -> O4
    r = math.hypot(ex, ey)
    along = (B * B - C * C + r * r) / (2 * r)  # from A along A -> O4
    h = math.sqrt(max(B * B - along * along, 0.0))
    bx = ax + (along * ex - h * ey) / r  # to the left of A -> O4
    by = ay + (along * ey + h * ex) / r
    return math.atan2(by, bx - D)


def _in_line() -> tuple[float, float]:
    """(crank angle, rocker angle) where crank and coupler are in line, B above."""
    r = A + B
    x = (r * r - C * C + D * D) / (2 * D)
    y = math.sqrt(r * r - x * x)
    return math.atan2(y, x), math.atan2(y, x - D)


def _on_turn(u: float, ref: float) -> float:
    """Distance between two crank angles on the circle (rad)."""
    return abs((u - ref + math.pi) % (2 * math.pi) - math.pi)


def test_the_closed_form_itself():
    # the vector loop closes at the in-line position and, at the edge, B is on A O4
    th, psi = _in_line()
    assert abs(_rocker(th) - psi) < 1e-9
    e_in, _ = _edges()
    ax, ay = A * math.cos(e_in), A * math.sin(e_in)
    assert abs(math.hypot(D - ax, ay) - (B + C)) < 1e-9
    assert abs(_rocker(e_in) - math.atan2(ay, ax - D)) < 1e-6  # (the root, to sqrt rounding)


def test_the_dead_zone_between_samples_is_reported_with_its_located_edges():
    res = ms.solve(ms.loads(DZ))
    assert res.ok.all()  # no sample falls in it
    zones = [e for e in res.events if e.kind == "dead zone"]
    assert len(zones) == 1
    e_in, e_out = _edges()
    assert abs(zones[0].edge_in - e_in) < 1e-9
    assert abs(zones[0].edge_out - e_out) < 1e-9


def test_limit_positions_reach_the_dead_zones_edge():
    res = ms.solve(ms.loads(DZ))
    lps = res.limit_positions()
    assert [lp.name for lp in lps] == ["rocker"]
    lp = lps[0]
    th, psi = _in_line()
    assert abs(lp.low - psi) < 1e-9 and _on_turn(lp.u_low, th) < 1e-7
    # the largest angle is at the edge where the loop closes again: B on A O4
    _, e_out = _edges()
    high = math.atan2(A * math.sin(e_out), A * math.cos(e_out) - D) % (2 * math.pi)
    assert abs(lp.high - high) < 1e-7, (math.degrees(lp.high), math.degrees(high))
    assert _on_turn(lp.u_high, e_out) < 1e-9
    assert math.degrees(high) > 180.0  # beyond every sample's angle
    assert lp.high > np.nanmax(res.link("rocker").angle)
    # over the samples the closed form gives no larger swing
    grid = np.radians(np.arange(2.5, 362.5, 0.01))
    closes = [t for t in grid if _on_turn(t, math.pi) > math.pi - _edges()[0]]
    vals = np.unwrap([_rocker(t) for t in closes])
    assert lp.low <= vals.min() + 1e-12
    assert lp.time_ratio is None  # the motion is not continuous over the turn


def test_the_transmission_minimum_is_at_the_edge_not_where_the_loop_cannot_close():
    res = ms.solve(ms.loads(DZ))
    (tr,) = res.transmission_angles()
    assert tr.angle == 0.0
    e_in, e_out = _edges()
    assert min(_on_turn(tr.u, e_in), _on_turn(tr.u, e_out)) < 1e-9, math.degrees(tr.u)
    # and the loop closes there: |O4 A| = b + c to rounding
    ax, ay = A * math.cos(tr.u), A * math.sin(tr.u)
    assert math.hypot(D - ax, ay) <= B + C + 1e-9


def test_work_and_mean_are_not_given_as_exact_across_a_dead_zone():
    res = ms.solve(ms.loads(DZ))
    assert math.isnan(res.work())
    why = res._work_why()[1]
    assert "cannot close between" in why and "dead zone" in why, why
    mean, what = res.mean_effort()
    assert what != "mean"  # the exact mean over the travel: not defined
    # next to the edge the kinetic energy (the rocker's rate per unit crank angle from
    # the closed form grows as 1 / sqrt(distance)) has no bound: the work has none either
    e_in, _ = _edges()
    rates = []
    for dist in (1e-4, 1e-6, 1e-8):
        t, h = e_in - dist, 1e-3 * dist
        rates.append(abs(_rocker(t + h) - _rocker(t - h)) / (2 * h))
    assert rates[1] > 5 * rates[0] and rates[2] > 5 * rates[1]


def test_the_command_line_says_so_too(tmp_path):
    f = tmp_path / "dz.yaml"
    f.write_text(DZ, encoding="utf-8")
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "out"), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert "work of the driver per cycle: not defined" in r.output, r.output
    assert "work of the driver per cycle: 0 J" not in r.output
    assert ", mean 0 " not in r.output
    assert "limit positions: rocker rocker 66.4235" in r.output, r.output


# -- a sweep at rest (speed 0, quasi-static) ---------------------------------------------

FA, FB, FC, FD = 26.5, 105.6, 59.0, 87.5  # the docs' four-bar crank-rocker (mm)

AT_REST = f"""
name: four-bar at rest
units: {{length: mm, angle: deg}}
ground: {{O2: [0, 0], O4: [{FD}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{FA}, 0]}}, mass: 0.05 kg, uniform_bar: [O2, A]}}
  coupler: {{points: {{A: [0, 0], B: [{FB}, 0]}}, mass: 0.2 kg, uniform_bar: [A, B]}}
  rocker: {{points: {{O4: [0, 0], B: [{FC}, 0]}}, mass: 0.11 kg, uniform_bar: [O4, B]}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: [B left of A -> O4]
driver: {{joint: O2, speed: SPEED, start: 0 deg}}
sweep: {{range: 360 deg, step: 2 deg}}
gravity: 9.81 m/s^2
"""


def _toggle(r: float) -> tuple[float, float]:
    """(crank angle, rocker angle) where |O2 B| = r (crank and coupler in line), B above."""
    x = (r * r - FC * FC + FD * FD) / (2 * FD)
    y = math.sqrt(r * r - x * x)
    return math.atan2(y, x), math.atan2(y, x - FD)


def test_a_sweep_at_rest_has_the_geometrys_limit_positions():
    th_ext, psi_ext = _toggle(FA + FB)  # extended: the rocker's smallest angle
    th_fold, psi_fold = _toggle(FB - FA)  # folded: its largest; the crank points away
    th_fold += math.pi
    for speed in ("0 rad/s", "1 rad/s"):
        res = ms.solve(ms.loads(AT_REST.replace("SPEED", speed)))
        (lp,) = res.limit_positions()
        assert lp.name == "rocker"
        assert abs(lp.low - psi_ext) < 1e-9 and _on_turn(lp.u_low, th_ext) < 1e-7, speed
        assert abs(lp.high - psi_fold) < 1e-9 and _on_turn(lp.u_high, th_fold) < 1e-7, speed
        fwd = (th_fold - th_ext) % (2 * math.pi)
        assert abs(lp.time_ratio - fwd / (2 * math.pi - fwd)) < 1e-7, speed


def test_the_command_line_gives_them_at_rest_too(tmp_path):
    f = tmp_path / "rest.yaml"
    f.write_text(AT_REST.replace("SPEED", "0 rad/s"), encoding="utf-8")
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "out"), "--no-plots"])
    assert r.exit_code == 0, r.output
    psi = math.degrees(_toggle(FA + FB)[1])
    assert f"limit positions: rocker rocker {psi:.5g}°" in r.output, r.output


# -- the driver's travel: the distance travelled ------------------------------------------

OSCILLATING = AT_REST.replace(
    "driver: {joint: O2, speed: SPEED, start: 0 deg}\nsweep: {range: 360 deg, step: 2 deg}",
    'driver: {joint: O2, motion: {law: "0.5 * sin(2 * t)"}}\n'
    "sweep: {duration: 3 s, time_step: 0.1 s}",
)


def _travelled(t: float) -> float:
    """The distance (rad) the law 0.5 sin(2 t) has travelled by time t <= 3 s: it turns
    back at pi/4 (u = 0.5) and 3 pi/4 (u = -0.5)."""
    s = 0.5 * math.sin(2 * t)
    if t <= math.pi / 4:
        return s
    if t <= 3 * math.pi / 4:
        return 1.0 - s
    return 2.0 + s


def test_the_travel_of_a_motion_that_turns_back_is_the_distance_travelled(tmp_path):
    assert "motion:" in OSCILLATING
    res = ms.solve(ms.loads(OSCILLATING))
    t = np.asarray(res.t, float)
    assert len(t) == 31 and abs(t[-1] - 3.0) < 1e-12
    expected = np.degrees([_travelled(x) for x in t])
    travel = np.asarray(res.driver_travel)
    assert np.max(np.abs(travel - expected)) < 1e-9, travel - expected
    assert np.all(np.diff(travel) > 0)
    # the CSV's input.travel column is the same (deg)
    path = res.to_csv(tmp_path / "osc.csv")
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines() if ln and ln[0] != "#"]
    head = lines[0].split(",")
    col = head.index("input.travel [deg]")
    got = np.array([float(ln.split(",")[col]) for ln in lines[1:]])
    assert np.max(np.abs(got - expected)) < 1e-6


def test_the_travel_of_a_sweep_one_way_is_its_distance_from_the_start():
    res = ms.solve(ms.loads(AT_REST.replace("SPEED", "-1 rad/s")))  # clockwise
    k = np.arange(len(res.u))
    assert np.max(np.abs(np.asarray(res.driver_travel) - 2.0 * k)) < 1e-9
