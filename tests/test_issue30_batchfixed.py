"""The kinematics-only design batch with less around its program: the singularity screen
made once per pass over every block's designs, a dyad's length terms made once per pass,
and a design family's numbers from a layout and a table of conversions shared by the
families of one study. Checked against the four-bar's transmission angle by hand (which
designs the batch keeps, over several blocks of the program), and against each design
written into its file and parsed (the stacked numbers, chunk after chunk)."""

from __future__ import annotations

import math

import numpy as np
import yaml

from mechsolve.analyses import batch_program
from mechsolve.analyses.batch import _split
from mechsolve.analyses.study.family import design_family, solve_family
from mechsolve.base.errors import InputError
from mechsolve.model.parse import from_source
from mechsolve.model.source import load_text

FOURBAR = """
name: screened four-bar
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}, mass: 0.05 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}, mass: 0.2 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [59, 0]}, mass: 0.11 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 1 deg}
"""

NEAR = math.sin(math.radians(5.0))


def _smallest_sin_mu(a: float, b: float, c: float, d: float) -> float:
    """The smallest sine of the transmission angle at B over the sweep's samples, by the
    law of cosines in the triangle A B O4 (r = |A O4|); NaN where the loop cannot close
    at some sample."""
    u = np.radians(np.arange(0.0, 361.0, 1.0))
    r2 = a * a + d * d - 2.0 * a * d * np.cos(u)
    cos_mu = (b * b + c * c - r2) / (2.0 * b * c)
    if np.any(np.abs(cos_mu) > 1.0):
        return math.nan
    return float(np.min(np.sqrt(1.0 - cos_mu * cos_mu)))


def test_designs_near_a_toggle_go_alone_in_every_block(monkeypatch):
    """Coupler lengths that bring the loop within 5 deg of its toggle (b + c = d + a at
    the extended crank, |b - c| = d - a at the folded one) over 600 designs in blocks of
    about 100 (the program's screen decided once per pass over every block): a design
    whose smallest sin(mu) by hand is below sin 5 deg is not kept by the batch, one
    above sin 20 deg is, and the kept designs' rocker angle is the vector loop's."""
    monkeypatch.setattr(batch_program, "BLOCK_COLUMNS", 100 * 361)
    b_mm = np.concatenate([np.linspace(50.0, 70.0, 200), np.linspace(100.0, 125.0, 100)])
    a_mm = np.array([26.5, 28.0])
    A, B = np.meshgrid(a_mm, b_mm, indexing="ij")
    fam = design_family(
        load_text(FOURBAR, "screen.yaml"),
        {"links.crank.points.A[0]": A.ravel(), "links.coupler.points.B[0]": B.ravel()},
    )
    batch = solve_family(fam, forces=False, acceleration=False)
    below = above = 0
    for k, (a, b) in enumerate(zip(A.ravel() / 1e3, B.ravel() / 1e3)):
        s = _smallest_sin_mu(a, b, 0.059, 0.0875)
        if not s > NEAR * (1 - 1e-6):  # near a toggle, or not closing: its own sweep
            below += 1
            assert not batch.batched[k], (k, a, b, s)
        elif s > math.sin(math.radians(20.0)):
            above += 1
            assert batch.batched[k], (k, a, b, s)
            rk = batch.results(k).link("rocker")
            # B on the left of A -> O4: the rocker angle from the two circles by hand
            u = np.radians(np.arange(0.0, 361.0, 1.0))
            ax, ay = a * np.cos(u), a * np.sin(u)
            ex, ey = 0.0875 - ax, -ay
            r = np.hypot(ex, ey)
            f = (b * b - 0.059**2 + r * r) / (2 * r)
            h = np.sqrt(b * b - f * f)
            bx = ax + (f * ex - h * ey) / r
            by = ay + (f * ey + h * ex) / r
            want = np.arctan2(by, bx - 0.0875)
            err = np.angle(np.exp(1j * (rk.angle - want)))
            assert np.max(np.abs(err)) < 1e-9
    assert below > 50 and above > 100  # both kinds, spread over the blocks


def _parsed_numbers(a: float, ox: float) -> list[float]:
    """The stacked numbers of the design written into the file and parsed."""
    data = yaml.safe_load(FOURBAR)
    data["links"]["crank"]["points"]["A"][0] = f"{a!r} mm"
    data["ground"]["O4"][0] = f"{ox!r} mm"
    return _split(from_source(load_text(yaml.safe_dump(data, sort_keys=False), "one.yaml")))[1]


def test_chunks_of_one_study_have_the_parsers_numbers():
    """Families of one study made chunk after chunk (values seen before, new ones, a
    zero-length crank the parser refuses): every stacked number, the bars' centres and
    inertias included, is the bits of the design parsed from its own file."""
    base = load_text(FOURBAR, "chunks.yaml")
    whole = design_family(base, {"links.crank.points.A[0]": [], "ground.O4[0]": []})
    chunks = [
        ([26.5, 20.0, 26.5, 31.25], [87.5, 87.5, 90.0, 90.0]),
        ([20.0, 26.5, 31.25, 20.0], [90.0, 87.5, 87.5, 90.0]),  # all seen: looked up
        ([22.75, 0.0, 26.5, 1e-3], [88.0, 87.5, 92.5, 87.5]),  # new ones, one refused
    ]
    for a_vals, o_vals in chunks:
        fam = whole.with_values(np.column_stack([a_vals, o_vals])).prepare()
        assert fam.why_not is None
        for k, (a, ox) in enumerate(zip(a_vals, o_vals)):
            if a == 0.0:
                assert k in fam.invalid
                try:
                    _parsed_numbers(a, ox)
                except InputError as exc:
                    # the same message (the file and line are the study's file's)
                    assert str(exc).split(": ", 1)[1] == str(fam.invalid[k]).split(": ", 1)[1]
                    assert str(fam.invalid[k]).startswith("chunks.yaml:")
                else:
                    raise AssertionError("the parser takes a zero-length crank")
                continue
            want = np.array(_parsed_numbers(a, ox), float)
            got = fam.mechanism(k)
            assert np.array_equal(
                np.array(_split(got)[1], float).view(np.int64), want.view(np.int64)
            )
            lk = got.link("crank")
            # the bar's centre and inertia by hand: the midpoint and m L^2 / 12
            assert lk.com == (a / 2e3, 0.0)
            assert math.isclose(lk.inertia, 0.05 * (a / 1e3) ** 2 / 12, rel_tol=1e-15)
