"""The summary's peak reactions say they are the largest samples, and name what a
slider's figure is (its normal force, not the resultant with friction)."""

from __future__ import annotations

import re
from pathlib import Path

from click.testing import CliRunner

from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]


def test_peak_reactions_are_labelled_samples_and_the_sliders_normal(tmp_path):
    r = CliRunner().invoke(
        main, ["run", str(ROOT / "mechanisms" / "slider-crank.yaml"), "--no-plots", "-o",
              str(tmp_path)]
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    line = next(ln for ln in r.output.splitlines() if "peak reactions" in ln)
    # the same spacing as the driving torque's line, which is sampled the same way
    torque = next(ln for ln in r.output.splitlines() if "driving torque (" in ln)
    spacing = re.search(r"driving torque \(([^)]*) samples\)", torque).group(1)
    assert line.startswith(f"  peak reactions ({spacing} samples): "), line
    assert re.search(r"cylinder [\d.]+ N \(normal\) at driver angle", line), line
    assert re.search(r"; A [\d.]+ N at driver angle", line), line  # a pin: its |F|
