"""Issue 30 (review R7), writing what the commands produce and refusing what they cannot:

* an output named through a symbolic link replaces the file the link points to and keeps
  the link; a pipe (FIFO) or a character device is written through, never replaced by a
  regular file (a device node of our own in tmp_path, never a real one);
* a full disk under ``sweep --keep-results`` is exit 2 with the solved rows kept;
* ``draw``/``polygons --at`` far from the start are refused with the limit named;
* a motion law that is not finite is named at its own key, with the time;
* the cam's pressure-angle peaks carry their unit; smaller wording fixes.
"""

from __future__ import annotations

import csv
import errno
import json
import math
import os
import stat
import threading
from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

from conftest import MECH

FIFOS = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")


def _invoke(*args) -> object:
    return CliRunner().invoke(main, [str(a) for a in args])


def _leftovers(*folders: Path) -> list[str]:
    return sorted(
        p.name
        for d in folders
        for p in Path(d).iterdir()
        if p.name.startswith(".") and p.name != ".mechsolve-outputs.json"  # the folder's record
    )


def _reader(fifo: Path) -> tuple[threading.Thread, list[bytes]]:
    """A thread reading ``fifo`` to its end (as ``cat fifo`` would)."""
    got: list[bytes] = []

    def read():
        with open(fifo, "rb") as fh:
            got.append(fh.read())

    t = threading.Thread(target=read, daemon=True)
    t.start()
    return t, got


# --- item 2: symbolic links, pipes and devices ------------------------------------------


def test_a_symlink_is_followed_and_its_target_replaced(tmp_path):
    """The link stays a link; the file it points to (in another folder) gets the new
    contents, by a rename there (a new inode: never half written); no temporary is left
    beside the link or beside the target."""
    from mechsolve.base.atomic import write_text

    (tmp_path / "real").mkdir()
    target = tmp_path / "real" / "out.csv"
    target.write_text("old\n")
    old_inode = target.stat().st_ino
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    write_text(link, "new, complete\n")
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_text() == "new, complete\n"
    assert target.stat().st_ino != old_inode  # replaced, not rewritten in place
    assert _leftovers(tmp_path, tmp_path / "real") == []


def test_a_link_to_nothing_yet_creates_its_target(tmp_path):
    from mechsolve.base.atomic import write_bytes

    link = tmp_path / "link.bin"
    link.symlink_to(tmp_path / "made.bin")
    write_bytes(link, b"\x00\x01")
    assert link.is_symlink() and (tmp_path / "made.bin").read_bytes() == b"\x00\x01"


def test_schema_to_a_symlink_writes_the_linked_file(tmp_path):
    """``schema -o link``: the link is kept, its target holds the whole schema (the same
    bytes as to a plain file)."""
    plain = tmp_path / "plain.json"
    assert _invoke("schema", "-o", plain).exit_code == 0
    target = tmp_path / "target.json"
    target.write_text("x")
    link = tmp_path / "link.json"
    link.symlink_to(target.name)  # a relative link
    r = _invoke("schema", "-o", link)
    assert r.exit_code == 0, r.output
    assert link.is_symlink()
    assert target.read_bytes() == plain.read_bytes()
    json.loads(target.read_text())


@FIFOS
def test_a_fifo_is_written_through_not_replaced(tmp_path, monkeypatch):
    """``schema -o fifo`` with a process reading it: the reader gets the whole schema
    and the FIFO is still a FIFO (it used to become a regular file, the reader getting
    nothing). The temporary (in the temporary folder) is removed."""
    import tempfile

    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmpdir))
    plain = tmp_path / "plain.json"
    assert _invoke("schema", "-o", plain).exit_code == 0
    fifo = tmp_path / "out.json"
    os.mkfifo(fifo)
    t, got = _reader(fifo)
    r = _invoke("schema", "-o", fifo)
    t.join(30)
    assert r.exit_code == 0, r.output
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert got == [plain.read_bytes()]
    assert list(tmpdir.iterdir()) == [] and _leftovers(tmp_path) == []


