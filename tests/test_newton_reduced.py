"""Issue 17: the Newton path's reduced unknowns and its small solves.

* a driver that fixes one link's angle alone is eliminated from the Newton unknowns (the
  angle set exactly from the driver value); the whole-system ``newton`` and the
  ``split-newton`` four-bar against the four-bar's circle intersection written here;
* the reduced Jacobian is singular exactly where the whole ``F_theta`` is (its
  determinant up to sign);
* the small solves in floats (Cramer's rule, one position's Newton) against NumPy's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core.sweep import Analysis
from mechsolve.groups import NewtonGroup
from mechsolve.groups.reduced import _rowmax_abs, _solve_small

A, B, C, D = 0.0265, 0.1056, 0.059, 0.0875  # crank, coupler, rocker, ground (m)
N = 360


def _fourbar(n: int) -> str:
    return f"""
ground: {{O2: [0, 0], O4: [{D}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{A}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{B}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{C}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 1 rad/s, start: 0}}
sweep: {{range: {360 * (n - 1) / n!r} deg, steps: {n - 1}}}
"""


def _by_circles(th2: np.ndarray, side: float) -> tuple[np.ndarray, np.ndarray]:
    """Coupler and rocker angles: B on the circles (A, b) and (O4, c), on the side
    ``side`` of the line A -> O4."""
    ax, ay = A * np.cos(th2), A * np.sin(th2)
    dx, dy = D - ax, -ay
    L = np.hypot(dx, dy)
    along = (B**2 - C**2 + L**2) / (2 * L)
    h = np.sqrt(B**2 - along**2)
    ex, ey = dx / L, dy / L
    bx = ax + along * ex - side * h * ey
    by = ay + along * ey + side * h * ex
    return np.arctan2(by - ay, bx - ax), np.arctan2(by, bx - D)


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize("method", ["newton", "split-newton"])
def test_fourbar_with_the_driven_angle_eliminated(method):
    mech = ms.loads(_fourbar(N))
    an = Analysis(mech, method)
    groups = [g for g in an.plan if isinstance(g, NewtonGroup)]
    assert groups and all(g.red is not None for g in groups)
    # the crank's angle is no Newton unknown: two angles left for the loop
    assert sum(g.red.sub.nb for g in groups) == 2
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    sol = an.solve(u, start=an.assemble(u0))
    assert sol.ok.all()
    st, ix = sol.state, an.system.index
    th2 = st.th[ix["crank"]]
    assert np.array_equal(th2, u)  # set from the driver value, not iterated
    # the side of A -> O4 the solver's B is on, at the start; then the whole turn
    bx, by = st.point(ix["rocker"], np.array([C, 0.0]))
    side = math.copysign(1.0, (D - A) * by[0] - 0.0 * (bx[0] - A))
    t3, t4 = _by_circles(th2, side)
    assert np.max(np.abs(_wrap(st.th[ix["coupler"]] - t3))) < 1e-12
    assert np.max(np.abs(_wrap(st.th[ix["rocker"]] - t4))) < 1e-12
    # velocities from the loop's derivative written here: J (w3, w4) = -dF/dth2
    c3, s3, c4, s4 = np.cos(t3), np.sin(t3), np.cos(t4), np.sin(t4)
    det = (-B * s3) * (-C * c4) - (C * s4) * (B * c3)
    r0, r1 = A * np.sin(th2), -A * np.cos(th2)
    w3 = ((-C * c4) * r0 - (C * s4) * r1) / det
    w4 = (-(B * c3) * r0 + (-B * s3) * r1) / det
    assert np.max(np.abs(st.w[ix["coupler"]] - w3)) < 1e-10 * np.max(np.abs(w3))
    assert np.max(np.abs(st.w[ix["rocker"]] - w4)) < 1e-10 * np.max(np.abs(w4))
    # the frames' rates: the coupler's origin is the crank pin A (w2 = 1, al2 = 0), the
    # rocker's point B turns about O4
    k = ix["coupler"]
    assert np.max(np.hypot(st.vx[k] + A * np.sin(th2), st.vy[k] - A * np.cos(th2))) < 1e-15
    assert np.max(np.hypot(st.ax[k] + A * np.cos(th2), st.ay[k] + A * np.sin(th2))) < 1e-15
    al4 = np.gradient(w4, th2[1] - th2[0])  # a difference quotient: to its own error
    vb = st.point_velocity(ix["rocker"], np.array([C, 0.0]))
    ab = st.point_acceleration(ix["rocker"], np.array([C, 0.0]))
    assert np.max(np.hypot(vb[0] + C * w4 * s4, vb[1] - C * w4 * c4)) < 1e-12
    want_ax = -C * al4 * s4 - C * w4**2 * c4
    want_ay = C * al4 * c4 - C * w4**2 * s4
    assert np.max(np.hypot(ab[0] - want_ax, ab[1] - want_ay)[1:-1]) < 1e-3 * C


@pytest.mark.parametrize("method", ["newton", "split-newton"])
def test_fourbar_few_positions_next_to_a_sweep(method):
    """Small calls (an instant, a dynamics step): 1 to 4 positions next to a solved
    sweep, against the circles and the loop's derivative written here; the driven
    crank's rates exactly the driver's (a constant signed permutation, no inverse)."""
    mech = ms.loads(_fourbar(N))
    an = Analysis(mech, method)
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    start = an.assemble(u0)
    sol = an.solve(u, start=start)
    ix = an.system.index
    bx, by = sol.state.point(ix["rocker"], np.array([C, 0.0]))
    side = math.copysign(1.0, (D - A) * by[0])
    for k, x in ((0, [0.3]), (100, [1.71, 1.72]), (200, [3.4, 3.5, 3.6, 3.7])):
        one = an.solve(np.array(x), start=start, near=(sol, k))
        st = one.state
        assert one.ok.all()
        t3, t4 = _by_circles(np.array(x), side)
        assert np.max(np.abs(_wrap(st.th[ix["coupler"]] - t3))) < 1e-12
        assert np.max(np.abs(_wrap(st.th[ix["rocker"]] - t4))) < 1e-12
        assert np.all(st.w[ix["crank"]] == 1.0) and np.all(st.al[ix["crank"]] == 0.0)
        c3, s3, c4, s4 = np.cos(t3), np.sin(t3), np.cos(t4), np.sin(t4)
        det = (-B * s3) * (-C * c4) - (C * s4) * (B * c3)
        r0, r1 = A * np.sin(x), -A * np.cos(x)
        w4 = (-(B * c3) * r0 + (-B * s3) * r1) / det
        assert np.max(np.abs(st.w[ix["rocker"]] - w4)) < 1e-10 * np.max(np.abs(w4))
        k2 = ix["coupler"]
        assert np.max(np.hypot(st.ax[k2] + A * np.cos(x), st.ay[k2] + A * np.sin(x))) < 1e-15


def test_reduced_jacobian_singular_with_the_whole():
    an = Analysis(ms.loads(_fourbar(8)), "newton")
    (g,) = an.plan
    red = g.red
    assert red.nb == 3 and red.sub.nb == 2 and red.fixed.size == 1
    rng = np.random.default_rng(1)
    th = rng.uniform(-np.pi, np.pi, (50, 3))
    full = np.linalg.det(red.jacobian(np.cos(th), np.sin(th)))
    tf = th[:, red.free]
    part = np.linalg.det(red.sub.jacobian(np.cos(tf), np.sin(tf)))
    assert np.allclose(np.abs(full), np.abs(part), rtol=1e-12, atol=1e-18)


def test_solve_small_against_numpy():
    rng = np.random.default_rng(2)
    for n in (1, 2, 3):
        for _ in range(20):
            J = rng.normal(size=(n, n))
            f = rng.normal(size=n)
            got = _solve_small(J.tolist(), f.tolist())
            assert np.allclose(got, np.linalg.solve(J, -f), rtol=1e-10, atol=1e-12)
        assert _solve_small(np.zeros((n, n)).tolist(), [1.0] * n) is None


def test_newton_floats_against_the_numpy_newton():
    an = Analysis(ms.loads(_fourbar(8)), "newton")
    (g,) = an.plan
    sub = g.red.sub
    rng = np.random.default_rng(3)
    th_true = np.array([0.4, 1.9])
    C_, S_ = np.cos(th_true)[None], np.sin(th_true)[None]
    K = -sub.residual(th_true[None], C_, S_, np.zeros((1, 2)))[0]  # F(th_true) = 0
    for _ in range(10):
        th0 = th_true + rng.uniform(-0.05, 0.05, 2)
        th, stats = sub.newton_floats(K, th0, 1e-12, 30)
        assert stats.converged and stats.method == "newton"
        assert np.max(np.abs(th - th_true)) < 1e-12
    # no solution near a guess far off: it reports failure (the caller's scipy fallback)
    th, stats = sub.newton_floats(K + 10.0, th_true, 1e-12, 30)
    assert not stats.converged


def test_one_position_poses_by_hand():
    """The frames placed from the angles at one position: the crank's and the rocker's
    at their ground pivots, the coupler's at the crank pin A."""
    an = Analysis(ms.loads(_fourbar(8)), "newton")
    (g,) = an.plan
    st = an.assemble(0.0).state
    _, Px, Py = g.red.known(st)
    order = {b: k for k, b in enumerate(g.bodies)}
    ix = an.system.index
    th_c = 0.7  # a closed loop (the tree's frames then meet at its closing joint too)
    t3, t4 = _by_circles(np.array([th_c]), 1.0)
    th = np.empty(3)
    th[order[ix["crank"]]], th[order[ix["coupler"]]], th[order[ix["rocker"]]] = th_c, t3[0], t4[0]
    xs, ys = g.red.poses_one(th, Px[0], Py[0])
    want = {"crank": (0.0, 0.0), "coupler": (A * math.cos(th_c), A * math.sin(th_c))}
    want["rocker"] = (D, 0.0)
    for name, (x, y) in want.items():
        k = order[ix[name]]
        assert abs(xs[k] - x) < 1e-14 and abs(ys[k] - y) < 1e-14


def test_rowmax_abs_keeps_nan():
    """A position whose step is NaN (an exactly singular Jacobian) must stay NaN, so that
    it never counts as converged."""
    a = np.array([[1.0, -3.0, 2.0], [np.nan, 0.0, 1.0], [0.5, -0.25, np.nan], [-7.0, 0, 0]])
    got = _rowmax_abs(a)
    assert got[0] == 3.0 and got[3] == 7.0
    assert np.isnan(got[1]) and np.isnan(got[2])


def test_methods_text_uniform_and_mixed():
    """How each position was solved: one text for a whole batched sweep is kept as one
    string until a position differs; the result is the same as position by position."""
    from mechsolve.core.sweep import _Methods

    m = _Methods(4)
    assert m.array() is None  # all closed form
    m.merge(np.array(["newton"] * 4, dtype=object))
    m.merge(np.array(["newton (batched)"] * 4, dtype=object))
    assert list(m.array()) == ["newton+newton (batched)"] * 4
    m = _Methods(3)
    m.merge(np.array(["newton"] * 3, dtype=object))
    m.merge(np.array(["newton", "", "scipy-hybr"], dtype=object))
    m.append(1, "newton polish")
    assert list(m.array()) == ["newton+newton", "newton+newton polish", "newton+scipy-hybr"]
    m = _Methods(2)
    m.merge(np.array(["", ""], dtype=object))
    assert m.array() is None
    # a group's sweep gives one text for all positions as a plain string
    m = _Methods(3)
    m.merge("")
    assert m.array() is None
    m.merge("newton")
    m.merge("newton (batched)")
    assert list(m.array()) == ["newton+newton (batched)"] * 3
    m = _Methods(3)
    m.merge(np.array(["", "newton", ""], dtype=object))
    m.merge("newton (batched)")
    assert list(m.array()) == ["newton (batched)", "newton+newton (batched)", "newton (batched)"]


@pytest.mark.parametrize("max_jump", [None, 0.004])
def test_coarse_continuation_in_floats(monkeypatch, max_jump):
    """The four-bar's coarse continuation over 3600 positions: its first step predicted
    along the tangent, every step is plain (no substeps); with a jump limit small enough
    that steps are not plain, those go through the general step (substeps) from the
    same history. Either way the whole turn matches the circles."""
    from mechsolve.groups import generic, newton_batched

    calls = []
    advance = NewtonGroup._advance

    def counting(self, *args, **kwargs):
        calls.append(args[1])
        return advance(self, *args, **kwargs)

    monkeypatch.setattr(NewtonGroup, "_advance", counting)
    if max_jump is not None:
        # the continuation's step limit, where the sequential and the batched sweeps read it
        monkeypatch.setattr(generic, "MAX_JUMP", max_jump)
        monkeypatch.setattr(newton_batched, "MAX_JUMP", max_jump)
    n = 3600
    an = Analysis(ms.loads(_fourbar(n)), "split-newton")
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    sol = an.solve(u, start=an.assemble(u0))
    assert sol.ok.all()
    assert (len(calls) > 5) if max_jump else not calls
    st, ix = sol.state, an.system.index
    t3, t4 = _by_circles(st.th[ix["crank"]], 1.0)
    assert np.max(np.abs(_wrap(st.th[ix["coupler"]] - t3))) < 1e-12
    assert np.max(np.abs(_wrap(st.th[ix["rocker"]] - t4))) < 1e-12
