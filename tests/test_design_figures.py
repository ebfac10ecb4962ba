"""Design figures whose extremes fall between samples, against exact values.

The sweeps are coarse (7 deg, starting at 4 deg) so that no extreme lies on a sample.
References, all independent of mechsolve:

* a crank-rocker's rocker swings between the positions where crank and coupler are
  collinear (|O2 B| = b + a and b - a), and the crank angles there give the time ratio;
* an offset slider-crank's stroke ends where crank and rod are collinear too:
  x = sqrt((l +- r)^2 - e^2) at crank angles asin(e / (l + r)) and pi + asin(e / (l - r));
* the shaper's slotted bar is at its limits where it is tangent to the crank circle
  (sin theta = -r / d), and so is the ram, which follows the bar;
* the transmission angle mu of an RRR loop has cos mu = (L1^2 + L2^2 - D^2) / (2 L1 L2),
  D the distance between its outer joints: its minimum (of sin mu) is at an extreme of D,
  for a crank-rocker where the crank lies along the ground line (0 and 180 deg).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms

from closed_form import fourbar
from conftest import MECH

TIGHT = 1e-9  # the limit positions are roots of the rate found by Brent's method


def wrap(x):
    """Angle difference into (-pi, pi]."""
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def by_name(items, name):
    return next(i for i in items if i.name == name)


# --- a crank-rocker four-bar -----------------------------------------------------------
a_, b_, c_, d_ = 0.3, 1.1, 0.8, 1.0
FOURBAR = f"""
ground: {{O2: [0, 0], O4: [{d_}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a_}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b_}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c_}, 0]}}}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 1 rad/s, direction: DIR, start: 4 deg}}
sweep: {{range: 360 deg, step: 7 deg}}
"""


def collinear_fourbar():
    """Crank angles and rocker angles where crank and coupler are collinear (extended:
    |O2 B| = a + b; folded: |O2 B| = b - a), on the branch B left of A -> O4."""
    out = {}
    for kind, R in (("extended", a_ + b_), ("folded", b_ - a_)):
        # B on the circle R about O2 and c about O4: two intersections, pick the branch
        x = (R * R - c_ * c_ + d_ * d_) / (2 * d_)
        for y in (math.sqrt(R * R - x * x), -math.sqrt(R * R - x * x)):
            th2 = math.atan2(y, x) if kind == "extended" else math.atan2(-y, -x)
            A = (a_ * math.cos(th2), a_ * math.sin(th2))
            left = (d_ - A[0]) * (y - A[1]) - (0 - A[1]) * (x - A[0]) > 0
            if left:
                out[kind] = (th2, math.atan2(y, x - d_))
    return out


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_rocker_limits_and_time_ratio(direction):
    res = ms.solve(ms.loads(FOURBAR.replace("DIR", direction)))
    ref = collinear_fourbar()
    lp = by_name(res.limit_positions(), "rocker")
    (u_ext, th_ext), (u_fold, th_fold) = ref["extended"], ref["folded"]
    hi, lo = (
        (ref["extended"], ref["folded"]) if th_ext > th_fold else (ref["folded"], ref["extended"])
    )
    assert abs(wrap(lp.high - hi[1])) < TIGHT and abs(wrap(lp.low - lo[1])) < TIGHT
    assert abs(wrap(lp.u_high - hi[0])) < TIGHT and abs(wrap(lp.u_low - lo[0])) < TIGHT
    assert lp.swing == pytest.approx(abs(th_ext - th_fold), abs=TIGHT)
    # the samples alone are off by far more: the extremes are not on a sample
    th4 = res.link("rocker").angle
    assert np.max(th4) < lp.high - 1e-6 and np.min(th4) > lp.low + 1e-6
    # time ratio: the driver's travel from the low limit to the high one and back
    sense = 1 if direction == "ccw" else -1
    fwd = (sense * (hi[0] - lo[0])) % (2 * math.pi)
    assert lp.forward == pytest.approx(fwd, abs=TIGHT)
    assert lp.back == pytest.approx(2 * math.pi - fwd, abs=TIGHT)
    K = max(fwd, 2 * math.pi - fwd) / min(fwd, 2 * math.pi - fwd)
    assert lp.time_ratio == pytest.approx(K, abs=TIGHT)
    # the textbook's form: (180 + alpha) / (180 - alpha), alpha the angle between the
    # two collinear crank positions less 180 deg
    alpha = abs(wrap(u_ext - u_fold)) - math.pi
    assert K == pytest.approx((math.pi + abs(alpha)) / (math.pi - abs(alpha)), rel=1e-12)


def transmission_fourbar(th2):
    D2 = a_ * a_ + d_ * d_ - 2 * a_ * d_ * np.cos(th2)
    cos_mu = (b_ * b_ + c_ * c_ - D2) / (2 * b_ * c_)
    return np.arcsin(np.sqrt(1 - cos_mu**2))


def fourbar_at(start):
    return ms.solve(ms.loads(FOURBAR.replace("DIR", "ccw").replace("start: 4", f"start: {start}")))


def test_fourbar_transmission_angle():
    # samples 3 deg before and 4 deg after the minimum at 0 (360)
    res = fourbar_at(98)
    (tr,) = res.transmission_angles()
    mu0, mu180 = transmission_fourbar(0.0), transmission_fourbar(math.pi)
    want, u_want = (mu0, 0.0) if mu0 < mu180 else (mu180, math.pi)
    assert want == pytest.approx(math.acos((b_**2 + c_**2 - (d_ - a_) ** 2) / (2 * b_ * c_)))
    # the samples' own minimum is well above it
    th3, th4, *_ = fourbar(a_, b_, c_, d_, res.u, 1.0, 1)
    sampled = np.arcsin(np.min(np.abs(np.sin(th4 - th3))))
    assert sampled > want + 5e-4
    # sub-sample refinement (a parabola through the three samples around the minimum):
    # 7e-6 rad off at this step; a refinement 0.15 deg off must fail
    assert tr.angle == pytest.approx(want, abs=3e-5)
    assert abs(wrap(tr.u - u_want)) < np.radians(0.1)


def test_fourbar_transmission_angle_exact():
    (tr,) = fourbar_at(98).transmission_angles()
    assert tr.angle == pytest.approx(transmission_fourbar(0.0), abs=1e-8)


def test_fourbar_transmission_angle_between_first_samples():
    # over a full turn the last sample is the first one's neighbour: refined exactly too
    (tr,) = fourbar_at(-2.5).transmission_angles()
    assert tr.angle == pytest.approx(transmission_fourbar(0.0), abs=1e-8)


# --- the offset slider-crank -------------------------------------------------------------
R_, L_, E_ = 0.3, 1.0, 0.1
SLIDER = f"""
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [{R_}, 0]}}}}
  rod: {{points: {{A: [0, 0], C: [{L_}, 0]}}}}
  piston: {{points: {{C: [0, 0]}}}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cyl: {{slider: [ground, piston], point: C, line: {{through: [0, {E_}], angle: 0}}}}
assembly: ["C.x > A.x"]
driver: {{joint: O, speed: 2 rad/s, start: 4 deg}}
sweep: {{range: 360 deg, step: 7 deg}}
"""


def test_slider_stroke_and_time_ratio():
    res = ms.solve(ms.loads(SLIDER))
    lp = by_name(res.limit_positions(), "cyl")
    x_ext, u_ext = math.sqrt((L_ + R_) ** 2 - E_**2), math.asin(E_ / (L_ + R_))
    x_fold, u_fold = math.sqrt((L_ - R_) ** 2 - E_**2), math.pi + math.asin(E_ / (L_ - R_))
    assert lp.kind == "slider"
    assert lp.high == pytest.approx(x_ext, abs=TIGHT)
    assert lp.low == pytest.approx(x_fold, abs=TIGHT)
    assert abs(wrap(lp.u_high - u_ext)) < TIGHT and abs(wrap(lp.u_low - u_fold)) < TIGHT
    assert lp.swing == pytest.approx(x_ext - x_fold, abs=TIGHT)
    x = res.point("C").x
    assert np.max(x) < x_ext - 1e-5 and np.min(x) > x_fold + 1e-5
    fwd = (u_ext - u_fold) % (2 * math.pi)  # from the inner dead centre to the outer
    assert lp.forward == pytest.approx(fwd, abs=TIGHT)
    assert lp.time_ratio == pytest.approx(
        max(fwd, 2 * math.pi - fwd) / min(fwd, 2 * math.pi - fwd), abs=TIGHT
    )
    assert lp.time_ratio > 1.02  # the offset makes it a (mild) quick return
    # the RRP loop's transmission angle: cos of the rod's angle to the guide, smallest
    # where the crank is perpendicular to the guide on the offset's far side
    (tr,) = res.transmission_angles()
    want = math.acos((R_ + E_) / L_)
    assert tr.angle == pytest.approx(want, abs=3e-5)


# --- the shaper ------------------------------------------------------------------------
def test_shaper_quick_return():
    r, d, bar, rod, yC = 0.11, 0.38, 0.54, 0.135, 0.52844
    res = ms.solve(ms.load(MECH / "shaper.yaml"), step=np.radians(7), forces=False)
    lps = res.limit_positions()
    beta = math.asin(r / d)
    # the bar is tangent to the crank circle where sin(theta) = -r / d
    limits = {}
    for th in (-beta, math.pi + beta):
        A = (r * math.cos(th), d + r * math.sin(th))
        psi = math.atan2(A[1], A[0])
        Bx, By = bar * math.cos(psi), bar * math.sin(psi)
        limits[th] = (psi, Bx + math.sqrt(rod**2 - (yC - By) ** 2))
    (th_r, (psi_r, x_r)), (th_l, (psi_l, x_l)) = sorted(limits.items(), key=lambda kv: kv[1][0])
    bar_lp = by_name(lps, "guide_bar")
    assert bar_lp.low == pytest.approx(psi_r, abs=TIGHT)
    assert bar_lp.high == pytest.approx(psi_l, abs=TIGHT)
    assert abs(wrap(bar_lp.u_low - th_r)) < TIGHT and abs(wrap(bar_lp.u_high - th_l)) < TIGHT
    ram = by_name(lps, "ram_guide")
    assert ram.low == pytest.approx(x_l, abs=TIGHT) and ram.high == pytest.approx(x_r, abs=TIGHT)
    assert abs(wrap(ram.u_low - th_l)) < TIGHT and abs(wrap(ram.u_high - th_r)) < TIGHT
    # the crank turns clockwise: the cutting stroke (ram to the right, from its left limit)
    # takes 180 + 2 beta of crank, the return 180 - 2 beta
    K = (math.pi + 2 * beta) / (math.pi - 2 * beta)
    assert ram.time_ratio == pytest.approx(K, abs=TIGHT)
    assert ram.forward == pytest.approx(math.pi + 2 * beta, abs=TIGHT)
    assert bar_lp.time_ratio == pytest.approx(K, abs=TIGHT)


# --- the crane's transmission angles ---------------------------------------------------
def crane_reference():
    """Minimum transmission angles of the crane's two loops from its geometry.

    Loop B (crank O1-A, coupler A-B, jib O3-B): extremes of |A O3| with the crank along
    O1 O3. Loop D (boom C-D, tie O4-D): |C O4| depends on the jib angle only; its extremes
    over the jib's swing are at the jib's limits (crank and coupler collinear) or where
    C crosses the line O3 O4.
    """
    O1, O3, O4 = np.array([2.86, 4.0]), np.array([0.0, 0.0]), np.array([5.6, 8.1])
    l1, l2, l3, lc = 1.388, 2.780, 4.0, 28.525
    boom, tie = 3.625, 25.15

    def sin_mu(D, p, q):
        return math.sqrt(1 - ((p * p + q * q - D * D) / (2 * p * q)) ** 2)

    e = np.linalg.norm(O1 - O3)
    mu_B = min(math.asin(sin_mu(e + s * l1, l2, l3)) for s in (1, -1))
    # jib limits: |O3 ... A B collinear|: B on circles (O1, l2 +- l1) and (O3, l3), left of
    # O3 -> A (the file's branch)
    jib = []
    for R in (l2 + l1, l2 - l1):
        dv = O1 - O3
        x = (l3 * l3 - R * R + e * e) / (2 * e)
        h = math.sqrt(l3 * l3 - x * x)
        ex, ey = dv / e
        for s in (1, -1):
            B = O3 + x * np.array([ex, ey]) + s * h * np.array([-ey, ex])
            A = O1 + (B - O1) * (l1 / R) * (1 if R > l2 else -1)
            # B left of O3 -> A: cross(A - O3, B - O3) > 0
            if (A[0] - O3[0]) * (B[1] - O3[1]) - (A[1] - O3[1]) * (B[0] - O3[0]) > 0:
                jib.append(math.atan2(B[1], B[0]))
    assert len(jib) == 2
    lo, hi = min(jib), max(jib)
    cands = [lo, hi]
    th_line = math.atan2(O4[1], O4[0]) - math.radians(25)  # C on the line O3 -> O4
    for t in (th_line, th_line + math.pi):
        if lo < t < hi:
            cands.append(t)

    def C(t):
        t = t + math.radians(25)
        return lc * np.array([math.cos(t), math.sin(t)])

    mu_D = min(math.asin(sin_mu(np.linalg.norm(C(t) - O4), boom, tie)) for t in cands)
    return mu_B, mu_D, (lo, hi)


def test_crane_jib_swing_and_transmission_angles():
    res = ms.solve(ms.load(MECH / "crane.yaml"), step=np.radians(7), forces=False)
    mu_B, mu_D, (lo, hi) = crane_reference()
    jib = by_name(res.limit_positions(), "jib")
    assert jib.low == pytest.approx(lo, abs=TIGHT) and jib.high == pytest.approx(hi, abs=TIGHT)
    tr = {t.group.split()[1]: t for t in res.transmission_angles()}
    # each minimum is located exactly between the samples (a parabola through three
    # samples was 4e-6 rad off on B and 1.1e-5 on D at this step)
    assert tr["B"].angle == pytest.approx(mu_B, abs=1e-8)
    assert tr["D"].angle == pytest.approx(mu_D, abs=1e-8)
    # and at the file's 10 deg step (the parabola: 6.3e-4 rad off on loop D)
    coarse = ms.solve(ms.load(MECH / "crane.yaml"), forces=False)
    tr = {t.group.split()[1]: t for t in coarse.transmission_angles()}
    assert tr["B"].angle == pytest.approx(mu_B, abs=1e-8)
    assert tr["D"].angle == pytest.approx(mu_D, abs=1e-8)


def test_transmission_minimum_next_to_a_near_singular_event_is_exact():
    """A crank-rocker close to its change point (b + c = a + d + 3e-4): the transmission
    angle dips to about 2.5 deg at a crank angle of 180 deg (a near-singular event of the
    branch analysis). Swept at 7 deg from 3 deg, the minimum falls between samples; it is
    located exactly there too, against the closed form at 180 deg."""
    a, b, c, d = 0.3, 0.8, 0.5003, 1.0
    text = f"""
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: 1 rad/s, start: 3 deg}}
sweep: {{range: 360 deg, step: 7 deg}}
"""
    res = ms.solve(ms.loads(text), forces=False)
    assert any(e.kind == "near-singular" for e in res.events)
    D2 = (a + d) ** 2
    cos_mu = (b * b + c * c - D2) / (2 * b * c)
    want = math.asin(math.sqrt(1 - cos_mu**2))
    (tr,) = res.transmission_angles()
    assert tr.angle == pytest.approx(want, abs=1e-9)
    assert math.degrees(tr.u) % 360 == pytest.approx(180.0, abs=1e-6)
