"""Issue 30 (review 3): the summary, report and requirements name positions that are
unambiguous on sweeps longer than one turn, a motion law's stroke() extremes refined in
the driver's travel, sweep -p naming a parameter twice, and the small wording items."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.report.build import figures_table
from mechsolve.results.requirements import check_requirements
from mechsolve.results.run import for_plots
from mechsolve.results.summary import places

MECH = Path(__file__).parents[1] / "mechanisms"


# -- a motion law's stroke() extremes ---------------------------------------------------
LAW = """
driver:
  joint: O
  direction: ccw
  start: 0 deg
  motion:
    from: 0 rpm
    segments:
      - {accelerate: 0.5 s, to: 60 rpm}
      - {run: 1 s}
      - {decelerate: 0.5 s}
      - {dwell: 0.5 s}
sweep: {duration: 2.5 s, time_step: STEP}
"""


def _law_run(step: str = "0.05 s"):
    """mechanisms/slider-crank.yaml driven by :data:`LAW` at time steps ``step``."""
    y = (MECH / "slider-crank.yaml").read_text()
    head, _, rest = y.partition("driver:")
    rest = rest.split("\n", 2)[2]
    return ms.solve(ms.loads(head + LAW.replace("STEP", step).lstrip("\n") + rest))


@pytest.mark.parametrize("step", ["0.05 s", "0.0125 s"])
def test_motion_law_stroke_extremes_and_work_do_not_depend_on_the_step(step):
    """The slider-crank driven from rest through 540° (accelerate, run, decelerate,
    dwell) with the gas load of mechanisms/slider-crank.yaml (-1500 N on the piston while
    it moves back and stroke(C.x) > 0.3): the extremes of C.x are those of the offset
    slider-crank, sqrt((l -+ r)^2 - e^2), and, starting and ending at rest at the same
    height of every centre of mass (crank at 0° and 180°: on the line of the pivot and
    the piston), the driver's work is minus the gas's, -2 * 1500 N * 0.7 * stroke: the
    gas acts twice over 70% of the stroke (before: -210.257 J at 0.05 s, extremes read
    off the time samples)."""
    res = _law_run(step)
    r, l, e = 0.05, 0.2, 0.01
    smin, smax = math.sqrt((l - r) ** 2 - e**2), math.sqrt((l + r) ** 2 - e**2)
    ((lo, hi),) = res.forces.stroke_extremes
    assert lo == pytest.approx(smin, abs=1e-12) and hi == pytest.approx(smax, abs=1e-12)
    assert res.work() == pytest.approx(-2 * 1500 * 0.7 * (smax - smin), rel=1e-9)


# -- gear-train.yaml in closed form ----------------------------------------------------
# pinion O1 (driver, 300 rpm ccw, 20 teeth) meshes with the wheel O2 (60 teeth, at 160 mm):
# the wheel turns clockwise at a third of the pinion's angle, phi = -theta / 3, with its
# pin A 60 mm from O2; rod A-B 260 mm (uniform bar 1.5 kg), ram B (12 kg) on y = 0;
# cutting force +1200 N on B while B.vx < 0 and B.x is within 0.1..0.9 of 360..480 mm.
R, L, M_ROD, M_RAM, G = 0.06, 0.26, 1.5, 12.0, 9.81
OMEGA = 300 * 2 * math.pi / 60


def _gt_points(theta: np.ndarray) -> tuple[np.ndarray, ...]:
    """A.x, A.y, B.x (m) at pinion angles ``theta`` (rad), by the gear ratio."""
    phi = -theta / 3.0
    ax, ay = 0.16 + R * np.cos(phi), R * np.sin(phi)
    return ax, ay, ax + np.sqrt(L * L - ay * ay)


def _gt_energy_rate(theta: float) -> float:
    """The pinion's torque (N m) at ``theta`` (rad): (dE/dt - P_cutting) / omega, E = the
    rod's and ram's kinetic energy + the rod's potential energy (the gears turn at
    constant speed, their centres of mass on their axes); rates differentiated by hand
    (the wheel's rate w = -omega / 3 is constant)."""
    phi, w = -theta / 3.0, -OMEGA / 3.0
    ay = R * math.sin(phi)
    ax1, ay1 = -R * math.sin(phi) * w, R * math.cos(phi) * w
    ax2, ay2 = -R * math.cos(phi) * w * w, -R * math.sin(phi) * w * w
    s = math.sqrt(L * L - ay * ay)  # B.x - A.x
    s1 = -ay * ay1 / s
    s2 = -(ay1 * ay1 + ay * ay2 + s1 * s1) / s
    bx1, bx2 = ax1 + s1, ax2 + s2
    gx1, gx2, gy1, gy2 = 0.5 * (ax1 + bx1), 0.5 * (ax2 + bx2), 0.5 * ay1, 0.5 * ay2
    b1 = -ay1 / s  # the rod's angle: sin(beta) = -A.y / L
    b2 = -(ay2 * s - ay1 * s1) / (s * s)
    dke = M_RAM * bx1 * bx2 + M_ROD * (gx1 * gx2 + gy1 * gy2) + M_ROD * L * L / 12 * b1 * b2
    dpe = M_ROD * G * gy1
    bx = 0.16 + R * math.cos(phi) + s
    p_load = 1200.0 * bx1 if bx1 < 0 and 0.372 < bx < 0.468 else 0.0
    return (dke + dpe - p_load) / OMEGA


def _named_angle(text: str) -> float:
    """The pinion angle (deg) that ``driver angle 251° after 2 turns`` names."""
    m = re.fullmatch(r"driver angle ([-\d.e+]+)°(?: after (\d+) turns?)?", text.strip())
    assert m, text
    return float(m.group(1)) + 360.0 * int(m.group(2) or 0)


def _same_printed(text: str, ref: float) -> bool:
    """Is ``text``, a number printed to 6 significant digits, ``ref`` rounded?"""
    v = float(text)
    return abs(v - ref) <= 0.6 * 10 ** (math.floor(math.log10(abs(v))) - 5)


@pytest.fixture(scope="module")
def gear_train():
    y = (MECH / "gear-train.yaml").read_text() + (
        "requirements:\n"
        "  tmax: max(input.torque) <= 100 N*m\n"
        "  tmin: min(input.torque) >= -100 N*m\n"
        "  ram: min(B.x) >= 0.3 m\n"
    )
    res = ms.solve(ms.loads(y))
    fine = for_plots(res.mechanism, res)
    return res, fine


def test_gear_train_limit_positions_name_the_turn(gear_train):
    """The ram is nearest (guide 200 mm) where the wheel has turned half a turn, phi =
    -180°, i.e. the pinion at 540° (at 180° the guide is at 284.75 mm); farthest at
    phi = 0 or -360°: the pinion at 0 or 1080°."""
    res, fine = gear_train
    line = next(s for s in res.summary(figures=fine).splitlines() if "limit positions" in s)
    m = re.search(r"guide ([\d.]+) m at (.+?) to ([\d.]+) m at (.+?) \(stroke", line)
    assert m, line
    lo, hi = _named_angle(m.group(2)), _named_angle(m.group(4))
    assert lo == pytest.approx(540.0, abs=1e-6), line
    assert hi == pytest.approx(0.0, abs=1e-6) or hi == pytest.approx(1080.0, abs=1e-6), line
    for value, at in ((m.group(1), lo), (m.group(3), hi)):
        bx = _gt_points(np.radians(np.array([at])))[2][0]
        assert float(value) == pytest.approx(bx - 0.16, rel=1e-6), (line, at)
    assert _gt_points(np.radians(np.array([180.0])))[2][0] - 0.16 == pytest.approx(0.28475, 1e-4)


def test_gear_train_torque_extremes_are_where_they_are_named(gear_train):
    """The summary's, the report's and the requirements' torque extremes, each at the
    pinion angle it names, equal the closed-form torque there (the smallest is at 971°,
    where the old text said 251°: there the torque is +24.26 N m)."""
    res, fine = gear_train
    line = next(s for s in res.summary(figures=fine).splitlines() if "driving torque" in s)
    found = re.findall(r"(max|min) ([-\d.e+]+) N·m at (driver angle [^,]+)", line)
    assert len(found) == 2, line
    for _, value, where in found:
        ref = _gt_energy_rate(math.radians(_named_angle(where)))
        assert _same_printed(value, ref), (line, ref)
    assert _gt_energy_rate(math.radians(251.0)) > 24.0  # the angle alone misleads
    rows = {r[0]: r for r in figures_table(fine).rows}
    for what in ("largest", "smallest"):
        value, where = rows[f"{what} driving torque"][1:]
        ref = _gt_energy_rate(math.radians(_named_angle(where)))
        assert _same_printed(value.split()[0], ref), (value, where, ref)
    low = rows["limit positions of slider guide"][2]
    assert "the lower at driver angle 180° after 1 turn;" in low, low


def test_gear_train_requirements_name_the_turn(gear_train):
    """The requirements locate min(input.torque) and min(B.x) between the samples: the
    places they name hold the values they print (closed form)."""
    res, fine = gear_train
    verdicts = {v.name: v for v in check_requirements(res.mechanism, res)}
    for name in ("tmax", "tmin"):
        v = verdicts[name]
        at = re.search(r"\(at (driver angle [^)]+)\)", v.message).group(1)
        ref = _gt_energy_rate(math.radians(_named_angle(at)))
        assert v.value == pytest.approx(ref, rel=1e-6, abs=1e-6), (v.message, ref)
    at = re.search(r"\(at (driver angle [^)]+)\)", verdicts["ram"].message).group(1)
    assert _named_angle(at) == pytest.approx(540.0, abs=1e-4), at


def test_places_do_not_merge_hits_from_different_turns(gear_train):
    """A place reached at the same angle in turns that follow each other from the first
    is said once with their number; in later turns with the first and last; otherwise
    each hit with its own turn (the old text merged 100° and 820° into "100° (in each of
    2 turns)", and named 540° as 180°)."""
    res, _ = gear_train
    r = np.radians
    assert places(res, r([100.0, 820.0])) == (
        "driver angle 100° and at driver angle 100° after 2 turns"
    )
    assert places(res, r([100.0, 460.0, 820.0])) == "driver angle 100° (in each of 3 turns)"
    assert places(res, r([460.0, 820.0])) == "driver angle 100° after each of 1 to 2 turns"
    assert places(res, r([540.0])) == "driver angle 180° after 1 turn"
    # the end of the sweep (1080°) is the end of the third turn, as one turn ends at 360°
    assert places(res, r([0.0, 1080.0])) == "driver angle 0° and at driver angle 360° after 2 turns"


def test_multi_turn_positions_from_elsewhere_give_the_travel():
    """Started at 30° (or clockwise), a sweep of three turns gives each position's travel
    from the start; a limit position reached in each turn is said once."""
    y = (MECH / "fourbar.yaml").read_text()
    y = y.replace("range: 360 deg", "range: 1080 deg").replace("start: 0 deg", "start: 30 deg")
    res = ms.solve(ms.loads(y))
    r = np.radians
    assert res.format_u(r(30.0 + 900.0)) == "driver angle 210° (900° from the start)"
    assert res.describe_u(len(res.u) - 1) == "driver angle 30° (1080° from the start)"
    line = next(s for s in res.summary().splitlines() if "limit positions" in s)
    assert line.count("(in each of 3 turns)") == 2, line


def test_time_law_summary_gives_its_time_step_and_the_shown_time_unit():
    """The samples of a motion law are 0.05 s apart, unevenly spaced along the driver
    (0.45° to 18°): the summary says "0.05 s samples" (it said "13.5° samples"); with
    --units time=ms the header says "over 2500 ms" and the jumps t = 500 ms."""
    from mechsolve.base.units import parse_output_units

    res = _law_run()
    step = np.diff(np.degrees(res.u))
    assert step.max() - step[step > 0].min() > 10  # uneven along the driver
    text = res.summary()
    assert "driving torque (0.05 s samples)" in text and "peak reactions (0.05 s samples)" in text
    assert "°" not in re.search(r"driving torque \(([^)]*)\)", text).group(1)
    U = parse_output_units("time=ms", res.mechanism.output_units())
    text = res.summary(units=U)
    assert text.splitlines()[0].endswith(" over 2500 ms"), text.splitlines()[0]
    assert "t = 500 ms (" in text and "(50 ms samples)" in text


# -- sweep -p naming a parameter twice --------------------------------------------------
@pytest.mark.parametrize(
    "second",
    ["links.crank.points.A[0]=22, 24 mm", "links.crank.points.A[ 0 ]=22, 24 mm"],
)
def test_sweep_refuses_a_parameter_given_twice(tmp_path, second):
    """Two -p of one key path (or of two spellings of it) exit 2 naming both, as --at and
    compare refuse a repeat (it ran the last one only, exit 0); a -p still replaces the
    file's own parameter of that key path."""
    from click.testing import CliRunner

    from mechsolve.cli.commands.sweep import sweep

    first = "links.crank.points.A[0]=20, 25 mm"
    args = [str(MECH / "fourbar.yaml"), "-p", first, "-p", second, "-o", str(tmp_path)]
    r = CliRunner().invoke(sweep, args + ["--no-plots", "-q"])
    assert r.exit_code == 2, r.output
    assert repr(first) in r.output and repr(second) in r.output, r.output
    assert not (tmp_path / "study.csv").exists()
    study = MECH / "studies" / "fourbar-study.yaml"
    args = [str(study), "-p", "links.crank.points.A[0]=22 mm", "-o", str(tmp_path / "s")]
    r = CliRunner().invoke(sweep, args + ["--no-plots", "-q", "-j", "1"])
    assert r.exit_code in (0, 5), r.output
    rows = (tmp_path / "s" / "study.csv").read_text().splitlines()
    assert len(rows) == 1 + 8  # 1 value of A[0] (the file's 7 replaced) x 8 of B[0]


# -- a mm file's "cannot close" -------------------------------------------------------
def test_cannot_close_message_in_the_files_length_unit(tmp_path):
    """A mm four-bar whose coupler (15 mm) and rocker (59 mm) cannot reach across
    |AO4| = sqrt(a^2 + d^2 - 2 a d cos(theta)) (a = 26.5, d = 87.5 mm): the reason is in
    mm (it was in m), in the summary, the CSV's status and the error at the start."""
    from mechsolve.base.errors import CannotCloseAtStart

    y = (MECH / "fourbar.yaml").read_text().replace("B: [105.6, 0]", "B: [15, 0]")
    res = ms.solve(ms.loads(y))
    f = res.failures[0]
    th = f.u_first
    D = math.sqrt(26.5**2 + 87.5**2 - 2 * 26.5 * 87.5 * math.cos(th))
    assert f"|AO4| = {D:.6g} mm > 15 mm + 59 mm" in f.reason, f.reason
    assert f.reason in res.summary()
    start = y.replace("start: 0 deg", "start: 180 deg").replace("range: 360 deg", "range: 10 deg")
    with pytest.raises(CannotCloseAtStart) as exc:
        ms.solve(ms.loads(start))
    assert "|AO4| = 114 mm > 15 mm + 59 mm" in str(exc.value), str(exc.value)
