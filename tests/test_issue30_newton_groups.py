"""Newton groups at the speed of the lean hand-written programs (issue 30, targets 1 and
4): a refinement that stops once its last step leaves an error predicted below the
tolerance, checked against independent references (Norton's closed form of the
four-bar, a batched Newton of the triad written by hand with LAPACK's solve)."""

from __future__ import annotations

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core.sweep import Analysis
from mechsolve_bench import _sol_fourbar, _triad_mech, fourbar_yaml
from mechsolve_bench import references as R


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def _sweep(mech, method):
    an = Analysis(mech, method)
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    start = an.assemble(u0)
    return an, u, start, an.solve(u, start=start)


def test_four_bar_sweep_stops_after_two_updates_with_nortons_numbers():
    """3600 positions of the four-bar, ``split-newton``: nearly every position refined
    in one batch takes two Newton iterations (the third, before, only saw a step at
    rounding level), and angles, rates and accelerations are Norton's."""
    n = 3600
    an, u, start, sol = _sweep(ms.loads(fourbar_yaml(n)), "split-newton")
    assert sol.methods[0] == "newton+newton (batched)"
    its = np.asarray(sol.iterations)
    assert np.mean(its <= 2) >= 0.98, np.bincount(its)
    th2 = np.arange(n) * 2 * np.pi / n
    want = R.fourbar_textbook(th2)
    got = _sol_fourbar(sol)
    for k in range(6):
        d = got[k] - want[k]
        if k < 2:
            d = _wrap(d)
        assert np.max(np.abs(d)) <= 1e-11 * max(1.0, float(np.max(np.abs(want[k])))), k
    assert np.nanmax(sol.residual) <= an.atol


def test_triad_sweep_stops_after_two_updates_with_the_hand_written_newtons_numbers():
    n = 3600
    an, u, start, sol = _sweep(_triad_mech(n), "auto")
    assert [g.kind for g in an.plan] == ["driver link", "Newton"]
    its = np.asarray(sol.iterations)
    assert np.mean(its <= 2) >= 0.98, np.bincount(its)
    th, w, al, _ = R.triad_newton(R.TRIAD_START + np.arange(n) * 2 * np.pi / n)
    idx = [an.system.index[k] for k in ("L1", "T", "L2", "L3")]
    st = sol.state
    assert np.max(np.abs(_wrap(st.th[idx].T - th))) <= 1e-11
    assert np.max(np.abs(st.w[idx].T - w)) <= 1e-9 * np.max(np.abs(w))
    assert np.max(np.abs(st.al[idx].T - al)) <= 1e-9 * np.max(np.abs(al))
    assert np.nanmax(sol.residual) <= an.atol


@pytest.mark.parametrize("predict", [False, True])
def test_float_newton_with_prediction_converges_to_the_same_root(predict):
    """One position of the four-bar's loop in floats: with ``predict`` the iteration
    ends one residual evaluation earlier (the same steps), on the same root to rounding
    (Norton's)."""
    an = Analysis(ms.loads(fourbar_yaml(360)), "split-newton")
    g = an.plan[1]
    red = g.red
    th2 = 0.7
    want = R.fourbar_textbook(np.array([th2]))
    st = an.assemble(th2).state
    K, _, _ = red.known(st)
    Kr, _ = red.reduce(red.with_driver(K, np.array([th2])))
    th0 = [float(want[0][0]) + 2e-4, float(want[1][0]) - 3e-4]
    x, ok, it, _, nfev = red.sub.newton_list(Kr[0], th0, g.atol, 30, predict=predict)
    assert ok
    assert abs(_wrap(x[0] - want[0][0])) <= 1e-13 and abs(_wrap(x[1] - want[1][0])) <= 1e-13
    _, _, it0, _, nfev0 = red.sub.newton_list(Kr[0], th0, g.atol, 30)
    assert it == it0 >= 2
    assert nfev == (nfev0 - 1 if predict else nfev0)


