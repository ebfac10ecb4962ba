"""Figures that are not determined where a sweep puts them (issue 30, review 7): the mean
driving torque of a motion law that returns to its start, the velocities next to a
change-point toggle, the peak of a reaction that grows without bound at a toggle, and
expressions that are not finite (division by zero)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.cli.main import main

# J0(1) = (1 / 2 pi) * integral of cos(sin t) dt over a period (Abramowitz & Stegun 9.1.18)
BESSEL_J0_1 = 0.7651976865579666

PENDULUM = """
name: pendulum
units: {length: mm, angle: rad}
ground: {O: [0, 0]}
links:
  arm:
    points: {O: [0, 0], A: [200, 0]}
    mass: 2 kg
    com: [200, 0]
    inertia: 0.01 kg*m^2
joints:
  O: [ground, arm]
driver: {joint: O, motion: {law: "sin(t)"}}
sweep: {duration: 6.283185307179586 s, steps: 360}
gravity: 9.81 m/s^2
"""


def test_mean_torque_of_a_law_that_returns_to_its_start_is_the_time_mean(tmp_path):
    """An arm (mass m, centre at r) swung by u = sin(t) over one period: the driving torque
    is T = J u'' + m g r cos u, whose mean over time is m g r J0(1) (the mean of u'' over a
    period is zero). The travel is sin(2 pi) = -2.4e-16 rad: the work over it was printed
    as the mean (0, or 1e17 with a load)."""
    res = ms.solve(ms.loads(PENDULUM))
    mean, what = res.mean_effort()
    assert what == "time mean"
    expect = 2.0 * 9.81 * 0.2 * BESSEL_J0_1  # N m
    assert math.isclose(mean, expect, rel_tol=1e-9)
    e = res.driving_effort
    assert np.nanmin(e) <= mean <= np.nanmax(e)
    text = res.summary()
    assert f"time mean {expect:.6g} N·m" in text
    # the travel's rounding is not printed either (was "from 0 to -1.40334e-14 deg")
    assert "driver O from 0 to 0 deg over 6.28319 s" in text.splitlines()[0]
    # the report's table says the same
    f = tmp_path / "pend.yaml"
    f.write_text(PENDULUM)
    out = CliRunner().invoke(main, ["report", str(f), "-o", str(tmp_path / "r.html")])
    assert out.exit_code == 0, out.output
    html = (tmp_path / "r.html").read_text()
    assert "time mean driving torque" in html and f"{expect * 1e3:.6g}" in html


def test_mean_torque_of_a_one_way_law_is_still_the_work_over_the_travel():
    """A law that goes one way keeps the mean over the travel, W / travel: for the arm
    turned by u = t over one turn at a steady speed, m g r times the mean of cos u = 0,
    and the work is zero."""
    text = PENDULUM.replace('"sin(t)"', '"t"')
    res = ms.solve(ms.loads(text))
    mean, what = res.mean_effort()
    assert what == "mean"
    assert abs(mean) < 1e-9


# A change-point four-bar (Grashof sum equal: crank 40 + coupler 100 = rocker 60 + frame
# 80, mm): at crank angle 0 all four links are collinear and its two branches cross.
CHANGE = """
name: changepoint
units: {{length: mm, angle: deg}}
ground: {{O2: [0, 0], O4: [80, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [40, 0]}}, mass: 0.05 kg, uniform_bar: [O2, A]}}
  coupler: {{points: {{A: [0, 0], B: [100, 0]}}, mass: 0.2 kg, uniform_bar: [A, B]}}
  rocker: {{points: {{O4: [0, 0], B: [60, 0]}}, mass: 0.11 kg, uniform_bar: [O4, B]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {{joint: O2, speed: 1 rad/s, start: {start} deg}}
sweep: {{range: {range} deg, step: {step} deg}}
gravity: 9.81 m/s^2
"""


def change_point_rocker(th2, sigma):
    """The change-point four-bar's rocker angle and its rate per unit crank rate on the
    smooth branch ``sigma`` (+-1) through the change point, in closed form.

    Freudenstein's half-angle solution (Norton 4.10): ``th4 = 2 atan2(-B -+ sqrt(B^2 -
    4AC), 2A)`` with ``K1 = d/a = 2``, ``K2 = d/c = 4/3``, ``K3 = (a^2 - b^2 + c^2 +
    d^2) / (2ac) = 1/3``: ``A = -(cos th2 + 5)/3``, ``B = -2 sin th2``, ``C = 7 (1 -
    cos th2) / 3``, so ``B^2 - 4AC = 4 (1 - cos th2)(44 + 16 cos th2)/9 = (2 k
    sin(th2/2))^2`` with ``k = sqrt(2 (44 + 16 cos th2)) / 3``. The root that is smooth
    through th2 = 0 takes ``sin(th2/2)`` with its sign (not its modulus): ``th4 = 2
    atan2(N, A)``, ``N = sin th2 - sigma k sin(th2/2)``, whose derivative has no 0/0."""
    c2, s2 = np.cos(th2), np.sin(th2)
    root = np.sqrt(2.0 * (44.0 + 16.0 * c2))
    k = root / 3.0
    dk = -16.0 * s2 / (3.0 * root)
    A, dA = -(c2 + 5.0) / 3.0, s2 / 3.0
    N = s2 - sigma * k * np.sin(th2 / 2)
    dN = c2 - sigma * (dk * np.sin(th2 / 2) + 0.5 * k * np.cos(th2 / 2))
    th4 = 2.0 * np.arctan2(N, A)
    return th4, 2.0 * (A * dN - N * dA) / (N * N + A * A)


def _change_point_reference(res):
    """The closed form's rocker rates on the branch the sweep starts on (picked by the
    start's pose, which is not in question)."""
    th4 = res.link("rocker").angle
    for sigma in (1.0, -1.0):
        ref4, w4 = change_point_rocker(res.u, sigma)
        if abs(np.angle(np.exp(1j * (ref4[0] - th4[0])))) < 1e-9:
            h = 1e-5  # the acceleration: a central difference of the exact rate
            a4 = (
                change_point_rocker(res.u + h, sigma)[1] - change_point_rocker(res.u - h, sigma)[1]
            ) / (2 * h)
            return w4, a4
    raise AssertionError("the start pose is on neither branch of the closed form")


