"""Balancing by least squares: the counterweights that minimise the RMS shaking force
over the turn.

References, independent of the least-squares code: the classic optimum of an in-line
slider-crank (half the reciprocating mass on the crank: the primary force cos th is half
a forward and half a backward rotating vector, and a crank counterweight can only
cancel the forward one), the four-bar's complete balance by the linearly independent
vectors method (the command's other path), and a scan of the partial balances c in
[0, 1] that no least-squares result may beat.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve import api
from mechsolve.cli.main import main

SLIDER = """
name: slider-crank
units: {{length: mm, angle: deg}}
ground: {{O: [0, 0]}}
links:
  crank:
    points: {{O: [0, 0], A: [50, 0], G2: [12, 0]}}
    mass: 1.3 kg
    com: G2
    inertia: 0.002 kg m^2
  rod:
    points: {{A: [0, 0], B: [200, 0], G3: [70, {g3y}]}}
    mass: 0.9 kg
    com: G3
    inertia: 0.004 kg m^2
  piston:
    points: {{B: [0, 0]}}
    mass: 0.6 kg
    com: B
joints:
  O: [ground, crank]
  A: [crank, rod]
  B: [rod, piston]
  cylinder: {{slider: [ground, piston], point: B, line: {{through: [0, {e}], angle: 0}}}}
assembly:
  - B.x > A.x
driver: {{joint: O, speed: 120 rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: 2 deg}}
"""


def rms_force(bal) -> float:
    return bal.after.figures()["RMS force"][0]


def test_inline_slider_crank_optimum_is_half_the_reciprocating_mass():
    mech = ms.loads(SLIDER.format(e=0, g3y=0), file="sc.yaml")
    best = api.balanced(mech, rms=True)
    half = api.balanced(mech, fraction=0.5)
    assert best.balance.fraction == pytest.approx(0.5, abs=1e-9)
    (cw,), (ref,) = best.balance.counterweights, half.balance.counterweights
    assert cw.mr == pytest.approx(ref.mr, rel=1e-9)
    assert math.cos(cw.angle - ref.angle) == pytest.approx(1.0, abs=1e-12)
    assert rms_force(best) == pytest.approx(rms_force(half), rel=1e-9)
    text = "\n".join(best.lines())
    assert "minimise the RMS shaking force" in text and "c = 0.5" in text


@pytest.mark.parametrize("e, g3y", [(15, 0), (0, 12), (-20, 8)])
def test_no_partial_balance_beats_the_least_squares_one(e, g3y):
    """An offset slider-crank, or a rod whose centre is off its pin line: the least-squares
    counterweight leaves no more RMS force than any fraction c of the textbook's family."""
    mech = ms.loads(SLIDER.format(e=e, g3y=g3y), file="sc.yaml")
    best = rms_force(api.balanced(mech, rms=True))
    scan = [rms_force(api.balanced(mech, fraction=c)) for c in np.linspace(0, 1, 11)]
    assert best <= min(scan) * (1 + 1e-12)
    assert best < api.balanced(mech, rms=True).before.figures()["RMS force"][0]


def test_fourbar_least_squares_is_the_complete_balance():
    mech = ms.load("mechanisms/fourbar.yaml")
    lsq = api.balanced(mech, rms=True)
    liv = api.balanced(mech)
    for a, b in zip(lsq.balance.counterweights, liv.balance.counterweights):
        assert a.link == b.link
        assert a.mr == pytest.approx(b.mr, rel=1e-9)
        assert math.cos(a.angle - b.angle) == pytest.approx(1.0, abs=1e-12)
    before = lsq.before.figures()["peak force"][0]
    assert np.nanmax(lsq.after.force) < 1e-12 * before


def test_rms_with_a_fraction_is_refused(tmp_path):
    f = tmp_path / "sc.yaml"
    f.write_text(SLIDER.format(e=0, g3y=0))
    r = CliRunner().invoke(main, ["shaking", str(f), "--rms", "--fraction", "0.3", "--no-plots"])
    assert r.exit_code == 2, r.output
    assert "--rms" in r.output and "Traceback" not in r.output
    r = CliRunner().invoke(
        main, ["shaking", str(f), "--rms", "--no-plots", "-o", str(tmp_path / "out")]
    )
    assert r.exit_code == 0, r.output
    assert (tmp_path / "out" / "sc-balanced.yaml").exists()
