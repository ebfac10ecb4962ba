"""An instant far from the driver's start (``run --at "theta=9e5 rad"``, ``draw``,
``polygons --at``) is solved within the machine's cycle, in bounded time and memory.

It was reached by following the branch on a grid from the start to it: 9e5 rad took 54 s
and 6 GB. A revolute driver's machine repeats after its cycle (one turn for a linkage, two
for a four-bar that changes branch at a change point), so the travel is reduced modulo the
cycle; what has no cycle is refused beyond a bounded travel.

References written here, independently of mechsolve: the four-bar's positions by the
vector loop (B where the circles about A and O4 meet, on the side the file's assembly
rule names), their rates by central differences of those closed forms, and for the
change-point four-bar (s + l = p + q) the branch it is on after each turn.
"""

from __future__ import annotations

import math
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.analyses.instants import Instant, solve_instants
from mechsolve.base.errors import InputError
from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
FOURBAR = ROOT / "mechanisms" / "fourbar.yaml"
TURN = 2 * math.pi

# a Grashof four-bar with s + l = p + q (20 + 50 = 40 + 30): it passes a change point,
# where its links line up, once a turn and comes back on its other branch: its cycle is
# two turns of the crank
CHANGE_POINT = """\
name: change-point four-bar
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [50, 0]}
links:
  crank: {points: {O2: [0, 0], A: [20, 0]}, mass: 0.05 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [40, 0]}, mass: 0.2 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [30, 0]}, mass: 0.05 kg, uniform_bar: [O4, B]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, speed: 10 rad/s, start: 30 deg}
sweep: {range: 720 deg, step: 2 deg}
gravity: 9.81 m/s^2
"""


def _b(theta: float, o4: float, a: float, b: float, c: float, left: bool) -> np.ndarray:
    """B of the four-bar (ground O2 = 0, O4 = (o4, 0); crank a, coupler b, rocker c) at
    the crank angle ``theta``, where the circles |B - A| = b and |B - O4| = c meet, on the
    left of A -> O4 (``left``) or on its right."""
    pa = a * np.array([math.cos(theta), math.sin(theta)])
    po4 = np.array([o4, 0.0])
    d = po4 - pa
    dist = math.hypot(*d)
    x = (dist * dist + b * b - c * c) / (2 * dist)
    h = math.sqrt(max(b * b - x * x, 0.0))
    n = np.array([-d[1], d[0]]) / dist  # the left normal of A -> O4
    return pa + x * d / dist + (h if left else -h) * n


def _fourbar_b(theta: float) -> np.ndarray:
    """mechanisms/fourbar.yaml (m): O4 = 87.5 mm, crank 26.5, coupler 105.6, rocker 59,
    B left of A -> O4."""
    return _b(theta, 0.0875, 0.0265, 0.1056, 0.059, True)


def _solve(mech, thetas, forces=None):
    return solve_instants(mech, [Instant(float(x), 1.0, 0.0) for x in thetas], forces=forces)


def test_fourbar_far_instant_is_the_closed_form_and_the_near_one():
    mech = ms.load(FOURBAR)
    th = math.radians(30.0)
    far, near = th + 1000 * TURN, th + 3 * TURN
    res = _solve(mech, [far, near, th], forces=True)
    bx, by = res.point("B").x, res.point("B").y
    ref = _fourbar_b(th)
    for k in range(3):
        assert (bx[k], by[k]) == pytest.approx(tuple(ref), abs=1e-11)
    h = 1e-6  # the rates by central differences of the closed form (omega = 1 rad/s)
    vb = (_fourbar_b(th + h) - _fourbar_b(th - h)) / (2 * h)
    assert (res.point("B").vx[0], res.point("B").vy[0]) == pytest.approx(tuple(vb), abs=1e-8)
    for name in ("A", "B", "P"):
        p = res.point(name)
        for q in ("x", "y", "vx", "vy", "ax", "ay"):
            v = getattr(p, q)
            assert v[0] == pytest.approx(v[1], abs=1e-12)
    assert res.driving_effort[0] == pytest.approx(res.driving_effort[1], rel=1e-9, abs=1e-12)
    assert res.u[0] == far  # the position asked is the one reported, with its time
    assert res.t[0] == pytest.approx(1000 * TURN + th, rel=1e-12)


def test_far_instant_needs_little_memory():
    """5000 turns ahead (and behind) of the start: a few MB, not the grid over the travel
    (about 220 MB before; 9e5 rad took 6 GB)."""
    mech = ms.load(FOURBAR)
    th = math.radians(30.0)
    tracemalloc.start()
    try:
        res = _solve(mech, [th + 5000 * TURN, th - 5000 * TURN])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 30e6
    assert (res.point("B").x[0], res.point("B").y[0]) == pytest.approx(
        tuple(_fourbar_b(th)), abs=1e-11
    )
    assert (res.point("B").x[1], res.point("B").y[1]) == pytest.approx(
        tuple(_fourbar_b(th)), abs=1e-11
    )