@FIFOS
def test_a_symlink_to_a_fifo_is_written_through(tmp_path):
    from mechsolve.base.atomic import write_text

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    link = tmp_path / "link"
    link.symlink_to(fifo)
    t, got = _reader(fifo)
    write_text(link, "a,b\n1,2\n" * 20000)  # more than a pipe's buffer
    t.join(30)
    assert got == [b"a,b\n1,2\n" * 20000]
    assert link.is_symlink() and stat.S_ISFIFO(os.lstat(fifo).st_mode)


@FIFOS
def test_a_fifo_nothing_reads_is_refused_not_waited_for(tmp_path, monkeypatch):
    """Nothing reads the FIFO: exit 2 after the bounded wait, naming the file; the FIFO
    is left as it was."""
    import time

    from mechsolve.base import atomic

    monkeypatch.setattr(atomic, "PIPE_WAIT", 0.3)
    fifo = tmp_path / "out.json"
    os.mkfifo(fifo)
    t0 = time.monotonic()
    r = _invoke("schema", "-o", fifo)
    assert time.monotonic() - t0 < 20
    assert r.exit_code == 2, r.output
    assert f"cannot write {fifo}: it is a pipe (FIFO) that no process reads" in r.output
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def _device(tmp_path: Path, name: str, minor: int) -> Path:
    """A character device node of our own in tmp_path (1, minor: 3 null, 7 full), or a
    skip where one cannot be made or opened (not root, a nodev mount)."""
    node = tmp_path / name
    try:
        os.mknod(node, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
        os.close(os.open(node, os.O_WRONLY))
    except (OSError, AttributeError) as exc:
        pytest.skip(f"no device node of our own here: {exc}")
    return node


def test_a_full_device_is_a_full_disk_and_stays_a_device(tmp_path):
    """A node like /dev/full (made in tmp_path): exit 2, "No space left on device" with
    the file named, and the node is still the same character device (it used to be
    replaced by a 128 kB regular file and the command said "wrote")."""
    node = _device(tmp_path, "full", 7)
    r = _invoke("schema", "-o", node)
    assert r.exit_code == 2, r.output
    assert f"cannot write {node}: {os.strerror(errno.ENOSPC)}" in r.output
    st = os.lstat(node)
    assert stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, 7)
    assert _leftovers(tmp_path) == []


def test_a_null_device_takes_the_output_and_stays_a_device(tmp_path):
    node = _device(tmp_path, "null", 3)
    r = _invoke("schema", "-o", node)
    assert r.exit_code == 0, r.output
    assert stat.S_ISCHR(os.lstat(node).st_mode)


# --- item 1: a full disk under sweep --keep-results -------------------------------------

STUDY = Path(__file__).parent / "data" / "study_fourbar.yaml"  # 3 x 2 designs
COUPLER, ROCKER = 105.6, 59.0  # mm, the file's b and c


def _swing(a: float, d: float) -> float:
    """The crank-rocker's rocker swing (deg), from the triangle O2-B-O4 at the two limit
    positions (crank and coupler in line: |O2B| = b + a and b - a)."""
    b, c = COUPLER, ROCKER

    def at_o4(s: float) -> float:
        return math.degrees(math.acos((c * c + d * d - s * s) / (2 * c * d)))

    return at_o4(b + a) - at_o4(b - a)


