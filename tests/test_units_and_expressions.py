"""Units as textbooks write them, the condition language, and the safe YAML source."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechsolve.base.errors import InputError
from mechsolve.base.units import UnitError, parse_quantity
from mechsolve.model.expr import ExprError, Expression
from mechsolve.model.source import load_text


@pytest.mark.parametrize(
    "text,kind,si",
    [
        ("110 mm", "length", 0.110),
        ("25 deg", "angle", math.radians(25)),
        ("1.06 rpm", "angular speed", 1.06 * 2 * math.pi / 60),
        ("60 r/min", "angular speed", 2 * math.pi),
        ("50 kN", "force", 50e3),
        ("1.1 kg m^2", "moment of inertia", 1.1),
        ("1.1 kg*m^2", "moment of inertia", 1.1),
        ("9.81 m/s^2", "acceleration", 9.81),
        ("475.7 N*m", "torque", 475.7),
        ("2 1/s", "angular speed", 2.0),
        ("1e3 mm", "length", 1.0),
        ("-3.5", "length", -3.5),
    ],
)
def test_quantities(text, kind, si):
    assert parse_quantity(text, kind) == pytest.approx(si, rel=1e-15)


def test_plain_numbers_use_the_default_unit():
    assert parse_quantity(110, "length", "mm") == pytest.approx(0.11)
    assert parse_quantity(90, "angle", "deg") == pytest.approx(math.pi / 2)
    assert parse_quantity("90", "angle", "deg") == pytest.approx(math.pi / 2)


@pytest.mark.parametrize(
    "text,kind,msg",
    [
        ("110 mm", "angle", "is a length, but an angle is expected"),
        ("3 parsecs", "length", "unknown unit 'parsecs'"),
        ("abc", "length", "cannot read 'abc'"),
        (".nan", "length", "cannot read"),
        (float("nan"), "length", "not a finite number"),
        (float("inf"), "force", "not a finite number"),
        (True, "length", "expected a length"),
    ],
)
def test_bad_quantities(text, kind, msg):
    with pytest.raises(UnitError, match=msg):
        parse_quantity(text, kind)


class Ctx:
    def __init__(self):
        self.pts = {
            "A": (np.array([0.0, 0.0]), np.array([0.0, 0.0])),
            "B": (np.array([1.0, 1.0]), np.array([0.0, 0.0])),
            "P": (np.array([0.5, 0.5]), np.array([1.0, -1.0])),
        }

    def point_xy(self, name):
        return self.pts[name]

    def quantity(self, name, attr):
        return {"x": self.pts[name][0], "y": self.pts[name][1], "vx": np.array([-1.0, 2.0])}[attr]


def test_expressions_evaluate_elementwise():
    c = Ctx()
    assert list(Expression("P left of A -> B").evaluate(c)) == [True, False]
    assert list(Expression("P right of A -> B").evaluate(c)) == [False, True]
    assert list(Expression("P.vx < 0").evaluate(c)) == [True, False]
    assert list(Expression("0 <= P.y + 1 < 1.5 and not P.vx > 0").evaluate(c)) == [False, False]
    assert list(Expression("abs(P.y) == 1 or P.x > 1 m").evaluate(c)) == [True, True]
    assert Expression("2 * (1 + 3) ^ 2 - 90 deg").evaluate(c) == pytest.approx(32 - math.pi / 2)
    assert Expression("K.vx < 0").points() == {"K"}
    assert Expression("0.05 <= stroke(C.x) <= 0.95").uses("stroke")


@pytest.mark.parametrize(
    "text,msg",
    [
        ("K.vx <", "expected a number"),
        ("K.vx < 0)", "unexpected '\\)'"),
        ("K < 0", "'K' needs a quantity"),
        ("__import__(os)", "unknown function '__import__'"),
        ("open('x')", "unexpected character"),
        ("K.vx $ 2", "unexpected character '\\$'"),
        ("", "empty"),
        ("sqrt(1, 2)", "takes 1 argument"),
        ("K.__class__ < 1", None),
        ("B left of O3 A", "expected '->'"),
    ],
)
def test_expression_errors(text, msg):
    if msg is None:  # parses, but only as a name the model must provide (checked later)
        assert Expression(text).points() == {"K"}
        return
    with pytest.raises(ExprError, match=msg):
        Expression(text)


def test_source_records_lines_and_refuses_tricks():
    src = load_text("a: 1\nb:\n  c: [1, 2]\n  d: x\n", "f.yaml")
    assert src.line(("b", "d")) == 4
    assert src.line(("b", "c", 1)) == 3
    e = src.error(("b", "d"), "bad")
    assert str(e) == "f.yaml:4: b.d: bad"
    with pytest.raises(InputError, match="appears twice"):
        load_text("a: 1\na: 2\n")
    with pytest.raises(InputError, match="not allowed"):
        load_text("a: !!python/object/apply:os.system ['echo hi']\n")
    bomb = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, "
        f"*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}]\n"
        for i in range(8)
    )
    with pytest.raises(InputError, match="alias bomb"):
        load_text(bomb)
    with pytest.raises(InputError, match="empty"):
        load_text("# nothing\n")
    with pytest.raises(InputError, match="a list"):
        load_text("- a\n- b\n")
