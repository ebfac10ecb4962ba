"""Issue 30, ``mechsolve synth``'s written files (review 6, item 2).

The file a synthesis writes must reproduce the design to rounding (every digit written,
the shortest decimal that reads back the same float, in the problem's unit), and every
error its header states must be that of the file as written (with ``--digits N`` too).

The references are computed here, not by mechsolve: the four-bar's output angle by
intersecting two circles (the reviewer's check) on the lengths read from the written
file with a plain YAML reader, Freudenstein's equation at the precision points, the
offset slider-crank's and the guide bar's closed forms.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from mechsolve import api
from mechsolve.cli.commands.synth import synth

ROOT = Path(__file__).parent.parent
SYNTH = ROOT / "mechanisms" / "synth"


def _synth(*args) -> str:
    r = CliRunner().invoke(synth, [str(a) for a in args])
    assert r.exit_code == 0, r.output
    return r.output


def _qty(v) -> float:
    """A number of a written file: a plain number or a quantity string ('12.5 mm')."""
    return float(str(v).split()[0])


# -- function generation: log10 over 1..2 (mechanisms/synth/function-log10.yaml) ----------

X0, X1, PHI0, DPHI, PSI0, DPSI = 1.0, 2.0, 45.0, 60.0, 135.0, 90.0  # the problem's


def _function_file(path: Path) -> tuple[float, float, float, float, str]:
    """(a, b, c, d) signed as written (m) and the assembly side, by a plain YAML read."""
    data = yaml.safe_load(path.read_text())
    links = data["links"]
    a = _qty(links["crank"]["points"]["A"][0])
    b = _qty(links["coupler"]["points"]["B"][0])
    c = _qty(links["rocker"]["points"]["B"][0])
    d = _qty(data["ground"]["O4"][0])
    assert data["driver"]["start"] in ("45 deg", "45.0 deg")
    return a, b, c, d, data["assembly"][0]


def _psi_circles(a, b, c, d, phi_deg):
    """The rocker's angle (deg, from the frame line; its x axis reversed for c < 0) for
    both assemblies, by intersecting the circle about A (radius b) with the circle about
    O4 (radius |c|)."""
    th = np.radians(phi_deg)
    ax, ay = a * np.cos(th), a * np.sin(th)
    ex, ey = ax - d, ay
    L = np.hypot(ex, ey)
    e = (L * L + c * c - b * b) / (2 * L)
    h = np.sqrt(c * c - e * e)
    ux, uy = ex / L, ey / L
    out = []
    for s in (1.0, -1.0):
        bx, by = e * ux - s * h * uy, e * uy + s * h * ux  # B - O4
        psi = np.degrees(np.arctan2(by, bx)) - (180.0 if c < 0 else 0.0)
        out.append(psi)
    return out


def _psi_want(x):
    return PSI0 + DPSI * np.log10(x) / math.log10(2.0)


def _errors(a, b, c, d, x):
    """The error (deg) of the written linkage at x on the assembly nearest the target."""
    phi = PHI0 + DPHI * (np.asarray(x) - X0) / (X1 - X0)
    errs = [(p - _psi_want(x) + 180.0) % 360.0 - 180.0 for p in _psi_circles(a, b, c, d, phi)]
    return min(errs, key=lambda e: float(np.max(np.abs(e))))


def _header_deg(text: str, what: str) -> float:
    return float(re.search(rf"# {what}: (-?[\d.]+) deg", text)[1])


def test_function_precision_points_reached_by_the_file_as_written(tmp_path):
    """The precision-point design (Freudenstein, 3 Chebyshev points): the file as written
    meets the precision points to rounding, by the reference circle intersection and by
    Freudenstein's equation; the header says so, and mechsolve's run reads the file back
    as these circles say. With 6 digits the errors were 1.3e-4 to 2.5e-4 deg."""
    out = tmp_path / "log10p.yaml"
    printed = _synth(SYNTH / "function-log10.yaml", "--solution", 1, "-o", out)
    a, b, c, d, _ = _function_file(out)
    xs = 1.5 - 0.5 * np.cos(np.array([1, 3, 5]) * math.pi / 6)  # Chebyshev in [1, 2]
    assert np.max(np.abs(_errors(a, b, c, d, xs))) < 1e-10  # deg
    # Freudenstein's equation K1 cos psi - K2 cos phi + K3 = cos(phi - psi), with the
    # rocker's direction O4 -> B (c signed: B at -|c| is the direction psi + 180 deg)
    phi = np.radians(PHI0 + DPHI * (xs - X0))
    psi = np.radians(_psi_want(xs))
    k1, k2, k3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    assert np.max(np.abs(k1 * np.cos(psi) - k2 * np.cos(phi) + k3 - np.cos(phi - psi))) < 1e-13
    text = out.read_text()
    for e in re.search(r"# Error at the precision points: (.*)\.\n", text)[1].split(", "):
        assert abs(float(e.split(": ")[1].split()[0])) < 1e-10
    assert "error at the precision points x = 1.06699: " in printed
    # the header's largest error is the written linkage's over the model's 101 positions
    ref = float(np.max(np.abs(_errors(a, b, c, d, np.linspace(X0, X1, 101)))))
    assert _header_deg(text, "Largest structural error over the range") == pytest.approx(
        ref, abs=6e-7
    )
    # mechsolve's run of the file: the rocker's angle at every sample is the circles'
    res = api.run(out)
    B = res.point("B")
    psi_run = np.degrees(np.arctan2(B.y, B.x - d)) - (180.0 if c < 0 else 0.0)
    phi_run = PHI0 + np.arange(len(psi_run)) * 1.0
    ref = min(_psi_circles(a, b, c, d, phi_run), key=lambda p: abs(p[0] - psi_run[0]))
    assert len(psi_run) == 61
    assert np.max(np.abs((psi_run - ref + 180) % 360 - 180)) < 1e-9


@pytest.mark.parametrize("digits", [None, 6])
def test_function_header_states_the_error_of_the_file_as_written(tmp_path, digits):
    """The optimised design: the header's largest structural error is the written
    file's (circle intersection on the lengths read back), every digit written or 6
    significant digits. The 6-digit file's header used to claim the design's 0.090476
    deg while the file gives 0.090624 deg."""
    out = tmp_path / "log10.yaml"
    more = () if digits is None else ("--digits", digits)
    _synth(SYNTH / "function-log10.yaml", "-o", out, *more)
    text = out.read_text()
    a, b, c, d, _ = _function_file(out)
    ref = float(np.max(np.abs(_errors(a, b, c, d, np.linspace(X0, X1, 101)))))
    shown = _header_deg(text, "Largest structural error over the range")
    assert shown == pytest.approx(ref, abs=6e-7)
    assert ("6 significant digits" in text) == (digits == 6)
    if digits is None:
        # every digit: lengths of 15 to 17 significant digits (the design's floats)
        n = re.search(r"A: \[([-\d.e]+), 0\]", text)[1]
        assert len(n.replace(".", "").replace("-", "").lstrip("0")) >= 14


# -- path generation: the coupler curve of mechanisms/fourbar.yaml ------------------------


def _coupler_point(u_deg, a, b, c, o4, p_len, p_ang_deg):
    """P of the four-bar O2 (0, 0) - A - B - O4, B left of A -> O4, P at (length, angle)
    from A in the coupler's frame (x along A -> B)."""
    u = math.radians(u_deg)
    ax, ay = a * math.cos(u), a * math.sin(u)
    ex, ey = o4[0] - ax, o4[1] - ay
    L = math.hypot(ex, ey)
    along = (b * b - c * c + L * L) / (2 * L)
    h = math.sqrt(b * b - along * along)
    bx, by = ax + along * ex / L - h * ey / L, ay + along * ey / L + h * ex / L
    th = math.atan2(by - ay, bx - ax) + math.radians(p_ang_deg)
    return ax + p_len * math.cos(th), ay + p_len * math.sin(th)


