"""Speed of the Newton groups (issue 30, targets 1 and 4): what is computed faster gives
the same numbers, checked against independent computations (LAPACK through NumPy on the
same matrices; the determinant of the group's block of Phi_q in body coordinates)."""

from __future__ import annotations

import numpy as np
import pytest

from mechsolve.base.state import State
from mechsolve.groups.reduced import (
    _entries_of,
    _stacked_det,
    _stacked_inverse,
    _stacked_solve,
    _StackedLU,
)


def _cases(n: int, seed: int):
    """Matrices (N, n, n) of three kinds: well conditioned, random (some positions need
    a row exchange the static order does not make), and with a structural zero pattern
    of a loop (each equation touches some of the angles only)."""
    rng = np.random.default_rng(seed)
    N = 400
    well = rng.normal(size=(N, n, n)) + 4 * np.eye(n)
    rand = rng.normal(size=(N, n, n))
    nz = rng.random((n, n)) > 0.3
    nz[np.arange(n), rng.permutation(n)] = True  # structurally nonsingular
    sparse = rng.normal(size=(N, n, n)) * nz
    return [(well, None), (rand, None), (sparse, nz)]


@pytest.mark.parametrize("n", [3, 4, 5, 6])
def test_stacked_elimination_is_lapacks_solve_inverse_and_determinant(n):
    rng = np.random.default_rng(n)
    for J, nz in _cases(n, n):
        b = rng.normal(size=(J.shape[0], n))
        x0 = np.linalg.solve(J, b[..., None])[..., 0]
        inv0 = np.linalg.inv(J)
        det0 = np.linalg.det(J)
        cond = np.linalg.cond(J)[:, None]
        tol = 1e-14 * cond * (1 + np.abs(x0))
        assert np.all(np.abs(_stacked_solve(J, b, nz) - x0) <= 10 * tol)
        tol_inv = 1e-14 * cond[:, :, None] * (1 + np.abs(inv0))
        assert np.all(np.abs(_stacked_inverse(J, nz) - inv0) <= 10 * tol_inv)
        assert np.allclose(_stacked_det(J, nz), det0, rtol=1e-12 * cond.max(), atol=0)


def test_positions_the_static_row_order_cannot_take_go_to_lapack():
    """A position whose pivot is far below the entry under it (here: the first column
    (1e-9, 1) against the sample positions' (1, 1e-9)) is flagged and solved by LAPACK:
    without a row exchange its elimination would lose nine digits."""
    N = 5
    J = np.tile(np.array([[1.0, 2.0, 0.5], [1e-9, 1.0, 3.0], [0.3, 0.2, 1.0]]), (N, 1, 1))
    J[1] = [[1e-9, 2.0, 0.5], [1.0, 1.0, 3.0], [0.3, 0.2, 1.0]]
    lu = _StackedLU(_entries_of(J), N)
    assert lu.bad.tolist() == [False, True, False, False, False]
    b = np.arange(3.0 * N).reshape(N, 3)
    want = np.linalg.solve(J, b[..., None])[..., 0]
    assert np.allclose(_stacked_solve(J, b), want, rtol=1e-14, atol=0)
    assert np.allclose(_stacked_inverse(J), np.linalg.inv(J), rtol=1e-13, atol=0)


