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


# -- the bench's lean hand-written Newtons (the Newton groups' speed references) ----------


@pytest.mark.parametrize("name", ["lean_fourbar", "shared_fourbar"])
def test_lean_fourbar_newton_is_nortons_closed_form(name):
    from mechsolve_bench import lean_newton as L
    from mechsolve_bench import references as R

    th2 = np.arange(720) * 2 * np.pi / 720
    got = getattr(L, name)(th2)
    want = R.fourbar_textbook(th2)
    for k in range(6):
        d = got[k] - want[k]
        if k < 2:
            d = np.angle(np.exp(1j * d))  # angles modulo a turn
        assert np.max(np.abs(d)) < 1e-12 * max(1.0, float(np.max(np.abs(want[k]))))


@pytest.mark.parametrize("name", ["lean_triad", "shared_triad"])
def test_lean_triad_newton_closes_its_loops_and_matches_the_4x4_newton(name):
    """The triad's angles close both loops to 1e-12 m, and they, their rates and
    accelerations agree with the earlier reference (np.linalg on the 4x4 loop Jacobian,
    another elimination) to 1e-10; the rates also agree with central differences of the
    angles (an independent check of the eliminated rate system)."""
    from mechsolve_bench import lean_newton as L
    from mechsolve_bench import references as R

    n = 3600
    th = R.TRIAD_START + np.arange(n) * 2 * np.pi / n
    x, w, al, _ = getattr(L, name)(th)
    g = L.triad_geo()
    e = lambda a: np.stack([np.cos(a), np.sin(a)])  # noqa: E731
    rot = lambda v: np.stack(  # noqa: E731
        [
            np.cos(x[:, 1]) * v[0] - np.sin(x[:, 1]) * v[1],
            np.sin(x[:, 1]) * v[0] + np.cos(x[:, 1]) * v[1],
        ]
    )
    P1 = np.array(g.G1)[:, None] + g.l1 * e(x[:, 0])
    loop1 = P1 + rot(g.v2) - np.array(g.G2)[:, None] - g.l2 * e(x[:, 2])
    loop2 = P1 + rot(g.v3) - g.r * e(th) - g.l3 * e(x[:, 3])
    assert np.max(np.abs(loop1)) < 1e-12 and np.max(np.abs(loop2)) < 1e-12
    ref = R.triad_newton(th)
    assert np.max(np.abs(x - ref[0])) < 1e-10
    assert np.max(np.abs(w - ref[1])) < 1e-10 and np.max(np.abs(al - ref[2])) < 1e-10
    h = th[1] - th[0]
    assert np.max(np.abs((x[2:] - x[:-2]) / (2 * h) - w[1:-1])) < 1e-5
    assert np.max(np.abs((w[2:] - w[:-2]) / (2 * h) - al[1:-1])) < 1e-4


# -- Newton groups: groups of four to six angles solved in floats, position by position -----


@pytest.mark.parametrize("n", [4, 5, 6])
def test_small_dense_solve_in_floats_recovers_a_known_solution(n):
    """J x = -f with x chosen: the elimination (partial pivoting) gives x back; a zero
    first pivot (a permutation-like J) needs the row exchange; a singular J gives None."""
    from mechsolve.groups.reduced import _solve_small

    rng = np.random.default_rng(n)
    for _ in range(50):
        J = rng.standard_normal((n, n))
        x = rng.standard_normal(n)
        got = _solve_small(J.tolist(), (-(J @ x)).tolist())
        assert np.allclose(got, x, rtol=1e-10, atol=1e-10)
    P = np.roll(np.eye(n), 1, axis=0) * np.arange(1, n + 1)  # zero diagonal
    x = np.arange(n) - 1.5
    assert np.allclose(_solve_small(P.tolist(), (-(P @ x)).tolist()), x, atol=1e-14)
    S = np.ones((n, n))
    assert _solve_small(S.tolist(), [1.0] * n) is None


def test_the_triad_coarse_continuation_makes_no_lapack_call_per_position(monkeypatch):
    """The triad six-bar's Newton group (four angles): its coarse continuation solves
    each position in floats; the only stacked solves are the batched refinement's few
    iterations (before: one per Newton iteration of every coarse position, ~140). The
    angles still close the loops (the loop residual at rounding level)."""
    from mechsolve.core.sweep import Analysis
    from mechsolve_bench import _triad_mech

    an = Analysis(_triad_mech(720), "auto")
    u0 = an.start_value()
    u, _ = an.sweep_values(u0)
    start = an.assemble(u0)
    calls = []
    real = np.linalg.solve

    def counting(*a, **k):
        calls.append(a[0].shape)
        return real(*a, **k)

    monkeypatch.setattr(np.linalg, "solve", counting)
    sol = an.solve(u, start=start)
    assert sol.ok.all()
    assert len(calls) <= 8, calls
    assert np.nanmax(sol.residual) < 1e-10
