"""The Newton groups' batched sweep, fifth pass: the triad's refinement on each angle's
own 1-D array (its residual summed as the compiled kernel sums it), and the jump check
of a revolute group on its free angles alone, each weighted by the largest lever arm
it moves a frame by (the coarse continuation and the batch both). Checked against the
closed form (Freudenstein's equation, Norton's solution), the triad solved position by
position, and weights worked out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
import mechsolve.groups.compiled as compiled
from mechsolve.core.sweep import Analysis
from mechsolve.groups.generic import NewtonGroup
from mechsolve.groups.newton_batched import BatchedSweep
from mechsolve_bench import _triad_mech

from closed_form import fourbar


def wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


# a crank-rocker whose coupler's frame is 500 mm from its joints (A at x = 500): its
# frame swings 500 mm per radian of the coupler's angle; the size (the longest distance
# between two points of a link, or of a ground point from the origin) is 105.6 mm
FOURBAR = """
units: {{length: mm, angle: deg}}
ground: {{O2: [0, 0], O4: [87.5, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [26.5, 0]}}}}
  coupler: {{points: {{A: [{ax}, 0], B: [{bx}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [59, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 2 rad/s, start: 10 deg}}
sweep: {{range: 360 deg, step: 0.5 deg}}
"""


def _newton_group(an: Analysis) -> NewtonGroup:
    return next(g for g in an.plan if isinstance(g, NewtonGroup) and g.red.sub.nb)


def test_the_jump_weights_are_the_lever_arms_over_the_size():
    """The four-bar's loop (coupler and rocker, from the crank's pin A): the coupler's
    angle moves the coupler's frame by |A - origin| = 500 mm and the rocker's by the
    coupler's length 105.6 mm; the rocker's angle moves the rocker's frame (reached
    through B) by |B| = 59 mm on the rocker. Over the size 105.6 mm: 500 / 105.6 and 1.
    With the frames at the joints every weight is 1."""
    an = Analysis(ms.loads(FOURBAR.format(ax=500, bx=605.6)), "split-newton")
    g = _newton_group(an)
    assert g.scale == pytest.approx(0.1056)
    assert [g.body_names[k] for k in g.red.free] == ["coupler", "rocker"]
    assert g._angle_jump_weights() == pytest.approx([500 / 105.6, 1.0], rel=1e-12)
    an = Analysis(ms.loads(FOURBAR.format(ax=0, bx=105.6)), "split-newton")
    assert _newton_group(an)._angle_jump_weights() == [1.0, 1.0]


@pytest.mark.parametrize("ax", [0.0, 500.0])
def test_fourbar_with_far_frames_against_freudenstein(ax):
    """Both frames' four-bars by ``split-newton`` (721 positions: the batched sweep):
    the closed form's angles, rates and accelerations on the user's branch."""
    res = ms.solve(ms.loads(FOURBAR.format(ax=ax, bx=ax + 105.6)), method="split-newton")
    assert res.ok.all() and len(res.u) == 721
    th2 = res.link("crank").angle
    a, b, c, d = 26.5e-3, 105.6e-3, 59e-3, 87.5e-3
    refs = [fourbar(a, b, c, d, th2, 2.0, br) for br in (1, -1)]
    th4 = res.link("rocker").angle
    br = min(refs, key=lambda r: np.max(np.abs(wrap(th4 - r[1]))))
    np.testing.assert_allclose(wrap(res.link("coupler").angle - br[0]), 0, atol=1e-10)
    np.testing.assert_allclose(wrap(th4 - br[1]), 0, atol=1e-10)
    np.testing.assert_allclose(res.link("coupler").omega, br[2], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(res.link("rocker").omega, br[3], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(res.link("coupler").alpha, br[4], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(res.link("rocker").alpha, br[5], rtol=1e-8, atol=1e-8)


@pytest.mark.parametrize("ax, caught", [(0.0, False), (500.0, True)])
def test_an_angle_move_is_a_jump_by_the_frame_it_swings(monkeypatch, ax, caught):
    """The batch's prediction of the coupler's angle put 0.03 rad off at one position
    (below the 0.05 rad a jump is): where the coupler's frame sits at its joint that
    is no jump; where the frame is 500 mm away it swings by 15 mm, 0.14 of the size:
    a jump, and the batch hands the sweep to the sequential continuation. The sweep
    is the closed form's either way."""
    predict = BatchedSweep._predict
    got = []

    def off(self, u, coarse, qc, dqc):
        pred = predict(self, u, coarse, qc, dqc)
        if len(u) > 100:
            pred[101, 0] += 0.03
        return pred

    batched = BatchedSweep.sweep_batched

    def spy(self, *a, **k):
        out = batched(self, *a, **k)
        got.append(out is None)
        return out

    monkeypatch.setattr(BatchedSweep, "_predict", off)
    monkeypatch.setattr(BatchedSweep, "sweep_batched", spy)
    res = ms.solve(ms.loads(FOURBAR.format(ax=ax, bx=ax + 105.6)), method="split-newton")
    assert got == [caught]
    th2 = res.link("crank").angle
    th3, th4 = fourbar(26.5e-3, 105.6e-3, 59e-3, 87.5e-3, th2, 2.0, 1)[:2]
    other = fourbar(26.5e-3, 105.6e-3, 59e-3, 87.5e-3, th2, 2.0, -1)[:2]
    if np.max(np.abs(wrap(res.link("rocker").angle - th4))) > 1e-6:
        th3, th4 = other
    np.testing.assert_allclose(wrap(res.link("coupler").angle - th3), 0, atol=1e-10)
    np.testing.assert_allclose(wrap(res.link("rocker").angle - th4), 0, atol=1e-10)


def _triad(n: int):
    an = Analysis(_triad_mech(n), "auto")
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    return an, u, an.assemble(u0)


def test_the_triads_refinement_takes_each_angle_on_its_own_array(monkeypatch):
    """The triad (a group of four angles eliminated to 2 x 2) is refined by
    ``_refine_elim``, not the stacked (N, 4) iterations; its sweep of 720 positions
    agrees with the same positions solved one at a time (each from the sweep's pose at
    the position before, moved off by 1e-3 rad: a Newton solve of its own) to 1e-12."""
    called = []
    refine = BatchedSweep._refine_elim

    def spy(self, *a, **k):
        called.append(1)
        return refine(self, *a, **k)

    def no(self, *a, **k):
        raise AssertionError("the stacked refinement")

    monkeypatch.setattr(BatchedSweep, "_refine_elim", spy)
    monkeypatch.setattr(BatchedSweep, "_refine_stacked", no)
    an, u, start = _triad(720)
    sol = an.solve(u, start=start)
    assert called and sol.ok.all()
    monkeypatch.undo()
    g = _newton_group(an)
    st = sol.state
    for i in range(1, 720, 37):
        q0 = g.get_q(st, i - 1)
        q0[2::3] += 1e-3
        st1 = st.take([i])
        q, stats = g._solve_one(st1, u[i : i + 1], q0)
        assert stats.converged
        np.testing.assert_allclose(wrap(q[2::3] - g.get_q(st, i)[2::3]), 0, atol=1e-12)
        np.testing.assert_allclose(q, g.get_q(st, i), rtol=0, atol=1e-12)


def test_the_triads_numpy_sweep_is_the_kernels_to_the_bit(monkeypatch):
    """The triad's NumPy refinement sums each residual as the compiled kernel does (no
    matrix product, which BLAS sums in its own order): the two paths give the same
    angles, cosines, sines, rates and iterations, bit for bit."""
    pytest.importorskip("numba")
    monkeypatch.delenv(compiled.ENV, raising=False)
    an, u, start = _triad(720)
    plain = an.solve(u, start=start)
    monkeypatch.setenv(compiled.ENV, "1")
    an2, u2, start2 = _triad(720)
    assert _newton_group(an2).compiled
    fast = an2.solve(u2, start=start2)
    assert plain.ok.all() and fast.ok.all()
    for f in ("th", "c", "s", "w", "al"):
        np.testing.assert_array_equal(getattr(fast.state, f), getattr(plain.state, f), f)
    np.testing.assert_array_equal(fast.iterations, plain.iterations)
    assert math.isfinite(float(np.max(plain.state.al)))
