"""Issue 30, what the studies left (``mechsolve sweep``):

1. ``study.samples`` and ``study.seed`` read a whole number written ``10.0`` as 10, as
   every other whole-number setting does and as the JSON Schema (an ``integer``) says;
   ``10.5`` is refused with the file, the key path and the line.
2. The command line reads numbers by the file's rule: full-width digits, ``1_000``,
   ``1:45`` and a decimal comma are refused naming the option and the value (exit 2).
3. The designs' results written by a pool's workers are in the output folder's record.
4. On a pool, the designs finished after a full disk stopped the study are named with
   their files: no result is lost.
"""

from __future__ import annotations

import csv
import errno
import json
import os
import re
import time
from pathlib import Path

import jsonschema
import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from mechsolve.analyses.study.designs import make_study
from mechsolve.base.errors import InputError
from mechsolve.cli.main import main
from mechsolve.model.source import load_text

STUDY = Path(__file__).parent / "data" / "study_fourbar.yaml"  # 3 x 2 designs
SCHEMA_FILE = (
    Path(__file__).resolve().parent.parent / "mechsolve/analyses/schema/mechanism.schema.json"
)


def _invoke(*args) -> object:
    return CliRunner().invoke(main, [str(a) for a in args])


def _random_study(samples, seed) -> str:
    """The study four-bar as a random study of two uniform parameters."""
    data = yaml.safe_load(STUDY.read_text("utf-8"))
    data["study"] = {
        "design": "random",
        "samples": samples,
        "seed": seed,
        "parameters": {
            "links.crank.points.A[0]": "uniform(20, 30 mm)",
            "ground.O4[0]": "uniform(80, 90 mm)",
        },
    }
    return yaml.safe_dump(data, sort_keys=False)


# --- item 1: samples and seed written 10.0 ----------------------------------------------


def test_samples_and_seed_written_with_a_point_are_whole_numbers():
    study = make_study(load_text(_random_study(10.0, 3.0), file="st.yaml"))
    assert len(study.designs) == 10
    # the designs are numpy's uniform draws of seed 3, scaled by hand to each range
    u = np.random.default_rng(3).random((10, 2))
    want = np.column_stack([20 + 10 * u[:, 0], 80 + 10 * u[:, 1]])
    got = np.array([[d[0], d[1]] for d in study.designs])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    "samples, seed, key, said",
    [
        (10.5, 3, "study.samples", "10.5"),
        (0.0, 3, "study.samples", "1 or more"),
        (10, 3.5, "study.seed", "3.5"),
        (10, -1.0, "study.seed", "0 or more"),
        (10, "3", "study.seed", "'3'"),
    ],
)
def test_a_fraction_is_refused_with_the_file_key_and_line(samples, seed, key, said):
    text = _random_study(samples, seed)
    line = next(i for i, s in enumerate(text.splitlines(), 1) if s.strip().startswith(key[6:]))
    with pytest.raises(InputError) as info:
        make_study(load_text(text, file="st.yaml"))
    msg = str(info.value)
    assert f"st.yaml:{line}" in msg and key in msg and said in msg, msg


def test_samples_of_a_grid_are_refused_where_they_are_written(tmp_path):
    text = STUDY.read_text("utf-8").replace("design: grid", "design: grid\n  samples: 10.0")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if "samples:" in s)
    with pytest.raises(InputError) as info:
        make_study(load_text(text, file="st.yaml"))
    msg = str(info.value)
    assert f"st.yaml:{line}: study.samples: a grid study takes every value" in msg, msg
    r = _invoke("sweep", STUDY, "--samples", "5", "-o", tmp_path / "o")
    assert r.exit_code == 2 and "--samples 5: a grid study" in r.output, r.output


def test_the_schema_says_what_the_parser_does():
    validator = jsonschema.Draft7Validator(json.loads(SCHEMA_FILE.read_text("utf-8")))

    def errors(samples, seed):
        return list(validator.iter_errors(yaml.safe_load(_random_study(samples, seed))))

    assert not errors(10.0, 3.0) and not errors(10, 0)
    for samples, seed in ((10.5, 3), (0, 3), (10, 3.5), (10, -1)):
        assert errors(samples, seed), (samples, seed)
        with pytest.raises(InputError):
            make_study(load_text(_random_study(samples, seed), file="st.yaml"))


