"""The cam profile by inversion against closed forms written from the textbook: the
translating roller follower's pitch curve and envelope, its pressure angle
tan(alpha) = (ds/dtheta - e) / (s0 + s), the flat face's r0 + s + s'', the oscillating
follower's pressure angle by the relative instant centre, and seed 001's cam."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from mechsolve.base.cam.laws import LAWS
from mechsolve.base.cam.profile import (
    Follower,
    base_radius_of,
    self_intersections,
    solve,
    start_angle_of,
)
from mechsolve.base.cam.program import build_program

DATA = Path(__file__).parent / "data"
d = math.radians


def program(law="cycloidal", h=0.02, rise=120, dwell1=30, ret=120, angular=False):
    L = LAWS[law]
    return build_program(
        [("rise", d(rise), h, L), ("dwell", d(dwell1), None, None), ("return", d(ret), None, L),
         ("dwell", d(360 - rise - dwell1 - ret), None, None)],
        angular,
    )  # fmt: skip


TH = np.linspace(0, 2 * math.pi, 1441)[:-1]


def textbook_roller(prog, r0, e, rr, th):
    """Translating offset roller follower, cam turning ccw (Sun Huan's form):
    x = (s0 + s) sin d + e cos d, y = (s0 + s) cos d - e sin d; working profile
    x' = x - rr cos b, y' = y - rr sin b with the normal from dx/dd, dy/dd."""
    s, ds, _, _ = prog.eval(th)
    s0 = math.sqrt(r0**2 - e**2)
    x = (s0 + s) * np.sin(th) + e * np.cos(th)
    y = (s0 + s) * np.cos(th) - e * np.sin(th)
    dx = (ds - e) * np.sin(th) + (s0 + s) * np.cos(th)
    dy = (ds - e) * np.cos(th) - (s0 + s) * np.sin(th)
    n = np.hypot(dx, dy)
    cos_b, sin_b = -dy / n, dx / n  # the outward normal (the curve runs clockwise)
    return np.stack([x, y], -1), np.stack([x - rr * cos_b, y - rr * sin_b], -1)


@pytest.mark.parametrize("e", [0.0, 0.008, -0.006])
def test_translating_roller_profile_is_the_closed_form_envelope(e):
    prog = program()
    f = Follower("translating", "roller", 0.05, roller=0.012, offset=e)
    p = solve(prog, f, +1, TH)
    pitch, work = textbook_roller(prog, 0.05, e, 0.012, TH)
    assert np.max(np.abs(p.pitch - pitch)) < 1e-12
    assert np.max(np.abs(p.profile - work)) < 1e-12
    # the roller of radius rr about the pitch point touches the profile point
    assert np.allclose(np.linalg.norm(p.pitch - p.profile, axis=1), 0.012, atol=1e-14)


@pytest.mark.parametrize("law", ["cycloidal", "simple-harmonic", "polynomial-345"])
@pytest.mark.parametrize("e", [0.0, 0.01, -0.01])
def test_translating_pressure_angle_formula(law, e):
    prog = program(law)
    r0 = 0.04
    s, ds, _, _ = prog.eval(TH)
    s0 = math.sqrt(r0**2 - e**2)
    for sense, sign in ((+1, -1.0), (-1, +1.0)):  # ccw: s' - e; cw: the mirror, s' + e
        f = Follower("translating", "roller", r0, roller=0.01, offset=e)
        p = solve(prog, f, sense, TH)
        ref = np.arctan(np.abs(ds + sign * e) / (s0 + s))
        assert np.max(np.abs(p.pressure - ref)) < 1e-12
        # the knife edge has the same pitch curve, so the same pressure angle
        k = solve(prog, Follower("translating", "knife-edge", r0, offset=e), sense, TH)
        assert np.max(np.abs(k.pressure - ref)) < 1e-12


def test_translating_flat_face():
    prog = program("cycloidal")
    r0 = 0.03
    s, ds, d2s, _ = prog.eval(TH)
    for sense in (1, -1):
        p = solve(prog, Follower("translating", "flat-faced", r0), sense, TH)
        assert np.allclose(p.rho_profile, r0 + s + d2s, atol=1e-15)
        assert np.max(p.pressure) < 1e-12  # the face is square to the guide
        # the contact point lies s' off the guide line (to the side the cam surface comes
        # from), on the face at height r0 + s
        assert np.allclose(p.contact[:, 0], sense * ds, atol=1e-15)
        assert np.allclose(p.contact[:, 1], r0 + s, atol=1e-15)
    # undercut where r0 + s + s'' <= 0: a small base circle for a fast rise
    small = solve(program("cycloidal", h=0.05, rise=40, ret=40),
                  Follower("translating", "flat-faced", 0.01), 1, TH)  # fmt: skip
    s, _, d2s, _ = program("cycloidal", h=0.05, rise=40, ret=40).eval(TH)
    assert np.array_equal(small.undercut(), 0.01 + s + d2s <= 0)
    assert small.undercut().any()


def test_curvature_of_a_circle_and_of_a_dwell():
    """A dwell at radius R is an arc of radius R: the pitch radius is R, the working
    profile's R - rr."""
    prog = program()
    p = solve(prog, Follower("translating", "roller", 0.05, roller=0.01), -1, TH)
    dwell = (TH > d(271)) & (TH < d(359))
    assert np.allclose(p.rho_pitch[dwell], 0.05, rtol=1e-12)
    assert np.allclose(p.rho_profile[dwell], 0.04, rtol=1e-12)
    top = (TH > d(122)) & (TH < d(148))
    assert np.allclose(p.rho_pitch[top], 0.07, rtol=1e-12)


def test_curvature_against_the_polygon():
    """The analytic radius of the pitch curve against the circle through three
    neighbouring points of a dense polygon (independent of the formula)."""
    prog = program("polynomial-345")
    th = np.linspace(0, 2 * math.pi, 72001)[:-1]
    f = Follower("oscillating", "roller", 0.04, roller=0.01, arm=0.1, pivot=0.11)
    f = f.with_base(start_angle=start_angle_of(0.11, 0.1, 0.04))
    prog = program("polynomial-345", h=d(20), angular=True)
    p = solve(prog, f, 1, th)
    a, b, c = p.pitch[:-2], p.pitch[1:-1], p.pitch[2:]
    ab, bc, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                  np.linalg.norm(a - c, axis=1))  # fmt: skip
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    with np.errstate(divide="ignore"):
        R = ab * bc * ca / (2 * np.abs(cross))
    rho = np.abs(p.rho_pitch[1:-1])
    ok = rho < 1.0
    assert np.allclose(R[ok], rho[ok], rtol=2e-4)