def test_change_point_closed_form_matches_a_sweep_through_the_toggle():
    """The reference itself: a sweep through the change point (the reviewer's 0.2 deg) and
    a coarse one follow the smooth branch of the closed form."""
    for start, rng, step in ((359.9, 0.2, 0.001), (300, 120, 1)):
        res = ms.solve(ms.loads(CHANGE.format(start=start, range=rng, step=step)))
        w4, _ = _change_point_reference(res)
        omega = res.link("rocker").omega
        assert np.all(np.isfinite(omega))
        np.testing.assert_allclose(omega, w4, rtol=1e-6)


def test_rates_next_to_a_change_point_where_the_sweep_stops_short_of_it():
    """A fine sweep that stops 0.001 deg before the change point: the rates of the
    positions next to it (77 rows said 'singular') were the other branch's, from side
    samples 0.29 deg past the sweep's end (rocker +47.31 deg/s against -161.90 deg/s),
    with status ok. They are the followed branch's or blank."""
    res = ms.solve(ms.loads(CHANGE.format(start=359.9, range=0.099, step=0.001)))
    w4, a4 = _change_point_reference(res)
    omega, alpha = res.link("rocker").omega, res.link("rocker").alpha
    shown = np.isfinite(omega)
    assert shown.sum() >= len(omega) - 5
    np.testing.assert_allclose(omega[shown], w4[shown], rtol=1e-6)
    shown = np.isfinite(alpha)
    np.testing.assert_allclose(alpha[shown], a4[shown], rtol=0, atol=1e-5)
    status = res.status()
    blank = ~np.isfinite(omega) | ~np.isfinite(alpha)
    assert all(s != "ok" for s, b in zip(status, blank) if b)


def _peak_line(res) -> str:
    return next(ln for ln in res.summary().splitlines() if "peak reactions" in ln)


