"""Cam motion laws against their textbook formulas (written here independently of
mechsolve.base.cam.laws), at many points including the ends and the joins of their pieces."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechsolve.base.cam.laws import LAWS, find_law
from mechsolve.base.cam.program import build_program

PI = math.pi
H = 0.02  # lift 20 mm
B = math.radians(120)  # over 120 deg of cam angle


def textbook(key: str, th: np.ndarray, h: float, b: float):
    """s, ds/dtheta, d2s/dtheta2 of a rise of h over b, as textbooks print them."""
    x = th / b
    if key == "uniform-velocity":
        return h * x, h / b + 0 * x, 0 * x
    if key == "parabolic":  # equal acceleration then equal deceleration
        first = th <= b / 2
        s = np.where(first, 2 * h * th**2 / b**2, h - 2 * h * (b - th) ** 2 / b**2)
        v = np.where(first, 4 * h * th / b**2, 4 * h * (b - th) / b**2)
        a = np.where(first, 4 * h / b**2, -4 * h / b**2)
        return s, v, a
    if key == "simple-harmonic":
        return (
            h / 2 * (1 - np.cos(PI * th / b)),
            PI * h / (2 * b) * np.sin(PI * th / b),
            PI**2 * h / (2 * b**2) * np.cos(PI * th / b),
        )
    if key == "cycloidal":
        return (
            h * (th / b - np.sin(2 * PI * th / b) / (2 * PI)),
            h / b * (1 - np.cos(2 * PI * th / b)),
            2 * PI * h / b**2 * np.sin(2 * PI * th / b),
        )
    if key == "polynomial-345":
        return (
            h * (10 * x**3 - 15 * x**4 + 6 * x**5),
            h / b * (30 * x**2 - 60 * x**3 + 30 * x**4),
            h / b**2 * (60 * x - 180 * x**2 + 120 * x**3),
        )
    if key == "polynomial-4567":
        return (
            h * (35 * x**4 - 84 * x**5 + 70 * x**6 - 20 * x**7),
            h / b * (140 * x**3 - 420 * x**4 + 420 * x**5 - 140 * x**6),
            h / b**2 * (420 * x**2 - 1680 * x**3 + 2100 * x**4 - 840 * x**5),
        )
    if key == "modified-trapezoid":  # Norton, Design of Machinery, eq. 8.15 (to 5/8)
        if np.any(x > 5 / 8):  # the second half by the law's symmetry s(x) = 1 - s(1 - x)
            lo = x <= 5 / 8
            s, v, a = (np.empty_like(x) for _ in range(3))
            s1, v1, a1 = textbook(key, th[lo], h, b)
            s2, v2, a2 = textbook(key, b - th[~lo], h, b)
            s[lo], v[lo], a[lo] = s1, v1, a1
            s[~lo], v[~lo], a[~lo] = h - s2, v2, -a2
            return s, v, a
        s = np.select(
            [x <= 1 / 8, x <= 3 / 8],
            [
                0.38898448 * x - 0.0309544 * np.sin(4 * PI * x),
                2.44406184 * x**2 - 0.22203097 * x + 0.00723407,
            ],
            1.6110154 * x - 0.0309544 * np.sin(4 * PI * x - PI) - 0.3055077,
        )
        v = np.select(
            [x <= 1 / 8, x <= 3 / 8],
            [0.38898448 * (1 - np.cos(4 * PI * x)), 4.88812367 * x - 0.22203097],
            1.6110154 - 0.38898448 * np.cos(4 * PI * x - PI),
        )
        a = np.select(
            [x <= 1 / 8, x <= 3 / 8],
            [4.88812407 * np.sin(4 * PI * x), 4.88812407 + 0 * x],
            4.88812407 * np.sin(4 * PI * x - PI),
        )
        return h * s, h / b * v, h / b**2 * a
    if key == "modified-sine":  # Norton, eq. 8.18
        s = np.select(
            [x <= 1 / 8, x <= 7 / 8],
            [
                0.43990085 * x - 0.0350062 * np.sin(4 * PI * x),
                0.28004957 + 0.43990085 * x - 0.31505577 * np.cos(4 * PI / 3 * x - PI / 6),
            ],
            0.56009915 + 0.43990085 * x - 0.0350062 * np.sin(2 * PI * (2 * x - 1)),
        )
        v = np.select(
            [x <= 1 / 8, x <= 7 / 8],
            [
                0.43990085 * (1 - np.cos(4 * PI * x)),
                0.43990085 * (1 + 3 * np.sin(4 * PI / 3 * x - PI / 6)),
            ],
            0.43990085 * (1 - np.cos(2 * PI * (2 * x - 1))),
        )
        a = np.select(
            [x <= 1 / 8, x <= 7 / 8],
            [
                5.5279571 * np.sin(4 * PI * x),
                5.5279571 * np.cos(4 * PI / 3 * x - PI / 6),
            ],
            5.5279571 * np.sin(2 * PI * (2 * x - 1)),
        )
        return h * s, h / b * v, h / b**2 * a
    raise KeyError(key)


# the ends, the joins of the pieces (1/8, 3/8, 1/2, 5/8, 7/8) and many points between
U = np.unique(np.concatenate([np.linspace(0, 1, 241), [1 / 8, 3 / 8, 0.5, 5 / 8, 7 / 8]]))


@pytest.mark.parametrize("key", sorted(LAWS))
def test_rise_against_textbook(key):
    prog = build_program([("rise", B, H, LAWS[key]), ("dwell", 2 * PI - B, None, None)], False)
    th = U * B * (1 - 1e-12)  # the end itself belongs to the dwell
    s, v, a, _ = prog.eval(th)
    s_ref, v_ref, a_ref = textbook(key, th, H, B)
    # Norton's constants are printed to 8 digits
    tol = 2e-7 if key.startswith("modified") else 1e-12
    assert np.allclose(s, s_ref, rtol=0, atol=tol * H)
    assert np.allclose(v, v_ref, rtol=0, atol=tol * H / B * 10)
    if key != "parabolic":  # its acceleration jumps at 1/2: compare away from it below
        assert np.allclose(a, a_ref, rtol=0, atol=tol * H / B**2 * 100)
    else:
        off = np.abs(U - 0.5) > 1e-9
        assert np.allclose(a[off], a_ref[off], rtol=0, atol=1e-12 * H / B**2)
    # boundary values: starts at rest at 0, ends at h
    assert s[0] == pytest.approx(0.0, abs=1e-15)
    end = prog.segments[0].eval(np.array([B]))
    assert end[0][0] == pytest.approx(H, rel=1e-12)


@pytest.mark.parametrize("key", sorted(LAWS))
def test_return_mirrors_the_rise(key):
    """A return of h is h minus the rise: s_ret(theta) = h - s_rise(theta - start)."""
    prog = build_program(
        [
            ("rise", B, H, LAWS[key]),
            ("dwell", PI / 6, None, None),
            ("return", B, None, LAWS[key]),
            ("dwell", 2 * PI - 2 * B - PI / 6, None, None),
        ],
        False,
    )
    t0 = B + PI / 6
    th = U * B * (1 - 1e-12)
    s, v, a, _ = prog.eval(t0 + th)
    s_ref, v_ref, a_ref = textbook(key, th, H, B)
    tol = 2e-7 if key.startswith("modified") else 1e-12
    assert np.allclose(s, H - s_ref, atol=tol * H)
    assert np.allclose(v, -v_ref, atol=tol * H / B * 10)
    off = np.abs(U - 0.5) > 1e-9
    assert np.allclose(a[off], -a_ref[off], atol=tol * H / B**2 * 100)


def test_peak_coefficients():
    """Peak velocity and acceleration coefficients as tables print them (Norton 8.3)."""
    u = np.linspace(0, 1, 200001)
    table = {
        "uniform-velocity": (1.0, 0.0),
        "parabolic": (2.0, 4.0),
        "simple-harmonic": (PI / 2, PI**2 / 2),
        "cycloidal": (2.0, 2 * PI),
        "polynomial-345": (1.875, 10 / math.sqrt(3)),
        "modified-trapezoid": (2.0, 4.8881),
        "modified-sine": (1.76, 5.5280),
    }
    for key, (cv, ca) in table.items():
        _, f1, f2, _ = LAWS[key](u)
        assert np.max(f1) == pytest.approx(cv, abs=5e-3), key
        assert np.max(np.abs(f2)) == pytest.approx(ca, abs=1e-3), key


def test_jerk_is_the_derivative_of_acceleration():
    """f''' against a centred difference of f'' (a check of the analytic jerk)."""
    u = np.linspace(0.01, 0.99, 97)
    h = 1e-6
    for key, law in LAWS.items():
        jerk = law(u)[3]
        fd = (law(u + h)[2] - law(u - h)[2]) / (2 * h)
        joins = np.min(np.abs(u[:, None] - np.array([1 / 8, 3 / 8, 0.5, 5 / 8, 7 / 8])), axis=1)
        ok = joins > 1e-4
        assert np.allclose(jerk[ok], fd[ok], rtol=1e-5, atol=1e-3), key


def test_names_an_engineer_writes():
    assert find_law("equal acceleration").key == "parabolic"
    assert find_law("Constant_Acceleration").key == "parabolic"
    assert find_law("3-4-5").key == "polynomial-345"
    assert find_law("4-5-6-7 polynomial").key == "polynomial-4567"
    assert find_law("modified trapezoidal").key == "modified-trapezoid"
    assert find_law("simple harmonic").key == "simple-harmonic"
    assert find_law("spline") is None


def _remarks(key):
    prog = build_program(
        [("rise", B, H, LAWS[key]), ("dwell", PI / 2, None, None),
         ("return", B, None, LAWS[key]), ("dwell", 2 * PI - 2 * B - PI / 2, None, None)],
        False,
    )  # fmt: skip
    return prog.remarks()


def test_continuity_remarks():
    uv = _remarks("uniform-velocity")
    assert [r.what for r in uv] == ["velocity"] * 4  # rigid impact at each end of each move
    assert all("rigid impact" in r.text for r in uv)
    assert uv[0].jump == pytest.approx(H / B)
    par = _remarks("parabolic")
    # at both ends of both moves and in the middle of each: soft impact
    assert sorted(round(math.degrees(r.angle), 6) for r in par) == [0, 60, 120, 210, 270, 330]
    assert all(r.what == "acceleration" for r in par)
    harm = _remarks("simple-harmonic")
    assert [r.what for r in harm] == ["acceleration"] * 4
    for key in ("cycloidal", "polynomial-345", "polynomial-4567", "modified-trapezoid",
                "modified-sine"):  # fmt: skip
        assert _remarks(key) == [], key
