"""Issue 23, §4: ``mechsolve run FILE --at "..."`` (one instant).

* A ``when:`` condition that combines a velocity with ``stroke()`` (the shaper's cutting
  force acts while the ram moves right, between 5 % and 95 % of its stroke) is evaluated on
  the instant's own state: its position and its velocity.
* The driver's speed and acceleration default to the file's.
* Greek names (θ, φ, ω, α, ε) are the same names as theta, omega, alpha.
* A name given twice is refused (exit 2).

References written here, independently of mechsolve: the shaper's quick-return geometry in
closed form (guide-bar angle from the crank, ram position from the rod), its rates
differentiated by hand, and the driving torque from the power balance
T ω + P_gravity + P_cut = dE_kin/dt, with the cutting force counted only where the ram moves
right and its stroke fraction (from the closed-form extremes of the ram's travel) lies in
[0.05, 0.95].
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.analyses.instants import parse_instant, solve_instants
from mechsolve.base.errors import InputError
from mechsolve.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
SHAPER = ROOT / "mechanisms" / "shaper.yaml"

# the shaper's data (m, N, kg m^2), as in mechanisms/shaper.yaml
R2, E, L4, S4, ROD, H = 0.110, 0.380, 0.540, 0.270, 0.135, 0.52844
G = 9.81
M4, M6, J4 = 200.0 / G, 700.0 / G, 1.1
P_CUT = 7000.0


def phi_rates(th: float) -> tuple[float, float, float]:
    """Guide-bar angle and its first two derivatives with respect to the crank angle.

    A = O2 + r (cos θ, sin θ) with O2 = (0, e) above O4: tan φ = (e + r sin θ) / (r cos θ),
    φ' = r (r + e sin θ) / D, D = r² + e² + 2 e r sin θ (= |O4 A|²)."""
    ax, ay = R2 * math.cos(th), E + R2 * math.sin(th)
    phi = math.atan2(ay, ax)
    n = R2 * (R2 + E * math.sin(th))
    d = R2 * R2 + E * E + 2 * E * R2 * math.sin(th)
    dn, dd = R2 * E * math.cos(th), 2 * E * R2 * math.cos(th)
    return phi, n / d, (dn * d - n * dd) / (d * d)


def ram_x(th: float) -> tuple[float, float, float]:
    """The ram's x and its first two derivatives with respect to θ (C right of B).

    B = L4 (cos φ, sin φ); C.x = B.x + sqrt(l² - h²), h = H - B.y."""
    phi, p1, p2 = phi_rates(th)
    bx, by = L4 * math.cos(phi), L4 * math.sin(phi)
    bx1, by1 = -by * p1, bx * p1
    bx2, by2 = -by * p2 - bx * p1 * p1, bx * p2 - by * p1 * p1
    h = H - by
    w = math.sqrt(ROD * ROD - h * h)
    # d/dθ sqrt(l² - h²) = h by' / w; again (h' = -by'): (h by'' - by'²) / w - h² by'² / w³
    w1 = h * by1 / w
    w2 = (-by1 * by1 + h * by2) / w - h * h * by1 * by1 / w**3
    return bx + w, bx1 + w1, bx2 + w2


def ram_extremes() -> tuple[float, float]:
    """The ram's ends: where φ' = 0 (the guide bar tangent to the crank circle),
    r + e sin θ = 0, θ = 180° + asin(r/e) (left) and 360° - asin(r/e) (right)."""
    edge = math.asin(R2 / E)
    return ram_x(math.pi + edge)[0], ram_x(2 * math.pi - edge)[0]


LO, HI = ram_extremes()


