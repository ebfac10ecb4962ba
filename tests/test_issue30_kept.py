"""The analysis kept between solves of an unchanged model (mechsolve.core.kept): built
once for repeated solves, built again after every kind of edit (each result checked
against the four-bar's closed form with the edited numbers), never shared between
calls, and the same answers from two threads solving one model."""

from __future__ import annotations

import dataclasses
import sys
import threading

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core import kept
from mechsolve.system import constraints
from mechsolve_bench import references as R

N = 360
A, B, C, D = 0.0265, 0.1056, 0.059, 0.0875


def _yaml(a=A, b=B, c=C, d=D, side="left"):
    return f"""
name: four-bar
ground: {{O2: [0, 0], O4: [{d!r}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a!r}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b!r}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c!r}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B {side} of A -> O4"]
driver: {{joint: O2, speed: 1 rad/s, start: 0}}
sweep: {{range: {360 * (N - 1) / N!r} deg, steps: {N - 1}}}
"""


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def _check(res, a=A, b=B, c=C, d=D, w2=1.0, start=0.0, branch=1.0):
    """The rocker's angle, rate and acceleration against Norton's closed form (open
    branch; the crossed one by the mirror image about the line O2 O4)."""
    th2 = res.u
    assert np.allclose(th2, start + np.radians(np.arange(N)), atol=1e-12)
    if branch > 0:
        _, th4, _, w4, _, al4 = R.fourbar_textbook(th2, w2, a, b, c, d)
    else:  # mirror: crank at -th2 on the open branch, angles and rates negated
        _, th4, _, w4, _, al4 = R.fourbar_textbook(-th2, -w2, a, b, c, d)
        th4, w4, al4 = -th4, -w4, -al4
    st = res.solution.state
    assert np.max(np.abs(_wrap(st.th[2] - th4))) < 1e-11
    assert np.max(np.abs(st.w[2] - w4)) <= 1e-9 * np.max(np.abs(w4))
    assert np.max(np.abs(st.al[2] - al4)) <= 1e-9 * np.max(np.abs(al4))


@pytest.fixture
def built(monkeypatch):
    """Counts the constraint systems built (one per new analysis)."""
    kept.forget()
    count = [0]
    real = constraints.ConstraintSystem.__init__

    def counting(self, *args, **kwargs):
        count[0] += 1
        real(self, *args, **kwargs)

    monkeypatch.setattr(constraints.ConstraintSystem, "__init__", counting)
    yield count
    kept.forget()


def test_repeated_solves_build_the_analysis_once(built):
    mech = ms.loads(_yaml())
    r1 = ms.solve(mech, forces=False)
    r2 = ms.solve(mech, forces=False)
    assert built[0] == 1
    _check(r1)
    _check(r2)
    # each call has its own analysis and groups (their caches are per call)
    assert r1.analysis is not r2.analysis
    assert all(g is not h for g, h in zip(r1.analysis.plan, r2.analysis.plan))
    assert r1.analysis.plan is r1.analysis.groups  # (the lazy start needs the same list)
    assert r1.analysis.mech is mech and r2.analysis.mech is mech


def test_an_equal_model_is_not_the_same_model(built):
    m1, m2 = ms.loads(_yaml()), ms.loads(_yaml())
    ms.solve(m1, forces=False)
    res = ms.solve(m2, forces=False)
    assert built[0] == 2 and res.analysis.mech is m2


def test_every_edit_gives_the_new_answer(built):
    mech = ms.loads(_yaml())
    _check(ms.solve(mech, forces=False))
    # a link's point moved in place (the coupler 10 mm longer)
    b2 = B + 0.01
    mech.link("coupler").points["B"] = (b2, 0.0)
    _check(ms.solve(mech, forces=False), b=b2)
    # a ground point replaced in its dict
    d2 = D + 0.005
    mech.ground["O4"] = (d2, 0.0)
    _check(ms.solve(mech, forces=False), b=b2, d=d2)
    # the driver's speed changed in place, then the driver replaced (another start)
    mech.driver.speed = 2.0
    _check(ms.solve(mech, forces=False), b=b2, d=d2, w2=2.0)
    mech.driver = dataclasses.replace(mech.driver, start=0.5)
    _check(ms.solve(mech, forces=False), b=b2, d=d2, w2=2.0, start=0.5)
    n = built[0]
    assert n == 5
    # the solver's tolerance (the analysis keeps it as atol)
    mech.solver.tolerance = 1e-11
    res = ms.solve(mech, forces=False)
    assert built[0] == n + 1 and res.analysis.atol == pytest.approx(1e-11 * res.analysis.scale)
    # the assembly condition is read from the model at every solve: the other branch
    mech.assembly.conditions = ms.loads(_yaml(side="right")).assembly.conditions
    _check(ms.solve(mech, forces=False), b=b2, d=d2, w2=2.0, start=0.5, branch=-1.0)
    # a link list edited: a link added and removed again, each a new structure
    extra = dataclasses.replace(mech.links[0], name="spare", points={"S": (0.0, 0.0)})
    mech.links.append(extra)
    assert kept.content_key(mech, None) != kept.content_key(ms.loads(_yaml()), None)
    mech.links.pop()
    _check(ms.solve(mech, forces=False), b=b2, d=d2, w2=2.0, start=0.5, branch=-1.0)
    # and back to the first numbers: the first answer again
    mech.link("coupler").points["B"] = (B, 0.0)
    mech.ground["O4"] = (D, 0.0)
    mech.driver = dataclasses.replace(mech.driver, speed=1.0, start=0.0)
    mech.assembly.conditions = ms.loads(_yaml()).assembly.conditions
    _check(ms.solve(mech, forces=False))


def test_a_newton_plan_or_a_field_that_cannot_be_pickled_is_not_kept(built):
    mech = ms.loads(_yaml())
    ms.solve(mech, method="newton", forces=False)
    ms.solve(mech, method="newton", forces=False)
    assert built[0] == 2 and not kept._KEPT
    mech.links[0].note = lambda: None  # (not picklable: no snapshot of the content)
    assert kept.content_key(mech, None) is None
    _check(ms.solve(mech, forces=False))
    _check(ms.solve(mech, forces=False))
    assert built[0] == 4 and not kept._KEPT


def test_an_array_edited_in_place_gives_the_new_answer(built):
    mech = ms.loads(_yaml())
    o4 = np.array([D, 0.0])
    mech.ground["O4"] = o4
    _check(ms.solve(mech, forces=False))
    o4[0] = D + 0.004  # the same array object, new numbers
    _check(ms.solve(mech, forces=False), d=D + 0.004)
    assert built[0] == 2


def test_two_threads_solving_one_model_agree():
    kept.forget()
    mech = ms.loads(_yaml())
    want = ms.solve(mech, forces=False).solution.state.block.copy()
    errors: list = []
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # switch threads as often as possible

    def work():
        try:
            for _ in range(25):
                got = ms.solve(mech, forces=False).solution.state.block
                if not np.array_equal(got, want, equal_nan=True):
                    errors.append(float(np.nanmax(np.abs(got - want))))
        except Exception as exc:  # noqa: BLE001 (reported below)
            errors.append(exc)

    try:
        threads = [threading.Thread(target=work) for _ in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(interval)
        kept.forget()
    assert errors == []
