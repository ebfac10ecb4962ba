"""The ``mechsolve sweep`` command: the table, the best design as a runnable file, the
plots, the exit codes, Parquet and the designs' own results."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.cli.commands.sweep import sweep

FOURBAR = Path(__file__).parent / "data" / "study_fourbar.yaml"


def invoke(*args):
    return CliRunner().invoke(sweep, [str(a) for a in args], catch_exceptions=False)


def read(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_sweep_writes_table_best_and_plots(tmp_path):
    r = invoke(FOURBAR, "-o", tmp_path, "-j", "1")
    assert r.exit_code == 0, r.output
    assert "6 designs (a grid of 3 x 2)" in r.output
    rows = read(tmp_path / "study.csv")
    assert len(rows) == 6
    head = list(rows[0])
    assert head[:4] == ["design [-]", "links.crank.points.A[0] [mm]", "ground.O4[0] [mm]", "status"]
    assert all("[" in h for h in head if h != "status")  # every column names its unit
    # the best design: the largest minimum transmission angle among those that pass
    ok = [r for r in rows if r["requirements.pass [-]"] == "true"]
    best = max(ok, key=lambda r: float(r["min(transmission_angle.B) [deg]"]))
    assert f"best (max min(transmission_angle.B)): design {best['design [-]']}" in r.output
    # best.yaml is a mechanism file that runs, with the design's values
    res = ms.run(tmp_path / "best.yaml")
    a = float(best["links.crank.points.A[0] [mm]"]) / 1000
    assert res.mechanism.links[0].points["A"][0] == pytest.approx(a)
    mu = min(t.angle for t in res.transmission_angles())
    assert math.degrees(mu) == pytest.approx(
        float(best["min(transmission_angle.B) [deg]"]), rel=1e-8
    )
    for name in (
        "study-links_crank_points_A_0.png",
        "study-ground_O4_0.png",
        "study-pass-fail.png",
    ):
        assert (tmp_path / name).stat().st_size > 10_000


def test_no_design_meets_the_requirements_exits_5(tmp_path):
    text = FOURBAR.read_text().replace("rocker.swing >= 55 deg", "rocker.swing >= 120 deg")
    path = tmp_path / "strict.yaml"
    path.write_text(text)
    r = invoke(path, "-o", tmp_path / "out", "-j", "1", "--no-plots")
    assert r.exit_code == 5, r.output
    assert "0 of 6 designs meet every requirement" in r.output


def test_invalid_designs_exit_0_and_are_rows(tmp_path):
    r = invoke(
        FOURBAR, "-o", tmp_path, "-j", "1", "--no-plots", "-p", "links.coupler.mass=0.2, -1 kg"
    )
    assert r.exit_code == 0 and "warning: 6 of 12 designs" in r.output, r.output
    rows = read(tmp_path / "study.csv")
    assert len(rows) == 12
    assert sum(r["status"].startswith("invalid") for r in rows) == 6


def test_bad_input_exits_2_with_a_message(tmp_path):
    r = invoke(FOURBAR, "-o", tmp_path, "-p", "links.crank.point.A[0]=20..30:3")
    assert r.exit_code == 2
    assert "did you mean links.crank.points.A[0]" in r.output
    r = invoke(FOURBAR, "-o", tmp_path, "--best", "min range(Q.y)")
    assert r.exit_code == 2 and "Q.y" in r.output
    r = invoke(FOURBAR, "-o", tmp_path, "--best", "smallest K.y")
    assert r.exit_code == 2 and "start with min or max" in r.output


def test_interrupt_writes_finished_rows(tmp_path, monkeypatch):
    from mechsolve.analyses.study import execute as ex

    real = ex.solve_design

    def stop_at_3(study, k, results_dir=None):
        if k == 3:
            raise KeyboardInterrupt
        return real(study, k, results_dir)

    monkeypatch.setattr(ex, "solve_design", stop_at_3)
    r = invoke(FOURBAR, "-o", tmp_path, "-j", "1", "--no-plots")
    assert r.exit_code == 130
    assert "3 of 6 designs were finished" in r.output
    assert [row["design [-]"] for row in read(tmp_path / "study.csv")] == ["0", "1", "2"]


def test_parquet_and_kept_results(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet", reason="pyarrow is optional")
    r = invoke(
        FOURBAR,
        "-o",
        tmp_path,
        "-j",
        "1",
        "--no-plots",
        "--format",
        "parquet",
        "--keep-results",
        "-p",
        "ground.O4[0]=87.5",
    )
    assert r.exit_code == 0, r.output
    table = pq.read_table(tmp_path / "study.parquet").to_pydict()
    assert table["design [-]"] == [0.0, 1.0, 2.0]
    from test_study import closed_form

    want = []
    for a in (20, 25, 30):  # swing >= 55 deg and transmission >= 25 deg, by the closed form
        cf = closed_form(a, 87.5)
        want.append(cf["swing"] >= 55 and cf["mu"] >= 25)
    assert want == [False, True, False]  # a = 20 mm swings too little, 30 mm transmits badly
    assert table["requirements.pass [-]"] == want
    res = ms.run(FOURBAR)  # the file's own design has a = 26.5 mm: not in the study
    assert len(read(tmp_path / "designs" / "design-00001.csv")) == len(res.u)


def test_random_study_scatter_matrix(tmp_path):
    r = invoke(
        FOURBAR,
        "-o",
        tmp_path,
        "-j",
        "1",
        "--design",
        "random",
        "--samples",
        "8",
        "-p",
        "links.crank.points.A[0]=uniform(20, 30 mm)",
        "-p",
        "ground.O4[0]=uniform(80, 90 mm)",
        "--step",
        "20 deg",
    )
    assert r.exit_code == 0, r.output
    assert len(read(tmp_path / "study.csv")) == 8
    assert (tmp_path / "study-scatter.png").stat().st_size > 10_000
