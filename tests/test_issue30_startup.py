"""Start-up of the command line: a process imports only what its command needs.

``mechsolve run FILE --no-plots`` is a whole process whose time is mostly imports (NumPy
alone is about half of it). These tests look at ``sys.modules`` in a fresh process after
the command (not at timings): no plotting, SciPy, templating, cluster or compiler
package, no other command's module, and no requirements machinery for a file without
requirements. The command list itself is checked against the files of
``mechsolve/cli/commands/``, since each command's module is imported only when it is
looked up.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

ROOT = Path(__file__).resolve().parent.parent
FOURBAR = ROOT / "mechanisms" / "fourbar.yaml"
COMMANDS_DIR = ROOT / "mechsolve" / "cli" / "commands"

# run as `python -m mechsolve ...` does, then list what the process imported
_PROBE = """
import json, runpy, sys
sys.argv = ["mechsolve"] + {args!r}
code = 0
try:
    runpy.run_module("mechsolve", run_name="__main__")
except SystemExit as exc:
    code = exc.code
sys.stdout.flush()
print(json.dumps([code, sorted(sys.modules)]))
"""

# packages a run without plots never needs (each costs 10 ms to 0.5 s to import)
NOT_NEEDED = (
    "matplotlib",
    "scipy",
    "jinja2",
    "dask",
    "numba",
    "ezdxf",
    "tqdm",
    "numpy.ma",
    "importlib.metadata",
)


def _modules_after(args: list[str]) -> tuple[int, set[str]]:
    import json

    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(args=args)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=True,
    )
    code, mods = json.loads(out.stdout.strip().splitlines()[-1])
    return code, set(mods)


def _loaded(mods: set[str], package: str) -> list[str]:
    return sorted(m for m in mods if m == package or m.startswith(package + "."))


def _command_modules() -> list[str]:
    return sorted(p.stem for p in COMMANDS_DIR.glob("*.py") if p.stem != "__init__")


@pytest.fixture(scope="module")
def run_modules(tmp_path_factory) -> set[str]:
    out = tmp_path_factory.mktemp("run")
    code, mods = _modules_after(["run", str(FOURBAR), "--no-plots", "-o", str(out)])
    assert code == 0
    assert (out / "results.csv").stat().st_size > 0
    return mods


@pytest.mark.parametrize("package", NOT_NEEDED)
def test_run_without_plots_does_not_import(run_modules, package):
    assert _loaded(run_modules, package) == []


def test_run_imports_only_its_own_command(run_modules):
    """The other commands' modules (report, sweep, animate, ...) are not imported."""
    loaded = sorted(
        m.rsplit(".", 1)[1] for m in run_modules if m.startswith("mechsolve.cli.commands.")
    )
    assert loaded == ["run"]


def test_run_without_requirements_skips_their_checker(run_modules):
    """fourbar.yaml has no 'requirements:': nothing checks or tabulates verdicts."""
    import yaml

    assert "requirements" not in yaml.safe_load(FOURBAR.read_text())
    assert "mechsolve.results.requirements" not in run_modules


def test_every_command_module_is_a_command():
    """Each file of mechsolve/cli/commands/ is one command of the group, reachable by its
    name (``main.commands``, ``from mechsolve.cli.main import NAME``) and listed by
    ``mechsolve --help`` with its own first line of help."""
    import click

    from mechsolve.cli import main as cli_main

    names = _command_modules()
    assert sorted(cli_main.main.commands) == names
    assert len(cli_main.main.commands) == len(names)
    out = CliRunner().invoke(cli_main.main, ["--help"]).output
    listed = out.split("Commands:", 1)[1]
    for name in names:
        cmd = cli_main.main.commands[name]
        assert isinstance(cmd, click.Command) and cmd.name == name
        assert getattr(cli_main, name) is cmd
        assert name in cli_main.main.commands
        assert f"\n  {name} " in listed, name
    assert "nosuch" not in cli_main.main.commands
    with pytest.raises(KeyError):
        cli_main.main.commands["nosuch"]
    with pytest.raises(AttributeError):
        cli_main.nosuch  # noqa: B018


def test_unknown_command_still_suggests(tmp_path):
    """A mistyped command gets click's usage error (exit 2) and the nearest name."""
    from mechsolve.cli.main import main

    res = CliRunner().invoke(main, ["rn", str(FOURBAR)])
    assert res.exit_code == 2
    assert "Did you mean 'run'?" in res.output


def test_help_imports_no_numpy():
    """`mechsolve --help` lists every command (importing their modules) without NumPy."""
    code, mods = _modules_after(["--help"])
    assert code == 0
    assert _loaded(mods, "numpy") == []
    assert (
        sorted(m.rsplit(".", 1)[1] for m in mods if m.startswith("mechsolve.cli.commands."))
        == _command_modules()
    )
