"""Issue 23, `mechsolve simulate`: what a run says and keeps when the machine stalls, runs
backwards, leaves the range where it closes, meets a motor law that is not finite, or is
asked for more steps than it can hold. Checked against static torque balance, the
closed-form run-up of a disc, and the geometry of where a four-bar closes."""

from __future__ import annotations

import csv
import math
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.analyses.dynamics import simulate
from mechsolve.cli.main import main

from conftest import MECH, ROOT

# a uniform bar 0.8 m, 3 kg, pivoted at one end: J = m l^2 / 3 = 0.64 kg m^2, gravity's
# moment m g (l / 2) cos(phi) = 11.772 cos(phi) N m
BAR = """
name: bar on a motor
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], A: [0.8, 0]}, mass: 3 kg, uniform_bar: [O, A]}
joints: {O: [ground, bar]}
driver: {joint: O, start: 0 deg}
GRAVITY
MOTOR
simulate: {duration: DURATION, step: 0.002 s, method: METHOD, from: rest}
"""
M_GRAVITY = 3 * 9.81 * 0.4


def bar(motor: str, gravity: str = "gravity: 9.81 m/s^2", duration="6 s", method="rk4"):
    return (
        BAR.replace("GRAVITY", gravity)
        .replace("MOTOR", f"motor: {motor}")
        .replace("DURATION", duration)
        .replace("METHOD", method)
    )


# a non-Grashof four-bar (crank a = 0.6, coupler b = 0.6, rocker c = 0.5, frame d = 1):
# the loop closes while |A O4| <= b + c, i.e. cos(phi) >= 0.125, phi <= 82.8192 deg; the
# motor drives the crank into that limit
NON_GRASHOF = """
name: non-Grashof four-bar on a motor
ground: {O2: [0, 0], O4: [1.0, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.6, 0]}, mass: 1 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [0.6, 0]}, mass: 1 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [0.5, 0]}, mass: 1 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 0 deg}
gravity: off
motor: {stall: 5 N m, slope: 0 N m s}
simulate: {duration: 2 s, step: 0.01 s, method: METHOD, from: rest}
"""
CLOSES_UP_TO = math.degrees(math.acos(0.125))  # 82.8192 deg


def run_cli(tmp_path, text: str, *args: str, name="m.yaml"):
    f = tmp_path / name
    f.write_text(text)
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(out), *args])
    return r, out


class Done:
    """What a command line run in its own process did: ``exit_code``, ``output``."""

    def __init__(self, p: subprocess.CompletedProcess) -> None:
        self.exit_code, self.output = p.returncode, p.stdout + p.stderr


def run_process(tmp_path, text: str, *args: str, timeout: float = 60):
    """As :func:`run_cli`, in a new process that must end within ``timeout`` seconds (a
    run that would go on for ever fails the test instead of hanging it)."""
    f = tmp_path / "m.yaml"
    f.write_text(text)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "mechsolve", "simulate", str(f), "-o", str(out), *args]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    return Done(p), out


def the_csv(out):
    """The CSV written to ``out`` (whatever its name)."""
    (path,) = [p for p in out.iterdir() if p.suffix == ".csv"]
    return path


def read_csv(path, *columns: str) -> list[np.ndarray]:
    """The named columns of a CSV as float arrays (blank: nan)."""
    with open(path, newline="") as fh:
        rows = [r for r in csv.reader(fh) if r and not r[0].startswith("#")]
    head = rows[0]
    return [np.array([float(r[head.index(c)] or "nan") for r in rows[1:]]) for c in columns]


# -- 2.1: a motion that leaves the closing range keeps what was computed, every method -------


