"""Instants (``run --at`` and a file's ``instants:``): a review's findings.

1. ``stroke(q)`` in a load's condition uses the exact extremes of ``q`` over the motion,
   the same ones the run uses, not the sweep's samples (whose maximum on the slider-crank
   sits on the first sample and was never refined).
5. A bare number in ``--at`` is read in the file's units, as the file's own ``instants:``
   are (mm and rad where ``units:`` says so; m and deg where it names none).
9. With a motion law, the instant is where the law reaches the driver value asked (on
   any turn), with the law's rates there, and the ``t`` column holds that time.

References written here, independently of mechsolve: the offset slider-crank in closed
form (piston x, its rates, the rod's angle, the driving torque from the power balance
T omega = dE_kin/dt - P_gravity - P_gas), its stroke's ends sqrt((l -+ r)^2 - e^2), and
the segmented motion law integrated by hand.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.optimize import brentq

import mechsolve as ms
from mechsolve.analyses.instants import parse_instant, solve_instants
from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
SLIDER_CRANK = ROOT / "mechanisms" / "slider-crank.yaml"

# mechanisms/slider-crank.yaml in SI: crank r, rod l, the line e above the pivot
R, L, E = 0.05, 0.2, 0.01
W = 1500 * 2 * math.pi / 60
M1, M2, M3, J2, G = 2.4, 0.9, 0.6, 0.0045, 9.81
X_LO, X_HI = math.sqrt((L - R) ** 2 - E * E), math.sqrt((L + R) ** 2 - E * E)
F_GAS = 1500.0


def _crank(th: float, w: float = W) -> dict:
    """Positions, velocities and accelerations at the crank angle ``th`` (constant ``w``):
    A = r (cos, sin), sin(phi) = (e - r sin th) / l, C = A + l (cos phi, sin phi)."""
    c, s = math.cos(th), math.sin(th)
    phi = math.asin((E - R * s) / L)
    dphi = -R * c * w / (L * math.cos(phi))
    ddphi = (R * s * w * w + L * math.sin(phi) * dphi * dphi) / (L * math.cos(phi))
    u = np.array([math.cos(phi), math.sin(phi)])
    n = np.array([-math.sin(phi), math.cos(phi)])
    a = R * np.array([c, s])
    va = R * w * np.array([-s, c])
    aa = -R * w * w * np.array([c, s])

    def on_rod(d: float):
        return a + d * u, va + d * dphi * n, aa + d * ddphi * n - d * dphi * dphi * u

    return {"A": (a, va, aa), "G1": (-0.1 * a, -0.1 * va, -0.1 * aa), "G": on_rod(0.06)} | {
        "C": on_rod(L),
        "dphi": dphi,
        "ddphi": ddphi,
    }


def _stroke(th: float) -> float:
    return (_crank(th)["C"][0][0] - X_LO) / (X_HI - X_LO)


def _torque(th: float) -> tuple[float, bool]:
    """The driving torque (N m) at a constant 1500 rpm and whether the gas acts."""
    k = _crank(th)
    power = J2 * k["ddphi"] * k["dphi"]
    for name, m in (("G1", M1), ("G", M2), ("C", M3)):
        _, v, acc = k[name]
        power += m * float((acc + [0.0, G]) @ v)
    vcx = k["C"][1][0]
    gas = bool(vcx < 0 and _stroke(th) > 0.3)
    if gas:
        power -= -F_GAS * vcx
    return power / W, gas


# where the gas switches off on the way in: stroke(C.x) = 0.3 exactly
SWITCH = brentq(lambda d: _stroke(math.radians(d)) - 0.3, 90.0, 130.0, xtol=1e-13)


def test_the_reference_holds_together():
    """The closed forms checked against themselves: C's speed by central differences, the
    stroke's ends reached (C.x over the turn stays inside them and touches both)."""
    th, h = math.radians(40.0), 1e-6
    x = [_crank(t)["C"][0][0] for t in (th - h, th + h)]
    assert (x[1] - x[0]) / (2 * h) * W == pytest.approx(_crank(th)["C"][1][0], rel=1e-7)
    xs = [_crank(t)["C"][0][0] for t in np.radians(np.linspace(0, 360, 72001))]
    assert X_LO <= min(xs) < X_LO + 1e-9 and X_HI - 1e-9 < max(xs) <= X_HI
    assert 109.66 < SWITCH < 109.67


