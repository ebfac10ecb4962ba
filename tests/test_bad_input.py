"""Bad input: one clear message naming the file, key and line; non-zero exit; no traceback."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

GOOD = """\
name: four-bar
ground:
  O2: [0, 0]
  O4: [3, 0]
links:
  crank:
    points: {O2: [0, 0], A: [1, 0]}
  coupler:
    points: {A: [0, 0], B: [3.5, 0]}
  rocker:
    points: {O4: [0, 0], B: [2.5, 0]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
driver: {joint: O2, speed: 1 rad/s}
"""


def run(tmp_path, text, command="run"):
    f = tmp_path / "bad.yaml"
    f.write_text(text)
    args = [command, str(f)] + (
        ["-o", str(tmp_path / "out"), "--no-plots"] if command == "run" else []
    )
    r = CliRunner().invoke(main, args)
    assert r.exception is None or isinstance(r.exception, SystemExit), r.exception
    assert "Traceback" not in r.output
    return r


def test_good_file_runs(tmp_path):
    assert run(tmp_path, GOOD).exit_code == 0


CASES = [
    # (replace, with, exit code, expected fragments)
    (
        "links:\n  crank:\n    points: {O2: [0, 0], A: [1, 0]}",
        "links:\n  crank:\n    points: {O2: [0, 0], A: [1, 0]",
        2,
        ["bad.yaml:", "invalid YAML"],
    ),
    (
        "  rocker:\n    points:",
        "  rocker:\n    lenght: 3\n    points:",
        2,
        ["bad.yaml:11:", "links.rocker.lenght", "unknown key 'lenght'"],
    ),
    (
        "  B: [coupler, rocker]",
        "  B: [coupler, rockr]",
        2,
        ["bad.yaml:15:", "joints.B", "'rockr', which does not exist", "did you mean 'rocker'"],
    ),
    (
        "    points: {O4: [0, 0], B: [2.5, 0]}",
        "    points: {O4: [0, 0], Q: [2.5, 0]}",
        2,
        ["bad.yaml:15:", "joints.B", "link 'rocker' has no point 'B'"],
    ),
    (
        "  A: [crank, coupler]",
        "  A: [crank, crank]",
        2,
        ["bad.yaml:14:", "joints.A", "joins the link 'crank' to itself"],
    ),
    (
        "B: [3.5, 0]}",
        "B: [9.5, 0]}",
        2,  # a mechanism that cannot be assembled is bad input (one exit-code rule)
        ["bad.yaml", "cannot assemble at driver angle 0°", "loop B", "cannot close"],
    ),
    (
        "driver: {joint: O2, speed: 1 rad/s}",
        "driver: {joint: O2, speed: 1 mm}",
        2,
        ["bad.yaml:17:", "driver.speed", "is a length, but an angular speed is expected"],
    ),
    (
        "driver: {joint: O2, speed: 1 rad/s}",
        "driver: {joint: O9, speed: 1 rad/s}",
        2,
        ["bad.yaml:17:", "driver.joint", "'O9', which does not exist"],
    ),
    (
        "joints:\n",
        "  extra:\n    points: {B: [0, 0], X: [1, 0]}\n"
        "joints:\n  B2: {revolute: [rocker, extra], point: B}\n",
        2,
        ["bad.yaml", "2 degrees of freedom", "the motion of 'extra' is not determined"],
    ),
    ("driver: {joint: O2, speed: 1 rad/s}\n", "", 2, ["bad.yaml", "no driver"]),
]


@pytest.mark.parametrize("old,new,code,fragments", CASES)
def test_bad_file(tmp_path, old, new, code, fragments):
    assert old in GOOD
    r = run(tmp_path, GOOD.replace(old, new))
    assert r.exit_code == code, r.output
    out = r.output
    assert out.count("error:") == 1, out
    for frag in fragments:
        assert frag in out, (frag, out)


def test_missing_file(tmp_path):
    r = CliRunner().invoke(main, ["check", str(tmp_path / "nope.yaml")])
    assert r.exit_code == 2 and "no such file" in r.output


def test_failed_run_leaves_no_csv(tmp_path):
    run(tmp_path, GOOD.replace("B: [3.5, 0]}", "B: [9.5, 0]}"))
    assert not (tmp_path / "out" / "results.csv").exists()
