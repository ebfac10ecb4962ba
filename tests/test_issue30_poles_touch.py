"""Poles of a law that touch zero between two samples without a change of sign.

``t + 1/(t^2 - 2.1 t + 1.1025)`` (that is ``1/(t - 1.05)^2`` expanded) sampled every
0.1 s is finite at every sample, and neither its denominator nor any part of it changes
sign, so a search for sign changes alone let the driver jump through infinity between
1.0 and 1.1 s (exit 0); so did ``1/(1 + cos(t))`` at pi. The denominator's smallest
magnitude between the samples is now located and the law beside it grows without
bound: refused, at t = 1.05 s. A denominator that dips but stays away from zero
(``t^2 - 2.1 t + 1.1125``: the law is bounded by 100) is kept.
"""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main
from mechsolve.model.expr import Expression
from mechsolve.model.expr.poles import first_pole

FOURBAR = """name: fourbar
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, motion: {law: "LAW"}}
sweep: {duration: 2 s, steps: 20}
"""

T = np.linspace(0.0, 2.0, 21)  # the samples of the sweep above: every 0.1 s


@pytest.mark.parametrize(
    "law",
    [
        ("t + 1/(t^2 - 2.1 * t + 1.1025)", T, 1.05),
        ("t + 0.01/(1 + cos(t))", np.linspace(0.0, 4.0, 41), np.pi),
        ("t + 1/(t - 1.05)^2", T, 1.05),  # (found before too: t - 1.05 changes sign)
    ],
)
def test_even_order_pole_between_samples_is_found(law):
    text, x, pole = law
    z = first_pole(Expression(text, ["t"]), "t", x)
    assert z == pytest.approx(pole, abs=1e-6)


@pytest.mark.parametrize(
    "law",
    [
        "t + 1/(t^2 - 2.1 * t + 1.1125)",  # bounded by 100: a dip, not a pole
        "t + 1/(2 + sin(6 * t))",  # oscillates, never below 1
        "t + sin(t - 1.05)^2 / (t - 1.05)^2",  # removable: 1 at t = 1.05
        "t + 1/(1 + t^2)",
    ],
)
def test_bounded_dips_are_not_poles(law):
    assert first_pole(Expression(law, ["t"]), "t", T) is None


def test_run_refuses_a_law_that_touches_a_pole(tmp_path):
    f = tmp_path / "m.yaml"
    f.write_text(FOURBAR.replace("LAW", "0.5 * t + 0.001/(t^2 - 2.1 * t + 1.1025)"))
    out = CliRunner().invoke(main, ["run", "--no-plots", str(f), "-o", str(tmp_path / "o")])
    assert out.exit_code == 2, out.output
    assert "driver.motion.law:" in out.output and "t = 1.05 s" in out.output
    assert "Traceback" not in out.output
    f.write_text(FOURBAR.replace("LAW", "0.5 * t + 0.001/(t^2 - 2.1 * t + 1.1125)"))
    ok = CliRunner().invoke(main, ["run", "--no-plots", str(f), "-o", str(tmp_path / "o")])
    assert ok.exit_code == 0, ok.output