ORIGINAL = (26.5, 105.6, 59.0, (87.5, 0.0), 60.0, 30.0)  # mm, deg: the targets' linkage
ANGLES = [0, 40, 80, 120, 160, 200]


def _path_problem(tmp_path) -> tuple[Path, np.ndarray]:
    targets = np.array([_coupler_point(u, *ORIGINAL) for u in ANGLES])
    pts = ", ".join(f"[{float(x)!r}, {float(y)!r}]" for x, y in targets)
    text = (
        "name: recover the four-bar\n"
        "units: {length: mm, angle: deg}\n"
        "path:\n"
        f"  mechanism: {ROOT / 'mechanisms' / 'fourbar.yaml'}\n"
        "  point: P\n"
        f"  targets: [{pts}]\n"
        "  vary:\n"
        "    ground.O4[0]: [60, 120]\n"
        "    ground.O4[1]: [-20, 20]\n"
        "    links.crank.points.A[0]: [15, 40]\n"
        "    links.coupler.points.B[0]: [80, 130]\n"
        "    links.coupler.points.P.length: [40, 80]\n"
        "    links.coupler.points.P.angle: [0, 60]\n"
        "    links.rocker.points.B[0]: [40, 80]\n"
        "  optimise: {max_iter: 300}\n"
    )
    p = tmp_path / "p.yaml"
    p.write_text(text)
    return p, targets


