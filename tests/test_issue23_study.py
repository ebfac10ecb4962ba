"""Issue 23, the design-study items and the work of a damper.

* §1.6: the work per cycle with a viscous damper is one exact computation (adaptive
  quadrature of the damper's power over the motion), independent of the step, and the same
  in the terminal, the plot and the report. References: the closed-form slider velocity of
  an offset slider-crank and the shaper's ram velocity, integrated with scipy's ``quad``.
* §1.7: a design that does not assemble gets no figures from its partial data.
* §3.1: Ctrl-C on ``sweep -j 2`` exits 130 within seconds and keeps the finished rows.
* §3.4: a sweep of very many designs prints its count and an estimate first, and is
  refused above a limit unless allowed.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from click.testing import CliRunner
from scipy.integrate import quad

import mechsolve as ms
from mechsolve import api
from mechsolve.cli.main import main

from conftest import MECH

# --- §1.6: a damper's work ------------------------------------------------------------
R, L, E = 0.05, 0.2, 0.01  # crank, rod, offset of the piston's line (m)
RPM = 1500.0
C_DAMP = 20.0  # N s/m

SLIDER_CRANK = f"""
name: damped slider-crank
units: {{length: mm, angle: deg}}
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [{R * 1e3}, 0], G1: [-5, 0]}}, mass: 2.4 kg, com: G1,
          inertia: 0.004 kg m^2}}
  rod: {{points: {{A: [0, 0], C: [{L * 1e3}, 0], G: [60, 0]}}, mass: 0.9 kg, com: G,
        inertia: 0.0045 kg m^2}}
  piston: {{points: {{C: [0, 0]}}, mass: 0.6 kg, com: C}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cylinder: {{slider: [ground, piston], point: C, line: {{through: [0, {E * 1e3}], angle: 0}}}}
assembly: ["C.x > A.x"]
driver: {{joint: O, speed: {RPM} rpm, start: 0 deg}}
sweep: {{range: 360 deg, step: 5 deg}}
gravity: 9.81 m/s^2
loads:
  d: {{damper: cylinder, coefficient: {C_DAMP} N s/m}}
"""


def _slider_dx(theta: float) -> float:
    """d x_C / d theta of the offset slider-crank, x_C = r cos + sqrt(l^2 - (r sin - e)^2)."""
    s, c = math.sin(theta), math.cos(theta)
    return -R * s - (R * s - E) * R * c / math.sqrt(L * L - (R * s - E) ** 2)


def _damper_work(dx, omega: float, c: float) -> float:
    """c * integral of v^2 dt over one turn = c * omega * integral of (dx/dtheta)^2."""
    val, err = quad(lambda th: dx(th) ** 2, 0.0, 2 * math.pi, epsabs=0, epsrel=1e-13, limit=500)
    return c * omega * val


@pytest.mark.parametrize("step", [15.0, 7.0])
def test_damper_work_per_cycle_is_exact_at_any_step(tmp_path, step):
    """Masses and gravity give no net work over a turn: the driver's work per cycle is
    the damper's dissipation c * integral of v^2 dt, to 1e-9 whatever the step."""
    f = tmp_path / "sc.yaml"
    f.write_text(SLIDER_CRANK)
    mech = ms.load(f)
    res = ms.solve(mech, step=math.radians(step))
    omega = RPM * 2 * math.pi / 60
    ref = _damper_work(_slider_dx, omega, C_DAMP)
    assert res.work() == pytest.approx(ref, rel=1e-9)
    mean, what = res.mean_effort()
    assert what == "mean" and mean == pytest.approx(ref / (2 * math.pi), rel=1e-9)


def _slider_x(theta: float) -> float:
    return R * math.cos(theta) + math.sqrt(L * L - (R * math.sin(theta) - E) ** 2)


@pytest.mark.parametrize("step", [5.0, 1.0])
def test_conditional_gas_force_and_damper_work_do_not_depend_on_the_step(tmp_path, step):
    """The issue's case: a gas force "while C moves in and stroke(C.x) > 0.3" and a damper
    gave -80.0227 J at 5 deg and -80.0001 J at 1 deg. The gas force acts over 70 % of the
    stroke's true span (its extremes from the closed form), the damper dissipates
    c * integral of v^2 dt: the driver's work is their sum at any step."""
    from scipy.optimize import minimize_scalar

    f = tmp_path / "sc.yaml"
    f.write_text(
        SLIDER_CRANK.replace(
            "loads:\n",
            "loads:\n  gas: {force: [-1500 N, 0], at: C, on: piston,"
            ' when: "C.vx < 0 and stroke(C.x) > 0.3"}\n',
        )
    )
    res = ms.solve(ms.load(f), step=math.radians(step))
    lo = minimize_scalar(_slider_x, bounds=(2.5, 3.8), method="bounded", options={"xatol": 1e-12})
    hi = minimize_scalar(
        lambda th: -_slider_x(th), bounds=(-0.6, 0.6), method="bounded", options={"xatol": 1e-12}
    )
    span = -hi.fun - lo.fun
    omega = RPM * 2 * math.pi / 60
    ref = -1500.0 * 0.7 * span + _damper_work(_slider_dx, omega, C_DAMP)
    assert res.work() == pytest.approx(ref, rel=1e-9)
    assert res.forces.stroke_extremes[0] == pytest.approx((lo.fun, -hi.fun), rel=1e-12)


# the shaper's ram C (mechanisms/shaper.yaml, in m): crank O2-A 0.11 about O2 (0, 0.38),
# guide bar O4-B 0.54 about O4 (0, 0), rod B-C 0.135, ram guide at y = 0.52844
def _shaper_dx(theta: float) -> float:
    ax, ay = 0.11 * math.cos(theta), 0.38 + 0.11 * math.sin(theta)
    dax, day = -0.11 * math.sin(theta), 0.11 * math.cos(theta)
    phi = math.atan2(ay, ax)
    dphi = (ax * day - ay * dax) / (ax * ax + ay * ay)
    by = 0.54 * math.sin(phi)
    dbx, dby = -0.54 * math.sin(phi) * dphi, 0.54 * math.cos(phi) * dphi
    h = 0.52844 - by
    return dbx + h * dby / math.sqrt(0.135**2 - h * h)


def _damped_shaper(tmp_path: Path, c: float | None) -> Path:
    text = (MECH / "shaper.yaml").read_text()
    if c is not None:
        text = text.replace(
            "loads:\n", f"loads:\n  damp: {{damper: ram_guide, coefficient: {c} N s/m}}\n", 1
        )
    f = tmp_path / f"shaper-{c}.yaml"
    f.write_text(text)
    return f


def test_shaper_damper_work_is_one_figure_in_terminal_plot_and_report(tmp_path):
    """The shaper with a damper on its ram guide: the terminal, the plot's sweep and the
    report's figures table give one work per cycle and one mean torque; the damper adds
    exactly c * integral of v_C^2 dt (closed form) to the work without it."""
    from mechsolve.report.build import figures_table

    damped = _damped_shaper(tmp_path, 20.0)
    out = tmp_path / "out"
    # in SI, as the API and the report give them
    r = CliRunner().invoke(
        main, ["run", str(damped), "-o", str(out), "--no-plots", "--units", "SI"]
    )
    assert r.exit_code == 0, r.output
    m = re.search(r"work of the driver per cycle: (\S+) J", r.output)
    assert m, r.output
    mean_line = re.search(r"mean (-?[\d.]+) N·m", r.output)
    assert mean_line, r.output

    mech = ms.load(damped)
    res = ms.solve(mech)
    fine = api.for_plots(mech, res)
    assert len(fine.u) > len(res.u)  # the plots' own, finer sweep
    # the plot's legend and the report read these
    assert fine.work_text() == res.work_text() == f"work of the driver per cycle: {m[1]} J"
    assert f"{fine.mean_effort()[0]:.6g}" == f"{res.mean_effort()[0]:.6g}" == mean_line[1]
    assert fine.mean_effort()[1] == "mean"
    rows = {row[0]: row[1] for row in figures_table(fine).rows}
    assert rows["work of the driver"] == f"{m[1]} J"
    assert rows["mean driving torque"] == f"{float(mean_line[1]):.6g} N m"

    plain = ms.solve(ms.load(_damped_shaper(tmp_path, None)))
    omega = 2 * math.pi  # 60 rpm
    ref = _damper_work(_shaper_dx, omega, 20.0)
    assert res.work() - plain.work() == pytest.approx(ref, rel=1e-6)
    # and at another step, the same work
    other = ms.solve(mech, step=math.radians(3.0))
    assert other.work() == pytest.approx(res.work(), rel=1e-9)


# --- §1.7: a design that does not assemble gets no figures --------------------------
STUDY_FOURBAR = Path(__file__).parent / "data" / "study_fourbar.yaml"


def test_design_that_assembles_in_part_has_blank_figures_and_no_pass(tmp_path):
    """A crank of 60 mm with the frame 87.5, coupler 105.6 and rocker 59 mm: |A O4| falls
    below b - c = 46.6 mm near 0 deg (|A O4| = d - a = 27.5 there), so the loop does not
    close over part of the turn. Its partial data once gave a "swing" of 191.5 deg and a
    passing swing requirement: every figure is blank, the status says why, the verdicts
    say "not assembled"; the design that assembles keeps its figures."""
    from mechsolve.analyses.study.table import read_csv

    out = tmp_path / "out"
    r = CliRunner().invoke(
        main,
        [
            "sweep",
            str(STUDY_FOURBAR),
            "-p",
            "links.crank.points.A[0]=60, 26.5 mm",
            "-p",
            "ground.O4[0]=87.5",
            "-j",
            "1",
            "-o",
            str(out),
            "--no-plots",
            "-q",
        ],
    )
    assert r.exit_code == 0, r.output  # a design is not solved everywhere: warned
    assert "warning: " in r.output
    rows = read_csv(out / "study.csv")
    bad, good = rows
    assert bad["status"].startswith("not assemblable at 8 of 37 positions"), bad["status"]
    assert "figures not computed" in bad["status"]
    assert bad["assembles [-]"] == "false" and bad["solved [-]"] == "29"
    figures = [
        "rocker.swing [deg]",
        "min(transmission_angle.B) [deg]",
        "max(abs(input.torque)) (samples) [N*mm]",  # the file's units: mm
        "max(O2.F) (samples) [N]",
        "cycle.work [J]",
        "req.transmission [deg]",
        "req.swing [deg]",
    ]
    for col in figures:
        assert bad[col] == "", (col, bad[col])
        assert good[col] != "", col
    for col in ("req.transmission.pass [-]", "req.swing.pass [-]", "requirements.pass [-]"):
        assert bad[col] == "not assembled", (col, bad[col])
    # the closed form of the good design: crank-rocker swing from the two limit triangles
    b, c, d, a = 105.6, 59.0, 87.5, 26.5
    swing = math.degrees(
        math.acos((c * c + d * d - (b + a) ** 2) / (2 * c * d))
        - math.acos((c * c + d * d - (b - a) ** 2) / (2 * c * d))
    )
    assert float(good["rocker.swing [deg]"]) == pytest.approx(swing, rel=1e-9)
    assert good["requirements.pass [-]"] == "true"


# --- §3.1: Ctrl-C on a study with workers ---------------------------------------------
ROOT = Path(__file__).resolve().parents[1]


def _slow_study(tmp_path: Path) -> Path:
    """The study four-bar without its study section: 512 designs in chunks of 32, the
    first 256 invalid (a negative coupler mass: their rows are finished at once), the
    others solved at 18000 positions each (a chunk of them takes seconds)."""
    text = STUDY_FOURBAR.read_text()
    f = tmp_path / "fourbar.yaml"
    f.write_text(text[: text.index("\nstudy:")] + "\n")
    return f


def _interrupt_after_first_rows(
    tmp_path: Path, extra: list[str], wait: float = 4.0, step: str = "0.02 deg", again: int = 0
):
    import os
    import signal
    import subprocess
    import sys
    import time

    f = _slow_study(tmp_path)
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-m",
        "mechsolve",
        "sweep",
        str(f),
        "-p",
        "links.coupler.mass=-1, 0.2 kg",
        "-p",
        "links.crank.points.A[0]=20..30 mm:256",
        "--step",
        step,
        "-o",
        str(out),
        "--no-plots",
        *extra,
    ]
    env = dict(os.environ, PYTHONPATH=str(ROOT), CI="1")
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=tmp_path,
        start_new_session=True,  # its own process group: Ctrl-C reaches every worker
    )
    first = proc.stdout.readline()  # "study four-bar: 512 designs ...": it is starting
    assert "512 designs" in first, first + proc.stderr.read()
    time.sleep(wait)  # the invalid designs' chunks are finished by then
    assert proc.poll() is None, "the study ended before it was interrupted"
    os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C at a terminal does
    t0 = time.monotonic()
    for _ in range(again):  # pressed again, every second, while it has not ended
        try:
            proc.wait(timeout=1)
            break
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGINT)
    try:
        rest, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    waited = time.monotonic() - t0
    return proc.returncode, waited, first + rest, err, out


