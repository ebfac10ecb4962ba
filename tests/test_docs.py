"""The README's example file and commands stay true."""

from __future__ import annotations

import re

import mechsolve as ms

from conftest import ROOT


def readme() -> str:
    return (ROOT / "README.md").read_text()


def test_readme_example_file_solves():
    block = readme().split("## The mechanism file", 1)[1].split("```yaml", 1)[1].split("```")[0]
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
