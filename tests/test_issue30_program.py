"""The narrower program of a recognised plan (mechsolve.core.program): the sweep of the
driver link and RRR / RRP dyads without the general sweep's machinery.

Checked against the textbook closed forms (Freudenstein's four-bar, the slider-crank by
the sine rule), against the general path (the program turned off) array by array, on a
near-toggle, a change point and an unassemblable range (where the program hands the sweep
to the general path: the same events, warnings, limits and failures), and that a plan it
does not recognise is solved by the general path."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core import kept, program
from mechsolve.core.sweep import Analysis
from tests import closed_form as cf


def _fourbar(
    a, b, c, d, n=360, step_deg=1.0, side="left", speed=2.0, masses=False, o2="ground, crank"
):
    extra = ""
    if masses:
        extra = "gravity: 9.81 m/s^2\nloads:\n  F: {force: [1 N, -2 N], at: P}\n"
    m = ", mass: 0.2, uniform_bar: [A, B]" if masses else ""
    return f"""
name: four-bar
ground: {{O2: [0, 0], O4: [{d!r}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a!r}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b!r}, 0], P: [0.01, 0.005]}}{m}}}
  rocker: {{points: {{O4: [0, 0], B: [{c!r}, 0]}}}}
joints: {{O2: [{o2}], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B {side} of A -> O4"]
driver: {{joint: O2, speed: {speed} rad/s, start: 0}}
sweep: {{range: {step_deg * (n - 1)!r} deg, steps: {n - 1}}}
{extra}"""


SLIDER_CRANK = """
name: slider-crank
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [0.05, 0]}}
  rod: {points: {A: [0, 0], C: [0.2, 0]}}
  piston: {points: {C: [0, 0]}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cylinder: {slider: [ground, piston], point: C, line: {through: [0, 0.01], angle: 0}}
assembly: ["C.x > A.x"]
driver: {joint: O, speed: 3 rad/s, start: 0}
sweep: {range: 359 deg, steps: 359}
"""


@pytest.fixture
def answered(monkeypatch):
    """Whether the program answered each sweep (True) or handed it on (False)."""
    calls: list[bool] = []
    orig = program.Program.sweep

    def spy(self, *args, **kw):
        out = orig(self, *args, **kw)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(program.Program, "sweep", spy)
    kept.forget()
    yield calls
    kept.forget()


def _both(mech, **kw):
    """The results with the program and with the general path alone."""
    kept.forget()
    with_program = ms.solve(mech, **kw)
    kept.forget()
    program.ENABLED = False
    try:
        general = ms.solve(mech, **kw)
    finally:
        program.ENABLED = True
    return with_program, general


def _same(r1, r2) -> None:
    """Every array of the two results equal (bit for bit, NaN where NaN), and the same
    start, events, warnings, failures and limits."""
    s1, s2 = r1.solution, r2.solution
    # the same bits (the signs of zeros too)
    assert np.array_equal(s1.state.block.view(np.int64), s2.state.block.view(np.int64))
    for name in ("u", "t", "ok", "indicator", "iterations", "ud", "udd"):
        assert np.array_equal(getattr(s1, name), getattr(s2, name), equal_nan=True), name
    for name in ("failures", "warnings", "events", "flips", "rates_by_limit"):
        assert getattr(s1, name) == getattr(s2, name), name
    assert s1.rates_undetermined == s2.rates_undetermined
    assert s1.methods is None and s2.methods is None
    assert (s1.start.modes, s1.start.reasons) == (s2.start.modes, s2.start.reasons)
    assert s1.start.group_modes == s2.start.group_modes
    assert np.array_equal(s1.start.state.block, s2.start.state.block)
    assert r1.warnings == r2.warnings
    if r1.forces is not None:
        f1, f2 = r1.forces, r2.forces
        assert np.array_equal(f1.effort, f2.effort, equal_nan=True)
        assert np.array_equal(f1.lam, f2.lam, equal_nan=True)
        assert f1.singular == f2.singular


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def test_fourbar_program_is_freudenstein_and_the_general_path(answered):
    a, b, c, d = 0.0265, 0.1056, 0.059, 0.0875
    mech = ms.loads(_fourbar(a, b, c, d))
    res, general = _both(mech)
    assert answered == [True, False]  # (the second with the program turned off)
    again = ms.solve(mech)  # a repeated solve: the kept analysis's program again
    assert answered[-1] is True
    assert np.array_equal(again.solution.state.block, res.solution.state.block)
    assert res.analysis.program is not None
    th2 = res.u
    assert np.allclose(th2, np.radians(np.arange(360)), atol=1e-12)
    th3, th4, w3, w4, al3, al4 = cf.fourbar(a, b, c, d, th2, 2.0, 1)
    st = res.solution.state
    assert np.max(np.abs(_wrap(st.th[1] - th3))) < 1e-11
    assert np.max(np.abs(_wrap(st.th[2] - th4))) < 1e-11
    for got, want in ((st.w[1], w3), (st.w[2], w4), (st.al[1], al3), (st.al[2], al4)):
        assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))
    # B, the coupler's end, from the rocker's angle
    bx, by = res.point("B").x, res.point("B").y
    assert np.allclose(bx, d + c * np.cos(th4), atol=1e-13)
    assert np.allclose(by, c * np.sin(th4), atol=1e-13)
    assert res.ok.all() and not res.failures and not res.solution.events
    _same(res, general)


def test_right_branch_and_forces_are_those_of_the_general_path(answered):
    mech = ms.loads(_fourbar(0.0265, 0.1056, 0.059, 0.0875, side="right", masses=True))
    res, general = _both(mech)
    assert answered and answered[0] is True
    assert res.solution.start.modes[1] == -1.0
    th2 = res.u
    _, th4, _, w4, _, _ = cf.fourbar(0.0265, 0.1056, 0.059, 0.0875, th2, 2.0, -1)
    assert np.max(np.abs(_wrap(res.solution.state.th[2] - th4))) < 1e-11
    _same(res, general)


@pytest.mark.parametrize("speed", [2.0, -1.5])
@pytest.mark.parametrize("o2", ["ground, crank", "crank, ground"])
def test_driver_either_way_round(answered, speed, o2):
    """The driver joint written either way round (the crank's angle is +u or -u of the
    joint's coordinate) and the crank turning either way: Freudenstein at the crank's
    angle, and the general path's arrays."""
    a, b, c, d = 0.0265, 0.1056, 0.059, 0.0875
    res, general = _both(ms.loads(_fourbar(a, b, c, d, speed=speed, o2=o2)))
    assert answered and answered[0] is True
    st = res.solution.state
    th2 = st.th[0]
    w2 = st.w[0]
    assert np.allclose(w2, speed if o2 == "ground, crank" else -speed, rtol=0, atol=1e-15)
    th3, th4, w3, w4, al3, al4 = cf.fourbar(a, b, c, d, th2, w2[0], 1)
    assert np.max(np.abs(_wrap(st.th[2] - th4))) < 1e-11
    assert np.max(np.abs(st.w[2] - w4)) <= 1e-9 * np.max(np.abs(w4))
    assert np.max(np.abs(st.al[2] - al4)) <= 1e-9 * np.max(np.abs(al4))
    _same(res, general)


def test_slider_crank_program_is_the_sine_rule(answered):
    mech = ms.loads(SLIDER_CRANK)
    res, general = _both(mech)
    assert answered and answered[0] is True  # the branch from 'C.x > A.x', as in general
    x, xd, xdd, phi, phid, phidd = cf.slider_crank(0.05, 0.2, 0.01, res.u, 3.0)
    st = res.solution.state
    assert np.max(np.abs(st.x[2] - x)) < 1e-13
    assert np.max(np.abs(st.vx[2] - xd)) <= 1e-10 * np.max(np.abs(xd))
    assert np.max(np.abs(st.ax[2] - xdd)) <= 1e-10 * np.max(np.abs(xdd))
    assert np.max(np.abs(_wrap(st.th[1] - phi))) < 1e-12
    assert np.max(np.abs(st.w[1] - phid)) <= 1e-10 * np.max(np.abs(phid))
    assert np.max(np.abs(st.al[1] - phidd)) <= 1e-10 * np.max(np.abs(phidd))
    assert res.solution.start.reasons[1] == general.solution.start.reasons[1] != ""
    _same(res, general)


def test_samples_further_apart_than_the_analysis_grid(answered):
    """10 deg samples: the branch analysis looks between them (its grid), as in general."""
    mech = ms.loads(_fourbar(0.0265, 0.1056, 0.059, 0.0875, n=36, step_deg=10.0))
    res, general = _both(mech)
    assert answered and answered[0] is True
    _, th4, *_ = cf.fourbar(0.0265, 0.1056, 0.059, 0.0875, res.u, 2.0, 1)
    assert np.max(np.abs(_wrap(res.solution.state.th[2] - th4))) < 1e-11
    _same(res, general)


def test_near_toggle_is_handed_to_the_general_path(answered):
    """b + c just above a + d: a near-singular minimum near 180 deg, its event and the
    rates next to it as the general path gives them."""
    mech = ms.loads(_fourbar(0.02, 0.07, 0.03002, 0.08))
    res, general = _both(mech)
    assert answered and answered[0] is False
    kinds = [e.kind for e in res.solution.events]
    assert kinds == ["near-singular"]
    assert abs(res.solution.events[0].u - math.pi) < math.radians(1.0)  # (settled early)
    _same(res, general)


@pytest.mark.parametrize("step", [1.0, 30.0, 7.0])
def test_change_point_bifurcation_is_handed_to_the_general_path(answered, step):
    """a + d = b + c: the links fold at 180 deg, a bifurcation (the branch flips there)
    and the rates there by their limit, as the general path gives them; with samples
    further apart than the analysis's grid too (found between them)."""
    n = int(round(359 / step)) + 1
    mech = ms.loads(_fourbar(0.25, 0.75, 0.5, 1.0, n=n, step_deg=step))
    res, general = _both(mech)
    assert answered and answered[0] is False
    assert [e.kind for e in res.solution.events] == ["bifurcation"]
    assert abs(res.solution.events[0].u - math.pi) < 1e-6
    if step == 1.0:
        assert res.solution.rates_by_limit
    _same(res, general)


def test_unassemblable_range_is_handed_to_the_general_path(answered):
    """A non-Grashof crank: the dyad does not close over a range of the turn; the same
    failures (reason, exact edges) and warnings as the general path."""
    mech = ms.loads(_fourbar(0.05, 0.06, 0.04, 0.08))
    res, general = _both(mech)
    assert answered and answered[0] is False
    assert res.failures and not res.ok.all()
    assert np.isfinite(res.failures[0].edge_in) and np.isfinite(res.failures[0].edge_out)
    # the edges are where |A O4| = b + c (the law of cosines)
    for edge in (res.failures[0].edge_in, res.failures[0].edge_out):
        ax, ay = 0.05 * math.cos(edge), 0.05 * math.sin(edge)
        assert abs(math.hypot(0.08 - ax, ay) - 0.10) < 1e-12
    _same(res, general)


def test_unrecognised_plan_takes_the_general_path(answered):
    """A plan solved by Newton's method (asked for) has no program; nor has an analysis
    built outside the kept ones."""
    mech = ms.loads(_fourbar(0.0265, 0.1056, 0.059, 0.0875))
    res = ms.solve(mech, method="newton")
    assert res.analysis.program is None
    assert answered == []
    _, th4, *_ = cf.fourbar(0.0265, 0.1056, 0.059, 0.0875, res.u, 2.0, 1)
    assert np.max(np.abs(_wrap(res.solution.state.th[2] - th4))) < 1e-9
    assert Analysis(mech).program is None


def test_recognised_plans():
    """The driver link with RRR and RRP dyads is recognised; an RPR dyad is not."""
    for text, want in (
        (_fourbar(0.0265, 0.1056, 0.059, 0.0875), True),
        (SLIDER_CRANK, True),
    ):
        kept.forget()
        assert (ms.solve(ms.loads(text)).analysis.program is not None) is want


def test_parallelogram_through_collinearity_between_coarse_samples(answered):
    """A parallelogram (branch from a sketch) sampled every 30 deg: the bifurcation at
    its collinear positions lies between samples, where the analysis's grid finds it
    (the driver link solved on the grid too); the coupler stays parallel to the ground."""
    text = """
ground: {O2: [0, 0], O4: [3, 0]}
links:
  crank: {points: {O2: [0, 0], A: [1, 0]}}
  coupler: {points: {A: [0, 0], B: [3, 0]}}
  rocker: {points: {O4: [0, 0], B: [1, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: {sketch: {B: [3.8, 0.6]}}
driver: {joint: O2, speed: 2 rad/s, start: 10 deg}
sweep: {range: 720 deg, step: 30 deg}
"""
    res, general = _both(ms.loads(text))
    assert answered and answered[0] is False
    assert res.ok.all()
    assert np.max(np.abs(_wrap(res.link("coupler").angle))) < 1e-12
    assert np.allclose(_wrap(res.link("rocker").angle - res.u), 0.0, atol=1e-12)
    _same(res, general)


@pytest.mark.parametrize("seed", range(12))
def test_random_fourbars_are_the_general_paths(seed):
    """Random four-bars (Grashof or not, either branch, conditions that are the dyad's own
    statement or not, steps finer and coarser than the analysis's grid, the driver either
    way round, with masses and a load): the same bits with the program as without, the
    same events, warnings, failures and errors."""
    rng = np.random.default_rng(seed)
    a, b, c, d = (float(x) for x in rng.uniform(0.5, 4.0, 4))
    side = "left" if rng.random() < 0.5 else "right"
    cond = [f"B {side} of A -> O4", "B.y > A.y", f"B {side} of O4 -> A"][seed % 3]
    step = float(rng.choice([0.5, 1.0, 1.9, 3.0, 10.0]))
    n = int(rng.integers(3, 300))
    speed = float(rng.choice([1.0, 2.5, -1.5]))
    o2 = "ground, crank" if rng.random() < 0.5 else "crank, ground"
    text = f"""
ground: {{O2: [0, 0], O4: [{d!r}, {0.3 * d!r}]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a!r}, 0]}}, mass: 0.1, uniform_bar: [O2, A]}}
  coupler: {{points: {{A: [0, 0], B: [{b!r}, 0], P: [0.3, -0.2]}}, mass: 0.2,
    uniform_bar: [A, B]}}
  rocker: {{points: {{O4: [0, 0], B: [{c!r}, 0]}}, mass: 0.1, uniform_bar: [O4, B]}}
joints: {{O2: [{o2}], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["{cond}"]
driver: {{joint: O2, speed: {speed} rad/s, start: {float(rng.uniform(-180, 180))!r} deg}}
sweep: {{range: {step * (n - 1)!r} deg, steps: {n - 1}}}
loads:
  F: {{force: [1 N, -2 N], at: P}}
"""
    mech = ms.loads(text)
    try:
        res, general = _both(mech)
    except ms.MechsolveError as exc:  # a start that cannot close: the same error
        kept.forget()
        program.ENABLED = False
        try:
            with pytest.raises(type(exc)) as again:
                ms.solve(ms.loads(text))
        finally:
            program.ENABLED = True
        assert str(again.value) == str(exc)
        return
    _same(res, general)
