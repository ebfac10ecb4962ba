"""Issue 30 (review 13): a dead zone that the sweep steps over between two samples.

A non-Grashof four-bar whose loop cannot close for |theta| < theta_e (|O4A| < b - c, the
coupler and rocker folded) is solved at every sample when theta_e is smaller than the
step. Before, ``closes: full turn`` passed, a torque that grows without bound towards the
edge was given a finite located peak and passed, the driver's work was a number across
the gap, and a study row said ``ok``. The edges are checked against the closed form.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.analyses.study.execute import status_of
from mechsolve.analyses.study.figures import design_row
from mechsolve.results.requirements import check_requirements

D, B, C = 87.5, 115.0, 59.0  # ground O2-O4, coupler A-B, rocker O4-B (mm)

TEMPLATE = """
name: toggle
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank:
    points: {O2: [0, 0], A: [CRANK, 0]}
    mass: 0.05 kg
    uniform_bar: [O2, A]
  coupler:
    points: {A: [0, 0], B: [115, 0], P: {length: 60, angle: 30}}
    mass: 0.2 kg
    uniform_bar: [A, B]
  rocker:
    points: {O4: [0, 0], B: [59, 0]}
    mass: 0.11 kg
    uniform_bar: [O4, B]
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, speed: 1 rad/s, start: START deg}
sweep: {range: 360 deg, step: 2 deg}
gravity: 9.81 m/s^2
loads:
  pull: {force: [0, -2 N], at: P, when: P.vx > 0}
requirements:
  transmission: min(transmission_angle.B) >= 0 deg
  torque: max(abs(input.torque)) <= 0.3 N m
  closes: full turn
"""


def _mech(crank: float, start: float):
    text = TEMPLATE.replace("CRANK", repr(crank)).replace("START", repr(start))
    return ms.loads(text)


def edge_deg(a: float) -> float:
    """Grashof: the loop cannot close where |O4A| < b - c; |O4A|^2 = a^2 + d^2 -
    2 a d cos(theta), so it stops closing at the crank angle theta_e (and -theta_e)."""
    return math.degrees(math.acos((a * a + D * D - (B - C) ** 2) / (2 * a * D)))


def rocker_rate(a: float, theta: float) -> float:
    """d(phi4)/d(theta) of the open branch by the vector loop (closed form): the
    rocker's angular velocity at a crank speed of 1 rad/s."""

    def phi4(t: float) -> float:
        ax, ay = a * math.cos(t), a * math.sin(t)
        dx, dy = D - ax, -ay  # A -> O4
        r = math.hypot(dx, dy)
        # angle at O4 between O4->A and O4->B (law of cosines), B on the upper side
        gamma = math.acos((C * C + r * r - B * B) / (2 * C * r))
        return math.atan2(-dy, -dx) - gamma

    h = 1e-9
    return (phi4(theta + h) - phi4(theta - h)) / (2 * h)


def _check_dead_zone(crank: float, start: float) -> None:
    mech = _mech(crank, start)
    res = ms.solve(mech)
    assert res.ok.all()  # every sample closes: the dead zone lies between two of them
    te = edge_deg(crank)
    v = {x.name: x for x in check_requirements(mech, res)}
    # closes fails, naming where the loop cannot close (the closed-form edges)
    assert not v["closes"].passed
    msg = v["closes"].message
    assert "cannot close between" in msg and msg.endswith("FAIL")
    shown = [float(x) for x in re.findall(r"driver angle ([0-9.e+-]+)°", msg)]
    assert abs(shown[0] - (360 - te)) < 6e-4  # printed to 6 digits
    assert abs(shown[1] - te) < 1e-5 * te
    (zone,) = [e for e in res.solution.events if e.kind == "dead zone"]
    assert abs(math.degrees(zone.edge_in) - (360 - te)) < 1e-9
    assert abs(math.degrees(zone.edge_out) - (360 + te)) < 1e-9
    # the torque grows without bound towards the edge: the rocker's rate does (closed
    # form: as 1/sqrt of the distance), so its kinetic energy, the integral of the
    # driving torque at constant crank speed, is unbounded over a bounded interval
    e = math.radians(te)
    w1, w2 = rocker_rate(crank, -e - 1e-4), rocker_rate(crank, -e - 1e-6)
    assert abs(w2) > 5 * abs(w1)
    assert math.isinf(v["torque"].value) and not v["torque"].passed
    assert "unbounded" in v["torque"].message
    assert f"{360 - te:.6g}"[:5] in v["torque"].message
    # a bounded extreme next to the gap is at the edge: transmission angle 0 there
    assert abs(v["transmission"].value) < 1e-6
    # the work over a motion that is not continuous is not defined
    assert math.isnan(res.work())
    assert "cannot close" in res.work_text()


