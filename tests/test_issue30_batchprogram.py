"""The kinematics-only design batch of a crank and RRR dyads runs a narrower program
(:mod:`mechsolve.analyses.batch_program`): checked against the four-bar's vector loop and
Freudenstein rates written here, against designs solved one by one through the public
API, on designs that do not assemble everywhere or pass near a toggle (the same rows as
separate solves), and on batches the program does not take (the general path)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses import batch_program
from mechsolve.analyses.batch import solve_designs
from mechsolve.analyses.study.designs import make_study
from mechsolve.analyses.study.execute import solve_chunk, solve_design
from mechsolve.model.source import load_text

FOURBAR = """
name: four-bar designs
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0], P: {length: 60, angle: 30}}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: SPEED, start: 10 deg}
sweep: {range: 360 deg, step: 3 deg}
"""
C, D = 0.059, 0.0875  # rocker and ground (m)


def _study(opts, speed="1 rad/s", text=FOURBAR):
    return make_study(load_text(text.replace("SPEED", speed), "p.yaml"), opts)


def _mechs(study):
    return [study.mechanism(k) for k in range(len(study))]


def _programs(batch) -> int:
    """How many of the batch's passes ran the narrower program."""
    return sum(1 for p in batch._passes if p.get("program") is not None)


def _fourbar(a, b, c, d, u, w2):
    """The four-bar by hand: B on the left of A -> O4 (vector loop), the rates by
    Freudenstein's relations, the transmission angle's sine."""
    ax, ay = a * np.cos(u), a * np.sin(u)
    ex, ey = d - ax, -ay
    r = np.hypot(ex, ey)
    f = (b * b - c * c + r * r) / (2 * r)
    h = np.sqrt(b * b - f * f)
    bx = ax + (f * ex - h * ey) / r
    by = ay + (f * ey + h * ex) / r
    th3 = np.arctan2(by - ay, bx - ax)
    th4 = np.arctan2(by, bx - d)
    w3 = a * w2 * np.sin(th4 - u) / (b * np.sin(th3 - th4))
    w4 = a * w2 * np.sin(th3 - u) / (c * np.sin(th3 - th4))
    return th3, th4, w3, w4, np.abs(np.sin(th3 - th4)), ax, ay


def _wrap(x):
    return np.angle(np.exp(1j * x))


@pytest.mark.parametrize("speed, w2", [("1 rad/s", 1.0), ("-150 rpm", -5 * math.pi)])
def test_program_against_the_four_bar_by_hand(speed, w2):
    study = _study(
        ["links.crank.points.A[0]=20, 25, 30 mm", "links.coupler.points.B[0]=96, 104, 110 mm"],
        speed,
    )
    batch = solve_designs(_mechs(study), forces=False, acceleration=False)
    assert batch.batched.all() and _programs(batch) == len(batch._passes) == 1
    for k in range(len(study)):
        a, b = (x / 1e3 for x in study.values(k))
        r = batch.results(k)
        u = r.u
        th3, th4, w3, w4, sin_mu, ax, ay = _fourbar(a, b, C, D, u, w2)
        cp, rk = r.link("coupler"), r.link("rocker")
        assert np.max(np.abs(_wrap(cp.angle - th3))) < 1e-13
        assert np.max(np.abs(_wrap(rk.angle - th4))) < 1e-13
        assert np.max(np.abs(cp.omega - w3)) < 1e-12 * abs(w2)
        assert np.max(np.abs(rk.omega - w4)) < 1e-12 * abs(w2)
        loop = next(i for i, g in enumerate(r.analysis.plan) if g.n_modes == 2)
        assert np.max(np.abs(r.solution.indicator[loop] - sin_mu)) < 1e-13
        A = r.point("A")
        assert np.max(np.abs(A.x - ax)) < 1e-16 and np.max(np.abs(A.y - ay)) < 1e-16
        assert r.solution.ok.all() and not r.solution.has_acceleration


def _same_state(r1, r2, rel=1e-12):
    s1, s2 = r1.solution.state, r2.solution.state
    for name in s1.ARRAYS:
        x, y = getattr(s1, name), getattr(s2, name)
        if name == "th":
            x, y = _wrap(x), _wrap(y)
        assert np.allclose(x, y, rtol=rel, atol=rel * (1 + np.max(np.abs(y)))), name


