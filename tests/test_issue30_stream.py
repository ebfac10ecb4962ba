"""Streamed (chunked) sweeps give the one-piece sweep's results (issue 30): the branch
followed across a chunk boundary next to a bifurcation, the driving effort at singular
positions, a start inside an unassemblable range, and the RMS effort of the summary."""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np
import pytest

import mechsolve as ms

PARALLELOGRAM = """
name: parallelogram
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [30, 0]}
links:
  crank: {points: {O2: [0, 0], A: [10, 0]}MASS_CRANK}
  coupler: {points: {A: [0, 0], B: [30, 0]}MASS_COUPLER}
  rocker: {points: {O4: [0, 0], B: [10, 0]}MASS_ROCKER}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: {sketch: {B: [38, 6]}}
driver: {joint: O2, speed: 1 rad/s, start: 10 deg}
sweep: {range: RANGE, step: 1 deg}
solver: {method: METHOD}
GRAVITY
"""


def parallelogram(method: str = "newton", rng: str = "720 deg", masses: bool = False) -> str:
    text = PARALLELOGRAM.replace("METHOD", method).replace("RANGE", rng)
    for name, m, a, b in (
        ("CRANK", 0.1, "O2", "A"),
        ("COUPLER", 0.2, "A", "B"),
        ("ROCKER", 0.1, "O4", "B"),
    ):
        extra = f", mass: {m} kg, uniform_bar: [{a}, {b}]" if masses else ""
        text = text.replace(f"MASS_{name}", extra)
    return text.replace("GRAVITY", "gravity: 9.81 m/s^2" if masses else "")


def table(path) -> tuple[list[str], list[list[str]]]:
    rows = [r for r in csv.reader(open(path)) if r and not r[0].startswith("#")]
    return rows[0], rows[1:]


def column(path, name: str) -> np.ndarray:
    head, rows = table(path)
    k = head.index(name)
    return np.array([float(r[k]) if r[k] else math.nan for r in rows])


@pytest.mark.parametrize("method", ["newton", "split-newton"])
@pytest.mark.parametrize("chunk", [169, 170])
def test_branch_kept_across_chunk_boundary(method, chunk, tmp_path):
    """A chunk boundary one or two samples before a bifurcation (crank 180 deg, 360 deg,
    ...): the streamed sweep stays on the parallelogram, rocker angle = crank angle and
    coupler angle 0 (the closed form of the open branch), through all four bifurcations,
    and counts them all."""
    summary, _ = ms.stream(ms.loads(parallelogram(method)), tmp_path / "s.csv", chunk=chunk)
    crank = column(tmp_path / "s.csv", "input.angle [deg]")
    rocker = column(tmp_path / "s.csv", "rocker.angle [deg]")
    coupler = column(tmp_path / "s.csv", "coupler.angle [deg]")
    assert len(crank) == 721 and summary.chunks > 4
    assert np.max(np.abs(rocker - crank)) < 1e-5
    assert np.max(np.abs(coupler)) < 1e-5
    # bifurcations at crank 180, 360, 540 and 720 deg (the links all in line)
    assert summary.events == 4


def test_effort_at_singular_positions_is_its_limit(tmp_path):
    """A parallelogram of uniform bars (0.1, 0.2, 0.1 kg) in gravity turned at a constant
    1 rad/s: its kinetic energy is constant (the coupler translates), so the driving
    torque is the rate of the potential energy, g (0.1 * 5 + 0.2 * 10 + 0.1 * 5) kg mm
    cos(crank) = 29.43 cos(crank) N*mm, also at the bifurcations (180 and 360 deg), where
    it is the limit along the motion. Its RMS over a turn is 29.43 / sqrt 2."""
    text = parallelogram("newton", "360 deg", masses=True)
    summary, coarse = ms.stream(ms.loads(text), tmp_path / "s.csv", chunk=100)
    crank = np.radians(column(tmp_path / "s.csv", "input.angle [deg]"))
    torque = column(tmp_path / "s.csv", "input.torque [N*m]")
    exact = 9.81 * 3.0e-3 * np.cos(crank)
    assert summary.chunks == 4 and np.all(np.isfinite(torque))
    singular = np.flatnonzero(np.isclose(np.cos(crank), -1) | np.isclose(np.cos(crank), 1))
    assert len(singular) == 2
    assert torque[singular] == pytest.approx(exact[singular], rel=1e-8)
    assert torque == pytest.approx(exact, rel=1e-8, abs=1e-12)
    assert summary.effort_peak == pytest.approx((-29.43e-3, 29.43e-3), rel=1e-8)
    assert summary.rms_effort() == pytest.approx(29.43e-3 / math.sqrt(2), rel=1e-8)
    assert summary.effort_by_limit == 2
    text_out = summary.text(coarse)
    assert "RMS 0.0208102 N·m" in text_out and "max 0.02943 N·m" in text_out


