"""A sweep that starts where a Newton group cannot close looks for the first position that
closes with a bounded number of start searches. Each failed search is every start guess with
Newton and scipy (up to a second for a six-bar's triad), and probing each of 361 positions
of a triad that never closes took over ten minutes; now about SKIP_PROBES searches."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.base.errors import CannotCloseAtStart
from mechsolve.core import failures
from mechsolve.core.sweep import Analysis

SRC = (Path(__file__).resolve().parent / "test_hard_cases.py").read_text()
TRIAD = re.search(r'TRIAD = """(.*?)"""', SRC, re.S).group(1)
SKETCH = "{B: [80, 40], C: [140, 40], D: [90, 110]}"


def _triad(crank: float, step: str = "10 deg") -> str:
    t = TRIAD.replace("SKETCH", SKETCH).replace("A: [20, 0]", f"A: [{crank}, 0]")
    return t.replace(
        "sweep: {range: 30 deg, step: 5 deg}", f"sweep: {{range: 360 deg, step: {step}}}"
    )


def _first_closing_one_by_one(mech) -> int:
    """The slow way: a start search at every position in turn."""
    an = Analysis(mech)
    u = np.radians(np.arange(37) * 10.0)  # the file's sweep: 0 to 360 deg by 10 deg
    for i, x in enumerate(u):
        try:
            an.assemble(float(x))
            return i
        except CannotCloseAtStart:
            continue
    return len(u)


def test_the_first_closing_position_is_the_one_by_one_answer(monkeypatch):
    mech = ms.loads(_triad(35))  # dead from 0 to 60 deg (crank 35 mm)
    k = _first_closing_one_by_one(mech)
    assert 0 < k < 20
    calls = []
    real = Analysis.assemble

    def counted(self, u0):
        calls.append(u0)
        return real(self, u0)

    monkeypatch.setattr(Analysis, "assemble", counted)
    monkeypatch.setattr(failures, "SKIP_PROBES", 4)  # a stride of 9 samples over 37
    res = ms.solve(ms.loads(_triad(35)))
    assert not res.ok[:k].any() and res.ok[k]
    assert "probed every 9 samples" in " ".join(res.warnings)
    # fewer start searches than one per position up to the first that closes
    assert len(calls) < k + 4
    monkeypatch.setattr(failures, "SKIP_PROBES", 10_000)  # one by one: the same rows
    ref = ms.solve(ms.loads(_triad(35)))
    np.testing.assert_array_equal(res.ok, ref.ok)
    m = res.ok
    np.testing.assert_allclose(res.solution.state.x[:, m], ref.solution.state.x[:, m], atol=1e-12)


def test_a_triad_that_never_closes_costs_a_bounded_number_of_searches(monkeypatch):
    calls = []
    real = Analysis.assemble

    def counted(self, u0):
        calls.append(u0)
        return real(self, u0)

    monkeypatch.setattr(Analysis, "assemble", counted)
    monkeypatch.setattr(failures, "SKIP_PROBES", 6)
    with pytest.raises(CannotCloseAtStart, match="cannot assemble at driver angle 0"):
        ms.solve(ms.loads(_triad(200, "1 deg")))  # a crank longer than any loop allows
    assert len(calls) <= 6 + 2  # the start, the probes and the last position
