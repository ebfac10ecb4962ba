"""A simulated free motion has no driving effort: nothing acts at the driver's joint, so
its torque is zero by definition. The inverse dynamics of the integrated motion gave only
its integration error there (2e-9 N m printed as a 'driving torque' of the N-four-bar)."""

from __future__ import annotations

import csv
from pathlib import Path

from click.testing import CliRunner

from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]


def test_free_motion_prints_no_driving_torque_and_writes_zero(tmp_path):
    out = tmp_path / "o"
    r = CliRunner().invoke(
        main, ["simulate", str(ROOT / "mechanisms" / "nfourbar-2.yaml"), "-o", str(out),
               "--no-plots"]
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    assert "  driving torque: none (free motion)" in r.output
    assert "work of the driver over the sweep: 0 J" in r.output
    with open(out / "simulation.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    col = next(k for k in rows[0] if k.startswith("input.torque"))
    values = [float(row[col]) for row in rows if row[col] != ""]
    assert len(values) == len(rows) and all(v == 0.0 for v in values)
