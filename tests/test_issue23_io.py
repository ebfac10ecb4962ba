"""Issue 23, input and output: no lost or half-written file, no hang, one exit-code rule.

* every file a command writes appears whole or not at all, and a full disk or a refused
  permission is exit 2 in one line (a real full tmpfs when the tests run as root, and
  an injected ENOSPC everywhere);
* ``simulate`` and ``run`` share a folder without overwriting each other's plots, and
  writers never share a temporary name;
* a FIFO with nothing writing to it is refused instead of blocking for ever;
* ``... | head``: a closed output pipe ends quietly (141), every command;
* Ctrl-C is exit 130 with "interrupted" in every command, ``--watch`` included;
* a non-standard YAML tag is refused (file, line, key path);
* ``--watch`` marks the plots of the last good run as stale while the file is broken.
"""

from __future__ import annotations

import errno
import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

from conftest import MECH

ROOT = Path(__file__).resolve().parents[1]


def mechsolve(*args: str, timeout: float = 240, **kwargs) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "MECHSOLVE_DEBUG"}
    return subprocess.run(
        [sys.executable, "-m", "mechsolve", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        cwd=ROOT,
        **kwargs,
    )


def leftovers(folder: Path) -> list[Path]:
    """Temporaries a writer left behind (every one starts with a dot; the folder's record
    of what a command wrote is not one)."""
    return [
        p
        for p in folder.rglob("*")
        if p.name.startswith(".") and p.name != ".mechsolve-outputs.json"
    ]


# --- full disk: a real one (a tmpfs filled to the brim) ---------------------------------


def _fill(folder: Path, leave: int) -> Path:
    """Fill the file system of ``folder`` but for about ``leave`` bytes."""
    filler = folder / "filler"
    with open(filler, "wb") as f:
        try:
            while True:
                f.write(b"\0" * (1 << 16))
                f.flush()
        except OSError as exc:
            assert exc.errno == errno.ENOSPC
    size = filler.stat().st_size
    os.truncate(filler, max(0, size - leave))
    return filler


@pytest.fixture
def full_disk(tmp_path):
    """A 2 MiB tmpfs filled to the brim (root only; skipped where it cannot be mounted)."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a small tmpfs needs root")
    mnt = tmp_path / "disk"
    mnt.mkdir()
    p = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mnt)],
        capture_output=True,
        text=True,
    )
    if p.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {p.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def _study(tmp_path: Path) -> str:
    return str(MECH / "studies" / "fourbar-study.yaml")


# (name, arguments with {d} for the full disk's folder)
COMMANDS = [
    ("run", ["run", "mechanisms/fourbar.yaml", "--step", "30 deg", "-o", "{d}/out"]),
    (
        "run --junit",
        [
            "run",
            "mechanisms/studies/fourbar-study.yaml",
            "--no-plots",
            "-o",
            "{tmp}/o",
            "--junit",
            "{d}/junit.xml",
        ],
    ),  # fmt: skip
    (
        "run --at",
        ["run", "mechanisms/fourbar.yaml", "--at", "theta=30 deg, omega=1 rad/s", "-o", "{d}/at"],
    ),
    ("simulate", ["simulate", "mechanisms/motor-linkage.yaml", "-o", "{d}/sim"]),
    ("flywheel", ["flywheel", "mechanisms/shaper.yaml", "--no-check", "-o", "{d}/fly"]),
    ("cam", ["cam", "mechanisms/shaper-cam.yaml", "-o", "{d}/cam"]),
    ("synth", ["synth", "mechanisms/synth/crane-crank-rocker.yaml", "-o", "{d}/design.yaml"]),
    ("schema", ["schema", "-o", "{d}/mechanism.schema.json"]),
    (
        "polygons",
        [
            "polygons",
            "mechanisms/shaper.yaml",
            "--variant",
            "graphical",
            "--at",
            "7",
            "-o",
            "{d}/poly",
        ],
    ),  # fmt: skip
    (
        "sweep",
        [
            "sweep",
            "mechanisms/studies/fourbar-study.yaml",
            "-j",
            "1",
            "--step",
            "10 deg",
            "--best",
            "min range(P.y)",
            "-o",
            "{d}/sweep",
        ],
    ),  # fmt: skip
    ("animate", ["animate", "mechanisms/fourbar.yaml", "--frames", "4", "-o", "{d}/a.gif"]),
    ("check --draw", ["check", "mechanisms/fourbar.yaml", "--draw", "{d}/start.png"]),
    ("report", ["report", "mechanisms/fourbar.yaml", "--frames", "4", "-o", "{d}/r.html"]),
]


@pytest.mark.parametrize("name,args", COMMANDS, ids=[c[0] for c in COMMANDS])
def test_full_disk_is_exit_2_in_one_line_and_leaves_no_part(full_disk, tmp_path, name, args):
    """On a file system with no space left every command ends with exit 2 and one line
    that names the file and says why (no "internal error", no traceback), and leaves no
    temporary, no empty and no cut file behind."""
    _fill(full_disk, leave=0)
    argv = [a.format(d=full_disk, tmp=tmp_path) for a in args]
    p = mechsolve(*argv, "-q") if name not in ("schema", "check --draw", "flywheel") else None
    if p is None:
        p = mechsolve(*argv)
    err = p.stderr.strip()
    assert p.returncode == 2, (p.returncode, err)
    assert len(err.splitlines()) == 1, err
    assert "No space left on device" in err and "internal error" not in err, err
    assert str(full_disk) in err, err  # the file (or folder) is named
    assert leftovers(full_disk) == []
    written = [f for f in full_disk.rglob("*") if f.is_file() and f.name != "filler"]
    assert [f for f in written if f.stat().st_size == 0] == []


def test_nearly_full_disk_keeps_the_finished_csv_and_cuts_no_plot(full_disk):
    """With room for the CSV and not for the plots: the CSV is there, whole (every row
    of the sweep); no plot is there cut short; no temporary is left; exit 2."""
    _fill(full_disk, leave=80_000)
    out = full_disk / "out"
    p = mechsolve("run", "mechanisms/fourbar.yaml", "--step", "10 deg", "-o", str(out), "-q")
    assert p.returncode == 2, p.stderr
    assert "No space left on device" in p.stderr and len(p.stderr.strip().splitlines()) == 1
    rows = (out / "results.csv").read_text().splitlines()
    assert len(rows) == 1 + 37 and rows[-1].split(",")[0] == "36"
    assert leftovers(full_disk) == []
    for png in out.glob("*.png"):  # any plot there is complete: it ends with IEND
        assert png.read_bytes().endswith(b"IEND\xaeB`\x82"), png


# --- full disk: injected (any user, any machine) ----------------------------------------


def _full_for(monkeypatch, part: str = "") -> None:
    """Every flush to the disk of a file whose name contains ``part`` fails as on a full
    disk. A writer that does not go through the atomic writer (which flushes each file
    before its rename) is not refused, and its command exits 0: the test sees it."""
    real = os.fsync

    def fsync(fd):
        try:
            name = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            name = ""
        if part in os.path.basename(name):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd)

    monkeypatch.setattr(os, "fsync", fsync)


# (name, arguments with {d} for the output folder, the file that cannot be written)
INJECTED = [
    ("schema", ["schema", "-o", "{d}/s.json"], "s.json"),
    ("synth", ["synth", "{m}/synth/crane-crank-rocker.yaml", "-o", "{d}/x.yaml"], "x.yaml"),
    (
        "run --junit",
        [
            "run",
            "{m}/studies/fourbar-study.yaml",
            "--no-plots",
            "-q",
            "-o",
            "{d}/o",
            "--junit",
            "{d}/j.xml",
        ],
        "j.xml",
    ),  # fmt: skip
    ("run", ["run", "{m}/fourbar.yaml", "--step", "30 deg", "-q", "-o", "{d}/o"], "results.csv"),
    (
        "run --at",
        ["run", "{m}/fourbar.yaml", "--at", "theta=30 deg, omega=1 rad/s", "-q", "-o", "{d}/o"],
        "instants.csv",
    ),
    ("run plot", ["run", "{m}/fourbar.yaml", "--step", "30 deg", "-q", "-o", "{d}/o"], "links.png"),
    (
        "sweep best.yaml",
        [
            "sweep",
            "{m}/studies/fourbar-study.yaml",
            "-j",
            "1",
            "-q",
            "--step",
            "30 deg",
            "--best",
            "min range(P.y)",
            "--no-plots",
            "-o",
            "{d}/s",
        ],
        "best.yaml",
    ),  # fmt: skip
    (
        "sweep plots",
        [
            "sweep",
            "{m}/studies/fourbar-study.yaml",
            "-j",
            "1",
            "-q",
            "--step",
            "30 deg",
            "-o",
            "{d}/s",
        ],
        "study-pass-fail.png",
    ),  # fmt: skip
    ("simulate", ["simulate", "{m}/motor-linkage.yaml", "-q", "-o", "{d}/sim"], "motion.png"),
    ("flywheel", ["flywheel", "{m}/shaper.yaml", "--no-check", "-o", "{d}/f"], "flywheel.png"),
    (
        "polygons",
        ["polygons", "{m}/slider-crank.yaml", "--at", "2", "-q", "-o", "{d}/p"],
        "polygons.txt",
    ),
    ("check --draw", ["check", "{m}/fourbar.yaml", "--draw", "{d}/start.png"], "start.png"),
    (
        "cam csv",
        ["cam", "{m}/shaper-cam.yaml", "-q", "--no-plots", "-o", "{d}/c"],
        "cam_motion.csv",
    ),
    (
        "cam dxf",
        ["cam", "{m}/shaper-cam.yaml", "-q", "--no-plots", "-o", "{d}/c"],
        "cam_profile.dxf",
    ),
    ("animate", ["animate", "{m}/fourbar.yaml", "--frames", "3", "-q", "-o", "{d}/a.gif"], "a.gif"),
    (
        "report",
        ["report", "{m}/slider-crank.yaml", "--frames", "3", "-q", "-o", "{d}/r.html"],
        "r.html",
    ),
]


@pytest.mark.parametrize("name,argv,target", INJECTED, ids=[c[0] for c in INJECTED])
def test_injected_enospc_is_exit_2_and_leaves_no_part(monkeypatch, tmp_path, name, argv, target):
    """A full disk while one file is written: exit 2 with one line naming that file,
    no "internal error", no temporary left, and that file not there."""
    _full_for(monkeypatch, target)
    r = CliRunner().invoke(main, [a.format(d=tmp_path, m=MECH) for a in argv])
    assert r.exit_code == 2, r.output
    err = [x for x in r.output.splitlines() if "error" in x]
    assert len(err) == 1 and "No space left on device" in err[0] and target in err[0], r.output
    assert "internal error" not in r.output and "Traceback" not in r.output
    assert leftovers(tmp_path) == []
    assert [f for f in tmp_path.rglob(target)] == []


def test_replacing_keeps_the_old_file_on_a_write_error(tmp_path):
    """A write that fails half-way: the old file is untouched, the temporary removed, and
    the error names the target (not the temporary) with the system's errno."""
    from mechsolve.base.atomic import WriteFailed, replacing

    target = tmp_path / "results.csv"
    target.write_text("old, complete\n")
    with pytest.raises(WriteFailed) as info:
        with replacing(target) as tmp:
            with open(tmp, "w") as fh:
                fh.write("new, half")
                fh.flush()
                raise OSError(errno.ENOSPC, "No space left on device")
    assert target.read_text() == "old, complete\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.csv"]
    exc = info.value
    assert isinstance(exc, OSError) and exc.errno == errno.ENOSPC
    assert exc.filename == str(target) and exc.exit_code == 2
    assert str(exc) == f"cannot write {target}: No space left on device"


