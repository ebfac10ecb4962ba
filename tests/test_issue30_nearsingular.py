"""A crank-rocker a hair off its change point is not singular: its values at the nearest
pose are determined and printed, and its reactions have a peak. The rocker 1 um longer
than the change point's (transmission angle 0.0148 deg at 180 deg) had its point
accelerations, torque and reactions blanked at 180 deg, and the summary said they grow
without bound; 0.2 um longer (0.209 deg) the summary said so too. Checked
against the closed form in extended precision and the law of cosines."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms

TEXT = """
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [100, 0]}
links:
  crank: {points: {O2: [0, 0], A: [20, 0]}, mass: 0.05 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [60, 0]}, mass: 0.2 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [ROCKER, 0]}, mass: 0.11 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 10 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 1 deg}
gravity: 9.81 m/s^2
"""


def _b(th: np.longdouble, c: np.longdouble) -> tuple:
    """B of the four-bar (mm) on the branch left of A -> O4, in extended precision."""
    a, b, d = np.longdouble(20), np.longdouble(60), np.longdouble(100)
    ax, ay = a * np.cos(th), a * np.sin(th)
    ex, ey = d - ax, -ay
    r = np.hypot(ex, ey)
    f = (b * b - c * c + r * r) / (2 * r)
    h = np.sqrt(b * b - f * f)
    return ax + (f * ex - h * ey) / r, ay + (f * ey + h * ex) / r


def test_values_next_to_a_change_point_are_printed_and_right():
    c = "60.000001"
    res = ms.solve(ms.loads(TEXT.replace("ROCKER", c)))
    i = int(np.argmin(np.abs(res.u - math.pi)))
    assert res.u[i] == pytest.approx(math.pi)
    B = res.point("B")
    cc, th = np.longdouble(c), np.longdouble(math.pi)

    def second(h):  # d2(B.y)/dth2 by the central difference, mm/rad^2
        ys = [_b(th + k * h, cc)[1] for k in (-1, 0, 1)]
        return (ys[0] - 2 * ys[1] + ys[2]) / (h * h)

    h = np.longdouble("1e-6")
    d2 = (4 * second(h) - second(2 * h)) / 3  # Richardson: the h^2 term cancelled
    ay = float(d2) * 100.0 * 1e-3  # w = 10 rad/s, in m/s^2
    assert np.isfinite(B.ax[i]) and np.isfinite(B.ay[i])  # (blank before)
    assert B.ay[i] == pytest.approx(ay, rel=1e-5)
    assert np.isfinite(res.driving_effort[i])
    assert i not in list(res.solution.rates_undetermined)
    assert "without bound" not in res.summary()


@pytest.mark.parametrize("c", ["60.0002", "60.000001"])
def test_a_sharp_bounded_peak_is_not_called_unbounded(c):
    res = ms.solve(ms.loads(TEXT.replace("ROCKER", c)))
    # the smallest transmission angle, at 180 deg, by the law of cosines: not zero
    cc = float(c)
    mu = math.degrees(math.acos((60**2 + cc**2 - 120**2) / (2 * 60 * cc)))
    mu = min(mu, 180 - mu)
    assert 0 < mu < 0.25
    text = res.summary()
    assert "without bound" not in text
    peak = max(float(np.nanmax(res.reaction(j)["F"])) for j in ("O2", "A", "B", "O4"))
    assert f"{peak:.4g} N at driver angle 180°" in text
