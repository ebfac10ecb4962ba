"""Designs solved as one batch (mechsolve.analyses.batch): every design's results equal its own
separate solve, the batched ones agree with the hand-written closed form of the
four-bar, and designs the batch must not take (near a toggle, unassemblable, another
structure, a condition over the stroke) are solved alone, with the reason."""

from __future__ import annotations

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses.batch import solve_designs
from mechsolve.analyses.study.designs import make_study
from mechsolve.base.errors import MechsolveError
from mechsolve.model.source import load_text
from mechsolve_bench.fourbar_batch import kinematics, kinetostatics
from mechsolve_bench.study import _FOURBAR

from conftest import MECH


def _study(text: str, opts: list[str], name: str = "batch.yaml"):
    return make_study(load_text(text, name), opts)


def _same(a, b, what: str) -> None:
    """Two Results of one design: every state array, flag and force equal to rounding."""
    assert np.array_equal(a.ok, b.ok), what
    assert np.allclose(a.u, b.u, rtol=0, atol=1e-15), what
    sa, sb = a.solution, b.solution
    assert sa.has_velocity == sb.has_velocity and sa.has_acceleration == sb.has_acceleration
    # each quantity (x, y, angle, ..., alpha) against its largest value over the bodies
    upto = 11 if sb.has_acceleration else 8 if sb.has_velocity else 5
    ba, bb = sa.state.block[:upto], sb.state.block[:upto]
    scale = np.nanmax(np.abs(bb), axis=(1, 2), keepdims=True) + 1e-300
    d = np.abs(ba - bb) / scale
    assert np.nanmax(d) < 1e-12, f"{what}: state differs by {np.nanmax(d):.3g}"
    assert np.array_equal(np.isnan(ba), np.isnan(bb)), what
    assert [m for m in sa.start.modes] == [m for m in sb.start.modes], what
    assert len(sa.failures) == len(sb.failures) == 0, what
    assert (a.forces is None) == (b.forces is None), what
    if a.forces is not None:
        fa, fb = a.forces, b.forces
        top = np.nanmax(np.abs(fb.effort)) + 1e-300
        assert np.nanmax(np.abs(fa.effort - fb.effort)) < 1e-11 * top, what
        for j, comps in fb.reactions.items():
            for c, v in comps.items():
                ref = np.nanmax(np.abs(v)) + 1e-300
                assert np.nanmax(np.abs(fa.reactions[j][c] - v)) < 1e-11 * ref, (what, j, c)
        for name, on in fb.active.items():
            assert np.array_equal(fa.active[name], on), (what, name)
        assert np.allclose(fa.residual, fb.residual, rtol=0, atol=1e-9 * top), what
        assert np.allclose(fa.kinetic, fb.kinetic, rtol=1e-12, atol=0), what


def _grid_study(step: str = "5 deg"):
    text = _FOURBAR.replace("step: 1 deg", f"step: {step}")
    return _study(
        text,
        [
            "links.crank.points.A[0]=20, 24.5, 29 mm",
            "links.coupler.points.B[0]=96, 103, 110 mm",
        ],
    )


def test_fourbar_grid_equals_separate_solves_and_the_closed_form():
    study = _grid_study()
    mechs = [study.mechanism(k) for k in range(len(study))]
    batch = solve_designs(mechs)
    assert batch.batched.all(), batch.why
    for k, m in enumerate(mechs):
        _same(batch.results(k), ms.solve(m), f"design {k}")
    # the hand-written closed form of the same designs (positions, rates, reactions)
    vals = np.array([study.values(k) for k in range(len(study))]) / 1e3
    u = batch.u
    kin = kinematics(vals[:, 0], vals[:, 1], 0.059, 0.0875, u)
    frc = kinetostatics(kin)
    for k in range(len(mechs)):
        r = batch.results(k)
        th4 = r.link("rocker").angle
        assert np.max(np.abs(np.angle(np.exp(1j * (th4 - kin["th4"][k]))))) < 1e-12
        assert np.max(np.abs(r.link("coupler").omega - kin["w3"][k])) < 1e-12
        assert np.max(np.abs(r.link("rocker").alpha - kin["al4"][k])) < 1e-11
        # away from where the pull switches (its condition P.vx > 0 changes between samples)
        calm = np.abs(kin["P.vx"][k]) > 1e-6
        top = np.max(np.abs(frc["torque"][k]))
        assert np.max(np.abs(r.forces.effort - frc["torque"][k])[calm]) < 1e-11 * top
        for j in ("O2", "A", "B", "O4"):
            fx = r.forces.reactions[j]["Fx"]
            ref = np.max(np.hypot(frc[j + ".Fx"][k], frc[j + ".Fy"][k]))
            assert np.max(np.abs(fx - frc[j + ".Fx"][k])[calm]) < 1e-11 * ref, j


def test_designs_split_over_several_passes_equal_separate_solves(monkeypatch):
    """A batch larger than a pass (CHUNK_COLUMNS) is solved pass by pass: each design
    lands in its own pass and slot and equals its separate solve."""
    import mechsolve.analyses.batch as mb

    study = _grid_study()
    mechs = [study.mechanism(k) for k in range(len(study))]
    positions = len(solve_designs(mechs[:1]).u)  # 73: every 5 degrees
    monkeypatch.setattr(mb, "CHUNK_COLUMNS", 2 * positions + 1)
    batch = solve_designs(mechs)
    assert batch.batched.all(), batch.why
    assert len(batch._passes) == 5  # 9 designs, 2 per pass
    for k, m in enumerate(mechs):
        _same(batch.results(k), ms.solve(m), f"design {k}")


