"""Hostile input: every file in tests/bad_inputs gives one clear message and its exit code.

Each file starts with ``# expect: <exit code>: <fragment>; <fragment>...`` (the empty file
keeps its expectation in ``empty.expect``). No traceback, ever; and no case may take long
(a guard against catastrophic behaviour, such as an alias bomb expanding; the speed itself
is not what this tests).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

BAD = Path(__file__).resolve().parent / "bad_inputs"
FILES = sorted(BAD.glob("*.yaml"))


def expectation(path: Path) -> tuple[int, list[str]]:
    src = path.with_suffix(".expect") if path.with_suffix(".expect").exists() else path
    first = src.read_text().splitlines()[0]
    assert first.startswith("# expect: "), path
    code, frags = first[len("# expect: ") :].split(": ", 1)
    return int(code), [f.strip() for f in frags.split("; ")]


def run(args):
    t0 = time.perf_counter()
    r = CliRunner().invoke(main, args)
    elapsed = time.perf_counter() - t0
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)
    assert "Traceback" not in r.output
    return r, elapsed


def test_corpus_is_there():
    assert len(FILES) >= 40


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_bad_file(path, tmp_path):
    code, frags = expectation(path)
    for command in (["check", str(path)], ["run", str(path), "-o", str(tmp_path), "--no-plots"]):
        r, elapsed = run(command)
        assert r.exit_code == code, r.output
        assert r.output.count("error:") == 1, r.output
        for frag in frags:
            assert frag in r.output, (frag, r.output)
        assert elapsed < 5.0
    assert not (tmp_path / "results.csv").exists()


def test_file_of_several_megabytes(tmp_path):
    big = tmp_path / "big.yaml"
    big.write_text("name: x\n" + "# padding\n" * 400_000)
    r, elapsed = run(["check", str(big)])
    assert r.exit_code == 2 and "limited to" in r.output and elapsed < 5.0


def test_binary_file(tmp_path):
    f = tmp_path / "image.yaml"
    f.write_bytes(bytes(range(256)) * 64)
    r, _ = run(["check", str(f)])
    assert r.exit_code == 2 and "not UTF-8 text" in r.output


def test_folder_and_missing_file(tmp_path):
    r, _ = run(["check", str(tmp_path / "nope.yaml")])
    assert r.exit_code == 2 and "no such file" in r.output


def test_unknown_variant_and_bad_step():
    mech = str(Path(__file__).resolve().parents[1] / "mechanisms" / "crane.yaml")
    r, _ = run(["check", mech, "--variant", "nope"])
    assert r.exit_code == 2 and "no variant named 'nope'" in r.output and "jib-driven" in r.output
    r, _ = run(["run", mech, "--step", "3 kg"])
    assert r.exit_code == 2 and "--step '3 kg'" in r.output


def test_a_failing_run_keeps_a_previous_complete_csv(tmp_path):
    """The CSV is written to a temporary file and moved into place: a failing run never
    leaves a half-written file, and never clobbers a complete one."""
    mech = Path(__file__).resolve().parents[1] / "mechanisms" / "fourbar.yaml"
    r, _ = run(["run", str(mech), "-o", str(tmp_path), "--no-plots"])
    assert r.exit_code == 0
    before = (tmp_path / "results.csv").read_text()
    r, _ = run(["run", str(BAD / "cannot_assemble.yaml"), "-o", str(tmp_path), "--no-plots"])
    assert r.exit_code == 2
    assert (tmp_path / "results.csv").read_text() == before
    assert not list(tmp_path.glob("*.part"))


# --- faults found by fuzzing (issue 10) ----------------------------------------------

FOURBAR = Path(__file__).resolve().parents[1] / "mechanisms" / "fourbar.yaml"


@pytest.mark.parametrize(
    "old,new,where",
    [
        ("B: [59, 0]", "B: [1e308, 0]", ":22: links.rocker.points.B[0]: "),
        ("O2: [0, 0], A:", "O2: [0, 1e308], A:", ":11: links.crank.points.O2[1]: "),
        ("mass: 0.2 kg", "mass: 1e300 kg", ":19: links.coupler.mass: "),
        ("force: [0, -2 N]", "force: [0, -1e300 N]", ":41: loads.pull.force[1]: "),
        ("speed: 1 rad/s", "speed: 1e200 rad/s", ":35: driver.speed: "),
        ("O4: [87.5, 0]", "O4: [1e7 km, 0]", ":7: ground.O4[0]: "),
    ],
)
def test_huge_numbers_are_refused_where_they_are_read(old, new, where, tmp_path):
    text = FOURBAR.read_text()
    assert old in text
    f = tmp_path / "fourbar.yaml"
    f.write_text(text.replace(old, new, 1))
    for command in (["check", str(f)], ["run", str(f), "-o", str(tmp_path), "--no-plots"]):
        r, _ = run(command)
        assert r.exit_code == 2, r.output
        assert f"{f}{where}" in r.output and "too large a number" in r.output, r.output


def test_huge_whole_numbers_and_unit_powers(tmp_path):
    text = FOURBAR.read_text()
    cases = [
        ("sweep: {range: 360 deg, step: 2 deg}", "sweep: {steps: " + "9" * 400 + "}", "steps"),
        ("sweep: {range: 360 deg, step: 2 deg}", "sweep: {steps: " + "9" * 5000 + "}", "steps"),
        ("gravity: 9.81 m/s^2", "solver: {tolerance: " + "9" * 330 + "}", "tolerance"),
        ("mass: 0.2 kg", "mass: 2 kg^400", "links.coupler.mass"),
        ("mass: 0.2 kg", "mass: 2 kg/g^-999", "links.coupler.mass"),
    ]
    for old, new, key in cases:
        f = tmp_path / "fourbar.yaml"
        f.write_text(text.replace(old, new, 1))
        r, _ = run(["check", str(f)])
        assert r.exit_code == 2 and key in r.output, (new[:40], r.output)
        assert len(r.output) < 400, r.output


def test_weight_under_a_tiny_gravity(tmp_path):
    text = FOURBAR.read_text().replace("gravity: 9.81 m/s^2", "gravity: 1e-300 m/s^2")
    text = text.replace("mass: 0.2 kg", "weight: 2 N")
    f = tmp_path / "fourbar.yaml"
    f.write_text(text)
    r, _ = run(["check", str(f)])
    assert r.exit_code == 2 and "links.coupler.weight" in r.output and "gravity" in r.output


def test_a_model_built_in_code_with_a_huge_number():
    import mechsolve as ms
    from mechsolve.base.errors import InputError

    mech = ms.load(FOURBAR)
    mech.links[2].points["B"] = (1e308, 0.0)
    with pytest.raises(InputError, match="links.rocker.points.B: .*too large a number"):
        mech.validate()


def test_deep_nesting_is_refused_fast(tmp_path):
    f = tmp_path / "deep.yaml"
    f.write_text("[" * 20_000 + "]" * 20_000)
    g = tmp_path / "deep_block.yaml"
    g.write_text("links:\n  a:\n    " + "- " * 20_000 + "x\n")
    for path in (f, g):
        t0 = time.process_time()
        r, _ = run(["check", str(path)])
        assert time.process_time() - t0 < 1.0
        assert r.exit_code == 2 and "nesting deeper than 64 levels" in r.output, r.output
    assert f"{g}:3: links.a[0][0]" in r.output


def test_a_huge_flat_list_is_refused_fast(tmp_path):
    f = tmp_path / "flat.yaml"
    f.write_text("links: [" + ", ".join(["1"] * 140_000) + "]\n")
    t0 = time.process_time()
    r, _ = run(["check", str(f)])
    assert time.process_time() - t0 < 1.0
    assert r.exit_code == 2 and "more than 100000 values" in r.output, r.output


def _limited(cmd: list[str], **kw):
    """Run the real command with 2 GB of address space (a runaway read fails fast)."""
    import resource
    import subprocess
    import sys

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))

    return subprocess.run(
        [sys.executable, "-m", "mechsolve", *cmd],
        capture_output=True,
        text=True,
        timeout=60,
        preexec_fn=limit,
        **kw,
    )


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom"])
def test_a_device_that_never_ends(device, tmp_path):
    if not Path(device).exists():
        pytest.skip(f"no {device}")
    t0 = time.perf_counter()
    r = _limited(["run", device, "-o", str(tmp_path), "--no-plots"])
    assert time.perf_counter() - t0 < 30
    assert r.returncode == 2, r.stderr
    assert f"{device}: the file is longer than 1000000 bytes" in r.stderr
    assert "Traceback" not in r.stderr


def test_a_fifo(tmp_path):
    import os
    import threading

    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    fifo = tmp_path / "pipe.yaml"

    def write(data: bytes, repeat: bool) -> None:
        try:
            with open(fifo, "wb") as w:
                while True:
                    w.write(data)
                    if not repeat:
                        break
        except (BrokenPipeError, OSError):
            pass

    # an endless writer: refused after the limit
    os.mkfifo(fifo)
    t = threading.Thread(target=write, args=(b"# padding\n" * 1000, True), daemon=True)
    t.start()
    r = _limited(["check", str(fifo)])
    assert r.returncode == 2 and "longer than 1000000 bytes" in r.stderr, r.stderr
    t.join(10)
    # a mechanism through a pipe is read like a file
    t = threading.Thread(target=write, args=(FOURBAR.read_bytes(), False), daemon=True)
    t.start()
    r = _limited(["check", str(fifo)])
    assert r.returncode == 0, r.stderr
    t.join(10)


def test_nesting_beyond_libyamls_own_limit_names_a_clean_key_path():
    """libyaml (PyYAML 6.0.4) refuses more than 1000 flow levels while scanning ahead;
    the message is ours, with the key path read so far and no placeholder in it."""
    import mechsolve as ms
    from mechsolve.base.errors import InputError

    with pytest.raises(InputError) as exc:
        ms.loads("a: " + "[" * 1200 + "]" * 1200)
    text = str(exc.value)
    assert "nesting deeper than 64 levels" in text and "None" not in text
