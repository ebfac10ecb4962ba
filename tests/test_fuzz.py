"""Fuzzing: mutants of the example mechanisms must never crash mechsolve.

Every mutant of a file in ``mechanisms/`` (keys deleted, duplicated, retyped; values
swapped; numbers made huge, tiny, negative, zero, NaN or given wrong units; conditions
nested deeply, chained long, given huge numbers, unknown names or garbage) must end with
exit code 0, 1, 2 or 3: never a traceback, never exit 4 ("internal error"). An input error
(exit 2) must name the file and be found in under a second of CPU time (CPU, not wall
clock, so that other work on the machine does not make the test flaky).

The runs are in-process through click's runner with a coarse step and no plots; a few
go through a real subprocess. Hypothesis is derandomized, so CI sees the same cases
every time. ``MECHSOLVE_FUZZ_EXAMPLES=5000`` runs that many cases of each in-process
test instead of the default (about 60 s on two cores).
"""

from __future__ import annotations

import copy
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import pytest
import yaml
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mechsolve.cli.main import main
from mechsolve.model.source import load_text

from conftest import MECHANISMS

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = [ROOT / "mechanisms" / name for name in MECHANISMS]  # not the cam design
TEXTS = {p.name: p.read_text() for p in EXAMPLES}
# read as mechsolve reads them ('on:' is a key, not the YAML 1.1 boolean)
DATA = {p.name: load_text(TEXTS[p.name]).data for p in EXAMPLES}

N = int(os.environ.get("MECHSOLVE_FUZZ_EXAMPLES", "0") or 0)
SETTINGS = dict(
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=list(HealthCheck),
)
CPU_LIMIT = 1.0  # seconds of CPU to refuse an input error
RUN = ["--no-plots", "--step", "30 deg", "-q"]


# --- running a mutant --------------------------------------------------------------


def run_text(text: str, name: str = "mutant.yaml", variant: str | None = None) -> tuple[int, str]:
    """Run ``mechsolve run`` on ``text`` in-process; check the outcome; return it."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / name
        path.write_text(text)
        args = ["run", str(path), "-o", str(Path(tmp) / "out"), *RUN]
        if variant:
            args += ["--variant", variant]
        t0 = time.process_time()
        r = CliRunner().invoke(main, args)
        cpu = time.process_time() - t0
        out = r.output
        described = f"\n--- mutant ---\n{text[:3000]}\n--- output ---\n{out[-3000:]}"
        assert r.exception is None or isinstance(r.exception, SystemExit), (
            repr(r.exception) + described
        )
        assert r.exit_code in (0, 2), f"exit {r.exit_code}" + described
        assert "Traceback" not in out and "internal error" not in out, described
        if r.exit_code == 2:
            assert str(path) in out, "the message does not name the file" + described
        if r.exit_code == 2:
            assert out.count("error:") == 1, described
            assert cpu < CPU_LIMIT, f"{cpu:.2f} s of CPU to refuse an input error" + described
        return r.exit_code, out


# --- walking the plain data of a file ----------------------------------------------

Path_ = tuple[Any, ...]


def all_paths(data: Any, prefix: Path_ = ()) -> list[Path_]:
    out = [prefix]
    if isinstance(data, dict):
        for k, v in data.items():
            out += all_paths(v, prefix + (k,))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            out += all_paths(v, prefix + (i,))
    return out


def get(data: Any, path: Path_) -> Any:
    for k in path:
        data = data[k]
    return data


def put(data: Any, path: Path_, value: Any) -> None:
    get(data, path[:-1])[path[-1]] = value


NUMBER_RE = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*)$")


def is_number(v: Any) -> bool:
    if isinstance(v, bool):
        return False
    return isinstance(v, (int, float)) or (isinstance(v, str) and bool(NUMBER_RE.match(v)))


def numeric_paths(data: Any) -> list[Path_]:
    return [p for p in all_paths(data) if p and is_number(get(data, p))]


def expression_paths(data: Any) -> list[Path_]:
    """Paths of conditions: loads' ``when``, assembly conditions, a limit start."""
    out = []
    for p in all_paths(data):
        if not p or not isinstance(get(data, p), str):
            continue
        if p[-1] == "when" or p[-1] == "limit":
            out.append(p)
        elif "assembly" in p and isinstance(p[-1], int):
            out.append(p)
    return out


def point_names(data: Any) -> list[str]:
    names = list((data.get("ground") or {}).keys())
    for link in (data.get("links") or {}).values():
        if isinstance(link, dict) and isinstance(link.get("points"), dict):
            names += list(link["points"])
    return names or ["P"]


