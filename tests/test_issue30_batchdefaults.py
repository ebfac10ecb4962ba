"""The design batch's defaults follow each design, as ``mechsolve.solve`` does: forces for
the designs with masses or loads whichever design comes first, and a driver measured from a
line whose direction varies between designs (each design solved on its own, not a crash).
Checked against the four-bar's closed form (Freudenstein's rocker angle, the crank torque
of a uniform rocker under gravity from the power balance) and single solves."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses.batch import solve_designs
from mechsolve.analyses.study.designs import make_study
from mechsolve.model.source import load_text

FOURBAR = """
name: four-bar designs
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [CRANK]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}ROCKER}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 1 rad/s, start: 10 deg DRIVER}
sweep: {range: 360 deg, step: 6 deg}
"""


def _mechs(opts, crank="26.5, 0", rocker="", driver=""):
    text = FOURBAR.replace("CRANK", crank).replace("ROCKER", rocker).replace("DRIVER", driver)
    study = make_study(load_text(text, "p.yaml"), opts)
    return [study.mechanism(k) for k in range(len(study))]


def _rocker_angle(a, u, b=0.1056, c=0.059, d=0.0875):
    """The rocker's angle of the four-bar, B on the left of A -> O4 (vector loop)."""
    ax, ay = a * np.cos(u), a * np.sin(u)
    ex, ey = d - ax, -ay
    r = np.hypot(ex, ey)
    f = (b * b - c * c + r * r) / (2 * r)
    h = np.sqrt(b * b - f * f)
    bx, by = ax + (f * ex - h * ey) / r, ay + (f * ey + h * ex) / r
    return np.arctan2(by, bx - d)


@pytest.mark.parametrize("masses", ["0, 0.1 kg", "0.1, 0 kg"])
def test_forces_by_default_for_each_design_that_has_masses(masses):
    mechs = _mechs([f"links.rocker.mass={masses}"], rocker=", mass: 0.1 kg, uniform_bar: [O4, B]")
    batch = solve_designs(mechs)
    for k, m in enumerate(mechs):
        r = batch.results(k)
        assert (r.forces is not None) == m.needs_forces == (ms.solve(m).forces is not None)
        if not m.needs_forces:
            continue
        # the power balance by hand: M w2 = m g (c/2) cos(th4) w4 + I_O4 w4 a4, w2 = 1 rad/s,
        # the rocker a uniform bar about O4 (I = m c^2 / 3); w4 and a4 from the closed-form
        # angle by central differences (h = 1e-5 rad: 1e-10 relative)
        u, h, c, mass = r.u, 1e-5, 0.059, 0.1

        def th4(x):
            return np.unwrap(_rocker_angle(0.0265, x))

        w4 = (th4(u + h) - th4(u - h)) / (2 * h)
        a4 = (th4(u + h) - 2 * th4(u) + th4(u - h)) / h**2
        torque = mass * 9.81 * c / 2 * np.cos(th4(u)) * w4 + mass * c * c / 3 * w4 * a4
        np.testing.assert_allclose(r.forces.effort, torque, rtol=1e-6, atol=1e-9)
        one = ms.solve(m)
        np.testing.assert_allclose(r.forces.effort, one.forces.effort, rtol=1e-12, atol=1e-15)


def test_a_driver_line_that_varies_between_designs_is_solved_design_by_design():
    mechs = _mechs(
        ["links.crank.points.A[0]=3, 5, 8 mm"], crank="3, 26.5", driver=", line: [O2, A]"
    )
    batch = solve_designs(mechs)  # raised TypeError from math.atan2 on the stacked points
    for k in range(len(mechs)):
        r = batch.results(k)
        ax = (3, 5, 8)[k] * 1e-3
        a = math.hypot(ax, 0.0265)
        # the driver's angle is the line O2 -> A's: the crank's A sits at the angle u
        th4 = _rocker_angle(a, r.u)
        got = r.link("rocker").angle
        assert np.max(np.abs(np.angle(np.exp(1j * (got - th4))))) < 1e-12
        assert k == 0 or not batch.batched[k]
