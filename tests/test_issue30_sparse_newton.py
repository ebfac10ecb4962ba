"""The coarse continuation's Newton iterations written out for a group's coefficients
(``mechsolve.groups.newton_floats.sparse_newton``): the four-bar's loop solved to
Freudenstein's closed form, the terms a hand count of its equations gives (two products
per residual, one per entry of ``F_theta``), the triad's four structural zeros of
``F_theta`` left out of the adjugate, and the iterates of the general loops to the bit
from starts near and far (the products left out are exactly zero)."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core.sweep import Analysis
from mechsolve.groups.generic import NewtonGroup
from mechsolve.groups.newton_floats import sparse_newton
from mechsolve_bench import _triad_mech

from closed_form import fourbar

A, B, C, D = 26.5e-3, 105.6e-3, 59e-3, 87.5e-3
FOURBAR = """
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 2 rad/s, start: 10 deg}
sweep: {range: 360 deg, step: 0.5 deg}
"""


def _group(mech, method: str) -> tuple[Analysis, NewtonGroup]:
    an = Analysis(mech, method)
    return an, next(g for g in an.plan if isinstance(g, NewtonGroup) and g.red.sub.nb)


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def test_the_fourbar_loop_converges_to_freudenstein():
    """From 0.2 rad off, at crank angles around the turn, the written-out iterations
    reach the closed form's coupler and rocker angles (the branch the start is near)."""
    an, g = _group(ms.loads(FOURBAR), "split-newton")
    fn = sparse_newton(g.red.sub)
    assert fn is not None
    red = g.red
    for th2 in np.radians([10.0, 75.0, 160.0, 250.0, 330.0]):
        st = an.solve(np.array([th2])).state
        K = red.reduce(red.with_driver(red.known(st)[0], np.array([th2])))[0][0].tolist()
        th3, th4 = fourbar(A, B, C, D, np.array([th2]), 1.0, 1)[:2]
        x, ok, it, r, _ = fn(K, [float(th3[0]) + 0.2, float(th4[0]) - 0.2], 1e-12, 30, False)
        assert ok and r <= 1e-12 and 2 <= it <= 10
        assert abs(_wrap(x[0] - th3[0])) < 1e-12 and abs(_wrap(x[1] - th4[0])) < 1e-12


def test_the_fourbar_source_has_the_terms_a_hand_count_gives():
    """The loop O2 A + A B = O2 O4 + O4 B in the coupler's and rocker's angles: its x
    row has the cosines (b cos th3 - c cos th4), its y row the sines; so each residual
    is the constant and two products, and each entry of ``F_theta`` one product (the
    eight zero coefficients' twelve products of the general loop left out)."""
    _, g = _group(ms.loads(FOURBAR), "split-newton")
    src = sparse_newton(g.red.sub).source
    lines = {
        ln.split(" = ")[0].strip(): ln.split(" = ", 1)[1] for ln in src.splitlines() if " = " in ln
    }
    assert lines["f0"].count("*") == 2 and "c0" in lines["f0"] and "c1" in lines["f0"]
    assert lines["f1"].count("*") == 2 and "s0" in lines["f1"] and "s1" in lines["f1"]
    for e in ("a00", "a01", "a10", "a11"):
        assert lines[e].count("*") == 1
    assert "x0 *" not in src and "* x1" not in src  # no angle terms: revolute joints only


def test_the_triads_structural_zeros_are_left_out():
    """The triad's loops: L1 (angle 0) only in the first loop's rows 0 and 2, L2 (angle
    1) only in the second's, 1 and 3: F_theta's entries (0, 1), (1, 0), (2, 1), (3, 0)
    are zero at every pose and appear nowhere in the source."""
    _, g = _group(_triad_mech(36), "auto")
    src = sparse_newton(g.red.sub).source
    assert "a00 = " in src and "a11 = " in src
    for e in ("a01", "a10", "a21", "a30"):
        assert e not in src


@pytest.mark.parametrize("which", ["fourbar", "triad"])
def test_the_iterates_are_the_general_loops_to_the_bit(which):
    """From starts 1e-4 to 2 rad off the solved poses, with 1, 3 or 30 iterations allowed
    and the stop on a predicted error or not, the same angles (to the bit), convergence,
    iterations and residual as ``_Eqs.newton_list``."""
    mech = ms.loads(FOURBAR) if which == "fourbar" else _triad_mech(72)
    an, g = _group(mech, "split-newton" if which == "fourbar" else "auto")
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    sol = an.solve(u)
    red, sub = g.red, g.red.sub
    fn = sparse_newton(sub)
    K = red.reduce(red.with_driver(red.known(sol.state)[0], u))[0]
    th = sol.state.th[g.bodies].T
    rng = random.Random(5)
    for i in range(0, len(u), 5):
        for sd in (1e-4, 1e-2, 0.3, 2.0):
            x0 = [t + rng.gauss(0.0, sd) for t in th[i].tolist()]
            for its in (1, 3, 30):
                for predict in (False, True):
                    want = sub.newton_list(K[i].tolist(), x0, g.atol, its, predict)
                    got = fn(K[i].tolist(), x0, g.atol, its, predict)
                    assert got[1:3] == want[1:3]
                    assert got[3] == want[3] or (math.isnan(got[3]) and math.isnan(want[3]))
                    assert np.array_equal(np.array(got[0]), np.array(want[0]), equal_nan=True)


@pytest.mark.parametrize("which", ["fourbar", "triad"])
def test_the_written_out_coarse_steps_are_the_loops(monkeypatch, which):
    """The coarse pass with its plain steps in ``coarse_runner``'s loop gives the angles
    and iterations of the same pass without it, bit for bit, and for the four-bar the
    closed form's angles at the coarse positions."""
    import mechsolve.groups.newton_batched as nbm
    from mechsolve.groups.base import Drive

    mech = ms.loads(FOURBAR) if which == "fourbar" else _triad_mech(720)
    an, g = _group(mech, "split-newton" if which == "fourbar" else "auto")
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    sol = an.solve(u)
    idx = np.arange(0, len(u), 21)
    q0 = g.get_q(sol.state, 0)
    runs = []
    for runner in (nbm.coarse_runner, lambda nb: None):
        monkeypatch.setattr(nbm, "coarse_runner", runner)
        st = sol.state.take(idx)
        its = g._coarse_floats(st, Drive(u[idx], np.ones(len(idx)), np.zeros(len(idx))), q0)
        runs.append((its, st.th[g.bodies].copy()))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert np.array_equal(runs[0][1].view(np.int64), runs[1][1].view(np.int64))
    if which == "fourbar":
        th2 = an.solve(u[idx]).state.th[an.system.index["crank"]]
        th3, th4 = fourbar(A, B, C, D, th2, 1.0, 1)[:2]
        if np.max(np.abs(_wrap(runs[0][1][1] - th4))) > 1e-6:
            th3, th4 = fourbar(A, B, C, D, th2, 1.0, -1)[:2]
        np.testing.assert_allclose(_wrap(runs[0][1][0] - th3), 0, atol=1e-10)
        np.testing.assert_allclose(_wrap(runs[0][1][1] - th4), 0, atol=1e-10)