def test_dead_zone_of_0p8_degrees_between_two_samples():
    # theta_e = 0.8166 deg: the samples 359 and 1 deg are either side of the gap
    assert abs(edge_deg(31.505) - 0.8166) < 1e-4
    _check_dead_zone(31.505, 1.0)


def test_tiny_dead_zone_between_two_samples():
    assert abs(edge_deg(31.50001) - 0.0365) < 1e-4
    _check_dead_zone(31.50001, 0.05)


def test_crank_rocker_still_closes_and_has_a_finite_peak():
    # a Grashof crank-rocker (a = 31 < the limit 31.5): no dead zone, full turn
    mech = _mech(31.0, 1.0)
    res = ms.solve(mech)
    v = {x.name: x for x in check_requirements(mech, res)}
    assert v["closes"].passed
    assert math.isfinite(v["torque"].value)
    assert math.isfinite(res.work())


def test_study_row_of_a_dead_zone_design_is_not_ok():
    mech = _mech(31.505, 1.0)
    res = ms.solve(mech)
    row = design_row(res, mech)
    assert row["assembles [-]"] is False
    assert math.isnan(row["cycle.work [J]"])
    assert row["req.closes.pass [-]"] == "not assembled"
    status = status_of(row, res)
    assert status.startswith("not assemblable between driver angle 359.18")
    assert np.isfinite(row["solved [-]"])


def test_compare_names_the_dead_zone_not_a_still_output():
    # before: "the output P.x does not move over the turn" (P.x travels about 88 mm)
    from mechsolve.analyses.compare.figures import scheme_figures
    from mechsolve.base.errors import InputError

    te = edge_deg(31.50001)
    for output in ("P.x", "rocker"):
        try:
            scheme_figures(_mech(31.50001, 0.05), name="tiny", output=output)
        except InputError as exc:
            msg = str(exc)
        else:
            raise AssertionError("compare accepted a crank that does not turn fully")
        assert "does not move" not in msg
        assert "cannot close between driver angle" in msg
        assert "compare needs a crank that turns fully" in msg
        shown = [float(x) for x in re.findall(r"driver angle ([0-9.e+-]+)°", msg)]
        assert abs(shown[0] - (360 - te)) < 6e-4 and abs(shown[1] - te) < 1e-5


# -- where an extreme is stated -----------------------------------------------------------
def _variant(crank: float, coupler: float, start: float, step: float, reqs: str, span=360.0):
    text = TEMPLATE.replace("CRANK", repr(crank)).replace("START", repr(start))
    text = text.replace("range: 360 deg", f"range: {span!r} deg")
    text = text.replace("B: [115, 0]", f"B: [{coupler!r}, 0]")
    text = text.replace("step: 2 deg", f"step: {step!r} deg")
    text = text[: text.index("requirements:")] + "requirements:\n" + reqs
    return ms.loads(text)


def test_transmission_zero_is_placed_at_the_dead_zones_edge_not_inside_it():
    # 30 deg step: the loop cannot close for |theta| < 8.091 deg (closed form); before,
    # "min(transmission_angle.B) = 0 deg (at driver angle 0 deg)", where it does not close
    mech = _variant(32.0, 115.0, 15.0, 30.0, "  t: min(transmission_angle.B) >= 30 deg\n")
    res = ms.solve(mech)
    (v,) = check_requirements(mech, res)
    te = math.degrees(math.acos((32.0**2 + D * D - (115.0 - C) ** 2) / (2 * 32.0 * D)))
    assert abs(te - 8.091) < 1e-3
    assert v.value == 0.0
    (at,) = [float(x) for x in re.findall(r"driver angle ([0-9.e+-]+)°", v.message)]
    assert min(abs(at - (360 - te)), abs(at - te)) < 6e-4


