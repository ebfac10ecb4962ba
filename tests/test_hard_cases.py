"""Hard cases: bifurcations, coarse steps, dead zones, redundant constraints, triads,
limit positions and design figures, exit codes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.cli.main import main

from closed_form import fourbar
from conftest import MECH, ref


def wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def parallelogram(method: str, step: float, start: float, sweep: float = 720.0) -> str:
    return f"""
ground: {{O2: [0, 0], O4: [3, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [1, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [3, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [1, 0]}}}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: {{sketch: {{B: [3.8, 0.6]}}}}
driver: {{joint: O2, speed: 2 rad/s, start: {start} deg}}
sweep: {{range: {sweep} deg, step: {step} deg}}
solver: {{method: {method}}}
"""


@pytest.mark.parametrize("method", ["auto", "newton"])
@pytest.mark.parametrize("step", [1, 7, 30, 45])
@pytest.mark.parametrize("start", [0, 10])
def test_parallelogram_stays_a_parallelogram_through_collinearity(method, step, start):
    """Driven through the positions where all links are collinear (0 and 180 deg), a
    parallelogram must not fold into the anti-parallelogram."""
    res = ms.solve(ms.loads(parallelogram(method, step, start)))
    assert res.ok.all()
    # the coupler translates and the rocker turns with the crank; a Newton solver at the
    # exactly singular samples reaches only the square root of the rounding error
    tol = 1e-12 if method == "auto" else 1e-7
    assert np.max(np.abs(wrap(res.link("coupler").angle))) < tol
    assert np.max(np.abs(wrap(res.link("rocker").angle - res.u))) < tol
    # rates everywhere, the singular samples too: the limits along the motion (a Newton
    # group reaches each side by continuation from the neighbouring sample)
    singular = np.abs(np.sin(res.u)) < 1e-6
    rock, coup, A, B = res.link("rocker"), res.link("coupler"), res.point("A"), res.point("B")
    blank = np.isnan(rock.omega)
    assert not blank.any()
    assert sorted(res.solution.rates_by_limit) == list(np.flatnonzero(singular))
    assert res.solution.rates_undetermined == []
    k = ~blank
    np.testing.assert_allclose(rock.omega[k], 2.0, atol=1e-9)
    np.testing.assert_allclose(coup.omega[k], 0.0, atol=1e-9)
    np.testing.assert_allclose(rock.alpha[k], 0.0, atol=1e-6)  # scale omega^2 = 4
    np.testing.assert_allclose(coup.alpha[k], 0.0, atol=1e-6)
    for q in ("vx", "vy", "ax", "ay"):  # the coupler translates
        np.testing.assert_allclose(getattr(B, q)[k], getattr(A, q)[k], atol=1e-6)
    if singular.any():
        assert "velocities and accelerations at" in res.summary()
    if method == "auto":
        kinds = {e.kind for e in res.events}
        assert kinds == {"bifurcation"}
        angles = sorted({round(math.degrees(e.u) % 360, 6) for e in res.events})
        assert angles == [0.0, 180.0]
        assert "bifurcation" in res.summary() and "followed the smooth motion" in res.summary()


def test_slotted_bar_through_its_pivot_turns_on():
    """A crank pin that passes exactly through the slotted bar's pivot: the bar turns on
    smoothly (a bifurcation followed), it does not flip by half a turn."""
    res = ms.solve(
        ms.loads("""
ground: {O4: [0, 0], O2: [0, 0.5]}
links:
  crank: {points: {O2: [0, 0], A: [0.5, 0]}}
  block: {points: {A: [0, 0]}}
  bar: {points: {O4: [0, 0], B: [1, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, block]
  slot: {slider: [bar, block], point: A, line: [O4, B]}
  O4: [ground, bar]
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 5 deg}
""")
    )
    bar = res.link("bar").angle
    # the pin is at the pivot at -90 deg; the bar's angle is half the crank's (inscribed angle)
    ok = np.abs(wrap(res.u + np.pi / 2)) > 1e-9
    np.testing.assert_allclose(wrap(bar[ok] - (res.u[ok] / 2 + np.pi / 4)), 0, atol=1e-12)
    assert any(e.kind == "bifurcation" for e in res.events)


CRANK_ROCKERS = [(0.3, 1.1, 0.8, 1.0), (1.0, 3.0, 2.5, 3.2), (0.2, 0.9, 0.5, 0.8), (2, 7, 9, 6)]


@pytest.mark.parametrize("geom", CRANK_ROCKERS)
@pytest.mark.parametrize("positions", [8, 12])
@pytest.mark.parametrize("side", ["left", "right"])
@pytest.mark.parametrize("method", ["auto", "newton"])
def test_coarse_step_keeps_the_branch(geom, positions, side, method):
    a, b, c, d = geom
    text = f"""
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B {side} of A -> O4"]
driver: {{joint: O2, speed: 1 rad/s, start: 17 deg}}
sweep: {{range: 720 deg, steps: {2 * positions}}}
solver: {{method: {method}}}
"""
    res = ms.solve(ms.loads(text))
    th2 = res.u
    want = None
    for br in (1, -1):
        th3, th4, *_ = fourbar(a, b, c, d, th2, 1.0, br)
        ax, ay = a * math.cos(th2[0]), a * math.sin(th2[0])
        bx, by = d + c * math.cos(th4[0]), c * math.sin(th4[0])
        if ((d - ax) * (by - ay) + ay * (bx - ax) > 0) == (side == "left"):
            want = th4
    assert np.max(np.abs(wrap(res.link("rocker").angle - want))) < 1e-9


def test_crane_double_rocker_driven_into_its_dead_zone():
    """The jib O3C driven down from 110 deg: below 92.569 deg the double rocker cannot
    close; those positions are reported with the loop, the others kept."""
    limit = 92.56911487175758  # tests/data/000_crane_design.json
    for method in ("auto", "newton"):
        mech = ms.load(MECH / "crane.yaml", variant="jib-driven")
        mech.driver.start = math.radians(110)
        mech.driver.speed = -abs(mech.driver.speed)
        mech.sweep.travel, mech.sweep.step = math.radians(30), math.radians(0.5)
        res = ms.solve(mech, method=method)
        angle = np.degrees(res.u)
        np.testing.assert_array_equal(res.ok, angle > limit)
        assert len(res.failures) == 1
        f = res.failures[0]
        assert angle[f.first] == pytest.approx(92.5) and angle[f.last] == pytest.approx(80)
        if method == "auto":
            assert "loop D" in f.reason and "cannot close" in f.reason
        assert np.isnan(res.point("K").x[~res.ok]).all()
        assert np.isfinite(res.point("K").x[res.ok]).all()
        assert res.solution.residual[res.ok].max() < 1e-9


def test_forces_over_a_sweep_with_gaps():
    """A crank too long for the four-bar: the positions where it closes keep their
    forces; the work per cycle is not defined over the gaps (no integral across them),
    the mean is that of the solved positions, and the gaps are failures, not singular
    positions of the force analysis."""
    text = (MECH / "fourbar.yaml").read_text()
    text = text.replace("A: [26.5, 0]", "A: [80, 0]").replace("start: 0 deg", "start: 90 deg")
    res = ms.solve(ms.loads(text))
    assert 0 < res.ok.sum() < len(res.u)
    assert math.isnan(res.work())
    e = res.driving_effort
    mean, what = res.mean_effort()
    assert what == "mean of the solved positions"
    assert mean == pytest.approx(np.mean(e[res.ok]), rel=1e-12)
    assert np.isfinite(e[res.ok]).all() and np.isnan(e[~res.ok]).all()
    assert res.forces.singular == []
    text = res.summary()
    assert "work of the driver per cycle: not defined" in text
    assert "forces indeterminate" not in text


def test_partial_sweep_exit_code_and_csv(tmp_path):
    text = (MECH / "crane.yaml").read_text()
    f = tmp_path / "crane.yaml"
    f.write_text(
        text.replace(
            "driver: {joint: O3, line: [O3, C], start: 93 deg}",
            "driver: {joint: O3, line: [O3, C], start: 100 deg, direction: cw}",
        ).replace(
            "sweep: {range: null, to: 134 deg, step: 1 deg}",
            "sweep: {range: null, to: 85 deg, step: 1 deg}",
        )
    )
    r = CliRunner().invoke(
        main, ["run", str(f), "--variant", "jib-driven", "-o", str(tmp_path / "o"), "--no-plots"]
    )
    assert r.exit_code == 0, r.output  # done, warned (issue 24: one rule, no 1)
    assert "unassemblable at driver angle 92° (8° from the start) to driver angle 85°" in r.output
    import csv

    rows = list(csv.reader((tmp_path / "o" / "results.csv").open()))
    assert len(rows) == 1 + 16
    assert rows[-1][-2].startswith("unassemblable: loop D")
    assert rows[1][-2] == "ok"


def test_non_grashof_rocker_driven_full_turn_keeps_the_users_branch():
    """A triple rocker driven over a full turn: two dead zones, and after each one the
    sweep resumes on the branch the user chose (B on the left of A -> O4)."""
    a, b, c, d = 1.0, 1.0, 1.0, 1.75
    for method in ("auto", "newton"):
        text = f"""
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 1 rad/s, start: 30 deg}}
sweep: {{range: 360 deg, step: 2 deg}}
solver: {{method: {method}}}
"""
        res = ms.solve(ms.loads(text))
        A = np.stack([a * np.cos(res.u), a * np.sin(res.u)])
        B = np.stack([res.point("B").x, res.point("B").y])
        cross = (d - A[0]) * (B[1] - A[1]) - (0 - A[1]) * (B[0] - A[0])
        assert np.all(cross[res.ok] > 0)
        D = np.hypot(d - A[0], A[1])
        np.testing.assert_array_equal(res.ok, D <= b + c)
        assert len(res.failures) == 1  # one dead zone around 180 deg


def narrow_dead_zone(step: float, method: str) -> str:
    """A four-bar whose coupler just fails to reach around 180 deg, for about 1 deg:
    |A - O4| there is a + d = 2.0, b + c = 1.99995 < 2.0."""
    return f"""
ground: {{O2: [0, 0], O4: [1.2, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [0.8, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [1.2, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [0.79995, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 1 rad/s, start: 5 deg}}
sweep: {{range: 350 deg, step: {step} deg}}
solver: {{method: {method}}}
"""


@pytest.mark.parametrize("method", ["auto", "newton"])
def test_dead_zone_narrower_than_the_step_is_reported(method):
    """A four-bar whose coupler just fails to reach around 180 deg for about 1 deg: a
    10 deg step jumps over it, and the summary says so (the whole-system Newton sweep
    too: it starts again past it on the user's branch)."""
    res = ms.solve(ms.loads(narrow_dead_zone(10, method)))
    assert res.ok.all()
    kinds = [e.kind for e in res.events]
    assert "dead zone" in kinds
    e = next(e for e in res.events if e.kind == "dead zone")
    if method == "auto":  # the minimum of its discriminant, located
        assert math.degrees(e.u) == pytest.approx(180.0, abs=1e-6)
        assert "steps over this dead zone" in res.summary()
    else:  # a point inside the range where it cannot close (about 179.4 to 180.6 deg)
        assert math.degrees(e.u) == pytest.approx(180.0, abs=0.6)
        assert "the motion between these positions is not continuous" in res.summary()
    # on the user's branch on both sides: B left of A -> O4
    th2 = res.u
    A = 0.8 * np.exp(1j * th2)
    B = res.point("B").x + 1j * res.point("B").y
    assert np.all(np.imag((B - A) * np.conj(1.2 - A)) > 0)  # cross(A->O4, A->B) > 0


def test_branch_that_cannot_be_followed_stops_with_a_message(monkeypatch, tmp_path):
    """If even the finest substeps jump (forced here by allowing no substeps at all) at a
    position where the group still closes, the branch past it is not known: the sweep
    stops there, keeping what it solved (right), and says where, suggesting a smaller
    step; it used to raise and lose everything."""
    import mechsolve.groups.generic as generic

    monkeypatch.setattr(generic, "MAX_DEPTH", 0)
    f = tmp_path / "p.yaml"
    f.write_text(parallelogram("newton", 30, 10))
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert "cannot be followed continuously" in r.output and "use a smaller step" in r.output
    assert "not solved at" in r.output and "unassemblable" not in r.output
    res = ms.solve(ms.loads(parallelogram("newton", 30, 10)))
    assert res.ok[0] and not res.ok[-1]
    k = np.flatnonzero(res.ok)
    assert np.array_equal(k, np.arange(len(k)))  # what it solved, up to where it stopped
    # ... is the parallelogram: the rocker parallel to the crank
    d = res.link("rocker").angle[k] - res.link("crank").angle[k]
    assert np.allclose(np.angle(np.exp(1j * d)), 0.0, atol=1e-9)


# --- redundant constraints ------------------------------------------------------------

REDUNDANT = """
# a parallelogram with a third parallel crank: one redundant constraint
ground: {O2: [0, 0], O4: [3, 0], O6: [1.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [1, 0]}, mass: 2, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [3, 0], C: [1.5, 0]}, mass: 6, uniform_bar: [A, B]}
  crank2: {points: {O4: [0, 0], B: [1, 0]}, mass: 2, uniform_bar: [O4, B]}
  crank3: {points: {O6: [0, 0], C: [1, 0]}, mass: 3, uniform_bar: [O6, C]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, crank2]
  O4: [ground, crank2]
  C: [coupler, crank3]
  O6: [ground, crank3]
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 2 rad/s, start: 20 deg}
sweep: {range: 140 deg, step: 10 deg}
"""


def test_redundant_parallelogram_kinematics_and_unique_torque(tmp_path):
    res = ms.solve(ms.loads(REDUNDANT))
    red = res.analysis.redundancy
    assert red is not None and red.count == 1
    assert res.ok.all()
    # every crank turns with the driver, the coupler translates
    for crank in ("crank", "crank2", "crank3"):
        np.testing.assert_allclose(wrap(res.link(crank).angle - res.u), 0, atol=1e-12)
        np.testing.assert_allclose(res.link(crank).omega, 2.0, atol=1e-12)
    np.testing.assert_allclose(res.link("coupler").angle, 0, atol=1e-12)
    # hand solution: the kinetic energy is constant, so T w = power against gravity:
    # T = g cos(theta) (sum over the cranks of m l/2 + m_coupler l)
    hand = 9.81 * np.cos(res.u) * (2 * 0.5 + 2 * 0.5 + 3 * 0.5 + 6 * 1.0)
    np.testing.assert_allclose(res.driving_effort, hand, rtol=0, atol=1e-9 * np.max(hand))
    f = res.forces
    assert "driver" not in f.nonunique and set(f.nonunique) == {"O2", "A", "B", "O4", "C", "O6"}
    headers = [c.header for c in res.columns()]
    assert "O6(ground->crank3).Fx [N] (minimum-norm)" in headers
    assert "input.torque [N*m]" in headers
    # the minimum-norm reactions still balance every link: the power balance holds
    assert np.max(np.abs(f.residual)) < 1e-9 * res.power_scale()
    text = res.summary()
    assert "redundant constraints: 1 equation(s)" in text and "driving torque is unique" in text
    # the single equation to remove is named: one component of the third crank's joints
    assert len(red.removable) == 1 and red.removable[0] in ("O6 (x)", "O6 (y)", "C (x)", "C (y)")
    assert f"without {red.removable[0]} the constraints are independent" in text
    f = tmp_path / "r.yaml"
    f.write_text(REDUNDANT)
    r = CliRunner().invoke(main, ["check", str(f)])
    assert r.exit_code == 0 and "0 by Grübler" in r.output and "1 by the rank" in r.output
    assert "the two counts differ" in r.output and "redundant constraints" in r.output
    # every group of the start assembly is listed with its branch
    assert "groups of the start assembly (without the redundant equations)" in r.output
    assert "    3. " in r.output and "loop" in r.output


def test_redundant_parallelogram_torque_at_collinearity_is_its_limit():
    """Through its collinear positions the redundant parallelogram's reactions are not
    determined, but its driving torque is (the hand solution holds at every angle): it is
    given there as its limit along the motion."""
    text = REDUNDANT.replace("start: 20 deg", "start: 30 deg").replace(
        "range: 140 deg, step: 10 deg", "range: 360 deg, step: 30 deg"
    )
    res = ms.solve(ms.loads(text))
    hand = 9.81 * np.cos(res.u) * (2 * 0.5 + 2 * 0.5 + 3 * 0.5 + 6 * 1.0)
    singular = sorted(i for i, _ in res.forces.singular)
    assert singular == [5, 11] and sorted(res.forces.effort_by_limit) == singular
    np.testing.assert_allclose(res.driving_effort, hand, rtol=0, atol=1e-6)
    assert np.isnan(res.reaction("O2")["Fx"][5])
    assert "is its limit along the motion" in res.summary()


def test_inconsistent_redundant_constraints_cannot_assemble():
    text = REDUNDANT.replace(
        "crank3: {points: {O6: [0, 0], C: [1, 0]}", "crank3: {points: {O6: [0, 0], C: [1.1, 0]}"
    )
    with pytest.raises(ms.AssemblyError, match="over-constrained and cannot close"):
        ms.solve(ms.loads(text))


@pytest.mark.parametrize("side", ["left", "right"])
def test_two_identical_links_in_parallel(side):
    """A four-bar whose coupler is doubled (two identical links between A and B).

    The file draws every link along +x, so the start guess is a singular configuration
    where the direction of Newton's first step is decided by rounding (by the LAPACK in
    use); the start must honour the condition on either side all the same."""
    text = """
ground: {O2: [0, 0], O4: [1.0, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.3, 0]}}
  coupler: {points: {A: [0, 0], B: [1.1, 0]}}
  twin: {points: {A: [0, 0], B: [1.1, 0]}}
  rocker: {points: {O4: [0, 0], B: [0.8, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  A2: {revolute: [crank, twin], point: A}
  B: [coupler, rocker]
  B2: {revolute: [twin, rocker], point: B}
  O4: [ground, rocker]
assembly: ["B SIDE of A -> O4"]
driver: {joint: O2, speed: 1 rad/s}
sweep: {range: 360 deg, step: 10 deg}
""".replace("SIDE", side)
    res = ms.solve(ms.loads(text), forces=False)
    assert res.analysis.redundancy is not None and res.ok.all()
    th3, th4, *_ = fourbar(0.3, 1.1, 0.8, 1.0, res.u, 1.0, 1)
    np.testing.assert_allclose(
        wrap(res.link("twin").angle - res.link("coupler").angle), 0, atol=1e-12
    )
    # B left of the line A -> O4 at the start (crank along +x): B above the x axis
    B = res.point("B")
    assert (B.y[0] > 0) == (side == "left")
    ref = (
        th4
        if np.all(np.abs(wrap(res.link("rocker").angle - th4)) < 1e-6)
        else fourbar(0.3, 1.1, 0.8, 1.0, res.u, 1.0, -1)[1]
    )
    np.testing.assert_allclose(wrap(res.link("rocker").angle - ref), 0, atol=1e-10)


# --- a class-III group (triad), solved by Newton, against a 1-D construction -----------


def triad_reference(th, geo):
    """Stephenson six-bar: crank O-A drives a ternary link T (P1, P2, P3) held by three
    binary links: G1-P1, G2-P2 and A-P3. For each crank angle, the angle phi of G1 -> P1
    is found by Brent's method so that |P3 - A| = l3 (P2 from a circle intersection);
    the rates come from the loop equations written in link angles."""
    from scipy.optimize import brentq

    G1, G2, r, l1, l2, l3, p1, p2, p3, phi0, br = geo
    p12 = np.subtract(p2, p1)
    p13 = np.subtract(p3, p1)
    d12 = math.hypot(*p12)

    def build(phi, t):
        P1 = np.array(G1) + l1 * np.array([math.cos(phi), math.sin(phi)])
        dx, dy = G2[0] - P1[0], G2[1] - P1[1]
        D = math.hypot(dx, dy)
        cg = (d12 * d12 + D * D - l2 * l2) / (2 * d12 * D)
        if abs(cg) > 1:
            return None
        ang = math.atan2(dy, dx) + br * math.acos(cg)
        P2 = P1 + d12 * np.array([math.cos(ang), math.sin(ang)])
        psi = ang - math.atan2(p12[1], p12[0])  # T's frame angle
        c, s = math.cos(psi), math.sin(psi)
        P3 = P1 + np.array([c * p13[0] - s * p13[1], s * p13[0] + c * p13[1]])
        A = np.array([r * math.cos(t), r * math.sin(t)])
        return P1, P2, P3, psi, A

    def f(phi, t):
        b = build(phi, t)
        return np.inf if b is None else math.hypot(*(b[2] - b[4])) - l3

    out = []
    phi = phi0
    for t in th:
        lo, hi = phi - 0.2, phi + 0.2
        grid = np.linspace(lo, hi, 81)
        vals = [f(x, t) for x in grid]
        k = min(
            (
                i
                for i in range(80)
                if np.isfinite(vals[i]) and np.isfinite(vals[i + 1]) and vals[i] * vals[i + 1] <= 0
            ),
            key=lambda i: abs(grid[i] - phi),
        )
        phi = brentq(f, grid[k], grid[k + 1], args=(t,), xtol=1e-15, rtol=1e-15)
        P1, P2, P3, psi, A = build(phi, t)
        phi2 = math.atan2(P2[1] - G2[1], P2[0] - G2[0])
        phi3 = math.atan2(P3[1] - A[1], P3[0] - A[0])
        out.append((phi, psi, phi2, phi3, P3, A))
    return out


def test_stephenson_triad_against_one_dimensional_construction():
    # a configuration built first, the link lengths taken from it
    G1, G2 = (0.0, 1.2), (0.96, 1.63)
    r = 0.4
    p1, p2, p3 = (0.0, 0.0), (0.9, 0.1), (0.4, -0.5)
    t0, phi0 = 0.3, math.radians(-60)
    P1 = np.array(G1) + 0.7 * np.array([math.cos(phi0), math.sin(phi0)])
    psi0 = 0.2
    rot = np.array([[math.cos(psi0), -math.sin(psi0)], [math.sin(psi0), math.cos(psi0)]])
    P2 = P1 + rot @ np.subtract(p2, p1)
    P3 = P1 + rot @ np.subtract(p3, p1)
    A0 = np.array([r * math.cos(t0), r * math.sin(t0)])
    l1, l2, l3 = 0.7, float(np.hypot(*(P2 - G2))), float(np.hypot(*(P3 - A0)))
    dx, dy = G2[0] - P1[0], G2[1] - P1[1]
    ang_true = math.atan2(P2[1] - P1[1], P2[0] - P1[0])
    br = 1 if (ang_true - math.atan2(dy, dx)) % (2 * math.pi) < math.pi else -1
    text = f"""
ground: {{O: [0, 0], G1: [{G1[0]}, {G1[1]}], G2: [{G2[0]}, {G2[1]}]}}
links:
  crank: {{points: {{O: [0, 0], A: [{r}, 0]}}}}
  L1: {{points: {{G1: [0, 0], P1: [{l1}, 0]}}}}
  L2: {{points: {{G2: [0, 0], P2: [{l2!r}, 0]}}}}
  L3: {{points: {{A: [0, 0], P3: [{l3!r}, 0]}}}}
  T: {{points: {{P1: [{p1[0]}, {p1[1]}], P2: [{p2[0]}, {p2[1]}], P3: [{p3[0]}, {p3[1]}]}}}}
joints:
  O: [ground, crank]
  A: [crank, L3]
  P3: [L3, T]
  P1: [L1, T]
  G1: [ground, L1]
  P2: [T, L2]
  G2: [ground, L2]
assembly:
  sketch: {{P1: {[float(v) for v in P1]}, P2: {[float(v) for v in P2]},
           P3: {[float(v) for v in P3]}}}
driver: {{joint: O, speed: 1.5 rad/s, start: {t0} rad}}
sweep: {{range: 60 deg, step: 2 deg}}
"""
    res = ms.solve(ms.loads(text))
    assert [g.kind for g in res.analysis.plan] == ["driver link", "Newton"]
    assert res.ok.all()
    ref = triad_reference(res.u, (G1, G2, r, l1, l2, l3, p1, p2, p3, phi0, br))
    phi = np.array([x[0] for x in ref])
    psi = np.array([x[1] for x in ref])
    np.testing.assert_allclose(wrap(res.link("L1").angle - phi), 0, atol=1e-9)
    np.testing.assert_allclose(wrap(res.link("T").angle - psi), 0, atol=1e-9)
    # rates: the loop equations G1 + l1 e1 + R(psi)(p2 - p1) = G2 + l2 e2 and
    # G1 + l1 e1 + R(psi)(p3 - p1) = A + l3 e3, differentiated: 4 equations in
    # (w1, wT, w2, w3)
    w = 1.5
    for k in range(0, len(res.u), 5):
        ph, ps, ph2, ph3, _, _ = ref[k]
        t = res.u[k]

        def perp_rot(v, ang):
            c, s = math.cos(ang), math.sin(ang)
            x, y = c * v[0] - s * v[1], s * v[0] + c * v[1]
            return np.array([-y, x])

        e1p = l1 * np.array([-math.sin(ph), math.cos(ph)])
        M = np.zeros((4, 4))
        M[:2, 0] = e1p
        M[:2, 1] = perp_rot(np.subtract(p2, p1), ps)
        M[:2, 2] = -l2 * np.array([-math.sin(ph2), math.cos(ph2)])
        M[2:, 0] = e1p
        M[2:, 1] = perp_rot(np.subtract(p3, p1), ps)
        M[2:, 3] = -l3 * np.array([-math.sin(ph3), math.cos(ph3)])
        rhs = np.zeros(4)
        rhs[2:] = r * w * np.array([-math.sin(t), math.cos(t)])
        w1, wT, w2, w3 = np.linalg.solve(M, rhs)
        assert res.link("L1").omega[k] == pytest.approx(w1, rel=1e-9, abs=1e-12)
        assert res.link("T").omega[k] == pytest.approx(wT, rel=1e-9, abs=1e-12)
        assert res.link("L3").omega[k] == pytest.approx(w3, rel=1e-9, abs=1e-12)


TRIAD = """
units: {length: mm, angle: deg}
ground: {O1: [0, 0], O2: [150, -20], O3: [60, 120]}
links:
  crank: {points: {O1: [0, 0], A: [20, 0]}}
  p: {points: {A: [0, 0], B: [72.1110255, 0]}}
  tern: {points: {B: [0, 0], C: [60, 0], D: [10, 70]}}
  q: {points: {O2: [0, 0], C: [60.8276253, 0]}}
  r: {points: {O3: [0, 0], D: [31.6227766, 0]}}
joints:
  O1: [ground, crank]
  A: [crank, p]
  B: [p, tern]
  C: [tern, q]
  O2: [ground, q]
  D: [tern, r]
  O3: [ground, r]
assembly:
  sketch: SKETCH
driver: {joint: O1, speed: 10 rad/s}
sweep: {range: 30 deg, step: 5 deg}
"""


@pytest.mark.parametrize(
    "sketch",
    [
        # a closed position (B, C, D exact), one sketched point per link
        {"B": (80, 40), "C": (140, 40), "D": (90, 110)},
        # the other assembly near it, sketched roughly
        {"B": (88, 24), "C": (146, 41), "D": (78, 94)},
    ],
)
def test_a_one_point_sketch_chooses_the_triads_assembly(sketch):
    """A Newton group starts from the sketch even when each link has only one sketched
    point: the assembly reached is the one nearest to the sketch."""
    text = TRIAD.replace("SKETCH", str({k: list(v) for k, v in sketch.items()}))
    res = ms.solve(ms.loads(text.replace("'", "")))
    assert res.ok.all()
    assert [g.kind for g in res.analysis.plan] == ["driver link", "Newton"]
    for name, (x, y) in sketch.items():
        pt = res.point(name)
        assert math.hypot(pt.x[0] * 1e3 - x, pt.y[0] * 1e3 - y) < 2.0, name


# --- limit positions and design figures -----------------------------------------------


def test_shaper_limit_positions_and_time_ratio():
    res = ms.run(MECH / "shaper.yaml", variant="graphical")
    lim = {lp.name: lp for lp in res.limit_positions()}
    ram = lim["ram_guide"]
    assert ram.swing == pytest.approx(2 * 0.54 * 0.11 / 0.38, abs=1e-9)  # the stroke
    # K = (180 + theta) / (180 - theta), theta = 2 asin(110/380): 1.46 in the seed
    theta = 2 * math.degrees(math.asin(110 / 380))
    assert ram.time_ratio == pytest.approx((180 + theta) / (180 - theta), rel=1e-9)
    assert round(ram.time_ratio, 2) == 1.46
    bar = lim["guide_bar"]
    assert math.degrees(bar.swing) == pytest.approx(
        2 * (90 - math.degrees(math.acos(110 / 380))), rel=1e-9
    )
    assert "time ratio: " in res.summary() and "K = 1.46" in res.summary()


def test_crane_jib_swing_is_the_designed_one():
    res = ms.run(MECH / "crane.yaml")
    jib = next(lp for lp in res.limit_positions() if lp.name == "jib")
    # the jib's frame is O3 -> B, 25 deg clockwise of O3 -> C
    lo, hi = math.degrees(jib.low) + 25, math.degrees(jib.high) + 25
    # exactly: at the rocker's limits the crank and the coupler are in line, |O1 B| =
    # l2 -+ l1, and the triangle O3-O1-B gives the angle of O3 -> B
    O1 = (2.86, 4.0)
    d = math.hypot(*O1)
    exact = [
        math.degrees(math.atan2(O1[1], O1[0]) + math.acos((16 + d * d - L * L) / (8 * d))) + 25
        for L in (2.780 - 1.388, 2.780 + 1.388)
    ]
    assert lo == pytest.approx(exact[0], abs=1e-9)
    assert hi == pytest.approx(exact[1], abs=1e-9)
    design = ref("000_crane_design.json")["recomputed"]  # found on a grid: within 1e-6 deg
    assert lo == pytest.approx(design["O3C_swing_with_rounded_l1_l2_deg"][0], abs=1e-5)
    assert hi == pytest.approx(design["O3C_swing_with_rounded_l1_l2_deg"][1], abs=1e-5)
    assert math.degrees(jib.u_low) == pytest.approx(design["K_right_limit"]["theta1_deg"], abs=1e-6)


def test_slider_crank_stroke_time_ratio_and_transmission():
    r, l, e = 0.05, 0.2, 0.01
    res = ms.run(MECH / "slider-crank.yaml")
    cyl = res.limit_positions()[0]
    assert cyl.swing == pytest.approx(
        math.sqrt((l + r) ** 2 - e**2) - math.sqrt((l - r) ** 2 - e**2), rel=1e-12
    )
    # limit positions: crank and rod in line, stretched and folded
    t_out = math.asin(e / (l + r))
    t_in = math.pi + math.asin(e / (l - r))
    fwd = (t_out - t_in) % (2 * math.pi)
    assert cyl.time_ratio == pytest.approx(
        max(fwd, 2 * math.pi - fwd) / min(fwd, 2 * math.pi - fwd), rel=1e-9
    )
    (tr,) = res.transmission_angles()
    # the rod's largest angle to the guide: when the crank is perpendicular to it
    assert math.degrees(tr.angle) == pytest.approx(
        90 - math.degrees(math.asin((r + e) / l)), abs=1e-6
    )


def test_fourbar_minimum_transmission_angle():
    a, b, c, d = 26.5, 105.6, 59.0, 87.5
    res = ms.run(MECH / "fourbar.yaml")
    (tr,) = res.transmission_angles()
    mu0 = math.acos((b * b + c * c - (d - a) ** 2) / (2 * b * c))
    mu180 = math.pi - math.acos((b * b + c * c - (d + a) ** 2) / (2 * b * c))
    assert tr.angle == pytest.approx(min(mu0, mu180), abs=1e-9)


def test_conditioning_column_and_exit_code_help(tmp_path):
    r = CliRunner().invoke(
        main, ["run", str(MECH / "fourbar.yaml"), "-o", str(tmp_path), "--no-plots"]
    )
    assert r.exit_code == 0
    header = (tmp_path / "results.csv").read_text().splitlines()[0].split(",")
    assert "jacobian.rcond [-]" in header
    r = CliRunner().invoke(main, ["--help"])
    for line in ("0    done", "2    bad input", "4    internal error", "5    a design check"):
        assert line in r.output


def test_newton_resumes_on_the_users_branch_after_a_dead_zone():
    """After a dead zone, the whole-system Newton solver must not close positions on the
    first loop's other branch (where the second loop happens to close): found by
    hypothesis, a coupler midpoint E whose dyad E-F-G fails for a third of the turn."""
    text = """
ground: {O2: [0, 0], O4: [1.0, 0], G: [0.0, 0.0]}
links:
  crank: {points: {O2: [0, 0], A: [0.5, 0]}}
  coupler: {points: {A: [0, 0], B: [1.0, 0], E: [0.5, 0.0]}}
  rocker: {points: {O4: [0, 0], B: [1.0, 0]}}
  link5: {points: {E: [0, 0], F: [1.5, 0]}}
  link6: {points: {G: [0, 0], F: [1.0, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker],
         E: [coupler, link5], F: [link5, link6], G: [ground, link6]}
assembly: ["B left of A -> O4", "F left of E -> G"]
driver: {joint: O2, speed: 0.9 rad/s, start: 1.0 rad}
sweep: {range: 360 deg, step: 5 deg}
solver: {method: METHOD}
"""
    auto = ms.solve(ms.loads(text.replace("METHOD", "auto")))
    newton = ms.solve(ms.loads(text.replace("METHOD", "newton")))
    np.testing.assert_array_equal(auto.ok, newton.ok)
    assert [(f.first, f.last) for f in newton.failures] == [(20, 55)]
    both = auto.ok
    np.testing.assert_allclose(newton.point("F").x[both], auto.point("F").x[both], atol=1e-9)
    assert not auto.events  # no event reported inside the unassemblable range


@pytest.mark.parametrize("step", [3, 4, 5])
def test_split_newton_batched_through_a_dead_zone(step):
    """split-newton on a non-Grashof four-bar, 73+ positions (the batched path, whose
    coarse continuation solves the driver group at substeps): every position where the
    closed form closes is solved, on the branch the automatic method keeps."""
    from closed_form import fourbar_disc

    text = f"""
ground: {{O2: [0, 0], O4: [3, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [2, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [2, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [2.5, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: [B left of A -> O4]
driver: {{joint: O2, speed: 1 rad/s, start: 90 deg}}
sweep: {{range: 360 deg, step: {step} deg}}
"""
    mech = ms.loads(text)
    res = ms.solve(mech, method="split-newton")
    auto = ms.solve(mech)
    closes = fourbar_disc(2.0, 2.0, 2.5, 3.0, res.u) >= 0
    np.testing.assert_array_equal(res.ok, closes)
    np.testing.assert_array_equal(auto.ok, closes)
    th4 = wrap(res.link("rocker").angle[res.ok])
    ref = [fourbar(2.0, 2.0, 2.5, 3.0, res.u[res.ok], 1.0, br)[1] for br in (1, -1)]
    on_a_branch = np.minimum(*(np.abs(wrap(th4 - r)) for r in ref))
    assert on_a_branch.max() < 1e-9
    np.testing.assert_allclose(wrap(th4 - auto.link("rocker").angle[res.ok]), 0, atol=1e-9)


def test_limit_positions_of_a_rocker_beside_a_dead_zone():
    """A sweep with an unassemblable range still reports the rocker's limit positions:
    the extreme where its angular velocity vanishes (refined between samples, checked
    against the closed form there) and the toggle side bounded by the last solved sample."""
    text = """
ground: {O2: [0, 0], O4: [3, 0]}
links:
  crank: {points: {O2: [0, 0], A: [2, 0]}}
  coupler: {points: {A: [0, 0], B: [2, 0]}}
  rocker: {points: {O4: [0, 0], B: [2.5, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: [B left of A -> O4]
driver: {joint: O2, speed: 1 rad/s, start: 90 deg}
sweep: {range: 360 deg, step: 5 deg}
"""
    res = ms.solve(ms.loads(text))
    assert res.failures
    (lp,) = res.limit_positions()
    th = np.unwrap(res.link("rocker").angle[res.ok])
    assert lp.low <= th.min() + 1e-12 and lp.high >= th.max() - 1e-12
    assert lp.time_ratio is None  # no full cycle of motion
    # the minimum is a true extreme: the closed form's rocker rate vanishes there
    w4 = [fourbar(2.0, 2.0, 2.5, 3.0, lp.u_low, 1.0, br)[3] for br in (1, -1)]
    assert min(abs(float(w)) for w in w4) < 1e-7


def test_states_on_a_solved_turns_branches_stay_a_parallelogram():
    """``core.states(..., within=sweep)`` solves positions in any order on the branches a
    sweep from the start found, without a new branch analysis: through the parallelogram's
    bifurcations (0 and 180 deg) it must stay a parallelogram (closed form: the coupler
    translates, the rocker turns with the crank), as the full path does."""
    from mechsolve.core import evaluate as core
    from mechsolve.core.sweep import Analysis

    an = Analysis(ms.loads(parallelogram("auto", 1, 10)))
    u0 = an.start_value()
    turn = core.states(an, u0 + np.radians(np.arange(0.0, 360.5, 1.0)), 1.0, 0.0)
    u = u0 + np.r_[np.random.default_rng(3).uniform(0, 2 * np.pi, 300), np.pi - u0, 2 * np.pi]
    w, e = np.full(len(u), 2.0), np.full(len(u), 0.5)
    fast = core.states(an, u, w, e, within=turn)
    full = core.states(an, u, w, e)
    assert fast.ok.all()
    crank, coupler, rocker = (an.system.index[k] for k in ("crank", "coupler", "rocker"))
    np.testing.assert_allclose(wrap(fast.state.th[coupler]), 0.0, atol=1e-12)
    np.testing.assert_allclose(wrap(fast.state.th[rocker] - u), 0.0, atol=1e-12)
    np.testing.assert_allclose(fast.state.w[rocker], 2.0, atol=1e-9)
    np.testing.assert_allclose(fast.state.al[rocker], 0.5, atol=1e-6)
    np.testing.assert_allclose(fast.state.block, full.state.block, rtol=0, atol=1e-9)
    # beyond the solved turn: solved as without it
    out = core.states(an, u0 + np.array([1.0, 7.0]), 2.0, 0.0, within=turn)
    np.testing.assert_allclose(wrap(out.state.th[coupler]), 0.0, atol=1e-12)


@pytest.mark.parametrize("offset", [1e-5, -1e-5, 1e-8, 3e-7])
def test_a_sample_just_past_a_bifurcation_is_not_a_second_event(offset):
    """With the start a hair off the grid that would hit the collinear positions, a
    sample falls 1e-5 rad (or less) past each bifurcation, where the discriminant touches
    zero to rounding. The refined minimum next to it and the sample are one event: two
    would flip the branch twice and fold the parallelogram (the coupler swung 1 rad)."""
    start = 10.0 + math.degrees(offset)
    res = ms.solve(ms.loads(parallelogram("auto", 1, start)))
    assert res.ok.all()
    np.testing.assert_allclose(wrap(res.link("coupler").angle), 0.0, atol=1e-7)
    np.testing.assert_allclose(wrap(res.link("rocker").angle - res.u), 0.0, atol=1e-7)
    angles = sorted(round(math.degrees(e.u) % 360, 3) for e in res.events)
    assert angles == [0.0, 0.0, 180.0, 180.0], angles  # twice round: each position once a turn


@pytest.mark.parametrize("step", [1, 2, 5, 7, 10, 15])
def test_newton_restart_on_a_limit_position_keeps_the_users_branch(step):
    """A slider-crank whose rod equals its crank (r = l = 0.1, e = 0.05) cannot close for
    210 < theta < 330 deg; the whole-system Newton sweep starts again past that range on
    the edge itself, where both branches meet: the positions after it stay on the user's
    branch (C behind A) at every step, not on either by chance (found by review: at a 2
    deg step it drifted onto the other branch), and the edge is no bifurcation."""
    from closed_form import slider_crank

    text = f"""
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [0.1, 0]}}}}
  rod: {{points: {{A: [0, 0], C: [0.1, 0]}}}}
  piston: {{points: {{C: [0, 0]}}}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cyl: {{slider: [ground, piston], point: C, line: {{offset: 0.05, angle: 0}}}}
assembly: ["C.x < A.x"]
driver: {{joint: O, speed: 2 rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: {step} deg}}
solver: {{method: newton}}
"""
    res = ms.solve(ms.loads(text))
    x, *_ = slider_crank(0.1, 0.1, 0.05, res.u, 2.0, False)
    deg = np.degrees(res.u)
    assert np.array_equal(res.ok, ~((deg > 210 + 1e-9) & (deg < 330 - 1e-9)))
    both = res.ok & np.isfinite(x)
    assert np.allclose(res.point("C").x[both], x[both], atol=1e-8)
    assert not [e for e in res.events if e.kind == "bifurcation"]


def test_newton_batched_sweep_reports_a_dead_zone_narrower_than_the_step():
    """The four-bar whose coupler just fails to reach around 180 deg, at a 2 deg step: a
    sweep of that many positions is refined in one batch, which cannot see the range it
    steps over; the determinant's sign change sends it to the sequential sweep, which
    reports the dead zone and keeps the user's branch (found by review: it reported a
    bifurcation and put 88 positions on the other branch)."""
    res = ms.solve(ms.loads(narrow_dead_zone(2, "newton")))
    assert res.ok.all() and len(res.u) >= 64
    assert [e.kind for e in res.events] == ["dead zone"]
    A = 0.8 * np.exp(1j * res.u)
    B = res.point("B").x + 1j * res.point("B").y
    assert np.all(np.imag((B - A) * np.conj(1.2 - A)) > 0)  # cross(A->O4, A->B) > 0


def test_a_streamed_sweep_stops_where_a_chunk_stopped(monkeypatch, tmp_path):
    """A chunk whose Newton sweep stopped (its branch past a jump not known) ends the
    stream there: the next chunk would start from a pose before the break, on a branch
    not known (found by review: the next chunks came back 'ok' as an anti-parallelogram).
    Forced by allowing no substeps in the first chunk alone."""
    import csv

    import mechsolve.groups.generic as generic
    from mechsolve.analyses.chunked import stream
    from mechsolve.core.sweep import Analysis

    solve = Analysis.solve

    def first_chunk_without_substeps(self, u, *args, **kw):
        depth = generic.MAX_DEPTH
        if kw.get("follow") is None and len(u) == 8:
            monkeypatch.setattr(generic, "MAX_DEPTH", 0)
        try:
            return solve(self, u, *args, **kw)
        finally:
            monkeypatch.setattr(generic, "MAX_DEPTH", depth)

    monkeypatch.setattr(Analysis, "solve", first_chunk_without_substeps)
    mech = ms.loads(parallelogram("newton", 30, 10))
    summary, _ = stream(mech, tmp_path / "r.csv", chunk=8, forces=False)
    rows = list(csv.DictReader((tmp_path / "r.csv").open()))
    ok = [r for r in rows if r["status"] == "ok"]
    assert 0 < len(ok) < len(rows) <= 25
    for r in ok:  # what was solved is the parallelogram: the rocker parallel to the crank
        d = math.radians(float(r["rocker.angle [deg]"]) - float(r["crank.angle [deg]"]))
        assert abs(math.remainder(d, 2 * math.pi)) < 1e-9
    assert summary.failures and summary.failures[-1].last == 24
    assert "cannot be followed continuously" in summary.failures[-1].reason
