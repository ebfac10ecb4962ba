"""The Newton groups' optional compiled sweep (numba; ``solver.compiled`` or
``MECHSOLVE_COMPILED=1``): the same answers as the NumPy path and as independent
values (the four-bar's closed form, the triad solved position by position), on easy
and hard sweeps (a near-toggle, dead zones, a bifurcation); off by default; a clear
error when it is asked for and numba is missing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
import mechsolve.groups.compiled as compiled
from mechsolve.cli.main import main
from mechsolve.groups.generic import NewtonGroup
from mechsolve.groups.newton_batched import BatchedSweep

from closed_form import fourbar, fourbar_disc

pytest.importorskip("numba")  # (the test extra installs it: CI runs these)

ROOT = Path(__file__).resolve().parents[1]
MECH = ROOT / "mechanisms"


def wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


@pytest.fixture
def calls(monkeypatch):
    """How many coarse passes and two-angle refinements went through the kernels."""
    n = {"coarse": 0, "refine2": 0, "elim": 0}
    coarse, refine2 = BatchedSweep._coarse_compiled, BatchedSweep._refine2_compiled
    elim = BatchedSweep._refine_elim_compiled

    def spy_elim(self, *a, **k):
        n["elim"] += 1
        return elim(self, *a, **k)

    def spy_coarse(self, *a, **k):
        n["coarse"] += 1
        return coarse(self, *a, **k)

    def spy_refine2(self, *a, **k):
        n["refine2"] += 1
        return refine2(self, *a, **k)

    monkeypatch.setattr(BatchedSweep, "_coarse_compiled", spy_coarse)
    monkeypatch.setattr(BatchedSweep, "_refine2_compiled", spy_refine2)
    monkeypatch.setattr(BatchedSweep, "_refine_elim_compiled", spy_elim)
    return n


def both(monkeypatch, text: str, method: str | None = None):
    """The sweep of ``text`` by the NumPy path, then by the compiled path (the
    environment variable)."""
    monkeypatch.delenv(compiled.ENV, raising=False)
    plain = ms.solve(ms.loads(text), method=method)
    monkeypatch.setenv(compiled.ENV, "1")
    fast = ms.solve(ms.loads(text), method=method)
    monkeypatch.delenv(compiled.ENV)
    return plain, fast


def assert_same(plain, fast, rtol=1e-12):
    """The same positions, rates, successes, events and warnings (to 1e-12 of each
    quantity's largest value: bit for bit where both paths use the same libm)."""
    np.testing.assert_array_equal(plain.ok, fast.ok)
    for f in ("x", "y", "th", "vx", "vy", "w", "ax", "ay", "al"):
        a, b = getattr(plain.solution.state, f), getattr(fast.solution.state, f)
        scale = max(1.0, float(np.nanmax(np.abs(a))))
        np.testing.assert_allclose(b, a, rtol=0, atol=rtol * scale, equal_nan=True, err_msg=f)
    assert [(e.kind, e.after) for e in fast.events] == [(e.kind, e.after) for e in plain.events]
    for e, e0 in zip(fast.events, plain.events):
        assert e.u == pytest.approx(e0.u, rel=1e-12, abs=1e-12)
    assert fast.solution.warnings == plain.solution.warnings
    assert fast.summary() == plain.summary()


FOURBAR = """
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: {w} rad/s, start: {start} deg}}
sweep: {{range: {sweep} deg, step: {step} deg}}
"""


@pytest.mark.parametrize("method", ["split-newton", "newton"])
def test_fourbar_against_freudenstein(monkeypatch, calls, method):
    """A Grashof crank-rocker over a full turn at 0.5 deg (721 positions, the batched
    sweep): the compiled path gives the NumPy path's positions and rates, and both the
    closed form's (Freudenstein's equation, Norton's solution) on the user's branch."""
    a, b, c, d, w = 1.0, 3.0, 2.5, 2.8, 3.0
    text = FOURBAR.format(a=a, b=b, c=c, d=d, w=w, start=20, sweep=360, step=0.5)
    plain, fast = both(monkeypatch, text, method)
    assert calls["coarse"] >= 1 and calls["refine2"] >= 1
    assert fast.ok.all() and len(fast.u) == 721
    assert_same(plain, fast)
    np.testing.assert_array_equal(fast.solution.iterations, plain.solution.iterations)
    th2 = fast.link("crank").angle
    refs = [fourbar(a, b, c, d, th2, w, br) for br in (1, -1)]
    th4 = fast.link("rocker").angle
    br = min(refs, key=lambda r: np.max(np.abs(wrap(th4 - r[1]))))
    np.testing.assert_allclose(wrap(fast.link("coupler").angle - br[0]), 0, atol=1e-10)
    np.testing.assert_allclose(wrap(th4 - br[1]), 0, atol=1e-10)
    np.testing.assert_allclose(fast.link("coupler").omega, br[2], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(fast.link("rocker").omega, br[3], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(fast.link("coupler").alpha, br[4], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(fast.link("rocker").alpha, br[5], rtol=1e-8, atol=1e-8)
    # the user's branch: B left of A -> O4, at every position
    A = a * np.exp(1j * th2)
    B = fast.point("B").x + 1j * fast.point("B").y
    assert np.all(np.imag((B - A) * np.conj(d - A)) > 0)


TRIAD = """
units: {length: mm, angle: deg}
ground: {O1: [0, 0], O2: [150, -20], O3: [60, 120]}
links:
  crank: {points: {O1: [0, 0], A: [20, 0]}}
  p: {points: {A: [0, 0], B: [72.1110255, 0]}}
  tern: {points: {B: [0, 0], C: [60, 0], D: [10, 70]}}
  q: {points: {O2: [0, 0], C: [60.8276253, 0]}}
  r: {points: {O3: [0, 0], D: [31.6227766, 0]}}
joints:
  O1: [ground, crank]
  A: [crank, p]
  B: [p, tern]
  C: [tern, q]
  O2: [ground, q]
  D: [tern, r]
  O3: [ground, r]
assembly:
  sketch: {B: [72.11, 20.0], C: [132, 38], D: [62, 90]}
driver: {joint: O1, speed: 10 rad/s}
sweep: {range: 360 deg, step: 1 deg}
"""


def test_triad_against_positions_solved_one_by_one(monkeypatch, calls):
    """The Stephenson triad (a Newton group of four angles under ``auto``) over a full
    turn at 1 deg: the compiled sweep gives the NumPy sweep's answers, and every tenth
    position equals the whole-system ``newton`` method's at a 10 deg step (37
    positions, below the batch's minimum: solved one after another by continuation,
    nothing compiled)."""
    plain, fast = both(monkeypatch, TRIAD)
    assert calls["coarse"] >= 1 and calls["elim"] >= 1  # (its residual: to rounding)
    assert [g.kind for g in fast.analysis.plan] == ["driver link", "Newton"]
    assert fast.ok.all() and len(fast.u) == 361
    assert_same(plain, fast)
    n0 = calls["coarse"]
    monkeypatch.setenv(compiled.ENV, "1")  # (not used: a sequential sweep)
    coarse = ms.solve(ms.loads(TRIAD.replace("step: 1 deg", "step: 10 deg")), method="newton")
    assert calls["coarse"] == n0 and coarse.ok.all() and len(coarse.u) == 37
    np.testing.assert_allclose(coarse.u, fast.u[::10], rtol=0, atol=1e-12)
    for p in ("B", "C", "D"):
        np.testing.assert_allclose(coarse.point(p).x, fast.point(p).x[::10], rtol=0, atol=1e-9)
        np.testing.assert_allclose(coarse.point(p).y, fast.point(p).y[::10], rtol=0, atol=1e-9)
    for ln in ("p", "tern", "q", "r"):
        w, w0 = fast.link(ln).omega[::10], coarse.link(ln).omega
        np.testing.assert_allclose(w, w0, rtol=1e-8, atol=1e-8 * np.max(np.abs(w0)))
        a, a0 = fast.link(ln).alpha[::10], coarse.link(ln).alpha
        np.testing.assert_allclose(a, a0, rtol=1e-7, atol=1e-7 * np.max(np.abs(a0)))


@pytest.mark.parametrize("eps", [1e-4, 1e-6])
def test_near_toggle_keeps_the_branch(monkeypatch, calls, eps):
    """A four-bar within a hair of folding (its two branches closer than one Newton
    step at 1 deg): the compiled ``split-newton`` sweep keeps the branch as the NumPy
    one does, equal to the closed-form method's positions, with no bifurcation."""
    text = (MECH / "fourbar.yaml").read_text()
    rocker = 114 - 105.6 + eps
    text = text.replace("B: [59, 0]}", f"B: [{rocker!r}, 0]}}").replace(
        "step: 2 deg", "step: 1 deg"
    )
    plain, fast = both(monkeypatch, text, "split-newton")
    assert calls["coarse"] >= 1
    assert_same(plain, fast)
    assert "bifurcation" not in fast.summary()
    ref = ms.solve(ms.loads(text))  # the closed form (auto)
    for p in ("B", "P"):
        np.testing.assert_allclose(fast.point(p).x, ref.point(p).x, atol=1e-9)
        np.testing.assert_allclose(fast.point(p).y, ref.point(p).y, atol=1e-9)


@pytest.mark.parametrize("step", [3, 4, 5])
def test_dead_zone_as_the_closed_form(monkeypatch, calls, step):
    """A non-Grashof four-bar over a full turn: ``split-newton`` compiled solves exactly
    the positions where the closed form closes, on the branch ``auto`` keeps, and
    reports the same dead zones and warnings as the NumPy path."""
    text = FOURBAR.format(a=2.0, b=2.0, c=2.5, d=3.0, w=1, start=90, sweep=360, step=step)
    plain, fast = both(monkeypatch, text, "split-newton")
    assert_same(plain, fast)
    closes = fourbar_disc(2.0, 2.0, 2.5, 3.0, fast.u) >= 0
    np.testing.assert_array_equal(fast.ok, closes)
    th4 = wrap(fast.link("rocker").angle[fast.ok])
    auto = ms.solve(ms.loads(text))
    np.testing.assert_allclose(wrap(th4 - auto.link("rocker").angle[fast.ok]), 0, atol=1e-9)


def test_narrow_dead_zone_is_reported(monkeypatch, calls):
    """The coupler just fails to reach for about 1 deg around 180 deg; a 2 deg step
    (a batched sweep) steps over it: the compiled whole-system Newton reports the
    dead zone and keeps the user's branch, as the NumPy path does."""
    text = FOURBAR.format(a=0.8, b=1.2, c=0.79995, d=1.2, w=1, start=5, sweep=350, step=2)
    text += "solver: {method: newton}\n"
    plain, fast = both(monkeypatch, text)
    assert calls["coarse"] >= 1
    assert_same(plain, fast)
    assert [e.kind for e in fast.events] == ["dead zone"]
    A = 0.8 * np.exp(1j * fast.u)
    B = fast.point("B").x + 1j * fast.point("B").y
    assert np.all(np.imag((B - A) * np.conj(1.2 - A)) > 0)


PARALLELOGRAM = """
ground: {O2: [0, 0], O4: [3, 0]}
links:
  crank: {points: {O2: [0, 0], A: [1, 0]}}
  coupler: {points: {A: [0, 0], B: [3, 0]}}
  rocker: {points: {O4: [0, 0], B: [1, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: {sketch: {B: [3.8, 0.6]}}
driver: {joint: O2, speed: 2 rad/s, start: 10 deg}
sweep: {range: 720 deg, step: STEP deg}
solver: {method: newton}
"""


@pytest.mark.parametrize("step", [1, 7])
def test_parallelogram_through_its_bifurcations(monkeypatch, calls, step):
    """Through the collinear positions (bifurcations at 0 and 180 deg) the compiled
    whole-system Newton keeps the parallelogram (the coupler translates, the rocker
    turns with the crank: the closed form), with the NumPy path's events."""
    text = PARALLELOGRAM.replace("STEP", str(step))
    plain, fast = both(monkeypatch, text)
    assert_same(plain, fast)
    assert fast.ok.all()
    np.testing.assert_allclose(wrap(fast.link("coupler").angle), 0, atol=1e-7)
    np.testing.assert_allclose(wrap(fast.link("rocker").angle - fast.u), 0, atol=1e-7)
    if len(fast.u) >= 64:
        assert calls["coarse"] >= 1


def test_steps_that_are_not_plain_take_the_general_step(monkeypatch, calls):
    """With a jump limit small enough that the coarse steps are not plain, the compiled
    pass hands those to the general step (substeps) with the same history, as the
    floats path does: the same sweep, matching the closed form."""
    from mechsolve.groups import generic, newton_batched

    advanced = []
    advance = NewtonGroup._advance

    def counting(self, *args, **kwargs):
        advanced.append(args[1])
        return advance(self, *args, **kwargs)

    monkeypatch.setattr(NewtonGroup, "_advance", counting)
    monkeypatch.setattr(generic, "MAX_JUMP", 0.004)
    monkeypatch.setattr(newton_batched, "MAX_JUMP", 0.004)
    text = FOURBAR.format(a=1.0, b=3.0, c=2.5, d=2.8, w=1, start=0, sweep=360, step=0.1)
    plain, fast = both(monkeypatch, text, "split-newton")
    assert calls["coarse"] == 1 and len(advanced) > 10
    assert advanced[: len(advanced) // 2] == advanced[len(advanced) // 2 :]  # the same steps
    assert_same(plain, fast)
    np.testing.assert_array_equal(fast.solution.iterations, plain.solution.iterations)
    th2 = fast.link("crank").angle
    ref = fourbar(1.0, 3.0, 2.5, 2.8, th2, 1.0, 1)
    refx = fourbar(1.0, 3.0, 2.5, 2.8, th2, 1.0, -1)
    th4 = fast.link("rocker").angle
    err = min(np.max(np.abs(wrap(th4 - r[1]))) for r in (ref, refx))
    assert err < 1e-10


def test_off_unless_asked_for(monkeypatch):
    """Off by default (no numba imported by a solve); on by the environment variable
    (anything but empty, 0, false, no, off) or by the file's ``solver.compiled``."""
    code = (
        "import sys, mechsolve as ms; ms.solve(ms.load(sys.argv[1]), method='split-newton');"
        "print('numba' in sys.modules)"
    )
    env = {k: v for k, v in __import__("os").environ.items() if k != compiled.ENV}
    out = subprocess.run(
        [sys.executable, "-c", code, str(MECH / "fourbar.yaml")],
        capture_output=True, text=True, env=env, cwd=ROOT, check=True,
    )  # fmt: skip
    assert out.stdout.strip() == "False"
    for value, on in (("", False), ("0", False), ("no", False), ("1", True), ("yes", True)):
        monkeypatch.setenv(compiled.ENV, value)
        assert compiled.requested() is on
        g = ms.solve(ms.loads(PARALLELOGRAM.replace("STEP", "7"))).analysis.plan[0]
        assert isinstance(g, NewtonGroup) and (g.compiled is not None) is on
    monkeypatch.delenv(compiled.ENV)
    mech = ms.loads(
        PARALLELOGRAM.replace("STEP", "7").replace("newton}", "newton, compiled: true}")
    )
    assert mech.solver.compiled
    assert ms.solve(mech).analysis.plan[0].compiled == "solver.compiled"


@pytest.fixture
def no_numba(monkeypatch):
    """numba cannot be imported (nor the kernels, which import it)."""
    monkeypatch.setitem(sys.modules, "numba", None)
    monkeypatch.delitem(sys.modules, "mechsolve.groups.kernels", raising=False)
    monkeypatch.setattr(compiled, "_kernels", None)


def test_missing_numba_the_environment_variable(monkeypatch, no_numba, tmp_path):
    monkeypatch.setenv(compiled.ENV, "1")
    with pytest.raises(compiled.CompiledUnavailable, match="MECHSOLVE_COMPILED.*numba"):
        ms.solve(ms.loads(PARALLELOGRAM.replace("STEP", "1")))
    args = ["run", str(MECH / "fourbar.yaml"), "--no-plots", "--method", "split-newton"]
    res = CliRunner().invoke(main, args + ["-o", str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    assert "MECHSOLVE_COMPILED" in res.output and "numba" in res.output
    assert "Traceback" not in res.output


def test_missing_numba_the_files_key(no_numba, tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text(PARALLELOGRAM.replace("STEP", "1").replace("newton}", "newton, compiled: true}"))
    with pytest.raises(ms.InputError, match="compiled.*numba"):
        ms.load(f)
    res = CliRunner().invoke(main, ["run", str(f), "--no-plots", "-o", str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    assert "solver.compiled" in res.output or "compiled" in res.output
    assert "p.yaml" in res.output and "numba" in res.output
    assert "Traceback" not in res.output


def test_the_files_key_takes_true_or_false(tmp_path):
    text = PARALLELOGRAM.replace("STEP", "7").replace("newton}", "newton, compiled: 1}")
    with pytest.raises(ms.InputError, match="true or false"):
        ms.loads(text)
    assert not ms.loads(text.replace("compiled: 1", "compiled: false")).solver.compiled


def test_the_bench_prints_the_compiled_rows_beside_the_default_ones():
    """``mechsolve bench --case newton-groups``: the compiled sweeps' rows, with their
    accuracy against the same references as the default rows, their ratios, the first
    call's time and the CPU times."""
    from mechsolve_bench import case_newton

    case = case_newton(400, 1)
    rows = {r.setting: r for r in case.rows}
    for key in ("four-bar: mechsolve split-newton", "triad six-bar: mechsolve auto"):
        (fast,) = [r for s, r in rows.items() if s.startswith(key) and "compiled" in s]
        assert fast.seconds > 0 and 0 < fast.error < 1e-12, fast
    text = "\n".join(case.lines)
    assert "ratio split-newton compiled / lean by hand (four-bar):" in text
    assert "ratio auto compiled / lean by hand (triad):" in text
    assert "compiled path: the first calls took" in text
    (cpu,) = [line for line in case.lines if line.startswith("CPU time (thread_time")]
    assert "default" in cpu and "compiled" in cpu


def test_six_free_angles_by_elimination_with_pivoting(monkeypatch, calls):
    """The whole-system ``newton`` method on the triad with a dyad hung from it (seven
    moving links, the crank's angle fixed by the driver: six free angles, whose coarse
    steps the kernel solves by Gaussian elimination with pivoting, as the floats path
    does): the NumPy path's answers, and the ``auto`` method's (a Newton triad and a
    closed-form dyad) positions."""
    text = (
        TRIAD.replace("D: [10, 70]}", "D: [10, 70], F: [30, 30]}")
        .replace(
            "  r: {points: {O3: [0, 0], D: [31.6227766, 0]}}\n",
            "  r: {points: {O3: [0, 0], D: [31.6227766, 0]}}\n"
            "  s: {points: {F: [0, 0], E: [80, 0]}}\n"
            "  t: {points: {O4: [0, 0], E: [70, 0]}}\n",
        )
        .replace("O3: [60, 120]}", "O3: [60, 120], O4: [120, 120]}")
        .replace(
            "  O3: [ground, r]\n",
            "  O3: [ground, r]\n  F: [tern, s]\n  E: [s, t]\n  O4: [ground, t]\n",
        )
        .replace("D: [62, 90]}", "D: [62, 90], E: [170, 72]}")
    )
    plain, fast = both(monkeypatch, text, "newton")
    group = fast.analysis.plan[0]
    assert group.red is not None and group.red.sub.nb == 6
    assert calls["coarse"] >= 1
    assert fast.ok.all() and len(fast.u) == 361
    assert_same(plain, fast)
    auto = ms.solve(ms.loads(text))
    for p in ("B", "C", "D", "E"):
        np.testing.assert_allclose(fast.point(p).x, auto.point(p).x, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fast.point(p).y, auto.point(p).y, rtol=0, atol=1e-9)