def test_change_point_extreme_is_the_limit_where_it_holds():
    # s + l = p + q (32 + 114.5 = 87.5 + 59): a change point at theta = 0, where the
    # driving torque jumps (another branch on each side). Before, the limit from below
    # 360 deg was printed "at driver angle 3.815e-06 deg", where the torque is 0.10667 N m
    mech = _variant(32.0, 114.5, 0.0, 2.0, "  torque: max(abs(input.torque)) <= 0.07 N m\n")
    res = ms.solve(mech)
    (v,) = check_requirements(mech, res)
    assert "e-06" not in v.message and "towards driver angle 360°" in v.message
    assert "limit" in v.message

    # the reference, as the review's: 0.001 deg sweeps either side of the change point
    # (the last thousandths of a degree before it are left blank: singular to rounding)
    def torque(start: float) -> tuple[np.ndarray, np.ndarray]:
        r = ms.solve(_variant(32.0, 114.5, start, 0.001, "  c: full turn\n", span=0.099))
        e = np.abs(r.driving_effort)
        return np.degrees(r.u)[np.isfinite(e)], e[np.isfinite(e)]

    (ub, below), (_, above) = torque(359.9), torque(0.0001)
    limit = np.polyval(np.polyfit(ub - 360.0, below, 2), 0.0)  # extrapolated to 360 deg
    assert abs(v.value - limit) < 1e-5 * limit
    assert abs(above[0] - 0.10667) < 1e-5  # the torque just after 0 deg: not that value


def test_summary_gives_no_peak_next_to_a_dead_zone():
    # before: "peak reactions (1° samples): O2 129.1 N at driver angle 359°" and a torque
    # "min -202.957 N·mm", finite samples of quantities unbounded towards 359.183 deg
    res = ms.solve(_mech(31.505, 1.0))
    text = res.summary()
    te = edge_deg(31.505)
    (peaks,) = [line for line in text.splitlines() if "peak reactions" in line]
    assert "grow without bound towards the edge" in peaks and "129.1" not in peaks
    (torque,) = [line for line in text.splitlines() if "driving torque" in line]
    assert "-202.957" not in torque and "RMS not determined" in torque
    shown = [float(x) for x in re.findall(r"driver angle ([0-9.e+-]+)°", torque)]
    assert abs(shown[0] - (360 - te)) < 6e-4 and abs(shown[1] - te) < 1e-5


# A dead zone inside a Newton group: the same four-bar solved as one Newton group. The
# edges of the zone the sweep steps over were not located ("cannot close near 0 deg"),
# and the driving torque, which grows without bound towards them, had a finite located
# peak that passed. The edges are checked against the law of cosines.
def _newton_toggle(crank: float, start: float):
    text = TEMPLATE.replace("CRANK", repr(crank)).replace("START", repr(start))
    text = text.replace("  transmission: min(transmission_angle.B) >= 0 deg\n", "")
    return ms.loads(text + "solver: {method: newton}\n")


@pytest.mark.slow
def test_dead_zone_edges_of_a_newton_group_are_located():
    for crank, start in ((31.505, 1.0), (31.50001, 0.05)):
        mech = _newton_toggle(crank, start)
        res = ms.solve(mech)
        assert type(res.analysis.plan[0]).__name__ == "NewtonGroup"
        te = math.radians(edge_deg(crank))  # the closed form (law of cosines)
        (zone,) = [e for e in res.solution.events if e.kind == "dead zone"]
        assert abs(zone.edge_in - (2 * math.pi - te)) < 1e-9
        assert abs(zone.edge_out - (2 * math.pi + te)) < 1e-9
        v = {x.name: x for x in check_requirements(mech, res)}
        msg = v["closes"].message
        assert f"cannot close between driver angle {360 - math.degrees(te):.6g}°" in msg, msg
        assert f"and driver angle {math.degrees(te):.6g}°" in msg, msg
        assert math.isinf(v["torque"].value) and not v["torque"].passed, v["torque"].message
