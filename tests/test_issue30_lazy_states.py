"""Issue 30 (target 2): the one-design sweep and its kinetostatics do only the work that
something reads, and the trust checks stay, cheaper.

- a pin's reaction magnitude is computed when first read, and is |(Fx, Fy)|;
- the kinetostatics' test for singular and near-singular positions, now one reduction
  where a group is far from singular, still finds every such position (and a position
  where an earlier group failed, NaN in the indicator, is neither).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core import kinetostatics
from mechsolve.core.conditioning import NEAR_SINGULAR_INDICATOR, SINGULAR_INDICATOR
from mechsolve.core.kinetostatics import _Q

FOURBAR = """
name: four-bar with masses
ground: {O2: [0, 0], O4: [0.0875, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.0265, 0]}, mass: 0.05, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [0.1056, 0], P: [0.05, 0.02]}, mass: 0.2, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [0.059, 0]}, mass: 0.11, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 3 rad/s, start: 0}
sweep: {range: 350 deg, steps: 35}
gravity: 9.81 m/s^2
loads:
  F: {force: [1 N, -2 N], at: P}
"""


def test_pin_reaction_magnitude_is_computed_when_read() -> None:
    res = ms.solve(ms.loads(FOURBAR))
    for joint in ("O2", "A", "B", "O4"):
        # the force analysis's own reactions (res.reaction gives the caller copies of them)
        r = res.forces.reactions[joint]
        assert isinstance(r, Mapping)
        assert list(r) == ["Fx", "Fy", "F"] and len(r) == 3
        assert r._f is None  # nothing has read it yet
        fx, fy = np.asarray(r["Fx"]), np.asarray(r["Fy"])
        np.testing.assert_allclose(r["F"], np.hypot(fx, fy), rtol=1e-15, atol=0)
        assert r["F"] is r["F"]  # computed once
        assert dict(r).keys() == {"Fx", "Fy", "F"}
        np.testing.assert_array_equal(res.reaction(joint)["F"], r["F"])


def test_singular_and_near_singular_positions_are_still_found() -> None:
    mech = ms.loads(FOURBAR)
    res = ms.solve(mech)
    an, sol = res.analysis, res.solution
    n = len(sol.u)
    ind = np.array(sol.indicator, float)
    gi = next(k for k, g in enumerate(an.plan) if g.n_modes == 2)
    assert ind[gi].min() > NEAR_SINGULAR_INDICATOR  # the sweep itself is far from it
    ind[gi, 5] = 0.5 * NEAR_SINGULAR_INDICATOR  # near singular
    ind[gi, 7] = 0.5 * SINGULAR_INDICATOR  # singular
    ind[gi, 9] = np.nan  # an earlier group failed here: neither
    acc = _Q(an, sol.state)
    acc.Q[:] = 1.0
    lam, singular, _, near = kinetostatics._solve_groups(an, sol.state, acc.Q, ind, sol.ok)
    label = an.plan[gi].label
    assert singular == [(7, label)]
    assert sorted(near) == [5, 7]
    assert near[5] == ind[gi, 5] and near[7] == ind[gi, 7]
    # the group's reactions are empty at the singular position only
    assert np.isnan(lam[7]).any() and np.isfinite(np.delete(lam, [7, 9], axis=0)).all()
    assert lam.shape == (n, an.system.nc)


def test_constants_are_shared_between_states_and_read_only() -> None:
    from mechsolve.base.state import State

    for n in (4, 3600):
        a, b = State(2, n), State(3, n)
        xa, _ = a.point(2, np.array([0.0875, -0.01]))
        xb, _ = b.point(3, np.array([0.0875, 0.5]))
        assert xa is xb and not xa.flags.writeable
        np.testing.assert_array_equal(xa, np.full(n, 0.0875))


def test_discriminant_is_computed_once_per_state() -> None:
    res = ms.solve(ms.loads(FOURBAR), forces=False)
    an = res.analysis
    g = next(g for g in an.plan if g.n_modes == 2)
    st = res.solution.state
    H, dH = g.disc(st)
    assert g.disc(st)[1] is dH  # the start's check and the branch analysis share it
    # the discriminant is sin^2 of the transmission angle (B on the coupler at M)
    th3, th4 = st.th[g.b1], st.th[g.b2]
    np.testing.assert_allclose(H, np.sin(th4 - th3) ** 2, rtol=0, atol=1e-12)


def test_analysis_grid_points_only_where_samples_are_further_apart_than_its_step() -> None:
    from mechsolve.base.state import State
    from mechsolve.core.branches import EVENT_STEP, _Context

    for step_deg, extra in ((1.9, 0), (1.0, 0), (2.5, 1), (5.0, 2)):
        text = FOURBAR.replace("steps: 35", f"step: {step_deg} deg")
        an = ms.solve(ms.loads(text), forces=False).analysis
        u, _ = an.sweep_values(0.0)
        ctx = _Context(an, State(an.system.nb, len(u)), u, None, {}, {})
        ctx.build_grid(EVENT_STEP)
        if extra == 0:
            assert ctx.grid is None
        else:
            ug, at_sample, _, _ = ctx.grid
            assert np.max(np.abs(np.diff(ug))) <= EVENT_STEP * (1 + 1e-12)
            assert np.count_nonzero(~at_sample) >= extra * (len(u) - 2)


def test_positions_cached_by_a_dyad_survive_the_scaling_of_the_rates() -> None:
    """The force analysis reads the dyad's ends and link vectors from the positions;
    turning rates per unit driver angle into time rates changes no position."""
    from mechsolve.core.evaluate import states
    from mechsolve.core.sweep import Analysis

    an = Analysis(ms.loads(FOURBAR))
    u, _ = an.sweep_values(0.0)
    sol = states(an, u)
    g = next(g for g in an.plan if g.n_modes == 2)
    st = sol.state
    assert g._ctoken == st.token and set(g.cache(st)) == {"ends", "g"}
    px, py, qx, qy, *_ = g.ends(st)
    g1x, g1y, g2x, g2y = g._g(st)
    mx, my = st.point(g.b1, g.sM1)  # M on link 1 and on link 2, from the poses
    nx, ny = st.point(g.b2, g.sM2)
    for a, b in ((px + g1x, mx), (py + g1y, my), (qx + g2x, nx), (qy + g2y, ny)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
    # the rates are the time rates (speed 3 rad/s): the dropped rate terms are not reused
    vpx, vpy, dvx, dvy = g._dv(st)
    vqx, vqy = st.point_velocity(g.k2, g.sQk)
    np.testing.assert_allclose(dvx, vqx - vpx, rtol=0, atol=0)
    np.testing.assert_allclose(np.hypot(vpx, vpy), 3.0 * 0.0265, rtol=1e-13)


def test_no_separating_force_pass_without_a_pair_that_has_one(monkeypatch) -> None:
    made = []
    init = _Q.__init__

    def counting(self, an, st):
        made.append(1)
        init(self, an, st)

    monkeypatch.setattr(_Q, "__init__", counting)
    ms.solve(ms.loads(FOURBAR))
    assert len(made) == 1  # the loads' own accumulator only


def test_rates_at_singular_positions_still_find_them() -> None:
    """The kinematics' check for (near-)singular positions is one reduction where a
    group is far from singular; an indicator below the thresholds is still found."""
    res = ms.solve(ms.loads(FOURBAR), forces=False)
    an, sol = res.analysis, res.solution
    gi = next(k for k, g in enumerate(an.plan) if g.n_modes == 2)
    assert an._singular_positions(sol)[0] == {}
    sol.indicator = np.array(sol.indicator, float)
    sol.indicator[gi, 4] = 0.5 * NEAR_SINGULAR_INDICATOR
    sol.indicator[gi, 6] = 0.5 * SINGULAR_INDICATOR
    sol.indicator[gi, 8] = np.nan
    sing_by, _, deep = an._singular_positions(sol)
    assert sing_by == {4: [gi], 6: [gi]}
    assert list(np.flatnonzero(deep)) == [6]


@pytest.mark.parametrize("written", [0, 5, 8, 11])
def test_state_rows_not_written_by_the_groups_start_at_zero(written) -> None:
    """Rows the closed-form groups fill whole are not zeroed first; the ground's rows
    (at rest, the identity frame) and the arrays no group writes are."""
    from mechsolve.base.state import State

    st = State(3, 50, written)
    g = st.nb
    for k, name in enumerate(State.ARRAYS):
        arr = getattr(st, name)
        assert np.all(arr[g] == (1.0 if name == "c" else 0.0))
        if k >= written:
            assert not np.any(arr[:g])


def test_positions_only_sweep_has_zero_rates() -> None:
    from mechsolve.core.sweep import Analysis

    an = Analysis(ms.loads(FOURBAR))
    sol = an.solve(np.array([0.3]), velocity=False, acceleration=False)
    st = sol.state
    assert np.all(np.isfinite(st.block[:5])) and not np.any(st.block[5:])
    sol = an.solve(np.array([0.3]), velocity=True, acceleration=False)
    assert np.all(np.isfinite(sol.state.block[:8])) and not np.any(sol.state.block[8:])


def test_a_point_velocity_from_the_arm_already_rotated_is_the_same() -> None:
    res = ms.solve(ms.loads(FOURBAR), forces=False)
    st = res.solution.state
    b = res.analysis.system.index["coupler"]
    s = np.array([0.05, 0.02])
    arm = st.rotated(b, s)
    for got, want in zip(st.point_velocity(b, s, arm=arm), st.point_velocity(b, s)):
        np.testing.assert_array_equal(got, want)
    # and the load's power is F . v_P, with v_P from the coupler's motion
    f = ms.solve(ms.loads(FOURBAR)).forces
    vx, vy = st.point_velocity(b, s)
    np.testing.assert_allclose(f.power_loads, 1.0 * vx - 2.0 * vy, rtol=1e-14, atol=1e-16)