def oscillating_pressure_by_instant_centre(prog, a, l, phi0, sense, th):
    """Relative instant centre P of cam (about O) and arm (about A = (a, 0)) on line OA:
    omega_cam * p = omega_arm * (p - a), so p = a r / (r - 1), r = omega_arm / omega_cam;
    the common normal passes through the roller centre B and P."""
    psi, dpsi, _, _ = prog.eval(th)
    g = phi0 + psi
    B = np.stack([a - l * np.cos(g), l * np.sin(g)], -1)
    # the arm turns clockwise as psi grows (B goes up and to the left about A)
    r = -dpsi / sense
    out = np.empty_like(th)
    for i in range(th.size):
        if abs(r[i]) < 1e-15:
            P = np.zeros(2)
        else:
            P = np.array([a * r[i] / (r[i] - 1), 0.0])
        n = P - B[i]
        u = (B[i] - np.array([a, 0.0])) / l
        vdir = np.array([-u[1], u[0]])
        out[i] = math.acos(min(abs(n @ vdir) / np.linalg.norm(n), 1.0))
    return out


@pytest.mark.parametrize("sense", [1, -1])
def test_oscillating_pressure_angle_by_instant_centre(sense):
    prog = program("cycloidal", h=d(18), angular=True)
    a, l, r0 = 0.12, 0.1, 0.035
    phi0 = start_angle_of(a, l, r0)
    th = TH[::4]
    f = Follower("oscillating", "roller", r0, roller=0.01, arm=l, pivot=a, start_angle=phi0)
    p = solve(prog, f, sense, th)
    ref = oscillating_pressure_by_instant_centre(prog, a, l, phi0, sense, th)
    assert np.max(np.abs(p.pressure - ref)) < 1e-10


