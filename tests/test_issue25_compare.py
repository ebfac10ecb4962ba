"""Issue 25: ``mechsolve compare`` (the schemes of a machine side by side).

The figures are checked against closed forms computed here, independently of the solver:

* an offset slider-crank (crank r, rod l, offset e) pushed back by a constant force F:
  the stroke sqrt((l + r)^2 - e^2) - sqrt((l - r)^2 - e^2), the time ratio
  (180 + psi) / (180 - psi) with psi = asin(e / (l - r)) - asin(e / (l + r)), the smallest
  transmission angle acos((r + e) / l), the driving torque T = F dx/dtheta (power balance
  of a massless linkage), its peak and RMS, the rod's force F / cos(phi) at its largest,
  the flywheel's energy excursion F * stroke (the work of a constant force is F times
  the displacement), and the velocity's uniformity by quadrature of the closed form;
* the shaper's guide bar: stroke 2 * 540 * 110 / 380 mm, swing and time ratio from
  theta = 2 asin(110 / 380).

The exit codes are checked in real processes; the CSV's columns carry their units; the
plots are PNG images that load.
"""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, optimize

from mechsolve import api
from mechsolve.analyses.compare import compare, parse_middle, resolve_output
from mechsolve.analyses.compare.figures import without_ties
from mechsolve.base.errors import InputError

ROOT = Path(__file__).resolve().parent.parent
MECH = ROOT / "mechanisms"
R, L, E, F, W = 0.1, 0.35, 0.04, 1000.0, 10.0  # m, m, m, N, rad/s

SLIDER_CRANK = f"""
name: offset slider-crank
units: {{length: m, angle: deg}}
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [{R}, 0]}}}}
  rod: {{points: {{A: [0, 0], B: [{L}, 0]}}}}
  slider: {{points: {{B: [0, 0]}}}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  B: [rod, slider]
  guide: {{slider: [ground, slider], point: B, line: {{through: [0, {E}], angle: 0}}}}
assembly: ["B.x > A.x"]
driver: {{joint: O, speed: {W} rad/s, start: 30 deg}}
sweep: {{range: 360 deg, step: 5 deg}}
loads:
  push: {{force: [-{F} N, 0], at: B, on: slider}}
outputs: {{points: [B]}}
"""


def x_of(th):
    """The slider's position: x = r cos(theta) + sqrt(l^2 - (e - r sin(theta))^2)."""
    return R * np.cos(th) + np.sqrt(L**2 - (E - R * np.sin(th)) ** 2)


def dx_of(th):
    """dx/dtheta of the closed form."""
    s = E - R * np.sin(th)
    return -R * np.sin(th) + s * R * np.cos(th) / np.sqrt(L**2 - s**2)


@pytest.fixture
def slider_crank(tmp_path) -> Path:
    f = tmp_path / "sc.yaml"
    f.write_text(SLIDER_CRANK)
    return f


