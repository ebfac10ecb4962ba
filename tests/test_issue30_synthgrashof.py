"""A path-synthesis design asked to be a crank-rocker is valid only if the table's own
Grashof type says crank-rocker: ``path-6-points-line.yaml --seed 2`` picked a design with
crank 20.352, coupler 35.739, rocker 60, frame 44.613 m (s + l = p + q to rounding),
labelled "change point" in its own row and written as the crank-rocker asked. The
reference: s + l against p + q of the four lengths, by hand."""

from __future__ import annotations

import math

import numpy as np

from conftest import MECH


def _spec():
    from mechsolve.analyses.synth.path_gen import read_path
    from mechsolve.analyses.synth.problem import _Reader, read

    src, method = read(MECH / "synth" / "path-6-points-line.yaml")
    return read_path(_Reader(src, method))


def _design_of(a: float, b: float, c: float, d: float):
    """The path design with O2 = (0, 0), O4 = (d, 0) and these crank, coupler and
    rocker lengths (the coupler point and the crank angles: the middle of their bounds)."""
    from mechsolve.analyses.synth.path_gen import Batch, _bounds, _design

    spec = _spec()
    names, bounds = _bounds(spec)
    x = np.array([(lo + hi) / 2 for lo, hi in bounds])
    for key, v in {
        "ground.O2[0]": 0.0,
        "ground.O2[1]": 0.0,
        "ground.O4[0]": d,
        "ground.O4[1]": 0.0,
        "links.crank.points.A.length": a,
        "links.coupler.points.B[0]": b,
        "links.rocker.points.B[0]": c,
    }.items():
        x[names.index(key)] = v
    return _design(Batch(spec), names, x, "optimised 1")


def test_a_change_point_is_not_the_crank_rocker_asked():
    a, b, c, d = 20.0, 35.0, 60.0, 45.0
    assert math.isclose(min(a, b, c, d) + max(a, b, c, d), b + d)  # s + l = p + q
    des = _design_of(a, b, c, d)
    assert des.grashof.startswith("change point"), des.grashof
    assert not des.valid
    assert any("not a crank-rocker" in n for n in des.notes), des.notes


def test_a_crank_rocker_stays_valid():
    a, b, c, d = 20.0, 35.0, 59.0, 45.0  # s + l = 79 < p + q = 80, the crank shortest
    des = _design_of(a, b, c, d)
    assert des.grashof.startswith("crank-rocker"), des.grashof
    assert des.valid, des.notes