def test_rms_effort_is_over_the_motion(tmp_path):
    """The summary's RMS driving torque is the one-piece summary's: the trapezoidal
    integral of torque^2 over the crank's travel, here computed again from the CSV."""
    path = Path(__file__).resolve().parents[1] / "mechanisms" / "fourbar.yaml"
    text = path.read_text().replace("step: 2 deg", "step: 10 deg")
    summary, coarse = ms.stream(ms.loads(text), tmp_path / "s.csv", chunk=20)
    u = np.radians(column(tmp_path / "s.csv", "input.angle [deg]"))
    e = column(tmp_path / "s.csv", "input.torque [N*m]")
    area = np.sum(0.5 * (e[1:] ** 2 + e[:-1] ** 2) * np.abs(np.diff(u)))
    assert summary.chunks == 2
    rms = math.sqrt(area / (2 * math.pi))
    printed = re.search(r"RMS ([0-9.e+-]+) N·m", summary.text(coarse))
    assert printed and float(printed.group(1)) == pytest.approx(rms, rel=2e-6)  # 6 figures
    assert summary.rms_effort() == pytest.approx(rms, rel=1e-8)


def test_start_inside_an_unassemblable_range(tmp_path):
    """The four-bar with a 8.4001 mm rocker: loop B closes only where |A O4| lies between
    105.6 - 8.4001 and 105.6 + 8.4001 mm (|A O4|^2 = 87.5^2 + 26.5^2 - 2 87.5 26.5
    cos(crank)); the sweep starts at crank 0, where it cannot close. The streamed sweep
    keeps the solved positions as the one-piece sweep does (not an error)."""
    path = Path(__file__).resolve().parents[1] / "mechanisms" / "fourbar.yaml"
    text = path.read_text().replace("B: [59, 0]", "B: [8.4001, 0]").replace("2 deg}", "1 deg}")
    for chunk in (50, 104, 50_000):
        summary, _ = ms.stream(ms.loads(text), tmp_path / "s.csv", chunk=chunk)
        th = np.radians(column(tmp_path / "s.csv", "input.angle [deg]"))
        x = column(tmp_path / "s.csv", "B.x [m]")
        y = column(tmp_path / "s.csv", "B.y [m]")
        ao4 = np.sqrt(87.5**2 + 26.5**2 - 2 * 87.5 * 26.5 * np.cos(th))
        closes = (ao4 >= 105.6 - 8.4001) & (ao4 <= 105.6 + 8.4001)
        assert len(th) == 361 and np.array_equal(np.isfinite(x), closes)
        assert summary.solved == int(closes.sum()) == 153
        assert [(f.first, f.last) for f in summary.failures] == [(0, 103), (257, 360)]
        # B on the rocker's circle about O4 and at the coupler's length from A
        bx, by = x[closes] * 1e3, y[closes] * 1e3
        assert np.hypot(bx - 87.5, by) == pytest.approx(8.4001, abs=1e-9)
        ax, ay = 26.5 * np.cos(th[closes]), 26.5 * np.sin(th[closes])
        assert np.hypot(bx - ax, by - ay) == pytest.approx(105.6, abs=1e-9)
        # the edges: |A O4| = 105.6 - 8.4001 mm
        c = (87.5**2 + 26.5**2 - (105.6 - 8.4001) ** 2) / (2 * 87.5 * 26.5)
        edge = math.acos(c)
        (f0, f1) = summary.failures
        assert math.isnan(f0.edge_in) and f0.edge_out == pytest.approx(edge, abs=1e-9)
        assert f1.edge_in == pytest.approx(2 * math.pi - edge, abs=1e-9)
        assert math.isnan(f1.edge_out)


@pytest.mark.parametrize("method", ["newton", "split-newton"])
def test_bifurcation_on_the_overlap_sample_is_counted(method, tmp_path):
    """Chunks of 171 positions: the second chunk starts on the bifurcation at crank 180
    deg (the overlap sample, the first chunk's last); it is counted once, as the other
    three: four events, as in the closed form."""
    summary, _ = ms.stream(ms.loads(parallelogram(method)), tmp_path / "s.csv", chunk=171)
    rocker = column(tmp_path / "s.csv", "rocker.angle [deg]")
    crank = column(tmp_path / "s.csv", "input.angle [deg]")
    assert np.max(np.abs(rocker - crank)) < 1e-5
    assert summary.events == 4


def test_effort_next_to_singular_positions(tmp_path):
    """Started 7e-5 deg past 10 deg, the samples at 180 and 360 deg lie next to the
    bifurcations: the driving torque there is the limit along the motion, 29.43
    cos(crank) N*mm (the closed form above), and the summary says so."""
    text = parallelogram("newton", "360 deg", masses=True)
    text = text.replace("start: 10 deg", "start: 10.00007 deg")
    summary, coarse = ms.stream(ms.loads(text), tmp_path / "s.csv", chunk=100)
    crank = np.radians(column(tmp_path / "s.csv", "input.angle [deg]"))
    torque = column(tmp_path / "s.csv", "input.torque [N*m]")
    assert torque == pytest.approx(9.81 * 3.0e-3 * np.cos(crank), rel=1e-7, abs=1e-12)
    assert summary.effort_near_limit == 2
    assert "at 2 position(s) next to a singular one is its limit" in summary.text(coarse)
