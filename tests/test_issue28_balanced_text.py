"""The balanced file keeps the original file's text: its comments, key order and layout,
with the counterweights' points and point masses added (the text edited, not the data
written out again). The reference: the original text's lines, all still there, and the
data read back, which must be the original data plus exactly the counterweights."""

from __future__ import annotations

import re

import pytest

import mechsolve as ms
from mechsolve import api

BLOCK = """\
# a four-bar written in block style, with comments everywhere
name: four-bar # its name
units: {length: mm, angle: deg}
ground:
  O2: [0, 0]
  O4: [87.5, 0]
links:
  crank:                      # the driven link
    points:
      O2: [0, 0]              # pivot
      A: [26.5, 0]            # crank pin
    mass: 0.05 kg
    uniform_bar: [O2, A]
  coupler: {points: {A: [0, 0], B: [105.6, 0]}, mass: 0.2 kg, uniform_bar: [A, B]}
  rocker:
    points: {O4: [0, 0], B: [59, 0]}
    mass: 0.11 kg
    uniform_bar: [O4, B]
    point_masses:
      B: 0.01 kg              # a pin's mass, already there
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 4 deg}  # the last line has no newline"""


def added_lines(before: str, after: str) -> list[str]:
    """The lines of ``after`` that are not in ``before``, checking that every line of
    ``before`` is in ``after`` in order, a flow mapping's line with its new entries taken
    out (an edit that only inserts)."""
    out, it = [], iter(after.splitlines())
    flow = re.compile(r", CW_\w+: (\[[^\]]*\]|[0-9.e+-]+ kg)")  # an entry added in a flow map
    for line in before.splitlines():
        for got in it:
            if flow.sub("", got) == line:
                break
            out.append(got)
        else:
            pytest.fail(f"the line {line!r} of the original is lost or changed")
    return out + list(it)


def test_block_and_flow_layouts_keep_every_line_and_comment():
    mech = ms.loads(BLOCK, file="fb.yaml")
    bal = api.balanced(mech)
    text = bal.text
    body = text.split("\n", 2)[2]  # after the two header lines
    new = added_lines(BLOCK, body)
    # one new line for the crank's block points and one for its point_masses; the
    # rocker's flow points and its block point_masses: one new line
    assert len(new) == 3, new
    assert re.fullmatch(r"      CW_crank: \[[-0-9.e]+, [-0-9.e]+\]", new[0])
    assert re.fullmatch(r"    point_masses: \{CW_crank: [0-9.e]+ kg\}", new[1])
    assert re.fullmatch(r"      CW_rocker: [0-9.e]+ kg", new[2])
    # the flow mapping of the rocker's points gained its entry in place
    assert re.search(r"points: \{O4: \[0, 0\], B: \[59, 0\], CW_rocker: \[", text)
    # the data read back: the original plus exactly the counterweights
    again = ms.loads(text, file="fb-balanced.yaml")
    assert set(again.link("crank").points) == {"O2", "A", "CW_crank"}
    assert set(again.link("rocker").points) == {"O4", "B", "CW_rocker"}
    before = {k for k in mech.source.data["links"]["rocker"]["point_masses"]}
    assert before | {"CW_rocker"} == set(again.source.data["links"]["rocker"]["point_masses"])
    # and it is balanced: the shaking force vanishes to rounding
    assert max(bal.after.force) < 1e-12 * max(bal.before.force)


def test_a_variant_is_written_out_afresh_with_the_variant_applied():
    text = BLOCK + "\nvariants:\n  heavy: {links: {crank: {mass: 0.5 kg}}}\n"
    mech = ms.loads(text, file="fb.yaml", variant="heavy")
    bal = api.balanced(mech, variant="heavy")
    assert "from the variant 'heavy'" in bal.text
    assert "# the driven link" not in bal.text  # the data written afresh
    assert ms.loads(bal.text).link("crank").mass == pytest.approx(
        0.5 + bal.balance.counterweights[0].mass
    )
