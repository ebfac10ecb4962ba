"""Symbolic derivatives of motion laws written as expressions of time (issue 12).

A driver's law ``u(t)`` is differentiated symbolically by :mod:`mechsolve.model.expr`. Each law
here is checked twice: against derivatives worked out by hand (to 1e-12) and, as an
independent cross-check that shares no code with the differentiation, against
high-order central differences of :meth:`Expression.evaluate_at`.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable

import numpy as np
import pytest

from mechsolve.model.expr import MAX_DEPTH, MAX_LENGTH, ExprError, Expression, walk

T = np.linspace(0.15, 1.85, 61)  # away from the kinks and poles of the laws below
Fn = Callable[[np.ndarray], np.ndarray]


def law(text: str) -> Expression:
    return Expression(text, variables=("t",))


def at(e: Expression, t: np.ndarray = T) -> np.ndarray:
    return e.evaluate_at({"t": t})


def d1_fd(f: Fn, t: np.ndarray, h: float = 1e-2) -> np.ndarray:
    """First derivative by the 8th-order central difference."""
    c = (4 / 5, -1 / 5, 4 / 105, -1 / 280)
    return sum(ck * (f(t + (k + 1) * h) - f(t - (k + 1) * h)) for k, ck in enumerate(c)) / h


def d2_fd(f: Fn, t: np.ndarray, h: float = 1e-2) -> np.ndarray:
    """Second derivative by the 8th-order central difference."""
    c = (8 / 5, -1 / 5, 8 / 315, -1 / 560)
    s = -205 / 72 * f(t)
    s = s + sum(ck * (f(t + (k + 1) * h) + f(t - (k + 1) * h)) for k, ck in enumerate(c))
    return s / h**2


def low_recursion_limit(frames_left: int = 200):
    """A context manager: only ``frames_left`` frames above the caller's."""

    class _Limit:
        def __enter__(self):
            self.old = sys.getrecursionlimit()
            depth = 0
            f = sys._getframe()
            while f is not None:
                depth += 1
                f = f.f_back
            sys.setrecursionlimit(depth + frames_left)

        def __exit__(self, *exc):
            sys.setrecursionlimit(self.old)

    return _Limit()


def evaluator(e: Expression) -> Fn:
    return lambda t: at(e, t)


def size(e: Expression) -> int:
    return sum(1 for _ in walk(e.tree))


