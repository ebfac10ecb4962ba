"""Streamed (chunked) sweeps give the one-piece sweep's results (issue 30): the branch
followed across a chunk boundary next to a bifurcation, the driving effort at singular
positions, a start inside an unassemblable range, and the RMS effort of the summary."""

from __future__ import annotations

import csv
import math

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
