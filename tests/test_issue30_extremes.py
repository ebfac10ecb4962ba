"""Issue 30 (review 8): printed figures that are the exact values, not samples: the
report's driving-effort extremes and the summary's point ranges located between the
samples, the report's tooth forces, the polygons' formula for a moving guide's point, and
the animation's traced paths drawn from a fine sweep whatever the number of frames.

Each figure is checked against a closed form written here (the oscillating cylinder, the
shaper's crank, slot and ram, the four-bar's crank circle) or against an independent
search with ``run --at`` (the driving torque at driver values chosen by the test)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import mechsolve as ms
from mechsolve import api
from mechsolve.analyses.polygons import build_polygons

MECH = Path(__file__).parents[1] / "mechanisms"

# -- polygons: an oscillating cylinder (the guide's pivot moves with the crank pin) -------
OSC = """
name: oscillating cylinder
units: {length: mm, angle: deg}
ground:
  O2: [0, 0]
  O4: [200, 30]
links:
  crank: {points: {O2: [0, 0], A: [60, 0]}}
  rod: {points: {A: [0, 0], E: [300, 0], F: [100, 40]}}
  block: {points: {O4: [0, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, rod]
  O4: [ground, block]
  cyl: {slider: [rod, block], point: O4, line: [A, E]}
driver: {joint: O2, speed: 10 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 10 deg}
"""


def _osc_rod_point_at_o4(theta: float, w2: float = 10.0) -> np.ndarray:
    """The acceleration (m/s^2) of the rod's point under O4 at crank angle ``theta``, by
    hand: a_A + alpha3 k x AO4 - omega3^2 AO4, the rod's angle phi = atan2(O4 - A) and
    its rates by a five-point difference in the crank angle (crank at a constant w2)."""
    r, o4 = 0.060, np.array([0.200, 0.030])

    def phi(t: float) -> float:
        a = r * np.array([math.cos(t), math.sin(t)])
        return math.atan2(o4[1] - a[1], o4[0] - a[0])

    h = 1e-3
    f = [phi(theta + k * h) for k in (-2, -1, 0, 1, 2)]
    d1 = (f[0] - 8 * f[1] + 8 * f[3] - f[4]) / (12 * h)
    d2 = (-f[0] + 16 * f[1] - 30 * f[2] + 16 * f[3] - f[4]) / (12 * h * h)
    w3, al3 = d1 * w2, d2 * w2**2
    a_pin = -(w2**2) * r * np.array([math.cos(theta), math.sin(theta)])
    d = o4 - r * np.array([math.cos(theta), math.sin(theta)])
    return a_pin + al3 * np.array([-d[1], d[0]]) - w3**2 * d


def test_polygons_moving_guide_point_formula_names_the_pivot_acceleration(tmp_path):
    """a_O43 (the rod's point under the block's pivot) is a_A + a^n + a^t: the printed
    formula names every term its value sums (it left out a_A: 7056 mm/s^2 by its
    terms against the 4585 printed), and the value is the closed form's."""
    path = tmp_path / "osc.yaml"
    path.write_text(OSC)
    r = build_polygons(ms.load(path), "50 deg")
    a = r.arrow("a_O43")
    ref = _osc_rod_point_at_o4(math.radians(50.0))
    np.testing.assert_allclose(a.vec, ref, rtol=1e-8, atol=1e-9 * np.hypot(*ref))
    assert abs(np.hypot(*ref) * 1e3 - 4585.07) < 0.01  # the reviewer's finite differences
    terms = [t.strip() for t in a.note.removeprefix("=").split("+")]
    assert terms[0] == "a_A", a.note
    total = sum(r.arrow(t).vec for t in terms)
    np.testing.assert_allclose(total, a.vec, rtol=1e-12, atol=1e-12 * np.hypot(*ref))
    assert "a_O43 " in r.text() and "= a_A + a^n_O43A + a^t_O43A" in r.text()


# -- report: the tooth forces of a gear mesh ------------------------------------------------
# mechanisms/gear-train.yaml: the pinion (driver, 300 rpm, r1 = 40 mm, 20° pressure angle)
# turns at a constant speed with its centre of mass on its axis, so its moment balance is
# T = Ft r1; the torque by the energy rate of the rod and the ram (the wheel turns at a
# constant -omega / 3 with its centre of mass on its axis), the cutting force's power out.
GT_R, GT_L, GT_ROD, GT_RAM, GT_G = 0.06, 0.26, 1.5, 12.0, 9.81
GT_OMEGA = 300 * 2 * math.pi / 60


def _gt_torque(theta: float) -> float:
    """The pinion's driving torque (N m) at pinion angle ``theta`` (rad), by hand."""
    phi, w = -theta / 3.0, -GT_OMEGA / 3.0
    ay = GT_R * math.sin(phi)
    ax1, ay1 = -GT_R * math.sin(phi) * w, GT_R * math.cos(phi) * w
    ax2, ay2 = -GT_R * math.cos(phi) * w * w, -GT_R * math.sin(phi) * w * w
    s = math.sqrt(GT_L**2 - ay * ay)  # B.x - A.x
    s1 = -ay * ay1 / s
    s2 = -(ay1 * ay1 + ay * ay2 + s1 * s1) / s
    bx1, bx2 = ax1 + s1, ax2 + s2
    gx1, gx2, gy1, gy2 = 0.5 * (ax1 + bx1), 0.5 * (ax2 + bx2), 0.5 * ay1, 0.5 * ay2
    b1 = -ay1 / s  # the rod's angle: sin(beta) = -A.y / L
    b2 = -(ay2 * s - ay1 * s1) / (s * s)
    dke = GT_RAM * bx1 * bx2 + GT_ROD * (gx1 * gx2 + gy1 * gy2) + GT_ROD * GT_L**2 / 12 * b1 * b2
    dpe = GT_ROD * GT_G * gy1
    bx = 0.16 + GT_R * math.cos(phi) + s
    p_load = 1200.0 * bx1 if bx1 < 0 and 0.372 < bx < 0.468 else 0.0
    return (dke + dpe - p_load) / GT_OMEGA


def _printed_within(text: str, ref: float, rel: float = 2e-4) -> bool:
    """``text`` (a table cell) is ``ref`` to its printed digits (or ``rel``)."""
    v = float(text)
    decimals = len(text.partition(".")[2])
    return abs(v - ref) <= max(0.51 * 10.0**-decimals, rel * abs(ref))


def test_report_reaction_table_has_the_tooth_forces():
    """The report's "Driving effort and joint reactions" table gives the mesh's tooth
    forces Ft, Fr and Fn in N, as the CSV does (it gave only Fx, Fy): Ft = T / r1, Fn =
    |Ft| / cos 20°, |Fr| = |Ft| tan 20°, T by the energy rate (closed form)."""
    from mechsolve.report.build import position_tables

    res = ms.solve(ms.load(MECH / "gear-train.yaml"))
    (table,) = [
        t for t in position_tables(res) if t.caption == "Driving effort and joint reactions"
    ]
    head = table.header
    col = {h: k for k, h in enumerate(head)}
    for q in ("Ft", "Fr", "Fn"):
        assert f"mesh(pinion->wheel).{q} [N]" in col, head
    alpha = math.radians(20.0)
    checked = 0
    for row in table.rows:
        theta = math.radians(float(row[col["input.angle [deg]"]]))
        ft = _gt_torque(theta) / 0.040
        if abs(ft) < 1.0:
            continue  # a cell of 2 or 3 digits: not a check of the relation
        assert _printed_within(row[col["mesh(pinion->wheel).Ft [N]"]], ft), (row, ft)
        assert _printed_within(row[col["mesh(pinion->wheel).Fn [N]"]], abs(ft) / math.cos(alpha))
        assert _printed_within(
            row[col["mesh(pinion->wheel).Fr [N]"]].lstrip("-"), abs(ft) * math.tan(alpha)
        )
        checked += 1
    assert checked > 150


def test_report_reaction_table_has_the_rack_tooth_forces():
    """The rack of shaper-scheme2 too: its Ft, Fr, Fn columns, Fn = hypot(Fx, Fy) (the
    tooth force along the line of action) and Fn = |Ft| / cos 20° at every row."""
    from mechsolve.report.build import position_tables

    res = ms.solve(ms.load(MECH / "shaper-scheme2.yaml"))
    (table,) = [
        t for t in position_tables(res) if t.caption == "Driving effort and joint reactions"
    ]
    col = {h: k for k, h in enumerate(table.header)}
    lab = "rack(ram->guide_bar)"
    for q in ("Ft", "Fr", "Fn"):
        assert f"{lab}.{q} [N]" in col, table.header
    for row in table.rows:
        fx, fy = (float(row[col[f"{lab}.{q} [N]"]]) for q in ("Fx", "Fy"))
        fn, ft = float(row[col[f"{lab}.Fn [N]"]]), float(row[col[f"{lab}.Ft [N]"]])
        assert abs(fn - math.hypot(fx, fy)) <= 2e-3 * max(fn, 1.0), row
        assert abs(fn - abs(ft) / math.cos(math.radians(20.0))) <= 2e-3 * max(fn, 1.0), row


# -- report: the driving effort's extremes, located ---------------------------------------
def _torque_search(mech, lo_deg: float, hi_deg: float, largest: bool) -> tuple[float, float]:
    """The driving torque's largest (smallest) value between driver angles ``lo_deg`` and
    ``hi_deg`` and where (deg), by ``run --at`` at the file's speed on a grid narrowed
    three times (0.002° at last): independent of the sweep and of the report's locator."""
    from mechsolve.analyses.instants import Instant, parse_instant, solve_instants

    rates = parse_instant(mech, f"theta={lo_deg} deg")
    sense = 1.0 if largest else -1.0
    for _ in range(3):
        grid = np.linspace(lo_deg, hi_deg, 201)
        inst = [Instant(math.radians(a), rates.ud, rates.udd) for a in grid]
        e = sense * solve_instants(mech, inst).driving_effort
        k = int(np.nanargmax(e))
        step = grid[1] - grid[0]
        lo_deg, hi_deg = grid[k] - step, grid[k] + step
    return sense * float(e[k]), float(grid[k])


def _figures(mech):
    from mechsolve.report.build import figures_table

    res = ms.solve(mech)
    return {r[0]: r for r in figures_table(api.for_plots(mech, res)).rows}


@pytest.mark.parametrize(
    "name, what, lo, hi, value, angle",
    [
        # the reviewer's bisection with run --at: 107416 N mm at 245.2°, -849454 at 91.15°
        ("shaper", "largest", 243.0, 247.0, 107.416, 245.2),
        ("shaper", "smallest", 89.0, 93.0, -849.454, 91.15),
        ("crane", "largest", 225.0, 229.0, 293.497e3, 227.17),
    ],
)
def test_report_driving_torque_extremes_are_located(name, what, lo, hi, value, angle):
    """The report's figures table gives the driving torque's extremes where they are,
    between the 1° samples (it printed the samples to 6 digits: 107393 N mm at 244.83°,
    off in the 4th digit): the value equals a fine run --at search to its 6 printed
    digits, at the angle the search finds (0.01°)."""
    mech = ms.load(MECH / f"{name}.yaml")
    ref, at = _torque_search(mech, lo, hi, what == "largest")
    assert ref == pytest.approx(value, rel=1e-5)  # the reviewer's numbers (SI)
    assert at == pytest.approx(angle, abs=0.03)
    row = _figures(mech)[f"{what} driving torque"]
    printed, unit = row[1].split()[:2]
    scale = {"N": 1.0, "kN": 1e3}[unit]
    assert abs(float(printed) * scale - ref) <= 0.51 * 10 ** (math.floor(math.log10(abs(ref))) - 5)
    shown = float(row[2].removeprefix("driver angle ").removesuffix("°"))
    assert shown == pytest.approx(at, abs=0.01), row
    assert "samples" not in row[2]


def test_report_driving_torque_of_a_motion_law_says_it_is_a_sample():
    """A motion law of time has no sweep to locate in: the row says it is the largest of
    the samples (and the sample's value)."""
    y = (MECH / "slider-crank.yaml").read_text()
    head, _, rest = y.partition("driver:")
    rest = rest.split("\n", 2)[2]
    law = (
        "driver:\n  joint: O\n  direction: ccw\n  start: 0 deg\n  motion:\n"
        "    from: 0 rpm\n    segments:\n      - {accelerate: 0.5 s, to: 60 rpm}\n"
        "      - {run: 1 s}\nsweep: {duration: 1.5 s, time_step: 0.05 s}\n"
    )
    mech = ms.loads(head + law + rest)
    res = ms.solve(mech)
    rows = _figures(mech)
    e = res.driving_effort
    row = rows["largest driving torque"]
    assert "(largest of the 0.05 s samples)" in row[2], row
    assert float(row[1].split()[0]) == pytest.approx(float(np.nanmax(e)), rel=1e-5)


# -- the summary's point ranges, located ----------------------------------------------------
def _shaper_ranges() -> dict[str, tuple[float, ...]]:
    """mechanisms/shaper.yaml by hand (mm): crank r = 110 about O2 (0, 380); the guide bar
    (B at 540 from O4 at the origin) swings +-beta, sin(beta) = 110 / 380, upright when A
    is on top; the rod B-C (135) drives C along y = 528.44 on the side C.x > B.x: C.x is
    extreme with the bar (B still at its limit)."""
    sb = 110 / 380
    cb = math.sqrt(1 - sb * sb)
    bx, by_low = 540 * sb, 540 * cb
    dc = math.sqrt(135**2 - (528.44 - by_low) ** 2)
    return {
        "A": (-110, 110, 270, 490),
        "B": (-bx, bx, by_low, 540),
        "C": (-bx + dc, bx + dc, 528.44, 528.44),
    }


def _slider_crank_ranges() -> dict[str, tuple[float, ...]]:
    """mechanisms/slider-crank.yaml by hand (mm): crank r = 50, rod l = 200, offset e =
    10: the piston C between sqrt((l -+ r)^2 - e^2) on y = 10; the crank pin on its
    circle."""
    r, ln, e = 50, 200, 10
    return {
        "A": (-r, r, -r, r),
        "C": (math.sqrt((ln - r) ** 2 - e**2), math.sqrt((ln + r) ** 2 - e**2), e, e),
    }


def _summary_ranges(text: str) -> dict[str, tuple[list[float], str]]:
    """Each point's ``x lo .. hi, y lo .. hi`` of a summary, in mm, and what follows."""
    import re

    out = {}
    pat = r"^  (\w+): x (\S+) \.\. (\S+) (mm|m), y (\S+) \.\. (\S+) (?:mm|m)([^,\n]*)"
    for m in re.finditer(pat, text, re.M):
        k = 1.0 if m[4] == "mm" else 1e3
        out[m[1]] = ([float(m[i]) * k for i in (2, 3, 5, 6)], m[7])
    return out


def _same6(value: float, ref: float) -> bool:
    """``value`` (printed to 6 significant digits) is ``ref`` rounded."""
    if ref == 0:
        return value == 0
    return abs(value - ref) <= 0.51 * 10 ** (math.floor(math.log10(abs(ref))) - 5)


@pytest.mark.parametrize(
    "name, ref, figures",
    [
        ("shaper", _shaper_ranges, True),
        ("shaper", _shaper_ranges, False),  # from the 5° table alone (the API's summary())
        ("slider-crank", _slider_crank_ranges, True),
    ],
)
def test_summary_point_ranges_are_located(name, ref, figures):
    """The summary's `C: x -21.8116 .. 290.778 mm` was the 5° table's samples beside the
    limit position 290.82 mm of the same summary: each end is now where it is, the
    closed form's to 6 digits (and B.x 156.316, A.x +-110, A.y 270 .. 490)."""
    mech = ms.load(MECH / f"{name}.yaml")
    res = ms.solve(mech)
    text = res.summary(figures=api.for_plots(mech, res) if figures else None)
    found = _summary_ranges(text)
    for p, want in ref().items():
        got, rest = found[p]
        assert "samples" not in rest, (p, rest)
        for g, w in zip(got, want):
            assert _same6(g, w), (p, got, want)
    if name == "shaper":
        assert "0.29082 m at" in text  # the limit position's line agrees


def test_summary_point_ranges_of_a_motion_law_are_located():
    """Driven by a motion law of time from rest (samples 0.05 s apart, uneven in the
    crank's angle), the slider-crank's piston range is still the closed form's."""
    y = (MECH / "slider-crank.yaml").read_text()
    head, _, rest = y.partition("driver:")
    rest = rest.split("\n", 2)[2]
    law = (
        "driver:\n  joint: O\n  direction: ccw\n  start: 0 deg\n  motion:\n"
        "    from: 0 rpm\n    segments:\n      - {accelerate: 0.5 s, to: 60 rpm}\n"
        "      - {run: 1 s}\nsweep: {duration: 1.5 s, time_step: 0.05 s}\n"
    )
    res = ms.solve(ms.loads(head + law + rest))
    found = _summary_ranges(res.summary())
    got, extra = found["C"]
    want = _slider_crank_ranges()["C"]
    assert "samples" not in extra
    assert all(_same6(g, w) for g, w in zip(got, want)), (got, want)


# -- animate: the paths from a fine sweep, whatever the number of frames ---------------------
def _off_circle(x: np.ndarray, y: np.ndarray, r: float) -> float:
    """The largest distance (m) from the circle of radius ``r`` about the origin of the
    polyline through (x, y): at its vertices and the middles of its segments."""
    mx, my = 0.5 * (x[1:] + x[:-1]), 0.5 * (y[1:] + y[:-1])
    px, py = np.r_[x, mx], np.r_[y, my]
    return float(np.max(np.abs(np.hypot(px, py) - r)))


@pytest.mark.parametrize("frames", [13, 7])
def test_animate_paths_come_from_a_fine_sweep(frames):
    """mechanisms/fourbar.yaml with --frames 13: the crank pin's path was a 12-gon through
    the frames, 0.9 mm inside A's circle (r = 26.5 mm about O2 at the origin); drawn from
    the 1° sweep it is within r (1 - cos 0.5°) = 1.0 um of the circle, and each frame's
    traced part runs from the start (0°) to the frame's position."""
    import importlib

    animate = importlib.import_module("mechsolve.report.animate")
    r = 0.0265
    fr = animate.solve_frames(ms.load(MECH / "fourbar.yaml"), frames)
    assert len(fr) == frames
    chord = r * (1 - math.cos(math.pi / (frames - 1)))  # what a polygon through the frames is off
    assert chord > 5e-4
    sag = r * (1 - math.cos(math.radians(0.5)))
    x, y = fr.path("A")
    assert _off_circle(x, y, r) <= 1.01 * sag
    for i in (1, frames // 2, frames - 1):
        tx, ty = fr.trace("A", i)
        assert _off_circle(tx, ty, r) <= 1.01 * sag, i
        assert (tx[0], ty[0]) == pytest.approx((r, 0.0), abs=1e-12)  # the start, 0°
        angle = math.degrees(math.atan2(ty[-1], tx[-1])) % 360 or 360.0
        assert angle == pytest.approx(360.0 * i / (frames - 1), abs=1e-9)  # the frame's own
        swept = np.unwrap(np.arctan2(ty, tx))
        assert np.all(np.diff(swept) > 0) and math.degrees(swept[-1] - swept[0]) == pytest.approx(
            360.0 * i / (frames - 1), abs=1e-9
        )
    # the report's player reads the same paths (rounded to 5 digits of the drawing's
    # 0.2 m: 1e-5 m), not the frames' polygon (``chord`` off)
    data = fr.to_json()
    jx, jy = (np.array(v, float) for v in data["traces"]["A"])
    assert _off_circle(jx, jy, r) <= sag + 1e-5 < chord
    assert len(data["trace_upto"]) == frames and data["trace_upto"][-1] == len(jx) - 1
