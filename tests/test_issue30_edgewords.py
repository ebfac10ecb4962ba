"""The summary names the located edge of a range that cannot close, for every method.

A triple rocker (crank 0.6 m, coupler 0.5 m, rocker 0.6 m, ground 1 m) cannot close
where |A O4| > 0.5 + 0.6 m: by the law of cosines |A O4|^2 = 0.36 + 1 - 1.2 cos(theta),
so the edges are at cos(theta) = 0.125 (82.8192 deg and 277.181 deg). The driving torque
and the reactions grow without bound towards both. With `method: newton` the summary
named the edge past the last solved sample by extrapolating two samples (84.7051 deg,
inside the range that cannot close) while the same summary's unassemblable line gave
the located edge.
"""

from __future__ import annotations

import math
import re

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

DZ = """
name: triple rocker dead zone
units: {length: m, angle: deg}
ground: {O2: [0, 0], O4: [1, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.6, 0]}, mass: 1 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [0.5, 0]}, mass: 1 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [0.6, 0]}, mass: 1 kg, uniform_bar: [O4, B]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: ["B.y >= 0"]
driver: {joint: O2, speed: 1 rad/s, start: 10 deg}
sweep: {range: 360 deg, step: 5 deg}
gravity: off
"""


@pytest.mark.parametrize("method", ["auto", "newton", "split-newton"])
def test_the_torque_grows_towards_the_located_edges(tmp_path, method):
    """As `mechsolve run` prints it (its figures from the finer 1 deg sweep)."""
    edge = math.degrees(math.acos(0.125))  # the law of cosines
    f = tmp_path / "dz.yaml"
    f.write_text(DZ + f"solver: {{method: {method}}}\n", encoding="utf-8")
    r = CliRunner().invoke(main, ["run", str(f), "--no-plots", "-o", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    text = r.output
    line = next(s for s in text.splitlines() if s.strip().startswith("driving torque"))
    grows = r"grows without bound towards .*?driver angle ([0-9.]+)°"
    said = [float(x) for x in re.findall(grows, line)]
    assert len(said) == 2, line
    assert abs(said[0] - edge) < 1e-3 and abs(said[1] - (360 - edge)) < 1e-3, line
    assert "about" not in line, line