def _path_distances(path: Path, targets: np.ndarray) -> tuple[np.ndarray, str]:
    """The distances (mm) of the written linkage's P, at the header's crank angles, from
    the targets: the numbers read with a plain YAML reader, P by intersecting circles."""
    text = path.read_text()
    data = yaml.safe_load(text)
    assert data["units"]["length"] == "mm" and data["ground"]["O2"] == [0, 0]
    o4 = tuple(_qty(v) for v in data["ground"]["O4"])
    lk = data["links"]
    a = _qty(lk["crank"]["points"]["A"][0])
    b = _qty(lk["coupler"]["points"]["B"][0])
    p = lk["coupler"]["points"]["P"]
    c = _qty(lk["rocker"]["points"]["B"][0])
    assert data["assembly"] == ["B left of A -> O4"]
    angles = re.search(r"# Crank angles at the targets \(deg\): (.*)", text)[1]
    u = [float(v) for v in angles.split(", ")]
    assert _qty(data["driver"]["start"]) == u[0]
    pts = [_coupler_point(x, a, b, c, o4, _qty(p["length"]), _qty(p["angle"])) for x in u]
    return np.hypot(*(np.array(pts) - targets).T), text


def test_path_file_reproduces_the_design_and_states_its_own_error(tmp_path):
    """The written path generator passes through the targets to rounding (the design's
    model error is ~1e-13 mm; with 6 digits the file was 4e-5 mm off and did not say so);
    with --digits 6 the header states the distances of the rounded file."""
    prob, targets = _path_problem(tmp_path)
    out = tmp_path / "d.yaml"
    printed = _synth(prob, "-o", out, "--seed", 1)
    dist, text = _path_distances(out, targets)
    assert np.max(dist) < 1e-9  # mm
    m = re.search(r"sum of squared distances ([\d.e+-]+) mm\^2, largest ([\d.e+-]+) mm", text)
    assert float(m[1]) < 1e-18 and float(m[2]) < 1e-9
    assert "every digit written" in text
    assert "largest " in printed
    out6 = tmp_path / "d6.yaml"
    _synth(prob, "-o", out6, "--seed", 1, "--digits", 6)
    dist6, text6 = _path_distances(out6, targets)
    assert np.max(dist6) > 1e-7  # the rounding shows
    m = re.search(r"sum of squared distances ([\d.e+-]+) mm\^2, largest ([\d.e+-]+) mm", text6)
    # 7 significant digits printed; the circles' distances at the header's crank angles
    assert float(m[1]) == pytest.approx(float(np.sum(dist6**2)), rel=1e-5)
    assert float(m[2]) == pytest.approx(float(np.max(dist6)), rel=1e-5)
    assert "6 significant digits" in text6


# -- the other writers: every digit by default ---------------------------------------------


def test_slider_crank_file_gives_the_stroke_and_time_ratio_to_rounding(tmp_path):
    """Offset slider-crank, stroke 100 mm, K = 1.4, offset 20 mm: the written lengths give
    the stroke sqrt((l + r)^2 - e^2) - sqrt((l - r)^2 - e^2) and the time ratio
    (180 + t) / (180 - t), t = asin(e/(l - r)) - asin(e/(l + r)), to rounding."""
    out = tmp_path / "sc.yaml"
    _synth(SYNTH / "slider-crank.yaml", "-o", out)
    text = out.read_text()
    r = float(re.search(r"crank: .*A: \[([\d.]+), 0\]", text)[1])
    rod = float(re.search(r"C: \[([\d.]+), 0\]", text)[1])
    e = 20.0
    stroke = math.sqrt((rod + r) ** 2 - e**2) - math.sqrt((rod - r) ** 2 - e**2)
    t = math.asin(e / (rod - r)) - math.asin(e / (rod + r))
    assert stroke == pytest.approx(100.0, abs=1e-11)
    assert (math.pi + t) / (math.pi - t) == pytest.approx(1.4, abs=1e-12)


