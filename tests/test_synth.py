"""Linkage synthesis (mechsolve.analyses.synth) against independent references: the seed's own
extreme-distance program (seed 000), closed forms of the slider-crank and the guide bar,
limit positions found here by circle intersection over a dense turn of the crank, and the
written mechanism files solved by mechsolve's own API."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses.synth import fourbar, guidebar, motion_gen, slidercrank
from mechsolve.analyses.synth.writer import mechanism_yaml
from mechsolve.base.errors import InputError

DATA = Path(__file__).parent / "data"
REF = json.loads((DATA / "synth_000_crane_design.json").read_text())
rad = math.radians


def seed_program():
    """Seed 000's C program for l1, l2, transcribed."""
    dr = math.pi / 180
    l3, l4 = 4.0, math.sqrt(2.86 * 2.86 + 4 * 4)
    thea0 = math.atan2(4.0, 2.86) + 25.0 * dr
    t1, t2 = 93.0 * dr - thea0, 134.0 * dr - thea0
    mn = math.sqrt(l3 * l3 + l4 * l4 - 2 * l3 * l4 * math.cos(t1))
    mx = math.sqrt(l3 * l3 + l4 * l4 - 2 * l3 * l4 * math.cos(t2))
    return (mx - mn) / 2, (mx + mn) / 2


def own_limits(o1, o3, a, b, c, left: bool, n=200_000):
    """Rocker angle extremes (rad) and the crank angles there, by intersecting the coupler
    circle about A with the rocker circle about O3 at n crank angles, refined by a
    parabola through the extreme sample and its neighbours."""
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ax, ay = o1[0] + a * np.cos(th), o1[1] + a * np.sin(th)
    dx, dy = o3[0] - ax, o3[1] - ay  # A -> O3
    e = np.hypot(dx, dy)
    x = (e * e + b * b - c * c) / (2 * e)
    h = np.sqrt(b * b - x * x)
    s = 1 if not left else -1  # B left of O3 -> A is right of A -> O3
    bx = ax + (x * dx - s * h * dy) / e
    by = ay + (x * dy + s * h * dx) / e
    psi = np.unwrap(np.arctan2(by - o3[1], bx - o3[0]))
    out = []
    for k in (int(np.argmin(psi)), int(np.argmax(psi))):
        y0, y1, y2 = psi[k - 1], psi[k], psi[(k + 1) % n]
        den = y0 - 2 * y1 + y2
        off = 0.5 * (y0 - y2) / den
        out.append((y1 - 0.25 * (y0 - y2) * off, th[k] + off * (th[1] - th[0])))
    mu = np.arccos(np.clip((b * b + c * c - e * e) / (2 * b * c), -1, 1))
    return out, float(np.min(np.minimum(mu, np.pi - mu)))


def test_seed_000_extreme_distances():
    l1, l2 = seed_program()
    (d,) = fourbar.extreme_distance((2.86, 4.0), (0, 0), 4.0, rad(93 - 25), rad(134 - 25))
    assert d.valid and d.grashof.startswith("crank-rocker")
    assert d.lengths["crank"] == pytest.approx(l1, abs=1e-12)
    assert d.lengths["coupler"] == pytest.approx(l2, abs=1e-12)
    assert d.lengths["crank"] == pytest.approx(REF["recomputed"]["l1"], abs=1e-12)
    assert d.lengths["coupler"] == pytest.approx(REF["recomputed"]["l2"], abs=1e-12)
    assert round(d.lengths["crank"], 3) == REF["printed_in_seed"]["l1_crank_O1A_m"]
    assert round(d.lengths["coupler"], 3) == REF["printed_in_seed"]["l2_coupler_AB_m"]


@pytest.mark.parametrize("round_to", [None, 0.001])
def test_seed_000_written_file_swings_the_jib(round_to):
    """The written file, solved by mechsolve: the jib O3C (25 deg from O3B) swings 93..134
    deg, and 92.993..134.000 deg with the lengths rounded to 1 mm as the seed prints them."""
    (d,) = fourbar.extreme_distance((2.86, 4.0), (0, 0), 4.0, rad(68), rad(109))
    text = mechanism_yaml(d, "crane", round_to, rocker_point=("C", 28.525, rad(25)))
    res = ms.solve(ms.loads(text))
    (lp,) = [lp for lp in res.limit_positions() if lp.name == "rocker"]
    lo, hi = math.degrees(lp.low) + 25, math.degrees(lp.high) + 25
    if round_to is None:
        assert (lo, hi) == (pytest.approx(93, abs=1e-7), pytest.approx(134, abs=1e-7))
    else:
        want = REF["recomputed"]["O3C_swing_with_rounded_l1_l2_deg"]
        assert (lo, hi) == (pytest.approx(want[0], abs=1e-6), pytest.approx(want[1], abs=1e-6))
    # the transmission angle mechsolve finds equals the closed form of the design
    (tr,) = res.transmission_angles()
    if round_to is None:
        assert tr.angle == pytest.approx(d.min_transmission, abs=1e-9)