def test_ctrl_c_on_a_pool_ends_at_once_and_keeps_the_finished_rows(tmp_path):
    """Ctrl-C on `sweep -j 2`: exit 130 within seconds (it used to wait 20-60 s for the
    workers' chunks), the finished rows written, no traceback."""
    from mechsolve.analyses.study.table import read_csv

    rc, waited, out_text, err, out = _interrupt_after_first_rows(tmp_path, ["-j", "2"])
    assert rc == 130, (rc, out_text, err)
    assert waited < 10.0, f"took {waited:.1f} s to exit after Ctrl-C"
    assert "Traceback" not in err, err
    m = re.search(r"interrupted: (\d+) of 512 designs were finished", err)
    assert m, err
    rows = read_csv(out / "study.csv")
    assert len(rows) == int(m[1]) >= 32
    assert all(r["status"].startswith("invalid") or r["status"] == "ok" for r in rows)


def test_ctrl_c_on_a_dask_cluster_prints_no_worker_tracebacks(tmp_path):
    """Ctrl-C on `sweep --dask -j 2`: the workers (in the same process group) print no
    KeyboardInterrupt tracebacks, the rows finished are written, exit 130. (Ctrl-C is
    held while the cluster starts: it is pressed again until the study ends.)"""
    pytest.importorskip("dask.distributed")
    from mechsolve.analyses.study.table import read_csv

    rc, waited, out_text, err, out = _interrupt_after_first_rows(
        tmp_path, ["--dask", "-j", "2"], wait=1.5, step="0.01 deg", again=30
    )
    assert rc == 130, (rc, out_text, err)
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    m = re.search(r"interrupted: (\d+) of 512 designs were finished", err)
    assert m, err
    assert len(read_csv(out / "study.csv")) == int(m[1])


