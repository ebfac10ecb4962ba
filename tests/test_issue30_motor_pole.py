"""A motor law with a pole the motion passes between two integration steps.

``M = 50 - 1.25 omega + 1/(omega - 30)`` grows without bound at omega = 30 rad/s. The
machine of seed 004 (mechanisms/motor-linkage.yaml) started from rest passes 30 rad/s at
about t = 0.175 s; the law is finite at every step (the steps land on either side), so
`simulate` integrated straight through infinity and printed a motion with exit 0. The
motion is now kept up to the step before the pole and the law refused (exit 2, naming
the key), on the reduced path and on the general (multibody) one. A law whose pole the
motion does not reach (omega = -30 rad/s) runs to its end.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
POLE = 30.0  # rad/s, where 1/(omega - 30) is not finite


def _file(tmp_path: Path, law: str, formulation: str) -> Path:
    text = (ROOT / "mechanisms" / "motor-linkage.yaml").read_text()
    lines = []
    for ln in text.splitlines():
        if ln.startswith("motor:"):
            ln = f'motor: {{torque: "{law}"}}'
        elif ln.startswith("simulate:"):
            ln = (
                "simulate: {duration: 0.4 s, step: 0.002 s, method: rk4, from: rest, "
                f"formulation: {formulation}}}"
            )
        lines.append(ln)
    f = tmp_path / f"m-{formulation}.yaml"
    f.write_text("\n".join(lines) + "\n")
    return f


def _omega(csv_path: Path) -> tuple[list[float], list[float]]:
    with open(csv_path) as fh:
        rows = list(csv.reader(fh))
    head = rows[0]
    it = next(i for i, h in enumerate(head) if h.startswith("t "))
    iw = next(i for i, h in enumerate(head) if h.startswith("omega") or "driver.omega" in h)
    scale = {"[rad/s]": 1.0, "[deg/s]": math.pi / 180}[head[iw].split()[-1]]  # the file's unit
    return [float(r[it]) for r in rows[1:]], [float(r[iw]) * scale for r in rows[1:]]


@pytest.mark.parametrize("formulation", ["reduced", "multibody"])
def test_motion_through_a_pole_of_the_motor_law_is_refused(tmp_path, formulation):
    f = _file(tmp_path, "50 - 1.25 * omega + 1/(omega - 30)", formulation)
    out = CliRunner().invoke(main, ["simulate", "--no-plots", str(f), "-o", str(tmp_path / "o")])
    assert out.exit_code == 2, out.output
    assert "motor.torque:" in out.output and "grows without bound at omega = 30 rad/s" in out.output
    assert "Traceback" not in out.output
    t, w = _omega(tmp_path / "o" / "simulation.csv")
    # the motion is kept up to the last step before the pole, none past it (the speed
    # grows about 1.3 rad/s a step there)
    assert max(w) < POLE < max(w) + 2.0
    assert t[-1] < 0.4


@pytest.mark.parametrize("formulation", ["reduced", "multibody"])
def test_a_pole_the_motion_does_not_reach_is_kept(tmp_path, formulation):
    f = _file(tmp_path, "50 - 1.25 * omega + 1/(omega + 30)", formulation)
    out = CliRunner().invoke(main, ["simulate", "--no-plots", str(f), "-o", str(tmp_path / "o")])
    assert out.exit_code == 0, out.output
    t, _ = _omega(tmp_path / "o" / "simulation.csv")
    assert t[-1] == pytest.approx(0.4)
