"""The bench's floor program (the vector-form closed form with the checks of mechsolve's
one-design call, by hand): right against Norton's closed form and the law of cosines,
and its checks fire where mechsolve's do (a near-toggle, a change-point bifurcation, an
unassemblable range)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve_bench import references as R
from mechsolve_bench.floor import fourbar_floor

N = 3600
TH = np.linspace(0.0, 2 * np.pi, N, endpoint=False)


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def _yaml(a, b, c, d, n=N):
    return f"""
name: four-bar
ground: {{O2: [0, 0], O4: [{d!r}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a!r}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b!r}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c!r}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 1 rad/s, start: 0}}
sweep: {{range: {360 * (n - 1) / n!r} deg, steps: {n - 1}}}
"""


def _transmission_sine(a, b, c, d, th):
    """|sin| of the angle at B by the law of cosines."""
    D2 = a * a + d * d - 2 * a * d * np.cos(th)
    cos_mu = (b * b + c * c - D2) / (2 * b * c)
    return np.sqrt(1.0 - cos_mu**2)


def test_floor_is_the_closed_form_with_its_outputs():
    w2 = 2.5
    f = fourbar_floor(TH, w2)
    th3, th4, w3, w4, al3, al4 = R.fourbar_textbook(TH, w2)
    assert np.max(np.abs(_wrap(f.th3 - th3))) < 1e-12
    assert np.max(np.abs(_wrap(f.th4 - th4))) < 1e-12
    for got, want in ((f.w3, w3), (f.w4, w4), (f.al3, al3), (f.al4, al4)):
        assert np.max(np.abs(got - want)) <= 1e-10 * np.max(np.abs(want))
    a, b, c, d = R.A2, R.B3, R.C4, R.D1
    assert np.allclose(f.ax, a * np.cos(TH), atol=1e-15)
    assert np.allclose(f.vay, a * w2 * np.cos(TH), atol=1e-14)
    assert np.allclose(f.aax, -a * w2 * w2 * np.cos(TH), atol=1e-13)
    assert np.allclose(np.hypot(f.bx - f.ax, f.by - f.ay), b, atol=1e-15, rtol=0)
    assert np.allclose(np.hypot(f.bx - d, f.by), c, atol=1e-15, rtol=0)
    assert np.allclose(f.t, TH / w2, atol=1e-15)
    assert f.ok.all() and not f.failures and not f.by_limit and not f.undetermined
    assert np.allclose(f.ind, _transmission_sine(a, b, c, d, TH), atol=1e-12)
    # the bench's crank-rocker: the least transmission angle is 28.9 deg, no event
    assert f.events == []
    # B is on the left of A -> O4 (the assembly condition) everywhere
    assert np.all((d - f.ax) * (f.by - f.ay) - (-f.ay) * (f.bx - f.ax) > 0)
    assert f.residual is None
    assert fourbar_floor(TH, w2, residual=True).residual < 1e-15


def test_the_condition_sets_the_branch():
    f = fourbar_floor(TH, side="right")
    d = R.D1
    assert np.all((d - f.ax) * (f.by - f.ay) - (-f.ay) * (f.bx - f.ax) < 0)


def test_near_toggle_is_an_event_as_mechsolve_finds_it():
    a, b, c, d = 0.02, 0.07, 0.03002, 0.08  # b + c just above a + d: near-toggle at 180 deg
    f = fourbar_floor(TH, 1.0, "left", a, b, c, d)
    assert [e[0] for e in f.events] == ["near-singular"]
    kind, u, after, mu = f.events[0]
    step = TH[1]
    assert abs(u - math.pi) <= 0.5 * step + 1e-12
    mu_exact = math.asin(float(_transmission_sine(a, b, c, d, np.array([math.pi]))[0]))
    assert mu_exact < math.radians(3.0)
    assert abs(mu - mu_exact) < 1e-6
    sol = ms.solve(ms.loads(_yaml(a, b, c, d)), forces=False).solution
    assert [(e.kind, e.u, e.transmission) for e in sol.events] == [(kind, u, mu)]
    assert f.ok.all() and np.array_equal(sol.ok, f.ok)


def test_change_point_bifurcation_flips_the_branch_and_takes_limits():
    a, b, c, d = 0.25, 0.75, 0.5, 1.0  # a + d = b + c: the links fold at 180 deg
    f = fourbar_floor(TH, 1.0, "left", a, b, c, d)
    assert [(e[0], e[1]) for e in f.events] == [("bifurcation", math.pi)]
    k = N // 2  # the sample at 180 deg
    # before it on the left branch, after it on the right one (the smooth motion)
    side = (d - f.ax) * (f.by - f.ay) + f.ay * (f.bx - f.ax)
    assert np.all(side[1:k] > 0) and np.all(side[k + 1 :] < 0)
    # rates at the fold by their limit, finite; the same as mechsolve's
    assert f.by_limit == [k] and not f.undetermined
    assert np.isfinite([f.w3[k], f.w4[k], f.al3[k], f.al4[k]]).all()
    sol = ms.solve(ms.loads(_yaml(a, b, c, d)), forces=False).solution
    assert sol.rates_by_limit == [k]
    assert [(e.kind, e.u) for e in sol.events] == [("bifurcation", math.pi)]
    for got, want in ((f.w3, sol.state.w[1]), (f.w4, sol.state.w[2]), (f.al4, sol.state.al[2])):
        assert np.max(np.abs(got - want)) <= 1e-8 * np.max(np.abs(want))


def test_unassemblable_range_is_reported_with_its_edges():
    a, b, c, d = 0.05, 0.06, 0.04, 0.08  # non-Grashof: the crank cannot turn round
    f = fourbar_floor(TH, 1.0, "left", a, b, c, d)
    D = np.sqrt(a * a + d * d - 2 * a * d * np.cos(TH))
    assert np.array_equal(f.ok, D <= b + c)
    assert np.all(np.isnan(f.th3[~f.ok])) and np.all(np.isnan(f.al4[~f.ok]))
    assert np.all(np.isfinite(f.th3[f.ok])) and np.all(f.ind[~f.ok] == 0.0)
    edge = math.acos((a * a + d * d - (b + c) ** 2) / (2 * a * d))  # where |AO4| = b + c
    (first, last, reason, e_in, e_out), *rest = f.failures
    assert not rest
    assert TH[first - 1] < edge < TH[first] and TH[last] < 2 * np.pi - edge < TH[last + 1]
    assert e_in == pytest.approx(edge, abs=1e-12)
    assert e_out == pytest.approx(2 * np.pi - edge, abs=1e-12)
    assert "cannot close" in reason and f.events == []
    sol = ms.solve(ms.loads(_yaml(a, b, c, d)), forces=False).solution
    assert [(x.first, x.last) for x in sol.failures] == [(first, last)]
    assert np.array_equal(sol.ok, f.ok)