# frames away from the joints: the crank's off its pivot, the coupler's off A, the
# rocker's x axis not along O4-B (the general placing and the rates' arms)
ODD = FOURBAR.replace(
    "crank: {points: {O2: [0, 0], A: [26.5, 0]}}", "crank: {points: {O2: [5, 2], A: [31.5, 2]}}"
).replace("A: [0, 0], B: [105.6, 0]", "A: [10, -3], B: [115.6, -3]")
ODD = ODD.replace(
    "rocker: {points: {O4: [0, 0], B: [59, 0]}}", "rocker: {points: {O4: [1, 1], B: [37, 48]}}"
)
# the driver's angle measured along the crank's line O2-A, which is off its x axis
LINE = FOURBAR.replace(
    "crank: {points: {O2: [0, 0], A: [26.5, 0]}}", "crank: {points: {O2: [0, 0], A: [3, 26.5]}}"
).replace("driver: {joint: O2,", "driver: {joint: O2, line: [O2, A],")
LINE_OPTS = ["links.rocker.points.B[0]=57, 60 mm", "links.coupler.points.B[0]=100, 105, 110 mm"]
ODD_OPTS = ["links.crank.points.A[0]=25.5, 33.5 mm", "links.rocker.points.B[0]=35, 37, 39 mm"]


@pytest.mark.parametrize(
    "text, opts, acceleration, block",
    [
        (
            FOURBAR,
            ["links.crank.points.A[0]=20, 28 mm", "links.rocker.points.B[0]=55, 58, 62 mm"],
            False,
            None,
        ),
        (
            FOURBAR,
            ["links.crank.points.A[0]=20, 28 mm", "links.rocker.points.B[0]=55, 58, 62 mm"],
            False,
            3 * 121,
        ),
        (
            FOURBAR,
            ["links.crank.points.A[0]=20, 28 mm", "links.rocker.points.B[0]=55, 58, 62 mm"],
            True,
            3 * 121,
        ),
        (ODD, ODD_OPTS, True, None),
        (ODD, ODD_OPTS, False, 3 * 121),
        (LINE, LINE_OPTS, True, 3 * 121),
    ],
)
def test_program_equals_designs_solved_one_by_one(text, opts, acceleration, block, monkeypatch):
    """In one block and in blocks of 3 designs, with and without accelerations, frames on
    the joints or away from them, a driver measured along a line off the crank's axis,
    at -150 rpm."""
    if block is not None:
        monkeypatch.setattr(batch_program, "BLOCK_COLUMNS", block)
    study = _study(opts, "-150 rpm", text=text)
    mechs = _mechs(study)
    batch = solve_designs(mechs, forces=False, acceleration=acceleration)
    assert batch.batched.all() and _programs(batch) == 1
    blocks = batch._passes[0]["program"].blocks
    assert [b.nd for b in blocks] == ([6] if block is None else [3, 3])
    for k, m in enumerate(mechs):
        one = ms.solve(m, acceleration=acceleration)
        got = batch.results(k)
        _same_state(got, one)
        assert np.allclose(got.solution.indicator, one.solution.indicator, rtol=0, atol=1e-13)
        assert np.array_equal(got.solution.ok, one.solution.ok)
        assert got.solution.start.modes == one.solution.start.modes
        assert got.solution.has_velocity == one.solution.has_velocity
        assert got.solution.has_acceleration == one.solution.has_acceleration == acceleration
        lp1, lp2 = got.limit_positions(), one.limit_positions()
        assert [x.name for x in lp1] == [x.name for x in lp2]
        for x, y in zip(lp1, lp2):
            assert x.swing == pytest.approx(y.swing, rel=1e-12)
            assert x.time_ratio == pytest.approx(y.time_ratio, rel=1e-12)


