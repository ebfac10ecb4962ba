"""The fixed cost of one solve: what every call did again with the same answer is done
once, and the answers are those of the longer way (hand-computed here)."""

from __future__ import annotations

import math

import numpy as np

import mechsolve
from mechsolve.base.state import State, scale_rates
from mechsolve.model.expr import Expression

FOURBAR = """
name: four-bar
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, speed: 3 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 120 deg}
"""


def test_public_names_are_looked_up_once() -> None:
    """``mechsolve.solve`` goes through the import machinery on its first use only."""
    f = mechsolve.solve
    assert vars(mechsolve)["solve"] is f
    assert mechsolve.solve is f


def test_constant_speed_scales_rates_as_the_chain_rule() -> None:
    """A scalar speed w turns q' into w q' and q'' into w^2 q'' (no driver acceleration),
    as the array form does; a scalar acceleration adds q' w'."""
    rng = np.random.default_rng(3)
    for ud, udd in ((2.5, 0.0), (2.5, 0.7), (1.0, 0.0)):
        st = State(3, 5)
        st.block[:] = rng.normal(size=st.block.shape)
        v0, a0 = st.block[5:8].copy(), st.block[8:11].copy()
        scale_rates(st, np.float64(ud), np.float64(udd))
        np.testing.assert_allclose(st.block[5:8], ud * v0, rtol=1e-15)
        np.testing.assert_allclose(st.block[8:11], ud * ud * a0 + udd * v0, rtol=1e-14)


def test_sweep_rates_at_constant_speed_match_the_closed_form() -> None:
    """The crank-rocker's rocker rate at 3 rad/s against the derivative of the
    closed-form rocker angle (central differences of the textbook formula)."""
    res = mechsolve.solve(mechsolve.loads(FOURBAR))
    a, b, c, d = 0.0265, 0.1056, 0.059, 0.0875
    th2 = np.asarray(res.u)

    def rocker(t):
        # B left of A -> O4: the open branch (Norton's theta4 with the minus sign)
        k1, k2, k3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
        big_a = np.cos(t) - k1 - k2 * np.cos(t) + k3
        big_b = -2 * np.sin(t)
        big_c = k1 - (k2 + 1) * np.cos(t) + k3
        return 2 * np.arctan2(-big_b - np.sqrt(big_b**2 - 4 * big_a * big_c), 2 * big_a)

    h = 1e-6
    w4 = 3.0 * (rocker(th2 + h) - rocker(th2 - h)) / (2 * h)
    got = np.asarray(res.solution.state.w[res.analysis.system.index["rocker"]])
    np.testing.assert_allclose(got, w4, rtol=1e-6, atol=1e-9)
    assert math.isclose(float(res.solution.ud[0]), 3.0)


def test_expression_uses_follows_its_tree() -> None:
    """``uses`` is kept per tree: an expression given another tree answers for that one."""
    e = Expression("stroke(P.x) > 0")
    assert e.uses("stroke") and not e.uses("max")
    other = Expression("max(P.x, 1) > 0")
    e.tree = other.tree
    assert e.uses("max") and not e.uses("stroke")


def test_ground_points_are_shared_read_only_constants() -> None:
    """A ground point at a few positions is one array per value, kept by the state and
    read-only (as the broadcast views at many positions are), with the point's value."""
    for n in (4, 100):
        st = State(2, n)
        x, y = st.point(2, np.array([0.0875, -0.01]))
        np.testing.assert_array_equal(x, np.full(n, 0.0875))
        np.testing.assert_array_equal(y, np.full(n, -0.01))
        assert not x.flags.writeable and not y.flags.writeable
        assert st.point(2, np.array([0.0875, 0.0]))[0] is x
        vx, vy = st.point_velocity(2, np.array([0.0875, -0.01]))
        assert vx is vy and not np.any(vx)