def test_seed_001_base_relation():
    """r0^2 = a^2 + l^2 - 2 a l cos(phi0), l = 125 mm: printed (11.8 deg, 134.27 mm ->
    28.2 mm) and adopted (12.5 deg, 135 mm -> 30 mm), at the printed digits."""
    ref = json.loads((DATA / "cam_001_table5_2.json").read_text())["printed_base_dims"]
    for v in (ref, ref["chosen"]):
        r0 = base_radius_of(v["a_mm"] / 1e3, 0.125, d(v["phi0_deg"]))
        assert round(r0 * 1e3, 1) == pytest.approx(v["r0_mm"], abs=1e-9)
        # and back: phi0 from a, l, r0 to the printed 0.1 deg
        phi = math.degrees(start_angle_of(v["a_mm"] / 1e3, 0.125, r0))
        assert phi == pytest.approx(v["phi0_deg"], abs=1e-9)


def seed_cam(a=0.135, phi0=0.2181661564992912):  # 12.5 deg
    L = LAWS["parabolic"]
    prog = build_program(
        [("rise", d(75), d(15), L), ("dwell", d(10), None, None),
         ("return", d(75), None, L), ("dwell", d(200), None, None)],
        True,
    )  # fmt: skip
    f = Follower("oscillating", "roller", base_radius_of(a, 0.125, phi0), roller=0.015,
                 arm=0.125, pivot=a, start_angle=phi0)  # fmt: skip
    return prog, f


def test_seed_001_pressure_angle():
    """Adopted base values: the largest pressure angle is 48.32 deg at mid-rise in one
    sense (46.20 on the return) and the values swap in the other sense; both by the
    instant centre too."""
    prog, f = seed_cam()
    th = np.linspace(0, 2 * math.pi, 7201)[:-1]
    res = {}
    for sense in (1, -1):
        p = solve(prog, f, sense, th)
        ref = oscillating_pressure_by_instant_centre(prog, 0.135, 0.125, d(12.5), sense, th)
        assert np.max(np.abs(p.pressure - ref)) < 1e-10
        rise, ret = th < d(75), (th > d(85)) & (th < d(160))
        res[sense] = (math.degrees(p.pressure[rise].max()), math.degrees(p.pressure[ret].max()))
        # at mid-move, where the swing's velocity is largest
        assert math.degrees(th[rise][np.argmax(p.pressure[rise])]) == pytest.approx(37.5)
    assert res[-1] == pytest.approx((48.32, 46.20), abs=0.005)
    assert res[1] == pytest.approx((46.20, 48.32), abs=0.005)
    assert 47 <= max(res[-1]) <= 49


def test_self_intersection_check():
    prog = program("cycloidal", h=0.03, rise=60, ret=60)
    good = solve(prog, Follower("translating", "roller", 0.05, roller=0.01), 1, TH)
    assert self_intersections(good.profile) == []
    assert not good.undercut().any()
    # a roller larger than the pitch curve's sharpest convex radius: undercut, and the
    # working profile (the offset curve) loops over itself there
    bad = solve(prog, Follower("translating", "roller", 0.02, roller=0.018), 1, TH)
    assert bad.undercut().any()
    assert self_intersections(bad.profile) != []
    convex = bad.rho_pitch > 0
    assert np.array_equal(bad.undercut(), convex & (bad.rho_pitch <= 0.018))
    # a figure eight is not simple; a square is
    t = np.linspace(0, 2 * math.pi, 400, endpoint=False) + 0.0123  # no vertex at the crossing
    assert self_intersections(np.stack([np.sin(t), np.sin(2 * t)], -1)) != []
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    assert self_intersections(sq) == []
