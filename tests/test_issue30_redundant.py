"""Review 6 (items 1, 3, 4): a redundant link passing a singular position on the general
multibody path, and the refusal of inconsistent ``simulate.rates``; against closed forms
(the four-bar's velocity analysis, the parallelogram's single-pendulum equation) and the
conservation of energy."""

from __future__ import annotations

import math
import re

import numpy as np
from click.testing import CliRunner

from mechsolve import loads
from mechsolve.analyses.dynamics import simulate
from mechsolve.cli.main import main

# a crank-rocker four-bar released with the crank's rate given by `from` and a rocker rate
# that the mechanism does not allow
FOURBAR = """
units: {length: m, angle: deg}
ground: {O2: [0, 0], O4: [0.8, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.25, 0]}, mass: 1, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [0.9, 0]}, mass: 3, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [0.6, 0]}, mass: 2, uniform_bar: [O4, B]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 40 deg}
gravity: 9.81 m/s^2
simulate: {duration: 0.1 s, step: 0.05 s, method: DOP853, rtol: 1e-10, atol: 1e-12,
           from: 3 rad/s, rates: {O4: %s rad/s}}
"""


def _invoke(tmp_path, text: str, *extra: str):
    f = tmp_path / "m.yaml"
    f.write_text(text)
    return CliRunner().invoke(
        main, ["simulate", str(f), "-o", str(tmp_path / "o"), "--no-plots", *extra]
    )


def _rocker_rate(a=0.25, b=0.9, c=0.6, d=0.8, th2_deg=40.0, w2=3.0) -> float:
    """The rocker's rate from the crank's by the velocity analysis by hand: B where the
    circles about A (radius b) and O4 (radius c) meet, on the left of A -> O4, then
    ``w2 x AO2 + w3 x AB = w4 x O4B`` for (w3, w4)."""
    th2 = math.radians(th2_deg)
    A = np.array([a * math.cos(th2), a * math.sin(th2)])
    O4 = np.array([d, 0.0])
    e = O4 - A
    L = math.hypot(*e)
    x = (b * b - c * c + L * L) / (2 * L)
    h = math.sqrt(b * b - x * x)
    u = e / L
    n = np.array([-u[1], u[0]])  # left of A -> O4
    B = A + x * u + h * n
    AB, O4B = B - A, B - O4
    vA = w2 * np.array([-A[1], A[0]])
    # vA + w3 k x AB = w4 k x O4B
    K = np.array([[-AB[1], O4B[1]], [AB[0], -O4B[0]]])
    w3, w4 = np.linalg.solve(K, -vA)
    return float(w4)


def test_refused_rates_suggest_the_rate_that_is_accepted(tmp_path):
    """Item 3: the refusal keeps the driver's ``from`` as given and suggests the rocker's
    rate of the velocity analysis with it; that value, put in the file, runs."""
    want = _rocker_rate()
    r = _invoke(tmp_path, FOURBAR % "5")
    assert r.exit_code == 2, r.output
    m = re.search(r"O4's rate 5 rad/s would have to be (\S+) rad/s with the driver's", r.output)
    assert m, r.output
    suggested = float(m.group(1))
    assert abs(suggested - want) <= 1e-9 * abs(want), (suggested, want)
    ok = _invoke(tmp_path, FOURBAR % m.group(1))
    assert ok.exit_code == 0, ok.output
    # and the value written to 6 significant digits is accepted, the crank keeping its
    # `from` (to rounding) and the rocker starting at the consistent rate
    res = simulate(loads(FOURBAR % f"{want:.6g}"))
    assert abs(res.trajectory.ud[0] - 3.0) <= 1e-14
    assert abs(res.link("rocker").omega[0] - want) <= 1e-12
