from __future__ import annotations

import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MECH = ROOT / "mechanisms"
# the example mechanisms (mechanisms/ also holds a cam design, which has no links)
MECHANISMS = sorted(p.name for p in MECH.glob("*.yaml") if "\nlinks:" in p.read_text())
DATA = Path(__file__).resolve().parent / "data"


def ref(name: str) -> dict:
    return json.loads((DATA / name).read_text())


@pytest.fixture
def data():
    return ref


# -- the fast tier: `python -m pytest -m "not slow"` ------------------------------------
# The tests that take longest on the project's 2-core machine are marked `slow`, either
# with `@pytest.mark.slow` in their file or listed in tests/slow_tests.txt (a whole module,
# a test, or one parametrisation, as pytest names them): the edit-test loop runs the rest,
# CI runs everything. The list is kept apart so that marking a test never edits its file;
# tests/test_issue29_tiers.py checks that every entry still names a test.
SLOW_LIST = Path(__file__).resolve().parent / "slow_tests.txt"


def slow_entries() -> list[str]:
    """The node ids of tests/slow_tests.txt: a comment line starts with ``#``, a note
    after an id with two spaces and ``#`` (an id may hold a ``#`` of its own)."""
    out = []
    for line in SLOW_LIST.read_text(encoding="utf-8").splitlines():
        line = line.split("  #", 1)[0].strip()
        if line and not line.startswith("#"):
            out.append(line)
    return out


def pytest_collection_modifyitems(config, items):
    slow = set(slow_entries())
    for item in items:
        nodeid = item.nodeid
        module = nodeid.split("::", 1)[0]
        if nodeid in slow or module in slow or nodeid.split("[", 1)[0] in slow:
            item.add_marker(pytest.mark.slow)
