"""mechsolve synth: the problem files of mechanisms/synth through the click command, the
window choice of seed 000 (task 1) on mechsolve's own solver, and bad input (exit 2)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.analyses.synth.window import choose_window, min_width
from mechsolve.cli.commands.synth import synth

ROOT = Path(__file__).parent.parent
PROBLEMS = ROOT / "mechanisms" / "synth"
REF = json.loads((Path(__file__).parent / "data" / "synth_000_crane_design.json").read_text())


def run(*args):
    return CliRunner().invoke(synth, [str(a) for a in args])


def test_crane_design_file_is_accepted_and_confirms_the_swing(tmp_path):
    out = tmp_path / "design.yaml"
    r = run(PROBLEMS / "crane-crank-rocker.yaml", "-o", out)
    assert r.exit_code == 0, r.output
    assert "crank 1.387798 m, coupler 2.780176 m" in r.output
    res = ms.run(out)
    (lp,) = [lp for lp in res.limit_positions() if lp.name == "rocker"]
    want = REF["recomputed"]["O3C_swing_with_rounded_l1_l2_deg"]
    assert math.degrees(lp.low) + 25 == pytest.approx(want[0], abs=1e-6)
    assert math.degrees(lp.high) + 25 == pytest.approx(want[1], abs=1e-6)
    assert "the line 92.993455 .. 134.000392 deg" in r.output
    # the jib's end C is on the written rocker, 28.525 m at 25 deg from O3B
    c = res.point("C")
    assert math.hypot(c.x[0], c.y[0]) == pytest.approx(28.525, abs=1e-12)


@pytest.mark.parametrize(
    "name", ["crank-rocker-time-ratio", "slider-crank", "shaper-guide-bar", "three-positions"]
)
def test_example_problems_write_files_mechsolve_runs(tmp_path, name):
    out = tmp_path / "d.yaml"
    # every digit written (--digits 17): the limits and K to 1e-7
    r = run(PROBLEMS / f"{name}.yaml", "-o", out, "--digits", 17)
    assert r.exit_code == 0, r.output
    res = ms.run(out)
    assert res.ok.all()
    if name == "crank-rocker-time-ratio":
        (lp,) = res.limit_positions()
        assert (math.degrees(lp.low), math.degrees(lp.high)) == (
            pytest.approx(70, abs=1e-7),
            pytest.approx(115, abs=1e-7),
        )
        assert lp.time_ratio == pytest.approx(1.5, abs=1e-7)
    if name == "shaper-guide-bar":
        assert "K = 1.459905" in r.output
        (lp,) = [lp for lp in res.limit_positions() if lp.name == "guide_bar"]
        assert round(lp.time_ratio, 2) == 1.46


def test_seed_000_window_by_the_seeds_scan():
    mech = ms.load(ROOT / "mechanisms" / "crane.yaml", "jib-driven")
    ch = choose_window(
        mech, "K", math.radians(41), "y-range", compare=[(math.radians(93), math.radians(134))]
    )
    assert math.degrees(ch.closes[0]) == pytest.approx(
        REF["recomputed"]["double_rocker_assembly_limit_O3C_deg"], abs=1e-7
    )
    assert ch.edges_exact[0]
    assert (math.degrees(ch.coarse.start), math.degrees(ch.coarse.end)) == (
        pytest.approx(93),
        pytest.approx(134),
    )
    # the seed's table 1 (printed): K.y over 93..134 spans 20.127 .. 20.791 at whole degrees
    assert ch.coarse.value == pytest.approx(20.791 - 20.127, abs=1.5e-3)
    # sampled finely, the seed's window holds the recomputed extremes of K.y
    lo, hi = REF["recomputed"]["K_y_range_m"]
    assert ch.compared[0].value == pytest.approx(hi - lo, abs=1e-4)
    # the refined window is no worse than the whole-degree one sampled as finely
    assert ch.fine.value <= ch.compared[0].value
    assert ch.fine.start >= ch.closes[0]


def test_min_width_against_hand_cases():
    import numpy as np

    assert min_width(np.array([[0, 0], [2, 0], [2, 1], [0, 1]], float)) == pytest.approx(1)
    # a triangle: its least height, 2 * area / longest side
    tri = np.array([[0, 0], [4, 0], [1, 3]], float)
    assert min_width(tri) == pytest.approx(12 / math.hypot(3, 3))


def test_window_cli_prints_both_windows():
    r = run(PROBLEMS / "crane-window.yaml")
    assert r.exit_code == 0, r.output
    assert "1 deg scan (as the seed): 93.000 .. 134.000 deg" in r.output
    assert "assembly limit" in r.output


@pytest.mark.parametrize(
    "text, match",
    [
        (
            "crank-rocker: {rocker_pivot: [0, 0], rocker: 1, limits: [10, 10], "
            "crank_pivot: [1, 1]}",
            "crank-rocker.limits: rocker limits",
        ),
        ("crank-rocker: {rocker_pivot: [0, 0], rocker: 1, limits: [10, 50]}", "give crank_pivot"),
        ("slider-crank: {stroke: 100 kg, time_ratio: 1.4}", "slider-crank.stroke"),
        ("guide-bar: {frame: 100, crank: 200}", "oscillate"),
        (
            "slider-crank: {stroke: 1, time_ratio: 1.4}\nguide-bar: {frame: 1, crank: 0.1}",
            "exactly one method",
        ),
        ("slider-crank: {stroke: 1, time_ratio: 1.4, offest: 1}", "unknown key"),
        ("window: {mechanism: nowhere.yaml, point: K, width: 41 deg}", "no such file"),
    ],
)
def test_bad_problems_exit_2_naming_the_key(tmp_path, text, match):
    f = tmp_path / "p.yaml"
    f.write_text("name: bad\nunits: {length: mm, angle: deg}\n" + text + "\n")
    r = run(f)
    assert r.exit_code == 2, r.output
    assert match in r.output and "Traceback" not in r.output
    assert str(f) in r.output or "nowhere" in r.output
