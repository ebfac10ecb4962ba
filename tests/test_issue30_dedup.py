"""The shared root finders that replaced code written twice, against closed forms."""

import math

import numpy as np
import pytest

from mechsolve.base.numerics import bisect_edge, illinois_root

WALLIS = 2.0945514815423265  # the real root of x^3 - 2x - 5 (Wallis; Newton's example)
DOTTIE = 0.7390851332151607  # cos x = x


def _counted(f):
    calls = []

    def g(x):
        calls.append(x)
        return f(x)

    return g, calls


def test_illinois_root_finds_known_roots_superlinearly():
    f, calls = _counted(lambda x: x**3 - 2 * x - 5)
    r = illinois_root(f, 2.0, 3.0, -1.0, 16.0, ftol=1e-14)
    assert r.finite and r.x is not None
    assert abs(r.x - WALLIS) <= 1e-14 / 11.0 + 4e-16  # |f'| > 11 near the root
    # plain regula falsi keeps the end at 3 and converges linearly: 33 evaluations to
    # |f| <= 1e-14; the Illinois modification halves the kept end's value: 8
    assert len(calls) <= 9
    assert all(2.0 < x < 3.0 for x in calls)  # only strictly inside the bracket


def test_illinois_root_either_order_and_to_rounding():
    g = lambda x: math.cos(x) - x  # noqa: E731
    r = illinois_root(g, 1.0, 0.0, g(1.0), g(0.0), xrel=1e-15)
    assert r.x == pytest.approx(DOTTIE, abs=2e-15)
    # without a tolerance, where no float is an exact zero (x^2 = 2), it narrows the
    # bracket to two neighbouring floats and says it found no point
    r = illinois_root(lambda x: x * x - 2.0, 0.0, 2.0, -2.0, 2.0, maxiter=200)
    assert r.x is None and r.finite
    s2 = math.sqrt(2.0)  # correctly rounded, and above the root: s2^2 > 2
    assert s2 * s2 > 2.0
    assert (r.lo, r.hi) == (math.nextafter(s2, 0.0), s2)


def test_illinois_root_stops_where_f_is_not_finite_with_the_bracket_so_far():
    # not defined just beyond the root (a position that does not close): the third
    # point (0.7415) is there; the bracket narrowed by the first two is kept
    g = lambda x: (math.cos(x) - x) if x < 0.7391 else math.nan  # noqa: E731
    r = illinois_root(g, 0.0, 1.0, 1.0, math.cos(1.0) - 1.0)
    assert not r.finite and r.x is None
    assert 0.73 < r.lo < DOTTIE < r.hi == 1.0
    assert r.f_lo == pytest.approx(math.cos(r.lo) - r.lo, rel=1e-15)


def test_illinois_root_refuses_a_bracket_without_a_sign_change():
    with pytest.raises(ValueError, match="different signs"):
        illinois_root(lambda x: x * x + 1, -1.0, 2.0, 2.0, 5.0)
    with pytest.raises(ValueError, match="not finite"):
        illinois_root(lambda x: x, -1.0, 2.0, -1.0, math.inf)
    # an end where f is zero is the root, found without evaluating f
    r = illinois_root(lambda x: 1 / 0, 0.5, 2.0, 0.0, 3.0)
    assert r.x == 0.5


class _Rows:
    """A simulated motion's rows: times, driver values and the driver's rates."""

    def __init__(self, law, d1, d2, t):
        self.t = np.asarray(t, float)
        self.u = law(self.t)
        self._rates = d1(self.t), d2(self.t)

    def driver_rates(self):
        return self._rates


QUINTIC = (
    lambda t: t**5 - t**3 + 2 * t,  # the quintic Hermite interpolant is exact for it
    lambda t: 5 * t**4 - 3 * t**2 + 2,  # > 0: one crossing of each level
    lambda t: 20 * t**3 - 6 * t,
)


@pytest.mark.parametrize("tau", [0.5, 0.5000001, 0.5731, 0.6 - 1e-9])
def test_time_at_a_driver_value_of_a_simulated_motion(tau):
    """The time at which a simulated motion passes a driver value (where a conditional
    load switches) is found on the rows' quintic interpolant to rounding: the closed
    time of a quintic motion."""
    from mechsolve.core.work import _time_at

    rows = _Rows(*QUINTIC, [0.4, 0.5, 0.6, 0.7])
    got = _time_at(rows, 1, float(QUINTIC[0](tau)))
    assert got == pytest.approx(tau, abs=4e-16)


def test_time_at_a_constant_acceleration_and_a_level_not_passed():
    from mechsolve.core.work import _time_at

    law = (lambda t: 0.3 + 2 * t + 1.5 * t * t, lambda t: 2 + 3 * t, lambda t: 3 + 0 * t)
    rows = _Rows(*law, [0.0, 0.1, 0.2])
    us = 0.7
    want = (-2 + math.sqrt(4 + 6 * (us - 0.3))) / 3  # 1.5 t^2 + 2 t - 0.4 = 0
    assert _time_at(rows, 1, us) == pytest.approx(want, abs=1e-16)
    # a level beyond the rows (the interpolant does not pass it): linear in time
    u1, u2 = rows.u[1], rows.u[2]
    beyond = u2 + 0.5 * (u2 - u1)
    assert _time_at(rows, 1, beyond) == pytest.approx(0.25, abs=1e-15)


def test_bisect_edge_to_neighbouring_floats_either_order():
    """The edge of x^2 <= 2 is sqrt(2): the last float that holds and the first that
    does not, whichever side the holding end is on."""
    s2 = math.sqrt(2.0)  # correctly rounded, above the edge: s2^2 > 2
    below = math.nextafter(s2, 0.0)
    assert below * below <= 2.0 < s2 * s2
    assert bisect_edge(lambda x: x * x <= 2.0, 0.0, 2.0) == (below, s2)
    assert bisect_edge(lambda x: x * x > 2.0, 2.0, 0.0) == (s2, below)


def test_bisect_edge_stops_at_a_width_and_a_count():
    calls = []

    def holds(x):
        calls.append(x)
        return x < 0.3

    good, bad = bisect_edge(holds, 0.0, 1.0, width=1e-6)
    assert good < 0.3 <= bad and bad - good < 1e-6
    assert len(calls) == 20  # 2^-20 < 1e-6 < 2^-19: twenty halvings of the unit interval
    good, bad = bisect_edge(lambda x: x < 0.3, 0.0, 1.0, maxiter=3)
    assert (good, bad) == (0.25, 0.375)
