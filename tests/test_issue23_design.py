"""Issue 23, the design tools (flywheel, synth, cam): inputs they could not take, and
exit codes and messages that were wrong. Every figure is checked against an independent
hand calculation or closed form."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

MECH = Path(__file__).resolve().parent.parent / "mechanisms"


def _run(*args: str):
    return CliRunner().invoke(main, [str(a) for a in args])


# --- flywheel: exit codes and messages (issue 23, section 4) --------------------------


@pytest.mark.parametrize("delta", ["1/0", "0/0", "2", "0", "-1/40", "nan", "x/40"])
def test_flywheel_bad_delta_is_an_input_error(tmp_path, delta):
    r = _run("flywheel", MECH / "crane.yaml", "--delta", delta, "-o", tmp_path)
    assert r.exit_code == 2, r.output
    assert "--delta" in r.output and "Traceback" not in r.output
    assert "internal error" not in r.output


def test_flywheel_on_a_file_without_masses_or_loads_has_nothing_to_size(tmp_path):
    r = _run("flywheel", MECH / "sixbar.yaml", "-o", tmp_path)
    assert r.exit_code == 2, r.output
    assert "nothing to size" in r.output and "J_F" not in r.output


CRANK_LOADED = """
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], A: [0.8, 0]}}
joints: {O: [ground, bar]}
driver: {joint: O, speed: 10 rad/s, start: 0 deg}
loads:
  weight: {force: [0, -29.43 N], at: A, on: bar}
"""


def test_flywheel_without_masses_but_with_a_load_sizes_the_whole_inertia(tmp_path):
    """A massless crank of length l carrying a constant vertical force F at its tip: the
    driving torque is F l cos(phi), its mean zero, so dE_max = 2 F l; the machine has no
    inertia of its own, J_F = 2 F l / (omega^2 delta) is all of it (hand calculation)."""
    f = tmp_path / "crank.yaml"
    f.write_text(CRANK_LOADED)
    r = _run("flywheel", f, "--delta", "1/40", "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    F, l, w, d = 29.43, 0.8, 10.0, 1 / 40
    assert f"ΔEₘₐₓ = {2 * F * l:.6g} J" in r.output
    assert f"flywheel J_F = {2 * F * l / (w * w * d):.6g} kg·m²" in r.output
    assert "no masses" in r.output


CRANK_BALANCED = """
ground: {O: [0, 0]}
links:
  disc: {points: {O: [0, 0], A: [0.2, 0]}, mass: 5 kg, com: O, inertia: 0.1 kg m^2}
