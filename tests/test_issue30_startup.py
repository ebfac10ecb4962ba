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

# run as `python -m mechsolve ...` does, then list what the process imported (from an
# atexit handler: the program ends through it as usual when one is registered)
_PROBE = """
import atexit, json, runpy, sys
def report():
    sys.stdout.flush()
    print(json.dumps(sorted(sys.modules)))
atexit.register(report)
sys.argv = ["mechsolve"] + {args!r}
runpy.run_module("mechsolve", run_name="__main__")
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
    "traceback",  # only to print a bug's traceback (MECHSOLVE_DEBUG)
)


def _modules_after(args: list[str]) -> tuple[int, set[str]]:
    import json

    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(args=args)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    mods = json.loads(out.stdout.strip().splitlines()[-1])
    return out.returncode, set(mods)


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


# -- the end of the process ---------------------------------------------------------
# `mechsolve` (the console script and `python -m mechsolve`) ends with os._exit once its
# output is flushed, skipping the interpreter's teardown, unless an atexit handler or
# another thread still has work to do.

_ENTRY = """
import sys
{setup}
sys.argv = ["mechsolve"] + {args!r}
from mechsolve.cli.main import entry
entry()
"""


def _entry(args: list[str], setup: str = "") -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", _ENTRY.format(setup=setup, args=args)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )


def test_console_script_is_the_entry():
    import tomllib

    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["mechsolve"] == "mechsolve.cli.main:entry"
    assert "entry()" in (ROOT / "mechsolve" / "__main__.py").read_text()


def test_entry_skips_the_teardown_but_keeps_the_output(tmp_path):
    """An object freed only by the interpreter's teardown is never finalised (the
    teardown is skipped), while the summary printed before it reaches the pipe whole and
    the CSV is complete: a header and one row per position of the 2-degree sweep."""
    setup = (
        "class Late:\n"
        "    def __del__(self):\n"
        "        print('torn down', flush=True)\n"
        "keep = Late()\n"
    )
    p = _entry(["run", str(FOURBAR), "--no-plots", "-o", str(tmp_path)], setup)
    assert p.returncode == 0, p.stderr
    assert "torn down" not in p.stdout
    lines = p.stdout.splitlines()
    assert lines[0].startswith("four-bar crank-rocker: 181 of 181 positions solved")
    assert lines[-1].strip() == f"wrote 1 file(s) to {tmp_path}/: results.csv"
    rows = (tmp_path / "results.csv").read_text().splitlines()
    assert len(rows) == 1 + 360 // 2 + 1


def test_entry_runs_atexit_handlers_and_keeps_the_exit_code(tmp_path):
    """With an atexit handler registered (coverage, a pool, Dask), Python ends as usual:
    the handler runs, and the teardown too; the exit code is the command's."""
    setup = (
        "import atexit\n"
        "atexit.register(lambda: print('handler ran', flush=True))\n"
        "class Late:\n"
        "    def __del__(self):\n"
        "        print('torn down', flush=True)\n"
        "keep = Late()\n"
    )
    p = _entry(["run", str(tmp_path / "missing.yaml"), "-o", str(tmp_path / "o")], setup)
    assert p.returncode == 2
    assert "no such file" in p.stderr
    assert "handler ran" in p.stdout and "torn down" in p.stdout


def test_entry_keeps_every_exit_code(tmp_path):
    """0 done, 2 bad input, 5 a requirement failed (the study's four-bar asks for more
    than it gives: its requirements' own verdicts), and a large output piped whole."""
    study = ROOT / "mechanisms" / "studies" / "fourbar-study.yaml"
    p = _entry(["run", str(study), "--no-plots", "-o", str(tmp_path / "s")])
    assert p.returncode == 5, p.stderr
    assert "FAIL" in p.stdout
    assert _entry(["run", "--step", "bogus", str(FOURBAR), "-o", str(tmp_path)]).returncode == 2
    import json

    p = _entry(["schema"])
    assert p.returncode == 0
    assert json.loads(p.stdout)["type"] == "object"
