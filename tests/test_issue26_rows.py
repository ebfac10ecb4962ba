"""Issue 26: the general path closes its output rows all at once, on arrays over the
rows (:mod:`mechsolve.analyses.dynamics.multibody_rows`), instead of one evaluation of
the equations per row. Checked at states near the motion (the integrated state's
small departures from the constraints, as the integrator leaves them): each closed row
satisfies the constraint equations at position and velocity level and the equations of
motion ``M q'' + Phi_q^T lambda = Q`` with ``Phi_q q'' = gamma``, both evaluated by the
general state and load machinery (joint by joint); and it is the row the one-by-one
closing gives, to the constraint tolerance. The redundant parallelogram's multipliers
are the minimum-norm ones."""

from __future__ import annotations

import numpy as np
import pytest
from test_issue26_multibody import REDUNDANT

import mechsolve as ms
from mechsolve.analyses.dynamics import multibody_integrate as integrate_module
from mechsolve.analyses.dynamics import simulate
from mechsolve.analyses.dynamics.multibody_rows import close_rows

from conftest import MECH


def _case(name):
    if name == "redundant":
        mech = ms.loads(REDUNDANT % "")
    else:
        mech = ms.load(MECH / f"{name}.yaml")
    mech.simulation.duration = 10 * mech.simulation.step
    return simulate(mech)


def _states(res, seed):
    """The outputs' states moved off the constraints by about an integrator's error."""
    mb, tr = res.multibody, res.trajectory
    rng = np.random.default_rng(seed)
    n = len(tr.t)
    q = tr.q + 1e-7 * mb.scale * rng.normal(size=tr.q.shape)
    qd = tr.qd + 1e-6 * rng.normal(size=tr.qd.shape) * (1.0 + np.abs(tr.qd))
    return tr.t, np.concatenate([q, qd, np.zeros((n, 1))], axis=1)


@pytest.mark.parametrize("name", ["andrews", "nfourbar-2", "redundant"])
def test_rows_closed_on_arrays_satisfy_the_equations_and_match_one_by_one(name):
    res = _case(name)
    mb, tr = res.multibody, res.trajectory
    part = mb.partition(tr.q[0])
    ts, ys = _states(res, 1)
    rows = close_rows(mb, part, ys)
    assert rows is not None
    assert (len(part.rows) < mb.nc) == (name == "redundant")
    for i, t in enumerate(ts):
        q, qd, qdd, lam = rows.q[i], rows.qd[i], rows.qdd[i], rows.lam[i]
        # the independent coordinates and rates are the integrated ones
        np.testing.assert_array_equal(q[part.ind], ys[i, part.ind])
        np.testing.assert_array_equal(qd[part.ind], ys[i, mb.nq + part.ind])
        # the constraints and the equations of motion, by the general machinery
        st = mb.state(q, qd, qdd)
        Jq = mb.system.jacobian(st)[0]
        phi = np.concatenate([c.residual(st, 0.0)[:, 0] for c in mb.system.constraints])
        assert np.max(np.abs(phi)) <= mb.tol
        assert rows.viol[i] == pytest.approx(np.max(np.abs(phi)), abs=1e-15)
        assert np.max(np.abs(Jq @ qd)) <= 1e-12 * (1 + np.max(np.abs(qd)))
        gamma = np.concatenate([c.gamma(st, 0.0)[:, 0] for c in mb.system.constraints])
        size = np.max(np.abs(Jq)) * np.max(np.abs(qdd)) + np.max(np.abs(gamma))
        np.testing.assert_allclose(Jq @ qdd, gamma, rtol=0, atol=1e-10 * size)
        Q, _, V = mb.forces(st, t)
        M = mb.mass_matrix(st)
        scale = np.max(np.abs(Q)) + np.max(np.abs(M @ qdd))
        np.testing.assert_allclose(M @ qdd + Jq.T @ lam, Q, atol=1e-10 * scale)
        assert rows.T[i] == pytest.approx(0.5 * qd @ M @ qd, rel=1e-12)
        assert rows.V[i] == pytest.approx(V, rel=1e-12, abs=1e-12)
        # the multipliers of least norm (in the null space of Phi_q^T's complement)
        if name == "redundant":
            _, sv, Vt = np.linalg.svd(Jq.T)
            null = Vt[np.sum(sv > 1e-10 * sv[0]) :]
            assert null.shape[0] >= 1
            assert np.max(np.abs(null @ lam)) <= 1e-9 * np.max(np.abs(lam))
        # the one-by-one closing of the same state
        mb._chord = None
        q1 = mb.close(part, ys[i, part.ind], t, ys[i, : mb.nq])
        qd1, _ = mb.rates(part, q1, ys[i, mb.nq + part.ind], t)
        mb._ev = None
        qdd1, lam1, T1, V1 = mb.output(part, q1, qd1, t)
        step = 10 * mb.tol
        np.testing.assert_allclose(q, q1, rtol=0, atol=step)
        np.testing.assert_allclose(qd, qd1, rtol=0, atol=step * (1 + np.max(np.abs(qd))) / mb.scale)
        np.testing.assert_allclose(qdd, qdd1, rtol=1e-7, atol=1e-7 * np.max(np.abs(qdd1)))
        np.testing.assert_allclose(lam, lam1, rtol=1e-7, atol=1e-7 * np.max(np.abs(lam1)))


def test_andrews_whole_run_same_rows_and_one_evaluation_less_per_row(monkeypatch):
    """No singular passage: the run with its rows closed on arrays is the run with them
    closed one by one, to the constraint tolerance, and it evaluates the equations
    once less per output row."""
    fast = simulate(_andrews()).trajectory
    monkeypatch.setattr(integrate_module, "close_rows", lambda *args: None)
    slow = simulate(_andrews()).trajectory
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.qd, slow.qd, rtol=1e-7, atol=1e-7 * np.max(np.abs(slow.qd)))
    np.testing.assert_allclose(fast.lam, slow.lam, rtol=1e-6, atol=1e-6 * np.max(np.abs(slow.lam)))
    assert fast.nfev == slow.nfev - (len(slow.t) - 1)


def _andrews():
    mech = ms.load(MECH / "andrews.yaml")
    mech.simulation.rtol, mech.simulation.atol = 1e-7, 1e-10
    return mech
