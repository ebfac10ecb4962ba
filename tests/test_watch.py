"""Watch mode in a real process: save a change, see the new run and what moved; save a
broken file, see the message and the watch going on; fix it, see the run again."""

from __future__ import annotations

import queue
import signal
import subprocess
import sys
import threading
import time

import pytest

from conftest import MECH

pytest.importorskip("watchfiles")  # in the test group: CI has it


class Lines:
    """The process's stdout, line by line, read on a thread."""

    def __init__(self, proc: subprocess.Popen) -> None:
        self.q: queue.Queue[str] = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, args=(proc,), daemon=True).start()

    def _read(self, proc) -> None:
        for line in proc.stdout:
            self.q.put(line.rstrip("\n"))

    def until(self, text: str, timeout: float = 90.0) -> list[str]:
        """The lines up to the first that contains ``text``."""
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


def test_watch_runs_again_on_save_and_survives_a_broken_file(tmp_path):
    f = tmp_path / "fourbar.yaml"
    good = (MECH / "fourbar.yaml").read_text()
    f.write_text(good)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "mechsolve",
            "run",
            str(f),
            "--watch",
            "--no-plots",
            "-o",
            str(tmp_path / "out"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        lines = Lines(proc)
        first = lines.until("Ctrl-C stops")
        assert any("181 of 181 positions solved" in x for x in first)
        time.sleep(0.5)
        f.write_text(good.replace("A: [26.5, 0]", "A: [28, 0]"))  # a longer crank
        moved = lines.until("Ctrl-C stops")
        text = "\n".join(moved)
        assert "changed since the last run:" in text
        assert "rocker swing:" in text and "->" in text
        time.sleep(0.5)
        f.write_text(good.replace("  O4: [ground, rocker]", "  O4: [ground, rockr]"))
        broken = "\n".join(lines.until("fix it and save"))
        assert "fourbar.yaml:" in broken and "joints.O4" in broken and "rockr" in broken
        assert "Traceback" not in broken and proc.poll() is None  # still watching
        time.sleep(0.5)
        f.write_text(good)
        again = "\n".join(lines.until("Ctrl-C stops"))
        assert "181 of 181 positions solved" in again
        assert "rocker swing:" in again  # back from the 28 mm crank's swing
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=20)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 130  # Ctrl-C, as in every command


def test_report_watch_rewrites_the_report_on_save(tmp_path):
    f = tmp_path / "slider.yaml"
    good = (MECH / "slider-crank.yaml").read_text()
    f.write_text(good)
    html = tmp_path / "r.html"
    proc = subprocess.Popen(
        [sys.executable, "-m", "mechsolve", "report", str(f), "--watch", "-o", str(html)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        lines = Lines(proc)
        lines.until("Ctrl-C stops", timeout=180)
        first = html.stat().st_mtime_ns
        time.sleep(0.5)
        f.write_text(good.replace("name: slider-crank", "name: watched slider-crank"))
        lines.until("Ctrl-C stops", timeout=180)
        assert html.stat().st_mtime_ns > first
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=20)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 130  # Ctrl-C, as in every command
