"""Five-position motion generation (``mechsolve synth``, a ``five-positions:`` section).

Five poses of the coupler of mechanisms/fourbar.yaml (crank 26.5, coupler 105.6, rocker
59, frame 87.5 mm; the coupler's frame at A along A -> B), computed here by intersecting
circles, not by mechsolve. Both ground pivots of that four-bar serve all five poses, so
they must be among the Burmester points (to 1e-9), the original linkage among the
defect-free solutions, and mechsolve's own run of the written file must put the coupler
line in the five poses. Every Burmester point returned is checked here on its own: the
five positions of its moving pivot lie on one circle about it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve.analyses.synth.burmester5 import burmester_points, five_positions, poles
from mechsolve.cli.commands.synth import synth

A, B, C, D = 26.5, 105.6, 59.0, 87.5
ANGLES = (0, 40, 80, 120, 160)


def pose(u_deg: float):
    u = math.radians(u_deg)
    ax, ay = A * math.cos(u), A * math.sin(u)
    ex, ey = D - ax, -ay
    L = math.hypot(ex, ey)
    along = (B * B - C * C + L * L) / (2 * L)
    h = math.sqrt(B * B - along * along)
    bx, by = ax + along * ex / L - h * ey / L, ay + along * ey / L + h * ex / L
    return (ax, ay), math.atan2(by - ay, bx - ax)


POSES = [pose(u) for u in ANGLES]


def place(p, f, m):
    return p[0] + math.cos(f) * m[0] - math.sin(f) * m[1], p[1] + math.sin(f) * m[0] + math.cos(
        f
    ) * m[1]


def test_both_ground_pivots_are_burmester_points():
    pts = burmester_points(POSES)
    assert 2 <= len(pts) <= 4 and len(pts) % 2 == 0
    cs = [c for c, _ in pts]
    for want, m_want in (((0.0, 0.0), (0.0, 0.0)), ((D, 0.0), (B, 0.0))):
        k = int(np.argmin([math.dist(c, want) for c in cs]))
        assert math.dist(cs[k], want) < 1e-9
        assert math.dist(pts[k][1], m_want) < 1e-9
    # every point returned serves all five poses: the moving pivot on one circle
    for c, m in pts:
        r = [math.dist(c, place(p, f, m)) for p, f in POSES]
        assert max(r) - min(r) < 1e-9 * max(r)
    # none is a pole (where the circle point is undetermined)
    for c, _ in pts:
        assert min(math.dist(c, p) for p in poles(POSES[:3])) > 1e-6


def test_the_original_fourbar_is_among_the_defect_free_solutions():
    designs = five_positions(POSES)
    got = [
        d
        for d in designs
        if d.valid
        and np.allclose(
            [d.lengths[k] for k in ("input", "coupler", "output", "frame")], [A, B, C, D], atol=1e-9
        )
    ]
    assert len(got) == 1
    d = got[0]
    inp = d.extra["input"]
    out = "B0" if inp == "A0" else "A0"
    assert math.dist(d.ground[inp], (0, 0)) < 1e-9 and math.dist(d.ground[out], (D, 0)) < 1e-9
    # driven from the rocker's pivot the same linkage does not reach the poses in order
    other = [x for x in designs if x is not d and x.lengths["input"] == pytest.approx(C)]
    assert any(not x.valid for x in other)


def test_cli_writes_a_file_mechsolve_runs_through_the_five_poses(tmp_path):
    rows = ", ".join(f"[{p[0]!r}, {p[1]!r}, {math.degrees(f)!r}]" for p, f in POSES)
    prob = tmp_path / "p.yaml"
    prob.write_text(
        f"name: five poses\nunits: {{length: mm, angle: deg}}\nfive-positions:\n"
        f"  positions: [{rows}]\n"
    )
    out, png = tmp_path / "d.yaml", tmp_path / "b.png"
    # every digit written (--digits 17): the poses are checked to 1e-9
    r = CliRunner().invoke(synth, [str(prob), "-o", str(out), "--plot", str(png), "--digits", "17"])
    assert r.exit_code == 0, r.output
    assert "mechsolve run of the written file: pose errors" in r.output
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.analyses.synth.problem import solve_problem
    from mechsolve.model.parse import load

    d = solve_problem(prob).chosen
    assert d.valid
    # the file says which input angles put the line in which of the five poses
    head = out.read_text().splitlines()[:6]
    assert any("through five positions" in ln for ln in head)
    (line,) = [ln for ln in head if "puts the coupler line" in ln]
    assert "positions 1, 2, 3, 4, 5." in line
    shown = [float(v) for v in line.split(" at ", 1)[1].split(" deg")[0].split(", ")]
    assert np.allclose(shown, np.degrees(d.extra["input_angles"]), atol=1e-6)
    res = solve_instants(load(out), [Instant(a, 1.0, 0.0) for a in d.extra["input_angles"]])
    p, q = res.point("P"), res.point("Q")
    for i, ((px, py), f) in enumerate(POSES):
        assert math.hypot(p.x[i] * 1000 - px, p.y[i] * 1000 - py) < 1e-9
        ang = math.atan2(q.y[i] - p.y[i], q.x[i] - p.x[i])
        assert abs(math.remainder(ang - f, 2 * math.pi)) < 1e-9


def test_four_poses_are_bad_input(tmp_path):
    prob = tmp_path / "p.yaml"
    rows = ", ".join(f"[{p[0]!r}, {p[1]!r}, {math.degrees(f)!r}]" for p, f in POSES[:4])
    prob.write_text(f"units: {{length: mm, angle: deg}}\nfive-positions:\n  positions: [{rows}]\n")
    r = CliRunner().invoke(synth, [str(prob)])
    assert r.exit_code == 2
    assert "five-positions.positions" in r.output and "expected 5 positions" in r.output
    assert "Traceback" not in r.output


def test_poses_no_fourbar_reaches_are_bad_input(tmp_path):
    # five poses whose two centre-point curves meet in no real point besides the poles
    rows = ("[-0.8287, -0.1337, -12.464], [-0.5264, -0.0419, 1.918], [0.6025, -0.6805, "
            "-7.949], [0.1643, 0.4692, 9.946], [-0.8117, -0.7727, 27.252]")  # fmt: skip
    prob = tmp_path / "p.yaml"
    prob.write_text(f"units: {{length: m, angle: deg}}\nfive-positions:\n  positions: [{rows}]\n")
    r = CliRunner().invoke(synth, [str(prob)])
    assert r.exit_code == 2, r.output
    assert "five-positions.positions" in r.output
    assert "0 real Burmester point(s)" in r.output and "no four-bar" in r.output
    assert "Traceback" not in r.output


@pytest.mark.parametrize(
    "rows, message",
    [
        (
            "[0, 0, 0], [0, 0, 0], [1, 0, 10], [2, 1, 20], [3, 1, 30]",
            "positions 1 and 2 are the same",
        ),
        (
            "[1, 0, 0], [0, 1, 90], [-1, 0, 180], [0, -1, 270], [0.6, 0.8, 53.13010235415598]",
            "the poses are turns about one point (0, 0)",
        ),
    ],
)
def test_degenerate_poses_are_named(tmp_path, rows, message):
    prob = tmp_path / "p.yaml"
    prob.write_text(f"units: {{length: m, angle: deg}}\nfive-positions:\n  positions: [{rows}]\n")
    r = CliRunner().invoke(synth, [str(prob)])
    assert r.exit_code == 2, r.output
    assert "five-positions.positions" in r.output and message in r.output
    assert "Traceback" not in r.output


def test_the_example_file_runs():
    from pathlib import Path

    p = Path(__file__).parent.parent / "mechanisms" / "synth" / "five-positions.yaml"
    r = CliRunner().invoke(synth, [str(p)])
    assert r.exit_code == 0, r.output


def test_a_loop_that_cannot_close_shows_no_transmission_figure():
    from pathlib import Path

    p = Path(__file__).parent.parent / "mechanisms" / "synth" / "five-positions.yaml"
    r = CliRunner().invoke(synth, [str(p)])
    assert r.exit_code == 0, r.output
    rows = r.output.splitlines()
    broken = [ln for ln in rows if "the loop cannot close" in ln]
    assert broken  # this example has such designs
    for ln in broken:
        assert "minimum transmission angle - (the loop does not close)" in ln
    assert "0.0000 deg" not in r.output
