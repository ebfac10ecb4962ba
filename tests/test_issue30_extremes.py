"""Issue 30 (review 8): printed figures that are the exact values, not samples: the
report's driving-effort extremes and the summary's point ranges located between the
samples, the report's tooth forces, the polygons' formula for a moving guide's point, and
the animation's traced paths drawn from a fine sweep whatever the number of frames.

Each figure is checked against a closed form written here (the oscillating cylinder, the
shaper's crank, slot and ram, the four-bar's crank circle) or against an independent
search with ``run --at`` (the driving torque at driver values chosen by the test)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import mechsolve as ms
from mechsolve.analyses.polygons import build_polygons

MECH = Path(__file__).parents[1] / "mechanisms"

# -- polygons: an oscillating cylinder (the guide's pivot moves with the crank pin) -------
OSC = """
name: oscillating cylinder
units: {length: mm, angle: deg}
ground:
  O2: [0, 0]
  O4: [200, 30]
links:
  crank: {points: {O2: [0, 0], A: [60, 0]}}
  rod: {points: {A: [0, 0], E: [300, 0], F: [100, 40]}}
  block: {points: {O4: [0, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, rod]
  O4: [ground, block]
  cyl: {slider: [rod, block], point: O4, line: [A, E]}
driver: {joint: O2, speed: 10 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 10 deg}
"""


def _osc_rod_point_at_o4(theta: float, w2: float = 10.0) -> np.ndarray:
    """The acceleration (m/s^2) of the rod's point under O4 at crank angle ``theta``, by
    hand: a_A + alpha3 k x AO4 - omega3^2 AO4, the rod's angle phi = atan2(O4 - A) and
    its rates by a five-point difference in the crank angle (crank at a constant w2)."""
    r, o4 = 0.060, np.array([0.200, 0.030])

    def phi(t: float) -> float:
        a = r * np.array([math.cos(t), math.sin(t)])
        return math.atan2(o4[1] - a[1], o4[0] - a[0])

    h = 1e-3
    f = [phi(theta + k * h) for k in (-2, -1, 0, 1, 2)]
    d1 = (f[0] - 8 * f[1] + 8 * f[3] - f[4]) / (12 * h)
    d2 = (-f[0] + 16 * f[1] - 30 * f[2] + 16 * f[3] - f[4]) / (12 * h * h)
    w3, al3 = d1 * w2, d2 * w2**2
    a_pin = -(w2**2) * r * np.array([math.cos(theta), math.sin(theta)])
    d = o4 - r * np.array([math.cos(theta), math.sin(theta)])
    return a_pin + al3 * np.array([-d[1], d[0]]) - w3**2 * d


def test_polygons_moving_guide_point_formula_names_the_pivot_acceleration(tmp_path):
    """a_O43 (the rod's point under the block's pivot) is a_A + a^n + a^t: the printed
    formula names every term its value sums (it left out a_A: 7056 mm/s^2 by its
    terms against the 4585 printed), and the value is the closed form's."""
    path = tmp_path / "osc.yaml"
    path.write_text(OSC)
    r = build_polygons(ms.load(path), "50 deg")
    a = r.arrow("a_O43")
    ref = _osc_rod_point_at_o4(math.radians(50.0))
    np.testing.assert_allclose(a.vec, ref, rtol=1e-8, atol=1e-9 * np.hypot(*ref))
    assert abs(np.hypot(*ref) * 1e3 - 4585.07) < 0.01  # the reviewer's finite differences
    terms = [t.strip() for t in a.note.removeprefix("=").split("+")]
    assert terms[0] == "a_A", a.note
    total = sum(r.arrow(t).vec for t in terms)
    np.testing.assert_allclose(total, a.vec, rtol=1e-12, atol=1e-12 * np.hypot(*ref))
    assert "a_O43 " in r.text() and "= a_A + a^n_O43A + a^t_O43A" in r.text()