def test_singular_and_non_finite_positions_as_lapack_gives_them():
    N, n = 4, 4
    rng = np.random.default_rng(3)
    J = rng.normal(size=(N, n, n)) + 4 * np.eye(n)
    J[1, 2] = J[1, 0]  # exactly singular (two equal rows)
    J[2, 3, 1] = np.nan
    inv = _stacked_inverse(J)
    assert np.all(np.isnan(inv[1])) and np.all(np.isnan(inv[2]))
    assert np.allclose(inv[[0, 3]], np.linalg.inv(J[[0, 3]]), rtol=1e-13)
    with pytest.raises(np.linalg.LinAlgError):  # as np.linalg.solve
        _stacked_solve(J[:2], np.ones((2, n)))
    assert _stacked_det(J[1:2])[0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("which", ["four-bar", "triad"])
def test_a_revolute_groups_determinant_changes_sign_with_its_block_of_phi_q(which):
    """The cheap determinant :meth:`red_dets` (the free angles' Jacobian, which the
    bifurcation search follows) is the body coordinates' block determinant times one
    constant, at random angles of the group's links (both signs, near-singular ones)."""
    import mechsolve as ms
    from mechsolve.core.sweep import Analysis
    from mechsolve_bench import _triad_mech, fourbar_yaml

    if which == "four-bar":
        an = Analysis(ms.loads(fourbar_yaml(12)), "split-newton")
    else:
        an = Analysis(_triad_mech(12), "auto")
    g = an.plan[-1]
    assert g.kind == "Newton" and g.red is not None
    N = 2000
    rng = np.random.default_rng(5)
    st = State(an.system.nb, N)
    for b in range(an.system.nb):
        st.set_angle(b, np.full(N, 0.4))
    for b in g.col:
        st.set_angle(b, rng.uniform(-np.pi, np.pi, N))
    ok = np.ones(N, bool)
    ok[7] = False
    det, good = g.red_dets(st, ok)
    assert np.isnan(det[7]) and not good[7] and good[ok].all()
    full = np.linalg.det(g.jacobian(st))
    ratio = full[good] / det[good]
    assert np.allclose(ratio, ratio[0], rtol=1e-8)
    assert (det < 0).any() and (det > 0).any()


def test_four_by_four_newton_step_by_the_adjugate():
    """The coarse continuation's 4 x 4 step (:func:`_solve4`) against LAPACK, including
    a matrix with a zero diagonal (elimination without a row exchange would fail) and
    an exactly singular one (None)."""
    from mechsolve.groups.reduced import _solve4

    rng = np.random.default_rng(4)
    for _ in range(200):
        J = rng.standard_normal((4, 4))
        f = rng.standard_normal(4)
        want = np.linalg.solve(J, -f)
        got = _solve4(J.tolist(), f.tolist())
        assert np.allclose(got, want, rtol=1e-9 * np.linalg.cond(J), atol=1e-12)
    P = np.roll(np.eye(4), 1, axis=0) * np.array([1.0, -2.0, 3.0, 0.5])
    x = np.array([0.3, -1.0, 2.0, 0.25])
    assert np.allclose(_solve4(P.tolist(), (-(P @ x)).tolist()), x, rtol=0, atol=1e-15)
    assert _solve4(np.ones((4, 4)).tolist(), [1.0] * 4) is None


def test_cosines_turned_by_small_steps_are_those_of_the_new_angles():
    """:func:`_rotate` (the batched Newton's cos and sin after a step) against np.cos and
    np.sin of the new angles: to rounding for steps below 1e-3, evaluated afresh for
    larger or non-finite ones. (Without the Taylor series' 4th and 5th order terms the
    largest steps below 1e-3 are off by 4e-14.)"""
    from mechsolve.groups.newton_batched import _rotate

    rng = np.random.default_rng(6)
    th = rng.uniform(-10, 10, (5000, 3))
    D = rng.normal(scale=1e-4, size=th.shape) * rng.choice([1e-8, 1e-2, 1, 9.99], th.shape)
    D[0, 0], D[1, 1], D[2, 2] = 0.5, np.nan, -3.0
    C, S = np.cos(th), np.sin(th)
    th2 = th + D
    _rotate(C, S, D, th2)
    ok = np.isfinite(th2)
    # (th2 is th + D rounded: its own rounding, eps |th2|, moves cos and sin as much)
    tol = 4e-16 + 2.2e-16 * np.abs(th2[ok])
    assert np.all(np.abs(C[ok] - np.cos(th2[ok])) <= tol)
    assert np.all(np.abs(S[ok] - np.sin(th2[ok])) <= tol)
    assert np.isnan(C[1, 1]) and np.isnan(S[1, 1])


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5])
def test_one_small_determinant_in_floats_is_lapacks(n):
    from mechsolve.groups.reduced import _det_small

    rng = np.random.default_rng(n + 10)
    for _ in range(100):
        J = rng.standard_normal((n, n))
        assert _det_small(J) == pytest.approx(float(np.linalg.det(J)), rel=1e-12, abs=1e-14)
    assert _det_small(np.ones((n, n))) == pytest.approx(0.0, abs=1e-15) or n == 1


@pytest.mark.parametrize("method", ["split-newton", "newton"])
def test_one_position_rates_in_floats_are_nortons(method, monkeypatch):
    """One position next to a solved sweep (its rates in plain floats, with a driver
    inside the group for ``newton``) against Norton's closed form of the same four-bar:
    angles, angular velocities and accelerations of the coupler and the rocker."""
    import mechsolve as ms
    from mechsolve.core.sweep import Analysis
    from mechsolve.groups.newton_rates import NewtonRates
    from mechsolve_bench import _sol_fourbar, fourbar_yaml
    from mechsolve_bench import references as R

    n = 360
    an = Analysis(ms.loads(fourbar_yaml(n)), method)
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    start = an.assemble(u0)
    sol = an.solve(u, start=start)
    taken = []
    one = NewtonRates._angle_rates_one
    monkeypatch.setattr(
        NewtonRates, "_angle_rates_one", lambda g, *a: taken.append(one(g, *a)) or taken[-1]
    )
    th2 = np.arange(n) * 2 * np.pi / n
    for i in (3, 91, 200, 331):
        s1 = an.solve(u[i : i + 1], start=start, near=(sol, i - 1))
        got = _sol_fourbar(s1)
        want = R.fourbar_textbook(th2[i : i + 1])
        for k in range(6):
            d = got[k] - want[k]
            if k < 2:
                d = (d + np.pi) % (2 * np.pi) - np.pi
            assert abs(float(d[0])) <= 1e-10 * max(1.0, abs(float(want[k][0])))
    assert taken and all(taken)