def test_run_at_9e5_rad(tmp_path):
    r = CliRunner().invoke(
        main, ["run", str(FOURBAR), "--at", "theta=9e5 rad", "--no-plots", "-o", str(tmp_path)]
    )
    assert r.exit_code == 0, r.output
    ref = _fourbar_b(9e5) * 1000  # mm
    lines = {ln.split("[")[0].strip(): ln.split()[-1] for ln in r.output.splitlines() if "[" in ln}
    assert float(lines["B.x"]) == pytest.approx(ref[0], rel=1e-5)
    assert float(lines["B.y"]) == pytest.approx(ref[1], rel=1e-5)


def test_change_point_fourbar_is_on_its_other_branch_after_odd_turns(tmp_path):
    f = tmp_path / "cp.yaml"
    f.write_text(CHANGE_POINT)
    mech = ms.load(f)
    th = math.radians(30.0)
    left = _b(th, 0.05, 0.02, 0.04, 0.03, True)
    right = _b(th, 0.05, 0.02, 0.04, 0.03, False)
    # the sweep over its two turns: at 30 deg + 1 turn it is on the other branch
    sweep = ms.run(f)
    k = int(np.argmin(np.abs(sweep.u - (th + TURN))))
    assert sweep.u[k] == pytest.approx(th + TURN, abs=1e-12)
    assert (sweep.point("B").x[k], sweep.point("B").y[k]) == pytest.approx(tuple(right), abs=1e-9)
    res = _solve(mech, [th + 1000 * TURN, th + 1001 * TURN, th + TURN, th - 1001 * TURN])
    b = np.c_[res.point("B").x, res.point("B").y]
    assert tuple(b[0]) == pytest.approx(tuple(left), abs=1e-9)
    assert tuple(b[1]) == pytest.approx(tuple(right), abs=1e-9)
    assert tuple(b[2]) == pytest.approx(tuple(right), abs=1e-9)
    assert tuple(b[3]) == pytest.approx(tuple(right), abs=1e-9)


def test_machine_without_cycle_is_refused_far_away(monkeypatch):
    """gear-train.yaml's cycle is 3 pinion turns; looked for over 2 turns only it has none:
    an instant within the bounded travel is solved as before, one beyond it refused."""
    from mechsolve.analyses.dynamics import cycle

    mech = ms.load(ROOT / "mechanisms" / "gear-train.yaml")
    near = _solve(mech, [math.radians(30.0) + 10 * TURN], forces=False)
    monkeypatch.setattr(cycle, "MAX_CYCLE_TURNS", 2)
    again = _solve(mech, [math.radians(30.0) + 10 * TURN], forces=False)
    assert again.point("A").x[0] == pytest.approx(near.point("A").x[0], abs=1e-12)
    with pytest.raises(InputError, match=r"no cycle .* up to 10472 rad"):
        _solve(mech, [math.radians(30.0) + 2000 * TURN], forces=False)


def _rotated(p: np.ndarray, centre: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    d = p - centre
    return centre + np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])


def test_draw_and_polygons_angle_on_the_turn_it_names():
    """``--at "400 deg"`` of gear-train.yaml's pinion (20 teeth driving the 60-tooth wheel
    the other way) was drawn at 40 deg, the wheel a third of a turn off: the wheel's pin A
    at 400 deg is its pin at 40 deg turned by -360/3 deg about O2; 40 deg + 3000 pinion
    turns is 40 deg again (1000 wheel turns)."""
    from mechsolve.analyses.polygons.construction import resolve_at
    from mechsolve.core.sweep import Analysis

    mech = ms.load(ROOT / "mechanisms" / "gear-train.yaml")
    an = Analysis(mech)
    at = [resolve_at(an, f"{x} deg") for x in (40, 400, 40 + 3000 * 360)]
    assert at[1].u == pytest.approx(math.radians(400.0), abs=1e-12)
    res = solve_instants(mech, at, forces=False)
    a = np.c_[res.point("A").x, res.point("A").y]
    o2 = np.array([0.160, 0.0])
    assert math.hypot(*(a[0] - o2)) == pytest.approx(0.060, abs=1e-12)
    assert tuple(a[1]) == pytest.approx(tuple(_rotated(a[0], o2, -TURN / 3)), abs=1e-10)
    assert tuple(a[2]) == pytest.approx(tuple(a[0]), abs=1e-10)
    behind = resolve_at(an, "-20 deg")  # behind the start: on the first turn, as before
    assert behind.u == pytest.approx(math.radians(340.0), abs=1e-12)