@pytest.mark.parametrize("offset", [-0.005, 0.002, 0.005, 0.01])
def test_stroke_condition_at_an_instant_uses_the_exact_extremes(offset):
    """Near the gas's switch the instant agrees with the closed form: on before it, off
    after (the sampled maximum, 249.7498 mm instead of 249.7999, kept the gas on up to
    109.684 deg)."""
    theta = SWITCH + offset
    torque, gas = _torque(math.radians(theta))
    assert gas is (offset < 0)
    mech = ms.load(SLIDER_CRANK)
    res = solve_instants(mech, [parse_instant(mech, f"theta={theta!r} deg")])
    assert bool(res.forces.active["gas"][0]) is gas
    assert res.driving_effort[0] == pytest.approx(torque, rel=1e-9)


def _csv_rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(row for row in fh if not row.startswith("#")))


def test_the_files_instants_and_at_switch_the_gas_as_the_run_does(tmp_path):
    """The reviewer's case, 109.67 deg: gas off, -24433.370 N mm, from ``--at`` and from
    the file's ``instants:`` alike (the closed form, gas off)."""
    torque, gas = _torque(math.radians(109.67))
    assert not gas and torque * 1e3 == pytest.approx(-24433.370, abs=1e-3)
    text = SLIDER_CRANK.read_text() + (
        "instants: [{theta: 109.67 deg, omega: 1500 rpm, alpha: 0 rad/s^2}]\n"
    )
    f = tmp_path / "sc.yaml"
    f.write_text(text)
    for args in (
        ["run", str(SLIDER_CRANK), "--at", "theta=109.67 deg"],
        ["run", str(f), "--no-plots", "-q"],
    ):
        out = tmp_path / "out"
        r = CliRunner().invoke(main, [*args, "-o", str(out)])
        assert r.exit_code == 0, r.output
        row = _csv_rows(out / "instants.csv")[0]
        assert float(row["load.gas.active [-]"]) == 0
        assert float(row["input.torque [N*mm]"]) == pytest.approx(torque * 1e3, rel=1e-9)


# -- 5: bare numbers in --at -----------------------------------------------------------

# a slider driving a crank through a rod: crank r = 50 mm about O, rod 150 mm, the
# slider C on the x axis (the reviewer's file); its own instant at s = 150 (mm)
PISTON_DRIVEN = """\
name: piston-driven
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [50, 0]}, mass: 1 kg, com: A, inertia: 0.001 kg m^2}
  rod: {points: {A: [0, 0], C: [150, 0]}, mass: 0.5 kg, uniform_bar: [A, C]}
  piston: {points: {C: [0, 0]}, mass: 0.3 kg, com: C}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cyl: {slider: [ground, piston], point: C, line: {through: [0, 0], angle: 0}}
assembly: ["A.y > 0"]
driver: {joint: cyl, speed: -0.2 m/s, start: 190 mm}
sweep: {range: 85 mm, step: 5 mm}
gravity: 9.81 m/s^2
instants: [{s: 150, v: -0.2, a: 0}]
"""


def _a_x(s: float, r: float = 0.05, rod: float = 0.15) -> float:
    """A.x with C at (s, 0): |A| = r, |C - A| = rod."""
    return (r * r - rod * rod + s * s) / (2 * s)