joints: {O: [ground, disc]}
driver: {joint: O, speed: 10 rad/s, start: 0 deg}
gravity: 9.81 m/s^2
"""


def test_flywheel_with_no_fluctuation_says_none_is_needed(tmp_path):
    """A balanced disc turning at constant speed needs no torque at all: no fluctuation,
    no flywheel; the command says so and prints no J_F formula."""
    f = tmp_path / "disc.yaml"
    f.write_text(CRANK_BALANCED)
    r = _run("flywheel", f, "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    assert "no flywheel is needed" in r.output
    assert "required inertia" not in r.output


def _stiff_motor(tmp_path: Path, slope: float) -> Path:
    """seed 004 with a motor law of the given slope giving the same steady speed."""
    text = (MECH / "motor-linkage.yaml").read_text()
    # the cycle's mean torque at 39.23 rad/s is 0.961 N m (the file's own steady state)
    stall = 0.9611 + slope * 39.2304
    text = text.replace(
        "motor: {stall: 50 N m, slope: 1.25 N m s}",
        f"motor: {{stall: {stall:.6f} N m, slope: {slope:g} N m s}}",
    )
    f = tmp_path / f"stiff-{slope:g}.yaml"
    f.write_text(text)
    return f


def test_flywheel_check_by_simulation_that_misses_is_flagged(tmp_path):
    """A stiff motor (3000 N m s per rad/s) damps the fluctuation itself: the energy
    method's flywheel, checked by simulation, reaches a delta several times smaller than
    asked. That is flagged (a WARNING line) and exits 5; the file's own soft motor
    (1.25 N m s) reaches the target within the tolerance and exits 0."""
    from mechsolve.analyses.flywheel import CHECK_TOLERANCE

    r = _run("flywheel", _stiff_motor(tmp_path, 3000), "--delta", "0.05", "-o", tmp_path / "a")
    assert r.exit_code == 5, r.output
    assert "WARNING: the simulation misses the asked delta" in r.output
    reached = float(r.output.split("delta reached ")[1].split()[0])
    assert reached < 0.05 / CHECK_TOLERANCE
    r = _run("flywheel", MECH / "motor-linkage.yaml", "--delta", "0.05", "-o", tmp_path / "b")
    assert r.exit_code == 0, r.output
    assert "WARNING" not in r.output


# --- synth: key paths and numbers (issue 23, section 4) -------------------------------


def _window_problem(tmp_path: Path, width: str) -> Path:
    text = (MECH / "synth" / "crane-window.yaml").read_text()
    text = text.replace("../crane.yaml", str(MECH / "crane.yaml"))
    text = text.replace("width: 41 deg", f"width: {width}")
    f = tmp_path / "window.yaml"
    f.write_text(text)
    return f


@pytest.mark.parametrize("width", ["-41 deg", "300 deg"])
def test_synth_window_errors_name_the_width_and_its_line(tmp_path, width):
    f = _window_problem(tmp_path, width)
    line = 1 + f.read_text().splitlines().index(f"  width: {width}")
    r = _run("synth", f)
    assert r.exit_code == 2, r.output
    assert f"window.yaml:{line}: window.width:" in r.output
    assert "window.point" not in r.output


def test_synth_reads_1e6_style_numbers(tmp_path):
    """YAML 1.1 reads 14e-1 and 1e2 (no dot) as strings: they are numbers. The design
    with K = 14e-1 has the time ratio 1.4 by the offset slider-crank's closed form
    theta = asin(e / (l - r)) - asin(e / (l + r)), K = (180 + theta) / (180 - theta)."""
    f = tmp_path / "sc.yaml"
    f.write_text(
        "name: s\nunits: {length: mm, angle: deg}\n"
        "slider-crank: {stroke: 1e2, time_ratio: 14e-1, offset: 20}\n"
    )
    out = tmp_path / "sc-design.yaml"
    r = _run("synth", f, "-o", out)
    assert r.exit_code == 0, r.output
    from mechsolve.analyses.synth.problem import solve_problem

    d = solve_problem(f).chosen
    a, b, e = d.lengths["crank"], d.lengths["rod"], 0.020
    theta = math.asin(e / (b - a)) - math.asin(e / (b + a))
    K = (math.pi + theta) / (math.pi - theta)
    assert K == pytest.approx(1.4, rel=1e-9)
    stroke = math.sqrt((a + b) ** 2 - e * e) - math.sqrt((b - a) ** 2 - e * e)
    assert stroke == pytest.approx(0.1, rel=1e-9)


# --- cam: the geometry is checked first (issue 23, section 4) -------------------------


def _cam_file(tmp_path: Path, **subs: str) -> Path:
    text = (MECH / "shaper-cam.yaml").read_text()
    for a, b in subs.items():
        assert a in text
        text = text.replace(a, b)
    f = tmp_path / "cam.yaml"
    f.write_text(text)
    return f


def _designed(text: str) -> str:
    """The shaper's cam with its base values left out (to be designed)."""
    for k in ("pivot_distance: 135 mm", "start_angle: 12.5 deg", "base_radius: 30 mm"):
        text = "\n".join(ln for ln in text.splitlines() if not ln.strip().startswith(k))
    return text + "\n"


@pytest.mark.parametrize("designed", [False, True])
def test_cam_impossible_swing_is_refused_from_the_geometry(tmp_path, designed):
    """An oscillating roller follower's distance from the cam's centre,
    sqrt(a^2 + l^2 - 2 a l cos(phi)), grows only for phi below 180 deg: a 359 deg swing
    cannot be a rise. Said at once, at the swing's key, not blamed on the pressure angle."""
    import time

    f = _cam_file(tmp_path, **{"swing: 15 deg": "swing: 359 deg"})
    if designed:
        f.write_text(_designed(f.read_text()))
    line = 1 + next(i for i, ln in enumerate(f.read_text().splitlines()) if "359 deg" in ln)
    t0 = time.perf_counter()
    r = _run("cam", f, "-o", tmp_path / "o", "--no-plots")
    assert time.perf_counter() - t0 < 1.0
    assert r.exit_code == 2, r.output
    assert f"cam.yaml:{line}: cam.motion[0].swing:" in r.output
    assert "180 deg" in r.output and "pressure" not in r.output


