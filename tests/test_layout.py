"""The layout CONTRIBUTING.md describes: each folder of mechsolve/ is one layer, and data
flows one way, from the file (model) to the command line.

import-linter checks it from pyproject.toml's ``[tool.importlinter]`` contracts: a layers
contract over the folders (exhaustive: a new folder must be placed in it), no import loop
between sibling folders at any depth, and the solver never importing the benchmarks.
Imports inside functions and under ``TYPE_CHECKING`` count.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import mechsolve

PKG = Path(mechsolve.__file__).parent
ROOT = PKG.parent


def lint(root: Path) -> subprocess.CompletedProcess:
    """import-linter on the source tree at ``root``, in a process of its own whose path
    finds that tree's mechsolve first."""
    code = "import sys; from importlinter.cli import lint_imports; sys.exit(lint_imports())"
    env = {**os.environ, "PYTHONPATH": str(root)}
    return subprocess.run(
        [sys.executable, "-c", code], cwd=root, env=env, capture_output=True, text=True
    )


def test_import_linter_contracts():
    """The contracts hold on the source tree."""
    assert (ROOT / "pyproject.toml").exists(), "run from a checkout"
    out = lint(ROOT)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-2000:]
    assert "0 broken" in out.stdout


def test_every_folder_is_a_layer():
    """Every subpackage of mechsolve is one of the declared layers (a module at the root
    other than the facade and the package's own files would have no layer)."""
    text = (ROOT / "pyproject.toml").read_text()
    block = text[text.index('type = "layers"') :]
    block = block[block.index("\nlayers = [") + len("\nlayers = [") :]
    block = block[: block.index("]")]
    layers = [x.strip().strip('",') for x in block.split() if x.strip().strip('",')]
    children = {p.stem for p in PKG.iterdir() if p.suffix == ".py" or (p / "__init__.py").exists()}
    children -= {"__init__", "__main__"}
    assert children == set(layers), children ^ set(layers)
    assert layers[-1] == "base" and layers[0] == "cli"


@pytest.mark.parametrize(
    "module, line, broken",
    [
        # the core reaching up to the results, at the top of a module
        ("core/sweep.py", "from mechsolve.results.results import Results", "mechsolve.core"),
        # the base reaching up to the API, hidden inside a function
        (
            "base/numerics.py",
            "def _sneak():\n    from mechsolve import api  # noqa\n",
            "mechsolve.base",
        ),
        # a writer importing an analysis under TYPE_CHECKING
        (
            "writers/plots.py",
            "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
            "    from mechsolve.analyses.dynamics import SimulationResults  # noqa\n",
            "mechsolve.writers",
        ),
    ],
)
def test_an_upward_import_breaks_the_contract(tmp_path, module, line, broken):
    """A deliberate upward import, in a copy of the tree, fails import-linter with a
    message that names the layers and the import."""
    shutil.copytree(PKG, tmp_path / "mechsolve", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(
        ROOT / "mechsolve_bench",
        tmp_path / "mechsolve_bench",
        ignore=shutil.ignore_patterns("__pycache__", "data"),
    )
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    target = tmp_path / "mechsolve" / module
    target.write_text(target.read_text() + "\n" + line + "\n")
    out = lint(tmp_path)
    assert out.returncode != 0, out.stdout
    assert "BROKEN" in out.stdout
    assert f"{broken} is not allowed to import" in out.stdout, out.stdout[-3000:]