def test_a_bare_length_is_in_the_files_length_unit(tmp_path):
    mech = ms.loads(PISTON_DRIVEN)
    assert parse_instant(mech, "s=150").u == pytest.approx(0.150, rel=1e-15)
    assert parse_instant(mech, "s=150, v=-0.2").ud == pytest.approx(-0.2)  # a rate: SI
    f = tmp_path / "lin.yaml"
    f.write_text(PISTON_DRIVEN)
    rows = {}
    for name, args in (("at", ["--at", "s=150"]), ("file", ["--no-plots", "-q"])):
        out = tmp_path / name
        r = CliRunner().invoke(main, ["run", str(f), *args, "-o", str(out)])
        assert r.exit_code == 0, r.output
        rows[name] = _csv_rows(out / "instants.csv")[0]
    for row in rows.values():  # --at and the file's own instant: one position, 150 mm
        assert float(row["input.s [mm]"]) == pytest.approx(150.0, rel=1e-12)
        assert float(row["A.x [mm]"]) == pytest.approx(_a_x(0.150) * 1e3, rel=1e-10)


def test_a_bare_length_without_units_is_in_metres():
    text = PISTON_DRIVEN.replace("units: {length: mm, angle: deg}\n", "")
    for a, b in (("[50, 0]", "[0.05, 0]"), ("[150, 0]", "[0.15, 0]"), ("190 mm", "0.19 m")):
        text = text.replace(a, b)
    text = text.replace("range: 85 mm, step: 5 mm", "range: 0.085 m, step: 0.005 m")
    text = text.replace("{s: 150,", "{s: 0.15,")
    mech = ms.loads(text)
    assert mech.length_unit == "m"
    i = parse_instant(mech, "s=0.15")
    assert i.u == pytest.approx(0.15, rel=1e-15)
    res = solve_instants(mech, [i])
    assert res.point("A").x[0] == pytest.approx(_a_x(0.15), rel=1e-10)


@pytest.mark.parametrize(
    ("units", "theta"),
    [("{length: mm, angle: rad}", 1.5), ("{length: mm}", math.radians(1.5))],
)
def test_a_bare_angle_is_in_the_files_angle_unit(units, theta):
    """1.5 is 1.5 rad in a file whose angles are in rad, 1.5 deg where it names none."""
    text = SLIDER_CRANK.read_text().replace("units: {length: mm, angle: deg}", f"units: {units}")
    text = text.replace("start: 0 deg", "start: 0 rad")
    mech = ms.loads(text)
    i = parse_instant(mech, "theta=1.5")
    assert i.u == pytest.approx(theta, rel=1e-15)
    res = solve_instants(mech, [i])
    assert res.point("C").x[0] == pytest.approx(_crank(theta)["C"][0][0], rel=1e-12)
    assert res.driving_effort[0] == pytest.approx(_torque(theta)[0], rel=1e-9)


# -- 9: a motion law past its first turn -------------------------------------------------

SEGMENTS = """driver:
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
sweep: {duration: 2.5 s, time_step: 0.05 s}
"""


def _with_driver(driver: str) -> str:
    text = SLIDER_CRANK.read_text()
    old = (
        "driver: {joint: O, speed: 1500 rpm, start: 0 deg}\nsweep: {range: 360 deg, step: 5 deg}\n"
    )
    assert old in text
    return text.replace(old, driver)


def _segments_by_hand(theta: float) -> tuple[float, float, float]:
    """(t, omega, alpha) in s, deg/s, deg/s^2 where the law first reaches ``theta`` deg:
    0 to 360 deg/s in 0.5 s (90 deg), 1 s at 360 deg/s (to 450 deg), to rest in 0.5 s
    (to 540 deg), at rest."""
    if theta <= 90:
        t = math.sqrt(theta / 360)
        return t, 720 * t, 720.0
    if theta <= 450:
        return 0.5 + (theta - 90) / 360, 360.0, 0.0
    # 450 + 360 tau - 360 tau^2 = theta, the smaller root
    tau = (1 - math.sqrt(1 - (theta - 450) / 90)) / 2
    return 1.5 + tau, 360 - 720 * tau, -720.0


