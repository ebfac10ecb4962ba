"""Issue 27, four-position motion generation (Burmester's centre-point curve).

Four poses of the coupler of mechanisms/fourbar.yaml (crank 26.5, coupler 105.6, rocker
59, frame 87.5 mm; the coupler's frame at A along A -> B) computed here by circle
intersection: the centre-point curve passes through both ground pivots, and with the
pivots asked near them the original linkage is among the solutions (to 1e-9), and
mechsolve's run of the written file puts the coupler line in the four poses.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve.analyses.synth.burmester import circle_point, cpc_det, four_positions
from mechsolve.cli.commands.synth import synth

A, B, C, D = 26.5, 105.6, 59.0, 87.5


def pose(u_deg: float):
    u = math.radians(u_deg)
    ax, ay = A * math.cos(u), A * math.sin(u)
    ex, ey = D - ax, -ay
    L = math.hypot(ex, ey)
    along = (B * B - C * C + L * L) / (2 * L)
    h = math.sqrt(B * B - along * along)
    bx, by = ax + along * ex / L - h * ey / L, ay + along * ey / L + h * ex / L
    return (ax, ay), math.atan2(by - ay, bx - ax)


POSES = [pose(u) for u in (0, 50, 100, 150)]


def test_centre_point_curve_passes_through_both_ground_pivots():
    typical = abs(float(cpc_det(30.0, 20.0, POSES)))
    assert abs(float(cpc_det(0.0, 0.0, POSES))) < 1e-12 * typical
    assert abs(float(cpc_det(D, 0.0, POSES))) < 1e-12 * typical
    assert abs(float(cpc_det(30.0, 20.0, POSES))) > 0
    # their circle points are the moving pivots A (origin of the coupler frame) and B
    assert circle_point((0.0, 0.0), POSES) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert circle_point((D, 0.0), POSES) == pytest.approx((B, 0.0), abs=1e-9)


def test_a_pivot_asked_off_the_curve_moves_onto_it():
    from mechsolve.analyses.synth.burmester import snap

    typical = abs(float(cpc_det(30.0, 20.0, POSES)))
    c = snap((0.3, -0.2), POSES)
    assert abs(float(cpc_det(*c, POSES))) < 1e-9 * typical
    assert math.hypot(c[0] - 0.3, c[1] + 0.2) < 0.37  # no farther than O2 is


def test_original_linkage_is_among_the_solutions():
    # the ground pivots of the original are on the curve: asked there, they stay
    designs = four_positions(POSES, (0.0, 0.0), (D, 0.0))
    d = designs[0]
    assert d.valid, d.notes
    L = d.lengths
    got = (L["input"], L["coupler"], L["output"], L["frame"])
    assert got == pytest.approx((A, B, C, D), abs=1e-9)
    assert np.hypot(*d.ground["A0"]) < 1e-9


def test_cli_writes_a_file_mechsolve_runs_through_the_four_poses(tmp_path):
    rows = ", ".join(f"[{p[0]!r}, {p[1]!r}, {math.degrees(f)!r}]" for p, f in POSES)
    prob = tmp_path / "p.yaml"
    prob.write_text(
        "name: four poses\nunits: {length: mm, angle: deg}\nfour-positions:\n"
        f"  positions: [{rows}]\n  pivots: {{A: [2, 3], B: [85, -2]}}\n"
    )
    out, png = tmp_path / "d.yaml", tmp_path / "c.png"
    # every digit written (--digits 17): the poses are checked to 1e-9 mm
    r = CliRunner().invoke(synth, [str(prob), "-o", str(out), "--plot", str(png), "--digits", "17"])
    assert r.exit_code == 0, r.output
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.analyses.synth.problem import solve_problem
    from mechsolve.model.parse import load

    d = solve_problem(prob).chosen
    res = solve_instants(load(out), [Instant(a, 1.0, 0.0) for a in d.extra["input_angles"]])
    p, q = res.point("P"), res.point("Q")
    for i, ((px, py), f) in enumerate(POSES):
        assert math.hypot(p.x[i] * 1000 - px, p.y[i] * 1000 - py) < 1e-9
        ang = math.atan2(q.y[i] - p.y[i], q.x[i] - p.x[i])
        assert abs(math.remainder(ang - f, 2 * math.pi)) < 1e-9
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_three_poses_are_bad_input(tmp_path):
    prob = tmp_path / "p.yaml"
    prob.write_text(
        "units: {length: mm, angle: deg}\nfour-positions:\n"
        "  positions: [[0, 0, 0], [1, 1, 10], [2, 1, 20]]\n  pivots: {A: [0, 0], B: [5, 0]}\n"
    )
    r = CliRunner().invoke(synth, [str(prob)])
    assert r.exit_code == 2
    assert "four-positions.positions" in r.output and "expected 4 positions" in r.output
