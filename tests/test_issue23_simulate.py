"""Issue 23, `mechsolve simulate`: what a run says and keeps when the machine stalls, runs
backwards, leaves the range where it closes, meets a motor law that is not finite, or is
asked for more steps than it can hold. Checked against static torque balance, the
closed-form run-up of a disc, and the geometry of where a four-bar closes."""

from __future__ import annotations

import csv
import math
import re

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve.cli import main

# a uniform bar 0.8 m, 3 kg, pivoted at one end: J = m l^2 / 3 = 0.64 kg m^2, gravity's
# moment m g (l / 2) cos(phi) = 11.772 cos(phi) N m
BAR = """
name: bar on a motor
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], A: [0.8, 0]}, mass: 3 kg, uniform_bar: [O, A]}
joints: {O: [ground, bar]}
driver: {joint: O, start: 0 deg}
GRAVITY
MOTOR
simulate: {duration: DURATION, step: 0.002 s, method: METHOD, from: rest}
"""
M_GRAVITY = 3 * 9.81 * 0.4


def bar(motor: str, gravity: str = "gravity: 9.81 m/s^2", duration="6 s", method="rk4"):
    return (
        BAR.replace("GRAVITY", gravity)
        .replace("MOTOR", f"motor: {motor}")
        .replace("DURATION", duration)
        .replace("METHOD", method)
    )


# a non-Grashof four-bar (crank a = 0.6, coupler b = 0.6, rocker c = 0.5, frame d = 1):
# the loop closes while |A O4| <= b + c, i.e. cos(phi) >= 0.125, phi <= 82.8192 deg; the
# motor drives the crank into that limit
NON_GRASHOF = """
name: non-Grashof four-bar on a motor
ground: {O2: [0, 0], O4: [1.0, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.6, 0]}, mass: 1 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [0.6, 0]}, mass: 1 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [0.5, 0]}, mass: 1 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 0 deg}
gravity: off
motor: {stall: 5 N m, slope: 0 N m s}
simulate: {duration: 2 s, step: 0.01 s, method: METHOD, from: rest}
"""
CLOSES_UP_TO = math.degrees(math.acos(0.125))  # 82.8192 deg


def run_cli(tmp_path, text: str, *args: str, name="m.yaml"):
    f = tmp_path / name
    f.write_text(text)
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(out), *args])
    return r, out


def read_csv(path, *columns: str) -> list[np.ndarray]:
    """The named columns of a CSV as float arrays (blank: nan)."""
    with open(path, newline="") as fh:
        rows = [r for r in csv.reader(fh) if r and not r[0].startswith("#")]
    head = rows[0]
    return [np.array([float(r[head.index(c)] or "nan") for r in rows[1:]]) for c in columns]


# -- 2.1: a motion that leaves the closing range keeps what was computed, every method -------


@pytest.mark.parametrize("method", ["rk4", "RK45", "LSODA", "DOP853", "Radau"])
def test_leaving_the_closing_range_writes_the_computed_part(tmp_path, method):
    """Exit 1 (completed with warnings, as `run` when positions cannot be solved: the
    mechanism reaching where it cannot close is a finding of the run, not bad input), the
    CSV and the plots hold the motion up to there, and the message says so and where."""
    r, out = run_cli(tmp_path, NON_GRASHOF.replace("METHOD", method))
    assert r.exit_code == 1, r.output
    assert "Traceback" not in r.output
    names = sorted(p.name for p in out.iterdir())
    assert any(n.endswith(".csv") for n in names) and any(n.endswith(".png") for n in names)
    csv_file = next(p for p in out.iterdir() if p.suffix == ".csv")
    t, angle = read_csv(csv_file, "t [s]", "input.angle [deg]")
    assert len(t) > 10 and np.all(np.diff(t) > 0) and t[-1] < 2.0
    # every row written closes: before the geometric limit, and the motion got near it
    assert np.all(angle <= CLOSES_UP_TO + 1e-9)
    assert angle[-1] > CLOSES_UP_TO - 3.0
    text = " ".join(r.output.split())
    assert "left the range where the mechanism closes" in text
    m = re.search(r"near driver angle ([\d.]+)°", text)
    assert m and abs(float(m.group(1)) - CLOSES_UP_TO) < 1.0, text
    assert f"stopped early at t = {t[-1]:.6g} s" in text, text
    assert f"wrote {len(names)} file(s) with the motion up to t = {t[-1]:.6g} s" in text, text
    assert "stopped stopped" not in text
