"""stroke(q) over a motion law that turns back between its time samples: the positions it
visits reach the law's turning points, which the samples fall short of. u = 2 sin t swings
the slider-crank's crank to -2 rad, where C.x = r cos u + sqrt(l^2 - (e - r sin u)^2)
(closed form); the extremes were the samples' range (3.5e-5 off at 0.05 s)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import mechsolve as ms

R, L, E = 0.05, 0.2, 0.01  # mechanisms/slider-crank.yaml in SI
TEXT = (Path(__file__).resolve().parents[1] / "mechanisms" / "slider-crank.yaml").read_text()
OLD = "driver: {joint: O, speed: 1500 rpm, start: 0 deg}\nsweep: {range: 360 deg, step: 5 deg}\n"


def _cx(th: float) -> float:
    return R * math.cos(th) + math.sqrt(L * L - (E - R * math.sin(th)) ** 2)


@pytest.mark.parametrize("dt", [0.05, 0.013])
def test_extremes_reach_the_laws_turning_points(dt):
    assert OLD in TEXT
    law = (
        'driver: {joint: O, motion: {law: "2 * sin(t)"}}\n'
        f"sweep: {{duration: 6 s, time_step: {dt} s}}\n"
    )
    r = ms.solve(ms.loads(TEXT.replace(OLD, law)), forces=True)
    lo, hi = r.forces.stroke_extremes[0]
    assert lo == pytest.approx(_cx(-2.0), abs=1e-12)  # the crank's swing to -2 rad
    assert hi == pytest.approx(math.sqrt((L + R) ** 2 - E * E), abs=1e-12)  # dead centre