def test_reaction_growing_without_bound_at_a_change_point_has_no_peak():
    """At the change point the coupler and rocker are collinear: the moment of the loads
    on the rocker about O4 is carried by the coupler's force along A-B, whose arm c sin g
    vanishes with the transmission angle g, so the reactions grow as 1/g, the largest
    sample being set by how close a sample lands (119 N at 1 deg, 1193 N at 0.1 deg).
    The summary says where they grow without bound instead of a 'peak'."""
    res = ms.solve(ms.loads(CHANGE.format(start=10, range=360, step=2)))
    line = _peak_line(res)
    assert "grow without bound towards the singular position at driver angle 0°" in line
    assert " N at " not in line  # no number that is only the nearest sample's
    # the claim, independently: the reaction scales as 1 / (distance to the toggle)
    near = [
        float(
            np.nanmax(
                np.abs(
                    ms.solve(ms.loads(CHANGE.format(start=s, range=0, step=1))).reaction("O4")["F"]
                )
            )
        )
        for s in (359.0, 359.9, 359.99)
    ]
    assert near[1] / near[0] == pytest.approx(10.0, rel=0.02)
    assert near[2] / near[1] == pytest.approx(10.0, rel=0.02)
    # a fine sweep stopping short of it, whose last rows' reactions are not determined
    res = ms.solve(ms.loads(CHANGE.format(start=359.9, range=0.099, step=0.001)))
    line = _peak_line(res)
    assert "grow without bound towards the singular position at about driver angle 360°" in line
    assert " N at " not in line


def test_sweep_stopping_short_of_a_toggle_keeps_its_peak_at_its_end():
    """A sweep that ends 1 deg before the change point: its largest reaction is at its
    end, a figure of the sweep (not of a sample that happens to land near the toggle)."""
    res = ms.solve(ms.loads(CHANGE.format(start=300, range=59, step=1)))
    line = _peak_line(res)
    assert "without bound" not in line
    f = np.abs(res.reaction("O2")["F"])
    assert f"O2 {float(np.nanmax(f)):.4g} N at driver angle 359°" in line


@pytest.mark.parametrize("at", [359.99, 359.999, 0.01])
def test_rates_at_one_position_next_to_a_change_point(at):
    """One position next to the change point (``run --at``, a drawing): its rates are its
    branch's, by a limit from the side that does not cross the change point (the side
    samples across it lie on the other branch: +47.31 deg/s for -161.90 deg/s)."""
    res = ms.solve(ms.loads(CHANGE.format(start=at, range=0, step=1)))
    w4, a4 = _change_point_reference(res)
    assert res.link("rocker").omega[0] == pytest.approx(w4[0], rel=1e-7)
    # (a one-sided limit: good to about 1e-6 of the natural size, 1 rad/s^2 at 1 rad/s)
    assert res.link("rocker").alpha[0] == pytest.approx(a4[0], abs=3e-6)


# -- expressions that are not finite (division by zero) -------------------------------

FOURBAR = """name: fourbar
units: {{length: mm, angle: deg}}
ground: {{O2: [0, 0], O4: [87.5, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [26.5, 0]}}, mass: 0.05 kg, uniform_bar: [O2, A]}}
  coupler:
    points: {{A: [0, 0], B: [105.6, 0], P: {{length: 60, angle: 30}}}}
    mass: 0.2 kg
    uniform_bar: [A, B]
  rocker: {{points: {{O4: [0, 0], B: [59, 0]}}, mass: 0.11 kg, uniform_bar: [O4, B]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
{driver}
gravity: 9.81 m/s^2
loads:
  pull:
    force: [0, -2 N]
    at: P
    when: {when}
"""
STEADY = "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}\nsweep: {range: 360 deg, step: 2 deg}"


def _run(tmp_path, text: str, *args: str, name: str = "m.yaml"):
    f = tmp_path / name
    f.write_text(text)
    out = CliRunner().invoke(main, [*args, str(f), "-o", str(tmp_path / "out")])
    return out, f


def _line(text: str, key: str) -> int:
    return next(i for i, ln in enumerate(text.splitlines(), 1) if ln.lstrip().startswith(key))


def test_condition_dividing_by_zero_is_refused(tmp_path):
    """``when: 1/(P.vx - P.vx) > 0`` is 1/0 = inf > 0 at every position: the load acted
    everywhere, silently. It is refused, naming file, line, key and where."""
    text = FOURBAR.format(driver=STEADY, when="1/(P.vx - P.vx) > 0")
    out, f = _run(tmp_path, text, "run")
    assert out.exit_code == 2, out.output
    assert f"m.yaml:{_line(text, 'when:')}: loads.pull.when:" in out.output
    assert "'1 / (P.vx - P.vx)' is not finite" in out.output and "driver angle 0°" in out.output
    assert "Traceback" not in out.output
    # a condition that divides by something that is never zero is kept
    ok, _ = _run(tmp_path, FOURBAR.format(driver=STEADY, when="P.vx / (1 + P.y^2) > 0"), "run")
    assert ok.exit_code == 0, ok.output