@pytest.mark.parametrize("method", ["rk4", "RK45", "LSODA", "DOP853", "Radau"])
def test_leaving_the_closing_range_writes_the_computed_part(tmp_path, method):
    """Exit 0 with a warning (as `run` when positions cannot be solved: the
    mechanism reaching where it cannot close is a finding of the run, not bad input), the
    CSV and the plots hold the motion up to there, and the message says so and where."""
    r, out = run_cli(tmp_path, NON_GRASHOF.replace("METHOD", method))
    assert r.exit_code == 0 and "warning: the motion stopped early" in r.output, r.output
    assert "Traceback" not in r.output
    # the folder's record of what the commands wrote is not an output of this run
    names = sorted(p.name for p in out.iterdir() if p.name != ".mechsolve-outputs.json")
    assert any(n.endswith(".csv") for n in names) and any(n.endswith(".png") for n in names)
    csv_file = the_csv(out)
    t, angle = read_csv(csv_file, "t [s]", "input.angle [deg]")
    assert len(t) > 10 and np.all(np.diff(t) > 0) and t[-1] < 2.0
    # every row written closes: before the geometric limit, and the motion got near it
    assert np.all(angle <= CLOSES_UP_TO + 1e-9)
    assert angle[-1] > CLOSES_UP_TO - 3.0
    text = " ".join(r.output.split())
    assert "left the range where the mechanism closes" in text
    m = re.search(r"near driver angle ([\d.]+)°", text)
    assert m and abs(float(m.group(1)) - CLOSES_UP_TO) < 1.0, text
    assert f"stopped early at t = {t[-1]:.6g} s" in text, text
    assert f"wrote {len(names)} file(s) with the motion up to t = {t[-1]:.6g} s" in text, text
    assert "stopped stopped" not in text


# -- 4, bullet 6: a motor law that is not finite is named as such ------------------------------


@pytest.mark.parametrize("method", ["rk4", "RK45"])
def test_a_motor_law_that_is_infinite_at_the_start_is_an_input_error(tmp_path, method):
    """M = 5 / omega from rest: inf at omega = 0, t = 0. Input error (exit 2) at the law's
    key and line, nothing written, no numpy warning, no 'stopped stopped'."""
    text = bar('{torque: "5 / omega"}', method=method)
    r, out = run_cli(tmp_path, text)
    assert r.exit_code == 2, r.output
    line = 1 + text.splitlines().index('motor: {torque: "5 / omega"}')
    assert f"m.yaml:{line}: motor.torque: the motor's law M = 5 / omega gives inf at " in r.output
    assert "omega = 0 rad/s, t = 0 s" in r.output, r.output
    assert "too large" not in r.output and "Warning" not in r.output
    assert "stopped stopped" not in r.output and "Traceback" not in r.output
    assert not out.exists() or not any(out.iterdir())
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning through the API either
        with pytest.raises(ms.InputError, match="gives inf at omega = 0 rad/s"):
            simulate(ms.loads(text))


@pytest.mark.parametrize("method", ["rk4", "RK45"])
def test_a_motor_law_that_becomes_nan_keeps_the_motion_up_to_there(tmp_path, method):
    """M = sqrt(omega - 1) N m, launched at 3 rad/s upwards against gravity: the speed
    falls through 1 rad/s, where the law has no value. The motion before is written; the
    message names the law, a speed below 1 rad/s (where sqrt is nan) and the time, and the
    exit is 2 (the file's law is at fault)."""
    text = bar('{torque: "sqrt(omega - 1)"}', method=method).replace("from: rest", "from: 3 rad/s")
    r, out = run_cli(tmp_path, text)
    assert r.exit_code == 2, r.output
    m = re.search(r"gives nan at omega = ([\d.]+) rad/s, t = ([\d.]+) s", r.output)
    assert m, r.output
    assert 0.9 < float(m.group(1)) < 1.0
    assert "motor.torque" in r.output and "Warning" not in r.output
    assert "too large" not in r.output and "stopped stopped" not in r.output
    csv_file = the_csv(out)
    t, omega = read_csv(csv_file, "t [s]", "omega [rad/s]")
    # every row written has a defined law, and the last is just before the speed of 1 rad/s
    assert np.all(omega >= 1.0) and omega[-1] < 1.05
    assert abs(float(m.group(2)) - t[-1]) < 0.01


# -- 3.2: a run too long to hold is refused before it starts, with its numbers -----------------


