"""Issue 26: a bridge across a singular position (RK4 on all coordinates, the
accelerations by least squares on every equation) is projected back onto the
constraints after every RK4 step, not only at its end: the stages' departure from the
constraints is what the least squares amplify next to the singular position. Checked by
the energy of the free N-four-bar (N = 1, conservative: T + V constant) over bridges of
13 lengths across its horizontal position after 2.6 s (the singular position falls at
a different fraction of a step in each). Before: 2 of the 13 within 1e-9 J (up to
2.3e-7 J lost); after: 12 of 13 (the worst 1e-7 J, a stage next to the position)."""

from __future__ import annotations

import numpy as np

import mechsolve as ms
from mechsolve.analyses.dynamics import simulate
from mechsolve.analyses.dynamics.multibody_integrate import _bridge

from conftest import MECH


def test_bridges_keep_the_energy_across_the_singular_position():
    mech = ms.load(MECH / "nfourbar-1.yaml")
    sim = mech.simulation
    sim.duration, sim.rtol, sim.atol = 2.6, 1e-11, 1e-13
    res = simulate(mech)
    tr, mb = res.trajectory, res.multibody
    q0, qd0, t0 = tr.q[-1], tr.qd[-1], tr.t[-1]
    E0 = sum(mb.energy(q0, qd0, t0))
    errors = []
    for span in np.linspace(0.03, 0.06, 13):
        q, qd, W = _bridge(mb, t0, t0 + span, q0, qd0, 0.0, 32)
        assert np.max(np.abs(mb.residual(q, t0 + span))) <= mb.tol
        errors.append(abs(sum(mb.energy(q, qd, t0 + span)) - W - E0))
    assert W == 0.0  # no non-conservative force
    assert sum(e <= 1e-9 for e in errors) >= 11, errors
    assert max(errors) <= 2e-7
