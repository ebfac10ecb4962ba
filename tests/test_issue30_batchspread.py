"""The kinematics-only design batch with a design's numbers written out over its block
(a column read by two products of the block's shape) and the start's branches kept
without a selection where every design takes branch +: checked on both branches of
four-bars whose crank and coupler lengths differ from design to design, against the
vector loop and Freudenstein's rates written here."""

from __future__ import annotations

import numpy as np
import pytest

from mechsolve.analyses.batch import _bodies, solve_designs
from mechsolve.analyses.study.designs import make_study
from mechsolve.model.source import load_text

FOURBAR = """
name: four-bar designs
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B SIDE of A -> O4"]
driver: {joint: O2, speed: 1 rad/s, start: 10 deg}
sweep: {range: 360 deg, step: 3 deg}
"""
C, D = 0.059, 0.0875  # rocker and ground (m)


def _by_hand(a, b, u, sign):
    """B on the side ``sign`` (+1 left, -1 right) of A -> O4: the coupler's and the
    rocker's angles and rates (crank at 1 rad/s), and the transmission angle's sine."""
    ax, ay = a * np.cos(u), a * np.sin(u)
    ex, ey = D - ax, -ay
    r = np.hypot(ex, ey)
    f = (b * b - C * C + r * r) / (2 * r)
    h = sign * np.sqrt(b * b - f * f)
    bx = ax + (f * ex - h * ey) / r
    by = ay + (f * ey + h * ex) / r
    th3 = np.arctan2(by - ay, bx - ax)
    th4 = np.arctan2(by, bx - D)
    w3 = a * np.sin(th4 - u) / (b * np.sin(th3 - th4))
    w4 = a * np.sin(th3 - u) / (C * np.sin(th3 - th4))
    return th3, th4, w3, w4, np.abs(np.sin(th3 - th4))


def _wrap(x):
    return np.angle(np.exp(1j * x))


@pytest.mark.parametrize("side, sign", [("left", 1.0), ("right", -1.0)])
def test_both_branches_with_lengths_per_design(side, sign):
    study = make_study(
        load_text(FOURBAR.replace("SIDE", side), "s.yaml"),
        ["links.crank.points.A[0]=20, 24, 28 mm", "links.coupler.points.B[0]=96, 101, 108 mm"],
    )
    mechs = [study.mechanism(k) for k in range(len(study))]
    batch = solve_designs(mechs, forces=False, acceleration=False)
    assert batch.batched.all()
    assert sum(p.get("program") is not None for p in batch._passes) == 1
    for k in range(len(study)):
        a, b = (x / 1e3 for x in study.values(k))
        res = batch.results(k)
        st, u = res.solution.state, res.u
        th3, th4, w3, w4, sin_mu = _by_hand(a, b, u, sign)
        assert np.abs(_wrap(st.th[1] - th3)).max() < 1e-12
        assert np.abs(_wrap(st.th[2] - th4)).max() < 1e-12
        assert np.allclose(st.c[1], np.cos(th3), rtol=0, atol=1e-12)
        assert np.allclose(st.s[1], np.sin(th3), rtol=0, atol=1e-12)
        assert np.allclose(st.w[1], w3, rtol=1e-9, atol=1e-12)
        assert np.allclose(st.w[2], w4, rtol=1e-9, atol=1e-12)
        assert np.allclose(res.solution.indicator[1], sin_mu, rtol=0, atol=1e-12)
        # the start: the branch the condition asks for, at the sweep's first position
        start = res.solution.start
        assert start.modes[1] == sign
        assert abs(_wrap(start.state.th[2][0] - th4[0])) < 1e-12


def test_bodies_as_rows():
    assert _bodies([1, 2]) == slice(1, 3)
    assert _bodies((3,)) == slice(3, 4)
    assert _bodies([2, 4]) == [2, 4]
