"""The one-design call's kept parts (mechsolve.core.kept, Analysis.sweep_values): the
sweep's values kept per analysis are each call's own arrays and follow every edit of the
sweep and the driver; an unchanged model found by its validated snapshot gets the
method it asks for. Each result is checked against Norton's closed form."""

from __future__ import annotations

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core import kept
from mechsolve_bench import references as R

A, B, C, D = 0.0265, 0.1056, 0.059, 0.0875


def _yaml(n: int = 360) -> str:
    return f"""
name: four-bar
ground: {{O2: [0, 0], O4: [{D!r}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{A!r}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{B!r}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{C!r}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 1 rad/s, start: 0}}
sweep: {{range: {360 * (n - 1) / n!r} deg, steps: {n - 1}}}
"""


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def _check(res, u_want, w2=1.0):
    """The crank angles are ``u_want``; the rocker's angle, rate and acceleration are
    Norton's (open branch) at those angles, and the times are the travel over the speed."""
    np.testing.assert_allclose(res.u, u_want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.t, np.abs(u_want - u_want[0]) / abs(w2), rtol=0, atol=1e-12)
    _, th4, _, w4, _, al4 = R.fourbar_textbook(np.asarray(u_want), w2, A, B, C, D)
    st = res.solution.state
    assert np.max(np.abs(_wrap(st.th[2] - th4))) < 1e-11
    assert np.max(np.abs(st.w[2] - w4)) <= 1e-9 * np.max(np.abs(w4))
    assert np.max(np.abs(st.al[2] - al4)) <= 1e-9 * np.max(np.abs(al4))


@pytest.fixture(autouse=True)
def _fresh():
    kept.forget()
    yield
    kept.forget()


def test_the_sweeps_values_are_each_calls_own():
    mech = ms.loads(_yaml())
    u = np.radians(np.arange(360.0))
    r1 = ms.solve(mech, forces=False)
    _check(r1, u)
    r1.u[:] = 7.0  # a caller writing into its results' arrays
    r1.t[:] = -1.0
    r2 = ms.solve(mech, forces=False)
    _check(r2, u)
    assert not np.shares_memory(r1.u, r2.u) and not np.shares_memory(r1.t, r2.t)
    _check(ms.solve(mech, forces=False), u)


def test_the_sweeps_values_follow_the_sweep_and_the_driver():
    mech = ms.loads(_yaml())
    _check(ms.solve(mech, forces=False), np.radians(np.arange(360.0)))
    # the sweep is not part of the analysis: the same kept analysis, new values
    mech.sweep.step = np.radians(2.0)
    mech.sweep.travel = np.radians(358.0)
    _check(ms.solve(mech, forces=False), np.radians(np.arange(0.0, 359.0, 2.0)))
    # a step given to the call (the last position is the sweep's end, 358 deg)
    want = np.radians(np.minimum(np.arange(0.0, 361.0, 3.0), 358.0))
    _check(ms.solve(mech, step="3 deg", forces=False), want)
    # the driver's speed and start
    mech.driver.speed = 2.5
    mech.driver.start = 0.25
    _check(ms.solve(mech, forces=False), 0.25 + np.radians(np.arange(0.0, 359.0, 2.0)), w2=2.5)
    # and back: the first values again
    mech.driver.speed, mech.driver.start = 1.0, 0.0
    mech.sweep.step, mech.sweep.travel = np.radians(1.0), np.radians(359.0)
    _check(ms.solve(mech, forces=False), np.radians(np.arange(360.0)))


def test_an_unchanged_model_gets_the_method_it_asks_for():
    mech = ms.loads(_yaml())
    u = np.radians(np.arange(360.0))
    for method in (None, "split-newton", None, "newton", None):
        res = ms.solve(mech, method=method, forces=False)
        _check(res, u)
        assert res.analysis.method == (method or "auto")
        newton = res.solution.methods is not None and any(
            "newton" in str(m) for m in res.solution.methods
        )
        assert newton == (method is not None)


def test_forgetting_one_model_keeps_the_others(monkeypatch):
    from mechsolve.system import constraints

    built = [0]
    real = constraints.ConstraintSystem.__init__

    def counting(self, *args, **kwargs):
        built[0] += 1
        real(self, *args, **kwargs)

    monkeypatch.setattr(constraints.ConstraintSystem, "__init__", counting)
    u = np.radians(np.arange(360.0))
    m1, m2 = ms.loads(_yaml()), ms.loads(_yaml())
    ms.solve(m1, forces=False)
    ms.solve(m2, forces=False)
    assert built[0] == 2
    kept.forget(m1)
    _check(ms.solve(m2, forces=False), u)  # still kept
    assert built[0] == 2
    _check(ms.solve(m1, forces=False), u)  # built again
    assert built[0] == 3