@pytest.mark.parametrize(
    "duration, step, steps", [("1e9 s", "1e-6 s", "1e+15"), ("2 s", "1e-300 s", "2e+300")]
)
def test_a_simulation_too_long_to_hold_is_refused_at_once(tmp_path, duration, step, steps):
    text = bar("{stall: 5 N m, slope: 2 N m s}").replace(
        "duration: 6 s, step: 0.002 s", f"duration: {duration}, step: {step}"
    )
    r, out = run_process(tmp_path, text, timeout=60)  # refused at once, not run for ever
    assert r.exit_code == 2, r.output
    line = 1 + next(i for i, s in enumerate(text.splitlines()) if s.startswith("simulate:"))
    assert f"m.yaml:{line}: simulate.step: " in r.output
    assert f"is {steps} steps" in r.output and "the limit is 200000 steps" in r.output
    assert "--max-steps" in r.output and "Traceback" not in r.output
    assert re.search(r"about [\d.e+]+ [EPTGM]B of results", r.output), r.output
    assert not out.exists()


def test_max_steps_sets_the_limit_and_the_estimate_counts_the_columns_written(tmp_path):
    """250 steps of 2 ms: refused over --max-steps 100, run under --max-steps 250; the
    refusal's estimate of the values a row holds is the CSV's own column count (the
    memory: rows times those values times 100 bytes, the measured cost of a value)."""
    text = bar("{stall: 5 N m, slope: 2 N m s}", duration="0.5 s")
    r, out = run_cli(tmp_path, text, "--max-steps", "100")
    assert r.exit_code == 2, r.output
    flat = " ".join(r.output.split())
    m = re.search(
        r"is 250 steps, about ([\d.]+) kB of results \(251 rows of about (\d+) values\)", flat
    )
    assert m and "the limit is 100 steps" in flat, flat
    r, out = run_cli(tmp_path, text, "--max-steps", "250", "--no-plots")
    assert r.exit_code == 0, r.output
    (t,) = read_csv(the_csv(out), "t [s]")
    assert len(t) == 251
    with open(the_csv(out)) as fh:
        columns = len(next(csv.reader(fh)))
    assert int(m.group(2)) == pytest.approx(columns, rel=0.1)
    assert float(m.group(1)) * 1e3 == pytest.approx(251 * int(m.group(2)) * 100, rel=0.01)


def test_an_adaptive_integrator_stops_after_max_steps_and_keeps_its_motion(tmp_path):
    """RK45 over 1e9 s (an output every 2e6 s) of a disc run up to a constant speed: the
    integrator's own steps are capped; the motion so far is written, exit 0, warned."""
    text = bar(
        "{stall: -5 N m, slope: 0.5 N m s}", gravity="gravity: off", duration="1e9 s", method="RK45"
    ).replace("step: 0.002 s, ", "")
    r, out = run_process(tmp_path, text, "--max-steps", "500", "--no-plots", timeout=120)
    assert r.exit_code == 0, r.output
    assert "the integrator took 500 steps, the limit (--max-steps raises it" in r.output
    assert the_csv(out).stat().st_size > 0


# -- 1.5: what the summary of a simulation says, each figure with its unit and meaning ---------


def number(pattern: str, text: str) -> float:
    m = re.search(pattern, text)
    assert m, (pattern, text)
    return float(m.group(1))