def test_designs_near_a_toggle_or_unassemblable_are_solved_alone():
    # ground 87.5 mm, rocker 59 mm: a coupler of 50 mm cannot reach across |O4 A| = 87.5 + a
    # mm (a part of the turn does not close); with crank 29 mm and coupler 57.6 mm, coupler
    # and rocker nearly line up (|O4 A| = 116.5 mm against 57.6 + 59): a near toggle
    text = _FOURBAR.replace("step: 1 deg", "step: 5 deg")
    study = _study(
        text,
        ["links.crank.points.A[0]=25, 29 mm", "links.coupler.points.B[0]=50, 57.6, 100 mm"],
    )
    mechs = [study.mechanism(k) for k in range(len(study))]
    batch = solve_designs(mechs)
    values = [tuple(study.values(k)) for k in range(len(study))]
    for k, m in enumerate(mechs):
        try:
            want = ms.solve(m)
        except MechsolveError as exc:
            with pytest.raises(type(exc)):
                batch.results(k)
            assert not batch.batched[k]
            continue
        if not batch.batched[k]:
            assert "singular" in batch.why[k] or "close" in batch.why[k], batch.why[k]
            assert batch.results(k).ok.sum() == want.ok.sum()
            continue
        assert want.ok.all() and not want.solution.events, values[k]
        _same(batch.results(k), want, f"design {values[k]}")
    assert batch.batched.sum() == 3 and len(batch.why) == 3, batch.why


def test_other_structures_go_alone_and_stroke_conditions_per_design():
    fourbar = ms.loads(_FOURBAR.replace("step: 1 deg", "step: 10 deg"))
    other = ms.loads(
        _FOURBAR.replace("step: 1 deg", "step: 10 deg").replace("when: P.vx > 0", "when: P.vy > 0")
    )
    batch = solve_designs([fourbar, other, fourbar])
    assert list(batch.batched) == [True, False, True]
    assert "structure" in batch.why[1]
    _same(batch.results(1), ms.solve(other), "other")
    # RPR and RRP groups, and a cutting force "except the first and last 5 % of the
    # stroke": stroke(C.x) over each design's own extremes
    text = (MECH / "shaper.yaml").read_text()
    study = make_study(
        load_text(text, "shaper.yaml"),
        ["links.crank.points.A[0]=100, 110, 120 mm", "links.rod.points.C[0]=120, 150 mm"],
    )
    mechs = [study.mechanism(k) for k in range(len(study))]
    batch = solve_designs(mechs)
    assert batch.batched.all(), batch.why
    for k, m in enumerate(mechs):
        want = ms.solve(m)
        got = batch.results(k)
        _same(got, want, f"shaper {study.describe(k)}")
        ext = np.array(got.forces.stroke_extremes)
        assert ext.shape == (1, 2)
        assert np.allclose(ext, np.array(want.forces.stroke_extremes), rtol=1e-13, atol=0)


@pytest.mark.parametrize(
    "name, opts",
    [
        # RRP: the slider-crank's crank, rod and the line's offset
        (
            "slider-crank.yaml",
            [
                "links.crank.points.A[0]=45, 50 mm",
                "links.rod.points.C[0]=180, 220 mm",
                "joints.cylinder.line.through[1]=0, 25 mm",
            ],
        ),
        # two RRR loops: the crane's tie pivot
        ("crane.yaml", ["ground.O4[0]=5.5, 5.6, 5.7 m"]),
    ],
)
def test_example_families_equal_separate_solves(name, opts):
    text = (MECH / name).read_text()
    study = make_study(load_text(text, name), opts)
    mechs = [study.mechanism(k) for k in range(len(study))]
    batch = solve_designs(mechs)
    assert batch.batched.any(), batch.why
    for k, m in enumerate(mechs):
        _same(batch.results(k), ms.solve(m), f"{name} design {study.describe(k)}")


KINEMATIC = """
name: kinematics only
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0], P: [40, 30]}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
driver: {joint: O2, speed: -30 rpm, start: 10 deg}
sweep: {range: 360 deg, step: 3 deg}
outputs: {quantities: [position, velocity]}
"""


def test_kinematics_only_and_empty():
    study = _study(KINEMATIC, ["ground.O4[0]=80, 87.5 mm", "links.coupler.points.P[1]=-30, 30 mm"])
    mechs = [study.mechanism(k) for k in range(len(study))]
    batch = solve_designs(mechs)
    for k, m in enumerate(mechs):
        want = ms.solve(m)
        assert batch.results(k).forces is None and want.forces is None
        _same(batch.results(k), want, f"fourbar {k}")
    assert len(solve_designs([])) == 0


def test_a_dead_zone_between_samples_is_left_to_the_sweep():
    # crank 29 mm, ground 87.5 mm: |O4 A| peaks at 116.5 mm at 180 deg; coupler 57.45 mm
    # and rocker 59 mm reach 116.45 mm only, so the loop opens for about 2 deg around
    # 180 deg, between the samples 165 and 195 deg of a 30-deg sweep from 15 deg, where
    # the angle at B is still 12.5 deg from straight: only the discriminant's slopes
    # tell, and the sweep reports the dead zone
    text = _FOURBAR.replace("step: 1 deg", "step: 30 deg").replace("start: 0 deg", "start: 15 deg")
    text = text.replace("A: [26.5, 0]", "A: [29, 0]")
    study = _study(text, ["links.coupler.points.B[0]=57.45, 100 mm"])
    mechs = [study.mechanism(k) for k in range(len(study))]
    batch = solve_designs(mechs)
    assert list(batch.batched) == [False, True], batch.why
    want = ms.solve(mechs[0])
    assert want.ok.all() and any(e.kind == "dead zone" for e in want.solution.events)
    got = batch.results(0)
    assert [e.kind for e in got.solution.events] == [e.kind for e in want.solution.events]
    _same(batch.results(1), ms.solve(mechs[1]), "regular")
