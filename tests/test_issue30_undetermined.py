"""Figures that are not determined where a sweep puts them (issue 30, review 7): the mean
driving torque of a motion law that returns to its start, the velocities next to a
change-point toggle, the peak of a reaction that grows without bound at a toggle, and
expressions that are not finite (division by zero)."""

from __future__ import annotations

import math

import numpy as np
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.cli.main import main

# J0(1) = (1 / 2 pi) * integral of cos(sin t) dt over a period (Abramowitz & Stegun 9.1.18)
BESSEL_J0_1 = 0.7651976865579666

PENDULUM = """
name: pendulum
units: {length: mm, angle: rad}
ground: {O: [0, 0]}
links:
  arm:
    points: {O: [0, 0], A: [200, 0]}
    mass: 2 kg
    com: [200, 0]
    inertia: 0.01 kg*m^2
joints:
  O: [ground, arm]
driver: {joint: O, motion: {law: "sin(t)"}}
sweep: {duration: 6.283185307179586 s, steps: 360}
gravity: 9.81 m/s^2
"""


def test_mean_torque_of_a_law_that_returns_to_its_start_is_the_time_mean(tmp_path):
    """An arm (mass m, centre at r) swung by u = sin(t) over one period: the driving torque
    is T = J u'' + m g r cos u, whose mean over time is m g r J0(1) (the mean of u'' over a
    period is zero). The travel is sin(2 pi) = -2.4e-16 rad: the work over it was printed
    as the mean (0, or 1e17 with a load)."""
    res = ms.solve(ms.loads(PENDULUM))
    mean, what = res.mean_effort()
    assert what == "time mean"
    expect = 2.0 * 9.81 * 0.2 * BESSEL_J0_1  # N m
    assert math.isclose(mean, expect, rel_tol=1e-9)
    e = res.driving_effort
    assert np.nanmin(e) <= mean <= np.nanmax(e)
    text = res.summary()
    assert f"time mean {expect:.6g} N·m" in text
    # the report's table says the same
    f = tmp_path / "pend.yaml"
    f.write_text(PENDULUM)
    out = CliRunner().invoke(main, ["report", str(f), "-o", str(tmp_path / "r.html")])
    assert out.exit_code == 0, out.output
    html = (tmp_path / "r.html").read_text()
    assert "time mean driving torque" in html and f"{expect * 1e3:.6g}" in html


def test_mean_torque_of_a_one_way_law_is_still_the_work_over_the_travel():
    """A law that goes one way keeps the mean over the travel, W / travel: for the arm
    turned by u = t over one turn at a steady speed, m g r times the mean of cos u = 0,
    and the work is zero."""
    text = PENDULUM.replace('"sin(t)"', '"t"')
    res = ms.solve(ms.loads(text))
    mean, what = res.mean_effort()
    assert what == "mean"
    assert abs(mean) < 1e-9