@pytest.mark.parametrize("k", [1.0, 1.25, 1.4, 1.8])
@pytest.mark.parametrize("frame", [None, 1.3])
def test_time_ratio_crank_rockers_by_circle_intersection(k, frame):
    """Every valid solution, checked by an own computation of its limit positions."""
    psi1, psi2 = rad(50), rad(95)
    if k == 1.0 and frame is None:
        with pytest.raises(InputError, match="give the frame length"):
            fourbar.from_time_ratio((0.1, -0.2), 1.0, psi1, psi2, k)
        return
    designs = fourbar.from_time_ratio((0.1, -0.2), 1.0, psi1, psi2, k, frame=frame)
    valid = [d for d in designs if d.valid]
    o3 = (0.1, -0.2)
    for d in designs:
        if not d.valid:  # listed with its reason, checked here: B1, B2 straddle O1-O3
            assert "opposite sides" in d.notes[0]
            o1 = d.ground["O1"]
            b = [(o3[0] + math.cos(p), o3[1] + math.sin(p)) for p in (psi1, psi2)]
            sides = [(o3[0] - o1[0]) * (q[1] - o1[1]) - (o3[1] - o1[1]) * (q[0] - o1[0]) for q in b]
            assert sides[0] * sides[1] < 0
    if (k, frame) == (1.8, 1.3):  # this frame gives no crank-rocker for K = 1.8
        assert not valid
        return
    assert len(valid) >= 2  # two families (folded at one limit or the other)
    assert {d.family.split(",")[0] for d in valid} == {"folded at limit 1", "folded at limit 2"}
    for d in valid:
        L = d.lengths
        if frame is not None:
            assert L["frame"] == pytest.approx(frame, rel=1e-12)
        lims, mu = own_limits(
            d.ground["O1"], o3, L["crank"], L["coupler"], L["rocker"], d.extra["B_left_of_O3_A"]
        )
        (lo, u_lo), (hi, u_hi) = lims
        lo = (lo - psi1 + math.pi) % (2 * math.pi) - math.pi + psi1
        hi = (hi - psi2 + math.pi) % (2 * math.pi) - math.pi + psi2
        assert lo == pytest.approx(psi1, abs=1e-8) and hi == pytest.approx(psi2, abs=1e-8)
        fwd = (u_hi - u_lo) % (2 * math.pi)
        ratio = max(fwd, 2 * math.pi - fwd) / min(fwd, 2 * math.pi - fwd)
        assert ratio == pytest.approx(k, abs=1e-6)
        assert d.min_transmission == pytest.approx(mu, abs=1e-6)


def test_time_ratio_without_frame_picks_the_best_transmission():
    designs = fourbar.from_time_ratio((0, 0), 1.0, rad(60), rad(100), 1.4)
    valid = [d for d in designs if d.valid]
    best = max(d.min_transmission for d in valid)
    # no pivot of a fine grid of frame lengths does better
    for frame in np.linspace(0.3, 3.0, 271):
        try:
            others = fourbar.from_time_ratio((0, 0), 1.0, rad(60), rad(100), 1.4, frame=frame)
        except InputError:
            continue
        for o in others:
            if o.valid:
                assert o.min_transmission <= best + 1e-9


def test_time_ratio_file_confirms_limits_and_k():
    designs = fourbar.from_time_ratio((0, 0), 0.08, rad(70), rad(115), 1.5, frame=0.1)
    d = max((x for x in designs if x.valid), key=lambda x: x.min_transmission)
    res = ms.solve(ms.loads(mechanism_yaml(d, "tr")))
    (lp,) = res.limit_positions()
    assert math.degrees(lp.low) == pytest.approx(70, abs=1e-7)
    assert math.degrees(lp.high) == pytest.approx(115, abs=1e-7)
    assert lp.time_ratio == pytest.approx(1.5, abs=1e-7)


def test_crank_pivot_between_the_limit_lines_is_refused():
    # O1 on the far side of O3 along the bisector: B1 and B2 straddle the frame line
    (d,) = fourbar.extreme_distance((0.3, -2.0), (0, 0), 1.0, rad(60), rad(120))
    assert not d.valid and "opposite sides" in d.notes[0]


def test_slider_crank_against_closed_form():
    for stroke, k, e in [(0.1, 1.4, 0.02), (0.3, 1.2, 0.05), (0.05, 1.6, 0.01)]:
        (d,) = slidercrank.slider_crank(stroke, k, e)
        a, b = d.lengths["crank"], d.lengths["rod"]
        x1, x2 = math.sqrt((b - a) ** 2 - e * e), math.sqrt((b + a) ** 2 - e * e)
        assert x2 - x1 == pytest.approx(stroke, rel=1e-12)
        theta = math.atan2(e, x1) - math.atan2(e, x2)
        assert theta == pytest.approx(math.pi * (k - 1) / (k + 1), abs=1e-12)
        assert d.min_transmission == pytest.approx(math.acos((a + e) / b), abs=1e-12)
        res = ms.solve(ms.loads(mechanism_yaml(d, "sc")))
        (lp,) = res.limit_positions()
        assert (lp.low, lp.high) == (pytest.approx(x1, abs=1e-10), pytest.approx(x2, abs=1e-10))
        assert lp.time_ratio == pytest.approx(k, abs=1e-7)
        (tr,) = res.transmission_angles()
        assert tr.angle == pytest.approx(d.min_transmission, abs=1e-7)


