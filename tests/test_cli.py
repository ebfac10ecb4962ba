"""The command line: run and check on every example, through click and as a process."""

from __future__ import annotations

import csv
import subprocess
import sys

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

from conftest import MECH, MECHANISMS

EXAMPLES = MECHANISMS


def test_a_cam_file_given_to_run_says_what_it_is(tmp_path):
    r = CliRunner().invoke(main, ["run", str(MECH / "shaper-cam.yaml"), "-o", str(tmp_path)])
    assert r.exit_code == 2 and "it is a cam design (mechsolve cam FILE)" in r.output, r.output


@pytest.mark.parametrize("name", EXAMPLES)
def test_check_every_example(name):
    r = CliRunner().invoke(main, ["check", str(MECH / name)])
    assert r.exit_code == 0, r.output
    if name == "shaper-scheme3.yaml":  # a redundant link (seed 001): F = 3*6 - 2*9 + 1
        assert "degrees of freedom: 0 by Grübler" in r.output
        assert "redundant constraints: 1 of the 19 equations" in r.output
    elif name == "parallelogram-redundant-crank.yaml":  # a third crank: 3*4 - 2*6
        assert "degrees of freedom: 0 by Grübler" in r.output
        assert "redundant constraints: 1 of the 13 equations" in r.output
    else:
        assert "degrees of freedom: 1 by Grübler" in r.output
    assert "1 by the rank of the constraint Jacobian" in r.output
    assert "start position" in r.output


@pytest.mark.parametrize("name", EXAMPLES)
def test_run_every_example(name, tmp_path):
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["run", str(MECH / name), "-o", str(out), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert "positions solved" in r.output
    rows = list(csv.reader((out / "results.csv").open()))
    header = rows[0]
    # results in the file's units (an angle in rad where the file says so)
    ang = "rad" if "angle: rad" in (MECH / name).read_text() else "deg"
    assert header[:4] == ["step", "t [s]", f"input.angle [{ang}]", f"input.travel [{ang}]"]
    # every quantity column names its unit (a reaction that redundant constraints leave
    # indeterminate says so after it)
    for h in header[1:-2]:
        assert h.removesuffix(" (minimum-norm)").endswith("]") and " [" in h, h
    assert header[-2:] == ["status", "solver.method"]
    assert all(row[-2] == "ok" for row in rows[1:])
    assert len({len(row) for row in rows}) == 1


def test_run_writes_plots_and_default_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(main, ["run", str(MECH / "fourbar.yaml"), "--step", "10 deg"])
    assert r.exit_code == 0, r.output
    folder = tmp_path / "fourbar"
    names = {p.name for p in folder.iterdir()}
    assert {"results.csv", "trajectories.png", "point_P.png", "links.png"} <= names
    assert not any(n.endswith(".part") for n in names)
    rows = list(csv.reader((folder / "results.csv").open()))
    assert len(rows) == 1 + 37  # 0..360 deg in 10 deg steps


def test_run_variant_and_time_step(tmp_path):
    out = tmp_path / "jib"
    r = CliRunner().invoke(
        main,
        ["run", str(MECH / "crane.yaml"), "--variant", "jib-driven", "-o", str(out), "--no-plots"],
    )
    assert r.exit_code == 0, r.output
    rows = list(csv.reader((out / "results.csv").open()))
    assert len(rows) == 1 + 42  # 93..134 deg
    r = CliRunner().invoke(
        main, ["run", str(MECH / "shaper.yaml"), "--step", "0.05 s", "-o", str(out), "--no-plots"]
    )
    assert r.exit_code == 0, r.output
    rows = list(csv.reader((out / "results.csv").open()))
    assert len(rows) == 1 + 21  # one turn at 60 rpm in 0.05 s steps


def test_check_draws_the_start(tmp_path):
    png = tmp_path / "start.png"
    r = CliRunner().invoke(main, ["check", str(MECH / "shaper.yaml"), "--draw", str(png)])
    assert r.exit_code == 0, r.output
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_real_process(tmp_path):
    out = tmp_path / "crane"
    p = subprocess.run(
        [sys.executable, "-m", "mechsolve", "run", str(MECH / "crane.yaml"), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 0, p.stderr
    assert "37 of 37 positions solved" in p.stdout
    assert (out / "point_K.png").exists()
    p = subprocess.run(
        [sys.executable, "-m", "mechsolve", "--help"], capture_output=True, text=True, timeout=60
    )
    assert p.returncode == 0 and "Exit codes" in p.stdout


def test_csv_gets_the_usual_file_mode(tmp_path):
    """The CSV is written to a private temporary file and moved into place; it must
    end with the mode any new file gets (umask), like the plots."""
    import os

    old = os.umask(0o022)
    try:
        r = CliRunner().invoke(
            main, ["run", str(MECH / "fourbar.yaml"), "--no-plots", "-o", str(tmp_path)]
        )
    finally:
        os.umask(old)
    assert r.exit_code == 0, r.output
    assert (tmp_path / "results.csv").stat().st_mode & 0o777 == 0o644


def test_sigterm_leaves_no_partial_file(tmp_path):
    """A long streamed run stopped by SIGTERM exits 130 and removes its partial CSV."""
    import signal
    import time

    out = tmp_path / "out"
    p = subprocess.Popen(
        [sys.executable, "-m", "mechsolve", "run", str(MECH / "fourbar.yaml")]
        + ["--step", "0.0002 deg", "--no-plots", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while not list(out.glob(".results.csv.*.part")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert list(out.glob(".results.csv.*.part")), "the streamed CSV was never started"
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert list(out.iterdir()) == []


def test_time_ratio_only_for_rockers_and_rams(tmp_path):
    """The shaper's block slides in the slotted bar (a moving guide): it has limit
    positions but no quick-return time ratio; the rocker and the ram have one."""
    r = CliRunner().invoke(
        main, ["run", str(MECH / "shaper.yaml"), "--no-plots", "-o", str(tmp_path)]
    )
    assert r.exit_code == 0, r.output
    line = next(x for x in r.output.splitlines() if x.strip().startswith("time ratio:"))
    assert "slot" not in line, line
    assert "guide_bar K = 1.46" in line and "ram_guide K = 1.46" in line
    limits = next(x for x in r.output.splitlines() if "limit positions:" in x)
    assert "slider slot" in limits  # its stroke along the slot is still reported