def test_a_motor_too_weak_to_lift_the_bar_is_reported_stalled_where_torques_balance(
    tmp_path, monkeypatch
):
    """M = 5 - 3 omega N m on the bar, whose weight needs 11.772 cos(phi) N m: it cannot
    lift it; the bar swings down and comes to rest where 5 = 11.772 cos(phi), phi =
    -acos(5 / 11.772) = -64.866 deg (static torque balance; the stable one, below). The
    mean of the motor torque is over time, said so, in the summary and the plot alike:
    with M linear in omega its time mean is 5 - 3 (phi_end - phi_0) / T."""
    res = simulate(ms.loads(bar("{stall: 5 N m, slope: 3 N m s}")))
    text = " ".join(res.summary().split())
    rest = math.degrees(math.acos(5 / M_GRAVITY))
    assert number(r"stalled at driver angle ([\d.]+)°", text) == pytest.approx(360 - rest, abs=1e-3)
    assert number(r"\(([\d.]+)° backwards from the start\) after", text) == pytest.approx(
        rest, abs=1e-3
    )
    t_rest = number(r"after t = ([\d.]+) s \(at rest from then on, to 0.01°\)", text)
    tr = res.trajectory
    assert 1.0 < t_rest < 6.0
    later = tr.t >= t_rest
    assert np.all(np.abs(np.degrees(tr.phi[later]) + rest) < 0.01 + 1e-3)
    assert not np.all(np.abs(np.degrees(tr.phi[tr.t >= t_rest - 0.1]) + rest) < 0.01 - 1e-3)
    assert "the motor's torque at standstill, 5 N*m, balances the static load" in text
    mean = 5 + 3 * math.radians(rest) / 6.0
    assert number(r"time mean (-?[\d.]+) N·m", text) == pytest.approx(mean, abs=2e-4)
    assert not re.search(r"(?<!time) mean -?\d", text), text  # no unlabelled mean left
    # the plot's mean is the same figure, the same words
    from matplotlib.axes import Axes

    labels = []
    original = Axes.axhline

    def spy(self, *args, **kwargs):
        labels.append(kwargs.get("label"))
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Axes, "axhline", spy)
    from mechsolve.analyses.dynamics.plots import write_simulation_plots

    write_simulation_plots(res, res.model, tmp_path)
    shown = number(r"time mean (-?[\d.]+) N·m", text)
    assert f"time mean {shown:.6g} N*m" in labels, labels


def test_a_machine_swinging_without_turning_is_said_so():
    """No damping, M = 5 N m < 11.772 N m: the bar swings about its balance forever."""
    text = simulate(ms.loads(bar("{stall: 5 N m, slope: 0 N m s}"))).summary()
    assert "does not turn: no full revolution in 6 s" in text and "stalled" not in text
    # the swing: from the start (0 deg) down to 2 x 64.866 deg (energy: the work of the
    # constant torque equals the change of potential energy between the turning points)
    low = number(r"\(([\d.]+)° backwards from the start\) and", " ".join(text.split()))
    assert 5 * math.radians(-low) == pytest.approx(
        M_GRAVITY * math.sin(math.radians(-low)), abs=2e-4
    )


def test_a_negative_stall_torque_runs_the_crank_backwards_and_the_summary_says_how_fast():
    """M = -5 - 0.5 omega N m on a balanced bar (J = 0.64 kg m^2, no gravity): it runs
    backwards, omega(t) = -10 (1 - exp(-t / 1.28)) rad/s, phi(t) = -10 (t - 1.28 (1 -
    exp(-t / 1.28))) rad; the summary gives the largest |omega| and its sense, and the
    peak reaction (m r omega^2, r = 0.4 m) at its time with the turns made."""
    res = simulate(
        ms.loads(bar("{stall: -5 N m, slope: 0.5 N m s}", gravity="gravity: off", duration="10 s"))
    )
    text = " ".join(res.summary().split())
    tau = 0.64 / 0.5
    w_end = 10 * (1 - math.exp(-10 / tau))
    fastest = number(r"fastest \|omega\| = ([\d.]+) rad/s at t = 10 s", text)
    assert fastest == pytest.approx(w_end, rel=1e-6)
    assert "clockwise: backwards, against the driver's direction" in text
    assert "max omega = 0" not in text
    phi_end = -10 * (10 - tau * (1 - math.exp(-10 / tau)))
    turns, part = divmod(math.degrees(-phi_end), 360.0)
    peak = number(r"peak reactions \(\d+ time samples\): O ([\d.]+) N at t = 10 s", text)
    eps_end = (-5 + 0.5 * w_end) / 0.64
    assert peak == pytest.approx(3 * 0.4 * math.hypot(w_end**2, eps_end), rel=1e-3)
    got = number(
        rf"O [\d.]+ N at t = 10 s \(driver angle [\d.]+°, {int(turns)} turns "
        r"\+ ([\d.]+)° backwards",
        text,
    )
    assert got == pytest.approx(part, abs=1e-3)


