"""Closed-form groups on moving guides and moving pivots, against independent solutions.

One mechanism holds every closed-form dyad with nothing on the ground but the four-bar
that moves them:

* an RRP dyad whose guide is the four-bar's rocker (turning with a varying angular
  velocity: Coriolis and angular-acceleration terms), its rod pinned to the crank;
* an RPR group whose bar is pinned to the rocker and whose block is pinned to the coupler,
  the bar's line offset from its pivot;
* an RRR dyad pinned to the coupler and to the rocker (both outer joints moving).

The reference positions are written here in closed form (circle intersections, the foot
of a point on a line); velocities and accelerations are their central differences at two
step sizes, extrapolated (Richardson), and the raw differences are shown to converge to
mechsolve's values at second order. The reactions and the driving torque are compared
with a free-body solution of all nine bodies (tests/refsol.py) on these kinematics, with
dampers along both moving slots (their reaction acts on the moving guide).

The shaper (the slotted bar of mechanisms/shaper.yaml, an RPR group, with every link
given a mass) is checked the same way.
"""

from __future__ import annotations

import numpy as np
import pytest

import mechsolve as ms

from closed_form import slotted_bar
from conftest import MECH
from handcalc import fourbar_kinematics
from refsol import Body, Rigid, fd_rates, newton_euler, rot

a_, b_, c_, d_ = 0.3, 1.1, 0.8, 1.0
W = 1.3  # crank speed (rad/s)
L_ROD, E_BAR, L5, L6 = 1.3, 0.05, 0.6, 0.7
PTS = {
    "crank": {"O2": (0, 0), "A": (a_, 0), "E": (0.2, 0.1)},
    "coupler": {"A": (0, 0), "B": (b_, 0), "P": (0.7, 0.25), "P2": (0.4, -0.2)},
    "rocker": {"O4": (0, 0), "B": (c_, 0), "R": (0.5, -0.1), "R2": (0.2, -0.3)},
    "rod": {"E": (0, 0), "M": (L_ROD, 0)},
    "blk": {"M": (0, 0)},
    "blk2": {"P": (0, 0)},
    "bar": {"R": (0, 0), "F": (0, E_BAR), "G": (1, E_BAR)},
    "l5": {"P2": (0, 0), "N": (L5, 0)},
    "l6": {"R2": (0, 0), "N": (L6, 0)},
}
MASS = {  # mass, com, inertia
    "crank": (2.0, (0.1, 0.03), 0.02),
    "coupler": (5.0, (0.5, -0.07), 0.6),
    "rocker": (3.5, (0.35, 0.04), 0.2),
    "rod": (1.8, (0.6, 0.05), 0.25),
    "blk": (0.9, (0.03, -0.02), 0.003),
    "blk2": (0.7, (0.02, 0.04), 0.002),
    "bar": (1.6, (0.45, 0.0), 0.12),
    "l5": (1.1, (0.3, 0.02), 0.03),
    "l6": (1.3, (0.35, -0.02), 0.05),
}
C1, C2 = 35.0, 22.0  # dampers along slot1 and slot2 (N s/m)
F_BAR = (-20.0, 45.0)  # on the bar at G


def text(step="23 deg", forces=True) -> str:
    def link(n):
        pts = ", ".join(f"{p}: {list(v)}" for p, v in PTS[n].items())
        m, g, J = MASS[n]
        mass = f", mass: {m} kg, com: {list(g)}, inertia: {J} kg m^2" if forces else ""
        return f"  {n}: {{points: {{{pts}}}{mass}}}"

    loads = f"""
gravity: 9.81 m/s^2
loads:
  d1: {{damper: slot1, coefficient: {C1} N s/m}}
  d2: {{damper: slot2, coefficient: {C2} N s/m}}
  push: {{force: [{F_BAR[0]} N, {F_BAR[1]} N], at: G}}
"""
    return f"""
ground: {{O2: [0, 0], O4: [{d_}, 0]}}
links:
{chr(10).join(link(n) for n in PTS)}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
  E: [crank, rod]
  M: [rod, blk]
  slot1: {{slider: [rocker, blk], point: M, line: [O4, B]}}
  P: [coupler, blk2]
  R: [rocker, bar]
  slot2: {{slider: [bar, blk2], point: P, line: [F, G]}}
  P2: [coupler, l5]
  R2: [rocker, l6]
  N: [l5, l6]
assembly: ["B left of A -> O4", "N left of P2 -> R2"]
driver: {{joint: O2, speed: {W} rad/s, start: 10 deg}}
sweep: {{range: 360 deg, step: {step}}}
{loads if forces else ""}"""


def _pt(O, th, p):
    return O + rot(th, p)


