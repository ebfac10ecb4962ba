"""The fast tier (issue 29, item 5): `python -m pytest -m "not slow"` for the edit-test
loop, the whole suite in CI. The list of slow tests must keep naming real tests, leave
each test file a fast representative, and mark what it names."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

from conftest import ROOT, slow_entries

TESTS = ROOT / "tests"
# whole modules in the slow tier, each covered in the fast tier by the file named
WHOLE = {
    "tests/test_fuzz.py": "test_bad_input.py, test_hostile_input.py",
    "tests/test_properties.py": "test_closed_form.py",
    "tests/test_report_browser.py": "test_report.py",
}


def _functions(path) -> set[str]:
    return set(re.findall(r"^(?:async )?def (test_\w+)\(", path.read_text(), re.M))


def test_the_slow_marker_is_registered(pytestconfig):
    assert any(m.startswith("slow:") for m in pytestconfig.getini("markers"))


def test_every_entry_names_a_test_and_every_file_keeps_a_fast_one():
    entries = slow_entries()
    assert entries, "tests/slow_tests.txt lists no test"
    named: dict[str, set[str]] = {}
    for e in entries:
        module, _, rest = e.partition("::")
        path = ROOT / module
        assert path.is_file(), f"slow_tests.txt: {module} is not a test file"
        if not rest:
            assert module in WHOLE, f"slow_tests.txt: the whole of {module} is slow: say why"
            continue
        assert "[" not in rest or rest.endswith("]"), f"slow_tests.txt: {e}: cut short"
        name = rest.split("[", 1)[0]
        assert name in _functions(path), f"slow_tests.txt: {e}: no such test in {module}"
        if "[" not in rest:
            named.setdefault(module, set()).add(name)
    for module, names in named.items():
        left = _functions(ROOT / module) - names
        assert left, f"{module}: every test is slow; keep one in the fast tier"


@pytest.mark.slow
def test_the_marker_is_applied():
    out = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-o", "addopts=", "-m", "slow",
         "-p", "no:cacheprovider", "tests/test_cli.py"],
        cwd=ROOT, capture_output=True, text=True, check=False,
    ).stdout  # fmt: skip
    assert "tests/test_cli.py::test_real_process" in out
    assert "test_check_every_example[fourbar.yaml]" not in out