def test_one_triad_position_next_to_a_sweep_is_the_hand_written_newtons():
    """One position of the triad next to its solved sweep (its rates, conditioning
    bound and residual in floats) against the batched Newton written by hand."""
    n = 360
    an, u, start, sol = _sweep(_triad_mech(n), "auto")
    idx = [an.system.index[k] for k in ("L1", "T", "L2", "L3")]
    tht = R.TRIAD_START + np.arange(n) * 2 * np.pi / n
    for i in (5, 120, 250):
        s1 = an.solve(u[i : i + 1], start=start, near=(sol, i - 1))
        th, w, al, _ = R.triad_newton(tht[i : i + 1])
        st = s1.state
        assert np.max(np.abs(_wrap(st.th[idx, 0] - th[0]))) <= 1e-11
        assert np.max(np.abs(st.w[idx, 0] - w[0])) <= 1e-9
        assert np.max(np.abs(st.al[idx, 0] - al[0])) <= 1e-9
        assert s1.residual[0] <= an.atol


def _pin_residual(an, st, i):
    """max |Phi| of the four-bar's pins and driver by hand from the bodies' poses."""
    out = 0.0
    for c in an.system.constraints:
        if c.letter == "R":
            p = []
            for b, s in ((c.a, c.sa), (c.b, c.sb)):
                if b == st.nb:
                    p.append(np.asarray(s, float))
                else:
                    t = st.th[b, i]
                    rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
                    p.append(np.array([st.x[b, i], st.y[b, i]]) + rot @ np.asarray(s, float))
            out = max(out, float(np.max(np.abs(p[0] - p[1]))))
    return out


def test_one_positions_residual_in_floats_is_the_pins_by_hand_and_keeps_nan():
    from mechsolve.base.state import State

    an = Analysis(ms.loads(fourbar_yaml(360)), "split-newton")
    sol = an.solve(np.array([0.3]))
    st = sol.state
    rng = np.random.default_rng(1)
    for _ in range(5):  # poses off the solution: a residual of the order of 1e-3 m
        st1 = st.take([0])
        for b in range(st.nb):
            st1.x[b, 0] += rng.normal(scale=1e-3)
            st1.set_angle(b, st1.th[b] + rng.normal(scale=1e-3))
        got = float(an.system.max_residual(st1, np.array([0.3]))[0])
        assert got == pytest.approx(_pin_residual(an, st1, 0), rel=1e-12, abs=1e-17)
        assert got > 1e-5
    st1 = st.take([0])
    st1.y[2, 0] = np.nan
    assert np.isnan(an.system.max_residual(st1, np.array([0.3]))[0])
    assert isinstance(st1, State)


def test_one_positions_conditioning_bound_is_the_one_from_lapacks_inverse():
    """The rcond bound at one position (the inverse's Frobenius norm in floats) is the
    one from LAPACK's inverse of the same F_theta, for the four-bar's and the triad's
    Newton groups, and NaN where F_theta is exactly singular."""
    for mech, method in ((ms.loads(fourbar_yaml(360)), "split-newton"), (_triad_mech(360), "auto")):
        an, u, start, sol = _sweep(mech, method)
        g = an.plan[-1]
        red = g.red
        for i in (7, 100, 300):
            st1 = sol.state.take([i])
            c, s = st1.c[g.bodies].T, st1.s[g.bodies].T
            inv = np.linalg.inv(red.jacobian(c, s))
            got = g.rcond_bound(st1)[0]
            c0, a0, a1 = g._bound
            want = 1.0 / (c0 * (a0 + a1 * np.linalg.norm(inv[0])))
            assert got == pytest.approx(want, rel=1e-12)
        st1 = sol.state.take([0])
        st1.c[g.bodies, 0] = 0.0  # every entry of F_theta zero: exactly singular
        st1.s[g.bodies, 0] = 0.0
        assert np.isnan(g.rcond_bound(st1)[0])


