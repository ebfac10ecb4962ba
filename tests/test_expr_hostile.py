"""Hostile expressions: deep, long or non-finite conditions get one clear message.

Conditions (and, later, requirements and motion laws) are read from files that CI runs
on pull requests. Parsing and every walk of the tree must not depend on Python's
recursion limit; evaluation must not recurse either.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main
from mechsolve.model.expr import MAX_DEPTH, MAX_LENGTH, ExprError, Expression

ROOT = Path(__file__).resolve().parents[1]
FOURBAR = (ROOT / "mechanisms" / "fourbar.yaml").read_text()

HOSTILE = {
    "150 parentheses": ("(" * 150 + "P.x" + ")" * 150 + " > 0", "nests deeper than 64"),
    "abs 3000 deep": ("abs(" * 3000 + "P.x" + ")" * 3000 + " > 0", "limited to 4000"),
    "abs 100 deep": ("abs(" * 100 + "P.x" + ")" * 100 + " > 0", "nests deeper than 64"),
    "2000 chained ^": ("^".join(["2"] * 2000) + " > P.x", "limited to 4000"),
    "100 chained ^": ("^".join(["2"] * 100) + " > P.x", "nests deeper than 64"),
    "20000 unary -": ("-" * 20000 + "P.x > 0", "limited to 4000"),
    "1000 unary -": ("-" * 1000 + "P.x > 0", "nests deeper than 64"),
    "20000 not": ("not " * 20000 + "P.x > 0", "limited to 4000"),
    "500 not": ("not " * 500 + "P.x > 0", "nests deeper than 64"),
    "50000 terms": (" + ".join(["P.x"] * 50000) + " > 0", "limited to 4000"),
    "infinite number": ("P.x < 1e999999", "1e999999 is not a finite number"),
    "infinite with a unit": ("P.x < 1e307 km", "1e307 km is not a finite number"),
    "unclosed 60 deep": ("(" * 60 + "P.x > 0", "expected ')'"),
}


class Ctx:
    def point_xy(self, name):
        return np.array([0.0, 1.0]), np.array([0.0, 0.0])

    def quantity(self, name, attr):
        return np.array([1.0, -2.0])


def low_recursion_limit(frames_left: int = 200):
    """A context manager: only ``frames_left`` frames above the caller's."""

    class _Limit:
        def __enter__(self):
            self.old = sys.getrecursionlimit()
            depth = 0
            f = sys._getframe()
            while f is not None:
                depth += 1
                f = f.f_back
            sys.setrecursionlimit(depth + frames_left)

        def __exit__(self, *exc):
            sys.setrecursionlimit(self.old)

    return _Limit()


@pytest.mark.parametrize("name", list(HOSTILE))
def test_hostile_expression_is_refused_clearly(name):
    text, message = HOSTILE[name]
    t0 = time.perf_counter()
    with low_recursion_limit(), pytest.raises(ExprError) as info:
        Expression(text)
    assert time.perf_counter() - t0 < 1.0
    assert message in str(info.value)
    assert len(str(info.value)) < 400  # the text is shortened, not echoed whole


def test_limits_are_what_the_messages_say():
    assert MAX_DEPTH == 64 and MAX_LENGTH == 4000
    ok = "(" * MAX_DEPTH + "P.x" + ")" * MAX_DEPTH + " > 0"
    Expression(ok)
    with pytest.raises(ExprError, match="nests deeper"):
        Expression("(" + ok + ")")
    Expression("P.x > 1" + " " * (MAX_LENGTH - 7))
    with pytest.raises(ExprError, match="limited to"):
        Expression("P.x > 1" + " " * (MAX_LENGTH - 6))
    with pytest.raises(ExprError, match=r"^1{20}\.\.\. is not a finite number"):
        Expression("1" * 400 + " > P.x")


def test_allowed_extremes_parse_walk_and_evaluate_without_recursion():
    """The deepest and the longest expressions allowed work with 200 frames to spare."""
    deep = "(" * 30 + "-" * 30 + "abs(P.x)" + ")" * 30 + " > 0"
    powers = "^".join(["1"] * 60) + " <= P.x"
    long_sum = "+".join(["P.x"] * 900) + " > 0"
    calls = "min(" * 30 + "P.x" + ", 1)" * 30 + " < 2 and not not P left of A -> B"
    with low_recursion_limit():
        e = Expression(deep)
        assert e.refs() and e.points() == {"P"} and not e.uses("stroke")
        assert list(e.evaluate(Ctx())) == [True, True]
        assert list(Expression(powers).evaluate(Ctx())) == [True, False]
        e = Expression(long_sum)
        assert len(e.refs()) == 900
        assert list(e.evaluate(Ctx())) == [True, False]
        e = Expression(calls)
        assert e.points() == {"P", "A", "B"}
        assert list(e.evaluate(Ctx())) == [False, False]


def test_huge_numbers_evaluate_without_warnings_or_errors():
    with np.errstate(all="raise"):
        v = Expression("P.x * 1e300 * 1e300 > 0 and 1e300 ^ 2 > P.x and 0 / 0 != 1").evaluate(Ctx())
    assert list(v) == [True, False]


def run(tmp_path, text):
    f = tmp_path / "fourbar.yaml"
    f.write_text(text)
    t0 = time.process_time()
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "o"), "--no-plots"])
    cpu = time.process_time() - t0
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)
    assert "Traceback" not in r.output and "internal error" not in r.output, r.output
    return r, cpu, f


@pytest.mark.parametrize("name", list(HOSTILE))
def test_hostile_condition_in_a_file_is_an_input_error(name, tmp_path):
    text, message = HOSTILE[name]
    mutated = FOURBAR.replace("when: P.vx > 0", f"when: '{text}'")
    assert mutated != FOURBAR
    r, cpu, f = run(tmp_path, mutated)
    assert r.exit_code == 2, r.output
    assert f"{f}:43: loads.pull.when: cannot read the condition: " in r.output
    assert message in r.output
    assert cpu < 1.0


def test_hostile_assembly_condition_is_an_input_error(tmp_path):
    text = "not " * 100 + "B left of A -> O4"
    mutated = FOURBAR.replace("- B left of A -> O4", f"- {text}")
    r, cpu, f = run(tmp_path, mutated)
    assert r.exit_code == 2, r.output
    assert f"{f}:33: assembly[0]: cannot read the condition" in r.output
    assert "nests deeper than 64" in r.output and cpu < 1.0