# --- §3.4: a very large study is estimated first, and refused above a limit -----------
def _run_sweep(tmp_path: Path, args: list[str], timeout: float = 120):
    import os
    import subprocess
    import sys

    f = _slow_study(tmp_path)
    env = dict(os.environ, PYTHONPATH=str(ROOT), CI="1")
    cmd = [sys.executable, "-m", "mechsolve", "sweep", str(f), "--no-plots", *args]
    return subprocess.run(
        cmd, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=timeout
    )


def test_a_million_designs_are_counted_estimated_and_refused(tmp_path):
    """10^6 designs: the count and an estimate (from the first designs, timed) come
    first, then the refusal with its numbers and the option that allows it: exit 2 in
    seconds, no output folder (it used to start solving for hours)."""
    out = tmp_path / "out"
    r = _run_sweep(
        tmp_path,
        [
            "-p",
            "links.coupler.mass=0.1..0.3 kg:1000",
            "-p",
            "links.crank.points.A[0]=20..30 mm:1000",
            "-o",
            str(out),
        ],
        timeout=90,
    )
    assert r.returncode == 2, r.stdout + r.stderr
    assert "1000000 designs (a grid of 1000 x 1000)" in r.stdout
    m = re.search(r"estimate: about ([\d.]+) (s|min|h|days) on a pool of \d+ processes", r.stdout)
    assert m, r.stdout
    assert re.search(r"\(([\d.]+) ms a design, timed on the first 32\)", r.stdout)
    assert "more than --max-designs 100000" in r.stderr
    assert "give --max-designs 1000000" in r.stderr
    assert "Traceback" not in r.stderr
    assert not out.exists()