def test_cam_swing_past_the_line_of_centres_with_the_given_start_angle(tmp_path):
    """phi0 = 12.5 deg given: a swing of 170 deg reaches 182.5 deg; at most 167.5 deg."""
    f = _cam_file(tmp_path, **{"swing: 15 deg": "swing: 170 deg"})
    r = _run("cam", f, "-o", tmp_path / "o", "--no-plots")
    assert r.exit_code == 2, r.output
    assert "cam.start_angle:" in r.output and "167.5 deg" in r.output


def test_cam_flat_face_swing_limit_is_90_deg(tmp_path):
    """An oscillating flat face's distance from the cam's centre a sin(phi) - f grows
    only for phi below 90 deg."""
    text = _designed((MECH / "shaper-cam.yaml").read_text())
    text = text.replace(
        "{type: oscillating roller, arm: 125 mm, roller_radius: 15 mm}",
        "{type: oscillating flat-faced, arm: 125 mm}",
    ).replace("swing: 15 deg", "swing: 95 deg")
    f = tmp_path / "flat.yaml"
    f.write_text(text)
    r = _run("cam", f, "-o", tmp_path / "o", "--no-plots")
    assert r.exit_code == 2, r.output
    assert "cam.motion[0].swing:" in r.output and "90 deg" in r.output


# --- cam: face width, base circle, the file's units (issue 23, 1.9) --------------------

FLAT_IN = """
name: flat face in inches
units: {length: in, angle: deg}
cam:
  follower: {type: translating flat-faced, offset: 0.25, face_margin: 0.125}
  rotation: ROT
  speed: 100 rpm
  base_radius: 2
  motion:
    - {rise: 100 deg, lift: 1, law: simple harmonic}
    - {dwell: 80 deg}
    - {return: 120 deg, law: cycloidal}
    - {dwell: 60 deg}
"""


def _csv(path: Path) -> list[dict[str, str]]:
    import csv

    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("rot", ["ccw", "cw"])
def test_cam_flat_face_width_against_the_closed_form(tmp_path, rot):
    """A translating flat face touches the cam at sigma ds/dtheta from the cam's centre
    line (Norton): with a harmonic rise h over beta1, ds/dtheta runs to
    pi h / (2 beta1), with a cycloidal return over beta2 down to -2 h / beta2, so the face
    needs pi h / (2 beta1) + 2 h / beta2 (plus the margin at each end)."""
    f = tmp_path / "flat.yaml"
    f.write_text(FLAT_IN.replace("ROT", rot))
    r = _run("cam", f, "-o", tmp_path / "o", "--no-plots", "--no-dxf")
    assert r.exit_code == 0, r.output
    h, b1, b2, e, c = 1.0, math.radians(100), math.radians(120), 0.25, 0.125
    up, down = math.pi * h / (2 * b1), 2 * h / b2
    sg = 1 if rot == "ccw" else -1
    lo, hi = sorted((sg * up - e, -sg * down - e))
    assert f"runs from {lo:.4f} in" in r.output and f"to {hi:.4f} in" in r.output
    assert f"at least {up + down:.4f} in" in r.output
    assert f"2 max|offset| = {2 * max(abs(lo), abs(hi)):.4f} in" in r.output
    assert f"at each end: {up + down + 2 * c:.4f} in" in r.output
    # the table's column, sample by sample, against sigma ds/dtheta - e of the laws
    rows = _csv(tmp_path / "o" / "cam_motion.csv")
    th = np.radians([float(x["cam angle [deg]"]) for x in rows])
    got = np.array([float(x["contact offset from the axis [in]"]) for x in rows])
    ds = np.where(th < b1, math.pi * h / (2 * b1) * np.sin(math.pi * th / b1), 0.0)
    u = (th - math.radians(180)) / b2
    ds = np.where((u >= 0) & (u <= 1), -h / b2 * (1 - np.cos(2 * math.pi * u)), ds)
    np.testing.assert_allclose(got, sg * ds - e, atol=1e-9)


