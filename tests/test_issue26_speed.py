"""Issue 26: the general path's fast evaluations give the same equations as the general
machinery they replace: the loads on arrays (torques, springs) against
:func:`mechsolve.core.loads.apply_loads`, the pins' Jacobian from its template against
the joint contract's, the mass matrix by flat index against its closed form, at random
configurations of Andrews' mechanism (a torque, a spring, ten pins, seven bodies)."""

from __future__ import annotations

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses.dynamics.multibody import Multibody
from mechsolve.core.sweep import Analysis

from conftest import MECH


@pytest.fixture(scope="module")
def andrews():
    mech = ms.load(MECH / "andrews.yaml")
    return Multibody(Analysis(mech))


def _random(mb, seed):
    rng = np.random.default_rng(seed)
    return rng.normal(size=mb.nq) * 0.05, rng.normal(size=mb.nq)


@pytest.mark.parametrize("seed", range(5))
def test_loads_on_arrays_match_the_general_loads(andrews, seed):
    mb = andrews
    assert mb.array_loads is not None  # Andrews: a torque and a spring
    q, qd = _random(mb, seed)
    q[2::3] = np.random.default_rng(seed + 10).uniform(-np.pi, np.pi, mb.nb)
    st = mb.state(q, qd)
    Q, P, V = mb.forces(st, 0.0)
    fast, mb.array_loads = mb.array_loads, None
    try:
        Q0, P0, V0 = mb.forces(mb.state(q, qd), 0.0)
    finally:
        mb.array_loads = fast
    np.testing.assert_allclose(Q, Q0, rtol=1e-12, atol=1e-12 * np.max(np.abs(Q0)))
    assert P == pytest.approx(P0, rel=1e-12, abs=1e-15)
    assert V == pytest.approx(V0, rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("seed", range(3))
def test_pins_jacobian_and_mass_matrix(andrews, seed):
    mb = andrews
    q, qd = _random(mb, seed)
    q[2::3] = np.random.default_rng(seed + 20).uniform(-np.pi, np.pi, mb.nb)
    st = mb.state(q, qd)
    # the joint contract's Jacobian (joint by joint)
    np.testing.assert_allclose(mb.pins.jacobian(q), mb.system.jacobian(st)[0], atol=1e-15)
    # M: [[m, 0, -m ry], [0, m, m rx], [-m ry, m rx, J + m |r|^2]] per body
    M = mb.mass_matrix(st)
    for b in range(mb.nb):
        m, J = mb.m[b], mb.J[b]
        c, s = np.cos(q[3 * b + 2]), np.sin(q[3 * b + 2])
        rx = c * mb.s[b, 0] - s * mb.s[b, 1]
        ry = s * mb.s[b, 0] + c * mb.s[b, 1]
        block = [[m, 0, -m * ry], [0, m, m * rx], [-m * ry, m * rx, J + m * (rx * rx + ry * ry)]]
        np.testing.assert_allclose(M[3 * b : 3 * b + 3, 3 * b : 3 * b + 3], block, atol=1e-15)
    off = M.copy()
    for b in range(mb.nb):
        off[3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = 0
    assert not off.any()


@pytest.mark.parametrize("name", ["andrews", "nfourbar-2"])
def test_evaluation_on_arrays_matches_the_states(name):
    """The accelerations' evaluation without states (pins, loads on arrays, gravity)
    against the one through the general state and load machinery."""
    mb = Multibody(Analysis(ms.load(MECH / f"{name}.yaml")))
    assert mb.lite
    q, qd = _random(mb, 3)
    th = q[2::3]
    Q, P, V = mb._forces_lite(q, qd, np.cos(th), np.sin(th))
    fast, mb.array_loads = mb.array_loads, None
    try:
        Q0, P0, V0 = mb.forces(mb.state(q, qd), 0.0)
    finally:
        mb.array_loads = fast
    np.testing.assert_allclose(Q, Q0, rtol=1e-12, atol=1e-12 * np.max(np.abs(Q0)))
    assert P == pytest.approx(P0, rel=1e-12, abs=1e-15)
    assert V == pytest.approx(V0, rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(mb._mass(np.cos(th), np.sin(th)), mb.mass_matrix(mb.state(q)))
