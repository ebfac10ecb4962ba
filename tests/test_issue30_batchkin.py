"""The kinematics-only design batch: a dyad between the driven crank and the ground is
screened with a bound on the rate of its discriminant made from each design's numbers
(:func:`mechsolve.analyses.batch_program._dH_bound`), checked here against the rate
written from the four-bar's triangle by hand; the designs it keeps are those whose
discriminant, by the same hand formula, stays clear of zero between the samples; and
``solve_designs`` validates an edited design as ``mechsolve.solve`` does."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses import batch_program
from mechsolve.analyses.batch import solve_designs
from mechsolve.analyses.study.designs import make_study
from mechsolve.base.errors import InputError
from mechsolve.model.source import load_text

FOURBAR = """
name: four-bar designs
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}, mass: 0.05 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}, mass: 0.2 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [59, 0]}, mass: 0.11 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 2 deg}
"""
# frames off the joints: the crank's frame origin is not its pivot, the ground pivot is
# off the origin (the bound's distances are measured from the pivot, not the frames)
OFFSET = """
name: four-bar, frames off the joints
units: {length: mm, angle: deg}
ground: {O2: [12, -7], O4: [99.5, -7]}
links:
  crank: {points: {O2: [5, 3], A: [31.5, 3]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 2 deg}
"""


def _hand(a: float, b: float, c: float, d: float, u: np.ndarray):
    """The dyad's discriminant and its rate per unit crank angle, by hand: A on the crank
    circle, D2 = |O4 - A|^2, H = (4 b^2 D2 - (b^2 - c^2 + D2)^2) / (4 b^2 c^2) (the
    squared sine of the angle at B), dH/du = dH/dD2 dD2/du with
    dD2/du = 2 a d sin u."""
    D2 = a * a + d * d - 2 * a * d * np.cos(u)
    H = (4 * b * b * D2 - (b * b - c * c + D2) ** 2) / (4 * b * b * c * c)
    dH_dD2 = (4 * b * b - 2 * (b * b - c * c + D2)) / (4 * b * b * c * c)
    return H, dH_dD2 * 2 * a * d * np.sin(u)


def _bounds(monkeypatch) -> list:
    """The bounds the program forms, per pass: (designs,) arrays (or floats)."""
    got = []
    real = batch_program._crank_bound

    def spy(crank, g, num):
        out = real(crank, g, num)
        got.append((out, num.one(g.L1), num.one(g.L2)))
        return out

    monkeypatch.setattr(batch_program, "_crank_bound", spy)
    return got


@pytest.mark.parametrize("text,a0", [(FOURBAR, 0.0), (OFFSET, 0.005)])
def test_bound_covers_the_discriminant_rate_by_hand(monkeypatch, text, a0):
    """k * bound >= max |dH/du| over a fine grid of the crank angle, for every design
    (k = 1 / (L1^2 L2^2), the factor the screening applies), and it is not loose by more
    than the triangle's distances allow (within a factor of 12 here)."""
    a_vals = [20.0, 24.0, 27.0, 30.0]
    b_vals = [95.0, 100.0, 105.0, 110.0]
    opts = [
        "links.crank.points.A[0]=" + ", ".join(f"{a0 * 1e3 + a}" for a in a_vals) + " mm",
        "links.coupler.points.B[0]=" + ", ".join(str(b) for b in b_vals) + " mm",
    ]
    study = make_study(load_text(text, "b.yaml"), opts)
    got = _bounds(monkeypatch)
    batch = solve_designs(
        [study.mechanism(k) for k in range(len(study))], forces=False, acceleration=False
    )
    assert batch.batched.all()
    assert len(got) == 1
    bound, L1, L2 = got[0]
    u = np.linspace(0, 2 * math.pi, 20001)
    for k in range(len(study)):
        a = study.values(k)[0] / 1e3 - a0  # the crank's length from its pivot
        b = study.values(k)[1] / 1e3
        _, dH = _hand(a, b, 0.059, 0.0875, u)
        Lb = L1 if np.ndim(L1) == 0 else float(np.ravel(L1)[k])
        Lc = L2 if np.ndim(L2) == 0 else float(np.ravel(L2)[k])
        assert {round(Lb, 12), round(Lc, 12)} == {round(b, 12), 0.059}
        kb = float(np.ravel(bound)[k] if np.ndim(bound) else bound) / (Lb * Lb * Lc * Lc)
        top = float(np.max(np.abs(dH)))
        assert kb >= top * (1 - 1e-9)
        assert kb <= 12 * top


def test_kept_designs_are_clear_of_zero_by_hand():
    """Crank lengths towards the Grashof limit (a + b = c + d at a = 41.9 mm): a design
    the batch keeps has, by the hand formula, H above sin^2 5 deg at every sample and
    H - h |dH| > 0; one whose smallest transmission angle is below 5 deg is solved on its
    own; the batch's indicator is sqrt(H) of the hand formula."""
    a_vals = [20.0, 30.0, 36.0, 39.0, 40.5, 41.5]
    opts = ["links.crank.points.A[0]=" + ", ".join(map(str, a_vals)) + " mm"]
    study = make_study(load_text(FOURBAR, "b.yaml"), opts)
    batch = solve_designs(
        [study.mechanism(k) for k in range(len(study))], forces=False, acceleration=False
    )
    h = math.radians(2.0)
    u = np.radians(np.arange(0.0, 360.0 + 1e-9, 2.0))
    near = math.sin(math.radians(5.0)) ** 2
    for k, a in enumerate(a_vals):
        H, dH = _hand(a / 1e3, 0.1056, 0.059, 0.0875, u)
        if batch.batched[k]:
            assert H.min() > near
            assert np.all(H - h * np.abs(dH) > 0)
            loop = next(i for i, g in enumerate(batch.results(k).analysis.plan) if g.n_modes == 2)
            ind = batch.results(k).solution.indicator[loop]
            np.testing.assert_allclose(ind, np.sqrt(H), atol=1e-12)
        if H.min() < near * 0.9:
            assert not batch.batched[k]
    assert batch.batched[:3].all() and not batch.batched.all()


def _edited(text: str, edit) -> tuple:
    """Three designs, the second edited after loading; the error mechsolve.solve gives."""
    mechs = [_load(text) for _ in range(3)]
    edit(mechs[1])
    with pytest.raises(InputError) as alone:
        ms.solve(mechs[1])
    return mechs, str(alone.value)


def _load(text: str):
    from mechsolve.model.parse import from_source

    return from_source(load_text(text, "edited.yaml"))


@pytest.mark.parametrize(
    "edit,says",
    [
        (lambda m: setattr(m.links[1], "mass", -1.0), "mass must be zero or positive"),
        (lambda m: setattr(m.sweep, "step", 0.0), "step must be positive"),
    ],
)
@pytest.mark.parametrize("forces", [False, None])
def test_solve_designs_validates_an_edited_design(edit, says, forces):
    mechs, alone = _edited(FOURBAR, edit)
    assert says in alone
    with pytest.raises(InputError) as batch:
        solve_designs(mechs, forces=forces)
    assert str(batch.value) == alone
    # unedited designs are not refused (checked by their content, as solve checks them)
    out = solve_designs([mechs[0], mechs[2], mechs[0]], forces=forces)
    assert out.batched.all()