def test_write_failed_crosses_a_process_pool():
    """A design's CSV written by a worker (sweep --keep-results) on a full disk reaches
    the main process as the same error: same message, errno and exit code."""
    import pickle

    from mechsolve.base.atomic import WriteFailed

    exc = WriteFailed("out/designs/design-00001.csv", OSError(errno.ENOSPC, "No space left"))
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is WriteFailed and str(back) == str(exc)
    assert back.errno == errno.ENOSPC and back.exit_code == 2
    assert back.filename == "out/designs/design-00001.csv"


def test_csv_stream_on_a_full_disk(tmp_path, monkeypatch):
    """The streamed CSV: a write refused by the disk removes its partial file."""
    from mechsolve import api
    from mechsolve.base.atomic import WriteFailed
    from mechsolve.results.csv import write_csv

    res = api.solve(api.load(MECH / "fourbar.yaml"))

    class Full:
        def __init__(self, fh):
            self.fh = fh

        def write(self, text):
            raise OSError(errno.ENOSPC, "No space left on device")

        def close(self):
            self.fh.close()

    real = os.fdopen

    def fdopen(fd, *a, **k):
        return Full(real(fd, *a, **k))

    monkeypatch.setattr(os, "fdopen", fdopen)
    with pytest.raises(WriteFailed, match="results.csv: No space left on device"):
        write_csv(res, tmp_path / "results.csv")
    assert list(tmp_path.iterdir()) == []


