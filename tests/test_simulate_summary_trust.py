"""The figures ``mechsolve simulate`` prints about a motion, checked against
conservation laws and closed forms: the driver's work, its mean effort, the state
written at an event at a singular position."""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from scipy.integrate import simpson

from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
MECH = ROOT / "mechanisms"


def _simulate(tmp_path: Path, text: str, name: str) -> tuple[str, list[dict]]:
    f = tmp_path / f"{name}.yaml"
    f.write_text(text)
    out = tmp_path / name
    res = CliRunner().invoke(main, ["simulate", str(f), "-o", str(out), "--no-plots"])
    assert res.exit_code == 0, res.output
    with open(out / "simulation.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return res.output, rows


def _work(output: str) -> float:
    return float(re.search(r"work of the driver [a-z ]+: ([-\d.e+]+) J", output).group(1))


def test_work_of_the_motor_does_not_depend_on_the_output_step(tmp_path):
    """The motor-driven linkage started from rest (a damper on the slider): the
    driver's work equals the integral of the motor's power over time (Simpson on the
    finer run's rows of M(omega) omega), at either output step. The work's quadrature
    took the speed as constant between rows: 225.96 J at 0.01 s, 220.72 J at 0.002 s."""
    base = (MECH / "motor-linkage.yaml").read_text()
    line = "simulate: {duration: 2.2 s, step: 0.002 s, method: rk4, from: rest}"
    assert line in base

    def run(step: str, name: str):
        return _simulate(
            tmp_path,
            base.replace(
                line,
                f"simulate: {{duration: 2.2 s, step: {step}, method: DOP853, rtol: 1e-10, "
                "atol: 1e-12, from: rest}",
            ),
            name,
        )

    works = [_work(run(step, f"ml{k}")[0]) for k, step in enumerate(("0.01 s", "0.002 s"))]
    # the reference: Simpson's rule on a run with rows every 0.5 ms (at 2 ms the rule
    # itself is 0.1 J off: the power has harmonics of the crank's 35 rad/s)
    _, rows = run("0.0005 s", "fine")
    t = np.array([float(r["t [s]"]) for r in rows])
    power = np.array([float(r["motor.power [W]"]) for r in rows])
    exact = simpson(power, x=t)
    for w in works:
        assert abs(w - exact) <= 1e-5 * abs(exact), (works, exact)


def test_free_motion_has_no_driver_work(tmp_path):
    """Nothing drives the N-four-bar (free motion): the driver's work is zero, not the
    integrator's energy drift (2e-5 J), and it has no driving torque."""
    output, _ = _simulate(tmp_path, (MECH / "nfourbar-1.yaml").read_text(), "nf1")
    assert _work(output) == 0.0
    # nothing acts at the driver's joint: no driving torque figures (they were the
    # integration error, 1e-9 N m)
    assert "  driving torque: none (free motion)" in output


def test_state_at_a_singular_stop_is_the_motion(tmp_path):
    """``singular: stop`` on the N-four-bar (N = 1) ends the run at the horizontal
    position. It moves as one pendulum: there T = T0 + V0 (V = 0) and both cranks turn
    at omega = sqrt(T / (5/6)), the coupler not at all. The rates projected onto the
    constraints there were thrown off by a singular value of 1e-9 (T = 3.2 J)."""
    text = (
        (MECH / "nfourbar-1.yaml")
        .read_text()
        .replace("from: 1 rad/s}", "from: 1 rad/s, singular: stop}")
    )
    output, rows = _simulate(tmp_path, text, "nfs")
    assert "singular position" in output
    last = rows[-1]
    energy = 0.5 * (1 / 3 + 1 + 1 / 3) * 1.0 + 2 * 9.81 * 1.0  # T0 + V0 at the start, 1 rad/s
    assert math.isclose(float(last["energy.kinetic [J]"]), energy, rel_tol=1e-7)
    omega = -math.degrees(math.sqrt(energy / (5 / 6)))
    # (the singular direction is left as the bridge across the passage integrated it)
    assert math.isclose(float(last["crank0.omega [deg/s]"]), omega, rel_tol=1e-4)
    assert math.isclose(float(last["crank1.omega [deg/s]"]), omega, rel_tol=1e-4)
    assert abs(float(last["coupler1.omega [deg/s]"])) < 0.01
    # the equations lose rank there: accelerations and forces are not determined (a
    # solve gave 1e13 N), so they are blank and the row says why; the peaks are finite
    assert last["crank0.alpha [deg/s^2]"] == "" and last["A0(ground->crank0).F [N]"] == ""
    assert last["status"].startswith("singular")
    peak = re.search(r"peak reactions \([^)]*\): A0 ([-\d.e+]+) N", output)
    assert peak and float(peak.group(1)) < 100
