"""Issue 26: the general path's cost on the N-four-bar (N = 2, 10 s, about ten singular
passages) at the benchmark's precision: its evaluations of the equations are counted
(the time depends on the machine, the count does not), and B0's position is checked
against the closed form (one pendulum) in the same run, so that fewer evaluations
never buy a wrong motion. Before: 2434 evaluations at rtol 1e-5 (the bridges across
the singular passages 32 RK4 steps per output step at every tolerance)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses.dynamics import simulate
from mechsolve.analyses.dynamics.multibody import Multibody
from mechsolve.analyses.dynamics.multibody_integrate import (
    BRIDGE_FEWEST,
    BRIDGE_SUBSTEPS,
    bridge_substeps,
)

from conftest import MECH, nfourbar_crank_angle


def test_bridge_steps_follow_the_tolerance():
    # RK4's error goes with h^4: a step 1e-3 times looser in rtol allows one 5.6x longer
    assert bridge_substeps("rk4", 1e-3) == BRIDGE_SUBSTEPS
    assert bridge_substeps("DOP853", 1e-8) == BRIDGE_SUBSTEPS
    assert bridge_substeps("DOP853", 1e-10) == BRIDGE_SUBSTEPS
    assert bridge_substeps("DOP853", 1e-7) == math.ceil(32 * 0.1**0.25)  # 18
    assert bridge_substeps("DOP853", 1e-5) == BRIDGE_FEWEST
    assert bridge_substeps("DOP853", 1e-3) == BRIDGE_FEWEST


def test_n_four_bar_at_the_bench_precision_in_fewer_evaluations(monkeypatch):
    # the evaluations on all coordinates (the bridges' only) counted: how many output
    # steps get bridged depends on the last bits of the arithmetic (4 to 6 here), the
    # evaluations per bridged step do not
    free = Multibody.free_accelerations
    calls = []

    def counted(self, *args, **kwargs):
        calls.append(1)
        return free(self, *args, **kwargs)

    monkeypatch.setattr(Multibody, "free_accelerations", counted)
    mech = ms.load(MECH / "nfourbar-2.yaml")
    mech.simulation.rtol, mech.simulation.atol = 1e-5, 1e-8
    res = simulate(mech)
    tr = res.trajectory
    assert tr.t[-1] == pytest.approx(10.0) and not tr.early
    # (it crosses about ten singular passages: bridged on all coordinates where an
    # integrator's step ends next to one, else stepped across)
    th = nfourbar_crank_angle(2, tr.t)
    b0 = res.point("B0")
    assert np.max(np.hypot(b0.x - np.cos(th), b0.y - np.sin(th))) < 1e-3
    # RK4: four evaluations per step, 8 steps per bridged output step (before: 32)
    assert len(calls) == 4 * BRIDGE_FEWEST * tr.bridges
    assert tr.nfev <= 1500  # before: 2434; 1629 before the output rows were closed on
    # arrays and a stretch of outputs went on with the integrator's step
