"""Issue 27: the six-bar path generation's branch check is exact, not a bound on samples.

The chain here is a Stephenson III six-bar: the four-bar A-B-C-D (crank 20, coupler B-C
60, rocker 50 mm, frame ``d``) carries the point E of its coupler, which drives the dyad
E-F-G (E-F ``L1`` on link5, F-G ``L2`` on link6, G on the ground). Near ``d`` = 30 mm the
four-bar is next to its change point: at crank angle 0 the coupler and the rocker are
within a fraction of a degree of folding onto each other (the first dyad's smallest
transmission angle, in closed form ``acos((b^2 + c^2 - (d - a)^2) / (2 b c))``), and the
coupler swings fast there. Everything the tests compare with is computed here by
intersecting circles (``tracer``), not by mechsolve.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

A, B, C = 20.0, 60.0, 50.0  # mm: crank, coupler B-C, rocker
E_LOCAL = (100.0, 30.0)  # mm: E on the coupler (origin B, x towards C)
G = (60.0, 100.0)  # mm


def coupler_e(u: np.ndarray, d: float) -> tuple[np.ndarray, np.ndarray]:
    """E at the crank angles ``u`` (rad), C left of B -> D (circle intersection)."""
    bx, by = A * np.cos(u), A * np.sin(u)
    ex, ey = d - bx, -by
    L = np.hypot(ex, ey)
    along = (B * B - C * C + L * L) / (2 * L)
    h = np.sqrt(B * B - along * along)
    cx, cy = bx + (along * ex - h * ey) / L, by + (along * ey + h * ex) / L
    th = np.arctan2(cy - by, cx - bx)
    x, y = E_LOCAL
    return bx + np.cos(th) * x - np.sin(th) * y, by + np.sin(th) * x + np.cos(th) * y


def sin2(L1: float, L2: float, D: np.ndarray) -> np.ndarray:
    """sin^2 of a dyad's angle at its middle joint from the distance of its outer joints
    (law of cosines; negative where the dyad cannot close)."""
    cos = (L1 * L1 + L2 * L2 - D * D) / (2 * L1 * L2)
    return 1 - cos * cos


def write_problem(tmp_path: Path, d: float, L1: float, L2: float, t0: float = 0.0,
                  min_mu: float = 0.0) -> Path:  # fmt: skip
    d, L1, L2, t0 = float(d), float(L1), float(L2), float(t0)
    template = tmp_path / "six.yaml"
    template.write_text(f"""\
name: near change point
units: {{length: mm, angle: deg}}
ground: {{A: [0, 0], D: [{d!r}, 0], G: [{G[0]}, {G[1]}]}}
links:
  crank: {{points: {{A: [0, 0], B: [{A}, 0]}}}}
  coupler: {{points: {{B: [0, 0], C: [{B}, 0], E: [{E_LOCAL[0]}, {E_LOCAL[1]}]}}}}
  rocker: {{points: {{D: [0, 0], C: [{C}, 0]}}}}
  link5: {{points: {{F: [0, 0], E: [{L1!r}, 0], P: [10, 5]}}}}
  link6: {{points: {{G: [0, 0], F: [{L2!r}, 0]}}}}
joints: {{A: [ground, crank], B: [crank, coupler], C: [coupler, rocker],
  D: [ground, rocker], E: [coupler, link5], F: [link5, link6], G: [ground, link6]}}
assembly: [C left of B -> D, F left of E -> G]
driver: {{joint: A, speed: 1 rad/s, start: {t0!r} deg}}
sweep: {{range: 360 deg, step: 5 deg}}
""")
    timing = [t0 + 90 * k for k in range(4)]
    problem = tmp_path / "p.yaml"
    problem.write_text(f"""\
name: p
units: {{length: mm, angle: deg}}
path:
  mechanism: {template}
  point: P
  targets: [[0, 0], [10, 0], [10, 10], [0, 10]]
  timing: {timing}
  closed: true
  min_transmission: {min_mu} deg
  vary:
    links.link6.points.F[0]: [1, 1000]