def test_crank_rocker_file_gives_the_limits_to_rounding(tmp_path):
    """Crank-rocker, rocker 80 mm between 70 and 115 deg, K = 1.5, frame 100 mm: at the
    limits crank and coupler are in line, so |O1 B| = l - r and l + r at the rocker's
    limit positions (the law of cosines) and the crank angle between them is 180 + t,
    t = 180 (K - 1) / (K + 1) = 36 deg."""
    out = tmp_path / "cr.yaml"
    _synth(SYNTH / "crank-rocker-time-ratio.yaml", "-o", out)
    data = yaml.safe_load(out.read_text())
    o1 = np.array([_qty(v) for v in data["ground"]["O1"]])
    o3 = np.array([_qty(v) for v in data["ground"]["O3"]])
    lk = data["links"]
    r = _qty(lk["crank"]["points"]["A"][0])
    lcp = _qty(lk["coupler"]["points"]["B"][0])
    rock = _qty(lk["rocker"]["points"]["B"][0])
    assert rock == 80.0 and np.linalg.norm(o1 - o3) == pytest.approx(100.0, abs=1e-12)
    bs = [o3 + rock * np.array([math.cos(math.radians(p)), math.sin(math.radians(p))])
          for p in (70.0, 115.0)]  # fmt: skip
    d1, d2 = sorted(np.linalg.norm(b - o1) for b in bs)
    assert d1 == pytest.approx(lcp - r, abs=1e-12)
    assert d2 == pytest.approx(lcp + r, abs=1e-12)
    # the crank's directions at the limits: along O1 -> B (extended) and B -> O1 (folded)
    angs = [math.atan2(*(b - o1)[::-1]) for b in bs]
    t = abs(math.degrees((angs[0] - angs[1] + math.pi) % (2 * math.pi) - math.pi))
    assert t == pytest.approx(36.0, abs=1e-10)


def test_a_rounded_crank_rocker_header_states_the_rounded_files_figures(tmp_path):
    """The dock crane (round: 1 mm): the header's minimum transmission angle and time
    ratio are those of the rounded lengths, by the law of cosines (they were the
    unrounded design's, 43.9056 deg and K = 1.106217, while the file gives 43.8887 deg
    and K = 1.106346)."""
    out = tmp_path / "crane.yaml"
    _synth(SYNTH / "crane-crank-rocker.yaml", "-o", out)
    text = out.read_text()
    data = yaml.safe_load(text)
    o1 = np.array([_qty(v) for v in data["ground"]["O1"]])
    o3 = np.array([_qty(v) for v in data["ground"]["O3"]])
    lk = data["links"]
    r = _qty(lk["crank"]["points"]["A"][0])
    lc = _qty(lk["coupler"]["points"]["B"][0])
    c = _qty(lk["rocker"]["points"]["B"][0])
    f = float(np.linalg.norm(o1 - o3))
    assert r == round(r, 3) and lc == round(lc, 3)  # rounded to 1 mm indeed
    # transmission angle at B: |O3 A| runs from f - r to f + r
    mus = []
    for oa in (f - r, f + r):
        g = math.degrees(math.acos((lc * lc + c * c - oa * oa) / (2 * lc * c)))
        mus.append(min(g, 180.0 - g))
    # limit positions: |O1 B| = l + r and l - r; the crank turns 180 + alpha one way
    at_o1 = [math.acos((f * f + L * L - c * c) / (2 * f * L)) for L in (lc + r, lc - r)]
    alpha = math.degrees(abs(at_o1[0] - at_o1[1]))
    k = (180.0 + alpha) / (180.0 - alpha)
    m = re.search(r"minimum transmission angle ([\d.]+) deg; time ratio K = ([\d.]+)\.", text)
    assert float(m[1]) == pytest.approx(min(mus), abs=6e-5)
    assert float(m[2]) == pytest.approx(k, abs=6e-7)
    assert "the figures above: mechsolve's run of the numbers as written" in text


def test_three_positions_file_puts_the_line_in_its_first_position(tmp_path):
    """Three positions of a coupler line (P at (0, 0) along 0 deg first): mechsolve's run
    of the written file starts with P and Q (1 unit along the line) there, to rounding
    (6 digits put P 1.7e-4 mm off)."""
    out = tmp_path / "three.yaml"
    _synth(SYNTH / "three-positions.yaml", "-o", out)
    res = api.run(out)
    P, Q = res.point("P"), res.point("Q")
    assert abs(P.x[0]) < 1e-12 and abs(P.y[0]) < 1e-12  # m
    assert math.atan2(Q.y[0] - P.y[0], Q.x[0] - P.x[0]) == pytest.approx(0.0, abs=1e-12)


