"""A revolute Newton group whose loops each have a link of their own (the Stephenson
triad) eliminated to 2 x 2 over all positions (issue 30, target 1): the Newton steps,
determinants, rates and the conditioning bound's |F_theta^-1|_F equal LAPACK's on the
same matrices, the split is found from the equations, and the triad's sweep needs no
4 x 4 factorisation while its numbers stay the hand-written Newton's."""

from __future__ import annotations

import numpy as np
import pytest

from mechsolve.core.sweep import Analysis
from mechsolve.groups import reduced
from mechsolve.groups.eliminated import Eliminated
from mechsolve_bench import _triad_mech
from mechsolve_bench import references as R


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def _triad(n: int):
    an = Analysis(_triad_mech(n), "auto")
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    start = an.assemble(u0)
    return an, u, start


def test_the_triads_loops_each_keep_a_link_of_their_own():
    """The group's tree grows from the crank through L3 and T; the joints P1 and P2
    close its two loops. L1 (pinned to the ground at G1) is in the first only, L2 (at
    G2) in the second only, L3 and T in both: the elimination keeps L3 and T and solves
    L1 and L2 from their loops' perpendicular rows."""
    an, _, _ = _triad(360)
    g = an.plan[-1]
    el = g.red.elim
    assert el is not None and g.red.sub is g.red
    names = [an.system.body_names[b] for b in g.bodies]
    assert sorted(names[k] for k in el.priv) == ["L1", "L2"]
    assert sorted(names[k] for k in el.rest) == ["L3", "T"]


def _poses(an, n_random=2000):
    """The sweep's poses and random ones (all angles uniform), as cosines and sines."""
    g = an.plan[-1]
    u, _ = an.sweep_values(an.start_value())
    sol = an.solve(u)
    th = sol.state.th[g.bodies].T
    rng = np.random.default_rng(3)
    th = np.concatenate([th, rng.uniform(-np.pi, np.pi, (n_random, th.shape[1]))])
    return np.cos(th), np.sin(th)


def test_eliminated_step_determinant_and_inverse_norm_are_lapacks():
    an, _, _ = _triad(720)
    red = an.plan[-1].red
    C, S = _poses(an)
    J = red.jacobian(C, S)
    f = np.random.default_rng(4).normal(size=C.shape)
    parts = red.elim.parts(C, S)
    x = np.stack(parts.solve([f[:, k] for k in range(4)]), axis=1)
    want = np.linalg.solve(J, -f[..., None])[..., 0]
    cond = np.linalg.cond(J)
    ok = cond < 1e6  # (a random pose can be nearly singular: both lose digits there)
    assert ok.mean() > 0.95
    err = np.max(np.abs(x - want), axis=1) / np.max(np.abs(want), axis=1)
    assert np.all(err[ok] <= 1e-15 * cond[ok] * 50)
    det = np.linalg.det(J)
    assert np.allclose(parts.dets()[ok], det[ok], rtol=1e-15 * 50 * cond[ok].max(), atol=0)
    assert np.all(np.sign(parts.dets()[ok]) == np.sign(det[ok]))
    nf = np.linalg.norm(np.linalg.inv(J), axis=(1, 2))
    assert np.allclose(parts.inverse_norm()[ok], nf[ok], rtol=1e-15 * 50 * cond[ok].max())


def test_the_inverse_norm_is_exact_next_to_a_singular_pose():
    """The conditioning bound must never miss a near-singular position, so its norm is
    the exact one, not a bound of it: at poses approaching a singular one (det F_theta
    -> 0, found by bisection between two poses of opposite signs), |F_theta^-1|_F grows
    as LAPACK's does; NaN where the determinant is zero (as the inverse is)."""
    an, _, _ = _triad(360)
    red = an.plan[-1].red
    el = red.elim

    def det(t):
        return el.parts(np.cos(t)[None], np.sin(t)[None]).dets()[0]

    rng = np.random.default_rng(5)
    while True:
        a, b = rng.uniform(-np.pi, np.pi, (2, 4))
        da = det(a)
        if da * det(b) < 0:
            break
    d = (b - a) / np.linalg.norm(b - a)
    for _ in range(80):
        m = 0.5 * (a + b)
        dm = det(m)
        if dm * da > 0:
            a, da = m, dm
        else:
            b = m
    th = np.array([a - d * 10.0**-e for e in range(2, 9)])
    C, S = np.cos(th), np.sin(th)
    got = el.parts(C, S).inverse_norm()
    want = np.linalg.norm(np.linalg.inv(red.jacobian(C, S)), axis=(1, 2))
    assert np.all(np.diff(want) > 0) and want[-1] > 1e6 * want[0] / 1e2
    assert np.allclose(got, want, rtol=1e-6)
    parts = el.parts(C[:1], S[:1])
    parts.det = np.zeros(1)
    assert np.isnan(parts.inverse_norm()[0])


def test_a_group_whose_links_are_in_both_loops_is_not_eliminated():
    """Equations whose every angle appears in both loops (no link of its own): no
    elimination, the general factorisation."""
    M = np.zeros((4, 12))
    V = np.array([[0.7, 0.8, -0.6, 0.4], [0.5, -0.3, 0.9, 0.2]])  # (loop, angle)
    for e in range(2):
        M[e, :4], M[e, 4:8] = V[e], 0.0  # x rows: V cos (local vectors along x)
        M[2 + e, 4:8] = V[e]  # y rows: V sin
    eqs = reduced._Eqs(M)
    with pytest.raises(ValueError):
        Eliminated(eqs, 2)


def test_the_triad_sweep_factors_no_4x4_and_keeps_the_hand_written_numbers(monkeypatch):
    """3600 positions of the triad: the refinement's steps, the determinants of the
    sign-change test and the bifurcation search, the rates and the conditioning bound
    all from the elimination (no stacked LU, no LAPACK inverse), and the angles, rates
    and accelerations those of the batched Newton written by hand with LAPACK."""

    def no(*a, **k):
        raise AssertionError("a 4 x 4 factorisation")

    n = 3600
    an, u, start = _triad(n)  # (the start's assembly in body coordinates by LAPACK)
    monkeypatch.setattr(reduced._Eqs, "lu", no)
    monkeypatch.setattr(reduced, "_batch_inverse", no)
    for name in ("solve", "inv"):  # over positions (the bound's constants: one matrix)
        f = getattr(np.linalg, name)
        monkeypatch.setattr(
            np.linalg, name, lambda A, *r, f=f: no() if np.ndim(A) == 3 else f(A, *r)
        )
    sol = an.solve(u, start=start)
    monkeypatch.undo()  # (the reference solves by LAPACK)
    assert sol.ok.all() and not sol.events
    th, w, al, _ = R.triad_newton(R.TRIAD_START + np.arange(n) * 2 * np.pi / n)
    idx = [an.system.index[k] for k in ("L1", "T", "L2", "L3")]
    st = sol.state
    assert np.max(np.abs(_wrap(st.th[idx].T - th))) <= 1e-11
    assert np.max(np.abs(st.w[idx].T - w)) <= 1e-9 * np.max(np.abs(w))
    assert np.max(np.abs(st.al[idx].T - al)) <= 1e-9 * np.max(np.abs(al))
    assert np.nanmax(sol.residual) <= an.atol