# law: (text, u, u', u'') with the derivatives worked out by hand
W = 6.283
CASES: dict[str, tuple[str, Fn, Fn, Fn]] = {
    "issue example": (
        "0.5 * 2 * t^2 + 0.3 * sin(6.283 * t)",
        lambda t: t**2 + 0.3 * np.sin(W * t),
        lambda t: 2 * t + 0.3 * W * np.cos(W * t),
        lambda t: 2 - 0.3 * W**2 * np.sin(W * t),
    ),
    "polynomial": (
        "3 * t^4 - 2*t**3 + t - 7 + 0.5 * t * t",
        lambda t: 3 * t**4 - 2 * t**3 + t - 7 + 0.5 * t**2,
        lambda t: 12 * t**3 - 6 * t**2 + 1 + t,
        lambda t: 36 * t**2 - 12 * t + 1,
    ),
    "trig with units": (
        "30 deg + 2 rad * cos(3 * t) - sin(t) * cos(t)",
        lambda t: math.pi / 6 + 2 * np.cos(3 * t) - np.sin(2 * t) / 2,
        lambda t: -6 * np.sin(3 * t) - np.cos(2 * t),
        lambda t: -18 * np.cos(3 * t) + 2 * np.sin(2 * t),
    ),
    "sqrt": (
        "sqrt(1 + t^2)",
        lambda t: np.sqrt(1 + t**2),
        lambda t: t / np.sqrt(1 + t**2),
        lambda t: (1 + t**2) ** -1.5,
    ),
    "exp and log": (
        "exp(-0.5 * t) * log(1 + t^2)",
        lambda t: np.exp(-t / 2) * np.log(1 + t**2),
        lambda t: np.exp(-t / 2) * (-0.5 * np.log(1 + t**2) + 2 * t / (1 + t**2)),
        lambda t: (
            np.exp(-t / 2)
            * (0.25 * np.log(1 + t**2) - 2 * t / (1 + t**2) + (2 - 2 * t**2) / (1 + t**2) ** 2)
        ),
    ),
    "quotient": (
        "(t^2 + 1) / (t + 2)",
        lambda t: (t**2 + 1) / (t + 2),
        lambda t: (t**2 + 4 * t - 1) / (t + 2) ** 2,
        lambda t: 10 / (t + 2) ** 3,
    ),
    "constant power": (
        "t^2.5 - 4 / t + (1 + t)^-2",
        lambda t: t**2.5 - 4 / t + (1 + t) ** -2,
        lambda t: 2.5 * t**1.5 + 4 / t**2 - 2 * (1 + t) ** -3,
        lambda t: 3.75 * t**0.5 - 8 / t**3 + 6 * (1 + t) ** -4,
    ),
    "exponential power": (
        "2^t + 3 ^ (t^2)",
        lambda t: 2**t + 3 ** (t**2),
        lambda t: math.log(2) * 2**t + 2 * t * math.log(3) * 3 ** (t**2),
        lambda t: (
            math.log(2) ** 2 * 2**t + 3 ** (t**2) * (2 * math.log(3) + (2 * t * math.log(3)) ** 2)
        ),
    ),
    "general power": (
        "t^t",
        lambda t: t**t,
        lambda t: t**t * (np.log(t) + 1),
        lambda t: t**t * ((np.log(t) + 1) ** 2 + 1 / t),
    ),
    "nested chain rule": (
        "sin(cos(2 * t)^2)",
        lambda t: np.sin(np.cos(2 * t) ** 2),
        lambda t: np.cos(np.cos(2 * t) ** 2) * -2 * np.sin(4 * t),
        lambda t: (
            -np.sin(np.cos(2 * t) ** 2) * 4 * np.sin(4 * t) ** 2
            - 8 * np.cos(np.cos(2 * t) ** 2) * np.cos(4 * t)
        ),
    ),
    "tan and atan": (
        "tan(t / 3) + atan(2 * t)",
        lambda t: np.tan(t / 3) + np.arctan(2 * t),
        lambda t: 1 / (3 * np.cos(t / 3) ** 2) + 2 / (1 + 4 * t**2),
        lambda t: 2 / 9 * np.tan(t / 3) / np.cos(t / 3) ** 2 - 16 * t / (1 + 4 * t**2) ** 2,
    ),
    "unary minus and deg": (
        "-(-t^3) - deg(t) / 100",
        lambda t: t**3 - np.degrees(t) / 100,
        lambda t: 3 * t**2 - 180 / math.pi / 100 + 0 * t,
        lambda t: 6 * t,
    ),
    "abs, min and max away from their kinks": (
        "abs(t - 1.01) + min(t, 2.02 - t) + max(t^2, 0.5)",
        lambda t: np.abs(t - 1.01) + np.minimum(t, 2.02 - t) + np.maximum(t**2, 0.5),
        lambda t: np.sign(t - 1.01) + np.where(t < 1.01, 1, -1) + np.where(t**2 > 0.5, 2 * t, 0),
        lambda t: np.where(t**2 > 0.5, 2.0, 0.0),
    ),
}