""")
    return problem


def batch_of(problem: Path):
    from mechsolve.analyses.synth.path_gen import read_path
    from mechsolve.analyses.synth.problem import _Reader, read

    src, _ = read(problem)
    return read_path(_Reader(src, "path")).chain


def rows(problem: Path, L2: float) -> np.ndarray:
    """The constraint rows (first dyad, second dyad, ...) of the design on the file's
    branches (C left of B -> D, F left of E -> G)."""
    batch = batch_of(problem)
    return batch.evaluate_combo(np.array([[L2 / 1000]]), np.array([1.0, 1.0]))[2][:, 0]


def lengths_with_margin(d: float, margin: float) -> tuple[float, float]:
    """L1, L2 that keep the second dyad ``margin`` mm inside its closure limits over a
    whole turn (on a 0.001 deg grid)."""
    u = np.radians(np.linspace(0, 360, 360001))
    ex, ey = coupler_e(u, d)
    D = np.hypot(ex - G[0], ey - G[1])
    return float(0.5 * (D.max() + D.min())), float(0.5 * (D.max() - D.min()) + margin)


@pytest.mark.parametrize("d", [30.02, 30.004])
def test_a_first_dyad_next_to_its_toggle_is_proven_feasible(tmp_path, d):
    # the first dyad's least transmission angle, in closed form (at crank angle 0)
    mu1 = math.degrees(math.acos((B * B + C * C - (d - A) ** 2) / (2 * B * C)))
    assert 0.2 < mu1 < 0.7  # deg: closes and keeps its branch, but only just
    L1, L2 = lengths_with_margin(d, 5.0)
    r = rows(write_problem(tmp_path, d, L1, L2, t0=2.5), L2)
    # a bound on the samples' cubic interpolant refused this design (it cannot tell a
    # fast swing from a branch point); the exact check proves it
    assert np.all(r > 0), r
    # the first row is a proven lower bound of sin^2 of the first dyad's angle
    assert r[0] <= math.sin(math.radians(mu1)) ** 2
    # mechsolve's own run of the file at a fine step: closes everywhere, one branch
    import mechsolve as ms

    res = ms.run(tmp_path / "six.yaml", step=math.radians(0.01))
    assert res.ok.all()
    assert not [e for e in res.events if "branch" in str(e.kind)]


def test_a_second_dyad_open_inside_one_sampling_interval_is_refused(tmp_path):
    d = 30.5
    u = np.radians(np.linspace(0, 360, 360001))
    ex, ey = coupler_e(u, d)
    D = np.hypot(ex - G[0], ey - G[1])
    k = int(np.argmax(D))
    t0 = (math.degrees(u[k]) + 2.5) % 5.0  # the largest distance mid-way between samples
    samples = np.radians(t0 + 5.0 * np.arange(73))
    sx, sy = coupler_e(samples, d)
    Ds = np.hypot(sx - G[0], sy - G[1])
    reach = D.max() - 0.25 * (D.max() - Ds.max())  # L1 + L2: short of D only near k
    L1, L2 = float(0.5 * (reach + 0.5 * D.min())), float(0.5 * (reach - 0.5 * D.min()))
    assert D.min() > 2  # mm: |L1 - L2| = D.min / 2 keeps the dyad open elsewhere
    # the independent closed form: the dyad closes at every sample, not in between
    assert np.all(sin2(L1, L2, Ds) > 0)
    uu = np.radians(t0) + np.linspace(0, 2 * np.pi, 720001)
    fx, fy = coupler_e(uu, d)
    bad = uu[sin2(L1, L2, np.hypot(fx - G[0], fy - G[1])) < 0]
    assert len(bad) and bad.max() - bad.min() < np.radians(5)
    r = rows(write_problem(tmp_path, d, L1, L2, t0=t0), L2)
    assert r[0] > 0 and r[1] < 0, r  # the first dyad proven, the second refused


def test_every_design_the_check_accepts_is_feasible_on_a_fine_grid(tmp_path):
    # designs around the near-toggle chain, with a minimum transmission angle of 10 deg
    # on the second dyad (the first one's is below it, so it is checked for closure
    # only with min 0 below): each accepted design is checked on a 0.005 deg grid
    d = 30.5
    L1, L2 = lengths_with_margin(d, 5.0)
    problem = write_problem(tmp_path, d, L1, L2)
    batch = batch_of(problem)
    rng = np.random.default_rng(7)
    L2s = np.concatenate([rng.uniform(L2 - 12, L2 + 3, 60), [L2]])
    r = batch.evaluate_combo(L2s[None, :] / 1000, np.array([1.0, 1.0]))[2]
    accepted = np.all(r > 0, axis=0)
    assert 5 < accepted.sum() < len(L2s)  # some of each
    u = np.radians(np.linspace(0, 360, 72001))
    ex, ey = coupler_e(u, d)
    D = np.hypot(ex - G[0], ey - G[1])
    for l2, ok, row in zip(L2s, accepted, r[1]):
        least = float(np.min(sin2(L1, l2, D)))
        if ok:
            assert least > 0 and row <= least + 1e-12  # a true lower bound
        else:
            assert row <= 0


def test_synthesis_on_the_near_toggle_chain_prints_the_true_least_angle(tmp_path):
    # the chain at d = 30.5 traces P (10, 5 on link5); the synthesis varies G's x and
    # F-G and must find them again; the table's smallest transmission angle is the first
    # dyad's, acos((b^2 + c^2 - (d - a)^2) / (2 b c)) at crank angle 0, proven from below
    from click.testing import CliRunner

    import mechsolve as ms
    from mechsolve.cli.commands.synth import synth

    d = 30.5
    L1, L2 = lengths_with_margin(d, 5.0)
    angles = np.arange(0, 360, 45)
    u = np.radians(angles)
    ex, ey = coupler_e(u, d)
    # F left of E -> G: |EF| = L1, |GF| = L2
    vx, vy = G[0] - ex, G[1] - ey
    D = np.hypot(vx, vy)
    along = (L1 * L1 - L2 * L2 + D * D) / (2 * D)
    h = np.sqrt(L1 * L1 - along * along)
    fx, fy = ex + (along * vx - h * vy) / D, ey + (along * vy + h * vx) / D
    th = np.arctan2(ey - fy, ex - fx)
    px, py = fx + np.cos(th) * 10 - np.sin(th) * 5, fy + np.sin(th) * 10 + np.cos(th) * 5
    problem = write_problem(tmp_path, d, L1, L2)
    text = problem.read_text()
    targets = ", ".join(f"[{x!r}, {y!r}]" for x, y in zip(px.tolist(), py.tolist()))
    text = text.replace("targets: [[0, 0], [10, 0], [10, 10], [0, 10]]", f"targets: [{targets}]")
    text = text.replace("timing: [0.0, 90.0, 180.0, 270.0]", f"timing: {angles.tolist()}")
    text = text.replace(
        "    links.link6.points.F[0]: [1, 1000]\n",
        f"    links.link6.points.F[0]: [{L2 - 8!r}, {L2 + 8!r}]\n"
        f"    ground.G[0]: [{G[0] - 8}, {G[0] + 8}]\n"
        "  optimise: {max_iter: 60, popsize: 12, top: 1}\n",
    )
    problem.write_text(text)
    out = tmp_path / "d.yaml"
    r = CliRunner().invoke(synth, [str(problem), "-o", str(out), "--seed", "1"])
    assert r.exit_code == 0, r.output
    row = next(line for line in r.output.splitlines() if line.startswith(" *"))
    printed = float(row.split()[-1])  # deg
    true = math.degrees(math.acos((B * B + C * C - (d - A) ** 2) / (2 * B * C)))
    assert true - 2e-4 <= printed <= true + 5e-5, (printed, true)
    # mechsolve's own run of the written file at a fine step: one branch, every position
    res = ms.run(out, step=math.radians(0.01))
    assert res.ok.all()
    assert not [e for e in res.events if "branch" in str(e.kind)]