def positions(th2):
    """Every body's frame origin and angle, and the slider displacements, in closed form."""
    th2 = np.asarray(th2, float)
    k = fourbar_kinematics(a_, b_, c_, d_, th2, 1.0, 1)
    th3, th4 = k["th3"], k["th4"]
    O2 = np.zeros((2, th2.size))
    A = k["A"]
    O4 = np.array([d_, 0.0])[:, None] + O2
    out = {}

    def body(n, O, th):
        out[f"{n}.x"], out[f"{n}.y"], out[f"{n}.th"] = O[0], O[1], th

    body("crank", O2, th2)
    body("coupler", A, th3)
    body("rocker", O4, th4)
    # RRP: the rod from E (crank) to M, the block on the rocker's line O4 -> B, M ahead of
    # the foot of E
    E = _pt(O2, th2, PTS["crank"]["E"])
    u4 = rot(th4, (1.0, 0.0))
    n4 = rot(th4, (0.0, 1.0))
    foot = np.sum((E - O4) * u4, axis=0)
    dist = np.sum((E - O4) * n4, axis=0)
    s1 = foot + np.sqrt(L_ROD**2 - dist**2)
    M = O4 + s1 * u4
    body("rod", E, np.arctan2(M[1] - E[1], M[0] - E[0]))
    body("blk", M, th4)  # the block keeps the guide's orientation
    out["slot1.s"] = s1
    # RPR: the bar pinned at R (rocker), its line at E_BAR from R on its left; the block
    # pinned at P (coupler); the line's direction has a positive component along R -> P
    P = _pt(A, th3, PTS["coupler"]["P"])
    R = _pt(O4, th4, PTS["rocker"]["R"])
    dv = P - R
    D = np.hypot(*dv)
    psi = np.arctan2(dv[1], dv[0]) - np.arcsin(E_BAR / D)
    body("bar", R, psi)
    body("blk2", P, psi)
    out["slot2.s"] = np.sqrt(D * D - E_BAR**2)  # from F, the foot of R on the line
    # RRR: l5 from P2 (coupler) and l6 from R2 (rocker) meet at N, left of P2 -> R2
    P2 = _pt(A, th3, PTS["coupler"]["P2"])
    R2 = _pt(O4, th4, PTS["rocker"]["R2"])
    dv = R2 - P2
    D = np.hypot(*dv)
    along = (L5**2 - L6**2 + D * D) / (2 * D)
    h = np.sqrt(L5**2 - along**2)
    N = P2 + (along * dv + h * np.array([-dv[1], dv[0]])) / D
    body("l5", P2, np.arctan2(N[1] - P2[1], N[0] - P2[0]))
    body("l6", R2, np.arctan2(N[1] - R2[1], N[0] - R2[0]))
    return out


ANGLES = tuple(f"{n}.th" for n in PTS)


@pytest.fixture(scope="module")
def solved():
    res = ms.solve(ms.loads(text()))
    assert res.ok.all() and res.forces.ok.all()
    fd = fd_rates(positions, res.u, angles=ANGLES)
    return res, fd


def _check(name, got, ref, raw, tol):
    """``got`` equals the extrapolated ``ref`` within ``tol``, and the raw second-order
    differences converge to ``got`` (their error falls by about 4 when h halves)."""
    scale = max(1.0, float(np.max(np.abs(ref))))
    err = np.max(np.abs(got - ref))
    assert err <= tol * scale, f"{name}: {err:.3g} > {tol * scale:.3g}"
    e1, e2 = np.max(np.abs(raw[0] - got)), np.max(np.abs(raw[1] - got))
    assert e2 <= 0.3 * e1 + 1e-9 * scale, f"{name}: differences do not converge ({e1}, {e2})"


@pytest.mark.parametrize("link", [n for n in PTS if n not in ("crank",)])
def test_link_motion(solved, link):
    res, fd = solved
    lm = res.link(link)
    th, d1, d2, raw = fd[f"{link}.th"]
    np.testing.assert_allclose(np.angle(np.exp(1j * (lm.angle - th))), 0, atol=1e-12)
    _check(f"{link}.omega", lm.omega, W * d1, [W * r[0] for r in raw], 1e-8)
    _check(f"{link}.alpha", lm.alpha, W * W * d2, [W * W * r[1] for r in raw], 1e-7)
    # and the frame origin's motion
    pt = {"rod": "E", "blk": "M", "blk2": "P", "bar": "R", "l5": "P2", "l6": "R2"}.get(link)
    if pt:
        pm = res.point(pt)
        for ax, q, vq, aq in (("x", pm.x, pm.vx, pm.ax), ("y", pm.y, pm.vy, pm.ay)):
            v, d1, d2, raw = fd[f"{link}.{ax}"]
            np.testing.assert_allclose(q, v, atol=1e-12)
            _check(f"{pt}.v{ax}", vq, W * d1, [W * r[0] for r in raw], 1e-8)
            _check(f"{pt}.a{ax}", aq, W * W * d2, [W * W * r[1] for r in raw], 1e-7)


