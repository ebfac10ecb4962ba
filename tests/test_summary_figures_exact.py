"""Figures of the summary computed over the motion, not as plain means of the samples.

The figures sweep has uneven samples (its limit positions and load switches are
inserted), so a figure that is an integral over the motion (the RMS of the driving
torque) must weigh each sample by the travel it stands for. Checked against closed forms
integrated by scipy's quad.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from scipy.integrate import quad

from mechsolve.cli.main import main

DATA = Path(__file__).parent / "data"


def _slider_crank_torque(phi: float) -> float:
    """The driving torque of a massless offset slider-crank (crank 50 mm, rod 180 mm,
    piston line 20 mm above the crank pivot) against a constant 1000 N push on the
    piston towards the crank: by virtual work, T = -F_x dx/dphi."""
    r, rod, e, fx = 0.05, 0.18, 0.02, -1000.0
    s = r * np.sin(phi) - e
    dx = -r * np.sin(phi) - s * r * np.cos(phi) / np.sqrt(rod * rod - s * s)
    return -fx * dx


def test_rms_driving_torque_is_over_the_turn(tmp_path):
    """The slider-crank's limit positions fall between the 1-degree samples and are
    inserted into the figures sweep: the RMS over the turn is still the closed form's
    (the plain mean of the squares was 0.4 % low)."""
    res = CliRunner().invoke(
        main,
        [
            "run",
            str(DATA / "slider_crank_constant_force.yaml"),
            "-o",
            str(tmp_path),
            "--no-plots",
            "--units",
            "SI",
        ],
    )
    assert res.exit_code == 0, res.output
    assert "limit positions" in res.output
    rms = float(re.search(r"RMS ([-\d.e+]+) N·m", res.output).group(1))
    area, _ = quad(lambda p: _slider_crank_torque(p) ** 2, 0, 2 * np.pi, limit=200)
    exact = np.sqrt(area / (2 * np.pi))
    assert abs(rms - exact) <= 2e-5 * exact, (rms, exact)


HELD_CRANK = """
name: held crank
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [200, 0]}, mass: 3 kg, uniform_bar: [O, A]}
joints: {O: [ground, crank]}
driver:
  joint: O
  start: 0 deg
  motion:
    from: 0 rpm
    segments:
      - {dwell: 2 s}
      - {accelerate: 0.5 s, to: 30 rpm}
      - {run: 1 s}
      - {decelerate: 0.5 s}
sweep: {duration: 4 s, time_step: 0.001 s}
gravity: 9.81 m/s^2
"""


def test_rms_of_a_motion_law_is_over_time():
    """A uniform crank (3 kg, 200 mm) held level for 2 s, then turned: the RMS driving
    torque of a sweep in time is over time, so the dwell's m g L / 2 counts (weighted by
    the crank's angle it counted for nothing: 2.16 against 2.59 N m). Reference: the
    closed-form torque I alpha + m g L/2 cos(theta) along the solved motion, integrated
    over time."""
    import mechsolve as ms

    res = ms.solve(ms.loads(HELD_CRANK))
    m, L, g = 3.0, 0.2, 9.81
    t = np.asarray(res.solution.t)
    crank = res.link("crank")
    th, al = crank.angle, crank.alpha
    torque = m * L * L / 3 * al + m * g * L / 2 * np.cos(th)
    exact = np.sqrt(np.trapezoid(torque**2, t) / (t[-1] - t[0]))
    line = next(s for s in res.summary().splitlines() if "RMS" in s)
    rms = float(re.search(r"RMS ([-\d.e+]+) N", line).group(1))
    assert abs(rms - exact) <= 1e-5 * exact, (line, exact)


def test_an_extreme_reached_every_turn_is_named_once_with_the_turns():
    """The motor-driven linkage runs 11 turns in its simulation: each limit position is
    at the same driver angle every turn, said once with the number of turns (it was the
    same text repeated eleven times)."""
    import mechsolve as ms
    from mechsolve.analyses.dynamics import simulate

    res = simulate(ms.load(Path(__file__).parents[1] / "mechanisms" / "motor-linkage.yaml"))
    line = next(s for s in res.summary().splitlines() if "limit positions" in s)
    assert "(in each of " in line and "turns)" in line, line
    assert line.count("at driver angle") == 4, line  # low and high of the rocker and slider