# -- review 6, item 5: a requirement over a sweep that meets toggles ------------------------

ROCKER_DRIVEN = """\
name: four-bar driven at the rocker
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}, mass: 0.05 kg, uniform_bar: [O2, A]}
  coupler:
    points: {A: [0, 0], B: [105.6, 0], P: {length: 60, angle: 30}}
    mass: 0.2 kg
    uniform_bar: [A, B]
  rocker: {points: {O4: [0, 0], B: [59, 0]}, mass: 0.11 kg, uniform_bar: [O4, B]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - A right of O2 -> B
driver: {joint: O4, speed: 1 rad/s, start: START deg}
sweep: {range: RANGE deg, step: 1 deg}
gravity: 9.81 m/s^2
requirements:
  t: min(transmission_angle.A) >= 5 deg
  tq: max(abs(input.torque)) <= 4 N m
"""
A_, B_, C_, D_ = 26.5, 105.6, 59.0, 87.5  # crank, coupler, rocker, frame (mm)


def _o2b2(theta):
    """|O2 B|^2 at the rocker's angle theta (rad): B = O4 + c (cos, sin), O4 = (d, 0)."""
    return D_**2 + C_**2 + 2 * D_ * C_ * np.cos(theta)


def _toggles() -> tuple[float, float]:
    """The rocker angles (deg) where crank and coupler are in line, |O2 B| = b + a and
    b - a (the law of cosines): loop A closes between them only."""
    return tuple(
        math.degrees(math.acos((L**2 - D_**2 - C_**2) / (2 * D_ * C_))) for L in (B_ + A_, B_ - A_)
    )


def _mu(theta):
    """The transmission angle of loop A (the angle at A between crank and coupler, taken
    in 0..90 deg), by the law of cosines."""
    g = np.arccos((A_**2 + B_**2 - _o2b2(theta)) / (2 * A_ * B_))
    return np.minimum(g, np.pi - g)


def test_a_requirement_over_a_toggle_fails_at_the_toggle(tmp_path):
    """Driven at the rocker from 50 to 120 deg: the loop stops closing at the toggles
    52.306 and 118.209 deg (law of cosines), where the transmission angle is 0. The
    minimum used to pass on the samples' 6.23876 deg ('not located'), and the summary's
    minimum was that sample's; the driving torque, which grows without bound towards a
    toggle, passed on the samples' 3.58 N m."""
    from mechsolve.cli.main import run
    from mechsolve.results.requirements import check_requirements

    t_in, t_out = _toggles()
    assert t_in == pytest.approx(52.306, abs=1e-3) and t_out == pytest.approx(118.2085, abs=1e-3)
    f = tmp_path / "rd.yaml"
    f.write_text(ROCKER_DRIVEN.replace("START", "50").replace("RANGE", "70"))
    mech = api.load(f)
    res = api.solve(mech)
    (tr,) = res.transmission_angles()
    assert tr.angle == 0.0
    assert math.degrees(tr.u) == pytest.approx(t_in, abs=1e-7)
    t, tq = check_requirements(mech, res)
    assert not t.passed and t.value == 0.0
    assert f"(at driver angle {t_in:.3f}°)" in t.message
    assert not tq.passed and math.isinf(tq.value)
    assert f"towards driver angle {t_out:.3f}°, where the mechanism stops closing" in tq.message
    r = CliRunner().invoke(run, [str(f), "-o", str(tmp_path / "out")])
    assert r.exit_code == 5, r.output
    assert "loop A (crank O2-A, coupler A-B) 0° at driver angle 52.306°" in r.output


def test_a_requirement_short_of_the_toggles_passes_on_its_located_minimum(tmp_path):
    """From 55 to 115 deg the loop closes everywhere: the minimum transmission angle is
    the law of cosines' over the range (at an end: |O2 B| is monotonic in the angle)."""
    from mechsolve.results.requirements import check_requirements

    f = tmp_path / "rd.yaml"
    f.write_text(ROCKER_DRIVEN.replace("START", "55").replace("RANGE", "60"))
    mech = api.load(f)
    t, _ = check_requirements(mech, api.solve(mech))
    want = float(np.min(_mu(np.radians(np.linspace(55, 115, 60001)))))
    assert t.passed and t.value == pytest.approx(want, abs=1e-12)