def _full_for(monkeypatch, part: str) -> None:
    """Every flush to the disk of a file whose name contains ``part`` fails as on a full
    disk (the atomic writer flushes each file before its rename)."""
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


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize(
    "jobs, full, kept",
    [
        ("1", "design-00002", 3),  # designs 0 and 1 written, 2 solved but not written
        ("1", "design-00000", 1),  # the first (timed) design's file already
        ("2", "design-00003", None),  # on a pool: at least the rows before, in order
    ],
)
def test_a_full_disk_stops_the_study_keeping_the_solved_rows(
    tmp_path, monkeypatch, jobs, full, kept
):
    """It used to be exit 0, every row "failed: cannot write ..." without its figures, and
    "wrote ... 6 design results". Now: exit 2, one error naming the design's file and
    the disk's reason, the rows solved kept in study.csv with their figures (the swing
    checked against the closed form), the files written whole and no claim of others."""
    if not os.path.isdir("/proc/self/fd"):
        pytest.skip("the injected full disk reads /proc/self/fd")
    pytest.importorskip("multiprocessing")
    _full_for(monkeypatch, full)
    out = tmp_path / "st"
    r = _invoke("sweep", STUDY, "-o", out, "-j", jobs, "--no-plots", "--keep-results")
    assert r.exit_code == 2, r.output
    target = out / "designs" / f"{full}.csv"
    err = [x for x in r.output.splitlines() if "error" in x]
    assert err == [f"error: cannot write {target}: {os.strerror(errno.ENOSPC)}"], r.output
    assert "design results" not in r.output and "Traceback" not in r.output
    rows = _rows(out / "study.csv")
    done = [int(row["design [-]"]) for row in rows]
    stop = int(full[-5:])
    if kept is not None:
        assert done == list(range(kept))
    assert stop in done or jobs != "1"
    assert f"stopped after {len(rows)} of 6 designs" in r.output
    for row in rows:
        assert row["status"] == "ok", row
        a, d = float(row["links.crank.points.A[0] [mm]"]), float(row["ground.O4[0] [mm]"])
        assert float(row["rocker.swing [deg]"]) == pytest.approx(_swing(a, d), abs=1e-6)
    written = sorted(p.name for p in (out / "designs").iterdir())
    assert f"{full}.csv" not in written
    assert all(not n.startswith(".") for n in written)  # no temporary left
    positions = {int(row["design [-]"]): int(row["positions [-]"]) for row in rows}
    for name in written:  # each whole: a row per position of its design
        # (on a pool, another worker may finish and write a design whose row reaches the
        # main process after the stop, as on Ctrl-C: its file is whole too; every design
        # of this study has the same sweep)
        want = positions.get(int(name[7:12]), next(iter(positions.values())))
        assert len(_rows(out / "designs" / name)) == want


def test_the_stop_crosses_a_process_pool_or_dask_with_its_rows():
    """A worker's ResultsNotWritten reaches the main process (pickled, as a pool or Dask
    sends it) with the same message, errno, exit code and the rows finished."""
    import pickle

    from mechsolve.analyses.study.execute import ResultsNotWritten

    rows = [{"design [-]": 4, "status": "ok", "rocker.swing [deg]": 48.3}]
    exc = ResultsNotWritten("st/designs/design-00004.csv", OSError(errno.ENOSPC, "full"), rows)
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is ResultsNotWritten and str(back) == str(exc)
    assert back.errno == errno.ENOSPC and back.exit_code == 2 and back.rows == rows
    assert str(back) == "cannot write st/designs/design-00004.csv: full"