def test_cam_oscillating_flat_face_length_against_intersecting_face_lines(tmp_path):
    """An oscillating flat face: the contact is where the face's line meets its
    neighbour's (the envelope, by intersecting the lines at theta -+ 0.001 deg in the
    cam's frame, no derivative used); its distance along the face from the foot of the
    pivot's perpendicular over the turn gives the face length printed."""
    text = """
name: oscillating flat face
units: {length: mm, angle: deg}
cam:
  follower: {type: oscillating flat-faced, arm: 120 mm, face_offset: 5 mm}
  pivot_distance: 100 mm
  start_angle: 25 deg
  rotation: cw
  speed: 60 rpm
  motion:
    - {rise: 150 deg, swing: 15 deg, law: cycloidal}
    - {dwell: 30 deg}
    - {return: 150 deg, law: simple harmonic}
    - {dwell: 30 deg}
"""
    f = tmp_path / "osc.yaml"
    f.write_text(text)
    r = _run("cam", f, "-o", tmp_path / "o", "--no-plots", "--no-dxf")
    assert r.exit_code == 0, r.output
    from mechsolve.analyses.cam.model import load

    model = load(f)
    a, phi0, fo, sg = 0.100, math.radians(25), 0.005, -1
    th = np.linspace(0, 2 * math.pi, 36000, endpoint=False)
    d = math.radians(0.001)
    psi = [model.program.eval(th + k * d)[0] for k in (-1, 1)]
    # in the cam's frame: the face's normal n at angle g - cam rotation, the line
    # n . x = a sin(g) - f (the pivot A = (a, 0) fixed, seen from the turning cam)
    lines = []
    for k, s in zip((-1, 1), psi):
        g = phi0 + s
        rot = -sg * (th + k * d)
        m = np.stack([np.sin(g), np.cos(g)], -1)
        n = np.stack([np.cos(rot) * m[:, 0] - np.sin(rot) * m[:, 1],
                      np.sin(rot) * m[:, 0] + np.cos(rot) * m[:, 1]], -1)  # fmt: skip
        lines.append((n, a * np.sin(g) - fo))
    (n1, h1), (n2, h2) = lines
    det = n1[:, 0] * n2[:, 1] - n1[:, 1] * n2[:, 0]
    x = (h1 * n2[:, 1] - h2 * n1[:, 1]) / det
    y = (n1[:, 0] * h2 - n2[:, 0] * h1) / det
    # back to the fixed frame at theta, then along the face from the pivot's foot
    rot = sg * th
    X = np.cos(rot) * x - np.sin(rot) * y
    Y = np.sin(rot) * x + np.cos(rot) * y
    g = phi0 + model.program.eval(th)[0]
    t = (X - a) * -np.cos(g) + Y * np.sin(g)
    line = next(ln for ln in r.output.splitlines() if "face length" in ln)
    lo = float(line.split("along the face from ")[1].split()[0])
    hi = float(line.split(" deg) to ")[1].split()[0])
    need = float(line.split("needs at least ")[1].split()[0])
    assert lo == pytest.approx(t.min() * 1e3, abs=2e-4)  # mm, as printed
    assert hi == pytest.approx(t.max() * 1e3, abs=2e-4)
    assert need == pytest.approx((t.max() - t.min()) * 1e3, abs=2e-4)


def test_cam_roller_base_circle_beside_the_prime_circle(tmp_path):
    """seed 001's roller (15 mm) on the prime circle r0 = 30.0002 mm: the base circle,
    the smallest circle touching the profile, is 15.0002 mm; the drawn profile's nearest
    point to the centre says so too (independent of the printed line)."""
    r = _run("cam", MECH / "shaper-cam.yaml", "-o", tmp_path, "--no-plots", "--no-dxf")
    assert "r0 = 30.0002 mm" in r.output
    assert "base circle r0 - roller = 15.0002 mm" in r.output
    rows = _csv(tmp_path / "cam_profile.csv")
    rad = [math.hypot(float(x["profile x [mm]"]), float(x["profile y [mm]"])) for x in rows]
    assert min(rad) == pytest.approx(15.0002, abs=5e-5)
    # the designed base for the allowances gives both circles too
    assert "r0 = 27.799 mm (prime circle; base circle 12.799 mm)" in r.output