def reference(theta_deg: float, omega: float, alpha: float = 0.0) -> dict[str, float]:
    """Ram velocity, whether the cutting force acts, and the driving torque (N m, counter-
    clockwise on the crank) at a crank state, from the closed forms above."""
    th = math.radians(theta_deg)
    phi, p1, p2 = phi_rates(th)
    x, x1, x2 = ram_x(th)
    vcx = x1 * omega
    acx = x2 * omega * omega + x1 * alpha
    w4, al4 = p1 * omega, p2 * omega * omega + p1 * alpha
    # the guide bar's centre S4 on the bar: speed S4 w4 across it, acceleration
    # S4 al4 across and -S4 w4² along
    v_s4 = (-S4 * math.sin(phi) * w4, S4 * math.cos(phi) * w4)
    a_s4 = (
        -S4 * math.sin(phi) * al4 - S4 * math.cos(phi) * w4 * w4,
        S4 * math.cos(phi) * al4 - S4 * math.sin(phi) * w4 * w4,
    )
    kinetic_rate = M4 * (v_s4[0] * a_s4[0] + v_s4[1] * a_s4[1]) + J4 * w4 * al4 + M6 * vcx * acx
    p_gravity = -M4 * G * v_s4[1]  # the ram moves horizontally: its weight does no work
    stroke = (x - LO) / (HI - LO)
    cutting = vcx > 0 and 0.05 <= stroke <= 0.95
    p_cut = -P_CUT * vcx if cutting else 0.0
    torque = (kinetic_rate - p_gravity - p_cut) / omega
    return {"vcx": vcx, "acx": acx, "cutting": cutting, "torque": torque, "stroke": stroke}


RPM60 = 2 * math.pi  # rad/s


def instant(text: str, path: Path = SHAPER):
    mech = ms.load(path)
    return solve_instants(mech, [parse_instant(mech, text)])


def test_the_reference_holds_together():
    """The closed forms against themselves by central differences (a check of the test)."""
    for th in (100.0, 190.0, 20.0, 270.0):
        t, h = math.radians(th), 1e-5
        x0, x1, x2 = ram_x(t)
        assert (ram_x(t + h)[0] - ram_x(t - h)[0]) / (2 * h) == pytest.approx(x1, rel=1e-7)
        assert (ram_x(t + h)[1] - ram_x(t - h)[1]) / (2 * h) == pytest.approx(x2, rel=1e-6)
    # the ram's ends: a standstill there, and no position beyond them over the turn
    edge = math.asin(R2 / E)
    assert ram_x(math.pi + edge)[1] == pytest.approx(0, abs=1e-15)
    assert ram_x(2 * math.pi - edge)[1] == pytest.approx(0, abs=1e-15)
    x = [ram_x(t)[0] for t in np.radians(np.linspace(0, 360, 7201))]
    assert LO <= min(x) and max(x) <= HI and HI - LO == pytest.approx(0.3126, abs=1e-4)


@pytest.mark.parametrize(
    ("theta", "omega", "cutting"),
    [
        (100.0, -RPM60, True),  # the working stroke, mid-way: the cutting force acts
        (100.0, RPM60, False),  # the same position turned the other way: the ram goes back
        (190.0, -RPM60, False),  # moving right but within the first 5 % of the stroke
        (20.0, -RPM60, True),  # 92 % of the stroke, still cutting
        (270.0, -RPM60, False),  # the return stroke
    ],
)
def test_shaper_instant_with_a_velocity_and_stroke_condition(theta, omega, cutting):
    ref = reference(theta, omega)
    assert ref["cutting"] is cutting  # the cases are what they say
    res = instant(f"theta={theta} deg, omega={omega!r} rad/s")
    assert res.ok[0]
    assert res.point("C").vx[0] == pytest.approx(ref["vcx"], rel=1e-9)
    assert res.point("C").ax[0] == pytest.approx(ref["acx"], rel=1e-7)
    assert bool(res.forces.active["cutting"][0]) is cutting
    assert res.driving_effort[0] == pytest.approx(ref["torque"], rel=1e-8)


def test_shaper_instant_with_an_angular_acceleration():
    theta, omega, alpha = 100.0, -RPM60, -3.0
    ref = reference(theta, omega, alpha)
    res = instant(f"theta={theta} deg, omega={omega!r} rad/s, alpha={alpha} rad/s^2")
    assert res.point("C").ax[0] == pytest.approx(ref["acx"], rel=1e-8)
    assert res.driving_effort[0] == pytest.approx(ref["torque"], rel=1e-8)


def _cli(args: list[str], tmp_path: Path):
    # in SI (--units SI), as the references are; the shaper is written in mm
    return CliRunner().invoke(main, [*args, "-o", str(tmp_path / "out"), "--units", "SI"])


