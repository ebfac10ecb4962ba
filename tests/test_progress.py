"""The progress bar of long (streamed) runs: on a terminal only, never under -q or in CI,
and nothing at all when tqdm is not installed."""

from __future__ import annotations

import fcntl
import io
import math
import os
import pty
import struct
import subprocess
import sys
import termios

import pytest

import mechsolve as ms
import mechsolve.cli.commands.run as run_cmd
import mechsolve.cli.kit as kit
import mechsolve.cli.main as cli

from conftest import MECH

# the command line with the bar's delay removed, so that a short run shows it
RUN_NOW = (
    "import sys, mechsolve.cli.kit as k, mechsolve.cli.main as c; "
    "k.PROGRESS_DELAY = 0; sys.exit(c.main())"
)


class FakeTTY(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_decision():
    env: dict[str, str] = {}
    assert kit.progress_wanted(False, FakeTTY(), env)
    assert not kit.progress_wanted(True, FakeTTY(), env)  # -q
    assert not kit.progress_wanted(False, io.StringIO(), env)  # not a terminal
    for ci in ("1", "true", "yes"):
        assert not kit.progress_wanted(False, FakeTTY(), {"CI": ci})
    for ci in ("", "0", "false"):  # set but saying "not CI"
        assert kit.progress_wanted(False, FakeTTY(), {"CI": ci})
    with open(os.devnull) as closed:
        pass
    assert not kit.progress_wanted(False, closed, env)  # isatty raises ValueError


def test_without_tqdm_no_bar_and_no_error(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "tqdm", None)  # import tqdm raises ImportError
    assert not kit.progress_wanted(False, FakeTTY(), {})
    monkeypatch.setattr(kit, "progress_wanted", lambda quiet, *a: True)  # pretend a terminal
    monkeypatch.setattr(run_cmd, "_progress_bar", lambda total, quiet: None)
    monkeypatch.setenv("MECHSOLVE_STREAM_ABOVE", "100")
    from click.testing import CliRunner

    r = CliRunner().invoke(
        cli.main, ["run", str(MECH / "fourbar.yaml"), "--no-plots", "-o", str(tmp_path)]
    )
    assert r.exit_code == 0, r.output


def test_stream_reports_each_chunk(tmp_path):
    calls: list[int] = []
    mech = ms.load(MECH / "fourbar.yaml")
    ms.stream(mech, tmp_path / "s.csv", step=2 * math.pi / 1500, chunk=317, progress=calls.append)
    assert len(calls) == 5 and sum(calls) == 1501  # every position once, chunk by chunk


def _run(tmp_path, *extra: str, tty: bool = True, env_extra: dict[str, str] | None = None):
    """``mechsolve run`` of a streamed sweep in a real process, its stderr on a pty (or
    a pipe); returns (exit code, stdout, what reached stderr)."""
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    env.update({"MECHSOLVE_STREAM_ABOVE": "1000"}, **(env_extra or {}))
    args = [sys.executable, "-c", RUN_NOW, "run", str(MECH / "fourbar.yaml")]
    args += ["--step", "0.05 deg", "--no-plots", "-o", str(tmp_path / "out"), *extra]
    if not tty:
        p = subprocess.run(args, capture_output=True, text=True, env=env, timeout=120)
        return p.returncode, p.stdout, p.stderr
    master, slave = pty.openpty()
    # a new pty has no size (0 columns: tqdm would draw nothing); give it a terminal's
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=slave, env=env)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    out, _ = p.communicate(timeout=120)
    os.close(master)
    return p.returncode, out.decode(), b"".join(chunks).decode(errors="replace")


def test_bar_on_a_terminal(tmp_path):
    code, out, err = _run(tmp_path)
    assert code == 0, err
    assert "solving" in err and "7.20k/7.20k" in err and "positions/s" in err, err
    assert "Traceback" not in err
    assert "7201 of 7201 positions solved" in out  # the summary is unchanged, on stdout


@pytest.mark.parametrize(
    "extra, tty, env",
    [((), False, {}), (("-q",), True, {}), ((), True, {"CI": "1"})],
    ids=["not-a-terminal", "quiet", "CI"],
)
def test_no_bar(tmp_path, extra, tty, env):
    code, out, err = _run(tmp_path, *extra, tty=tty, env_extra=env)
    assert code == 0, err
    assert "solving" not in err and "positions/s" not in err, err
    assert err.strip() == ""
