"""Issue 23, `mechsolve report` (and `animate`): an impossible --frames is refused before
any work; a default polygon position the mechanism cannot reach does not cost the report;
the PDF is A4 (or Letter) with every table complete; one value per figure."""

from __future__ import annotations

import math
import re
import time

import pytest
from click.testing import CliRunner
from test_report import Page

import mechsolve.api
from mechsolve.commands.animate import animate
from mechsolve.commands.report import report

from conftest import MECH

# A four-bar whose input link cannot turn fully: |A O4| exceeds coupler + rocker
# (60 + 59 mm) past 117.2 deg of the input (hand calculation below). Started at 95 deg
# and swept over 20 deg, it never leaves the range where it closes, but the report's
# default polygon position (position 2 of 12 per turn, 30 deg after the start) is outside.
DOUBLE_ROCKER = """\
name: double rocker
units: {length: mm, angle: deg}
ground:
  O2: [0, 0]
  O4: [87.5, 0]
links:
  crank:
    points: {O2: [0, 0], A: [50, 0]}
  coupler:
    points: {A: [0, 0], B: [60, 0]}
  rocker:
    points: {O4: [0, 0], B: [59, 0]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, speed: 1 rad/s, start: 95 deg}
sweep: {range: 20 deg, step: 2 deg}
"""


def _no_solving(monkeypatch) -> list[str]:
    """Make loading a mechanism fail the test: the options must be refused before."""
    called: list[str] = []

    def refuse(*args, **kwargs):
        called.append("load")
        raise AssertionError("the file was loaded before the options were checked")

    monkeypatch.setattr(mechsolve.api, "load", refuse)
    return called


@pytest.mark.parametrize("frames", ["10000000", "20001"])
def test_report_refuses_too_many_frames_before_any_work(frames, tmp_path, monkeypatch):
    """`report --frames 1e7` was refused only after the whole report was solved (8 to
    14 s); it is refused first, with animate's bound and message."""
    called = _no_solving(monkeypatch)
    out = tmp_path / "r.html"
    t0 = time.perf_counter()
    r = CliRunner().invoke(report, [str(MECH / "crane.yaml"), "-o", str(out), "--frames", frames])
    took = time.perf_counter() - t0
    a = CliRunner().invoke(
        animate, [str(MECH / "crane.yaml"), "-o", str(tmp_path / "a.gif"), "--frames", frames]
    )
    assert called == []
    assert r.exit_code == a.exit_code == 2, (r.output, a.output)
    assert r.output == a.output == f"error: --frames {frames}: at most 20000 frames\n"
    assert took < 2.0
    assert not out.exists()


def test_write_report_refuses_too_many_frames_before_any_work(tmp_path, monkeypatch):
    from mechsolve.errors import InputError
    from mechsolve.report import write_report

    _no_solving(monkeypatch)
    with pytest.raises(InputError, match="at most 20000 frames"):
        write_report(MECH / "crane.yaml", out=tmp_path / "r.html", frames=10**7)


def _section(html: str, ident: str) -> str:
    m = re.search(rf'<section id="{ident}">(.*?)</section>', html, re.S)
    assert m, f"no section {ident}"
    return m.group(1)


def test_default_polygon_position_that_cannot_close(tmp_path):
    """The report was not written at all (exit 3) when position 2, the polygons' default,
    lies where the mechanism cannot close: it is written, the polygons section says which
    position and which loop, and the exit status is that of the rest (0)."""
    # hand calculation: at 125 deg of the input, A is farther from O4 than the coupler
    # and the rocker can reach together
    a = (50 * math.cos(math.radians(125)), 50 * math.sin(math.radians(125)))
    assert math.hypot(a[0] - 87.5, a[1]) > 60 + 59
    src = tmp_path / "rocker.yaml"
    src.write_text(DOUBLE_ROCKER)
    out = tmp_path / "rocker.html"
    r = CliRunner().invoke(report, [str(src), "-o", str(out), "--frames", "6"])
    assert r.exit_code == 0, r.output
    html = out.read_text(encoding="utf-8")
    text = _section(html, "polygons")
    assert "position 2 of 12 per turn" in text and "driver angle 125°" in text
    assert "cannot close" in text and "loop B" in text
    assert "--polygons-at" in text  # what to do about it
    assert "no polygons" in r.output.lower()  # the terminal says it too
    # the rest of the report is all there
    page = Page(html)
    assert len(page.table("Positions of the points")["rows"]) == 11


def test_requested_polygon_position_that_cannot_close(tmp_path):
    """A position asked for with --polygons-at that cannot close: the report is still
    written, with the reason, and the command exits 1 (something asked for is missing)."""
    src = tmp_path / "rocker.yaml"
    src.write_text(DOUBLE_ROCKER)
    out = tmp_path / "rocker.html"
    r = CliRunner().invoke(
        report, [str(src), "-o", str(out), "--frames", "6", "--polygons-at", "130 deg"]
    )
    assert r.exit_code == 1, r.output
    text = _section(out.read_text(encoding="utf-8"), "polygons")
    assert "driver angle 130°" in text and "loop B" in text
    # a position it reaches is drawn
    r = CliRunner().invoke(
        report, [str(src), "-o", str(out), "--frames", "6", "--polygons-at", "100 deg"]
    )
    assert r.exit_code == 0, r.output
    text = _section(out.read_text(encoding="utf-8"), "polygons")
    assert "<img" in text and "cannot close" not in text