# --- values ---------------------------------------------------------------------------

HUGE = [1e308, -1e308, 1.7976931348623157e308, 1e300, 1e154, 1e20, 1e7, 10**400, -(10**30)]
TINY = [5e-324, -5e-324, 1e-308, 1e-300, 1e-160, 1e-12]
ODD = [0, 0.0, -0.0, -1, -26.5, float("nan"), float("inf"), -float("inf")]
WRONG = ["3 kg", "5 N", "2 deg", "1 furlong", "7 m/s^2", "2 km^9", "kg", "", "1 2 3", "1e999 m"]
TYPES = [None, True, "text", 42, [], {}, [1, 2, 3], {"x": 1}, [[0, 0], [1, 1]], "B left of A"]


@st.composite
def number_value(draw: st.DrawFn, old: Any) -> Any:
    """A replacement for a number: a fixed hostile value, or the same value scaled by a
    power of ten (keeping its unit), or with another unit."""
    kind = draw(st.sampled_from(["fixed", "scaled", "scaled", "unit"]))
    if kind == "fixed":
        return draw(st.sampled_from(HUGE + TINY + ODD + WRONG))
    m = NUMBER_RE.match(str(old))  # no match: nan or inf from an earlier mutation
    number, unit = (float(m.group(1)) or 1.0, m.group(2)) if m else (1.0, "")
    if kind == "scaled":
        k = draw(st.integers(-330, 330))
        try:
            x = number * 10.0**k
        except OverflowError:
            x = math.copysign(1e308, number)
        return f"{x!r} {unit}".strip() if unit or draw(st.booleans()) else x
    return f"{number!r} " + draw(st.sampled_from(["kg", "N", "deg", "mm", "s", "rpm", "N m", "xx"]))


@st.composite
def expression_text(draw: st.DrawFn, names: list[str], old: str) -> str:
    p = draw(st.sampled_from(names))
    q = f"{p}.x"
    n = draw(st.sampled_from([1, 2, 10, 63, 64, 65, 100, 150, 1000, 3000, 20000, 50000]))
    kind = draw(
        st.sampled_from(
            ["parens", "abs", "pow", "neg", "not", "sum", "number", "name", "garbage", "splice"]
        )
    )
    if kind == "parens":
        return "(" * n + q + ")" * n + " > 0"
    if kind == "abs":
        return "abs(" * n + q + ")" * n + " > 0"
    if kind == "pow":
        return "^".join(["2"] * n) + f" > {q}"
    if kind == "neg":
        return "-" * n + f"{q} > 0"
    if kind == "not":
        return "not " * n + f"{q} > 0"
    if kind == "sum":
        return " + ".join([q] * n) + " > 0"
    if kind == "number":
        num = draw(
            st.sampled_from(["1e999999", "1e308", "1e-400", "1e308 km", "1e300 ^ 2", "0 / 0"])
        )
        return draw(
            st.sampled_from(
                [f"{q} < {num}", f"{q} * {num} > 1", f"{num} > {q} - {num}", f"sqrt(-{num}) < {q}"]
            )
        )
    if kind == "name":
        return draw(
            st.sampled_from(
                ["Zz.x > 0", f"foo({q}) > 1", f"{p}.qq > 0", f"{p} left of Zz -> {p}", "x > 0"]
            )
        )
    garbage = draw(
        st.text(alphabet="()[]{}^*-+/<>=!.,;:'\"$#@\\ \t\nPx0123456789aeéz", max_size=40)
    )
    if kind == "garbage":
        return garbage
    at = draw(st.integers(0, len(old)))
    return old[:at] + garbage + old[at:]


# --- mutations -----------------------------------------------------------------------


