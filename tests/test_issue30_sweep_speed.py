"""Issue 30 (targets 2, 3): the speed work on the one-design sweep, kinetostatics and the
design batch must not change results.

The split of a structure into groups is now kept for structures already seen
(:func:`mechsolve.system.structure.decompose`): designs of one structure with other
dimensions must still get their own answers (Freudenstein's closed form), and a
structural error must still be diagnosed every time (it is not kept).
"""

from __future__ import annotations

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core.sweep import Analysis
from mechsolve.system import structure

from closed_form import fourbar


def _fourbar(a: float, b: float, c: float, d: float, masses: bool = False) -> str:
    m = ", mass: 0.2 kg, uniform_bar: [{}]" if masses else ""
    load = "gravity: 9.81 m/s^2\n" if masses else ""
    return f"""
name: four-bar
units: {{length: m, angle: deg}}
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}{m.format("O2, A")}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}{m.format("A, B")}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}{m.format("O4, B")}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 1.3 rad/s, start: 0.2 rad}}
sweep: {{range: 360 deg, step: 5 deg}}
{load}"""


def _branch_left(a, c, d, th2, th4) -> bool:
    ax, ay = a * np.cos(th2), a * np.sin(th2)
    bx, by = d + c * np.cos(th4), c * np.sin(th4)
    return (d - ax) * (by - ay) - (0 - ay) * (bx - ax) > 0


@pytest.mark.parametrize(
    "geoms",
    [[(1.0, 3.0, 2.5, 3.2), (0.2, 0.9, 0.5, 0.8), (2.0, 7.0, 9.0, 6.0), (1.0, 3.0, 2.5, 3.2)]],
)
def test_one_structure_other_dimensions_each_its_own_closed_form(geoms):
    structure._SPLITS.clear()
    for a, b, c, d in geoms:
        res = ms.solve(ms.loads(_fourbar(a, b, c, d)))
        th2 = res.u
        for branch in (1, -1):
            want = fourbar(a, b, c, d, th2, 1.3, branch)
            if _branch_left(a, c, d, th2[0], want[1][0]):
                break
        assert res.ok.all()
        rk = res.link("rocker")
        assert np.max(np.abs(np.angle(np.exp(1j * (rk.angle - want[1]))))) < 1e-10
        assert np.max(np.abs(rk.omega - want[3])) < 1e-9 * max(1.0, np.max(np.abs(want[3])))
        assert np.max(np.abs(rk.alpha - want[5])) < 1e-9 * max(1.0, np.max(np.abs(want[5])))
    assert len(structure._SPLITS) == 1  # one structure, kept once


def test_groups_hold_the_new_models_constraints():
    structure._SPLITS.clear()
    m1 = ms.loads(_fourbar(1.0, 3.0, 2.5, 3.2))
    m2 = ms.loads(_fourbar(0.2, 0.9, 0.5, 0.8))
    a1, a2 = Analysis(m1), Analysis(m2)
    cons2 = {id(c) for c in a2.system.constraints}
    for g in a2.plan:
        assert all(id(c) in cons2 for c in g.constraints)
    assert [type(g).__name__ for g in a1.plan] == [type(g).__name__ for g in a2.plan]
    assert a2.plan[-1].L1 == pytest.approx(0.9) and a1.plan[-1].L1 == pytest.approx(3.0)


def test_a_structural_error_is_diagnosed_every_time():
    from mechsolve.system.constraints import ConstraintSystem

    text = _fourbar(1.0, 3.0, 2.5, 3.2)
    no_driver = "\n".join(ln for ln in text.splitlines() if not ln.startswith("driver"))
    system = ConstraintSystem(ms.loads(no_driver))  # one degree of freedom left free
    structure._SPLITS.clear()
    for _ in range(2):
        with pytest.raises(structure.StructureError, match="degree"):
            structure.decompose(system)
    assert not structure._SPLITS


def test_kinetostatics_do_not_change_the_generalised_forces_they_are_given():
    """The group-by-group solve may overwrite Q only when told it owns it."""
    from mechsolve.core import evaluate
    from mechsolve.core.kinetostatics import _solve_groups

    mech = ms.loads(_fourbar(1.0, 3.0, 2.5, 3.2, masses=True))
    an = Analysis(mech)
    u, t = an.sweep_values(an.start_value())
    sol = evaluate.states(an, u, t=t)
    Q = np.random.default_rng(0).normal(size=(3 * an.system.nb, len(u)))
    Q0 = Q.copy()
    lam = _solve_groups(an, sol.state, Q, sol.indicator, sol.ok)[0]
    assert np.array_equal(Q, Q0)
    lam2 = _solve_groups(an, sol.state, Q, sol.indicator, sol.ok, own=True)[0]
    assert np.array_equal(lam, lam2)