def test_a_study_over_the_time_limit_is_refused_with_its_estimate(tmp_path):
    """--max-time: 4096 designs at 0.1 deg against a limit of 1 s: refused, exit 2, with
    the estimate, the time per design and the --max-time that would run it."""
    r = _run_sweep(
        tmp_path,
        [
            "-p",
            "links.coupler.mass=0.1..0.3 kg:64",
            "-p",
            "links.crank.points.A[0]=20..30 mm:64",
            "--step",
            "0.1 deg",
            "--max-time",
            "1 s",
            "-j",
            "1",
            "-o",
            str(tmp_path / "out"),
        ],
    )
    assert r.returncode == 2, r.stdout + r.stderr
    assert "4096 designs would take more than --max-time 1 s: about" in r.stderr
    assert "on this process" in r.stderr and "ms a design, timed on the first 32" in r.stderr
    assert re.search(r"give --max-time '\d+ min'", r.stderr), r.stderr


def test_the_timed_first_chunk_is_the_tables_first_rows(tmp_path):
    """The designs timed for the estimate are not solved again: the table equals the one
    solved without the estimate (the rows of every design, the first chunk's included)."""
    from mechsolve.analyses.study.designs import make_study
    from mechsolve.analyses.study.execute import execute, time_first_chunk
    from mechsolve.model.source import load_file

    f = _slow_study(tmp_path)
    study = make_study(
        load_file(f),
        ["links.coupler.mass=0.1..0.3 kg:8", "links.crank.points.A[0]=20..30 mm:8"],
    )
    est = time_first_chunk(study, 1)
    assert est.timed == 4 and est.per_design > 0 and est.memory > 0
    got = execute(study, jobs=1, first=est.rows).rows
    want = execute(study, jobs=1).rows
    assert [r["design [-]"] for r in got] == list(range(64))

    def same(a, b):
        return a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)

    assert all(r.keys() == w.keys() and all(same(r[k], w[k]) for k in r) for r, w in zip(got, want))