def _instants_csv(tmp_path: Path) -> dict[str, float]:
    with open(tmp_path / "out" / "instants.csv", newline="") as fh:
        rows = list(csv.reader(row for row in fh if not row.startswith("#")))
    head, values = rows[0], rows[1]
    out = {}
    for h, v in zip(head, values):
        try:
            out[h] = float(v)
        except ValueError:  # the status and method columns
            out[h] = math.nan
    return out


def test_cli_shaper_at_100_deg_60_rpm(tmp_path):
    """The command of the issue: a positive 60 rpm is counter-clockwise (values are signed),
    against the file's clockwise crank: the ram moves left and does not cut; the output says
    that the speed is against the file's direction."""
    r = _cli(["run", str(SHAPER), "--at", "theta=100 deg, omega=60 rpm"], tmp_path)
    assert r.exit_code == 0, r.output
    ref = reference(100.0, RPM60)
    row = _instants_csv(tmp_path)
    vx = [v for k, v in row.items() if k.startswith("C.vx")][0]
    assert vx == pytest.approx(ref["vcx"], rel=1e-9)
    torque = [v for k, v in row.items() if k.startswith("input.torque")][0]
    assert torque == pytest.approx(ref["torque"], rel=1e-8)
    assert [v for k, v in row.items() if k.startswith("load.cutting.active")][0] == 0
    assert "counter-clockwise" in r.output and "clockwise" in r.output


def test_cli_speed_defaults_to_the_files(tmp_path):
    """``--at "theta=100 deg"``: the file's 60 rpm clockwise and no acceleration."""
    r = _cli(["run", str(SHAPER), "--at", "theta=100 deg"], tmp_path)
    assert r.exit_code == 0, r.output
    ref = reference(100.0, -RPM60)
    row = _instants_csv(tmp_path)
    assert [v for k, v in row.items() if k.startswith("C.vx")][0] == pytest.approx(
        ref["vcx"], rel=1e-9
    )
    assert [v for k, v in row.items() if k.startswith("input.torque")][0] == pytest.approx(
        ref["torque"], rel=1e-8
    )
    assert [v for k, v in row.items() if k.startswith("load.cutting.active")][0] == 1
    assert "omega = -6.28319 rad/s (60 rpm clockwise), alpha = 0 rad/s²: the file's driver" in (
        r.output
    )


def test_speed_and_acceleration_default_to_the_files():
    mech = ms.load(SHAPER)
    i = parse_instant(mech, "theta=100 deg")
    assert (i.u, i.ud, i.udd) == pytest.approx((math.radians(100), -RPM60, 0.0))
    # given speed, default acceleration; given acceleration, default speed
    i = parse_instant(mech, "theta=100 deg, alpha=2 rad/s^2")
    assert (i.ud, i.udd) == pytest.approx((-RPM60, 2.0))


def test_speed_default_of_a_motion_law():
    """A driver with a constant-acceleration law: the speed and acceleration the law has
    when it first reaches the position (ω² = ω0² + 2 ε Δθ), from the law itself."""
    text = (ROOT / "mechanisms" / "fourbar.yaml").read_text()
    line = "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}"
    assert line in text
    law = "driver: {joint: O2, start: 20 deg, motion: {accelerate: 4 rad/s^2, from: 1.5 rad/s}}"
    mech = ms.loads(
        text.replace(line, law).replace("range: 360 deg, step: 2 deg", "range: 300 deg")
    )
    i = parse_instant(mech, "theta=80 deg")
    w = math.sqrt(1.5**2 + 2 * 4 * math.radians(60))
    assert (i.ud, i.udd) == pytest.approx((w, 4.0), rel=1e-12)
    # behind the start: reached after going on round the turn
    i = parse_instant(mech, "theta=10 deg")
    w = math.sqrt(1.5**2 + 2 * 4 * math.radians(350))
    assert i.ud == pytest.approx(w, rel=1e-12)


@pytest.mark.parametrize(
    "text",
    [
        "θ=100 deg, ω=-60 rpm",
        "θ = 100 deg, ω = -60 rpm, α = 0 rad/s^2",
        "φ=100 deg, ω=-60 rpm, ε=0",
        "theta=100 deg, omega=-60 rpm, epsilon=0 rad/s^2",
        "ϑ=100 deg, omega=-60 rpm, ϵ=0",
        "𝜃=100 deg, 𝜔=-60 rpm, 𝛼=0",  # mathematical italic letters (NFKC: θ, ω, α)
    ],
)
def test_greek_names_are_the_same_names(text):
    mech = ms.load(SHAPER)
    i = parse_instant(mech, text)
    assert (i.u, i.ud, i.udd) == pytest.approx((math.radians(100), -RPM60, 0.0))