def test_samples_and_seed_on_the_command_line_follow_the_same_rule(tmp_path):
    path = tmp_path / "st.yaml"
    path.write_text(_random_study(4, 0), "utf-8")
    r = _invoke("sweep", path, "--samples", "3.0", "--seed", "3.0", "-j", "1", "--no-plots",
                "-o", tmp_path / "out")  # fmt: skip
    assert r.exit_code == 0, r.output
    assert "3 designs" in r.output, r.output
    r = _invoke("sweep", path, "--samples", "3.5", "-o", tmp_path / "out")
    assert r.exit_code == 2 and "--samples" in r.output and "3.5" in r.output, r.output
    assert "Traceback" not in r.output


# --- item 2: the command line reads numbers as the file does -----------------------------

A0 = "links.crank.points.A[0]"


@pytest.mark.parametrize(
    "values, said",
    [
        ("２０, 25 mm", "write '20'"),  # full-width digits
        ("20, ２５ mm", "write '25 mm'"),
        ("1_000, 25", "grouped with '_' are not read; write '1000'"),
        ("1:45, 25", "'a:b' values"),
        ("22,5 mm", "a decimal comma is not read; write '22.5 mm', or '22, 5 mm' for a list"),
        ("２０..30 mm:3", "write '20'"),
        ("20..3_0 mm:3", "grouped with '_'"),
        ("20..30 mm:３", "write '3'"),
        ("20..30 mm:1_0", "grouped with '_'"),
        ("20..30 mm:2.5", "not a whole number"),
        ("uniform(２０, 30 mm)", "write '20'"),
        ("nan, 25", "cannot read 'nan'"),
    ],
)
def test_a_parameter_on_the_command_line_is_read_as_the_file_reads_numbers(tmp_path, values, said):
    opt = f"{A0}={values}"
    r = _invoke("sweep", STUDY, "-p", opt, "-j", "1", "--no-plots", "-o", tmp_path / "o")
    assert r.exit_code == 2, r.output
    assert f"-p {opt!r}" in r.output and said in r.output, r.output
    assert "Traceback" not in r.output and not (tmp_path / "o" / "study.csv").exists()


def test_a_parameter_in_the_file_follows_the_same_rule():
    text = STUDY.read_text("utf-8").replace("20..30 mm:3", "２０..30 mm:3")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if "２０" in s)
    with pytest.raises(InputError) as info:
        make_study(load_text(text, file="st.yaml"))
    msg = str(info.value)
    assert f"st.yaml:{line}" in msg and f"study.parameters.{A0}" in msg and "'20" in msg, msg


def test_what_the_file_reads_the_command_line_reads_the_same():
    # a count written 3.0 is 3, as a whole number of the file; spaces of any kind around
    study = make_study(
        load_text(STUDY.read_text("utf-8"), file="st.yaml"),
        [f"{A0}=20..30 mm:3.0", "ground.O4[0]=\u300080 mm, 87.5 mm, 0.0875 m"],
    )
    got = {p.name: p.values for p in study.params}
    assert got[A0] == [20.0, 25.0, 30.0]
    assert got["ground.O4[0]"] == pytest.approx([80.0, 87.5, 87.5], rel=1e-12)


@pytest.mark.parametrize(
    "args, option, value",
    [
        (["sweep", STUDY, "--samples", "２０"], "--samples", "２０"),
        (["sweep", STUDY, "--seed", "1_0"], "--seed", "1_0"),
        (["sweep", STUDY, "-j", "1:2"], "-j", "1:2"),
        (["sweep", STUDY, "--max-designs", "1,000"], "--max-designs", "1,000"),
        (["polygons", STUDY, "--scale-v", "0,5"], "--scale-v", "0,5"),
        (["polygons", STUDY, "--scale-v", "nan"], "--scale-v", "nan"),
        (["polygons", STUDY, "--per-turn", "１２"], "--per-turn", "１２"),
        (["animate", STUDY, "--fps", "2_5"], "--fps", "2_5"),
        (["simulate", STUDY, "--max-steps", "1e2.5"], "--max-steps", "1e2.5"),
        (["flywheel", STUDY, "--delta", "１/40"], "--delta", "１/40"),
        (["flywheel", STUDY, "--delta", "1/4_0"], "--delta", "1/4_0"),
        (["compare", STUDY, STUDY, "--delta", "0,025"], "--delta", "0,025"),
        (["animate", STUDY, "--size", "８００x600"], "--size", "８００x600"),
        (["polygons", STUDY, "--at", "２"], "--at", "２"),
        (["draw", STUDY, "--at", "1_0 deg"], "--at", "1_0 deg"),
    ],
)
def test_every_number_option_follows_the_rule(tmp_path, args, option, value):
    out = tmp_path / ("o.dxf" if args[0] == "draw" else "o")
    r = CliRunner().invoke(main, [str(a) for a in args] + ["-o", str(out)])
    assert r.exit_code == 2, r.output
    assert option in r.output and repr(value) in r.output, r.output
    assert "Traceback" not in r.output


