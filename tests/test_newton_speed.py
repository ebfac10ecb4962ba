"""Issue 17: the fast Newton path keeps its guarantees.

* the Stephenson triad six-bar (a Newton group) over the whole turn against a
  one-dimensional root search on its closure written here, positions, velocities and
  accelerations to 1e-10;
* the cheap singularity measure (a lower bound of the exact reciprocal condition number,
  from the inverse the velocities use) flags every position the exact one flags, on
  sweeps that pass close to and exactly through singular configurations of a four-bar's
  and of the triad's Newton groups;
* the reduced (angles only) Jacobian is singular exactly where the group's block of
  Phi_q is (determinant test) and its rates agree with the body-coordinate solve.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import mechsolve as ms
from mechsolve.base.state import State
from mechsolve.core.conditioning import group_block, near_singular, rcond, rcond_lower
from mechsolve.core.sweep import Analysis
from mechsolve.groups import NewtonGroup

# the triad of tests/test_hard_cases.py with a 0.2 crank, built from a configuration
G1, G2 = (0.0, 1.2), (0.96, 1.63)
R_CRANK = 0.2
P1L, P2L, P3L = (0.0, 0.0), (0.9, 0.1), (0.4, -0.5)
T0, PHI0, PSI0, L1 = 0.3, math.radians(-60), 0.2, 0.7


def _geometry():
    P1 = np.array(G1) + L1 * np.array([math.cos(PHI0), math.sin(PHI0)])
    rot = np.array([[math.cos(PSI0), -math.sin(PSI0)], [math.sin(PSI0), math.cos(PSI0)]])
    P2 = P1 + rot @ np.subtract(P2L, P1L)
    P3 = P1 + rot @ np.subtract(P3L, P1L)
    A0 = R_CRANK * np.array([math.cos(T0), math.sin(T0)])
    l2, l3 = float(np.hypot(*(P2 - G2))), float(np.hypot(*(P3 - A0)))
    return P1, P2, P3, l2, l3


def _triad_text(n: int, method: str = "auto") -> str:
    P1, P2, P3, l2, l3 = _geometry()
    return f"""
ground: {{O: [0, 0], G1: [{G1[0]}, {G1[1]}], G2: [{G2[0]}, {G2[1]}]}}
links:
  crank: {{points: {{O: [0, 0], A: [{R_CRANK}, 0]}}}}
  L1: {{points: {{G1: [0, 0], P1: [{L1}, 0]}}}}
  L2: {{points: {{G2: [0, 0], P2: [{l2!r}, 0]}}}}
  L3: {{points: {{A: [0, 0], P3: [{l3!r}, 0]}}}}
  T: {{points: {{P1: [{P1L[0]}, {P1L[1]}], P2: [{P2L[0]}, {P2L[1]}], P3: [{P3L[0]}, {P3L[1]}]}}}}
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
driver: {{joint: O, speed: 2 rad/s, start: {T0} rad}}
sweep: {{range: {360 * (n - 1) / n!r} deg, steps: {n - 1}}}
solver: {{method: {method}}}
"""


def _closure_reference(th):
    """For each crank angle: L1's angle phi by Brent's method on |P3 - A| - l3 (P2 by a
    circle intersection on the assembled branch), then every link's angle."""
    P1s, P2s, _, l2, l3 = _geometry()
    p12, p13 = np.subtract(P2L, P1L), np.subtract(P3L, P1L)
    d12 = math.hypot(*p12)
    dx, dy = G2[0] - P1s[0], G2[1] - P1s[1]
    ang = math.atan2(P2s[1] - P1s[1], P2s[0] - P1s[0])
    br = 1 if (ang - math.atan2(dy, dx)) % (2 * math.pi) < math.pi else -1

    def build(phi, t):
        P1 = np.array(G1) + L1 * np.array([math.cos(phi), math.sin(phi)])
        ex, ey = G2[0] - P1[0], G2[1] - P1[1]
        D = math.hypot(ex, ey)
        cg = (d12 * d12 + D * D - l2 * l2) / (2 * d12 * D)
        if abs(cg) > 1:
            return None
        a = math.atan2(ey, ex) + br * math.acos(cg)
        P2 = P1 + d12 * np.array([math.cos(a), math.sin(a)])
        psi = a - math.atan2(p12[1], p12[0])
        c, s = math.cos(psi), math.sin(psi)
        P3 = P1 + np.array([c * p13[0] - s * p13[1], s * p13[0] + c * p13[1]])
        A = np.array([R_CRANK * math.cos(t), R_CRANK * math.sin(t)])
        return P1, P2, P3, psi, A

    def f(phi, t):
        b = build(phi, t)
        return np.inf if b is None else math.hypot(*(b[2] - b[4])) - l3

    out, phi = [], PHI0
    for t in th:
        grid = np.linspace(phi - 0.15, phi + 0.15, 61)
        vals = [f(x, t) for x in grid]
        k = min(
            (
                i
                for i in range(60)
                if np.isfinite(vals[i] * vals[i + 1]) and vals[i] * vals[i + 1] <= 0
            ),
            key=lambda i: abs(grid[i] - phi),
        )
        phi = brentq(f, grid[k], grid[k + 1], args=(t,), xtol=1e-15, rtol=1e-15)
        P1, P2, P3, psi, A = build(phi, t)
        phi2 = math.atan2(P2[1] - G2[1], P2[0] - G2[0])
        phi3 = math.atan2(P3[1] - A[1], P3[0] - A[0])
        out.append((phi, psi, phi2, phi3))
    return np.array(out), l2, l3


