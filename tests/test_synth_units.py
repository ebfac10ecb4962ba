"""The optimising and Burmester syntheses print and draw in the problem's length unit.

A problem in millimetres gets its table, its check line and its figure's axes in mm:
the numbers are the SI ones divided by 1e-3, checked against the linkage the targets
were taken from (mechanisms/fourbar.yaml: crank 26.5 mm, coupler 105.6 mm, rocker 59 mm,
frame 87.5 mm) and against the written file solved again here.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve.cli.main import synth

ROOT = Path(__file__).resolve().parents[1]
PATH_MM = ROOT / "mechanisms" / "synth" / "path-fourbar.yaml"


def _row(output: str) -> list[str]:
    return next(ln for ln in output.splitlines() if ln.startswith(" *1")).split()


def test_path_table_and_check_are_in_the_problems_millimetres(tmp_path):
    out = tmp_path / "d.yaml"
    r = CliRunner().invoke(synth, [str(PATH_MM), "--seed", "1", "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert "largest distance (mm)" in r.output and "frame (mm)" in r.output
    assert "(m)" not in r.output
    cells = _row(r.output)
    crank, coupler, rocker, frame = (float(c) for c in cells[5:9])
    # the linkage the six targets lie on, in mm (a metre figure would read 0.0265)
    assert crank == pytest.approx(26.5, abs=1e-3)
    assert coupler == pytest.approx(105.6, abs=1e-3)
    assert rocker == pytest.approx(59.0, abs=1e-3)
    assert frame == pytest.approx(87.5, abs=1e-3)
    # the check line's distances: the written file solved again, SI -> mm
    m = re.search(r"target point ([-0-9.e, +]+) mm \(largest ([-0-9.e+]+) mm\)", r.output)
    assert m, r.output
    shown = np.array([float(x) for x in m.group(1).split(",")])
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.model.parse import load

    mech = load(out)
    text = out.read_text()
    angles = re.search(r"Crank angles at the targets \(deg\): (.*)", text).group(1)
    u = np.radians([float(a) for a in angles.split(",")])
    res = solve_instants(mech, [Instant(float(a), 1.0, 0.0) for a in u], forces=False)
    p = res.point("P")
    targets = np.array(
        [[58.431416, 50.797487], [60.964479, 61.152060], [45.910834, 69.612386],
         [25.356954, 68.879001], [8.196944, 59.108209], [-0.249271, 45.637930]]
    ) * 1e-3  # fmt: skip
    dist_mm = np.hypot(p.x - targets[:, 0], p.y - targets[:, 1]) / 1e-3
    np.testing.assert_allclose(shown, dist_mm, rtol=2e-3, atol=1e-9)
    assert float(m.group(2)) == pytest.approx(shown.max(), rel=1e-3)
    assert "mm^2, largest" in text and "numbers as written" in text


def _figure_of(monkeypatch, problem: Path, tmp_path: Path, *args: str):
    figs = []
    import mechsolve.writers.plots as plots

    real = plots.pretty_figure

    def keep(fig):
        figs.append(fig)
        real(fig)

    monkeypatch.setattr(plots, "pretty_figure", keep)
    png = tmp_path / "f.png"
    r = CliRunner().invoke(synth, [str(problem), "--plot", str(png), *args])
    assert r.exit_code == 0, r.output
    assert figs
    return figs[-1]


def _ticks_in_mm(ax, data_m: np.ndarray) -> None:
    ax.figure.canvas.draw()
    assert ax.get_xlabel() == "x (mm)" and ax.get_ylabel() == "y (mm)"
    labels = [t.get_text().replace("\u2212", "-") for t in ax.get_xticklabels()]
    locs = ax.get_xticks()
    shown = [(float(t), v) for t, v in zip(labels, locs) if t]
    assert shown
    for text, loc in shown:  # a label is its tick's position in mm
        assert text == pytest.approx(loc / 1e-3, abs=1e-9)
    # and the data (metres inside) lie within the labelled range
    lo, hi = ax.get_xlim()
    assert lo <= data_m.min() and data_m.max() <= hi


def test_path_figure_axes_are_in_mm(monkeypatch, tmp_path):
    fig = _figure_of(monkeypatch, PATH_MM, tmp_path, "--seed", "1")
    ax = fig.axes[0]
    _ticks_in_mm(ax, np.array([-0.249271e-3, 60.964479e-3]))


def test_five_positions_report_pose_errors_in_mm(tmp_path):
    prob = ROOT / "mechanisms" / "synth" / "five-positions.yaml"
    assert "length: mm" in prob.read_text()
    r = CliRunner().invoke(synth, [str(prob)])
    assert r.exit_code == 0, r.output
    line = next(ln for ln in r.output.splitlines() if "pose errors" in ln)
    assert re.search(r"1: [0-9.e+-]+ mm, ", line), line
    assert "-0.000 mm" not in r.output
