"""Issue 26: the general path integrates its outputs in stretches of
:data:`~mechsolve.analyses.dynamics.multibody_integrate.CHUNK` (what a failed stage can
cost); a stretch that goes on from where the last one ended, no event between, starts
with the step the integrator would have taken next. So a run in stretches costs about
what one uninterrupted integration costs (before: each stretch chose a new, small
first step and grew it again: 439 evaluations here against 333)."""

from __future__ import annotations

import mechsolve as ms
from mechsolve.analyses.dynamics import multibody_integrate as integrate_module
from mechsolve.analyses.dynamics import simulate

PENDULUM = """
units: {length: m, angle: deg}
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], P: [1, 0]}, mass: 1 kg, com: P}
joints:
  O: [ground, bar]
driver: {joint: O, start: 30 deg}
gravity: 9.81 m/s^2
simulate: {duration: 3 s, step: 0.005 s, method: DOP853, rtol: 1e-6, atol: 1e-9}
"""


def test_stretches_of_outputs_cost_what_one_integration_costs(monkeypatch):
    chunked = simulate(ms.loads(PENDULUM)).trajectory
    monkeypatch.setattr(integrate_module, "CHUNK", 10**6)
    whole = simulate(ms.loads(PENDULUM)).trajectory
    assert len(chunked.t) == len(whole.t) == 601
    stretches = 600 // 50  # of CHUNK = 50 outputs
    # at most the start's two evaluations (f(t0) and the first step's choice) more per
    # stretch; the motion itself is the same to the tolerance
    assert chunked.nfev <= whole.nfev + 2 * stretches
    assert abs(chunked.q - whole.q).max() < 1e-4  # rad: rtol 1e-6 over 3 s