def mechsolve(*args, cwd=None, timeout=300):
    p = subprocess.run(
        [sys.executable, "-m", "mechsolve", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd or ROOT,
    )
    assert "Traceback" not in p.stdout + p.stderr, p.stderr
    return p


# -- the figures against closed forms ----------------------------------------------------
def test_slider_crank_figures_against_closed_forms(slider_crank):
    (s,) = compare([slider_crank], delta=0.05).schemes
    assert s.output.spec == "B.x"  # the file's first output point, its longer travel
    stroke = math.sqrt((L + R) ** 2 - E**2) - math.sqrt((L - R) ** 2 - E**2)
    psi = math.asin(E / (L - R)) - math.asin(E / (L + R))
    assert s.stroke == pytest.approx(stroke, rel=1e-10)
    assert s.time_ratio == pytest.approx((math.pi + psi) / (math.pi - psi), rel=1e-8)
    assert s.work_travel == pytest.approx(math.pi + psi, rel=1e-8)
    assert s.v_mean == pytest.approx(stroke * W / (math.pi + psi), rel=1e-8)
    # the smallest transmission angle of an offset slider-crank
    assert math.degrees(s.transmission) == pytest.approx(
        math.degrees(math.acos((R + E) / L)), abs=1e-6
    )
    # driving torque T = F dx/dtheta (a massless linkage: T omega = -Fx v)
    th = np.linspace(0, 2 * math.pi, 200001)
    T = F * dx_of(th)
    assert s.torque_peak == pytest.approx(np.max(np.abs(T)), rel=1e-5)
    rms = math.sqrt(
        integrate.quad(lambda t: (F * dx_of(t)) ** 2, 0, 2 * math.pi)[0] / (2 * math.pi)
    )
    assert s.torque_rms == pytest.approx(rms, rel=1e-6)
    assert abs(s.torque_mean) < 1e-6 * rms  # a constant force does no net work per turn
    # the rod carries F / cos(phi): largest where |e - r sin(theta)| = r + e
    assert s.reaction_joint in ("O", "A", "B")
    assert s.reaction_peak == pytest.approx(F / math.sqrt(1 - ((R + E) / L) ** 2), rel=1e-6)
    # flywheel: the energy excursion of a constant force is F times the stroke
    assert s.energy_max == pytest.approx(F * stroke, rel=1e-5)
    assert s.inertia_needed == pytest.approx(F * stroke / (W * W * 0.05), rel=1e-5)


def test_uniformity_by_quadrature(slider_crank):
    """The coefficient of variation of the speed over the middle 80 % of the working
    stroke, weighted by the displacement, from the closed form by adaptive quadrature."""
    (s,) = compare([slider_crank], middle=0.8).schemes
    stroke = s.stroke
    th_hi = math.asin(E / (L + R))  # crank and rod in line: the limits
    th_lo = math.pi + math.asin(E / (L - R))
    x_lo, x_hi = x_of(th_lo), x_of(th_hi)
    # the working stroke is the slower: the longer way round, ccw, between the limits
    up = (th_hi - th_lo) % (2 * math.pi)  # ccw from the low limit to the high one
    if up >= math.pi:
        a, first, last = th_lo, x_lo + 0.1 * stroke, x_lo + 0.9 * stroke
    else:
        a, first, last = th_hi, x_hi - 0.1 * stroke, x_hi - 0.9 * stroke
    span = max(up, 2 * math.pi - up)
    b = a + span
    assert span == pytest.approx(s.work_travel, rel=1e-8)
    grid = np.linspace(a, b, 20001)
    xs = x_of(grid)
    k1 = int(np.flatnonzero(np.diff(np.sign(xs - first)))[0])
    k2 = int(np.flatnonzero(np.diff(np.sign(xs - last)))[-1])
    t1 = optimize.brentq(lambda t: x_of(t) - first, grid[k1], grid[k1 + 1], xtol=1e-15)
    t2 = optimize.brentq(lambda t: x_of(t) - last, grid[k2], grid[k2 + 1], xtol=1e-15)
    ds = integrate.quad(lambda t: abs(dx_of(t)), t1, t2, epsabs=0, epsrel=1e-12)[0]
    mean = integrate.quad(lambda t: W * dx_of(t) ** 2, t1, t2, epsabs=0, epsrel=1e-12)[0] / ds
    var = (
        integrate.quad(
            lambda t: (W * abs(dx_of(t)) - mean) ** 2 * abs(dx_of(t)),
            t1,
            t2,
            epsabs=0,
            epsrel=1e-12,
        )[0]
        / ds
    )
    assert s.uniformity == pytest.approx(math.sqrt(var) / mean, rel=1e-4)
    speeds = W * np.abs(dx_of(np.linspace(t1, t2, 100001)))
    assert s.v_band[0] == pytest.approx(speeds.min(), rel=1e-6)
    assert s.v_band[1] == pytest.approx(speeds.max(), rel=1e-6)


def test_guide_bar_stroke_swing_and_time_ratio():
    """The shaper's guide bar (mechsolve synth's design, seed 001): the ram's stroke is
    the chord 2 * 540 * 110 / 380 mm; the bar swings theta = 2 asin(110 / 380), and both
    strokes have K = (180 + theta) / (180 - theta)."""
    c = compare([MECH / "shaper.yaml", MECH / "shaper.yaml"], outputs=["C.x", "guide_bar"])
    ram, bar = c.schemes
    theta = 2 * math.asin(110 / 380)
    k = (math.pi + theta) / (math.pi - theta)
    assert ram.stroke == pytest.approx(2 * 0.540 * 110 / 380, rel=1e-9)
    assert ram.time_ratio == pytest.approx(k, rel=1e-9)
    assert bar.output.angular and bar.stroke == pytest.approx(theta, rel=1e-9)
    assert bar.time_ratio == pytest.approx(k, rel=1e-9)
    # the slotted bar's transmission is 90 deg; the rod's is the smallest: the rod
    # B-C of 135 mm leaves the guide line y = 528.44 by at most 540 - 528.44 mm
    assert math.degrees(ram.transmission) == pytest.approx(
        math.degrees(math.acos((540 - 528.44) / 135)), abs=1e-6
    )


def test_scheme3_poses_the_seeds_six_bar():
    """Scheme 3: six moving links, nine joints, one redundant constraint: Grübler's
    3*6 - 2*9 = 0, the rank of the constraints gives 1, as the seed's F = 3*6 - 2*9 + 1.
    Leaving the immobile tie out changes neither the motion nor the torque."""
    mech = api.load(MECH / "shaper-scheme3.yaml")
    rep = api.check(mech)
    assert (len(mech.links), len(mech.joints), rep.grubler, rep.jacobian_dof) == (6, 9, 0, 1)
    light, ties = without_ties(mech)
    assert ties == ["tie"]
    a, b = api.solve(mech), api.solve(light)
    np.testing.assert_allclose(a.point("C").x, b.point("C").x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.driving_effort, b.driving_effort, rtol=1e-9, atol=1e-9)
    (s,) = compare([MECH / "shaper-scheme3.yaml"]).schemes
    assert s.stroke == pytest.approx(0.312632, abs=2e-6)  # sized to the shaper's stroke
    assert s.time_ratio == pytest.approx(1.4599, abs=1e-4)


def test_a_tie_is_no_limit_position():
    """A link pinned to the ground twice does not move: its rate is rounding, and no sign
    change of it is a limit position (before: 'rocker tie ... swing 7e-15 deg', found by
    thousands of root searches)."""
    res = api.solve(api.load(MECH / "shaper-scheme3.yaml"))
    names = [lp.name for lp in res.limit_positions()]
    assert "tie" not in names and "ram_guide" in names


# -- input -------------------------------------------------------------------------------
def test_output_names_checked_with_a_suggestion():
    mech = api.load(MECH / "shaper.yaml")
    assert resolve_output(mech, None).spec == "C"  # the first output point
    with pytest.raises(InputError, match=r"a point's coordinate is C\.x or C\.y"):
        resolve_output(mech, "C.z")
    with pytest.raises(InputError, match=r"no point, slider or link named 'ram_gide'.*"):
        resolve_output(mech, "ram_gide")
    with pytest.raises(InputError, match=r"did you mean 'ram_guide'"):
        resolve_output(mech, "ram_gide")
    assert parse_middle("80%") == pytest.approx(0.8)
    with pytest.raises(InputError):
        parse_middle("0")


# -- the command in real processes --------------------------------------------------------
def test_command_writes_csv_plots_and_report(tmp_path, slider_crank):
    out = tmp_path / "cmp"
    p = mechsolve(
        "compare",
        MECH / "shaper.yaml",
        f"{MECH / 'shaper.yaml'}@graphical",
        slider_crank,
        "-o",
        out,
        "--report",
        out / "compare.html",
        "--output",
        "C.x",
        "--output",
        "C.x",
        "--output",
        "B.x",
        "--delta",
        "1/40",
    )
    # the slider-crank turns at 10 rad/s, the shaper at 60 rpm: not comparable
    assert p.returncode == 2, p.stderr
    assert "different speeds" in p.stderr
    p = mechsolve(
        "compare",
        MECH / "shaper.yaml",
        f"{MECH / 'shaper.yaml'}@graphical",
        MECH / "shaper-scheme3.yaml",
        "-o",
        out,
        "--report",
        out / "compare.html",
        "--units",
        "SI",
    )
    assert p.returncode == 0, p.stderr
    assert "312.632 mm" in p.stdout and "shaper (graphical)" in p.stdout
    with open(out / "compare.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["scheme"] for r in rows] == [
        "shaper",
        "shaper (graphical)",
        "shaper scheme 3 (six-bar)",
    ]
    text_columns = {
        "scheme",
        "file",
        "variant",
        "output",
        "output.kind",
        "transmission.loop",
        "contact.joint",
        "reaction.joint",
        "requirements.failing",
    }
    for h in rows[0]:  # every figure has its unit in its header
        assert h in text_columns or h.endswith("]"), h
    assert float(rows[0]["stroke [m]"]) == pytest.approx(2 * 0.540 * 110 / 380, rel=1e-9)
    assert float(rows[2]["transmission.min [deg]"]) < 40  # scheme 3: a poor transmission
    from matplotlib.image import imread

    for name in ("compare_velocity", "compare_displacement", "compare_torque"):
        f = out / f"{name}.png"
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        img = imread(f)
        assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 300
    html = (out / "compare.html").read_text()
    assert "shaper scheme 3 (six-bar)" in html and html.count("data:image/png;base64") == 3
    # no temporary left (the folder's record of what compare wrote is not one)
    assert not [
        f for f in out.iterdir() if f.name.startswith(".") and f.name != ".mechsolve-outputs.json"
    ]


def test_exit_codes(tmp_path, slider_crank):
    failing = tmp_path / "failing.yaml"
    failing.write_text(SLIDER_CRANK + "requirements:\n  torque: max(abs(input.torque)) <= 10 N m\n")
    passing = tmp_path / "passing.yaml"
    passing.write_text(
        SLIDER_CRANK.replace("offset slider-crank", "sc 2")
        + "requirements:\n  torque: max(abs(input.torque)) <= 1 kN m\n"
    )
    p = mechsolve("compare", passing, slider_crank, "-o", tmp_path / "a", "--no-plots")
    assert p.returncode == 0, p.stderr
    assert "1 of 1 pass" in p.stdout
    p = mechsolve("compare", passing, failing, "-o", tmp_path / "b", "--no-plots")
    assert p.returncode == 5, p.stderr
    assert "1 FAIL: torque" in p.stdout
    assert (tmp_path / "b" / "compare.csv").exists()  # everything was written
    # bad input: a missing file, an unknown variant, an output the file lacks, a driver
    # that is no crank, a crank that cannot turn fully, outputs that do not match
    linear = tmp_path / "linear.yaml"
    linear.write_text(
        SLIDER_CRANK.replace(
            f"driver: {{joint: O, speed: {W} rad/s, start: 30 deg}}",
            "driver: {joint: guide, speed: -0.1 m/s, start: 0.4}",
        ).replace("sweep: {range: 360 deg, step: 5 deg}", "sweep: {range: 0.05, step: 0.01}")
    )
    partial = tmp_path / "partial.yaml"  # a + d > b + c: no closure around 180 deg
    partial.write_text(
        """
ground: {O2: [0, 0], O4: [1.0, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.6, 0]}}
  coupler: {points: {A: [0, 0], B: [0.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [0.5, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
assembly: [B left of A -> O4]
"""
    )
    for args, said in (
        ((linear,), "is a slider"),
        ((partial, "--output", "rocker"), "cannot close over the whole turn"),
        ((MECH / "shaper.yaml", MECH / "shaper-scheme3.yaml", *["--output", "C.x"] * 3), "3 times"),
        ((tmp_path / "nope.yaml",), "no such file"),
        ((f"{MECH / 'shaper.yaml'}@nope",), "no variant named 'nope'"),
        ((MECH / "shaper.yaml", "--output", "ram_gide"), "did you mean 'ram_guide'"),
        ((MECH / "shaper.yaml", "--middle", "120%"), "--middle"),
        ((MECH / "shaper.yaml", MECH / "shaper.yaml"), "given twice"),
    ):
        p = mechsolve("compare", *args, "-o", tmp_path / "c", "--no-plots")
        assert p.returncode == 2, (args, p.stderr)
        assert said in p.stderr, p.stderr


def test_variants_of_one_file(tmp_path):
    c = compare([MECH / "shaper.yaml"], all_variants=True)
    assert [s.name for s in c.schemes] == [
        "shaper",
        "shaper (graphical)",
        "shaper (exact-start)",
    ]
    # one motion, three starts and two branches of the rod: the same stroke and K
    for s in c.schemes:
        assert s.stroke == pytest.approx(2 * 0.540 * 110 / 380, rel=1e-9)