@pytest.fixture
def small_disk(tmp_path):
    """A 2 MiB tmpfs (root only; skipped where it cannot be mounted)."""
    import shutil
    import subprocess

    if not hasattr(os, "geteuid") or os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a small tmpfs needs root")
    mnt = tmp_path / "disk"
    mnt.mkdir()
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mnt)],
                       capture_output=True, text=True)  # fmt: skip
    if p.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {p.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def test_a_real_full_disk_under_keep_results(small_disk):
    """The reviewer's case on a real file system: room for the table and a few designs'
    results, not for all. Exit 2 naming a design's file, every design finished before it
    in the table with its figures, its files whole, nothing else claimed."""
    filler = small_disk / "filler"
    with open(filler, "wb") as fh:  # fill it to the brim, then free 60 kB
        try:
            while True:
                fh.write(b"\0" * (1 << 16))
                fh.flush()
        except OSError as exc:
            assert exc.errno == errno.ENOSPC
    os.truncate(filler, filler.stat().st_size - 60_000)
    out = small_disk / "st"
    r = _invoke("sweep", STUDY, "-o", out, "-j", "1", "--no-plots", "--keep-results")
    assert r.exit_code == 2, r.output
    err = [x for x in r.output.splitlines() if "error" in x]
    assert len(err) == 1 and os.strerror(errno.ENOSPC) in err[0], r.output
    assert f"{out}/designs/design-" in err[0]
    rows = _rows(out / "study.csv")
    written = sorted(p.name for p in (out / "designs").iterdir())
    assert 1 <= len(written) < len(rows) <= 6
    assert [int(row["design [-]"]) for row in rows] == list(range(len(rows)))
    assert written == [f"design-{k:05d}.csv" for k in range(len(written))]
    for row in rows:
        a, d = float(row["links.crank.points.A[0] [mm]"]), float(row["ground.O4[0] [mm]"])
        assert float(row["rocker.swing [deg]"]) == pytest.approx(_swing(a, d), abs=1e-6)
    for name in written:
        assert len(_rows(out / "designs" / name)) == int(rows[0]["positions [-]"])


def test_kept_results_counts_only_the_files_written(tmp_path):
    """Invalid designs have no results file: the summary counts the files it wrote (2),
    not the designs (4)."""
    out = tmp_path / "st"
    # a crank of 0 mm is an invalid design (its two points coincide)
    r = _invoke(
        "sweep", STUDY, "-o", out, "-j", "1", "--no-plots", "--keep-results",
        "-p", "links.crank.points.A[0]=20, 0 mm",
    )  # fmt: skip
    assert r.exit_code in (0, 5), r.output  # 5: no design meets the file's requirements
    rows = _rows(out / "study.csv")
    assert [row["status"].split(":")[0] for row in rows] == ["ok", "ok", "invalid", "invalid"]
    assert sorted(p.name for p in (out / "designs").iterdir()) == [
        "design-00000.csv",
        "design-00001.csv",
    ]
    assert f"and 2 design results in {out}/designs/" in r.output


# --- item 5: draw and polygons --at far from the start ----------------------------------

FOURBAR = MECH / "fourbar.yaml"  # driver O2 at 1 rad/s from 0 deg


def _with_driver(tmp_path: Path, driver: str, sweep: str, name: str = "m.yaml") -> Path:
    text = FOURBAR.read_text()
    old_d, old_s = (
        "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}",
        "sweep: {range: 360 deg, step: 2 deg}",
    )
    assert old_d in text and old_s in text
    path = tmp_path / name
    path.write_text(text.replace(old_d, driver).replace(old_s, sweep))
    return path


@pytest.mark.parametrize("command", ["draw", "polygons"])
@pytest.mark.parametrize(
    "at, said",
    [
        ("1e7 s", "the driver would travel 1e+07 rad from the start by t = 1e+07 s; "
                  "mechsolve accepts at most 1e+06 rad"),
        ("1e9 deg", "too large a number for an angle: mechsolve accepts at most 1e+06 rad"),
        ("1e9", "give the angle with its unit"),
    ],
)  # fmt: skip
def test_a_far_instant_is_refused_with_the_limit(tmp_path, command, at, said):
    """It was an internal error (MemoryError: 213 GiB for the grid from the start), exit
    4, or minutes of solving; now exit 2 at once, naming the limit ``run --at`` has."""
    out = tmp_path / ("d.svg" if command == "draw" else "pg")
    r = _invoke(command, FOURBAR, "--at", at, "-o", out)
    assert r.exit_code == 2, r.output
    assert f"--at {at!r}: " in r.output and said in r.output, r.output
    assert "internal error" not in r.output
    assert not out.exists() or not any(out.iterdir())  # nothing written


def test_a_motion_law_far_from_its_start_is_refused(tmp_path):
    """A law that reaches 2e6 rad at t = 2 s: refused by the same limit."""
    f = _with_driver(tmp_path, 'driver: {joint: O2, motion: {law: "1e6 * t"}}',
                     "sweep: {duration: 1 s, steps: 10}")  # fmt: skip
    r = _invoke("draw", f, "--at", "2 s", "-o", tmp_path / "d.svg")
    assert r.exit_code == 2, r.output
    assert "the driver would travel 2e+06 rad from the start by t = 2 s" in r.output


def test_an_instant_within_reach_is_drawn_at_its_angle(tmp_path):
    """100 s at 1 rad/s from 0 deg: the crank at 100 rad = 5729.58 deg, i.e. 329.58 deg
    into its 16th turn (the closed form of a constant speed)."""
    r = _invoke("draw", FOURBAR, "--at", "100 s", "-o", tmp_path / "d.svg")
    assert r.exit_code == 0, r.output
    want = math.degrees(100.0) % 360.0
    assert f"(driver angle {want:.6g}°)" in r.output, r.output


# --- item 7: a motion law that is not finite --------------------------------------------


@pytest.mark.parametrize(
    "law, t, which",
    [
        ("2 * t + 1/(t - 1)", 1.0, ""),  # a pole at t = 1 s (position and rates)
        # u(1) = 0, u'(1) = -1/(2 sqrt(0)), u''(1) = -1/(4 (1 - t)^1.5)
        ("sqrt(1 - t)", 1.0, " (its speed and acceleration)"),
        ("t*1e300*1e300", 0.0, " (its speed)"),  # u(0) = 0, u' = 1e600 everywhere
    ],
)
def test_a_motion_law_not_finite_is_named_at_its_key_with_the_time(tmp_path, law, t, which):
    """It was "driver.speed: the driver speed must be a finite number", a key not in the
    file (the speed derived from the law). The law's own key path, its line (the driver's
    line, 35) and the time where it is not finite (by hand: the pole, or where the root's
    derivative is infinite) are named."""
    f = _with_driver(tmp_path, f'driver: {{joint: O2, motion: {{law: "{law}"}}}}',
                     "sweep: {duration: 2 s, steps: 20}")  # fmt: skip
    r = _invoke("check", f)
    assert r.exit_code == 2, r.output
    want = f"{f}:35: driver.motion.law: the law is not finite at t = {t:g} s{which}"
    assert want in r.output, r.output
    assert "driver.speed" not in r.output


def test_a_law_not_finite_only_later_in_the_sweep_is_named_there(tmp_path):
    """1/(t - 1.5) is finite over the first second (where the law's nominal speed is
    read) and has its pole at a sample of the sweep, t = 1.5 s."""
    f = _with_driver(tmp_path, 'driver: {joint: O2, motion: {law: "t + 1/(t - 1.5)"}}',
                     "sweep: {duration: 2 s, steps: 20}")  # fmt: skip
    r = _invoke("run", f, "-o", tmp_path / "o", "-q")
    assert r.exit_code == 2, r.output
    assert "driver.motion.law: the law is not finite at t = 1.5 s" in r.output, r.output


# --- item 8: the cam's pressure-angle peaks carry their unit ----------------------------


def test_the_pressure_peaks_are_labelled_with_their_unit(tmp_path, monkeypatch):
    """The labels of the peaks on pressure.png read "48.3°", not "48.3"; the largest is
    the largest pressure angle of the profile (read off its own array here)."""
    import numpy as np

    from mechsolve.analyses.cam import writers
    from mechsolve.analyses.cam.analysis import analyse
    from mechsolve.analyses.cam.model import load

    figs: list = []

    def keep(fig, path, plt, tight=False):
        figs.append(fig)
        return path

    monkeypatch.setattr(writers, "_save", keep)
    monkeypatch.setattr(writers, "draw_cam", lambda res, path, positions=4: path)
    res = analyse(load(MECH / "shaper-cam.yaml", None))
    writers.write_plots(res, tmp_path)
    (fig,) = [f for f in figs if "pressure angle" in f.axes[0].get_title()]
    labels = [t.get_text() for t in fig.axes[0].texts]
    assert len(labels) >= 2 and all(s.endswith("°") for s in labels), labels
    peak = float(np.degrees(np.max(res.profile.pressure)))
    assert max(float(s.rstrip("°")) for s in labels) == pytest.approx(peak, abs=0.05)


# --- smaller items ----------------------------------------------------------------------


def test_flywheel_of_a_change_point_linkage_names_its_branch_change(tmp_path):
    """A change-point four-bar (s + l = p + q: 40 + 100 = 60 + 80 mm) passes a position
    with all its links in line every turn and comes back on its other branch: its cycle is
    two turns. It has no gears, which the note used to give as the cause."""
    text = FOURBAR.read_text()
    for old, new in [
        ("O4: [87.5, 0]", "O4: [80, 0]"),
        ("A: [26.5, 0]", "A: [40, 0]"),
        ("B: [105.6, 0]", "B: [100, 0]"),
        ("B: [59, 0]", "B: [60, 0]"),
        ("start: 0 deg", "start: 10 deg"),
    ]:
        assert old in text, old
        text = text.replace(old, new)
    f = tmp_path / "change.yaml"
    f.write_text(text)
    r = _invoke("flywheel", f, "--no-check", "-o", tmp_path / "fw")
    assert r.exit_code == 0, r.output
    assert "the machine's cycle is 2 turns of the driver (720 deg)" in r.output, r.output
    assert "gear" not in r.output.replace("no gears", "")
    assert "changes assembly branch where its links line up" in r.output


def test_the_gear_train_still_names_its_gear_ratios():
    from mechsolve import api
    from mechsolve.analyses.dynamics.cycle import cycle_cause

    assert cycle_cause(api.load(MECH / "gear-train.yaml")) == "its gear ratios"


def test_a_single_position_is_one_sample(tmp_path):
    """A sweep of range 0: "(1 sample)", not "(1 samples)"."""
    f = _with_driver(tmp_path, "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}",
                     "sweep: {range: 0 deg, step: 2 deg}")  # fmt: skip
    r = _invoke("run", f, "-o", tmp_path / "o", "--no-plots")
    assert r.exit_code == 0, r.output
    assert "driving torque (1 sample): " in r.output and "peak reactions (1 sample): " in r.output
    assert "samples)" not in r.output


def test_simulation_plots_place_their_legends_without_a_search(tmp_path, monkeypatch):
    """A long simulation printed Matplotlib's UserWarning 'Creating legend with
    loc="best" can be slow with large amounts of data' (the reactions over 200001 time
    samples): the search for the best place took over a second. Each legend of the
    simulation's plots is now placed where it is drawn; a clock that makes every search
    look slow (as 400 s of simulation did) finds none to warn about."""
    import itertools
    import warnings

    import matplotlib.legend

    from mechsolve import api
    from mechsolve.analyses.dynamics import simulate
    from mechsolve.analyses.dynamics.plots import write_simulation_plots

    sim = simulate(api.load(MECH / "motor-linkage.yaml"))
    assert sim.forces is not None  # the reactions' plot is drawn
    clock = itertools.count(0.0, 2.0)  # 2 s between any two readings
    monkeypatch.setattr(matplotlib.legend.time, "perf_counter", lambda: next(clock))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        files = write_simulation_plots(sim, sim.model, tmp_path)
    assert "simulation-reactions.png" in [p.name for p in files]
    slow = [str(w.message) for w in seen if "loc=" in str(w.message)]
    assert slow == []
