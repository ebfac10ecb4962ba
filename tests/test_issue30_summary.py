"""Issue 30 (review 3): the summary, report and requirements name positions that are
unambiguous on sweeps longer than one turn, a motion law's stroke() extremes refined in
the driver's travel, sweep -p naming a parameter twice, and the small wording items."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import mechsolve as ms

MECH = Path(__file__).parents[1] / "mechanisms"


# -- a motion law's stroke() extremes ---------------------------------------------------
LAW = """
driver:
  joint: O
  direction: ccw
  start: 0 deg
  motion:
    from: 0 rpm
    segments:
      - {accelerate: 0.5 s, to: 60 rpm}
      - {run: 1 s}
      - {decelerate: 0.5 s}
      - {dwell: 0.5 s}
sweep: {duration: 2.5 s, time_step: STEP}
"""


def _law_run(step: str = "0.05 s"):
    """mechanisms/slider-crank.yaml driven by :data:`LAW` at time steps ``step``."""
    y = (MECH / "slider-crank.yaml").read_text()
    head, _, rest = y.partition("driver:")
    rest = rest.split("\n", 2)[2]
    return ms.solve(ms.loads(head + LAW.replace("STEP", step).lstrip("\n") + rest))


@pytest.mark.parametrize("step", ["0.05 s", "0.0125 s"])
def test_motion_law_stroke_extremes_and_work_do_not_depend_on_the_step(step):
    """The slider-crank driven from rest through 540° (accelerate, run, decelerate,
    dwell) with the gas load of mechanisms/slider-crank.yaml (-1500 N on the piston while
    it moves back and stroke(C.x) > 0.3): the extremes of C.x are those of the offset
    slider-crank, sqrt((l -+ r)^2 - e^2), and, starting and ending at rest at the same
    height of every centre of mass (crank at 0° and 180°: on the line of the pivot and
    the piston), the driver's work is minus the gas's, -2 * 1500 N * 0.7 * stroke: the
    gas acts twice over 70% of the stroke (before: -210.257 J at 0.05 s, extremes read
    off the time samples)."""
    res = _law_run(step)
    r, l, e = 0.05, 0.2, 0.01
    smin, smax = math.sqrt((l - r) ** 2 - e**2), math.sqrt((l + r) ** 2 - e**2)
    ((lo, hi),) = res.forces.stroke_extremes
    assert lo == pytest.approx(smin, abs=1e-12) and hi == pytest.approx(smax, abs=1e-12)
    assert res.work() == pytest.approx(-2 * 1500 * 0.7 * (smax - smin), rel=1e-9)
