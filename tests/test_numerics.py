"""Brent's method and composite Simpson, against scipy and closed forms."""

import math

import numpy as np
import pytest
from scipy.integrate import simpson as scipy_simpson
from scipy.optimize import brentq

from mechsolve.base.numerics import brent_root, simpson

FUNCS = [
    (lambda x: x**3 - 2 * x - 5, 2.0, 3.0),  # Wallis's example
    (lambda x: math.cos(x) - x, 0.0, 1.0),
    (lambda x: math.exp(x) - 10.0, 0.0, 5.0),
    (lambda x: (x - 1.0) ** 3, 0.0, 3.0),  # a triple root: slow for interpolation
    (lambda x: math.atan(20 * (x - 0.3)), -1.0, 2.0),  # steep
    (lambda x: x if x != 0.7 else 0.0, -1.0, 0.7),  # the root at an end
]


@pytest.mark.parametrize("f, a, b", FUNCS)
def test_brent_root_agrees_with_scipy(f, a, b):
    x = brent_root(f, a, b, xtol=1e-14, rtol=1e-15, maxiter=500)
    want = brentq(f, a, b, xtol=1e-14, rtol=1e-15, maxiter=500)
    assert abs(f(x)) <= max(abs(f(want)), 1e-12) or abs(x - want) < 1e-12


def test_brent_root_known_values():
    assert brent_root(lambda x: x * x - 2, 0, 2, xtol=1e-15, rtol=1e-15) == pytest.approx(
        math.sqrt(2), abs=2e-15
    )
    # Dottie's number
    assert brent_root(lambda x: math.cos(x) - x, 0, 1, xtol=1e-15) == pytest.approx(
        0.7390851332151607, abs=2e-15
    )


def test_brent_root_rejects_bad_brackets():
    with pytest.raises(ValueError, match="different signs"):
        brent_root(lambda x: x * x + 1, -1, 1)
    with pytest.raises(ValueError, match="not finite"):
        brent_root(lambda x: math.nan if 0.2 < x < 0.9 else x - 0.5, 0, 1)
    with pytest.raises(RuntimeError, match="did not converge"):
        brent_root(lambda x: (x - 1.0) ** 3, 0.0, 3.0, xtol=1e-14, rtol=1e-15, maxiter=5)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 10, 11, 101])
def test_simpson_agrees_with_scipy_on_uneven_samples(n):
    rng = np.random.default_rng(n)
    x = np.sort(rng.uniform(0, 3, n))
    y = np.sin(x) + x**2
    assert simpson(y, x) == pytest.approx(scipy_simpson(y, x=x), rel=1e-12, abs=1e-14)


@pytest.mark.parametrize("n", [3, 4, 7, 8])
def test_simpson_is_exact_for_quadratics(n):
    rng = np.random.default_rng(7)
    x = np.sort(rng.uniform(-1, 2, n))
    y = 3 * x**2 - x + 2
    a, b = x[0], x[-1]
    exact = (b**3 - a**3) - (b**2 - a**2) / 2 + 2 * (b - a)
    assert simpson(y, x) == pytest.approx(exact, rel=1e-12)
