"""Base size of a cam against answers worked out by hand from the formulas."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechsolve.analyses.cam.design import Allowance, extremes, min_base_translating, size
from mechsolve.base.cam.laws import LAWS
from mechsolve.base.cam.profile import Follower, base_radius_of, solve
from mechsolve.base.cam.program import build_program

d = math.radians


def program(law, h, rise, dwell1=30, ret=None, angular=False):
    L = LAWS[law]
    ret = rise if ret is None else ret
    return build_program(
        [("rise", d(rise), h, L), ("dwell", d(dwell1), None, None), ("return", d(ret), None, L),
         ("dwell", d(360 - rise - dwell1 - ret), None, None)],
        angular,
    )  # fmt: skip


def test_uniform_velocity_minimum_base():
    """s' = h/beta everywhere on the rise; the worst point is s = 0:
    r0 = h / (beta tan[alpha])."""
    h, beta, alpha = 0.03, d(100), d(30)
    prog = program("uniform-velocity", h, 100)
    r0 = min_base_translating(prog, 0.0, 1, Allowance(alpha, alpha))
    assert r0 == pytest.approx(h / (beta * math.tan(alpha)), rel=1e-10)


def test_parabolic_minimum_base():
    """Parabolic rise, no offset: s0 >= 4 h u / (beta t) - 2 h u^2 grows over the first
    half when 1/(beta t) > 1/2, and falls over the second, so the worst point is u = 1/2:
    r0 = h (2 / (beta tan[alpha]) - 1/2)."""
    h, beta, alpha = 0.025, d(90), d(30)
    assert 1 / (beta * math.tan(alpha)) > 0.5
    prog = program("parabolic", h, 90)
    r0 = min_base_translating(prog, 0.0, 1, Allowance(alpha, alpha))
    assert r0 == pytest.approx(h * (2 / (beta * math.tan(alpha)) - 0.5), rel=1e-9)
    # the cam of that base radius reaches the allowance exactly, at mid-rise
    p = solve(prog, Follower("translating", "roller", r0, roller=0.005), 1,
              np.linspace(0, 2 * math.pi, 7200, endpoint=False))  # fmt: skip
    ex = extremes(p, prog)
    assert ex["rise"][0] == pytest.approx(alpha, abs=1e-9)
    assert math.degrees(ex["rise"][1]) == pytest.approx(45.0, abs=0.05)


def test_offset_and_separate_allowances():
    """Cycloidal rise and return with an offset: the base radius against a brute-force
    search (bisection on r0, checking tan(alpha) = |s' - e| / (s0 + s) at 0.01 deg)."""
    h, e = 0.02, 0.006
    prog = program("cycloidal", h, 80, ret=60)
    allow = Allowance(d(30), d(45))
    r0 = min_base_translating(prog, e, 1, allow)
    th = np.linspace(0, 2 * math.pi, 36000, endpoint=False)
    s, ds, _, _ = prog.eval(th)
    rise, ret = th < d(80), (th >= d(110)) & (th < d(170))

    def ok(r):
        s0 = math.sqrt(r * r - e * e)
        t = np.abs(ds - e) / (s0 + s)
        return t[rise].max() <= math.tan(d(30)) and t[ret].max() <= math.tan(d(45))

    lo, hi = e * 1.0001, 1.0
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    assert r0 == pytest.approx(hi, rel=1e-5)
    # an offset to the other side needs a larger cam
    assert min_base_translating(prog, -e, 1, allow) > r0


def test_flat_face_minimum_base():
    """r0 + s + s'' >= rho_min; for a cycloidal rise s + s'' = h (u - sin(2 pi u)/(2 pi))
    + 2 pi h / beta^2 sin(2 pi u), smallest where its derivative vanishes (solved here by
    dense sampling of the formula)."""
    h, beta = 0.02, d(90)
    prog = program("cycloidal", h, 90)
    u = np.linspace(0, 1, 2_000_001)
    g = h * (u - np.sin(2 * math.pi * u) / (2 * math.pi)) + 2 * math.pi * h / beta**2 * np.sin(
        2 * math.pi * u
    )
    gmin = g.min()
    # the return is the mirror: s + s'' = h - (same function); its minimum is h - max(g')
    g_ret = h * (1 - (u - np.sin(2 * math.pi * u) / (2 * math.pi))) - 2 * math.pi * h / (
        beta**2
    ) * np.sin(2 * math.pi * u)
    need = 0.004 - min(gmin, g_ret.min())
    sz = size(prog, Follower("translating", "flat-faced", 0.0), 1, Allowance(rho_min=0.004))
    assert sz.follower.base_radius == pytest.approx(need, rel=1e-6)
    assert sz.rho_min == pytest.approx(0.004, rel=1e-3)


def test_roller_curvature_sets_the_base():
    """A big roller on a fast rise: the pressure angle allows a small cam, the roller
    does not; the designed cam's smallest convex profile radius is the margin."""
    prog = program("cycloidal", 0.03, 60)
    f = Follower("translating", "roller", 0.0, roller=0.02)
    allow = Allowance(d(70), d(80), rho_min=0.002)
    sz = size(prog, f, 1, allow)
    assert sz.follower.base_radius > min_base_translating(prog, 0.0, 1, allow)
    assert sz.rho_min == pytest.approx(0.002, abs=2e-5)
    assert "curvature" in sz.method


def test_oscillating_design_is_minimal():
    """Seed 001's law: the designed (a, phi0, r0) keep the rise within 40 deg and satisfy
    r0^2 = a^2 + l^2 - 2 a l cos(phi0); 1 % smaller r0 fails for every pivot distance."""
    prog = program("parabolic", d(15), 75, dwell1=10, angular=True)
    f = Follower("oscillating", "roller", 0.0, roller=0.0, arm=0.125)
    allow = Allowance(d(40), d(70))
    sz = size(prog, f, -1, allow)
    g = sz.follower
    assert g.base_radius == pytest.approx(base_radius_of(g.pivot, 0.125, g.start_angle), rel=1e-12)
    assert sz.reached["rise"][0] <= d(40) + 1e-6
    assert sz.reached["return"][0] <= d(70) + 1e-6
    th = np.linspace(0, 2 * math.pi, 1440, endpoint=False)
    r_small = 0.99 * g.base_radius
    best = math.inf
    for a in np.linspace(abs(0.125 - r_small) * 1.001, (0.125 + r_small) * 0.999, 400):
        c = (a * a + 0.125**2 - r_small**2) / (2 * a * 0.125)
        fol = f.with_base(base_radius=r_small, pivot=a, start_angle=math.acos(c))
        ex = extremes(solve(prog, fol, -1, th), prog)
        best = min(best, max(ex["rise"][0] - d(40), ex["return"][0] - d(70)))
    assert best > 0