def test_cam_results_in_the_files_unit(tmp_path):
    """The translating roller cam of tests/data written in inches: every length in the
    terminal and the CSV files in inches (the mm file's values / 25.4), speeds in in/s."""
    mm = (Path(__file__).parent / "data" / "cam_translating.yaml").read_text()
    mm = mm.replace("  min_curvature_radius: 2 mm\n", "  base_radius: 40 mm\n")
    inch = mm.replace("{length: mm, angle: deg}", "{length: in, angle: deg}")
    for k in ("25", "40", "8", "5"):
        inch = inch.replace(f"{k} mm", f"{float(k) / 25.4!r}")
    plain = inch.replace("units: {length: in, angle: deg}\n", "")
    for k in ("25", "40", "8", "5"):  # no units section: the lengths say their unit
        plain = plain.replace(f"{float(k) / 25.4!r}", f"{float(k) / 25.4!r} in")
    out = {}
    for name, text in (("mm", mm), ("in", inch), ("plain", plain)):
        f = tmp_path / f"{name}.yaml"
        f.write_text(text)
        r = _run("cam", f, "-o", tmp_path / name, "--no-plots", "--no-dxf")
        assert r.exit_code == 0, r.output
        out[name] = (r.output, _csv(tmp_path / name / "cam_motion.csv"))
    for name in ("in", "plain"):
        text, rows = out[name]
        assert f"r0 = {40 / 25.4:.4f} in" in text and " mm" not in text
        assert "roller radius 0.314961 in" in text
        for a, b in zip(out["mm"][1], rows):
            assert float(b["displacement [in]"]) == pytest.approx(
                float(a["displacement [mm]"]) / 25.4, rel=1e-10, abs=1e-12
            )
            assert float(b["profile x [in]"]) == pytest.approx(
                float(a["profile x [mm]"]) / 25.4, rel=1e-10, abs=1e-12
            )
            assert float(b["velocity [in/s]"]) == pytest.approx(
                float(a["velocity [m/s]"]) / 0.0254, rel=1e-9, abs=1e-9
            )
        # at the end of the rise the follower is up by its lift, 25 mm = 0.984252 in
        top = next(x for x in rows if float(x["cam angle [deg]"]) == 120.0)
        assert float(top["displacement [in]"]) == pytest.approx(25 / 25.4, rel=1e-11)


# --- flywheel from a power diagram (issue 23, 1.9) -------------------------------------


def _power_file(tmp_path: Path, body: str, name: str = "p.yaml") -> Path:
    f = tmp_path / name
    f.write_text("name: power diagram\n" + body)
    return f