@st.composite
def mutant(draw: st.DrawFn) -> tuple[str, str | None]:
    """The text of a mutated example file, and maybe a variant to run."""
    name = draw(st.sampled_from(sorted(DATA)))
    data = copy.deepcopy(DATA[name])
    dup = None
    for _ in range(draw(st.integers(1, 3))):
        op = draw(
            st.sampled_from(
                ["number", "number", "number", "delete", "retype", "swap", "duplicate", "expr"]
            )
        )
        paths = [p for p in all_paths(data) if p]
        if op == "number":
            nums = numeric_paths(data)
            if nums:
                p = draw(st.sampled_from(nums))
                put(data, p, draw(number_value(get(data, p))))
        elif op == "delete":
            p = draw(st.sampled_from(paths))
            parent = get(data, p[:-1])
            del parent[p[-1]]
        elif op == "retype":
            put(data, draw(st.sampled_from(paths)), copy.deepcopy(draw(st.sampled_from(TYPES))))
        elif op == "swap":
            a, b = draw(st.sampled_from(paths)), draw(st.sampled_from(paths))
            if a[: len(b)] != b and b[: len(a)] != a:
                va, vb = get(data, a), get(data, b)
                put(data, a, vb)
                put(data, b, va)
        elif op == "expr":
            exprs = expression_paths(data)
            if exprs:
                p = draw(st.sampled_from(exprs))
                put(data, p, draw(expression_text(point_names(data), get(data, p))))
        elif op == "duplicate":  # the same mapping key twice: done on the text
            dup = draw(st.integers(0, 10_000))
    text = yaml.safe_dump(data, sort_keys=False, width=10**9)
    if dup is not None:
        lines = text.splitlines(keepends=True)
        keyed = [i for i, ln in enumerate(lines) if re.match(r"^\s*[A-Za-z_]\w*:", ln)]
        if keyed:
            i = keyed[dup % len(keyed)]
            lines.insert(i + 1, lines[i])
            text = "".join(lines)
    variants = DATA[name].get("variants") or {}
    variant = draw(st.sampled_from([None, None, *variants]))
    if variant is not None and not (
        isinstance(data, dict)
        and isinstance(data.get("variants"), dict)
        and variant in data["variants"]
    ):
        variant = None
    return text, variant


# --- the tests -----------------------------------------------------------------------


def test_examples_run_cleanly():
    """The harness itself: the unmutated examples succeed (so mutants test something)."""
    for name, text in TEXTS.items():
        code, out = run_text(text, name)
        assert code == 0, out


@settings(max_examples=N or 200, **SETTINGS)
@given(mutant())
def test_mutated_examples(case):
    text, variant = case
    run_text(text, variant=variant)


@st.composite
def expression_mutant(draw: st.DrawFn) -> str:
    name = draw(st.sampled_from(sorted(DATA)))
    data = copy.deepcopy(DATA[name])
    paths = expression_paths(data)
    if not paths:
        return yaml.safe_dump(data, sort_keys=False)
    p = draw(st.sampled_from(paths))
    put(data, p, draw(expression_text(point_names(data), get(data, p))))
    return yaml.safe_dump(data, sort_keys=False, width=10**9)


@settings(max_examples=N or 100, **SETTINGS)
@given(expression_mutant())
def test_mutated_conditions(text):
    run_text(text)


# every number of every example, made huge and tiny, one at a time
NUMBERS = [
    (name, p) for name in sorted(DATA) for p in numeric_paths(DATA[name]) if "variants" not in p
]


@pytest.mark.parametrize("name,path", NUMBERS, ids=[f"{n}:{p}" for n, p in NUMBERS])
def test_every_number_huge_and_tiny(name, path):
    for value in (1e308, -1e308, 5e-324, -5e-324):
        data = copy.deepcopy(DATA[name])
        put(data, path, value)
        code, out = run_text(yaml.safe_dump(data, sort_keys=False), name)
        if abs(value) > 1:  # refused where it is read, naming its key
            key = [k for k in path if not isinstance(k, int)][-1]
            assert code == 2 and f"{key}" in out and "too large" in out, out


SUBPROCESS_CASES = [
    ("fourbar.yaml", ("links", "rocker", "points", "B", 0), 1e308),
    ("fourbar.yaml", ("links", "crank", "points", "O2", 1), 1e308),
    ("fourbar.yaml", ("loads", "pull", "when"), "(" * 150 + "P.x" + ")" * 150 + " > 0"),
    ("shaper.yaml", ("loads", "cutting", "when"), "abs(" * 3000 + "C.x" + ")" * 3000 + " > 0"),
    ("crane.yaml", ("assembly", 0), " + ".join(["K.x"] * 50_000) + " > 0"),
]


@pytest.mark.parametrize("name,path,value", SUBPROCESS_CASES, ids=range(len(SUBPROCESS_CASES)))
def test_mutants_in_a_real_process(name, path, value, tmp_path):
    data = copy.deepcopy(DATA[name])
    try:
        put(data, path, value)
    except (KeyError, IndexError):
        pytest.skip(f"{name} has no {path}")
    f = tmp_path / name
    f.write_text(yaml.safe_dump(data, sort_keys=False, width=10**9))
    r = subprocess.run(
        [sys.executable, "-m", "mechsolve", "run", str(f), "-o", str(tmp_path / "o"), *RUN],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr + r.stdout
    assert str(f) in r.stderr