@pytest.mark.parametrize("slider", ["slot1", "slot2"])
def test_slider_motion_on_a_moving_guide(solved, slider):
    res, fd = solved
    sm = res.slider(slider)
    s, d1, d2, raw = fd[f"{slider}.s"]
    np.testing.assert_allclose(sm.s, s, atol=1e-12)
    _check(f"{slider}.v", sm.v, W * d1, [W * r[0] for r in raw], 1e-8)
    _check(f"{slider}.a", sm.a, W * W * d2, [W * W * r[1] for r in raw], 1e-7)


def _rigid(fd, n):
    x, y, th = fd[f"{n}.x"], fd[f"{n}.y"], fd[f"{n}.th"]
    return Rigid(
        np.array([x[0], y[0]]),
        W * np.array([x[1], y[1]]),
        W * W * np.array([x[2], y[2]]),
        th[0],
        W * th[1],
        W * W * th[2],
    )


def test_reactions_and_driving_torque(solved):
    """Nine free bodies, eleven pins, two slots on moving guides, the driver."""
    res, fd = solved
    lk = {n: _rigid(fd, n) for n in PTS}
    bodies = {n: Body(lk[n]).mass(*MASS[n]) for n in PTS}

    def at(n, p):
        return lk[n].pos(PTS[n][p])

    # dampers along the slots: on the block at its slider point, the opposite on the guide
    # at the same place
    slots = (("rocker", "blk", "M", "slot1", C1), ("bar", "blk2", "P", "slot2", C2))
    for guide, blk, pt, slot, c in slots:
        u = lk[guide].vec((1.0, 0.0))
        f = -c * W * fd[f"{slot}.s"][1] * u
        bodies[blk].force(at(blk, pt), f)
        bodies[guide].force(at(blk, pt), -f)
    bodies["bar"].force(at("bar", "G"), np.array(F_BAR)[:, None])
    pins = [
        ("O2", "ground", "crank"),
        ("A", "crank", "coupler"),
        ("B", "coupler", "rocker"),
        ("O4", "ground", "rocker"),
        ("E", "crank", "rod"),
        ("M", "rod", "blk"),
        ("P", "coupler", "blk2"),
        ("R", "rocker", "bar"),
        ("P2", "coupler", "l5"),
        ("R2", "rocker", "l6"),
        ("N", "l5", "l6"),
    ]
    joints = [("pin", j, a, b, at(b, j)) for j, a, b in pins]
    joints += [
        ("slider", "slot1", "rocker", "blk", at("blk", "M"), lk["rocker"].vec((0.0, 1.0))),
        ("slider", "slot2", "bar", "blk2", at("blk2", "P"), lk["bar"].vec((0.0, 1.0))),
        ("driver", "T", "crank"),
    ]
    ref = newton_euler(bodies, joints)
    tol = 1e-6  # the reference's accelerations are finite differences (about 1e-9)
    T = ref["T"]
    np.testing.assert_allclose(res.driving_effort, T, rtol=0, atol=tol * np.max(np.abs(T)))
    for j, *_ in pins:
        r, s = res.reaction(j), tol * np.max(np.abs(ref[j]))
        np.testing.assert_allclose(r["Fx"], ref[j][0], rtol=0, atol=s, err_msg=j)
        np.testing.assert_allclose(r["Fy"], ref[j][1], rtol=0, atol=s, err_msg=j)
    for j in ("slot1", "slot2"):
        r, s = res.reaction(j), tol * np.max(np.abs(ref[j]))
        np.testing.assert_allclose(r["N"], ref[j][0], rtol=0, atol=s, err_msg=j)
        np.testing.assert_allclose(r["M"], ref[j][1], rtol=0, atol=s, err_msg=j)
    f = res.forces
    assert np.max(np.abs(f.residual)) <= 1e-9 * res.power_scale()


# --- the shaper: the slotted bar as a moving guide, with every link massive -----------
SH = dict(r=0.11, d=0.38, bar=0.54, rod=0.135, yC=0.52844)
SH_MASS = {  # mass, com (local), inertia
    "crank": (3.0, (0.05, 0.01), 0.004),
    "block": (1.2, (0.0, 0.0), 0.001),
    "guide_bar": (200 / 9.81, (0.27, 0.0), 1.1),
    "rod": (2.0, (0.06, 0.005), 0.004),
    "ram": (700 / 9.81, (0.0, 0.0), 0.0),
}