def test_a_whole_number_option_written_with_a_point_is_whole(tmp_path):
    out = tmp_path / "o"
    r = _invoke("sweep", STUDY, "-j", "1.0", "--no-plots", "-o", out)
    assert r.exit_code == 0, r.output
    assert "6 designs" in r.output and "this process" in r.output, r.output


# --- item 3: the designs a pool's workers write are in the folder's record ---------------


def _recorded(out: Path) -> set[str]:
    data = json.loads((out / ".mechsolve-outputs.json").read_text("utf-8"))
    return set(data["commands"]["sweep"]["files"])


def _earlier(output: str) -> set[str]:
    m = re.search(r"from an earlier sweep, not from this one[^:]*: (.*)", output)
    return set(m.group(1).split(", ")) if m else set()


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_pools_design_results_are_recorded_and_named_next_time(tmp_path, jobs):
    out = tmp_path / "st"
    r = _invoke("sweep", STUDY, "-o", out, "-j", jobs, "--no-plots", "--keep-results")
    assert r.exit_code == 0, r.output
    if jobs == "2":
        assert "a pool of 2 processes" in r.output, r.output
    six = {f"designs/design-{k:05d}.csv" for k in range(6)}  # the study's 3 x 2 designs
    assert {f"designs/{p.name}" for p in (out / "designs").iterdir()} == six
    assert six <= _recorded(out), _recorded(out)
    # a study of 3 designs into the same folder: the other three are an earlier run's
    r = _invoke("sweep", STUDY, "-o", out, "-j", jobs, "--no-plots", "--keep-results",
                "-p", "ground.O4[0]=87.5 mm")  # fmt: skip
    assert r.exit_code == 0, r.output
    assert "3 designs" in r.output, r.output
    assert _earlier(r.output) == {f"designs/design-{k:05d}.csv" for k in (3, 4, 5)}, r.output


# --- item 4: designs finished after a full disk stopped a pool ----------------------------


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _stop_with_one_design_written_late(monkeypatch, marker: Path, stop: str) -> None:
    """On a pool of 2 with chunks of 2 designs (20 designs; chunk [0, 1] is timed in the
    main process): the worker on chunk [4, 5] writes design 4, then its flush of design 5
    says so (``marker``) and never ends; the worker on chunk [2, 3] then finds the disk
    full at design 2 (``stop`` "full disk"), or presses Ctrl-C there ("ctrl-c": SIGINT to
    the main process). Design 4's file is whole, its row never reaches the main process."""
    import signal

    real = os.fsync

    def fsync(fd):
        try:
            name = os.path.basename(os.readlink(f"/proc/self/fd/{fd}"))
        except OSError:
            name = ""
        if "design-00005" in name:
            marker.touch()
            time.sleep(120)  # ended by the pool's terminate long before
        if "design-00002" in name:
            t0 = time.monotonic()
            while not marker.exists() and time.monotonic() - t0 < 60:
                time.sleep(0.02)
            if stop == "full disk":
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            os.kill(os.getppid(), signal.SIGINT)
            time.sleep(120)  # ended by the pool's terminate
        return real(fd)

    monkeypatch.setattr(os, "fsync", fsync)


