"""A figure that is zero by statics prints 0, not its rounding: the flat-faced follower of
an eccentric cam on a guide along the contact normal puts no normal force on the guide
(the contact force, the load and the inertia are all along the guide), so its peak is
0 N; it printed 6.123e-15 N."""

from __future__ import annotations

import re

from click.testing import CliRunner

from mechsolve.cli.main import main

ECCENTRIC = """
name: eccentric cam, flat-faced translating follower
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  cam: {points: {O: [0, 0]}}
  fol: {points: {F: [0, 40], T: [0, 80]}, mass: 2 kg, com: F}
joints:
  O: [ground, cam]
  guide: {slider: [ground, fol], point: F, line: {through: [0, 0], angle: 90}}
  touch:
    cam_contact: [cam, fol]
    centre: O
    eccentric: {radius: 40 mm, eccentricity: 10 mm}
    face: {through: F, normal: 90 deg}
driver: {joint: O, speed: 10 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 30 deg}
gravity: off
loads:
  press: {force: [0, -100 N], at: F, on: fol}
"""


def test_a_reaction_zero_by_statics_prints_zero(tmp_path):
    f = tmp_path / "ecc.yaml"
    f.write_text(ECCENTRIC)
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    assert r.exit_code == 0, r.output
    line = next(ln for ln in r.output.splitlines() if "peak reactions" in ln)
    assert "guide 0 N (normal);" in line, line
    # the contact: the press plus m * e * omega^2 = 100 + 2 * 0.01 * 100 = 102 N, at the
    # follower's lowest point (its acceleration e * omega^2 upwards)
    m = re.search(r"touch ([\d.]+) N \(normal\) at driver angle ([\d.]+)°", line)
    assert m and abs(float(m.group(1)) - 102.0) < 0.05, line
    assert abs(float(m.group(2)) - 270.0) < 1e-6, line