def test_motion_law_with_a_pole_between_samples_is_refused(tmp_path):
    """``t + 1/(t - 1.05)`` sampled every 0.1 s: finite at every sample, the driver jumped
    through infinity between 1.0 and 1.1 s. Refused at the pole, t = 1.05 s (the zero of
    t - 1.05); a removable singularity between samples is not a pole."""
    law = 'driver: {{joint: O2, motion: {{law: "{}"}}}}\nsweep: {{duration: 2 s, steps: 20}}'
    text = FOURBAR.format(driver=law.format("t + 1/(t - 1.05)"), when="P.vx > 0")
    out, f = _run(tmp_path, text, "run", "--no-plots")
    assert out.exit_code == 2, out.output
    assert f"m.yaml:{_line(text, 'driver:')}: driver.motion.law:" in out.output
    assert "t = 1.05 s" in out.output and "without bound" in out.output
    for fine in ("t + sin(t - 1.05) / (t - 1.05)", "t + 1/sign(t - 1.05)", "t + 1/(1 + t^2)"):
        text = FOURBAR.format(driver=law.format(fine), when="P.vx > 0")
        ok, _ = _run(tmp_path, text, "run", "--no-plots")
        assert ok.exit_code == 0, (fine, ok.output)


def test_flywheel_torque_law_with_a_pole_between_samples_is_refused(tmp_path):
    """``150 sin(2 angle) / (angle - 1)`` has a pole at angle = 1 rad, between the
    36001 samples of the cycle: the energy excursion printed (1293 J) was the samples'."""
    text = (
        "name: law\n"
        'torque: {law: "200 + 150 * sin(2 * angle) / (angle - 1)", cycle: 360 deg}\n'
        "resisting: mean\nspeed: 3000 rpm\ndelta: 1/80\n"
    )
    f = tmp_path / "fw.yaml"
    f.write_text(text)
    out = CliRunner().invoke(main, ["flywheel", str(f), "-o", str(tmp_path / "fw")])
    assert out.exit_code == 2, out.output
    assert "fw.yaml:2: torque.law:" in out.output and "angle = 1 rad" in out.output
    f.write_text(text.replace("(angle - 1)", "(angle + 1)"))
    ok = CliRunner().invoke(main, ["flywheel", str(f), "-o", str(tmp_path / "fw")])
    assert ok.exit_code == 0, ok.output


def test_compare_gives_no_peak_reaction_for_a_change_point(tmp_path):
    """``compare`` printed 1193.1 N at 0.1 deg for the change-point linkage: its nearest
    sample to the toggle. It says 'unbounded' (blank in its CSV) and where."""
    a = tmp_path / "change.yaml"
    a.write_text(CHANGE.format(start=10, range=360, step=2))
    b = tmp_path / "fourbar.yaml"
    b.write_text(FOURBAR.format(driver=STEADY, when="P.vx > 0"))
    args = ["compare", str(a), str(b), "--output", "B.x", "-o", str(tmp_path / "cmp")]
    out = CliRunner().invoke(main, args)
    assert out.exit_code == 0, out.output
    row = next(ln for ln in out.output.splitlines() if ln.startswith("peak joint reaction"))
    assert row.split()[3] == "unbounded" and row.split()[4] != "unbounded"
    assert "grow without bound towards the singular" in out.output


def test_driving_torque_through_dead_centres_has_no_peak_nor_time_mean(tmp_path):
    """The rocker driven by a sine law through both dead centres of the crank (crank and
    coupler collinear): the torque on the rocker grows as 1/s there, so its largest sample
    (4528 N mm, 0.005 deg from the dead centre) and its mean over time are set by where
    the samples land. The summary and the plot say so; the work stays (energy method)."""
    drive = (
        'driver: {joint: O4, motion: {law: "1.488019985597753 + 0.575107925126888 * '
        'sin(t)"}}\nsweep: {duration: 6.283185307179586 s, steps: 360}'
    )
    res = ms.solve(ms.loads(FOURBAR.format(driver=drive, when="P.vx > 0")))
    mean, what = res.mean_effort()
    assert what == "time mean" and math.isnan(mean)
    line = next(ln for ln in res.summary().splitlines() if ln.startswith("  driving torque"))
    assert "max: grows without bound towards the singular position at driver angle" in line
    assert "RMS not determined" in line and "time mean not determined" in line
    assert math.isfinite(res.work())