def test_unassemblable_and_toggle_designs_give_the_rows_of_separate_solves():
    """A crank of 40.8 mm passes 2.2 deg from a toggle (Grashof's limit is 40.9 mm: the
    batch screens below 5 deg), one of 45 mm cannot turn (the loop opens at its toggles):
    both leave the program for their own solve, and the study's rows are those of
    designs solved one by one."""
    study = _study(["links.crank.points.A[0]=20, 40.8, 45, 30 mm"])
    mechs = _mechs(study)
    batch = solve_designs(mechs, forces=False, acceleration=False)
    assert _programs(batch) == 1
    assert list(batch.batched) == [True, False, False, True]
    assert set(batch.why) == {1, 2}
    chunk = solve_chunk(study, list(range(len(study))))
    for k in range(len(study)):
        alone = solve_design(study, k)
        assert chunk[k].keys() == alone.keys()
        for key, v in alone.items():
            if isinstance(v, float) and math.isnan(v):
                assert math.isnan(chunk[k][key]), key
            elif isinstance(v, float):
                assert chunk[k][key] == pytest.approx(v, rel=1e-12), key
            else:
                assert chunk[k][key] == v, key
    assert chunk[0]["status"] == chunk[3]["status"] == "ok"
    assert chunk[2]["status"].startswith("not assemblable")
    assert chunk[1]["status"] == "ok" and 2 < chunk[1]["min(transmission_angle.B) [deg]"] < 5


SLIDER = """
name: slider-crank designs
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [30, 0]}}
  rod: {points: {A: [0, 0], C: [100, 0]}}
  piston: {points: {C: [0, 0]}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cylinder: {slider: [ground, piston], point: C, line: {through: [0, 10], angle: 0}}
assembly: ["C.x > A.x"]
driver: {joint: O, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 5 deg}
"""


def test_batches_the_program_does_not_take_take_the_general_path():
    # another plan (a slider): the general path, the same results as separate solves
    study = make_study(load_text(SLIDER, "s.yaml"), ["links.crank.points.A[0]=25, 30 mm"])
    mechs = _mechs(study)
    batch = solve_designs(mechs, forces=False, acceleration=False)
    assert batch.batched.all() and _programs(batch) == 0
    for k, m in enumerate(mechs):
        _same_state(batch.results(k), ms.solve(m, acceleration=False))
    # the four-bar with forces: the general path
    four = _mechs(_study(["links.crank.points.A[0]=20, 25 mm"]))
    assert _programs(solve_designs(four, forces=True)) == 0
    # a mixed batch: the second design's structure differs (another assembly branch), it
    # is solved alone and the others by the program
    other = _study(["links.crank.points.A[0]=22 mm"], text=FOURBAR.replace("left of", "right of"))
    mixed = [four[0], other.mechanism(0), four[1]]
    batch = solve_designs(mixed, forces=False, acceleration=False)
    assert list(batch.batched) == [True, False, True] and _programs(batch) == 1
    assert "structure differs" in batch.why[1]
    for k, m in enumerate(mixed):
        _same_state(batch.results(k), ms.solve(m, acceleration=False))


def test_a_chain_of_dyads_the_six_bar(monkeypatch):
    """The six-bar's second dyad hangs on the coupler's point E (off the coupler's axis):
    the program's designs equal separate solves, and it leaves to their own solves the
    designs the general pass leaves (some of these do not close)."""
    from pathlib import Path

    from mechsolve.analyses import batch as batch_mod
    from mechsolve.model.source import load_file

    src = load_file(Path(__file__).resolve().parents[1] / "mechanisms" / "sixbar.yaml")
    opts = ["links.crank.points.B[0]=24, 26.5, 28 mm", "links.link6.points.F[0]=37, 39, 41 mm"]
    mechs = _mechs(make_study(src, opts))
    for acceleration in (False, True):
        batch = solve_designs(mechs, forces=False, acceleration=acceleration)
        assert _programs(batch) == 1 and 0 < batch.batched.sum() < len(mechs)
        for k, m in enumerate(mechs):
            got, one = batch.results(k), ms.solve(m, acceleration=acceleration)
            s1, s2 = got.solution.state, one.solution.state
            for name in s1.ARRAYS:
                x, y = getattr(s1, name), getattr(s2, name)
                tol = 1e-12 * (1 + np.nanmax(np.abs(y)))
                assert np.allclose(x, y, rtol=1e-12, atol=tol, equal_nan=True), (k, name)
    monkeypatch.setattr(batch_mod, "plan_program", lambda *a: False)
    general = solve_designs(mechs, forces=False, acceleration=False)
    assert _programs(general) == 0
    assert general.why == batch.why and list(general.batched) == list(batch.batched)