@pytest.mark.parametrize("name", list(CASES))
def test_derivatives_match_the_hand_derived_closed_forms(name):
    text, u, du, ddu = CASES[name]
    e = law(text)
    e1 = e.derivative("t")
    e2 = e1.derivative("t")
    np.testing.assert_allclose(at(e), u(T), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(at(e1), du(T), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(at(e2), ddu(T), rtol=1e-12, atol=1e-11)


@pytest.mark.parametrize("name", list(CASES))
def test_derivatives_match_finite_differences(name):
    """Independent of the hand-derived forms: differences of the law's own values."""
    text = CASES[name][0]
    e = law(text)
    e1, e2 = e.derivative("t"), e.derivative("t").derivative("t")
    t = T[(np.abs(T - 1.01) > 0.05) & (np.abs(T - math.sqrt(0.5)) > 0.05)]  # no kink in reach

    def f(x):
        return at(e, x)

    scale = 1 + np.abs(at(e2, t))
    np.testing.assert_allclose(at(e1, t), d1_fd(f, t), rtol=1e-7, atol=1e-7 * scale.max())
    np.testing.assert_allclose(at(e2, t), d2_fd(f, t), rtol=1e-5, atol=1e-5 * scale.max())


@pytest.mark.parametrize("name", list(CASES))
def test_derivative_text_parses_back_to_the_same_values(name):
    e = law(CASES[name][0])
    for _ in range(2):
        e = e.derivative("t")
        again = law(e.text)
        assert e.to_text() == e.text
        np.testing.assert_allclose(at(again), at(e), rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize(
    "text,first,second",
    [
        ("0.5 * 2 * t^2 + 0.3 * sin(6.283 * t)", "2 * t + 1.8849 * cos(6.283 * t)", None),
        ("t^3", "3 * t ^ 2", "6 * t"),
        ("0.5 * t * t", "t", "1"),
        ("1 * t + 0", "1", "0"),
        ("0 * sin(t) + 4", "0", "0"),
        ("3 * t^4 - 2 * t^3 + t - 7", "12 * t ^ 3 - 6 * t ^ 2 + 1", "36 * t ^ 2 - 12 * t"),
        ("cos(2 * t)", "-2 * sin(2 * t)", "-4 * cos(2 * t)"),
        ("sqrt(t)", "0.5 / sqrt(t)", None),
        ("abs(t)", "sign(t)", "0"),
        ("t / 2 - 4", "0.5", "0"),
        ("(1 + t)^-2", "-2 * (1 + t) ^ -3", "6 * (1 + t) ^ -4"),
        ("2 ^ t", "0.6931471805599453 * 2 ^ t", "0.4804530139182014 * 2 ^ t"),
        ("-(t - 4)", "-1", "0"),
        ("90 deg * t", "1.5707963267948966", "0"),
    ],
)
def test_simplified_derivatives_stay_small_and_readable(text, first, second):
    e1 = law(text).derivative("t")
    assert e1.text == first
    if second is not None:
        assert e1.derivative("t").text == second


def test_second_derivatives_of_polynomial_and_trig_laws_are_small():
    for text in (
        "0.5 * 2 * t^2 + 0.3 * sin(6.283 * t)",
        "0.3 + 2 * t + 0.5 * sin(3 * t)",
        "1 - cos(2 * t) + t^5 / 20",
        "0.1 * sin(t) * cos(t)",
    ):
        e = law(text)
        e2 = e.derivative("t").derivative("t")
        assert size(e2) <= 4 * size(e), (text, e2.text)


def test_constant_law_evaluates_to_an_array_of_the_times_shape():
    e = law("30 deg")
    assert at(e).shape == T.shape and np.all(at(e) == pytest.approx(math.pi / 6))
    z = e.derivative("t")
    assert z.text == "0" and at(z).shape == T.shape and not at(z).any()
    assert law("t^2").evaluate_at({"t": 3.0}) == 9.0


def test_variables_are_allowed_only_where_listed():
    with pytest.raises(ExprError, match=r"unknown name 'x' \(a variable here is t\)"):
        law("x^2 + t")
    with pytest.raises(ExprError, match=r"the variables here are t, s"):
        Expression("t * y", variables=("t", "s"))
    with pytest.raises(ExprError, match="'t' needs a quantity"):
        Expression("t > 0")  # no variables: exactly today's behaviour
    with pytest.raises(
        ExprError, match=r"a number followed by the variable 't' \(write '2 \* t'\)"
    ):
        law("2 t")  # not two tonnes
    with pytest.raises(ExprError, match="not a variable"):
        law("t^2").derivative("x")
    with pytest.raises(ExprError, match="not a variable"):
        Expression("P.x > 0").derivative("t")
    with pytest.raises(ExprError, match="cannot be a variable"):
        Expression("1", variables=("sin",))
    with pytest.raises(ExprError, match="no value is given for the variable 't'"):
        law("t + 1").evaluate_at({})
    e = Expression("s * t", variables=("t", "s"))
    assert e.derivative("t").text == "s" and e.derivative("s").text == "t"
    assert list(e.evaluate_at({"t": np.array([1.0, 2.0]), "s": 3.0})) == [3.0, 6.0]


@pytest.mark.parametrize(
    "text,message",
    [
        ("P.x + t", "'P.x' is a quantity of the mechanism, not a function of t"),
        ("sin(t) * K.vx", "'K.vx' is a quantity of the mechanism"),
        ("t < 1", "condition"),
        ("t > 0 and t < 1", "condition"),
        ("not t > 1", "condition"),
        ("P left of A -> B", "condition"),
        ("min(t < 1, 2)", "condition"),
        ("stroke(t)", r"stroke\(\) cannot be differentiated"),
    ],
)
def test_quantities_and_conditions_are_not_differentiable(text, message):
    with pytest.raises(ExprError, match=message):
        law(text).derivative("t")


def test_quantities_cannot_be_read_by_evaluate_at():
    with pytest.raises(ExprError, match="'P.x' is a quantity of the mechanism"):
        law("P.x + t").evaluate_at({"t": T})
    with pytest.raises(ExprError, match="stroke"):
        law("stroke(t)").evaluate_at({"t": T})


def test_min_max_sign_are_piecewise_and_the_mean_at_a_tie():
    t = np.array([0.5, 1.0, 1.5])
    np.testing.assert_array_equal(at(law("min(t, 2 - t)").derivative("t"), t), [1, 0, -1])
    np.testing.assert_array_equal(at(law("max(t, 2 - t)").derivative("t"), t), [-1, 0, 1])
    np.testing.assert_array_equal(at(law("abs(t - 1)").derivative("t"), t), [-1, 0, 1])
    assert law("sign(t - 1)").derivative("t").text == "0"


def test_derivative_keeps_the_variables_and_can_be_taken_again():
    e = law("t^5")
    d = e
    for _ in range(5):
        d = d.derivative("t")
        assert d.variables == ("t",)
    assert d.text == "120"
    assert d.derivative("t").text == "0"


def nested_sin(depth: int) -> tuple[str, Fn, Fn]:
    """``sin(sin(...sin(t)))`` with its value and derivative by the chain rule."""

    def u(t):
        for _ in range(depth):
            t = np.sin(t)
        return t

    def du(t):
        out = np.ones_like(t)
        for _ in range(depth):
            out = out * np.cos(t)
            t = np.sin(t)
        return out

    return "sin(" * depth + "t" + ")" * depth, u, du


def test_deep_laws_differentiate_without_recursion():
    text, u, du = nested_sin(MAX_DEPTH)
    tower = "t^" * MAX_DEPTH + "t"  # t^(t^(t^...)), right-associative
    # 0.5 + sqrt(exp(2 log(tan(atan(x))))) is x + 0.5: 12 of them (60 levels) around t^2
    mixed = "0.5 + sqrt(exp(2 * log(tan(atan(" * 12 + "t^2" + ")))))" * 12
    parens = "(" * (MAX_DEPTH - 1) + "t^3" + ")" * (MAX_DEPTH - 1)  # "^" is the 64th
    minus = "-" * (MAX_DEPTH - 1) + "t^3"
    t = np.linspace(1.05, 1.3, 9)
    with low_recursion_limit():
        e = law(text)
        e1 = e.derivative("t")
        e2 = e1.derivative("t")
        np.testing.assert_allclose(at(e1, t), du(t), rtol=1e-12)
        np.testing.assert_allclose(at(e2, t), d1_fd(du, t), rtol=1e-7)
        for deep in (tower, mixed):
            e = law(deep)
            e1 = e.derivative("t")
            e2 = e1.derivative("t")
            assert e1.text and e2.text
            np.testing.assert_allclose(at(e1, t), d1_fd(evaluator(e), t), rtol=1e-7)
            np.testing.assert_allclose(at(e2, t), d1_fd(evaluator(e1), t), rtol=1e-6)
        e1 = law(mixed).derivative("t")
        e2 = e1.derivative("t")
        np.testing.assert_allclose(at(e1, t), 2 * t, rtol=1e-12)
        np.testing.assert_allclose(at(e2, t), 2, rtol=1e-12)
        assert law(parens).derivative("t").text == "3 * t ^ 2"
        assert law(minus).derivative("t").derivative("t").text == "-6 * t"
        with pytest.raises(ExprError, match="nests deeper than 64"):
            law("(" + parens + ")")


def test_long_laws_differentiate_without_recursion():
    terms = [f"{k}e-3 * sin({k} * t) + {k}e-4 * t^{k % 5}" for k in range(1, 200)]
    text = " + ".join(terms)
    text = text[: text.rfind(" + ", 0, MAX_LENGTH - 20)]
    n = text.count("sin(")
    t = np.linspace(0.2, 1.2, 11)
    ks = np.arange(1, n + 1)[:, None]
    with low_recursion_limit():
        e = law(text)
        e1 = e.derivative("t")
        e2 = e1.derivative("t")
        cos_part = (ks * 1e-3 * ks * np.cos(ks * t)).sum(axis=0)
        sin_part = (-ks * 1e-3 * ks**2 * np.sin(ks * t)).sum(axis=0)
        p = ks % 5
        poly1 = (ks * 1e-4 * p * t ** np.maximum(p - 1, 0)).sum(axis=0)
        poly2 = (ks * 1e-4 * p * (p - 1) * t ** np.maximum(p - 2, 0)).sum(axis=0)
        np.testing.assert_allclose(at(e1, t), cos_part + poly1, rtol=1e-12)
        np.testing.assert_allclose(at(e2, t), sin_part + poly2, rtol=1e-12)
        # long products: the powers of t are gathered, not multiplied out term by term
        prod = "*".join(["t"] * ((MAX_LENGTH + 1) // 2))
        assert law(prod).derivative("t").text == "2000 * t ^ 1999"
        assert law("+".join(["t"] * 2000)).derivative("t").text == "2000"
        assert len(law("-".join(["t"] * 2000)).derivative("t").text) < 10


def test_a_law_too_long_to_differentiate_is_refused_clearly_and_quickly():
    text = "sin(t)"
    k = 2
    while len(text) < MAX_LENGTH - 20:
        text += f" * sin({k} * t)"
        k += 1
    with low_recursion_limit():
        t0 = time.process_time()
        with pytest.raises(ExprError, match="^the law is too long to differentiate$"):
            law(text).derivative("t").derivative("t")
        assert time.process_time() - t0 < 2.0


def test_a_long_derivative_text_falls_back_to_a_description():
    text = " * ".join(f"(1 + {k}e-2 * t)" for k in range(40))
    e1 = law(text).derivative("t")
    assert e1.text == f"d/dt ({text})"
    assert e1.derivative("t").text == f"d/dt (d/dt ({text}))"
    t = np.linspace(0.1, 1, 7)
    np.testing.assert_allclose(at(e1, t), d1_fd(lambda x: at(law(text), x), t), rtol=1e-8)


def test_evaluation_is_finite_safe_and_silent():
    with np.errstate(all="raise"):
        v = law("exp(1000 * t) + log(t) + 1 / t").derivative("t").evaluate_at({"t": T - T[0]})
    assert np.isnan(v[0]) or np.isinf(v[0])
    with pytest.raises(ExprError, match="not a finite number"):
        law("t * 1e999")