@pytest.mark.parametrize("which", ["split-newton", "newton", "triad"])
def test_one_position_takes_no_batched_inverse_or_residual(which, monkeypatch):
    """One position next to a solved sweep: the solved bodies' terms, the positions (the
    driven crank's too, and a crank inside the group: ``newton``), the conditioning
    bound, the rates and the residual check in floats, none of the batched code's
    arrays ((N, n) terms, (N, n, n) inverses, joint-by-joint array residuals); the
    numbers as before."""
    from mechsolve.groups.newton_rates import NewtonRates
    from mechsolve.groups.reduced import _Angles
    from mechsolve.joints.revolute import RevoluteConstraint

    mech, method = (
        (_triad_mech(360), "auto") if which == "triad" else (ms.loads(fourbar_yaml(360)), which)
    )
    an, u, start, sol = _sweep(mech, method)
    want = an.solve(u[40:41], start=start, near=(sol, 39))

    def no(*a, **k):
        raise AssertionError("batched code at one position")

    monkeypatch.setattr(NewtonRates, "_angle_inverse", no)
    monkeypatch.setattr(_Angles, "known", no)
    monkeypatch.setattr(RevoluteConstraint, "max_residual_into", no)
    got = an.solve(u[40:41], start=start, near=(sol, 39))
    assert np.array_equal(got.state.block, want.state.block)
    assert np.array_equal(got.residual, want.residual)
    if which != "triad":  # and Norton's
        th2 = 40 * 2 * np.pi / 360
        want_n = R.fourbar_textbook(np.array([th2]))
        for k, v in enumerate(_sol_fourbar(got)):
            d = _wrap(v - want_n[k]) if k < 2 else v - want_n[k]
            assert abs(float(d[0])) <= 1e-10 * max(1.0, abs(float(want_n[k][0])))


def test_a_sweeps_determinants_are_computed_once_and_follow_the_poses(monkeypatch):
    """The batched sweep's test for a sign change and the bifurcation search read the
    same determinants: computed once per sweep; new poses (another sweep, or the same
    state's angles changed) compute them again (the four-bar's F_theta determinant is
    sin(th4 - th3) times the coupler's and rocker's lengths, up to sign)."""
    from mechsolve.groups.generic import NewtonGroup

    calls = []
    red_dets = NewtonGroup.red_dets
    monkeypatch.setattr(
        NewtonGroup, "red_dets", lambda g, st, ok: calls.append(1) or red_dets(g, st, ok)
    )
    n = 720
    an, u, start, sol = _sweep(ms.loads(fourbar_yaml(n)), "split-newton")
    assert len(calls) == 1
    g = an.plan[1]
    st = sol.state
    ok = np.ones(n, bool)
    det, good = g.dets(st, ok)
    assert len(calls) == 1 and good.all()
    th3, th4 = st.th[1], st.th[2]
    want = R.B3 * R.C4 * np.sin(th4 - th3)
    assert np.allclose(np.abs(det), np.abs(want), rtol=1e-12, atol=0)
    st.th[2, 5] += 0.1  # another pose of the rocker at one position
    st.c[2, 5], st.s[2, 5] = np.cos(st.th[2, 5]), np.sin(st.th[2, 5])
    det2, _ = g.dets(st, ok)
    assert len(calls) == 2
    assert det2[5] != det[5] and np.array_equal(np.delete(det2, 5), np.delete(det, 5))
    an.solve(u, start=start)
    assert len(calls) == 3


def test_determinants_and_inverse_of_the_same_poses_factor_once():
    """The triad's F_theta at a sweep's poses: its determinants and then its inverse
    (as the sign-change test and the rates ask for them) from one factorisation, equal
    to LAPACK's; other poses factor again. (Without the triad's 2 x 2 elimination, as a
    group whose loops have no link of their own is solved.)"""
    from mechsolve.groups import reduced

    n = 360
    an, u, start, sol = _sweep(_triad_mech(n), "auto")
    red = an.plan[-1].red
    bodies = an.plan[-1].bodies
    C, S = sol.state.c[bodies].T, sol.state.s[bodies].T
    red._lu_kept = None
    made = []
    lu = red.lu
    red.lu = lambda C, S: made.append(1) or lu(C, S)
    elim, red.elim = red.elim, None
    try:
        det = red.dets(C, S)
        inv = red.inverse(C, S)
        assert len(made) == 1
        J = red.jacobian(C, S)
        assert np.allclose(det, np.linalg.det(J), rtol=1e-10, atol=0)
        assert np.allclose(inv, np.linalg.inv(J), rtol=1e-9, atol=1e-12)
        C2 = np.roll(C, 1, axis=0)
        S2 = np.roll(S, 1, axis=0)
        det2 = red.dets(C2, S2)
        assert len(made) == 2
        assert np.allclose(det2, np.linalg.det(red.jacobian(C2, S2)), rtol=1e-10, atol=0)
    finally:
        del red.lu
        red.elim = elim
    assert reduced.STACKED_MIN <= n
