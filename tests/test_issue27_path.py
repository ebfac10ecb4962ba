"""Issue 27, path generation (``mechsolve synth``, a ``path:`` section).

The targets are points of the coupler curve of mechanisms/fourbar.yaml computed here by
intersecting circles (crank 26.5, coupler 105.6, rocker 59, frame 87.5 mm, P 60 mm from
A at 30 deg from A -> B, B left of A -> O4), not by mechsolve. The synthesis must recover
a linkage through them with an objective below 1e-10 (seeded), and mechsolve's own run
of the written file must pass through them, in order, on one branch.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve.cli.commands.synth import synth

ROOT = Path(__file__).parent.parent
TEMPLATE = ROOT / "mechanisms" / "fourbar.yaml"
ANGLES = [0, 40, 80, 120, 160, 200]


def coupler_point(u_deg: float) -> tuple[float, float]:
    a, b, c, d = 26.5, 105.6, 59.0, 87.5
    u = math.radians(u_deg)
    ax, ay = a * math.cos(u), a * math.sin(u)
    ex, ey = d - ax, -ay
    L = math.hypot(ex, ey)
    along = (b * b - c * c + L * L) / (2 * L)
    h = math.sqrt(b * b - along * along)
    bx = ax + along * ex / L - h * ey / L  # left of A -> O4
    by = ay + along * ey / L + h * ex / L
    th = math.atan2(by - ay, bx - ax) + math.radians(30)
    return ax + 60 * math.cos(th), ay + 60 * math.sin(th)


VARY = """\
  vary:
    ground.O4[0]: [60, 120]
    ground.O4[1]: [-20, 20]
    links.crank.points.A[0]: [15, 40]
    links.coupler.points.B[0]: [80, 130]
    links.coupler.points.P.length: [40, 80]
    links.coupler.points.P.angle: [0, 60]
    links.rocker.points.B[0]: [40, 80]
"""


def problem(tmp_path, *, timing=True, extra="", angles=ANGLES, vary=VARY) -> Path:
    pts = ", ".join("[{:.15g}, {:.15g}]".format(*coupler_point(u)) for u in angles)
    text = (
        "name: recover the four-bar\n"
        "units: {length: mm, angle: deg}\n"
        "path:\n"
        f"  mechanism: {TEMPLATE}\n"
        "  point: P\n"
        f"  targets: [{pts}]\n" + (f"  timing: {list(angles)}\n" if timing else "") + vary + extra
    )
    p = tmp_path / "p.yaml"
    p.write_text(text)
    return p


def run(*args):
    return CliRunner().invoke(synth, [str(a) for a in args])


def _check_written(tmp_path, p, *opts):
    from mechsolve.analyses.synth.problem import solve_problem

    out = tmp_path / "d.yaml"
    # every digit written (--digits 17): the synthesis itself is checked to 1e-6 mm
    r = run(p, "-o", out, "--seed", "1", "--digits", "17", *opts)
    assert r.exit_code == 0, r.output
    o = solve_problem(p, seed=1)
    d = o.chosen
    assert d.extra["objective"] * 1e6 < 1e-10  # mm^2
    # mechsolve's own run of the written file, at the crank angles of the design
    import mechsolve as ms
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.model.parse import load

    mech = load(out)
    res = solve_instants(mech, [Instant(float(u), 1.0, 0.0) for u in d.extra["u"]])
    pt = res.point("P")
    for (x, y), u in zip(zip(pt.x, pt.y), ANGLES):
        want = coupler_point(u)
        assert math.hypot(x * 1000 - want[0], y * 1000 - want[1]) < 1e-6  # mm
    assert ms.run(out).ok.all()
    assert "reached in order on one branch" in r.output
    return r, d


def test_coupler_curve_recovered_with_timing(tmp_path):
    r, d = _check_written(tmp_path, problem(tmp_path, extra="  optimise: {max_iter: 200}\n"))
    # with the timing prescribed and O2 fixed, the linkage is the original one
    assert d.lengths["crank"] == pytest.approx(0.0265, abs=1e-9)
    assert d.lengths["coupler"] == pytest.approx(0.1056, abs=1e-9)
    assert d.lengths["rocker"] == pytest.approx(0.059, abs=1e-9)
    assert d.lengths["frame"] == pytest.approx(0.0875, abs=1e-9)


def test_coupler_curve_recovered_without_timing_in_order(tmp_path):
    p = problem(tmp_path, timing=False, extra="  optimise: {max_iter: 400}\n")
    r, d = _check_written(tmp_path, p)
    steps = np.diff(d.extra["u"])
    assert np.all(steps >= 0) and steps.sum() < 2 * math.pi


def test_bounds_excluding_every_crank_rocker(tmp_path):
    vary = "  vary:\n    links.crank.points.A[0]: [120, 150]\n"
    p = problem(tmp_path, vary=vary, extra="  grashof: crank-rocker\n")
    r = run(p)
    assert r.exit_code == 2, r.output
    assert "exclude every crank-rocker" in r.output
    assert "Traceback" not in r.output


def test_too_few_targets(tmp_path):
    p = problem(tmp_path, angles=[0, 40])
    r = run(p)
    assert r.exit_code == 2
    assert "path.targets" in r.output and "at least 3" in r.output


def test_a_number_the_synthesis_cannot_vary(tmp_path):
    p = problem(tmp_path, vary="  vary:\n    links.crank.mass: [0.01, 0.1]\n")
    r = run(p)
    assert r.exit_code == 2
    assert "path.vary.links.crank.mass" in r.output


def test_the_example_file_runs(tmp_path):
    r = run(ROOT / "mechanisms" / "synth" / "path-fourbar.yaml", "-o", tmp_path / "d.yaml")
    assert r.exit_code == 0, r.output
    assert "reached in order on one branch" in r.output


def test_closed_path_the_crank_turns_fully_on_one_branch(tmp_path):
    angles = [0, 60, 120, 180, 240, 300]
    p = problem(
        tmp_path,
        angles=angles,
        extra="  closed: true\n  grashof: crank-rocker\n  optimise: {max_iter: 200}\n",
    )
    out = tmp_path / "d.yaml"
    r = run(p, "-o", out, "--seed", "2")
    assert r.exit_code == 0, r.output
    import mechsolve as ms

    res = ms.run(out)
    assert res.ok.all()
    assert abs(res.u[-1] - res.u[0]) == pytest.approx(2 * math.pi)
    pt = res.point("P")
    # the full turn passes through every target (the sweep's 1 deg grid holds them)
    for u in angles:
        i = int(np.argmin(np.abs(np.degrees(res.u) - u)))
        want = coupler_point(u)
        assert math.hypot(pt.x[i] * 1000 - want[0], pt.y[i] * 1000 - want[1]) < 1e-6