@pytest.mark.parametrize("stop, code", [("full disk", 2), ("ctrl-c", 130)])
def test_designs_finished_after_a_stop_on_a_pool_are_named_with_their_files(
    tmp_path, monkeypatch, stop, code
):
    """The designs a worker finished after a full disk or Ctrl-C stopped the study, whose
    rows were lost with the worker, are named with their files (whole, each a row per
    position), and the folder's record lists every design's file of the run."""
    if not os.path.isdir("/proc/self/fd"):
        pytest.skip("the injected full disk reads /proc/self/fd")
    _stop_with_one_design_written_late(monkeypatch, tmp_path / "marker", stop)
    out = tmp_path / "st"
    r = _invoke("sweep", STUDY, "-o", out, "-j", "2", "--no-plots", "--keep-results",
                "-p", "links.crank.points.A[0]=20..30 mm:5",
                "-p", "ground.O4[0]=80, 85, 87.5, 90 mm")  # fmt: skip
    assert r.exit_code == code, r.output
    assert "Traceback" not in r.output
    if stop == "full disk":
        err = [x for x in r.output.splitlines() if "error" in x]
        assert err == [f"error: cannot write {out / 'designs' / 'design-00002.csv'}: "
                       f"{os.strerror(errno.ENOSPC)}"], r.output  # fmt: skip
    rows = {int(row["design [-]"]) for row in _rows(out / "study.csv")}
    files = {int(p.name[7:12]) for p in (out / "designs").iterdir() if p.suffix == ".csv"}
    assert 4 in files and 4 not in rows  # written, its row lost with its worker
    late = sorted(files - rows)
    m = re.search(r"(\d+) design\(s\) finished after the stop have no row in [^:]*: (.*)",
                  r.output)  # fmt: skip
    assert m, r.output
    assert int(m.group(1)) == len(late)
    assert m.group(2).split(", ") == [f"designs/design-{k:05d}.csv" for k in late]
    for k in late:  # each whole: a row per position, 0 to 360 deg every 10 deg
        got = _rows(out / "designs" / f"design-{k:05d}.csv")
        assert [float(x["input.angle [deg]"]) for x in got] == [10.0 * i for i in range(37)]
    # and in the folder's record, as the files of this run
    assert {f"designs/design-{k:05d}.csv" for k in files} <= _recorded(out)


@pytest.mark.parametrize(
    "text, said",
    [
        ("1,5 rpm", "a decimal comma is not read; write '1.5 rpm'"),
        (
            "1,500 rpm",
            "(a decimal comma, or digits grouped by thousands?); write '1.500 rpm' or '1500 rpm'",
        ),  # fmt: skip
        ("1,000,000 rpm", "digits grouped with ',' are not read; write '1000000 rpm'"),
        ("12,345.6 rpm", "digits grouped with ',' are not read; write '12345.6 rpm'"),
        ("0,025 rpm", "a decimal comma is not read; write '0.025 rpm'"),
    ],
)
def test_a_comma_that_may_group_thousands_is_not_read_as_a_decimal_comma_only(text, said):
    """The number to write is suggested only where it is certain: ``1,500`` may be 1.5 or
    1500, so both are named (it was "write '1.500'")."""
    from mechsolve.base.units import UnitError, parse_quantity

    with pytest.raises(UnitError) as info:
        parse_quantity(text, "angular speed")
    assert said in str(info.value), str(info.value)
    r = _invoke("sweep", STUDY, "--max-designs", text.replace(" rpm", ""))
    assert r.exit_code == 2 and said.replace(" rpm", "") in r.output, r.output


@pytest.mark.parametrize(
    "values, designs",
    [
        ("20,25,30", [20.0, 25.0, 30.0]),
        ("20,25,30 mm", [20.0, 25.0, 30.0]),
        ("20, 25", [20.0, 25.0]),
    ],
)
def test_a_list_of_three_or_more_without_spaces_is_a_list(tmp_path, values, designs):
    """No number has two decimal commas: ``20,25,30`` is three values, as it always was."""
    out = tmp_path / "o"
    r = _invoke("sweep", STUDY, "-p", f"{A0}={values}", "-j", "1", "--no-plots", "-o", out)
    assert r.exit_code == 0, r.output
    with open(out / "study.csv", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    col = next(k for k in rows[0] if k.startswith(A0))
    assert sorted({float(x[col]) for x in rows}) == designs


@pytest.mark.parametrize(
    "values, grouped", [("1,000,000", "'1000000'"), ("20,250,300 mm", "'20250300 mm'")]
)
def test_digits_that_may_be_grouped_by_thousands_are_refused_with_both_readings(
    tmp_path, values, grouped
):
    opt = f"{A0}={values}"
    r = _invoke("sweep", STUDY, "-p", opt, "-j", "1", "--no-plots", "-o", tmp_path / "o")
    assert r.exit_code == 2, r.output
    assert "grouped by thousands" in r.output and grouped in r.output, r.output
    assert "for a list" in r.output and "Traceback" not in r.output