def _wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize("method", ["auto", "newton"])
def test_triad_over_the_whole_turn_against_a_root_search(method):
    n = 240  # a batched sweep (>= 64 positions)
    res = ms.solve(ms.loads(_triad_text(n, method)))
    assert res.ok.all()
    kinds = [g.kind for g in res.analysis.plan]
    assert kinds == (["driver link", "Newton"] if method == "auto" else ["Newton"])
    ref, l2, l3 = _closure_reference(res.u)
    names = ["L1", "T", "L2", "L3"]
    for j, name in enumerate(names):
        np.testing.assert_allclose(_wrap(res.link(name).angle - ref[:, j]), 0, atol=1e-10)
    # rates: the two loops G1-P1-P2-G2 and G1-P1-P3-A-O written in the link angles,
    # differentiated once and twice: M w = b, M al = g
    w2 = 2.0
    d2, d3 = np.subtract(P2L, P1L), np.subtract(P3L, P1L)
    for k in range(0, n, 7):
        x, t = ref[k], float(res.u[k])
        vec = [  # each loop's vector of each angle, in that link's own frame
            [(L1, 0.0), tuple(d2), (-l2, 0.0), (0.0, 0.0)],
            [(L1, 0.0), tuple(d3), (0.0, 0.0), (-l3, 0.0)],
        ]
        rot = [
            [
                np.array(
                    [
                        math.cos(x[i]) * v[0] - math.sin(x[i]) * v[1],
                        math.sin(x[i]) * v[0] + math.cos(x[i]) * v[1],
                    ]
                )
                for i, v in enumerate(row)
            ]
            for row in vec
        ]
        M = np.zeros((4, 4))
        for e in range(2):
            for i in range(4):
                M[2 * e : 2 * e + 2, i] = (-rot[e][i][1], rot[e][i][0])
        crank = R_CRANK * np.array([math.cos(t), math.sin(t)])
        b = np.r_[0.0, 0.0, -crank[1] * w2, crank[0] * w2]
        w = np.linalg.solve(M, b)
        g = np.zeros(4)
        for e in range(2):
            for i in range(4):
                g[2 * e : 2 * e + 2] += rot[e][i] * w[i] ** 2
        g[2:] -= crank * w2 * w2
        al = np.linalg.solve(M, g)
        for j, name in enumerate(names):
            lk = res.link(name)
            assert abs(lk.omega[k] - w[j]) <= 1e-10 * max(1.0, abs(w[j])), (name, k)
            assert abs(lk.alpha[k] - al[j]) <= 1e-10 * max(1.0, abs(al[j])), (name, k)


# --- the cheap singularity measure ----------------------------------------------------


FOURBAR = """
ground: {O2: [0, 0], O4: [0.0875, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.0265, 0]}}
  coupler: {points: {A: [0, 0], B: [0.1056, 0]}}
  rocker: {points: {O4: [0, 0], B: [0.059, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
driver: {joint: O2, speed: 1 rad/s, start: 0}
sweep: {range: 30 deg, step: 1 deg}
"""


def _groups():
    fb = Analysis(ms.loads(FOURBAR), "split-newton")
    tr = Analysis(ms.loads(_triad_text(12)), "auto")
    out = []
    for an in (fb, tr):
        g = an.plan[-1]
        assert isinstance(g, NewtonGroup) and g.red is not None
        out.append((an, g))
    return out


def _det(g, st):
    C = st.c[g.bodies].T
    S = st.s[g.bodies].T
    return np.linalg.det(g.red.jacobian(C, S))


def _state(an, g, th):
    """A state with the group's links at angles ``th`` (N, links); the solved bodies
    (the crank) at a fixed pose. The Jacobians depend on the angles alone."""
    st = State(an.system.nb, th.shape[0])
    for b in range(an.system.nb):
        st.set_angle(b, np.full(th.shape[0], 0.4))
    for b, k in g.col.items():
        st.set_angle(b, th[:, k])
    return st


