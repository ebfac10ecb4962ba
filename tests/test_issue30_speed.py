"""Speed work (issue 30): the command line imports and computes only what it needs, and
what is made faster gives the same numbers as before, checked against independent
references (a median by the standard library, closed forms, hand calculations)."""

from __future__ import annotations

import math
import statistics
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parent.parent
FOURBAR = ROOT / "mechanisms" / "fourbar.yaml"

_PROBE = """
import sys
from mechsolve.cli.main import main
try:
    main({args!r})
except SystemExit as exc:
    code = exc.code
print(code, [m for m in ("numpy.ma", "matplotlib", "scipy") if m in sys.modules])
"""


def _modules_after(args: list[str]) -> tuple[str, str]:
    out = subprocess.run(
        [sys.executable, "-c", _PROBE.format(args=args)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=True,
    )
    code, _, mods = out.stdout.strip().splitlines()[-1].partition(" ")
    return code, mods


def test_run_without_plots_imports_no_plotting_nor_masked_arrays(tmp_path):
    """`run --no-plots` (printing its summary) needs neither matplotlib nor scipy, nor
    numpy.ma, which np.median imports on its first call (~10 ms of a 0.2 s process)."""
    code, mods = _modules_after(["run", str(FOURBAR), "--no-plots", "-o", str(tmp_path)])
    assert code == "0"
    assert mods == "[]"


def test_quiet_run_without_plots_makes_no_plot_sweep(tmp_path, monkeypatch):
    """Nothing reads the finer sweep of the plots when nothing is printed or drawn and the
    file has no requirements: it is not made."""
    import mechsolve.api as api

    def no_plots(*a, **k):
        raise AssertionError("the plots' sweep was made")

    monkeypatch.setattr(api, "for_plots", no_plots)
    r = CliRunner().invoke(main, ["run", str(FOURBAR), "--no-plots", "-q", "-o", str(tmp_path)])
    assert r.exit_code == 0, r.output
    rows = (tmp_path / "results.csv").read_text().splitlines()
    assert len(rows) > 180  # the CSV at the file's step (2 deg over a turn: 181 rows)


def test_sample_spacing_is_the_median_step():
    """The summary's sample spacing is the median of the steps (the standard library's
    median), on an even sweep and on the plots' uneven one (limit positions inserted)."""
    res = ms.solve(ms.load(FOURBAR))
    assert res.sample_spacing() == "2°"
    fine = ms.api.for_plots(res.mechanism, res)
    du = np.abs(np.diff(fine.u))
    assert len(set(np.round(du, 12))) > 1  # uneven
    want = math.degrees(statistics.median(du.tolist()))
    assert fine.sample_spacing() == f"{want:.4g}°"
    # an even number of steps: the mean of the two middle ones
    fine.u = np.array([0.0, 0.01, 0.03, 0.06, 0.1])
    want = math.degrees(statistics.median([0.01, 0.02, 0.03, 0.04]))
    assert fine.sample_spacing() == f"{want:.4g}°"


# -- the adaptive integrators' guard: the state is copied only when a step fails ----------


def test_the_guard_records_no_state_on_successful_steps():
    """y' = -y over 2 s with RK45: it runs through, and no state was copied (the guard
    only keeps the last accepted one when a step fails)."""
    from scipy.integrate import solve_ivp

    from mechsolve.analyses.dynamics.integrators import _guarded

    guard = _guarded("RK45", None, 10**6)
    out = solve_ivp(lambda t, y: -y, (0.0, 2.0), [1.0], method=guard, rtol=1e-10, atol=1e-12)
    assert out.status == 0 and guard.steps > 20
    assert guard.last is None and guard.end is None
    assert out.y[0, -1] == pytest.approx(math.exp(-2.0), rel=1e-8)  # the closed form


@pytest.mark.parametrize("method", ["RK45", "DOP853", "Radau", "BDF", "LSODA"])
def test_the_guard_keeps_the_last_accepted_state_when_stopped(method):
    """Stopped after 7 steps: the state it keeps is the last accepted one, on the closed
    form exp(-t) of y' = -y."""
    from scipy.integrate import solve_ivp

    from mechsolve.analyses.dynamics.integrators import _guarded

    guard = _guarded(method, None, 7)
    out = solve_ivp(lambda t, y: -y, (0.0, 50.0), [1.0], method=guard, rtol=1e-9, atol=1e-12)
    assert out.status == -1 and "took 7 steps" in guard.end.reason
    t, y = guard.last
    assert t == out.t[-1] and 0 < t < 50
    assert y[0] == out.y[0, -1] == pytest.approx(math.exp(-t), rel=1e-6)
