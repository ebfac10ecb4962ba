"""No "-0" cell in a CSV: a crank at 0 deg solved by Newton came out as -0.0, which the
table wrote as "-0" (the same number, but a reader or a diff sees a sign)."""

from __future__ import annotations

import csv

import numpy as np

from mechsolve.results.csv import format_values


def test_format_values_writes_zero_without_a_sign():
    assert format_values(np.array([-0.0, 0.0, -1e-300, np.nan])) == ["0", "0", "-1e-300", ""]


def test_an_instant_at_zero_writes_no_negative_zero(tmp_path):
    """The six-bar solved by Newton at 0 deg: its crank angle is -0.0."""
    from pathlib import Path

    from click.testing import CliRunner

    from mechsolve.cli.main import main

    text = (Path(__file__).parents[1] / "mechanisms" / "sixbar.yaml").read_text()
    f = tmp_path / "six.yaml"
    f.write_text(text + "\nsolver: {method: newton}\n")
    r = CliRunner().invoke(
        main, ["run", str(f), "--at", "theta=0 deg", "-o", str(tmp_path / "o"), "--no-plots", "-q"]
    )
    assert r.exit_code == 0, r.output
    rows = list(csv.reader(open(tmp_path / "o" / "instants.csv")))
    col = rows[0].index("crank.angle [deg]")
    assert rows[1][col] == "0"
    assert "-0" not in [c for row in rows for c in row]