@pytest.mark.parametrize("theta", [530.0, 500.0, 170.0, 60.0])
def test_a_segmented_law_is_met_on_the_turn_asked(theta):
    """530 deg is on the second turn, in the deceleration: 120 deg/s, -720 deg/s^2 at
    1.8333 s (not the first turn's 170 deg at 360 deg/s)."""
    mech = ms.loads(_with_driver(SEGMENTS))
    i = parse_instant(mech, f"theta={theta} deg")
    t, w, a = _segments_by_hand(theta)
    assert math.degrees(i.u) == pytest.approx(theta, rel=1e-14)
    assert (i.t, math.degrees(i.ud), math.degrees(i.udd)) == pytest.approx((t, w, a), rel=1e-9)
    assert f"t = {t:.6g} s" in i.note
    res = solve_instants(mech, [i])
    assert res.t[0] == pytest.approx(t, rel=1e-9)
    k = _crank(math.radians(theta), math.radians(w))
    assert res.point("C").x[0] == pytest.approx(k["C"][0][0], rel=1e-12)
    assert res.point("C").vx[0] == pytest.approx(k["C"][1][0], rel=1e-9)


def test_the_end_of_a_law_that_comes_to_rest():
    """540 deg is where the deceleration ends, at 2 s: at rest (no speed left over from
    meeting it within rounding a little before)."""
    mech = ms.loads(_with_driver(SEGMENTS))
    i = parse_instant(mech, "theta=540 deg")
    assert i.t == pytest.approx(2.0, rel=1e-12)
    assert abs(i.ud) < 1e-12
    assert math.degrees(i.u) == pytest.approx(540, rel=1e-14)


def test_an_angle_behind_the_start_is_met_on_the_next_turn():
    """-10 deg: the law never turns back, it meets the angle at 350 deg (1.2222 s); the
    instant is solved there and says so."""
    mech = ms.loads(_with_driver(SEGMENTS))
    i = parse_instant(mech, "theta=-10 deg")
    t, w, a = _segments_by_hand(350.0)
    assert math.degrees(i.u) == pytest.approx(350, rel=1e-12)
    assert (i.t, math.degrees(i.ud), math.degrees(i.udd)) == pytest.approx((t, w, a), rel=1e-9)
    assert "later turn, at 350 deg" in i.note


def test_an_angle_beyond_the_law_is_refused(tmp_path):
    f = tmp_path / "law.yaml"
    f.write_text(_with_driver(SEGMENTS))
    r = CliRunner().invoke(main, ["run", str(f), "--at", "theta=600 deg", "-o", str(tmp_path)])
    assert r.exit_code == 2, r.output
    assert "does not reach this position" in r.output and "0 to 540 deg" in r.output
    assert "Traceback" not in r.output
    # with both rates given, it is solved where it is asked; the law is never there: no t
    r = CliRunner().invoke(
        main,
        [
            "run",
            str(f),
            "--at",
            "theta=600 deg, omega=1 rad/s, alpha=0 rad/s^2",
            "-o",
            str(tmp_path),
        ],
    )
    assert r.exit_code == 0, r.output
    row = _csv_rows(tmp_path / "instants.csv")[0]
    assert float(row["input.angle [deg]"]) == pytest.approx(600)
    assert row["t [s]"] == ""


