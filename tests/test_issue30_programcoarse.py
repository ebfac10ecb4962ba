"""A recognised plan sampled more coarsely than the branch analysis's grid whose first or
last sample sits at a change point or a toggle: the rates there are their limits along
the motion (or undetermined), as the vector loop's closed form gives them next to it,
never the 0/0 of the dyad's formulas (the program answered -4 rad/s and 2.4e16 rad/s)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms


def _text(a, b, c, d, rng, step):
    return f"""
ground: {{O2: [0, 0], O4: [{d!r}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a!r}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b!r}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c!r}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 2 rad/s, start: 0 deg}}
sweep: {{range: {rng!r} deg, step: {step!r} deg}}
"""


def _vector_loop(a, b, c, d, th2, s):
    """The rocker's angle and rate (w2 = 2 rad/s) on branch ``s``, by the vector loop."""
    ax, ay = a * math.cos(th2), a * math.sin(th2)
    dx, dy = d - ax, -ay
    r = math.hypot(dx, dy)
    x = (b * b - c * c + r * r) / (2 * r)
    h = math.sqrt(max(b * b - x * x, 0.0))
    bx, by = ax + (x * dx - s * h * dy) / r, ay + (x * dy + s * h * dx) / r
    th3, th4 = math.atan2(by - ay, bx - ax), math.atan2(by, bx - d)
    return th4, 2.0 * a * math.sin(th2 - th3) / (c * math.sin(th4 - th3))


@pytest.mark.parametrize(
    "links, step, i",
    [((0.2, 0.5, 0.4, 0.3), 30.0, 0), ((0.25, 0.75, 0.5, 1.0), 10.0, -1)],
    ids=["folded at the first sample", "extended at the last sample"],
)
def test_change_point_at_an_end_sample_of_a_coarse_sweep(links, step, i):
    a, b, c, d = links
    res = ms.solve(ms.loads(_text(a, b, c, d, 180.0, step)))
    u = float(res.u[i])
    k = 1 if i == 0 else -2  # the branch the sweep follows next to the end sample
    near = float(res.link("rocker").angle[k])

    def gap(s):
        return abs(
            math.remainder(_vector_loop(a, b, c, d, float(res.u[k]), s)[0] - near, 2 * math.pi)
        )

    s = min((1, -1), key=gap)
    w = _vector_loop(a, b, c, d, u + math.copysign(1e-4, 1 if i == 0 else -1), s)[1]
    got = float(res.link("rocker").omega[i])
    assert got == pytest.approx(w, rel=1e-6)
    assert abs(float(res.link("rocker").alpha[i])) < 1e-3  # (2e9 rad/s^2 before)
    assert (i % len(res.u)) in list(res.solution.rates_by_limit)


def test_a_coarse_sweep_ending_next_to_a_toggle_has_undetermined_rates_there():
    a, b, c, d = 0.05, 0.06, 0.04, 0.08  # non-Grashof: the dyad toggles at th_e
    th_e = math.degrees(math.acos((a * a + d * d - (b + c) ** 2) / (2 * a * d)))
    res = ms.solve(ms.loads(_text(a, b, c, d, th_e - 1e-11, (th_e - 1e-11) / 10)))
    assert np.isnan(res.link("rocker").omega[-1])  # (2.6e6 rad/s, unflagged, before)
    assert list(res.solution.rates_undetermined) == [len(res.u) - 1]