def test_the_shaper_summary_gives_speeds_as_sizes_with_their_sense_and_units():
    """The shaper's crank turns clockwise: the fastest speed is a size with its sense
    (was 'max omega = -6.72', the signed minimum); its reduced inertia is the flywheel's
    2 kg m^2 (the crank is massless) at the guide bar's limits, where the ram and the bar
    stop, with its unit; the revolution's mean speed says which mean it is."""
    res = simulate(ms.load(MECH / "shaper.yaml"))
    text = " ".join(res.summary().split())
    tr = res.trajectory
    fastest = number(r"fastest \|omega\| = ([\d.]+) rad/s", text)
    assert fastest == pytest.approx(float(np.max(-tr.omega)), rel=1e-6) and fastest > 0
    assert "clockwise (the driver's direction)" in text
    assert number(r"reduced inertia J from ([\d.]+) to [\d.]+ kg\*m\^2", text) == pytest.approx(
        2.0, abs=1e-6
    )
    assert "last full revolution: time mean of |omega|" in text
    assert "max omega = -" not in text
    # peaks are placed in time, with the turns made: the crank starts at 196.83 deg
    m = re.search(
        r"O4 [\d.]+ N at t = ([\d.]+) s \(driver angle ([\d.]+)°, "
        r"1 turn \+ ([\d.]+)° from the start\)",
        text,
    )
    assert m, text
    k = int(np.argmin(np.abs(tr.t - float(m.group(1)))))
    travel = math.degrees(tr.phi[0] - tr.phi[k])  # clockwise
    assert float(m.group(3)) == pytest.approx(travel - 360, abs=1e-3)


def holding_torque(text: str, angle: float, h: float = 0.01) -> tuple[float, float]:
    """Seed 004's machine: the torque that holds it still at the driver angle ``angle``
    (deg), dV/dphi, and the stiffness d2V/dphi2, by virtual work from the positions alone:
    V = g sum(m y_centre) (uniform bars: their midpoints; the slider at D)."""
    probe = text.replace("start: 0 deg}", f"start: {angle - h} deg}}").replace(
        "sweep: {range: 360 deg, step: 1 deg}", f"sweep: {{range: {2 * h} deg, step: {h} deg}}"
    )
    res = ms.solve(ms.loads(probe), forces=False)
    y = {p: res.point(p).y for p in ("A", "B", "K", "D")}
    y["O"] = 0.0
    y["O1"] = 0.37
    mid = {"crank": ("O", "A", 1.5), "coupler": ("A", "B", 9.7), "rocker": ("O1", "B", 6.6)}
    mid["rod"] = ("K", "D", 8.6)
    V = 9.81 * (sum(m * 0.5 * (y[a] + y[b]) for a, b, m in mid.values()) + 2.0 * y["D"])
    dx = math.radians(h)
    return (V[2] - V[0]) / (2 * dx), (V[2] - 2 * V[1] + V[0]) / dx**2


SEED_004 = (MECH / "motor-linkage.yaml").read_text()


def test_seed_004_with_a_weak_motor_stalls_where_its_weight_needs_the_motor_torque():
    """The six-link machine of seed 004 with M = 3 - 1.25 omega N m: its links' weight
    turns the crank back and it rests where the motor's 3 N m holds it (virtual work)."""
    text = SEED_004.replace(
        "motor: {stall: 50 N m, slope: 1.25 N m s}", "motor: {stall: 3 N m, slope: 1.25 N m s}"
    ).replace("duration: 2.2 s", "duration: 6 s")
    summary = " ".join(simulate(ms.loads(text)).summary().split())
    rest = number(r"stalled at driver angle ([\d.]+)°", summary)
    assert "the motor's torque at standstill, 3 N*m, balances the static load" in summary
    hold, stiffness = holding_torque(text, rest)
    assert hold == pytest.approx(3.0, abs=2e-3) and stiffness > 0  # a stable rest