def test_the_time_column_holds_the_time_of_each_instant(tmp_path):
    """``t [s]``: the law's time where it is at each instant (the file's own instants too,
    their rates given), the constant-speed driver's travel over its speed."""
    text = _with_driver(SEGMENTS) + (
        "instants: [{theta: 530 deg, omega: 120 deg/s, alpha: -720 deg/s^2},\n"
        "           {theta: 170 deg, omega: 360 deg/s}]\n"
    )
    f = tmp_path / "law.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["run", str(f), "--no-plots", "-q", "-o", str(tmp_path / "a")])
    assert r.exit_code == 0, r.output
    rows = _csv_rows(tmp_path / "a" / "instants.csv")
    for row, theta in zip(rows, (530.0, 170.0)):
        assert float(row["t [s]"]) == pytest.approx(_segments_by_hand(theta)[0], rel=1e-9)
    r = CliRunner().invoke(
        main,
        ["run", str(SLIDER_CRANK), "--at", "theta=100 deg", "-o", str(tmp_path / "b")],
    )
    assert r.exit_code == 0, r.output
    row = _csv_rows(tmp_path / "b" / "instants.csv")[0]
    assert float(row["t [s]"]) == pytest.approx(100 / 360 / 25, rel=1e-12)  # 1500 rpm


def test_a_law_that_turns_back():
    """u = 2 sin t (rad): 90 deg first at asin(pi / 4); -60 deg, behind the start, on the
    way back at pi + asin(pi / 6), with the law's rates 2 cos t and -2 sin t there; 150
    deg (beyond its 114.6 deg) is never reached."""
    law = (
        'driver: {joint: O, motion: {law: "2 * sin(t)"}}\n'
        "sweep: {duration: 6 s, time_step: 0.05 s}\n"
    )
    mech = ms.loads(_with_driver(law))
    for theta, t in ((90.0, math.asin(math.pi / 4)), (-60.0, math.pi + math.asin(math.pi / 6))):
        i = parse_instant(mech, f"theta={theta} deg")
        assert math.degrees(i.u) == pytest.approx(theta, rel=1e-14)
        assert (i.t, i.ud, i.udd) == pytest.approx((t, 2 * math.cos(t), -2 * math.sin(t)), rel=1e-9)
    with pytest.raises(ms.InputError, match="does not reach"):
        parse_instant(mech, "theta=150 deg")


def test_a_constant_acceleration_on_a_later_turn():
    """The exact inverse of a constant acceleration (4 rad/s^2 from 1.5 rad/s, from 20
    deg): 400 deg is 380 deg of travel, omega^2 = omega0^2 + 2 eps dtheta."""
    text = (ROOT / "mechanisms" / "fourbar.yaml").read_text()
    line = "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}"
    law = "driver: {joint: O2, start: 20 deg, motion: {accelerate: 4 rad/s^2, from: 1.5 rad/s}}"
    mech = ms.loads(
        text.replace(line, law).replace("range: 360 deg, step: 2 deg", "range: 720 deg")
    )
    i = parse_instant(mech, "theta=400 deg")
    w = math.sqrt(1.5**2 + 2 * 4 * math.radians(380))
    assert (i.ud, i.udd, i.t) == pytest.approx((w, 4.0, (w - 1.5) / 4), rel=1e-12)
    assert math.degrees(i.u) == pytest.approx(400, rel=1e-14)


def test_a_sliders_law():
    """s = 0.19 - 0.02 t (m) over 2 s: 170 mm at exactly 1 s (met within rounding, then
    put on the value by a Newton step); 100 mm is beyond it, said in the file's mm."""
    text = PISTON_DRIVEN.replace(
        "driver: {joint: cyl, speed: -0.2 m/s, start: 190 mm}",
        'driver: {joint: cyl, motion: {law: "0.19 - 0.02 * t"}}',
    ).replace("sweep: {range: 85 mm, step: 5 mm}", "sweep: {duration: 2 s, time_step: 0.1 s}")
    mech = ms.loads(text)
    i = parse_instant(mech, "s=170")
    assert (i.u, i.ud, i.udd, i.t) == pytest.approx((0.17, -0.02, 0.0, 1.0), rel=1e-14)
    res = solve_instants(mech, [i])
    assert res.point("A").x[0] == pytest.approx(_a_x(0.17), rel=1e-10)
    with pytest.raises(ms.InputError, match="it covers 150 to 190 mm"):
        parse_instant(mech, "s=100")
