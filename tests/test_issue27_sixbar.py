"""Issue 27, path generation for a six-bar (a Stephenson III chain of two dyads).

The targets are points of the path of P on link5 of
mechanisms/synth/templates/sixbar-stephenson.yaml, computed here by intersecting circles
(crank 26.5, coupler B-C 75, rocker 59, frame 87.5 mm; E 65 mm from C at -60 deg from
B -> C; E-F 48.4, G-F 39 mm, G at (153.5, 41.7) mm; P at (20, 15) mm in link5's frame,
x along F -> E; C left of B -> D, F right of E -> G), not by mechsolve. The synthesis
varies the second dyad (G, both link lengths and P) within bounds around them and must
bring the sum of squared distances below 1e-8 of the size squared; mechsolve's run of the
written file must pass through the targets on one branch.
"""

from __future__ import annotations

import math
from pathlib import Path

from click.testing import CliRunner

from mechsolve.cli.commands.synth import synth

ROOT = Path(__file__).parent.parent
TEMPLATE = ROOT / "mechanisms" / "synth" / "templates" / "sixbar-stephenson.yaml"
ANGLES = [0, 45, 90, 135, 180, 225, 270, 315]
SIZE = 153.5  # mm: the frame's extent, the scale of the objective


def _circles(px, py, qx, qy, r1, r2, left):
    """The point at r1 from P and r2 from Q, left (or right) of P -> Q."""
    ex, ey = qx - px, qy - py
    L = math.hypot(ex, ey)
    along = (r1 * r1 - r2 * r2 + L * L) / (2 * L)
    h = math.sqrt(r1 * r1 - along * along) * (1 if left else -1)
    return px + (along * ex - h * ey) / L, py + (along * ey + h * ex) / L


def tracer(u_deg: float) -> tuple[float, float]:
    u = math.radians(u_deg)
    bx, by = 26.5 * math.cos(u), 26.5 * math.sin(u)
    cx, cy = _circles(bx, by, 87.5, 0.0, 75.0, 59.0, left=True)
    th3 = math.atan2(cy - by, cx - bx)
    lx, ly = 75 + 65 * math.cos(math.radians(-60)), 65 * math.sin(math.radians(-60))
    ex = bx + math.cos(th3) * lx - math.sin(th3) * ly
    ey = by + math.sin(th3) * lx + math.cos(th3) * ly
    fx, fy = _circles(ex, ey, 153.5, 41.7, 48.4, 39.0, left=False)
    th5 = math.atan2(ey - fy, ex - fx)
    return fx + math.cos(th5) * 20 - math.sin(th5) * 15, fy + math.sin(th5) * 20 + math.cos(
        th5
    ) * 15


VARY = """\
  vary:
    ground.G[0]: [130, 175]
    ground.G[1]: [25, 60]
    links.link5.points.E[0]: [35, 60]
    links.link5.points.P[0]: [0, 40]
    links.link5.points.P[1]: [0, 30]
    links.link6.points.F[0]: [28, 50]
"""


def problem(tmp_path, *, extra="", vary=VARY, angles=ANGLES) -> Path:
    pts = ", ".join("[{:.15g}, {:.15g}]".format(*tracer(u)) for u in angles)
    text = (
        "name: recover the six-bar\n"
        "units: {length: mm, angle: deg}\n"
        "path:\n"
        f"  mechanism: {TEMPLATE}\n"
        "  point: P\n"
        f"  targets: [{pts}]\n"
        f"  timing: {list(angles)}\n"
        "  closed: true\n" + vary + extra
    )
    p = tmp_path / "p.yaml"
    p.write_text(text)
    return p


def run(*args):
    return CliRunner().invoke(synth, [str(a) for a in args])


def test_the_closed_form_here_is_the_template():
    # the independent closed form above describes the template (else the test is moot)
    import mechsolve as ms
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.model.parse import load

    res = solve_instants(
        load(TEMPLATE), [Instant(math.radians(u), 1.0, 0.0) for u in ANGLES], forces=False
    )
    p = res.point("P")
    for x, y, u in zip(p.x, p.y, ANGLES):
        want = tracer(u)
        assert math.hypot(x * 1000 - want[0], y * 1000 - want[1]) < 1e-9
    assert ms.run(TEMPLATE).ok.all()


def test_sixbar_path_recovered_and_the_written_file_reproduces_it(tmp_path):
    p = problem(tmp_path, extra="  optimise: {max_iter: 150, popsize: 15, top: 3}\n")
    out, png = tmp_path / "d.yaml", tmp_path / "d.png"
    r = run(p, "-o", out, "--plot", png, "--seed", "1")
    assert r.exit_code == 0, r.output
    assert "reached in order on one branch" in r.output
    assert png.stat().st_size > 0
    import mechsolve as ms
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.model.parse import load

    # mechsolve's own run of the written file, at the prescribed crank angles
    mech = load(out)
    res = solve_instants(mech, [Instant(math.radians(u), 1.0, 0.0) for u in ANGLES])
    pt = res.point("P")
    sq = 0.0
    for x, y, u in zip(pt.x, pt.y, ANGLES):
        want = tracer(u)
        sq += (x * 1000 - want[0]) ** 2 + (y * 1000 - want[1]) ** 2  # mm^2
    assert sq < 1e-8 * SIZE**2
    # with the timing given, the known six-bar is the solution (read back from the file)
    links = {lk.name: lk for lk in mech.links}
    got = {
        "G": tuple(mech.ground["G"]),
        "E on link5": tuple(links["link5"].points["E"]),
        "P on link5": tuple(links["link5"].points["P"]),
        "F on link6": tuple(links["link6"].points["F"]),
    }
    want = {"G": (153.5, 41.7), "E on link5": (48.4, 0), "P on link5": (20, 15),
            "F on link6": (39, 0)}  # fmt: skip
    for k, (wx, wy) in want.items():
        assert math.hypot(got[k][0] * 1000 - wx, got[k][1] * 1000 - wy) < 1e-6, k  # mm
    full = ms.run(out)
    assert full.ok.all()
    assert math.isclose(abs(full.u[-1] - full.u[0]), 2 * math.pi)


def test_grashof_is_refused_for_a_sixbar(tmp_path):
    r = run(problem(tmp_path, extra="  grashof: crank-rocker\n"))
    assert r.exit_code == 2, r.output
    assert "path.grashof" in r.output and "Traceback" not in r.output


def test_a_point_not_on_a_moving_link(tmp_path):
    p = problem(tmp_path)
    p.write_text(p.read_text().replace("point: P", "point: Z"))
    r = run(p)
    assert r.exit_code == 2, r.output
    assert "path.point" in r.output


def test_a_template_with_a_slider_is_refused_with_its_reason(tmp_path):
    slider = ROOT / "mechanisms" / "slider-crank.yaml"
    text = (
        "name: slider\n"
        "units: {length: mm, angle: deg}\n"
        "path:\n"
        f"  mechanism: {slider}\n"
        "  point: G\n"
        "  targets: [[100, 0], [120, 5], [150, 8], [170, 5]]\n"
        "  timing: [0, 30, 60, 90]\n"
        "  vary:\n"
        "    links.rod.points.G[0]: [20, 100]\n"
    )
    p = tmp_path / "p.yaml"
    p.write_text(text)
    r = run(p)
    assert r.exit_code == 2, r.output
    assert "path.mechanism" in r.output and "revolute dyad" in r.output
    assert "Traceback" not in r.output
