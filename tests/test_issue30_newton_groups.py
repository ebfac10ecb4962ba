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