def test_seed_004_stops_and_stays_when_its_motor_is_cut_off():
    """The motor runs it up for 0.5 s, then only brakes (-1.25 omega): the machine turns
    on, stops and stays, where its weight needs no torque (dV/dphi = 0, a minimum of V);
    no 'last full revolution' figures for a machine at rest."""
    text = SEED_004.replace(
        "motor: {stall: 50 N m, slope: 1.25 N m s}",
        'motor: {torque: "(50 - 1.25 * omega) * (t < 0.5) - 1.25 * omega"}',
    ).replace("duration: 2.2 s", "duration: 12 s")
    res = simulate(ms.loads(text))
    summary = " ".join(res.summary().split())
    rest = number(r"stalled at driver angle ([\d.]+)°", summary)
    travel = number(r"stalled at driver angle [\d.]+° \(([\d.]+)° from the start\)", summary)
    assert travel > 360 and (travel - rest) % 360 == pytest.approx(0, abs=1e-6)
    assert "the motor's torque at standstill, 0 N*m, balances the static load" in summary
    assert "last full revolution" not in summary
    hold, stiffness = holding_torque(text, rest)
    assert hold == pytest.approx(0.0, abs=2e-3) and stiffness > 0
    t_rest = number(r"after t = ([\d.]+) s", summary)
    tr = res.trajectory
    assert np.ptp(np.degrees(tr.phi[tr.t >= t_rest])) <= 0.02


def test_a_linear_driver_pushed_back_by_gravity_has_its_speed_and_law_with_units():
    """A 2 kg block on a 30 deg incline, F = 5 N - 4 N s/m v along it, against the 9.81 N
    of its weight along the incline: it slides back, v(t) = -1.2025 (1 - exp(-2 t)) m/s."""
    text = """
name: block on an incline
ground: {P: [0, 0]}
links:
  block: {points: {C: [0, 0]}, mass: 2 kg, com: C}
joints:
  cyl: {slider: [ground, block], point: C, line: {through: [0, 0], angle: 30}}
driver: {joint: cyl, start: 0 m}
sweep: {range: 1 m, step: 0.1 m}
gravity: 9.81 m/s^2
motor: {stall: 5 N, slope: 4 N s/m}
simulate: {duration: 3 s, step: 0.002 s, method: rk4, from: rest}
"""
    summary = " ".join(simulate(ms.loads(text)).summary().split())
    v_end = (5 - 9.81) / 4 * (1 - math.exp(-2 * 3))
    fastest = number(r"fastest \|v\| = ([\d.]+) m/s at t = 3 s", summary)
    assert fastest == pytest.approx(-v_end, rel=1e-6)
    assert "against the driver's direction (backwards)" in summary
    assert "motor F = 5 N - 4 N*s/m * v" in summary and "reduced mass from 2 to 2 kg" in summary


def test_a_machine_that_never_moves_is_stalled_at_its_start():
    """A balanced disc (centre on the pivot) and a motor with no torque at standstill:
    nothing moves it; it is at rest at its start from t = 0 (any angle balances: the
    start is given, not a point found by the balance's iterations)."""
    text = bar("{stall: 0 N m, slope: 1 N m s}", gravity="gravity: off", duration="1 s")
    text = text.replace("uniform_bar: [O, A]", "com: O, inertia: 1 kg m^2")
    summary = " ".join(simulate(ms.loads(text)).summary().split())
    assert "stalled at driver angle 0° (the start) after t = 0 s" in summary, summary
    assert "fastest |omega| = 0 rad/s" in summary


def test_seed_004_with_a_negative_stall_torque_runs_backwards_as_the_mirrored_machine():
    """M = -50 - 1.25 omega on the counter-clockwise driver is the seed's own law on the
    same machine driven clockwise (a law is written along its driver's direction): the
    same motion, and the summary gives the same fastest speed, clockwise both times,
    'backwards' only for the first (was 'max omega = 0' at t = 0)."""
    back = SEED_004.replace("stall: 50 N m", "stall: -50 N m")
    mirrored = SEED_004.replace("start: 0 deg}", "start: 0 deg, direction: cw}")
    a, b = simulate(ms.loads(back)), simulate(ms.loads(mirrored))
    np.testing.assert_allclose(a.trajectory.omega, b.trajectory.omega, rtol=0, atol=1e-9)
    sa, sb = (" ".join(r.summary().split()) for r in (a, b))
    fast = r"fastest \|omega\| = ([\d.]+) rad/s at t = ([\d.]+) s"
    assert re.search(fast, sa).groups() == re.search(fast, sb).groups()
    w = number(fast, sa)
    assert w == pytest.approx(float(np.max(np.abs(a.trajectory.omega))), rel=1e-6) and w > 30
    assert "clockwise: backwards, against the driver's direction" in sa
    assert "clockwise (the driver's direction)" in sb and "backwards" not in sb.split("fastest")[1]
