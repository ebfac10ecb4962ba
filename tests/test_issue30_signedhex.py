"""Hexadecimal and octal numbers with a sign, and binary numbers, are not YAML 1.2 core
numbers: refused naming the number and what to write (review R18 item 5), as ``1_000``,
``1:45`` and ``1,5`` are, not as an unknown unit ('x1F')."""

from __future__ import annotations

import pytest

from mechsolve.base.errors import InputError
from mechsolve.model import parse

FOURBAR = """\
name: fb
units: {{length: mm, angle: deg}}
ground: {{O2: [0, 0], O4: [60, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [70, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [50, 0]}}}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
driver: {{joint: O2, speed: 1 rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: 10 deg}}
"""


@pytest.mark.parametrize(
    "written, value, what",
    [
        # by hand: 0x1F = 16 + 15 = 31, 0b11010 = 16 + 8 + 2 = 26, 0o17 = 8 + 7 = 15
        ("-0x1F", "-31", "sign"),
        ("+0x1F", "31", "sign"),
        ("-0o17", "-15", "sign"),
        ("0b11010", "26", "binary"),
        ("-0b11010", "-26", "binary"),
        ('"0x1F mm"', "31 mm", "unit"),
    ],
)
def test_a_signed_hex_or_binary_number_is_refused_naming_it(written, value, what):
    with pytest.raises(InputError) as info:
        parse.loads(FOURBAR.format(a=written), file="fb.yaml")
    err, text = info.value, str(info.value)
    assert err.file == "fb.yaml" and err.line == 5, text
    assert err.keypath == "links.crank.points.A[0]", text
    assert "unknown unit" not in text, text
    assert "not a number" in text and f"write {value!r}" in text, text
    assert {"sign": "sign", "binary": "binary", "unit": "before a unit"}[what] in text, text


def test_unsigned_hex_and_octal_are_still_read():
    for written, mm in (("0x1F", 31), ("0o17", 15)):
        mech = parse.loads(FOURBAR.format(a=written), file="fb.yaml")
        assert mech.links[0].points["A"][0] * 1e3 == pytest.approx(mm, rel=1e-12)
