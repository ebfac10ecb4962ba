"""The README's commands and the documentation's example file and promises stay true."""

from __future__ import annotations

import re

import mechsolve as ms

from conftest import ROOT


def readme() -> str:
    return (ROOT / "README.md").read_text()


def page(name: str) -> str:
    """A page of the documentation site (docs/), where README's longer sections went."""
    return (ROOT / "docs" / name).read_text()


def test_readme_example_file_solves():
    """The commented example file of the how-to (README's, before the site had it)."""
    text = page("how-to/new-mechanism.md")
    block = text.split("## The mechanism file", 1)[1].split("```yaml", 1)[1].split("```")[0]
    mech = ms.loads(block, file="README example")
    res = ms.solve(mech)
    assert res.ok.all() and res.forces is not None and res.forces.ok.all()
    ms.solve(ms.loads(block, variant="reversed"))


def test_readme_first_commands_and_ci_agree():
    lines = [ln for ln in readme().splitlines() if ln.startswith("pip install")]
    assert lines[0] == "pip install . && mechsolve run mechanisms/crane.yaml"
    test_cmd = lines[1]
    assert "python -m pytest" in test_cmd
    ci = (ROOT / ".ci" / "run").read_text()
    assert re.search(r"grep -m1 -E '\^pip install \.\*python -m pytest' README.md", ci)


def test_every_hard_case_promise_names_a_test_that_exists():
    """The hard-cases page (README's hard-case section, moved) names, in brackets, the test
    that proves each promise: every name must be a test function (or file) of this suite."""
    section = page("theory/hard-cases.md")
    refs = {n for b in re.findall(r"\[(`[^\]]+`)\]", section) for n in re.findall(r"`([^`]+)`", b)}
    assert len(refs) >= 8
    tests = {p.name: p.read_text() for p in (ROOT / "tests").glob("test_*.py")}
    for ref in refs:
        file, _, func = ref.rpartition("::") if "::" in ref else ("", "", ref)
        if ref.endswith(".py") and "::" not in ref:
            assert ref in tests, ref
            continue
        pattern = re.escape(func).replace(r"\*", r"\w*")
        where = [tests[file]] if file else list(tests.values())
        assert any(re.search(rf"^def {pattern}\(", t, re.M) for t in where), ref
