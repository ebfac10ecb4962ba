"""A link drawn at 0 deg whose computed start is a rounding below zero (-1e-16 rad) starts
at 0 deg, not at 360 deg: the cam linkage's rocker swings from 0 to -15 deg and its link
from 0 to +1.09 deg (the file's drawing), so requirements on their angles pass."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from mechsolve.cli.main import main
from mechsolve.results.results import unwrap_angle

ROOT = Path(__file__).resolve().parents[1]


def test_a_start_rounded_below_zero_is_zero():
    th = np.array([-1.14e-16, -0.1, -0.2, -0.1])
    out = unwrap_angle(th)
    assert abs(out[0]) < 1e-15 and math.isclose(out[1], -0.1)
    # a genuine start below a whole turn keeps its place in [0, 2 pi)
    out = unwrap_angle(np.array([-0.01, 0.0]))
    assert math.isclose(out[0], 2 * math.pi - 0.01)


def test_requirements_on_angles_that_start_at_zero(tmp_path):
    text = (ROOT / "mechanisms" / "cam-linkage.yaml").read_text()
    text += (
        "requirements:\n"
        "  rocker stays below its start: max(rocker.angle) <= 0.5 deg\n"
        "  link: max(abs(link.angle)) <= 10 deg\n"
    )
    f = tmp_path / "cam.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert "FAIL" not in r.output
