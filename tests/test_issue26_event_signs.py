"""Issue 26: the conditioning event (Phi_d's reciprocal condition falling below 0.1 of
its value at the partition's choice) is seen at a step's end from the step's last
evaluation and located by root finding on fresh closures; where the two disagree about
its sign (next to the threshold: the closures differ within the constraint tolerance)
the root finder had no bracket and the run stopped with a Python ValueError ('f(a) and
f(b) must have different signs'; seen on the N-four-bar with RK45 at rtol 3e-5). Now
that output step is bridged, as where no partition closes. Forced here by making
every fresh closure report a healthy condition."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

import mechsolve as ms
from mechsolve.analyses.dynamics import multibody_integrate as integrate_module
from mechsolve.analyses.dynamics import simulate

from conftest import MECH


def test_an_event_without_a_bracket_is_bridged_not_a_crash(monkeypatch):
    monkeypatch.setattr(integrate_module, "_lu", lambda A: (None, 1.0))
    mech = ms.load(MECH / "nfourbar-2.yaml")
    mech.simulation.duration = 2.0
    mech.simulation.rtol, mech.simulation.atol = 1e-6, 1e-9
    res = simulate(mech)
    tr = res.trajectory
    assert tr.t[-1] == 2.0 and not tr.early and tr.bridges >= 1
    # B0 on the closed form (one pendulum, N = 2: I = 3, M_g = 3.5 g)
    ref = solve_ivp(
        lambda _, y: [y[1], -9.81 * 3.5 / 3.0 * np.cos(y[0])],
        (0, 2.0),
        [np.pi / 2, -1.0],
        t_eval=tr.t,
        rtol=1e-12,
        atol=1e-12,
    ).y[0]
    b0 = res.point("B0")
    assert np.max(np.hypot(b0.x - np.cos(ref), b0.y - np.sin(ref))) < 1e-3
