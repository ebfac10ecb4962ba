"""The layout README describes: data flows one way through the package's modules.

Every import between mechsolve's modules counts (at the top, inside functions, and under
``TYPE_CHECKING``); the graph must have no cycle.
"""

from __future__ import annotations

import ast
import os
from pathlib import Path

import mechsolve

PKG = Path(mechsolve.__file__).parent


def module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_of(path: Path) -> set[str]:
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.startswith("mechsolve"):
                out.add(target)
                for alias in node.names:  # "from . import core": a module
                    out.add(f"{target}.{alias.name}")
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("mechsolve")}
    return out


def graph() -> dict[str, set[str]]:
    mods = {module_name(p): p for p in PKG.rglob("*.py")}
    g = {}
    for name, path in mods.items():
        deps = set()
        for target in imports_of(path):
            # the deepest module the import names
            while target and target not in mods:
                target = target.rpartition(".")[0]
            if target and target != name:
                deps.add(target)
        g[name] = deps
    return g


def find_cycle(g: dict[str, set[str]]) -> list[str] | None:
    color: dict[str, int] = {}
    stack: list[str] = []
    for root in sorted(g):
        if color.get(root):
            continue
        todo = [(root, iter(sorted(g[root])))]
        color[root] = 1
        stack.append(root)
        while todo:
            node, it = todo[-1]
            nxt = next(it, None)
            if nxt is None:
                todo.pop()
                stack.pop()
                color[node] = 2
                continue
            if color.get(nxt) == 1:
                return stack[stack.index(nxt) :] + [nxt]
            if not color.get(nxt):
                color[nxt] = 1
                stack.append(nxt)
                todo.append((nxt, iter(sorted(g.get(nxt, ())))))
    return None


def test_no_import_cycles():
    g = graph()
    # the package's __init__ re-exports the API: it may import anything, nothing imports it
    g.pop("mechsolve", None)
    for name, deps in g.items():
        deps.discard("mechsolve")
        # a subpackage's __init__ may gather its own modules (mechsolve.model's dataclasses
        # and its parser): that is one unit, not a cycle between stages
        deps -= {d for d in deps if d.startswith(name + ".")}
    cycle = find_cycle(g)
    assert cycle is None, " -> ".join(cycle)


def test_the_solver_core_does_not_reach_up_to_results_or_writers():
    g = graph()
    low = ["mechsolve.sweep", "mechsolve.core", "mechsolve.solution", "mechsolve.conditioning"]
    for mod in low:
        seen, todo = set(), [mod]
        while todo:
            m = todo.pop()
            for d in g.get(m, ()):
                if d not in seen:
                    seen.add(d)
                    todo.append(d)
        bad = {d for d in seen if d.startswith(("mechsolve.results", "mechsolve.writers"))}
        assert not bad, (mod, bad)


def test_import_linter_contracts():
    """The layer contracts of pyproject.toml ([tool.importlinter]) hold: import-linter,
    run on the source tree (imports inside functions and under TYPE_CHECKING count)."""
    from importlinter.cli import lint_imports

    root = PKG.parent
    assert (root / "pyproject.toml").exists(), "run from a checkout"
    here = os.getcwd()
    os.chdir(root)
    try:
        code = lint_imports(config_filename=str(root / "pyproject.toml"), no_cache=True)
    finally:
        os.chdir(here)
    assert code == 0, "import-linter: a layer contract is broken (run lint-imports)"
