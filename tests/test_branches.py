"""The branch a sweep follows through singular positions, against an independent
continuation.

The reference here knows nothing of mechsolve's discriminants or events: it marches the
crank in steps of 0.05 degrees, takes both circle intersections for B at every step and
keeps the one nearest to the linear extrapolation of the last two B positions (the smooth
continuation), starting on the side of the line A -> O4 that the assembly condition names,
just after the start. mechsolve, at 4 to 400 positions per turn, must put every solved
position on that motion.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mechsolve as ms

# numpy's warnings at singular positions must not leak through the API
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")


def fourbar_text(a, b, c, d, start_deg, speed, steps, side="left", extra=""):
    return f"""
ground: {{O2: [0, 0], O4: [{d!r}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a!r}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b!r}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c!r}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B {side} of A -> O4"]
driver: {{joint: O2, speed: {speed!r} rad/s, start: {start_deg!r} deg}}
sweep: {{range: 360 deg, steps: {steps}}}
{extra}"""


def _both_b(a, b, c, d, th):
    """The two positions of B (circle about A of radius b, about O4 of radius c), the one
    left of A -> O4 first; None where they do not exist or A is on O4."""
    ax, ay = a * math.cos(th), a * math.sin(th)
    dx, dy = d - ax, -ay
    D2 = dx * dx + dy * dy
    if D2 < 1e-24:
        return None
    along = (b * b - c * c + D2) / (2 * D2)
    h2 = b * b / D2 - along * along
    if h2 < -1e-12:
        return None
    h = math.sqrt(max(h2, 0.0))
    bx, by = ax + along * dx, ay + along * dy
    return (bx - h * dy, by + h * dx), (bx + h * dy, by - h * dx)


def reference_b(a, b, c, d, u, side, direction):
    """B along the smooth motion at the driver angles ``u`` (monotonic, from u[0])."""
    fine = math.radians(0.05)
    out = np.full((len(u), 2), np.nan)
    # the start: on the named side just after the start (two points, for a predictor)
    eps = 1e-7
    hist = []
    for k in (1, 2):
        x = u[0] + direction * k * eps
        pair = _both_b(a, b, c, d, x)
        hist.append((x, np.array(pair[0] if side == "left" else pair[1])))
    cur = hist[-1][0]
    for i, target in enumerate(u):
        # march to just before the target (or just after the start), then read B there
        goal = target - direction * eps if i else target + direction * eps
        n = max(1, math.ceil(abs(goal - cur) / fine))
        for x in np.linspace(cur, goal, n + 1)[1:]:
            pair = _both_b(a, b, c, d, x)
            if pair is None:
                continue
            (x0, b0), (x1, b1) = hist
            pred = b1 + (b1 - b0) * ((x - x1) / (x1 - x0))
            p0, p1 = (np.array(p) for p in pair)
            near0 = np.hypot(*(p0 - pred)) <= np.hypot(*(p1 - pred))
            hist = [hist[-1], (x, p0 if near0 else p1)]
        cur = goal
        out[i] = hist[-1][1]
    return out


@st.composite
def change_point_fourbars(draw):
    """Four-bars whose branches meet during the crank's turn: parallelograms, rhombi,
    kites (deltoids) and general change-point linkages (s + l = p + q), with the crank
    the shortest link so that it turns fully."""
    kind = draw(st.sampled_from(["parallelogram", "rhombus", "kite", "change-point"]))
    r = draw(st.floats(0.2, 1.0))
    L = draw(st.floats(1.2, 3.0)) * r
    if kind == "parallelogram":
        a, b, c, d = r, L, r, L
    elif kind == "rhombus":
        a = b = c = d = r
    elif kind == "kite":  # crank = coupler, rocker = ground
        a, b, c, d = r, r, L, L
    else:  # a + l = p + q with a the shortest
        p = draw(st.floats(1.1, 2.5)) * r
        q = draw(st.floats(1.1, 2.5)) * r
        lng = p + q - r
        b, c, d = draw(st.permutations([lng, p, q]))
        a = r
    return kind, a, b, c, d


@settings(
    max_examples=60,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(
    geo=change_point_fourbars(),
    start=st.one_of(st.sampled_from([0.0, 180.0, 90.0]), st.floats(0.0, 360.0)),
    steps=st.integers(4, 400),
    direction=st.sampled_from([1.0, -1.0]),
    side=st.sampled_from(["left", "right"]),
)
def test_no_solved_position_leaves_the_smooth_motion(geo, start, steps, direction, side):
    kind, a, b, c, d = geo
    text = fourbar_text(a, b, c, d, start, direction, steps, side)
    res = ms.solve(ms.loads(text), forces=False)
    B = res.point("B")
    ref = reference_b(a, b, c, d, res.u, side, direction)
    got = np.column_stack([B.x, B.y])
    ok = res.ok
    assert ok.sum() >= 0.9 * len(ok), res.summary()
    err = np.hypot(*(got[ok] - ref[ok]).T)
    assert np.all(err < 1e-5 * max(a, b, c, d)), (
        kind,
        [math.degrees(x) for x in res.u[ok][err >= 1e-5 * max(a, b, c, d)]],
    )


@pytest.mark.parametrize("steps", [4, 5, 8, 13, 37, 361])
@pytest.mark.parametrize("start", [0.0, 30.0, 180.0])
def test_rhombus_through_coincident_joints(steps, start):
    """All links equal: at 0 deg the crank pin A lies on the rocker's pivot O4, where every
    position of B closes the loop. The parallelogram goes on as a parallelogram; the
    position at 0 deg is solved (it is not 'cannot close'), also as the start."""
    # just after 0 or 30 deg the parallelogram has B left of A -> O4; after 180, right
    side = "right" if start == 180.0 else "left"
    text = fourbar_text(1.0, 1.0, 1.0, 1.0, start, 1.0, steps, side)
    res = ms.solve(ms.loads(text), forces=False)
    assert res.ok.all(), res.summary()
    th2, th4 = res.link("crank").angle, res.link("rocker").angle
    np.testing.assert_allclose(np.sin(th4 - th2), 0, atol=1e-9)
    np.testing.assert_allclose(np.cos(th4 - th2), 1, atol=1e-9)
    np.testing.assert_allclose(np.sin(res.link("coupler").angle), 0, atol=1e-9)
    assert any(e.kind == "bifurcation" for e in res.events)
    # the rates at the coincident position are its limits: the rocker turns with the crank
    np.testing.assert_allclose(res.link("rocker").omega, 1.0, atol=1e-7)


@pytest.mark.parametrize("steps", [4, 7, 37])
def test_rhombus_folded_branch_stays_folded(steps):
    """The other branch of the rhombus: B stays on the crank's pivot O2 (the rocker at
    rest along the ground line) while the coupler turns with the crank, through the
    coincident position at 0 deg as well."""
    text = fourbar_text(1.0, 1.0, 1.0, 1.0, 180.0, 1.0, steps, "left")
    res = ms.solve(ms.loads(text), forces=False)
    assert res.ok.all(), res.summary()
    B = res.point("B")
    np.testing.assert_allclose(np.hypot(B.x, B.y), 0, atol=1e-9)


def test_singular_group_blanks_only_its_own_rates():
    """A rocker-driven four-bar swept exactly to its limit position: the crank's and the
    coupler's rates grow without bound there and are left blank, but the driven rocker's
    prescribed angular velocity, and the positions, stay."""
    a, b, c, d = 0.3, 1.1, 0.8, 1.0
    # limit of the rocker: |O2 B| = a + b
    r = a + b
    cos4 = (r * r - d * d - c * c) / (2 * d * c)
    th_lim = math.degrees(math.acos(cos4))
    text = f"""
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
driver: {{joint: O4, speed: 1 rad/s, direction: cw, start: {th_lim + 30!r} deg}}
sweep: {{range: 30 deg, steps: 31}}
"""
    res = ms.solve(ms.loads(text), forces=False)
    assert res.ok.all()
    last = len(res.u) - 1
    assert res.solution.rates_undetermined == [last]
    assert np.isnan(res.link("crank").omega[last]) and np.isnan(res.link("coupler").alpha[last])
    w = res.link("rocker").omega
    assert w[last] == pytest.approx(w[0]) and abs(w[0]) == pytest.approx(1.0)
    assert res.link("rocker").alpha[last] == pytest.approx(0.0)
    assert np.isfinite(res.point("A").x[last])


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "mechsolve", *args], capture_output=True, text=True, timeout=120
    )


@pytest.mark.parametrize("side", ["left", "right"])
def test_check_and_run_agree_at_a_singular_start(tmp_path, side):
    """Started exactly on the parallelogram's collinear position, where both branches
    coincide, the condition is read just after the start, by `check` and `run` alike."""
    f = tmp_path / "p.yaml"
    f.write_text(fourbar_text(1.0, 2.0, 1.0, 2.0, 0.0, 1.0, 12, side))
    chk = _cli("check", str(f))
    run = _cli("run", str(f), "-o", str(tmp_path / "o"), "--no-plots", "-q")
    assert chk.returncode == 0, chk.stdout + chk.stderr
    assert run.returncode == 0, run.stdout + run.stderr
    res = ms.run(str(f), forces=False)
    th2, th4 = res.link("crank").angle, res.link("rocker").angle
    parallel = np.allclose(np.sin(th4 - th2), 0, atol=1e-9)
    assert parallel == (side == "left")  # just after 0 deg, B left of A -> O4: parallel
    asm = ms.check(ms.load(str(f)))
    assert "B left of A -> O4" in asm.text() or "B right of A -> O4" in asm.text()


def test_sweep_starting_inside_a_dead_zone_skips_ahead():
    """A non-Grashof four-bar started where the coupler and rocker cannot reach the crank
    pin: the sweep skips to the first position that closes (cos(theta) >= 0.125 here,
    from the closed form |A O4| <= b + c), keeps the skipped positions as unassemblable
    rows, says so, and solves the rest on the branch the condition names."""
    text = fourbar_text(0.6, 0.6, 0.5, 1.0, 150.0, 1.0, 360)
    res = ms.solve(ms.loads(text), forces=False)
    closes = (0.36 + 1.0 - 1.2 * np.cos(res.u)) <= 1.1**2 + 1e-12
    np.testing.assert_array_equal(res.ok, closes)
    first = int(np.flatnonzero(closes)[0])
    f = res.failures[0]
    assert (f.first, f.last) == (0, first - 1) and "cannot close" in f.reason
    assert "cannot close at the start of the sweep" in res.summary()
    assert "150° (0° from the start)" in res.summary()
    B = res.point("B")
    ref = np.array([_both_b(0.6, 0.6, 0.5, 1.0, x) or ((np.nan,) * 2,) * 2 for x in res.u])
    np.testing.assert_allclose(B.x[res.ok], ref[res.ok, 0, 0], atol=1e-12)
    np.testing.assert_allclose(B.y[res.ok], ref[res.ok, 0, 1], atol=1e-12)
    np.testing.assert_allclose(res.t, res.u - res.u[0], atol=1e-12)


@pytest.mark.parametrize("step", [1.0, 7.0, 13.0])
def test_edges_of_an_unassemblable_range_are_exact(step):
    """A non-Grashof four-bar: the loop stops closing where |A O4| = b + c, at crank
    angles +-acos(0.125), whatever the step; there the rocker reaches its limit (coupler
    and rocker collinear), which bounds its swing."""
    text = fourbar_text(0.6, 0.6, 0.5, 1.0, 0.0, 1.0, round(360 / step))
    res = ms.solve(ms.loads(text), forces=False)
    edge = math.acos(0.125)
    (f,) = res.failures
    assert f.edge_in == pytest.approx(edge, abs=1e-12)
    assert f.edge_out == pytest.approx(2 * math.pi - edge, abs=1e-12)
    assert "it stops closing at driver angle 82.8192" in res.summary()

    def rocker_at(th):
        A = 0.6 * np.array([math.cos(th), math.sin(th)])
        O4 = np.array([1.0, 0.0])
        B = A + 0.6 * (O4 - A) / np.linalg.norm(O4 - A)
        return math.atan2(B[1], B[0] - 1.0) % (2 * math.pi)

    (lp,) = [lp for lp in res.limit_positions() if lp.name == "rocker"]
    assert lp.u_high % (2 * math.pi) == pytest.approx(2 * math.pi - edge, abs=1e-9)
    # the angle grows as the square root of the distance to the toggle: a root found to
    # rounding (1e-16) gives the angle to about 1e-8
    assert lp.high % (2 * math.pi) == pytest.approx(rocker_at(-edge), abs=1e-7)
