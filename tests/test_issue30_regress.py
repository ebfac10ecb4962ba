"""A sequential Newton sweep's per-step checks at the old speed: the determinant whose
sign it follows (Hadamard's ratio) in floats from the angles alone, against the
four-bar's closed form; no second reduction of the loop equations per position; the
continuation's angle correction and jump measured from one difference, against hand
values."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.core.sweep import Analysis
from mechsolve.groups.generic import _near_angles
from mechsolve_bench import _triad_mech, fourbar_yaml
from mechsolve_bench import references as R


def _sequential(mech, method: str = "newton"):
    an = Analysis(mech, method)
    for g in an.plan:
        if hasattr(g, "batched"):
            g.batched = False
    u, _ = an.sweep_values(an.start_value())
    return an, u, an.solve(u, start=an.assemble(u[0]))


def test_four_bars_determinant_ratio_is_the_closed_form():
    """The whole four-bar as one group (its crank fixed by the driver): F_theta in the
    coupler's and rocker's angles is [[-b s3, c s4], [b c3, -c c4]] up to signs of rows
    and columns, so its Hadamard ratio is b c sin(th4 - th3) over the rows' lengths."""
    n = 36
    an, u, sol = _sequential(ms.loads(fourbar_yaml(n)))
    assert sol.ok.all()
    g = an.plan[0]
    assert g.red.sub.nb == 2
    st = sol.state
    b, c = R.B3, R.C4
    for i in range(n):
        th3, th4 = st.th[1, i], st.th[2, i]
        rows = math.hypot(b * math.sin(th3), c * math.sin(th4)) * math.hypot(
            b * math.cos(th3), c * math.cos(th4)
        )
        want = abs(b * c * math.sin(th4 - th3)) / rows
        got = g._det(None, u[i : i + 1], g.get_q(st, i))
        assert abs(abs(got) - want) <= 1e-13, i
        assert got == g.red.sub.det_ratio([th3, th4])


@pytest.mark.parametrize("nb", [2, 3, 4])
def test_determinant_ratio_in_floats_is_lapacks(nb):
    """Any group of two to four angles: the ratio from LAPACK's determinant of the
    Jacobian written out by hand (M2 cos - M1 sin + M3) and NumPy's row norms; 0 where
    a row vanishes or an angle is not finite (NaN or infinite, where math.cos raises)."""
    from mechsolve.groups.reduced import _Eqs

    rng = np.random.default_rng(nb)
    for trial in range(200):
        M = rng.normal(size=(nb, 3 * nb)) * rng.uniform(0.01, 10)
        M[:, 2 * nb :] *= trial % 2  # half with angle terms (sliders' drivers), half none
        eqs = _Eqs(M)
        th = rng.uniform(-7, 7, nb)
        J = M[:, nb : 2 * nb] * np.cos(th) - M[:, :nb] * np.sin(th) + M[:, 2 * nb :]
        want = np.linalg.det(J) / np.prod(np.linalg.norm(J, axis=1))
        assert eqs.det_ratio(th.tolist()) == pytest.approx(want, rel=1e-12, abs=1e-15)
    Z = np.zeros((nb, 3 * nb))
    assert _Eqs(Z).det_ratio([0.3] * nb) == 0.0
    for bad in (math.nan, math.inf, -math.inf):
        assert _Eqs(np.ones((nb, 3 * nb))).det_ratio([bad] + [0.1] * (nb - 1)) == 0.0


@pytest.mark.parametrize("which", ["fourbar", "triad"])
def test_sequential_sweep_reduces_the_loop_equations_once_per_solve(which, monkeypatch):
    """The determinant of each step needs only the solved angles: the loop equations'
    constant part is reduced for the Newton solves alone (before: once more per
    position, for the determinant), and the sweep still solves every position."""
    mech = ms.loads(fourbar_yaml(48)) if which == "fourbar" else _triad_mech(48)
    an = Analysis(mech, "newton" if which == "fourbar" else "auto")
    g = an.plan[-1]
    for h in an.plan:
        if hasattr(h, "batched"):
            h.batched = False
    counts = {"reduce": 0, "solve": 0}
    red, solve_one = g.red.reduce, g._solve_one

    def reduce(Ku):
        counts["reduce"] += 1
        return red(Ku)

    def solve(*a, **k):
        counts["solve"] += 1
        return solve_one(*a, **k)

    monkeypatch.setattr(g.red, "reduce", reduce)
    monkeypatch.setattr(g, "_solve_one", solve)
    u, _ = an.sweep_values(an.start_value())
    sol = an.solve(u, start=an.assemble(u[0]))
    assert sol.ok.all()
    assert counts["solve"] >= len(u)
    assert counts["reduce"] <= counts["solve"]


def test_near_angles_and_jump_from_one_difference_are_the_hand_values():
    """A step's pose against its prediction: an angle that landed a whole turn away is
    moved back (2 pi + 0.01 -> 0.01 from 0) and the jump is the largest of the angles'
    change in radians and the positions' change over the size (0.1 m over 2 m)."""
    an = Analysis(ms.loads(fourbar_yaml(8)), "newton")
    g = an.plan[0]
    g.scale = 2.0
    pred = np.zeros(9)
    q = pred.copy()
    q[2] = 2 * math.pi + 0.01
    q[0] = 0.1
    got, jump = g._near_jump(q, pred)
    assert got[2] == pytest.approx(0.01, abs=1e-15)
    assert jump == pytest.approx(0.05, abs=1e-15)  # 0.1 m / 2 m
    q[2] = 0.03  # no whole turn: the same array, the angle's change the largest
    got, jump = g._near_jump(q, pred)
    assert got is q and jump == 0.05
    q[5] = 0.2
    assert g._near_jump(q, pred)[1] == 0.2
    rng = np.random.default_rng(1)
    for _ in range(200):  # the same values as the two checks one after the other
        qp = rng.normal(size=9)
        qq = qp + rng.normal(size=9) * rng.choice([0.01, 1.0, 10.0])
        got, jump = g._near_jump(qq, qp)
        near = _near_angles(qq, qp)
        assert np.array_equal(got, near) and jump == g._jump(near, qp)