def shaper_positions(th):
    """The shaper in closed form: the bar through the crank pin (closed_form.slotted_bar),
    then the ram C on the line y = yC, ahead of B (the file's branch C.x > B.x)."""
    th = np.asarray(th, float)
    psi, *_ = slotted_bar(SH["r"], SH["d"], th, 1.0)
    B = SH["bar"] * np.array([np.cos(psi), np.sin(psi)])
    Cx = B[0] + np.sqrt(SH["rod"] ** 2 - (SH["yC"] - B[1]) ** 2)
    A = np.array([SH["r"] * np.cos(th), SH["d"] + SH["r"] * np.sin(th)])
    z = np.zeros_like(th)
    return {
        "crank.x": z, "crank.y": z + SH["d"], "crank.th": th,
        "block.x": A[0], "block.y": A[1], "block.th": psi,
        "guide_bar.x": z, "guide_bar.y": z, "guide_bar.th": psi,
        "rod.x": B[0], "rod.y": B[1], "rod.th": np.arctan2(SH["yC"] - B[1], Cx - B[0]),
        "ram.x": Cx, "ram.y": z + SH["yC"], "ram.th": z,
        "slot.s": np.hypot(*A),
    }  # fmt: skip


def test_shaper_with_massive_links_against_free_bodies():
    text = (MECH / "shaper.yaml").read_text()
    mech = ms.loads(text)
    for lk in mech.links:
        m, g, J = SH_MASS[lk.name]
        lk.mass, lk.com, lk.inertia = m, g, J
    mech.loads[0].when = None  # the cutting force all the way
    res = ms.solve(mech, step=np.radians(17))
    assert res.ok.all() and res.forces.ok.all()
    w = mech.driver.speed  # clockwise: negative
    assert w < 0
    fd = fd_rates(
        shaper_positions, res.u, angles=("crank.th", "block.th", "guide_bar.th", "rod.th")
    )
    for n in ("guide_bar", "rod"):
        th, d1, d2, raw = fd[f"{n}.th"]
        _check(f"{n}.omega", res.link(n).omega, w * d1, [w * r[0] for r in raw], 1e-8)
        _check(f"{n}.alpha", res.link(n).alpha, w * w * d2, [w * w * r[1] for r in raw], 1e-7)
    s, d1, d2, raw = fd["slot.s"]
    _check("slot.a", res.slider("slot").a, w * w * d2, [w * w * r[1] for r in raw], 1e-7)

    def rigid(n):
        x, y, th = fd[f"{n}.x"], fd[f"{n}.y"], fd[f"{n}.th"]
        return Rigid(
            np.array([x[0], y[0]]),
            w * np.array([x[1], y[1]]),
            w * w * np.array([x[2], y[2]]),
            th[0],
            w * th[1],
            w * w * th[2],
        )

    lk = {n: rigid(n) for n in SH_MASS}
    bodies = {n: Body(lk[n]).mass(*SH_MASS[n]) for n in SH_MASS}
    C = lk["ram"].O
    bodies["ram"].force(C, np.array([-7000.0, 0.0])[:, None])
    A, B = lk["block"].O, lk["rod"].O
    O2 = lk["crank"].O
    joints = [
        ("pin", "O2", "ground", "crank", O2),
        ("pin", "A", "crank", "block", A),
        ("slider", "slot", "guide_bar", "block", A, lk["guide_bar"].vec((0.0, 1.0))),
        ("pin", "O4", "ground", "guide_bar", 0 * A),
        ("pin", "B", "guide_bar", "rod", B),
        ("pin", "C", "rod", "ram", C),
        ("slider", "ram_guide", "ground", "ram", C, np.array([0 * C[0], 0 * C[0] + 1.0])),
        ("driver", "T", "crank"),
    ]
    ref = newton_euler(bodies, joints)
    tol = 1e-6
    np.testing.assert_allclose(
        res.driving_effort, ref["T"], rtol=0, atol=tol * np.max(np.abs(ref["T"]))
    )
    for j in ("O2", "A", "O4", "B", "C"):
        r, s = res.reaction(j), tol * np.max(np.abs(ref[j]))
        np.testing.assert_allclose(r["Fx"], ref[j][0], rtol=0, atol=s, err_msg=j)
        np.testing.assert_allclose(r["Fy"], ref[j][1], rtol=0, atol=s, err_msg=j)
    for j in ("slot", "ram_guide"):
        r, s = res.reaction(j), tol * np.max(np.abs(ref[j]))
        np.testing.assert_allclose(r["N"], ref[j][0], rtol=0, atol=s, err_msg=j)
        np.testing.assert_allclose(r["M"], ref[j][1], rtol=0, atol=s, err_msg=j)