def test_permission_refused_is_exit_2(tmp_path):
    """A read-only target folder for a single file (schema -o, synth -o): exit 2, one
    line naming the file, no traceback."""
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        pytest.skip("root may write anywhere")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        r = CliRunner().invoke(main, ["schema", "-o", str(ro / "s.json")])
    finally:
        ro.chmod(0o700)
    assert r.exit_code == 2 and "Permission denied" in r.output and "s.json" in r.output


@pytest.mark.parametrize(
    "argv,target",
    [
        (["schema", "-o", "{d}/s.json"], "s.json"),
        (["run", "{m}/fourbar.yaml", "--step", "30 deg", "-q", "-o", "{d}/o"], "results.csv"),
        (["check", "{m}/fourbar.yaml", "--draw", "{d}/start.png"], "start.png"),
    ],
    ids=["schema", "run", "check --draw"],
)
def test_injected_permission_refused_is_exit_2(monkeypatch, tmp_path, argv, target):
    """The system refuses to create the file (EACCES, as a folder made read-only under a
    running command would): exit 2, one line naming the file, nothing left."""
    import tempfile

    real = tempfile.mkstemp

    def refuse(*args, **kwargs):
        if target in kwargs.get("prefix", ""):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), kwargs.get("dir"))
        return real(*args, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    r = CliRunner().invoke(main, [a.format(d=tmp_path, m=MECH) for a in argv])
    assert r.exit_code == 2, r.output
    err = [x for x in r.output.splitlines() if "error" in x]
    assert len(err) == 1 and "Permission denied" in err[0] and target in err[0], r.output
    assert leftovers(tmp_path) == [] and list(tmp_path.rglob(target)) == []


def test_read_only_file_system_is_exit_2(full_disk):
    """A real refusal: the tmpfs remounted read-only (EROFS) under `schema -o`."""
    subprocess.run(["mount", "-o", "remount,ro", str(full_disk)], check=True)
    p = mechsolve("schema", "-o", str(full_disk / "s.json"))
    assert p.returncode == 2, p.stderr
    assert p.stderr.strip().splitlines() == [
        f"error: cannot write {full_disk / 's.json'}: Read-only file system"
    ]


# --- simulate beside run; unique temporaries ---------------------------------------------


def test_simulate_does_not_overwrite_the_plots_of_run(tmp_path):
    """`run` and `simulate` of one file default to one folder: simulate's files have
    names of their own, and run's reactions.png is left as it was."""
    f = MECH / "motor-linkage.yaml"
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path), "-q"])
    assert r.exit_code == 0, r.output
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert "reactions.png" in before
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(tmp_path), "-q"])
    assert r.exit_code == 0, r.output
    after = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    for name, data in before.items():
        if name != ".mechsolve-outputs.json":  # the folder's record: simulate's run added
            assert after[name] == data, f"simulate overwrote {name}"
    new = sorted(set(after) - set(before))
    assert new == [
        "simulation-inertia.png",
        "simulation-motion.png",
        "simulation-reactions.png",
        "simulation.csv",
    ]