def test_greek_alpha_sets_the_acceleration():
    mech = ms.load(SHAPER)
    for name in ("α", "ε", "alpha", "epsilon"):
        assert parse_instant(mech, f"θ=100 deg, {name}=3 rad/s^2").udd == pytest.approx(3.0)


def test_cli_greek_names(tmp_path):
    r = _cli(["run", str(SHAPER), "--at", "θ=100 deg, ω=-60 rpm"], tmp_path)
    assert r.exit_code == 0, r.output
    ref = reference(100.0, -RPM60)
    row = _instants_csv(tmp_path)
    assert [v for k, v in row.items() if k.startswith("input.torque")][0] == pytest.approx(
        ref["torque"], rel=1e-8
    )


@pytest.mark.parametrize(
    "text",
    [
        "theta=30 deg, theta=40 deg",
        "theta=30 deg, θ=40 deg, omega=1 rad/s",
        "theta=30 deg, omega=1 rad/s, ω=2 rad/s",
        "theta=30 deg, alpha=1 rad/s^2, ε=2 rad/s^2",
    ],
)
def test_a_name_given_twice_is_refused(text, tmp_path):
    mech = ms.load(SHAPER)
    with pytest.raises(InputError, match="twice"):
        parse_instant(mech, text)
    r = _cli(["run", str(SHAPER), "--at", text], tmp_path)
    assert r.exit_code == 2, r.output
    assert "twice" in r.output and "Traceback" not in r.output
    assert not (tmp_path / "out" / "instants.csv").exists()


LINEAR = """
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [0.12, 0]}}
  rod: {points: {A: [0, 0], C: [0.45, 0]}}
  piston: {points: {C: [0, 0]}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cyl: {slider: [ground, piston], point: C, line: {through: [0, 0.03], angle: 0}}
assembly: ["A.y > 0"]
driver: {joint: cyl, speed: -0.5 m/s, start: 0.5 m}
sweep: {range: 0.2 m, step: 0.01 m}
"""


def test_linear_driver_speed_defaults_to_the_files():
    """A slider driver (s, v, a): ``s=0.45 m`` moves at the file's -0.5 m/s. The crank's
    rate from the loop |A - C| = l differentiated: θ' = -(s - R cos θ) s' /
    ((s - R cos θ) R sin θ - (e - R sin θ) R cos θ)."""
    mech = ms.loads(LINEAR)
    i = parse_instant(mech, "s=0.45 m")
    assert (i.u, i.ud, i.udd) == pytest.approx((0.45, -0.5, 0.0))
    res = solve_instants(mech, [i])
    r, l_, e, s, v = 0.12, 0.45, 0.03, 0.45, -0.5
    d = math.hypot(s, e)
    th = math.atan2(e, s) + math.acos((r * r + d * d - l_ * l_) / (2 * r * d))  # A above
    c, sn = math.cos(th), math.sin(th)
    w = -(s - r * c) * v / ((s - r * c) * r * sn - (e - r * sn) * r * c)
    assert res.link("crank").omega[0] == pytest.approx(w, rel=1e-10)
    # the angle names are not this driver's: refused, naming the ones it takes
    with pytest.raises(InputError, match="s, v, a"):
        parse_instant(mech, "θ=30 deg")
    # a speed against the file's direction is said
    assert "against the file's driver" in parse_instant(mech, "s=0.45 m, v=0.5 m/s").note
    assert "against" not in parse_instant(mech, "s=0.45 m, v=-0.5 m/s").note


def test_unknown_name_is_refused_with_the_names_it_takes(tmp_path):
    r = _cli(["run", str(SHAPER), "--at", "theta=100 deg, speed=60 rpm"], tmp_path)
    assert r.exit_code == 2, r.output
    assert "speed" in r.output and "omega" in r.output and "ω" in r.output


