"""``mechsolve bench --quick`` runs every case, so that the benchmarks cannot rot.

Nothing here asserts a timing: only that each case runs, prints its table and its final
line, that the errors it reports against its references are at rounding level, and that
the optional peers are skipped cleanly when they are not installed.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys

import pytest

CASES = [
    "fourbar-kinematics",
    "crane-kinematics",
    "fourbar-kinetostatics",
    "crane-kinetostatics",
    "chain-growth",
    "positions-growth",
    "stream",
    "startup",
    "peers",
]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    png = tmp_path_factory.mktemp("bench") / "wp.png"
    out = subprocess.run(
        [sys.executable, "-m", "mechsolve", "bench", "--quick", "--plot", str(png)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    return out, png


def _section(text: str, name: str) -> str:
    m = re.search(rf"^== {re.escape(name)}:.*?(?=^== |\Z)", text, re.S | re.M)
    assert m, f"no section {name!r} in:\n{text}"
    return m.group(0)


def test_every_case_runs(quick):
    out, png = quick
    assert out.returncode == 0, out.stderr
    assert "Traceback" not in out.stdout + out.stderr
    for name in CASES:
        _section(out.stdout, name)
    assert png.exists() and png.stat().st_size > 10_000


@pytest.mark.parametrize(
    "name, lines",
    [
        ("fourbar-kinematics", ["ratio mechsolve (whole call) / closed form (textbook):"]),
        ("crane-kinematics", ["ratio mechsolve (whole call) / closed form:"]),
        ("fourbar-kinetostatics", ["ratio mechsolve (whole call) / free bodies by hand:"]),
        ("crane-kinetostatics", ["ratio mechsolve (whole call) / free bodies by hand:"]),
        ("chain-growth", ["fitted exponent of time against N:"]),
        ("positions-growth", ["fitted exponent of time against the number of positions:"]),
        ("stream", ["peak resident memory:"]),
        ("startup", ["targets:"]),
    ],
)
def test_case_prints_its_final_line(quick, name, lines):
    sec = _section(quick[0].stdout, name)
    for line in lines:
        assert line in sec
        m = re.search(re.escape(line) + r"\s*([0-9.]+)", sec)
        if m:
            assert float(m.group(1)) > 0


@pytest.mark.parametrize(
    "name",
    ["fourbar-kinematics", "crane-kinematics", "fourbar-kinetostatics", "crane-kinetostatics"],
)
def test_reported_errors_are_at_rounding_level(quick, name):
    """Every error column of the mechsolve rows (and of the second hand-written form)."""
    sec = _section(quick[0].stdout, name)
    errors = []
    for row in sec.splitlines():
        if row.strip().startswith(("mechsolve", "closed form by hand, vector")):
            errors += [float(x) for x in re.findall(r"\d\.\de[+-]\d\d", row)]
    assert errors, sec
    assert max(errors) < 1e-9, sec


def test_streamed_sweep_writes_every_row(quick):
    sec = _section(quick[0].stdout, "stream")
    m = re.search(r"(\d+) rows of (\d+); peak resident memory (\d+) MB", sec)
    assert m, sec
    assert m.group(1) == m.group(2)


@pytest.mark.skipif(
    importlib.util.find_spec("pylinkage") is not None
    or importlib.util.find_spec("exudyn") is not None,
    reason="a peer is installed here",
)
def test_missing_peers_are_skipped_cleanly(quick):
    sec = _section(quick[0].stdout, "peers")
    assert "pylinkage: not installed" in sec and "exudyn: not installed" in sec