def test_two_writers_of_one_file_never_share_a_temporary(tmp_path):
    """Each write of a plot takes a temporary of its own (two `simulate`s into one folder
    collided on `.motion.png.part.png`); it is in the target's folder and gone after."""
    from mechsolve.analyses.dynamics.plots import _save

    names = []

    class Fig:
        def savefig(self, fname, **kwargs):
            names.append(str(fname))
            Path(fname).write_bytes(b"png")

    target = tmp_path / "simulation-motion.png"
    _save(Fig(), target)
    _save(Fig(), target)
    assert len(set(names)) == 2
    assert all(Path(n).parent == tmp_path for n in names)
    assert [p.name for p in tmp_path.iterdir()] == [target.name]


def test_two_simulates_into_one_folder(tmp_path):
    """Two simulations of one file into one folder at the same time both finish."""
    cmd = [sys.executable, "-m", "mechsolve", "simulate", "mechanisms/motor-linkage.yaml"]
    cmd += ["-o", str(tmp_path), "-q"]
    procs = [
        subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    for p in procs:
        _, err = p.communicate(timeout=240)
        assert p.returncode == 0, err
    assert leftovers(tmp_path) == []


# --- a FIFO ------------------------------------------------------------------------------


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_fifo_with_no_writer_is_refused_not_waited_for(tmp_path):
    """Opening a FIFO that nothing writes to blocks for ever: it is refused, exit 2,
    within the bounded wait (5 s) instead."""
    fifo = tmp_path / "mech.yaml"
    os.mkfifo(fifo)
    t0 = time.monotonic()
    p = mechsolve("check", str(fifo), timeout=60)
    assert p.returncode == 2, p.stderr
    assert time.monotonic() - t0 < 30
    assert f"{fifo}: this is a pipe (FIFO), not a regular file" in p.stderr
    assert "Traceback" not in p.stderr


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_fifo_with_a_writer_is_read(tmp_path, monkeypatch):
    """A FIFO that something writes a mechanism to (a process substitution) still works."""
    from mechsolve.model import source

    monkeypatch.setattr(source, "PIPE_WAIT", 20.0)
    fifo = tmp_path / "mech.yaml"
    os.mkfifo(fifo)
    text = (MECH / "fourbar.yaml").read_bytes()

    def writer():
        time.sleep(0.3)
        with open(fifo, "wb") as f:  # blocks until the reader opens
            for k in range(0, len(text), 100):  # in pieces, as a slow producer
                f.write(text[k : k + 100])
                f.flush()

    th = threading.Thread(target=writer, daemon=True)
    th.start()
    src = source.load_file(fifo)
    th.join(5)
    assert src.data["name"] == "four-bar crank-rocker"


def test_fifo_wait_is_bounded_in_process(tmp_path, monkeypatch):
    from mechsolve.model import source

    monkeypatch.setattr(source, "PIPE_WAIT", 0.2)
    fifo = tmp_path / "m.yaml"
    os.mkfifo(fifo)
    r = CliRunner().invoke(main, ["check", str(fifo)])
    assert r.exit_code == 2 and "sent nothing for 0.2 s" in r.output


# --- a closed output pipe ----------------------------------------------------------------


@pytest.mark.parametrize(
    "args",
    [
        ["run", "mechanisms/fourbar.yaml", "--no-plots", "-o", "{tmp}/o"],
        ["run", "mechanisms/fourbar.yaml", "--at", "theta=30 deg, omega=1 rad/s", "-o", "{tmp}/o"],
        ["check", "mechanisms/fourbar.yaml"],
        ["synth", "mechanisms/synth/crane-crank-rocker.yaml"],
        ["schema"],
    ],
    ids=["run", "run --at", "check", "synth", "schema"],
)
def test_closed_output_pipe_ends_quietly(tmp_path, args):
    """`mechsolve ... | head` where head has gone: exit 141 as a tool ended by SIGPIPE,
    nothing on stderr (it was exit 4, "internal error: BrokenPipeError")."""
    r, w = os.pipe()
    os.close(r)  # the reader is gone before anything is written
    try:
        p = subprocess.run(
            [sys.executable, "-m", "mechsolve", *(a.format(tmp=tmp_path) for a in args)],
            stdout=w,
            stderr=subprocess.PIPE,
            text=True,
            timeout=240,
            cwd=ROOT,
        )
    finally:
        os.close(w)
    assert p.returncode == 141, p.stderr
    assert p.stderr == ""


def test_closed_output_pipe_after_writing_keeps_the_files(tmp_path):
    r, w = os.pipe()
    os.close(r)
    try:
        p = subprocess.run(
            [sys.executable, "-m", "mechsolve", "run", "mechanisms/fourbar.yaml", "--step",
             "30 deg", "--no-plots", "-o", str(tmp_path)],
            stdout=w, stderr=subprocess.PIPE, text=True, timeout=240, cwd=ROOT,
        )  # fmt: skip
    finally:
        os.close(w)
    assert p.returncode == 141 and p.stderr == ""
    assert len((tmp_path / "results.csv").read_text().splitlines()) == 1 + 13


# --- Ctrl-C --------------------------------------------------------------------------


def _interrupt(*args, **kwargs):
    raise KeyboardInterrupt


@pytest.mark.parametrize(
    "where,argv",
    [
        ("mechsolve.api.check", ["check", str(MECH / "fourbar.yaml")]),
        ("mechsolve.analyses.flywheel.size_flywheel",
         ["flywheel", str(MECH / "shaper.yaml"), "-o", "{tmp}"]),
        ("mechsolve.analyses.synth.problem.solve_problem",
         ["synth", str(MECH / "synth" / "crane-crank-rocker.yaml")]),
        ("mechsolve.analyses.schema.build.text", ["schema", "-o", "{tmp}/s.json"]),
    ],
    ids=["check", "flywheel", "synth", "schema"],
)  # fmt: skip
def test_ctrl_c_is_130_in_every_command(monkeypatch, tmp_path, where, argv):
    """Ctrl-C anywhere in a command is exit 130 with "interrupted", the rule `run` has
    (click's own "Aborted!" with 1 was what check, flywheel and synth gave)."""
    mod, _, attr = where.rpartition(".")
    import importlib

    monkeypatch.setattr(importlib.import_module(mod), attr, _interrupt)
    if where.endswith("schema.build.text"):  # schema -o copies the shipped file: interrupt that
        from mechsolve.cli.commands import schema

        monkeypatch.setattr(schema, "shipped_path", _interrupt)
    r = CliRunner().invoke(main, [a.format(tmp=tmp_path) for a in argv])
    assert r.exit_code == 130, r.output
    assert "interrupted" in r.output and "Aborted" not in r.output


def test_ctrl_c_in_check_through_a_real_process(tmp_path):
    """A real SIGINT into `check` while it loads: 130, "interrupted", no traceback."""
    slow = tmp_path / "slow.py"
    slow.write_text(
        "import sys, time\n"
        "import mechsolve.api as api\n"
        "real = api.check\n"
        "def check(m):\n"
        "    print('checking', flush=True); time.sleep(60); return real(m)\n"
        "api.check = check\n"
        "from mechsolve.cli.main import main\n"
        "sys.exit(main())\n"
    )
    p = subprocess.Popen(
        [sys.executable, str(slow), "check", str(MECH / "fourbar.yaml")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert p.stdout.readline().strip() == "checking"
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert err.strip() == "interrupted" and "Traceback" not in out + err


# --- YAML tags -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "value",
    [
        "!!python/name:os.system",
        "!!python/name:os.system ''",
        "!!python/none ''",
        "!!python/str x",
        "!!value x",
        "!!yaml x",
        "!!merge x",
        "!custom x",
    ],
)
def test_non_standard_tags_are_refused(tmp_path, value):
    """README: non-standard tags are refused (`name: !!python/name:os.system` was read
    as an empty name with exit 0)."""
    text = (MECH / "fourbar.yaml").read_text()
    text = text.replace("name: four-bar crank-rocker", f"name: {value}")
    f = tmp_path / "m.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["check", str(f)])
    assert r.exit_code == 2, r.output
    line = next(i for i, t in enumerate(text.splitlines(), 1) if t.startswith("name:"))
    assert f"{f}:{line}: name: the tag " in r.output and "is not allowed" in r.output


def test_standard_tags_still_read():
    from mechsolve.model.source import load_text

    src = load_text("a: !!str 12\nb: !!int '3'\nc: !!float 1\nd: !!null ''\ne: !!bool true\n")
    assert src.data == {"a": "12", "b": 3, "c": 1.0, "d": None, "e": True}


# --- watch ---------------------------------------------------------------------------


class Lines:
    """The process's stdout, line by line, read on a thread."""

    def __init__(self, proc: subprocess.Popen) -> None:
        self.q: queue.Queue[str] = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, args=(proc,), daemon=True).start()

    def _read(self, proc) -> None:
        for line in proc.stdout:
            self.q.put(line.rstrip("\n"))

    def until(self, text: str, timeout: float = 120.0) -> list[str]:
        out = []
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                line = self.q.get(timeout=0.2)
            except queue.Empty:
                continue
            out.append(line)
            self.seen.append(line)
            if text in line:
                return out
        raise AssertionError(f"no {text!r} within {timeout} s; saw:\n" + "\n".join(self.seen))


def test_watch_marks_stale_plots_and_ctrl_c_is_130(tmp_path):
    """A broken save leaves the last good run's files in place with STALE.txt beside
    them (the error, and which run they are from) and says so on the terminal; the next
    good run removes the marker; Ctrl-C ends the watch with 130."""
    pytest.importorskip("watchfiles")
    f = tmp_path / "fourbar.yaml"
    good = (MECH / "fourbar.yaml").read_text()
    f.write_text(good)
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "mechsolve", "run", str(f), "--watch", "--no-plots",
         "--step", "10 deg", "-o", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    try:
        lines = Lines(proc)
        lines.until("Ctrl-C stops")
        assert not (out / "STALE.txt").exists()
        time.sleep(0.5)
        f.write_text(good.replace("  O4: [ground, rocker]", "  O4: [ground, rockr]"))
        broken = "\n".join(lines.until("fix it and save"))
        assert "are from the last good run" in broken and "STALE.txt" in broken
        stale = (out / "STALE.txt").read_text()
        assert "rockr" in stale and "joints.O4" in stale
        assert (out / "results.csv").exists()  # the last good run's files stay
        time.sleep(0.5)
        f.write_text(good)
        lines.until("Ctrl-C stops")
        assert not (out / "STALE.txt").exists()
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=30)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 130
    assert leftovers(out) == []
