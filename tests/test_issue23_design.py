"""Issue 23, the design tools (flywheel, synth, cam): inputs they could not take, and
exit codes and messages that were wrong. Every figure is checked against an independent
hand calculation or closed form."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve.cli import main

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
    assert f"dE_max = {2 * F * l:.6g} J" in r.output
    assert f"flywheel J_F = {2 * F * l / (w * w * d):.6g} kg*m^2" in r.output
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
    from mechsolve.flywheel import CHECK_TOLERANCE

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
    from mechsolve.synth.problem import solve_problem

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
