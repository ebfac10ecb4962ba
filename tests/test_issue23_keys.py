"""Synthesis errors name the key of the problem file they concern (issue 23, 4): a
guide-bar stroke too short for its slot was reported at guide-bar.frame."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

GUIDE = """name: shaper guide bar
units: {{length: mm, angle: deg}}
guide-bar: {{frame: 380, crank: 110, {extra}}}
"""


@pytest.mark.parametrize(
    "extra, key",
    [
        # the slot must reach d + r = 490 mm: with theta = 2 asin(110/380) a stroke of
        # 2 * 490 * sin(theta/2) = 283.7 mm at least
        ("stroke: 250", "guide-bar.stroke"),
        ("bar: 400", "guide-bar.bar"),
        ("bar: 600, stroke: 300", "guide-bar.stroke"),
    ],
)
def test_guide_bar_errors_name_their_key(tmp_path, extra, key):
    f = tmp_path / "g.yaml"
    f.write_text(GUIDE.format(extra=extra))
    r = CliRunner().invoke(main, ["synth", str(f)])
    assert r.exit_code == 2, r.output
    assert f"{key}:" in r.output and "Traceback" not in r.output
    if extra == "stroke: 250":
        least = 2 * 490 * 110 / 380  # 2 (d + r) sin(theta / 2), sin(theta / 2) = r / d
        assert f"{least * 1e-3:g} m" in r.output


def test_a_stroke_that_fits_gives_the_bar(tmp_path):
    f = tmp_path / "g.yaml"
    f.write_text(GUIDE.format(extra="stroke: 312.63"))
    r = CliRunner().invoke(main, ["synth", str(f)])
    assert r.exit_code == 0, r.output
