"""Issue 23 §5: hand-made faults that the suite let through, each caught here against a
formula written independently of mechsolve (textbook closed forms, finite differences of
closed-form positions, the SI definitions of the units).

(a) the cam program's jerk divided by beta^2 instead of beta^3;
(b) guide-bar synthesis taking the bar from a given stroke with sin(theta), not sin(theta/2);
(c) a factor of the units table changed in its fourth digit;
(d) a dead-zone event recorded one sample late (the swing and time ratio of a rocker whose
    extreme lies just after the dead zone silently dropped);
(e) the x/y columns of known bodies swapped in a Newton group's rate equations (a slider
    hanging off a four-bar's coupler under ``split-newton``).
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.base.cam.laws import LAWS
from mechsolve.base.cam.program import build_program

PI = math.pi
ROOT = Path(__file__).parent.parent
DATA = Path(__file__).parent / "data"


# -- (a) cam motion laws: displacement, velocity, acceleration and jerk ------------------------


def _textbook(key: str, x: np.ndarray):
    """f, f', f'', f''' of a unit rise over a unit cam angle (x = 0..1), written here from
    the textbook formulas (Norton, Design of Machinery, ch. 8; Shigley, ch. 6). The
    modified laws' second halves follow from their symmetry f(x) = 1 - f(1 - x), which
    makes f' and f''' even and f'' odd about x = 1/2."""
    z = 0.0 * x
    if key == "uniform-velocity":
        return x, 1.0 + z, z, z
    if key == "parabolic":
        first = x < 0.5
        return (
            np.where(first, 2 * x**2, 1 - 2 * (1 - x) ** 2),
            np.where(first, 4 * x, 4 * (1 - x)),
            np.where(first, 4.0, -4.0),
            z,
        )
    if key == "simple-harmonic":
        return (
            (1 - np.cos(PI * x)) / 2,
            PI / 2 * np.sin(PI * x),
            PI**2 / 2 * np.cos(PI * x),
            -(PI**3) / 2 * np.sin(PI * x),
        )
    if key == "cycloidal":
        return (
            x - np.sin(2 * PI * x) / (2 * PI),
            1 - np.cos(2 * PI * x),
            2 * PI * np.sin(2 * PI * x),
            4 * PI**2 * np.cos(2 * PI * x),
        )
    if key == "polynomial-345":
        return (
            10 * x**3 - 15 * x**4 + 6 * x**5,
            30 * x**2 - 60 * x**3 + 30 * x**4,
            60 * x - 180 * x**2 + 120 * x**3,
            60 - 360 * x + 360 * x**2,
        )
    if key == "polynomial-4567":
        return (
            35 * x**4 - 84 * x**5 + 70 * x**6 - 20 * x**7,
            140 * x**3 - 420 * x**4 + 420 * x**5 - 140 * x**6,
            420 * x**2 - 1680 * x**3 + 2100 * x**4 - 840 * x**5,
            840 * x - 5040 * x**2 + 8400 * x**3 - 4200 * x**4,
        )
    if key in ("modified-trapezoid", "modified-sine"):
        half = x <= 0.5
        out = [np.empty_like(x) for _ in range(4)]
        a = _modified_first_half(key, x[half])
        b = _modified_first_half(key, 1 - x[~half])
        for k, sign in enumerate((None, 1, -1, 1)):
            out[k][half] = a[k]
            out[k][~half] = 1 - b[k] if sign is None else sign * b[k]
        return tuple(out)
    raise KeyError(key)


def _modified_first_half(key: str, x: np.ndarray):
    """Norton eqs. 8.15 (modified trapezoid, C = 4.888124) and 8.18 (modified sine,
    C = 5.527957) for x <= 1/2, to their printed digits."""
    if key == "modified-trapezoid":
        c = 4.88812407
        q = 4 * PI
        f = np.select(
            [x <= 1 / 8, x <= 3 / 8],
            [
                0.38898448 * x - 0.0309544 * np.sin(q * x),
                2.44406184 * x**2 - 0.22203097 * x + 0.00723407,
            ],
            1.6110154 * x - 0.0309544 * np.sin(q * x - PI) - 0.3055077,
        )
        f1 = np.select(
            [x <= 1 / 8, x <= 3 / 8],
            [0.38898448 * (1 - np.cos(q * x)), 4.88812367 * x - 0.22203097],
            1.6110154 - 0.38898448 * np.cos(q * x - PI),
        )
        f2 = np.select(
            [x <= 1 / 8, x <= 3 / 8], [c * np.sin(q * x), c + 0 * x], c * np.sin(q * x - PI)
        )
        f3 = np.select(
            [x <= 1 / 8, x <= 3 / 8], [c * q * np.cos(q * x), 0 * x], c * q * np.cos(q * x - PI)
        )
        return f, f1, f2, f3
    c = 5.5279571
    q = 4 * PI
    f = np.where(
        x <= 1 / 8,
        0.43990085 * x - 0.0350062 * np.sin(q * x),
        0.28004957 + 0.43990085 * x - 0.31505577 * np.cos(q / 3 * x - PI / 6),
    )
    f1 = np.where(
        x <= 1 / 8,
        0.43990085 * (1 - np.cos(q * x)),
        0.43990085 * (1 + 3 * np.sin(q / 3 * x - PI / 6)),
    )
    f2 = np.where(x <= 1 / 8, c * np.sin(q * x), c * np.cos(q / 3 * x - PI / 6))
    f3 = np.where(x <= 1 / 8, c * q * np.cos(q * x), -c * q / 3 * np.sin(q / 3 * x - PI / 6))
    return f, f1, f2, f3


# the joins inside the laws, where f'' or f''' jumps: compared beside them, not on them
JOINS = np.array([0.0, 1 / 8, 3 / 8, 0.5, 5 / 8, 7 / 8, 1.0])
X = np.linspace(0.0, 1.0, 401)
X = X[np.min(np.abs(X[:, None] - JOINS[None, :]), axis=1) > 1e-3]
BETAS = [20.0, 45.0, 75.0, 150.0, 250.0]  # deg: beta^2 and beta^3 differ at all of them


def _program(key: str, beta: float, lift: float, s_before: float):
    """A rise of ``s_before`` (3-4-5) over 40 deg, a dwell, then the law's rise of ``lift``
    over ``beta``, a dwell, its return of the whole stroke over ``beta`` (or over 360 -
    80 - beta deg when 2 beta does not fit) and the rest of the turn a dwell: the tested
    segments start away from 0 and from displacement 0. Returns the program, the rise's
    and the return's start and the return's angle (rad)."""
    law, p345 = LAWS[key], LAWS["polynomial-345"]
    b, d = math.radians(beta), math.radians(10)
    br = b if beta <= 140 else math.radians(360 - 80 - beta)
    rest = 2 * PI - math.radians(40) - 2 * d - b - br
    assert rest > 0
    items = [("rise", math.radians(40), s_before, p345), ("dwell", d, None, None),
             ("rise", b, lift, law), ("dwell", d, None, None), ("return", br, None, law),
             ("dwell", rest, None, None)]  # fmt: skip
    t_rise = math.radians(40) + d
    return build_program(items, False), t_rise, t_rise + b + d, br


@pytest.mark.parametrize("key", sorted(LAWS))
@pytest.mark.parametrize("beta", BETAS)
def test_cam_program_derivatives_against_textbook(key, beta):
    """s, ds/dθ, d²s/dθ², d³s/dθ³ of a rise and a return against h f(x), h f'/β, h f''/β²,
    h f'''/β³ written here (with x = (θ - θ0)/β)."""
    h, s0 = 0.025, 0.004
    prog, t_rise, t_ret, br = _program(key, beta, h, s0)
    b = math.radians(beta)
    f, f1, f2, f3 = _textbook(key, X)
    tol = 3e-7 if key.startswith("modified") else 1e-11  # Norton prints 8 digits
    s, v, a, j = prog.eval(t_rise + X * b)
    assert np.allclose(s, s0 + h * f, rtol=0, atol=tol * h)
    assert np.allclose(v, h * f1 / b, rtol=0, atol=tol * h / b * 10)
    assert np.allclose(a, h * f2 / b**2, rtol=0, atol=tol * h / b**2 * 100)
    assert np.allclose(j, h * f3 / b**3, rtol=0, atol=tol * h / b**3 * 1000)
    # the return of the whole stroke s0 + h: s = (s0 + h)(1 - f), every derivative negated
    b = br
    s, v, a, j = prog.eval(t_ret + X * b)
    H = s0 + h
    assert np.allclose(s, H * (1 - f), rtol=0, atol=tol * H)
    assert np.allclose(v, -H * f1 / b, rtol=0, atol=tol * H / b * 10)
    assert np.allclose(a, -H * f2 / b**2, rtol=0, atol=tol * H / b**2 * 100)
    assert np.allclose(j, -H * f3 / b**3, rtol=0, atol=tol * H / b**3 * 1000)


@pytest.mark.parametrize("key", sorted(LAWS))
@pytest.mark.parametrize("beta", [30.0, 100.0, 230.0])
def test_cam_program_rates_are_differences_of_its_displacement(key, beta):
    """The program's own velocity, acceleration and jerk against central differences of
    its displacement alone (no law formula involved): 1st, 2nd and 3rd differences with
    step e, accurate to O(e^2) away from the joins."""
    h = 0.03
    prog, t_rise, t_ret, br = _program(key, beta, h, 0.002)
    x = X[np.min(np.abs(X[:, None] - JOINS[None, :]), axis=1) > 5e-3]
    for t0, b in ((t_rise, math.radians(beta)), (t_ret, br)):
        e = 2e-3 * b
        th = t0 + x * b

        def s(t):
            return prog.eval(t)[0]

        _, v, a, j = prog.eval(th)
        v_fd = (s(th + e) - s(th - e)) / (2 * e)
        a_fd = (s(th + e) - 2 * s(th) + s(th - e)) / e**2
        j_fd = (s(th + 2 * e) - 2 * s(th + e) + 2 * s(th - e) - s(th - 2 * e)) / (2 * e**3)
        # scale of each derivative for the tolerance: the law's peak values
        sv, sa, sj = h / b * 2.5, h / b**2 * 8, h / b**3 * 120
        assert np.allclose(v, v_fd, rtol=0, atol=2e-4 * sv), key
        assert np.allclose(a, a_fd, rtol=0, atol=2e-4 * sa), key
        assert np.allclose(j, j_fd, rtol=0, atol=2e-3 * sj), key


def test_cam_motion_csv_jerk_in_time(tmp_path):
    """The motion table the user reads: velocity, acceleration and jerk in m/s, m/s^2,
    m/s^3 at 120 rpm equal omega, omega^2, omega^3 times the closed forms (a cycloidal rise
    of 25 mm over 120 deg, a 3-4-5 return over 90 deg)."""
    from mechsolve.cli.commands.cam import cam

    r = CliRunner().invoke(
        cam, [str(DATA / "cam_translating.yaml"), "-o", str(tmp_path), "--no-plots"]
    )
    assert r.exit_code == 0, r.output
    with open(tmp_path / "cam_motion.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    w = 120 * 2 * PI / 60
    h = 0.025
    b1, b2 = math.radians(120), math.radians(90)
    seen = {"rise": 0, "return": 0}
    for row in rows:
        th = math.radians(float(row["cam angle [deg]"]))
        if 1e-9 < th < b1 - 1e-9:
            x, b, sign, seg = th / b1, b1, 1.0, "rise"
            f = _textbook("cycloidal", np.array([x]))
        elif math.radians(180) + 1e-9 < th < math.radians(270) - 1e-9:
            x, b, sign, seg = (th - math.radians(180)) / b2, b2, -1.0, "return"
            f = _textbook("polynomial-345", np.array([x]))
        else:
            continue
        seen[seg] += 1
        s_want = h * f[0][0] if sign > 0 else h * (1 - f[0][0])
        assert float(row["displacement [mm]"]) == pytest.approx(s_want * 1e3, abs=1e-8)
        assert float(row["velocity [m/s]"]) == pytest.approx(sign * h * f[1][0] / b * w, abs=1e-9)
        assert float(row["acceleration [m/s^2]"]) == pytest.approx(
            sign * h * f[2][0] / b**2 * w**2, abs=1e-8
        )
        assert float(row["jerk [m/s^3]"]) == pytest.approx(
            sign * h * f[3][0] / b**3 * w**3, abs=1e-6
        )
    assert seen["rise"] >= 5 and seen["return"] >= 5


def test_cam_motion_csv_angular_jerk_of_an_oscillating_follower(tmp_path):
    """The seed's oscillating follower (15 deg over 75 deg of cam angle, back over 75 deg,
    60 rpm) with a cycloidal law: swing, angular velocity, acceleration and jerk in the
    table against omega^n times the closed forms."""
    from mechsolve.cli.commands.cam import cam

    text = (ROOT / "mechanisms" / "shaper-cam.yaml").read_text()
    assert "law: equal acceleration" in text
    f = tmp_path / "cyc.yaml"
    f.write_text(text.replace("law: equal acceleration", "law: cycloidal"))
    r = CliRunner().invoke(
        cam, [str(f), "-o", str(tmp_path / "out"), "--no-plots", "--variant", "as-seed"]
    )
    assert r.exit_code == 0, r.output
    with open(tmp_path / "out" / "cam_motion.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    w, h, b = 2 * PI, math.radians(15), math.radians(75)
    n = 0
    for row in rows:
        th = math.radians(float(row["cam angle [deg]"]))
        if 1e-9 < th < b - 1e-9:
            x, sign = th / b, 1.0
        elif math.radians(85) + 1e-9 < th < math.radians(160) - 1e-9:
            x, sign = (th - math.radians(85)) / b, -1.0
        else:
            continue
        n += 1
        f0, f1, f2, f3 = (float(v[0]) for v in _textbook("cycloidal", np.array([x])))
        swing = h * f0 if sign > 0 else h * (1 - f0)
        assert float(row["swing [deg]"]) == pytest.approx(math.degrees(swing), abs=1e-9)
        got = [float(row[k]) for k in ("angular velocity [rad/s]",
               "angular acceleration [rad/s^2]", "angular jerk [rad/s^3]")]  # fmt: skip
        want = [sign * h * f1 / b * w, sign * h * f2 / b**2 * w**2, sign * h * f3 / b**3 * w**3]
        assert got == pytest.approx(want, abs=1e-8)
    assert n >= 20


# -- (b) guide-bar synthesis from a stroke ----------------------------------------------------


def _theta_of_k(k: float) -> float:
    """The crank's angle between its two limit positions from the time ratio (rad):
    theta = 180 deg (K - 1)/(K + 1)."""
    return PI * (k - 1) / (k + 1)


@pytest.mark.parametrize("k", [1.2, 1.46, 1.8, 2.5])
@pytest.mark.parametrize("stroke", [0.1, 0.3126])
def test_guide_bar_from_a_stroke(k, stroke):
    """A guide bar with time ratio K on a frame d, given the stroke H of the bar's end:
    the bar swings psi = theta (the crank is perpendicular to the bar at both limits), the
    crank is r = d sin(theta/2) and the bar L = H / (2 sin(theta/2))."""
    from mechsolve.analyses.synth.guidebar import guide_bar

    th = _theta_of_k(k)
    L = stroke / (2 * math.sin(th / 2))
    d = 0.9 * L / (1 + math.sin(th / 2))  # the slot reaches the block: L > d + r
    (des,) = guide_bar(frame=d, k=k, stroke=stroke)
    assert des.lengths["crank"] == pytest.approx(d * math.sin(th / 2), rel=1e-12)
    assert des.lengths["bar"] == pytest.approx(L, rel=1e-12)
    assert des.extra["stroke"] == pytest.approx(stroke, rel=1e-12)
    assert des.extra["swing"] == pytest.approx(th, rel=1e-12)
    assert des.time_ratio == pytest.approx(k, rel=1e-12)


def test_guide_bar_stroke_through_synth_and_the_solver(tmp_path):
    """`mechsolve synth` on a guide bar given K = 1.5 and a 300 mm stroke: the written
    mechanism, solved, swings its bar by theta = 36 deg, and the bar's end B sweeps a
    chord 2 |O4B| sin(swing/2) equal to the stroke; the crank is d sin(18 deg)."""
    from mechsolve.cli.commands.synth import synth

    prob = tmp_path / "gb.yaml"
    prob.write_text(
        "name: guide bar from a stroke\nunits: {length: mm, angle: deg}\n"
        "guide-bar: {frame: 300, time_ratio: 1.5, stroke: 300}\n"
    )
    out = tmp_path / "design.yaml"
    # every digit written (--digits 17): the swing to 1e-9 rad
    r = CliRunner().invoke(synth, [str(prob), "-o", str(out), "--digits", "17"])
    assert r.exit_code == 0, r.output
    res = ms.run(out)
    assert res.ok.all()
    (lp,) = [lp for lp in res.limit_positions() if lp.name == "guide_bar"]
    th = _theta_of_k(1.5)
    assert lp.swing == pytest.approx(th, abs=1e-9)
    assert lp.time_ratio == pytest.approx(1.5, abs=1e-7)
    b = res.point("B")
    o4 = res.point("O4")
    L = math.hypot(b.x[0] - o4.x[0], b.y[0] - o4.y[0])
    assert 2 * L * math.sin(lp.swing / 2) == pytest.approx(0.300, abs=1e-9)
    a, o2 = res.point("A"), res.point("O2")
    assert math.hypot(a.x[0] - o2.x[0], a.y[0] - o2.y[0]) == pytest.approx(
        0.3 * math.sin(th / 2), abs=1e-12
    )


# -- (c) the units table against the definitions of its units ---------------------------------

_IN, _FT, _LBF = 0.0254, 0.3048, 4.4482216152605  # m, m, N: exact (1959; NIST SP 811)
_L, _M, _T, _A = (1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1)
_F, _E, _P, _PR = (1, 1, -2, 0), (2, 1, -2, 0), (2, 1, -3, 0), (-1, 1, -2, 0)
# symbol -> (SI value of one unit, dimension over (length, mass, time, angle)), written
# from the definitions; a superset of the table (units it may gain are defined here too)
DEFINITIONS = {
    "m": (1.0, _L), "mm": (0.001, _L), "cm": (0.01, _L), "dm": (0.1, _L), "km": (1000.0, _L),
    "um": (1e-6, _L), "in": (_IN, _L), "inch": (_IN, _L), "ft": (_FT, _L),
    "yd": (3 * _FT, _L), "mi": (5280 * _FT, _L),
    "kg": (1.0, _M), "g": (0.001, _M), "t": (1000.0, _M), "lbm": (0.45359237, _M),
    "slug": (_LBF / _FT, _M), "blob": (_LBF / _IN, _M),
    "s": (1.0, _T), "ms": (0.001, _T), "sec": (1.0, _T), "min": (60.0, _T),
    "h": (3600.0, _T),
    "rad": (1.0, _A), "deg": (PI / 180, _A), "°": (PI / 180, _A), "rev": (2 * PI, _A),
    "r": (2 * PI, _A), "turn": (2 * PI, _A), "rpm": (2 * PI / 60, (0, 0, -1, 1)),
    "N": (1.0, _F), "kN": (1e3, _F), "MN": (1e6, _F), "kgf": (9.80665, _F),
    "lbf": (_LBF, _F), "kip": (1000 * _LBF, _F),
    "Nm": (1.0, _E), "kNm": (1e3, _E), "J": (1.0, _E), "kJ": (1e3, _E),
    "W": (1.0, _P), "kW": (1e3, _P), "hp": (745.69987158227022, _P),
    "Pa": (1.0, _PR), "kPa": (1e3, _PR), "MPa": (1e6, _PR), "bar": (1e5, _PR),
    "psi": (_LBF / _IN**2, _PR), "ksi": (1000 * _LBF / _IN**2, _PR),
}  # fmt: skip


def test_every_unit_of_the_table_is_its_definition():
    """Every symbol of the units table converts by its definition (to rounding), with its
    dimension; a symbol the table gains must be defined here as well."""
    from mechsolve.base.units import _UNITS, parse_unit

    missing = sorted(set(_UNITS) - set(DEFINITIONS))
    assert not missing, f"define these units in DEFINITIONS: {missing}"
    for sym, (factor, dim) in _UNITS.items():
        want, want_dim = DEFINITIONS[sym]
        assert factor == pytest.approx(want, rel=1e-14), sym
        assert tuple(dim) == want_dim, sym
        unit = parse_unit(sym)  # the path a file's "<number> <unit>" takes
        assert unit.factor == pytest.approx(want, rel=1e-14), sym
        assert tuple(unit.dim) == want_dim, sym


def test_units_against_printed_conversion_values():
    """A few conversions as the tables print them (NIST SP 811, appendix B), and compound
    units through the parser."""
    from mechsolve.base.units import parse_quantity, parse_unit

    assert parse_unit("psi").factor == pytest.approx(6894.757293168, rel=1e-12)
    assert parse_unit("slug").factor == pytest.approx(14.59390293720636, rel=1e-13)
    assert parse_unit("lbf in").factor == pytest.approx(0.1129848290276167, rel=1e-13)
    assert parse_unit("lbf ft").factor == pytest.approx(1.3558179483314004, rel=1e-13)
    assert parse_unit("r/min").factor == pytest.approx(0.10471975511965977, rel=1e-14)
    assert parse_quantity("2 lb", "force") == pytest.approx(2 * _LBF, rel=1e-14)
    assert parse_quantity("2 lb", "mass") == pytest.approx(0.90718474, rel=1e-14)
    assert parse_quantity("0.3 lb in s^2", "moment of inertia") == pytest.approx(
        0.3 * _LBF * _IN, rel=1e-14
    )
    assert parse_quantity("25 deg", "angle") == pytest.approx(25 * PI / 180, rel=1e-15)


# -- (d) a rocker whose extreme lies just after a dead zone the sweep steps over -------------

FB = (30.0, 100.0, 80.0, 90.0)  # crank, coupler, rocker, frame (mm): a crank-rocker


def _fourbar_extremes():
    """The rocker's limit positions in closed form: crank and coupler in line (extended,
    O2B = b + a; folded, O2B = b - a), B above the frame. Returns the crank angles and the
    rocker angles there (rad)."""
    a, b, c, d = FB
    out = []
    for r, turn in ((b + a, 0.0), (b - a, PI)):
        ang = math.acos((r * r + d * d - c * c) / (2 * r * d))  # angle B O2 O4
        bx, by = r * math.cos(ang), r * math.sin(ang)
        out.append((ang + turn, math.atan2(by, bx - d)))
    return out


def _dead_zone_linkage(centre: float, half: float, step: float) -> str:
    """The four-bar FB, and a dyad arm E-F, lever F-O6 hung on the crank at E (30 mm behind
    O2): |E O6| = sqrt(a^2 + D^2 + 2 a D cos(phi - centre)) with O6 at D = 100 mm in the
    direction ``centre``, so the dyad (arm + lever = |E O6| at phi = centre +- half) cannot
    close for |phi - centre| < half deg."""
    a, b, c, d = FB
    D, p = 100.0, 70.0
    q = math.sqrt(a * a + D * D + 2 * a * D * math.cos(math.radians(half))) - p
    ox, oy = D * math.cos(math.radians(centre)), D * math.sin(math.radians(centre))
    return f"""
units: {{length: mm, angle: deg}}
ground: {{O2: [0, 0], O4: [{d}, 0], O6: [{ox!r}, {oy!r}]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0], E: [-{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
  arm: {{points: {{E: [0, 0], F: [{p}, 0]}}}}
  lever: {{points: {{O6: [0, 0], F: [{q!r}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker],
         E: [crank, arm], F: [arm, lever], O6: [ground, lever]}}
assembly: [B left of A -> O4]
driver: {{joint: O2, speed: 1 rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: {step} deg}}
"""


# (dead zone's centre, half width, step), deg: the dead zone between two samples and the
# rocker's extreme (crank at 37.35 deg, extended; 238.41 deg, folded) between the next two
DEAD_ZONES = [(25.0, 4.0, 10.0), (33.0, 2.5, 6.0), (225.0, 4.0, 10.0), (234.0, 1.5, 4.0)]


@pytest.mark.parametrize("centre,half,step", DEAD_ZONES)
def test_rocker_extreme_just_after_a_stepped_over_dead_zone(centre, half, step):
    (ce, re), (cf, rf) = _fourbar_extremes()
    # the layout the test needs: the extreme in the interval after the dead zone's
    k = int(centre // step)
    assert k * step < centre - half and centre + half < (k + 1) * step
    ext = math.degrees(ce if centre < 180 else cf)
    assert (k + 1) * step < ext < (k + 2) * step
    res = ms.solve(ms.loads(_dead_zone_linkage(centre, half, step)))
    dz = [e for e in res.solution.events if e.kind == "dead zone"]
    assert len(dz) == 1 and dz[0].after == k  # between samples k and k + 1
    assert math.degrees(dz[0].u) == pytest.approx(centre, abs=1e-6)
    (lp,) = [lp for lp in res.limit_positions() if lp.name == "rocker"]
    assert lp.low == pytest.approx(re, abs=1e-9)
    assert lp.high == pytest.approx(rf, abs=1e-9)
    assert lp.swing == pytest.approx(rf - re, abs=1e-9)
    # the crank cannot turn through the dead zone (the arm and lever cannot close there):
    # no cycle, so no time ratio, as where a sample falls in an unassemblable range
    assert lp.time_ratio is None


# -- (e) a slider driven from a four-bar's coupler point, every solver method ----------------

W = 3.0  # crank speed (rad/s)


def _coupler_slider(method: str) -> str:
    """The docs' four-bar (crank 26.5, coupler 105.6, rocker 59, frame 87.5 mm, P 60 mm
    from A at 30 deg from A -> B) and a rod P-C of 150 mm to a block C on the ground line
    y = 10 mm: under ``split-newton`` the rod and block are a Newton group whose known
    body (the coupler) moves."""
    return f"""
units: {{length: mm, angle: deg}}
ground: {{O2: [0, 0], O4: [87.5, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [26.5, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [105.6, 0], P: {{length: 60, angle: 30}}}}}}
  rocker: {{points: {{O4: [0, 0], B: [59, 0]}}}}
  rod: {{points: {{P: [0, 0], C: [150, 0]}}}}
  block: {{points: {{C: [0, 0]}}}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
  P: [coupler, rod]
  C: [rod, block]
  guide: {{slider: [ground, block], point: C, line: {{through: [0, 10], angle: 0}}}}
assembly: [B left of A -> O4, C.x > P.x]
driver: {{joint: O2, speed: {W} rad/s, start: 10 deg}}
sweep: {{range: 360 deg, step: 7.5 deg}}
solver: {{method: {method}}}
"""


def _block_x(phi: np.ndarray) -> np.ndarray:
    """C.x (m) at crank angles phi in closed form: B from the two circles about A and O4
    (on the left of A -> O4), P on the coupler, C on the line y = 10 mm right of P."""
    a, b, c, d = 0.0265, 0.1056, 0.059, 0.0875
    ax, ay = a * np.cos(phi), a * np.sin(phi)
    ex, ey = d - ax, -ay  # A -> O4
    r = np.hypot(ex, ey)
    along = (b * b - c * c + r * r) / (2 * r)
    off = np.sqrt(b * b - along * along)
    bx = ax + (along * ex - off * ey) / r  # the left of A -> O4: +90 deg from it
    by = ay + (along * ey + off * ex) / r
    ux, uy = (bx - ax) / b, (by - ay) / b
    k, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    px, py = ax + 0.06 * (k * ux - s * uy), ay + 0.06 * (s * ux + k * uy)
    return px + np.sqrt(0.15**2 - (0.01 - py) ** 2)


@pytest.mark.parametrize("method", ["split-newton", "newton", "auto"])
def test_slider_on_a_coupler_point_rates(method):
    """The block's position, velocity and acceleration against the closed-form position
    and its central differences in the crank angle (times omega, omega^2: constant
    speed), at every sample and every solver method."""
    res = ms.solve(ms.loads(_coupler_slider(method)))
    assert res.ok.all()
    phi = np.asarray(res.u, dtype=float)
    h = 1e-4
    x0, xp, xm = _block_x(phi), _block_x(phi + h), _block_x(phi - h)
    v = (xp - xm) / (2 * h) * W
    acc = (xp - 2 * x0 + xm) / h**2 * W**2
    c = res.point("C")
    assert np.allclose(c.x, x0, rtol=0, atol=1e-12)
    assert np.allclose(c.y, 0.01, rtol=0, atol=1e-12)
    assert np.allclose(c.vx, v, rtol=0, atol=1e-8)
    assert np.allclose(c.vy, 0.0, rtol=0, atol=1e-12)
    assert np.allclose(c.ax, acc, rtol=0, atol=1e-6)
    assert np.allclose(c.ay, 0.0, rtol=0, atol=1e-10)
    # the rates change sign over the turn: a swapped sign or factor cannot pass
    assert np.ptp(v) > 0.1 and np.ptp(acc) > 0.5


# -- survivors of the mutation run (README, "Development"): real ones, each killed here ------


def test_oscillating_flat_face_curvature_is_the_profiles():
    """cam/profile.py:219 (h'' of an oscillating flat face, ``ds**2`` as ``ds - 2``): the
    profile's radius of curvature against the curvature of the drawn profile itself,
    |r'|^3 / |r' x r''| by central differences in the cam angle, both senses."""
    from mechsolve.base.cam.profile import Follower, solve

    law, deg = LAWS["cycloidal"], math.radians
    prog = build_program(
        [("rise", deg(120), deg(10), law), ("dwell", deg(30), None, None),
         ("return", deg(120), None, law), ("dwell", deg(90), None, None)],
        True,
    )  # fmt: skip
    a, r0 = 0.15, 0.06
    f = Follower("oscillating", "flat-faced", r0, pivot=a, start_angle=math.asin(r0 / a))
    th = np.linspace(0, 2 * PI, 7200, endpoint=False)
    e = th[1] - th[0]
    joins = np.radians([0, 120, 150, 270, 360])
    away = np.min(np.abs(th[:, None] - joins[None, :]), axis=1) > 0.01
    for sense in (1, -1):
        p = solve(prog, f, sense, th)
        assert p.valid and np.all(p.rho_profile > 0)
        r = p.profile
        r1 = (np.roll(r, -1, axis=0) - np.roll(r, 1, axis=0)) / (2 * e)
        r2 = (np.roll(r, -1, axis=0) - 2 * r + np.roll(r, 1, axis=0)) / e**2
        cross = r1[:, 0] * r2[:, 1] - r1[:, 1] * r2[:, 0]
        rho = np.hypot(r1[:, 0], r1[:, 1]) ** 3 / np.abs(cross)
        assert np.allclose(p.rho_profile[away], rho[away], rtol=2e-6, atol=0)


@pytest.mark.parametrize("key", ["cycloidal", "polynomial-345", "polynomial-4567"])
@pytest.mark.parametrize("e", [0.0, 0.01, -0.008])
def test_smallest_base_radius_of_a_translating_follower(key, e):
    """cam/design.py:122 (the refinement's bracket about the best coarse sample, 2 pi / n
    as 2 - pi / n): the smallest base radius for the pressure-angle allowances equals
    hypot(s0, e), s0 = max over the rise and the return of |s' - e| / tan(alpha) - s
    (tan(alpha) = (s' - e) / (sqrt(r0^2 - e^2) + s)), the maximum found here from the
    textbook law on a fine grid refined by Brent's method."""
    from scipy.optimize import minimize_scalar

    from mechsolve.analyses.cam.design import Allowance, min_base_translating

    deg = math.radians
    h, b_up, b_down = 0.03, deg(100), deg(140)
    law = LAWS[key]
    prog = build_program(
        [("rise", b_up, h, law), ("dwell", deg(40), None, None),
         ("return", b_down, None, law), ("dwell", deg(80), None, None)],
        False,
    )  # fmt: skip
    a_up, a_down = deg(30), deg(50)

    def need(x, b, alpha, up):
        f, f1 = (float(v[0]) for v in _textbook(key, np.array([x]))[:2])
        s, ds = (h * f, h * f1 / b) if up else (h * (1 - f), -h * f1 / b)
        return abs(ds - e) / math.tan(alpha) - s

    s0 = 0.0
    for b, alpha, up in ((b_up, a_up, True), (b_down, a_down, False)):
        x = np.linspace(0, 1, 20001)
        f, f1 = _textbook(key, x)[:2]
        s, ds = (h * f, h * f1 / b) if up else (h * (1 - f), -h * f1 / b)
        i = int(np.argmax(np.abs(ds - e) / math.tan(alpha) - s))
        lo, hi = x[max(i - 1, 0)], x[min(i + 1, len(x) - 1)]
        best = minimize_scalar(
            lambda t, b=b, alpha=alpha, up=up: -need(t, b, alpha, up), bounds=(lo, hi),
            method="bounded", options={"xatol": 1e-13},
        )  # fmt: skip
        s0 = max(s0, -best.fun, need(lo, b, alpha, up), need(hi, b, alpha, up))
    r0 = min_base_translating(prog, e, 1, Allowance(rise=a_up, ret=a_down))
    assert r0 == pytest.approx(math.hypot(s0, e), rel=1e-10)


def test_a_return_below_the_lowest_position_names_its_lift(tmp_path):
    """cam/model.py:248 (``level * (1 + 1e-9)`` as ``level + (1 + 1e-9)``): a return of
    30 mm after a rise of 25 mm is refused at its own key, saying so."""
    from mechsolve.cli.commands.cam import cam

    text = (DATA / "cam_translating.yaml").read_text()
    old = "{return: 90 deg, law: 3-4-5}"
    assert old in text
    f = tmp_path / "low.yaml"
    f.write_text(text.replace(old, "{return: 90 deg, lift: 30 mm, law: 3-4-5}"))
    r = CliRunner().invoke(cam, [str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 2, r.output
    assert "cam.motion[2].lift: the return goes below the lowest position" in r.output


def test_slider_crank_with_k_one():
    """synth/slidercrank.py:32 (``1e-12 * h_len`` as ``1e-12 - h_len``): K = 1 with no
    offset says any crank H/2 works; with an offset, that K = 1 needs none."""
    from mechsolve.analyses.synth.slidercrank import slider_crank_at
    from mechsolve.base.errors import InputError

    with pytest.raises(InputError, match="any crank a = H/2 works"):
        slider_crank_at(0.1, 0.0, 0.0)
    with pytest.raises(InputError, match="needs a centred slider-crank"):
        slider_crank_at(0.1, 0.0, 0.01)


def _tr_min(stroke: float, theta: float, e: float) -> float:
    """The smallest transmission angle of the offset slider-crank whose pivot sees the
    limit positions (x1, e), (x1 + H, e) under theta: crank a and rod b from
    b - a = |P C1|, b + a = |P C2|; the angle is least with the crank normal to the guide
    on the side away from it: cos(mu_min) = (a + e) / b."""
    x1 = (-stroke + math.sqrt(stroke**2 + 4 * (stroke * e / math.tan(theta) - e * e))) / 2
    near, far = math.hypot(x1, e), math.hypot(x1 + stroke, e)
    a, b = (far - near) / 2, (far + near) / 2
    return math.acos(min(1.0, (a + e) / b))


@pytest.mark.parametrize("k", [1.2, 1.4, 1.8])
def test_slider_crank_offset_with_the_largest_transmission_angle(k):
    """The offset synthesis chooses: its minimum transmission angle is the largest over all
    offsets, found here from the closed form on a fine grid refined by Brent's method.
    (The sampled mutant synth/slidercrank.py:113, the refinement's upper bound
    ``best + step`` as ``best // step``, is equivalent: the bracket only widens.)"""
    from scipy.optimize import minimize_scalar

    from mechsolve.analyses.synth.slidercrank import slider_crank

    H = 0.1
    th = _theta_of_k(k)
    (d,) = slider_crank(H, k)
    e_max = H / math.tan(th)
    grid = np.linspace(e_max * 1e-4, e_max * (1 - 1e-6), 20001)
    vals = []
    for e in grid:
        try:
            vals.append(_tr_min(H, th, e))
        except ValueError:
            vals.append(-1.0)
    i = int(np.argmax(vals))
    best = minimize_scalar(
        lambda e: -_tr_min(H, th, e),
        bounds=(grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]),
        method="bounded",
        options={"xatol": 1e-14},
    )
    assert d.min_transmission == pytest.approx(-best.fun, abs=1e-9)


def test_flywheel_from_a_torque_curve_prints_rpm_and_refuses_bad_delta():
    """flywheel.py:56 (rpm as ``omega * 30 % pi``) and :229 (``0 < delta < 1`` as
    ``0 is not delta < 1``): the mean speed is printed in rpm = omega 30 / pi; a delta
    of 0 or below is refused."""
    from mechsolve.analyses.flywheel import size_from_torque
    from mechsolve.base.errors import InputError

    x = np.linspace(0, 2 * PI, 37)
    T = 200 + 150 * np.sin(2 * x)
    fw = size_from_torque(x, T, speed=1500 * PI / 30, delta=1 / 80)
    assert "(1500 rpm)" in fw.text()
    fw = size_from_torque(x, T, speed=12.0, delta=0.05)
    assert f"({12.0 * 30 / PI:.6g} rpm)" in fw.text()
    for bad in (-0.05, 0.0, 1.0, 1.5):
        with pytest.raises(InputError, match="coefficient of fluctuation"):
            size_from_torque(x, T, speed=12.0, delta=bad)


FOURBAR_REQ = (ROOT / "mechanisms" / "fourbar.yaml").read_text()


def test_requirement_figures_swing_in_degrees_and_at_the_last_position():
    """requirements.py:182 (a rocker's swing given the unit m) and :243 (``at(q, w)``
    with w the sweep's last position refused): the swing of the docs' four-bar is
    printed in deg, and the rocker's angle at 360 deg of crank is the closed form's at 0."""
    from mechsolve.results.requirements import check_requirements, evaluate_figure

    a, b, c, d = 26.5e-3, 105.6e-3, 59e-3, 87.5e-3
    folded, extended = b - a, b + a
    swing = abs(
        math.acos((d * d + c * c - folded**2) / (2 * d * c))
        - math.acos((d * d + c * c - extended**2) / (2 * d * c))
    )
    text = FOURBAR_REQ + (
        f"\nrequirements:\n  swing: rocker.swing >= {math.degrees(swing) - 0.01} deg\n"
        "  bare: rocker.swing >= 0.5\n"  # SI (rad), shown in the figure's unit
    )
    mech = ms.loads(text)
    res = ms.solve(mech)
    for v in check_requirements(mech, res):
        assert v.passed and v.unit == "deg", v.message
        assert f"rocker.swing = {math.degrees(swing):.6g} deg >= " in v.message
    # crank at 0 (and 360) deg: A = (a, 0); B above the frame, left of A -> O4
    gamma = math.acos((c * c + (d - a) ** 2 - b * b) / (2 * c * (d - a)))
    want = PI - gamma
    for at in ("0 deg", "360 deg"):
        got = evaluate_figure(f"at(rocker.angle, {at})", mech, res)
        assert (got - want + PI) % (2 * PI) - PI == pytest.approx(0, abs=1e-9), at


POLYGON_EXAMPLES = [("shaper", "graphical"), ("shaper", None), ("fourbar", None),
                    ("sixbar", None), ("slider-crank", None), ("motor-linkage", None),
                    ("rod-to-rocker", None)]  # fmt: skip
# a rod from the crank to a block sliding along the four-bar's rocker: a guide on a moving
# link, drawn with Coriolis and sliding components
ROD_TO_ROCKER = """
name: rod to a block on the rocker
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0], E: [-20, 0]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [59, 0], T: [120, 0]}}
  rod: {points: {E: [0, 0], M: [110, 0]}}
  block: {points: {M: [0, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
  E: [crank, rod]
  M: [rod, block]
  along: {slider: [rocker, block], point: M, line: [O4, T]}
assembly: [B left of A -> O4, M.y > 0]
driver: {joint: O2, speed: 5 rad/s, start: 0 deg}
"""


@pytest.mark.parametrize("file,variant", POLYGON_EXAMPLES)
def test_every_polygon_arrow_joins_its_nodes(file, variant):
    """polygons.py:569 (the sliding acceleration's vector ``arel * d`` as ``arel + d``):
    every arrow drawn, in both polygons, is the vector from its tail node to its head
    node (the polygons' own geometry: what is drawn closes)."""
    from mechsolve.analyses.polygons import build_polygons

    if file == "rod-to-rocker":
        mech = ms.loads(ROD_TO_ROCKER)
    else:
        mech = ms.load(ROOT / "mechanisms" / f"{file}.yaml", variant)
    for at in (2, 5, 9):
        r = build_polygons(mech, at)
        for poly in (r.velocity, r.acceleration):
            size = poly.extent()
            for arrow in poly.arrows:
                gap = poly.nodes[arrow.head] - poly.nodes[arrow.tail] - arrow.vec
                assert np.abs(gap).max() <= 1e-12 * size, (file, at, arrow.name)
                if arrow.along is not None:  # a vector along a guide: its signed length
                    assert abs(arrow.along) == pytest.approx(
                        float(np.hypot(*arrow.vec)), rel=1e-12, abs=1e-15 * size
                    )


@pytest.mark.parametrize("file,omega", [("fourbar", 1.0), ("slider-crank", 1500 * PI / 30)])
def test_polygon_position_names_its_time(file, omega):
    """polygons.py:869 (``du / speed`` as ``du % speed``): position k of 12 per turn is
    (k - 1) 30 deg after the start, reached (k - 1) (pi / 6) / omega after it."""
    from mechsolve.analyses.polygons import build_polygons

    mech = ms.load(ROOT / "mechanisms" / f"{file}.yaml")
    for k in (2, 5, 9, 12):
        r = build_polygons(mech, k)
        m = re.search(r"t = (\S+) s from position 1", r.label)
        assert m, r.label
        assert float(m.group(1)) == pytest.approx((k - 1) * PI / 6 / omega, rel=1e-5)


def test_study_parameter_suggests_the_whole_key_path():
    """study/params.py:133 (the key-path walk's depth counted twice): a parameter written
    without its top key is answered with the full path of the number it names, five keys
    deep (the closest of every number's key path in the file)."""
    import yaml

    from mechsolve.analyses.study.params import lookup
    from mechsolve.base.errors import InputError

    data = yaml.safe_load((ROOT / "mechanisms" / "fourbar.yaml").read_text())
    for path, want in (
        (("coupler", "points", "P", "length"), "links.coupler.points.P.length"),
        (("rocker", "points", "B", 0), "links.rocker.points.B[0]"),
    ):
        with pytest.raises(InputError, match=re.escape(f"did you mean {want}?")):
            lookup(data, path)