def test_slider_crank_best_offset_beats_a_grid():
    (best,) = slidercrank.slider_crank(0.1, 1.4)
    for e in np.linspace(0.001, 0.17, 170):
        try:
            (d,) = slidercrank.slider_crank(0.1, 1.4, e)
        except InputError:
            continue
        assert d.min_transmission <= best.min_transmission + 1e-9


def test_guide_bar_seed_001():
    (d,) = guidebar.guide_bar(frame=0.380, crank=0.110, bar=0.540)
    assert round(d.time_ratio, 2) == 1.46
    theta = 2 * math.asin(110 / 380)
    assert d.time_ratio == pytest.approx((math.pi + theta) / (math.pi - theta), rel=1e-14)
    assert d.extra["stroke"] == pytest.approx(2 * 540 * 110 / 380 / 1000, rel=1e-12)
    (back,) = guidebar.guide_bar(frame=0.380, k=d.time_ratio)
    assert back.lengths["crank"] == pytest.approx(0.110, rel=1e-12)
    res = ms.solve(ms.loads(mechanism_yaml(d, "gb")))
    (lp,) = [lp for lp in res.limit_positions() if lp.name == "guide_bar"]
    assert lp.swing == pytest.approx(theta, abs=1e-9)
    assert lp.time_ratio == pytest.approx(d.time_ratio, abs=1e-7)


POSITIONS = [((0.0, 0.0), rad(0)), ((0.4, 0.1), rad(20)), ((0.7, 0.35), rad(45))]


def test_three_positions_pass_through_the_positions():
    designs = motion_gen.three_positions(POSITIONS, (-0.1, 0.05), (0.3, 0.0))
    assert all(d.valid for d in designs)
    for d in designs:
        mech = ms.loads(mechanism_yaml(d, "mg"))
        from mechsolve.core import evaluate as core
        from mechsolve.core.sweep import Analysis
        from mechsolve.results.results import Results

        an = Analysis(mech)
        u = np.unwrap(np.array(d.extra["input_angles"]))
        res = Results(an, core.states(an, u, velocity=False, acceleration=False))
        P, Q = res.point("P"), res.point("Q")
        for i, (p, phi) in enumerate(POSITIONS):
            assert (P.x[i], P.y[i]) == (
                pytest.approx(p[0], abs=1e-10),
                pytest.approx(p[1], abs=1e-10),
            )
            ang = math.atan2(Q.y[i] - P.y[i], Q.x[i] - P.x[i])
            assert ang == pytest.approx(phi, abs=1e-10)
        # the fixed pivots are equidistant from the three positions of their pins
        for pts, c in zip(
            d.extra["moving"],
            (d.ground["A0"], d.ground["B0"])
            if d.extra["input"] == "A0"
            else (d.ground["B0"], d.ground["A0"]),
        ):
            r = [math.dist(p, c) for p in pts]
            assert max(r) - min(r) < 1e-12


def test_three_positions_branch_defect_is_reported():
    # the output's pin crosses the line A-B0 between positions: flagged, never silent
    pos = [((0.0, 0.0), rad(0)), ((0.2, 0.3), rad(80)), ((0.5, 0.1), rad(170))]
    designs = motion_gen.three_positions(pos, (0.0, 0.0), (0.3, 0.0))
    for d in designs:
        if not d.valid:
            assert any("defect" in n for n in d.notes)


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: fourbar.extreme_distance((1, 1), (0, 0), 1.0, rad(10), rad(10)), "swing"),
        (lambda: fourbar.extreme_distance((1, 1), (0, 0), -1.0, rad(10), rad(50)), "positive"),
        (lambda: fourbar.from_time_ratio((0, 0), 1.0, rad(10), rad(50), 0.5), ">= 1"),
        (
            lambda: fourbar.from_time_ratio((0, 0), 1.0, rad(10), rad(50), 1.4, frame=100),
            "no crank pivot",
        ),
        (lambda: slidercrank.slider_crank(0.1, 1.4, 5.0), "no crank pivot"),
        (lambda: slidercrank.slider_crank(-0.1, 1.4), "positive"),
        (lambda: guidebar.guide_bar(frame=0.1, crank=0.2), "oscillate"),
        (lambda: guidebar.guide_bar(frame=0.1), "exactly two"),
        (lambda: motion_gen.three_positions(POSITIONS[:2], (0, 0), (1, 0)), "three"),
        (
            lambda: motion_gen.three_positions(
                [((0, 0), 0.0), ((1, 0), 0.0), ((2, 0), 0.0)], (0, 0), (1, 0)
            ),
            "collinear",
        ),
    ],
)
def test_bad_input_is_an_input_error(call, match):
    with pytest.raises(InputError, match=match):
        call()
