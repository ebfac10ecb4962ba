"""Issue 26: the integrator's right-hand side for mechanisms of pins with their loads on
arrays (:mod:`mechsolve.analyses.dynamics.multibody_lite`: the equations linear in the
bodies' cos and sin, the augmented matrix kept between evaluations) gives what the
general evaluation gives (:meth:`Multibody.close`, :meth:`rates`,
:meth:`accelerations`), at states near the motion of Andrews' mechanism (a torque, a
spring, ten pins), the N-four-bar and the redundant parallelogram (a partition with
fewer equations than the file has); and the loads in Python floats what the general
load machinery gives."""

from __future__ import annotations

import numpy as np
import pytest
from test_issue26_multibody import REDUNDANT

import mechsolve as ms
from mechsolve.analyses.dynamics import simulate
from mechsolve.analyses.dynamics.multibody_integrate import _Run

from conftest import MECH


def _run(name):
    mech = ms.loads(REDUNDANT % "") if name == "redundant" else ms.load(MECH / f"{name}.yaml")
    mech.simulation.duration = 10 * mech.simulation.step
    res = simulate(mech)
    mb, tr = res.multibody, res.trajectory
    return _Run(mb, tr.q[5], tr.qd[5], tr.t, "DOP853", 1e-8, 1e-10), tr


@pytest.mark.parametrize("name", ["andrews", "nfourbar-2", "redundant"])
def test_lite_right_hand_side_is_the_general_one(name):
    run, tr = _run(name)
    mb, part = run.mb, run.part
    assert run.lite is not None
    assert (len(part.rows) < mb.nc) == (name == "redundant")
    rng = np.random.default_rng(3)
    nq = mb.nq
    for i in range(2, 9):
        y = np.concatenate([tr.q[i], tr.qd[i], [0.0]])
        y[:nq] += 1e-7 * mb.scale * rng.normal(size=nq)
        y[nq:-1] += 1e-6 * rng.normal(size=nq) * (1 + np.abs(y[nq:-1]))
        mb._chord = None
        fast = run.lite.rhs(run, part, tr.t[i], y)
        mb._chord = None
        q = mb.close(part, y[part.ind], tr.t[i], y[:nq])
        qd, Jq = mb.rates(part, q, y[nq + part.ind], tr.t[i])
        qdd, _, P, _ = mb.accelerations(part, q, qd, tr.t[i], Jq)
        np.testing.assert_allclose(fast[:nq], qd, rtol=1e-12, atol=1e-12 * np.max(np.abs(qd)))
        np.testing.assert_allclose(
            fast[nq:-1], qdd, rtol=1e-9, atol=1e-10 * np.max(np.abs(qdd)) + 1e-300
        )
        assert fast[-1] == pytest.approx(P, rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("seed", range(4))
def test_loads_in_floats_match_the_general_loads(seed):
    run, _ = _run("andrews")
    mb = run.mb
    rng = np.random.default_rng(seed)
    q, qd = rng.normal(size=mb.nq) * 0.05, rng.normal(size=mb.nq)
    q[2::3] = rng.uniform(-np.pi, np.pi, mb.nb)
    Q = np.zeros(mb.nq)
    P = mb.array_loads.apply_fast(q, qd, np.cos(q[2::3]), np.sin(q[2::3]), Q)
    Q0 = np.zeros(mb.nq)
    P0, _ = mb.array_loads.apply(q, qd, Q0)
    np.testing.assert_allclose(Q, Q0, rtol=1e-12, atol=1e-12 * np.max(np.abs(Q0)))
    assert P == pytest.approx(P0, rel=1e-12, abs=1e-15)