@pytest.mark.parametrize("which", [0, 1], ids=["four-bar", "triad"])
def test_cheap_measure_flags_every_position_the_exact_one_flags(which):
    an, g = _groups()[which]
    rng = np.random.default_rng(17)
    rows = []
    found = 0
    for _ in range(60):  # lines through angle space; bisect the determinant's sign changes
        a, d = rng.uniform(-np.pi, np.pi, len(g.bodies)), rng.normal(size=len(g.bodies))
        s = np.linspace(-1.5, 1.5, 61)
        dets = _det(g, _state(an, g, a + s[:, None] * d))
        for i in np.flatnonzero(np.sign(dets[:-1]) * np.sign(dets[1:]) < 0)[:2]:
            lo, hi = s[i], s[i + 1]
            flo = dets[i]
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                if mid in (lo, hi):
                    break
                fm = _det(g, _state(an, g, (a + mid * d)[None]))[0]
                if np.sign(fm) == np.sign(flo):
                    lo, flo = mid, fm
                else:
                    hi = mid
            found += 1
            # exactly through (to the last bit), and ever closer to it
            for off in [0.0, 1e-15, -1e-15, 1e-12, -1e-11, 1e-9, -1e-8, 1e-6, 1e-4, 1e-2]:
                rows.append(a + (lo + off) * d)
                rows.append(a + (hi + off) * d)
    assert found >= 10
    st = _state(an, g, np.array(rows))
    exact = rcond(group_block(g, st)[0])
    bound = g.rcond_bound(st)
    # a lower bound, above the rounding noise of both (about 1e-16 at a singular point)
    above = np.isfinite(bound) & (exact > 1e-13)
    assert np.all(bound[above] <= exact[above] * (1 + 1e-9))
    for thr in (1e-10, 1e-7, 1e-4, 1e-2):
        want = exact <= thr
        got = near_singular(g, st, thr)
        np.testing.assert_array_equal(got, want)  # the exact value decides where flagged
        assert want.any()
        # the cheap one alone never misses a flagged position
        assert np.all(~(bound > thr)[want])
    # the exact measure is computed only near the singular configurations: the bound
    # is within a constant factor of the exact value
    far = exact > 1e-3
    assert far.any() and np.all(bound[far] > 1e-7)
    print("largest ratio exact / bound:", float(np.max(exact[above] / bound[above])))


def test_cheap_measure_on_a_sweep_through_a_toggle():
    """A four-bar driven by its rocker, swept exactly to its limit (crank and coupler
    in line: the Newton group of crank and coupler singular) and near it."""
    a, b, c, d = 0.3, 0.8, 0.6, 1.0  # rocker-driven: the crank group toggles
    lim = math.acos(((a + b) ** 2 - c * c - d * d) / (-2 * c * d))  # O4's angle at a toggle
    text = f"""
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
driver: {{joint: O4, speed: 1 rad/s, start: {math.pi - lim + 0.3!r} rad}}
sweep: {{range: 60 deg, step: 1 deg}}
"""
    an = Analysis(ms.loads(text), "split-newton")
    g = next(h for h in an.plan if isinstance(h, NewtonGroup) and len(h.bodies) == 2)
    assert g.red is not None
    u0 = math.pi - lim
    u = u0 + np.r_[0.3 - np.arange(0, 0.3, 0.01), 1e-4, 1e-8, 1e-12, 0.0]
    sol = an.solve(u, start=an.assemble(float(u[0])), limits=False)
    st = sol.state
    exact = rcond(group_block(g, st)[0])
    for thr in (1e-7, 1e-5, 1e-3):
        want = sol.ok & (exact <= thr)
        got = near_singular(g, st, thr) & sol.ok
        np.testing.assert_array_equal(got, want)
    assert exact[sol.ok][-1] < 1e-5  # the sweep really reaches the toggle


def test_generic_lower_bound_is_a_lower_bound():
    rng = np.random.default_rng(3)
    J = rng.normal(size=(500, 6, 6))
    J[:100, :, 0] = J[:100, :, 1] * (1 + 10.0 ** -rng.uniform(4, 15, (100, 1)))
    J[100, 2] = 0.0  # a zero row: exactly singular
    lo, ex = rcond_lower(J), rcond(J)
    ok = np.isfinite(lo) & (ex > 1e-13)  # above the rounding noise at singular ones
    assert np.all(lo[ok] <= ex[ok] * (1 + 1e-9)) and np.all(lo[ok] * 6 >= ex[ok] * (1 - 1e-9))
    assert ok.sum() >= 390
    assert not ok[100]


def test_reduced_rates_agree_with_the_body_block():
    """Velocities of the angles-only solve against Phi_q qdot = nu solved in body
    coordinates on the same poses."""
    an = Analysis(ms.loads(_triad_text(120)), "auto")
    sol = an.solve(an.sweep_values(T0)[0], start=an.assemble(T0), limits=False)
    g = an.plan[-1]
    st = sol.state
    qd = g._solve_batch(st, g._rhs(st, type("D", (), {"ud": np.ones(st.n)})(), 1))
    for b, k in g.col.items():
        # the solved bodies' rates are in time units already (the crank's: 2 rad/s)
        np.testing.assert_allclose(st.w[b], qd[:, 3 * k + 2], atol=1e-12)
        np.testing.assert_allclose(st.vx[b], qd[:, 3 * k], atol=1e-12)
        np.testing.assert_allclose(st.vy[b], qd[:, 3 * k + 1], atol=1e-12)