def test_an_error_in_a_condition_at_the_instant_names_file_line_and_key(monkeypatch):
    """Were a condition not evaluable at the instant (as the velocity was not, before), the
    error names the file, the line and the key of the load's ``when``."""
    from mechsolve.core.solution import StateView

    def unknown(self, attr):
        raise InputError(f"'{attr}' is not known here: only positions are")

    monkeypatch.setattr(StateView, "_need", unknown)
    mech = ms.load(SHAPER)
    with pytest.raises(InputError) as info:
        solve_instants(mech, [parse_instant(mech, "theta=100 deg")])
    err = info.value
    line = next(
        k + 1
        for k, text in enumerate(SHAPER.read_text().splitlines())
        if text.strip().startswith("when:")
    )
    assert (err.file, err.keypath, err.line) == (str(SHAPER), "loads.cutting.when", line)
    assert "'vx' is not known here" in str(err)


def _fourbar_with(driver: str, sweep: str):
    text = (ROOT / "mechanisms" / "fourbar.yaml").read_text()
    line = "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}"
    sweep_line = "sweep: {range: 360 deg, step: 2 deg}"
    assert line in text and sweep_line in text
    return ms.loads(text.replace(line, driver).replace(sweep_line, sweep))


def test_speed_default_of_a_law_of_time():
    """u = 0.3 + 2 t + 0.5 sin 3t (u' = 2 + 1.5 cos 3t > 0): the rates where it first
    reaches the angle, found here by bisection of the law as written; an angle below the
    start is reached on the next turn (u = θ + 2π)."""
    from scipy.optimize import brentq

    mech = _fourbar_with(
        'driver: {joint: O2, motion: {law: "0.3 + 2 * t + 0.5 * sin(3 * t)"}}',
        "sweep: {duration: 5 s, time_step: 0.05 s}",
    )
    for deg, turn in ((80.0, 0), (10.0, 1)):
        target = math.radians(deg) + 2 * math.pi * turn
        t = brentq(lambda s, g=target: 0.3 + 2 * s + 0.5 * math.sin(3 * s) - g, 0, 5, xtol=1e-15)
        i = parse_instant(mech, f"θ={deg} deg")
        assert i.ud == pytest.approx(2 + 1.5 * math.cos(3 * t), rel=1e-10)
        assert i.udd == pytest.approx(-4.5 * math.sin(3 * t), rel=1e-9)
        assert f"t = {t:.6g} s" in i.note
    # beyond the sweep's 5 s (u(5) = 0.8 rad): no speed to take, ask for it; with the
    # speed given, no acceleration
    slow = _fourbar_with(
        'driver: {joint: O2, motion: {law: "0.3 + 0.1 * t"}}',
        "sweep: {duration: 5 s, time_step: 0.05 s}",
    )
    with pytest.raises(InputError, match="give omega"):
        parse_instant(slow, "theta=90 deg")
    i = parse_instant(slow, "theta=90 deg, omega=2 rad/s")
    assert (i.ud, i.udd) == (2.0, 0.0) and "does not reach" in i.note
    # within it: the law's acceleration with the given speed
    i = parse_instant(mech, "theta=80 deg, ω=3 rad/s")
    t = brentq(lambda s: 0.3 + 2 * s + 0.5 * math.sin(3 * s) - math.radians(80), 0, 5)
    assert i.ud == 3.0 and i.udd == pytest.approx(-4.5 * math.sin(3 * t), rel=1e-9)


def test_speed_default_of_segments():
    """From rest, 0.5 s up to 60 rpm (ε = 4π rad/s²), then 1 s at 60 rpm: at 30° of travel
    ω = sqrt(2 ε Δθ); at 300° of travel (past the 90° of the ramp) 60 rpm and ε = 0."""
    mech = _fourbar_with(
        "driver: {joint: O2, start: 0 deg, direction: ccw, motion: {from: 0 rpm, segments: "
        "[{accelerate: 0.5 s, to: 60 rpm}, {run: 1 s}]}}",
        "sweep: {duration: 1.5 s, time_step: 0.01 s}",
    )
    eps = 2 * math.pi / 0.5
    i = parse_instant(mech, "theta=30 deg")
    assert (i.ud, i.udd) == pytest.approx((math.sqrt(2 * eps * math.radians(30)), eps))
    i = parse_instant(mech, "theta=300 deg")
    assert (i.ud, i.udd) == pytest.approx((2 * math.pi, 0.0), abs=1e-12)