@pytest.mark.parametrize(
    "start, alpha, p_work, p_idle, rpm",
    [(0, 220, 3.5, 0.5, 60), (40, 200, 5.0, 0.8, 90), (300, 150, 2.0, 0.0, 45)],
)
def test_flywheel_from_a_piecewise_constant_power_diagram(tmp_path, start, alpha, p_work,
                                                          p_idle, rpm):  # fmt: skip
    """The shaper as course books pose it: a motor of constant power; the resistance
    P_work over the working stroke's alpha degrees and P_idle over the rest. With
    f = alpha / 360, the mean is P_m = f P_w + (1 - f) P_i and the energy excursion the
    surplus over the working stroke, dE_max = (P_w - P_m) alpha / omega
    = (P_w - P_i) f (1 - f) 2 pi / omega; J_F = dE_max / (omega^2 delta)."""
    end = (start + alpha) % 360
    steps = [[start, p_work], [end, p_idle]]
    steps.sort()
    rows = ", ".join(f"[{a} deg, {p} kW]" for a, p in steps)
    f = _power_file(
        tmp_path,
        f"power:\n  resisting: {{steps: [{rows}]}}\n  driving: mean\n"
        f"speed: {rpm} rpm\ndelta: 1/40\n",
    )
    r = _run("flywheel", f, "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    w = rpm * math.pi / 30
    fr = alpha / 360
    dE = (p_work - p_idle) * 1e3 * fr * (1 - fr) * 2 * math.pi / w
    assert f"ΔEₘₐₓ = {dE:.6g} J" in r.output
    assert f"flywheel J_F = ΔEₘₐₓ / (ωₘ² delta) = {dE / (w * w / 40):.6g} kg·m²" in (r.output)
    pm = fr * p_work + (1 - fr) * p_idle
    assert f"mean power over the cycle {pm:.6g} kW" in r.output
    assert (tmp_path / "o" / "flywheel.png").exists()


def test_flywheel_from_a_power_law_and_a_power_table(tmp_path):
    """A law P_r = 2000 + 500 sin(angle) W against a constant motor: the surplus
    -500 sin(phi) / omega integrates to 500 (cos(phi) - 1) / omega, range 1000 / omega.
    A triangle table 0 -> 2 kW (at 180 deg) -> 0: the surplus (1 kW - P) / omega runs
    to +-(pi / 4) kW / omega, range (pi / 2) kW / omega. Also a driving curve against a
    constant resistance, and --delta over the file's."""
    w = 100 * math.pi / 30
    f = _power_file(tmp_path, "power:\n  resisting: {law: '2000 + 500 * sin(angle)'}\n"
                    "  driving: mean\nspeed: 100 rpm\n", "law.yaml")  # fmt: skip
    r = _run("flywheel", f, "--delta", "0.02", "-o", tmp_path / "a")
    assert r.exit_code == 0, r.output
    got = float(r.output.split("ΔEₘₐₓ = ")[1].split()[0])
    assert got == pytest.approx(1000 / w, rel=1e-6)  # the law sampled at 36001 points
    f = _power_file(tmp_path, "power:\n  driving: {table: [[0 deg, 0 W], [180 deg, 2 kW]]}\n"
                    "  resisting: 1 kW\nspeed: 100 rpm\ndelta: 0.02\n", "table.yaml")  # fmt: skip
    r = _run("flywheel", f, "-o", tmp_path / "b")
    assert r.exit_code == 0, r.output
    assert f"ΔEₘₐₓ = {1000 * math.pi / 2 / w:.6g} J" in r.output
    assert f"= {1000 * math.pi / 2 / w / (w * w * 0.02):.6g} kg·m²" in r.output


def test_flywheel_power_diagram_that_is_not_steady_or_flat(tmp_path):
    """A motor of 2 kW against a resistance whose mean is 2.333 kW is not a steady cycle:
    refused, at 'power', with both means. Equal constant powers need no flywheel."""
    f = _power_file(tmp_path, "power:\n  resisting: {steps: [[0 deg, 3.5 kW], "
                    "[220 deg, 0.5 kW]]}\n  driving: 2 kW\nspeed: 60 rpm\n")  # fmt: skip
    r = _run("flywheel", f, "-o", tmp_path / "o")
    assert r.exit_code == 2, r.output
    assert "p.yaml:2: power:" in r.output and "2.33333 kW" in r.output
    f = _power_file(tmp_path, "power: {resisting: 2 kW, driving: mean}\nspeed: 60 rpm\n")
    r = _run("flywheel", f, "-o", tmp_path / "o")
    assert r.exit_code == 0, r.output
    assert "no flywheel is needed" in r.output and "J_F" not in r.output
    f = _power_file(tmp_path, "power: {resisting: 2 kN, driving: mean}\nspeed: 60 rpm\n")
    r = _run("flywheel", f, "-o", tmp_path / "o")
    assert r.exit_code == 2 and "power.resisting" in r.output, r.output


# --- synth: a crank-rocker from K, the rocker, the frame and one limit (issue 23, 1.9) --

ONE_LIMIT = """
name: crank-rocker K 1.2, one limit
units: {length: mm, angle: deg}
crank-rocker:
  rocker_pivot: [100, 0]      # D
  PIVOT
  rocker: 75                  # CD
  limit: 135                  # the rocker 45 deg from the frame DA at one limit
  time_ratio: 1.2
"""


def _closed_form_limits(a: float, b: float, c: float, d: float):
    """A crank-rocker with O1 at the origin and O3 at (d, 0), the rocker above the frame:
    at its limits the crank and coupler are in line, |O1 B| = b + a and b - a; the
    rocker's angle (from +x) is 180 deg - gamma, cos gamma = (c^2 + d^2 - r^2) / (2 c d),
    and O1 sees the two positions under theta, the difference of the angles
    cos beta = (r^2 + d^2 - c^2) / (2 r d); K = (180 + theta) / (180 - theta)."""
    psi, beta = [], []
    for r in (b + a, b - a):
        psi.append(180 - math.degrees(math.acos((c * c + d * d - r * r) / (2 * c * d))))
        beta.append(math.degrees(math.acos((r * r + d * d - c * c) / (2 * r * d))))
    theta = abs(beta[0] - beta[1])
    return sorted(psi), (180 + theta) / (180 - theta)


@pytest.mark.parametrize("pivot", ["crank_pivot: [0, 0]", "frame: 100"])
def test_synth_crank_rocker_from_one_limit_gives_both_solutions(tmp_path, pivot):
    """K = 1.2, rocker 75 mm, frame 100 mm, one limit 45 deg from the frame: two
    crank-rockers. Each, written with --solution N and solved by mechsolve's own run,
    and by the closed form of its lengths, has K = 1.2 and the given limit 135 deg."""
    from mechsolve import api
    from mechsolve.analyses.synth.problem import solve_problem

    f = tmp_path / "one.yaml"
    f.write_text(ONE_LIMIT.replace("PIVOT", pivot))
    r = _run("synth", f)
    assert r.exit_code == 0, r.output
    assert "2 solution(s)" in r.output
    out = solve_problem(f)
    assert [d.valid for d in out.designs] == [True, True]
    others = set()
    for n, d in enumerate(out.designs, 1):
        L = d.lengths
        psi, K = _closed_form_limits(L["crank"], L["coupler"], L["rocker"], L["frame"])
        assert K == pytest.approx(1.2, rel=1e-9)
        assert min(abs(p - 135) for p in psi) < 1e-7
        other = max(psi, key=lambda p: abs(p - 135))
        others.add(round(other, 6))
        assert f"other limit at {other:.6f} deg" in r.output
        written = tmp_path / f"design-{n}.yaml"
        # every digit written (--digits 17): the design's limits to 1e-6 deg
        r2 = _run("synth", f, "--solution", n, "-o", written, "--digits", 17)
        assert r2.exit_code == 0, r2.output
        res = api.solve(api.load(written))
        (lp,) = [x for x in res.limit_positions() if x.name == "rocker"]
        lims = sorted(math.degrees(x) for x in (lp.low, lp.high))
        assert lims == pytest.approx(sorted(psi), abs=1e-6)
        assert lp.time_ratio == pytest.approx(1.2, rel=1e-6)
    assert len(others) == 2  # two different designs
    r = _run("synth", MECH / "synth" / "crank-rocker-one-limit.yaml")  # the shipped example
    assert r.exit_code == 0 and "2 solution(s)" in r.output, r.output


def test_synth_one_limit_input_errors(tmp_path):
    f = tmp_path / "one.yaml"
    f.write_text(ONE_LIMIT.replace("PIVOT", "crank_pivot: [0, 0]\n  frame: 100"))
    r = _run("synth", f)
    assert r.exit_code == 2 and "crank_pivot" in r.output, r.output
    f.write_text(ONE_LIMIT.replace("PIVOT", "crank_pivot: [0, 0]"))
    r = _run("synth", f, "--solution", "3")
    assert r.exit_code == 2 and "2 solution(s)" in r.output, r.output
    f.write_text(
        ONE_LIMIT.replace("PIVOT", "crank_pivot: [0, 0]").replace("rocker: 75", "rocker: 5")
    )
    r = _run("synth", f)
    assert r.exit_code == 2 and "Traceback" not in r.output, r.output


@pytest.mark.parametrize(
    "body",
    [
        "torque: {table: [[0 deg, 0 N m], [90 deg, 100 N m], [180 deg, 0 N m]]}\n",
        "power: {resisting: {steps: [[0 deg, 3 kW], [90 deg, 1 kW]]}, driving: mean}\n",
    ],
)
def test_flywheel_problem_files_with_delta_1_over_0(tmp_path, body):
    f = tmp_path / "d.yaml"
    f.write_text(f"name: d\n{body}speed: 60 rpm\ndelta: 1/0\n")
    r = _run("flywheel", f, "-o", tmp_path / "o")
    assert r.exit_code == 2, r.output
    assert "d.yaml:4: delta:" in r.output
