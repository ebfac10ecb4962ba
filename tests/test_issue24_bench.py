"""Issue 24, item 7: the benchmarks are a package beside the solver (``mechsolve_bench``),
not inside it.

The solver's import graph -- every import of every module under ``mechsolve/``, at the
top, inside functions and under ``TYPE_CHECKING``, read from the source with ``ast`` --
reaches no module of the bench package (nor the peers it compares: pylinkage, numba,
exudyn), except the one lazy import of the ``mechsolve bench`` command. A fresh
interpreter that imports every solver module and solves a mechanism has loaded none of
them; without the bench package, ``mechsolve bench`` says how to install it.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

import mechsolve
from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
PKG = Path(mechsolve.__file__).parent

# the bench package, where it is now and where it was (inside the solver)
BENCH = ("mechsolve_bench", "mechsolve.bench")
# the peers the bench compares: the solver imports none of them
PEERS = ("pylinkage", "numba", "exudyn")
# the one allowed edge: (module, function) of the `mechsolve bench` command's lazy import
ALLOWED = {("mechsolve.cli.commands.bench", "_bench_tool")}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is(name: str, prefixes: tuple[str, ...]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def _imports(path: Path) -> list[tuple[str, str | None, int]]:
    """Every module ``path`` imports: (target, the enclosing function or None, line).

    Relative imports are resolved against the module's package; ``from a import b``
    counts both ``a`` and ``a.b`` (b may be a module); ``importlib.import_module("x")``
    and ``__import__("x")`` with a literal name count too.
    """
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: list[tuple[str, str | None, int]] = []

    def visit(node: ast.AST, func: str | None) -> None:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            func = node.name
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            out.append((target, func, node.lineno))
            out.extend((f"{target}.{a.name}", func, node.lineno) for a in node.names)
        elif isinstance(node, ast.Import):
            out.extend((a.name, func, node.lineno) for a in node.names)
        elif isinstance(node, ast.Call) and node.args:
            f = node.func
            callee = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
            arg = node.args[0]
            if (
                callee in ("import_module", "__import__")
                and isinstance(arg, ast.Constant)
                and isinstance(arg.value, str)
            ):
                out.append((arg.value, func, node.lineno))
        for child in ast.iter_child_nodes(node):
            visit(child, func)

    visit(ast.parse(path.read_text(encoding="utf-8")), None)
    return out


def _solver_modules() -> list[Path]:
    return sorted(PKG.rglob("*.py"))


def test_the_solver_package_holds_no_bench_module():
    names = {_module_name(p) for p in _solver_modules()}
    inside = sorted(n for n in names if _is(n, BENCH))
    assert not inside, f"bench modules inside the solver package: {inside}"
    # (a folder mechsolve/bench/ left with only an ignored __pycache__ is no module)
    assert not list((PKG / "bench").glob("**/*.yaml"))


def test_no_solver_module_imports_the_bench_but_the_bench_command():
    bad, allowed = [], []
    for path in _solver_modules():
        mod = _module_name(path)
        for target, func, line in _imports(path):
            if _is(target, BENCH):
                (allowed if (mod, func) in ALLOWED else bad).append(f"{mod}:{line} {target}")
    assert not bad, "the solver imports the bench package:\n" + "\n".join(bad)
    # the bench command's lazy import is there (else this test checks nothing of it)
    assert allowed == [f"mechsolve.cli.commands.bench:{_bench_tool_line()} mechsolve_bench"], (
        allowed
    )


def _bench_tool_line() -> int:
    tree = ast.parse((PKG / "cli" / "commands" / "bench.py").read_text(encoding="utf-8"))
    fn = next(
        n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == "_bench_tool"
    )
    return next(n.lineno for n in ast.walk(fn) if isinstance(n, ast.Import))


def test_the_bench_import_is_inside_a_function_only_the_bench_command_calls():
    """The allowed edge is lazy: ``_bench_tool`` is called by the ``bench`` command and by
    nothing else in the solver package."""
    callers = []
    for path in _solver_modules():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Module)):
                continue
            for node in ast.walk(fn):
                if isinstance(node, ast.Name) and node.id == "_bench_tool":
                    if isinstance(fn, ast.Module):
                        continue  # counted in its function
                    callers.append((_module_name(path), fn.name))
    assert set(callers) == {("mechsolve.cli.commands.bench", "bench")}, callers


# the optional compiled Newton kernels (the `fast` extra) are numba's by design: that one
# module imports it, and only mechsolve.groups.compiled imports that module, lazily, when
# the compiled path is asked for (the fresh process below checks that a solve does not)
COMPILED_KERNELS = "mechsolve.groups.kernels"


def test_the_solver_imports_no_peer():
    bad = [
        f"{_module_name(p)}:{line} {t}"
        for p in _solver_modules()
        for t, _, line in _imports(p)
        if _is(t, PEERS) and not (_module_name(p) == COMPILED_KERNELS and _is(t, ("numba",)))
    ]
    assert not bad, bad


def test_the_bench_package_is_where_the_cli_looks():
    """The graph test above matches the real import: the bench is ``mechsolve_bench``, a
    top-level package beside ``mechsolve`` with its data, and the command finds it."""
    import mechsolve_bench

    here = Path(mechsolve_bench.__file__).parent
    assert here.parent == PKG.parent
    assert {"crane.yaml", "fourbar.yaml", "motor-linkage.yaml"} <= {
        p.name for p in (here / "data").iterdir()
    }
    from mechsolve.cli.commands.bench import _bench_tool

    assert _bench_tool() is mechsolve_bench


def test_a_fresh_solver_process_loads_no_bench_and_no_peer():
    """Import every module of the solver package (the CLI included) and solve a mechanism
    with forces: nothing of the bench package or of its peers is loaded."""
    code = (
        "import importlib, pkgutil, sys\n"
        "import mechsolve\n"
        "for m in pkgutil.walk_packages(mechsolve.__path__, 'mechsolve.'):\n"
        "    if not m.name.endswith('.__main__') and m.name != " + repr(COMPILED_KERNELS) + ":\n"
        "        importlib.import_module(m.name)\n"
        "res = mechsolve.solve(mechsolve.load(sys.argv[1]))\n"
        "assert res is not None\n"
        "bad = sorted(n for n in sys.modules if n.split('.')[0] in "
        "('mechsolve_bench', 'pylinkage', 'numba', 'exudyn') or n.startswith('mechsolve.bench'))\n"
        "print('loaded:', bad)\n"
    )  # (not __main__, which runs the command line, nor the compiled kernels, numba's)
    p = subprocess.run(
        [sys.executable, "-c", code, str(ROOT / "mechanisms" / "fourbar.yaml")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=dict(os.environ, MPLBACKEND="Agg"),
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip().splitlines()[-1] == "loaded: []", p.stdout


def test_bench_without_the_bench_package_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "mechsolve_bench", None)  # its import now fails
    r = CliRunner().invoke(main, ["bench", "--quick", "--case", "startup"])
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    assert "mechsolve_bench" in r.output and "pip install 'mechsolve[bench]'" in r.output


def test_bench_with_a_broken_dependency_is_not_called_an_install_problem(monkeypatch):
    """A module the bench itself imports missing is a bug (exit 4), not the message to
    install the bench package."""
    import builtins

    real = builtins.__import__

    def broken(name, *args, **kwargs):
        if name == "mechsolve_bench":  # found, but its own import of a module fails
            raise ModuleNotFoundError("No module named 'something_else'", name="something_else")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", broken)
    r = CliRunner().invoke(main, ["bench", "--quick", "--case", "startup"])
    assert r.exit_code == 4, r.output
    assert "pip install" not in r.output


@pytest.mark.parametrize("args", [["bench", "--help"], ["--help"]])
def test_help_needs_no_bench(monkeypatch, args):
    monkeypatch.setitem(sys.modules, "mechsolve_bench", None)
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
