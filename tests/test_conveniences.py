"""Model-file conveniences (issue 12): pins through three or more links, relative link
angles as outputs, US customary units, and variants that replace exclusive keys."""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.base.errors import InputError
from mechsolve.base.units import UnitError, parse_quantity
from mechsolve.model import GROUND, PinJoint

from closed_form import fourbar

# --- 1. a pin through three or more links ----------------------------------------------

SIXBAR = """
name: six-bar with a ternary pin
units: {{length: mm, angle: deg}}
ground: {{A: [0, 0], D: [87.5, 0], G: [150, 90]}}
links:
  crank: {{points: {{A: [0, 0], B: [26.5, 0]}}, mass: 0.05 kg, uniform_bar: [A, B]}}
  coupler: {{points: {{B: [0, 0], C: [105.6, 0]}}, mass: 0.2 kg, uniform_bar: [B, C]}}
  rocker: {{points: {{D: [0, 0], C: [59, 0]}}, mass: 0.11 kg, uniform_bar: [D, C]}}
  link5: {{points: {{C: [0, 0], F: [80, 0]}}, mass: 0.15 kg, uniform_bar: [C, F]}}
  link6: {{points: {{G: [0, 0], F: [70, 0]}}, mass: 0.12 kg, uniform_bar: [G, F]}}
joints:
  A: [ground, crank]
  B: [crank, coupler]
{pin}
  D: [ground, rocker]
  F: [link5, link6]
  G: [ground, link6]
assembly: [C left of B -> D, F left of C -> G]
driver: {{joint: A, speed: 12 rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: 5 deg}}
loads:
  press: {{force: [3 N, -20 N], at: F, on: link6}}
"""

TERNARY = "  C: [coupler, rocker, link5]"
TERNARY_LONG = "  C: {revolute: [coupler, rocker, link5], point: C}"
PAIRWISE = "  C: [coupler, rocker]\n  C_2: {revolute: [coupler, link5], point: C}"
CHAIN = "  C: [coupler, rocker]\n  C5: {revolute: [rocker, link5], point: C}"


def sixbar(pin: str) -> ms.Results:
    return ms.solve(ms.loads(SIXBAR.format(pin=pin), file="six.yaml"))


def test_a_ternary_pin_is_revolute_joints_from_the_first_link():
    mech = ms.loads(SIXBAR.format(pin=TERNARY))
    pins = [j for j in mech.joints if j.point == "C"]
    assert pins == [
        PinJoint("C", "coupler", "rocker", "C", where=("joints", "C")),
        PinJoint("C_2", "coupler", "link5", "C", where=("joints", "C")),
    ]
    long = ms.loads(SIXBAR.format(pin=TERNARY_LONG))
    assert [j for j in long.joints if j.point == "C"] == pins


def test_four_links_on_one_pin_are_named_in_order():
    text = """
ground: {O: [0, 0]}
links:
  a: {points: {O: [0, 0], P: [1, 0]}}
  b: {points: {O: [0, 0], Q: [1, 0]}}
  c: {points: {O: [0, 0], R: [1, 0]}}
joints:
  O: [ground, a, b, c]
  PQ: {revolute: [a, b], point: P}
"""
    src = ms.model.source.load_text(text)
    r = ms.model.parse.Reader(src)
    ground = ms.model.parse.read_ground(r, src.data["ground"])
    links = ms.model.parse.read_links(r, src.data["links"])
    joints = ms.model.parse.read_joints(r, src.data["joints"], ground, links)
    assert [(j.name, j.a, j.b, j.point) for j in joints] == [
        ("O", GROUND, "a", "O"),
        ("O_2", GROUND, "b", "O"),
        ("O_3", GROUND, "c", "O"),
        ("PQ", "a", "b", "P"),
    ]


@pytest.fixture(scope="module")
def sixbars():
    return {k: sixbar(v) for k, v in (("ternary", TERNARY), ("pairwise", PAIRWISE))} | {
        "long": sixbar(TERNARY_LONG),
        "chain": sixbar(CHAIN),
    }


def test_ternary_pin_matches_separate_pairwise_joints(sixbars):
    t, p = sixbars["ternary"], sixbars["pairwise"]
    assert t.ok.all() and p.ok.all()
    for ln in ("coupler", "rocker", "link5", "link6"):
        a, b = t.link(ln), p.link(ln)
        np.testing.assert_array_equal(a.angle, b.angle)
        np.testing.assert_array_equal(a.omega, b.omega)
        np.testing.assert_array_equal(a.alpha, b.alpha)
    np.testing.assert_allclose(t.driving_effort, p.driving_effort, rtol=0, atol=1e-12)
    for j in ("C", "C_2", "F"):
        for c in ("Fx", "Fy"):
            np.testing.assert_allclose(t.reaction(j)[c], p.reaction(j)[c], rtol=0, atol=1e-12)
    lo = sixbars["long"]
    np.testing.assert_array_equal(lo.driving_effort, t.driving_effort)
    # pinned as a chain (rocker to link5) instead: other reactions, the same motion and torque
    ch = sixbars["chain"]
    np.testing.assert_allclose(ch.link("link5").angle, t.link("link5").angle, rtol=0, atol=1e-13)
    scale = np.max(np.abs(t.driving_effort))
    np.testing.assert_allclose(ch.driving_effort, t.driving_effort, rtol=0, atol=1e-11 * scale)


def test_ternary_pin_reactions_balance_every_link(sixbars):
    res = sixbars["ternary"]
    mech = res.mechanism
    g = np.array(mech.gravity_vector())
    xy = {p: np.array([res.point(p).x, res.point(p).y]) for p in "ABCDFG"}
    acc = {p: np.array([res.point(p).ax, res.point(p).ay]) for p in "ABCDFG"}
    ends = {"crank": "AB", "coupler": "BC", "rocker": "DC", "link5": "CF", "link6": "GF"}
    force = {ln: np.zeros((2, len(res))) for ln in ends}
    moment = {ln: np.zeros(len(res)) for ln in ends}
    com = {ln: (xy[p] + xy[q]) / 2 for ln, (p, q) in ends.items()}

    def apply(ln, f, at):
        if ln == GROUND:
            return
        force[ln] += f
        r = xy[at] - com[ln]
        moment[ln] += r[0] * f[1] - r[1] * f[0]

    for j in mech.joints:
        r = res.reaction(j.name)
        f = np.array([r["Fx"], r["Fy"]])
        apply(j.b, f, j.point)  # on b by a
        apply(j.a, -f, j.point)
    apply("link6", np.array([[3.0], [-20.0]]) * np.ones(len(res)), "F")
    moment["crank"] += res.driving_effort
    for ln, (p, q) in ends.items():
        lk = mech.link(ln)
        f = force[ln] + lk.mass * g[:, None]
        a_com = (acc[p] + acc[q]) / 2
        scale = 20.0 + lk.mass * np.max(np.abs(a_com))
        np.testing.assert_allclose(f, lk.mass * a_com, rtol=0, atol=1e-10 * scale)
        alpha = res.link(ln).alpha
        np.testing.assert_allclose(moment[ln], lk.inertia * alpha, rtol=0, atol=1e-10 * scale)


def test_ternary_pin_reactions_are_csv_columns(sixbars, tmp_path):
    path = sixbars["ternary"].to_csv(tmp_path / "six.csv")
    with open(path, newline="") as f:
        head = next(csv.reader(f))
    for col in ("C(coupler->rocker).Fx [N]", "C_2(coupler->link5).F [N]"):
        assert col in head


@pytest.mark.parametrize(
    "pin,fragments",
    [
        (
            "  C: [coupler, rocker, link6]",
            ["six.yaml:14: joints.C[2]: ", "link 'link6' has no point 'C'"],
        ),
        (
            "  C: {revolute: [coupler, rocker, link6], point: C}",
            ["six.yaml:14: joints.C.revolute[2]: ", "link 'link6' has no point 'C'"],
        ),
        ("  C: [coupler, rocker, link55]", ["joints.C[2]: no link named 'link55'", "link5"]),
        ("  C: [coupler, rocker, rocker]", ["joints.C[2]: ", "lists the link 'rocker' twice"]),
        (
            "  C: [coupler, rocker, link5]\n  C_2: [ground, crank]",
            ["six.yaml:14: joints.C: ", "named C, C_2, but the file has a joint 'C_2'"],
        ),
        ("  C: {revolute: [coupler, rocker, link5], line: [B, C]}", ["unknown key 'line'"]),
    ],
)
def test_ternary_pin_mistakes(pin, fragments):
    with pytest.raises(InputError) as exc:
        ms.loads(SIXBAR.format(pin=pin), file="six.yaml")
    for frag in fragments:
        assert frag in str(exc.value)


def test_ternary_pin_mistake_exits_2_without_traceback(tmp_path):
    f = tmp_path / "six.yaml"
    f.write_text(SIXBAR.format(pin="  C: [coupler, rocker, link6]"))
    p = subprocess.run(
        [sys.executable, "-m", "mechsolve", "check", str(f)], capture_output=True, text=True
    )
    assert p.returncode == 2
    assert "Traceback" not in p.stderr
    assert "six.yaml:14: joints.C[2]: " in p.stderr


# --- 2. relative angles ------------------------------------------------------------------

FOURBAR = """
name: four-bar
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: ["B left of A -> O4"]
driver: {{joint: O2, speed: {w} rad/s, start: 40 deg, direction: {direction}}}
sweep: {{range: 720 deg, step: 3 deg}}
outputs: {{points: [B], relative: [[coupler, crank], rocker/coupler, [rocker, ground]]}}
"""


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_relative_angles_against_closed_form(direction, tmp_path):
    a, b, c, d, w = 1.0, 3.0, 2.5, 3.2, 1.7
    res = ms.solve(ms.loads(FOURBAR.format(a=a, b=b, c=c, d=d, w=w, direction=direction)))
    assert res.ok.all()
    sw = w if direction == "ccw" else -w
    th2 = res.u
    for branch in (1, -1):
        th3, th4, w3, w4, al3, al4 = fourbar(a, b, c, d, th2, sw, branch)
        if abs(wrap(th4[0] - res.link("rocker").angle[0])) < 1e-6:
            break
    want = {
        "coupler/crank": (th3 - th2, w3 - sw, al3),
        "rocker/coupler": (th4 - th3, w4 - w3, al4 - al3),
        "rocker/ground": (th4, w4, al4),
    }
    cols = {col.name: col.values for col in res.columns()}
    for name, (th, om, al) in want.items():
        ang = cols[f"{name}.angle"]
        assert 0 <= ang[0] < 360
        assert np.max(np.abs(np.diff(ang))) < 30  # unwrapped: no jumps of a turn
        np.testing.assert_allclose(wrap(np.radians(ang) - th), 0, atol=1e-10)
        np.testing.assert_allclose(cols[f"{name}.omega"], om, rtol=0, atol=1e-10 * w)
        np.testing.assert_allclose(cols[f"{name}.alpha"], al, rtol=0, atol=1e-10 * w * w)
    # the crank turns twice relative to the coupler: the unwrapped angle goes on
    span = cols["coupler/crank.angle"][-1] - cols["coupler/crank.angle"][0]
    assert span == pytest.approx(-720 if direction == "ccw" else 720, abs=1e-9)
    rel = res.relative("coupler", "crank")
    np.testing.assert_array_equal(np.degrees(rel.angle), cols["coupler/crank.angle"])
    with open(res.to_csv(tmp_path / "r.csv"), newline="") as f:
        head = next(csv.reader(f))
    for h in (
        "coupler/crank.angle [deg]",
        "coupler/crank.omega [rad/s]",
        "coupler/crank.alpha [rad/s^2]",
        "rocker/coupler.angle [deg]",
    ):
        assert h in head


def test_relative_angles_follow_the_quantities_asked():
    text = FOURBAR.format(a=1.0, b=3.0, c=2.5, d=3.2, w=1.0, direction="ccw").replace(
        "relative:", "quantities: [position], relative:"
    )
    res = ms.solve(ms.loads(text))
    names = [c.name for c in res.columns()]
    assert "coupler/crank.angle" in names and "coupler/crank.omega" not in names


@pytest.mark.parametrize(
    "rel,fragment",
    [
        ("[[coupler, crnk]]", "outputs.relative[0]: no link named 'crnk' (did you mean 'crank'?)"),
        ("[[coupler]]", "outputs.relative[0]: a relative angle is a pair of links"),
        ("[coupler]", "outputs.relative[0]: a relative angle is a pair of links"),
        ("coupler", "outputs.relative: 'relative' is a list of link pairs"),
        ("[[crank, crank]]", "relative to itself is always zero"),
        ("[[crank, coupler], crank/coupler]", "outputs.relative[1]: the relative angle"),
    ],
)
def test_relative_angle_mistakes(rel, fragment):
    text = FOURBAR.format(a=1.0, b=3.0, c=2.5, d=3.2, w=1.0, direction="ccw")
    text = text.replace("[[coupler, crank], rocker/coupler, [rocker, ground]]", rel)
    with pytest.raises(InputError) as exc:
        ms.loads(text, file="f.yaml")
    assert str(exc.value).startswith("f.yaml:16: ")
    assert fragment in str(exc.value)


# --- 3. US customary units ----------------------------------------------------------------

LB = Fraction("0.45359237")
LBF = LB * Fraction("9.80665")
IN, FT = Fraction("0.0254"), Fraction("0.3048")


@pytest.mark.parametrize(
    "text,kind,exact",
    [
        ("1 in", "length", IN),
        ("1 inch", "length", IN),
        ("1 ft", "length", FT),
        ("1 yd", "length", 3 * FT),
        ("1 lb", "mass", LB),
        ("1 lbm", "mass", LB),
        ("1 lbf", "force", LBF),
        ("1 lb", "force", LBF),
        ("1 kip", "force", 1000 * LBF),
        ("1 slug", "mass", LBF / FT),
        ("1 lbf s^2/ft", "mass", LBF / FT),
        ("1 blob", "mass", LBF / IN),
        ("1 lb-sec^2/in", "mass", LBF / IN),
        ("1 lbf in", "torque", LBF * IN),
        ("1 lbf*in", "torque", LBF * IN),
        ("1 lb-in", "torque", LBF * IN),
        ("1 lbf·in", "torque", LBF * IN),
        ("1 ft lbf", "torque", LBF * FT),
        ("1 ft-lb", "torque", LBF * FT),
        ("1 lb in s^2", "moment of inertia", LBF * IN),
        ("1 lb·in·s²", "moment of inertia", LBF * IN),
        ("1 lbf in s^2", "moment of inertia", LBF * IN),
        ("1 slug ft^2", "moment of inertia", LBF * FT),
        ("1 lbm in^2", "moment of inertia", LB * IN * IN),
        ("1 lb in^2", "moment of inertia", LB * IN * IN),
        ("1 lbf/in", "stiffness", LBF / IN),
        ("1 lb/in", "stiffness", LBF / IN),
        ("1 lbf s/in", "damping", LBF / IN),
        ("1 lb/ft", "density per length", LB / FT),
        ("1 in/s^2", "acceleration", IN),
        ("1 ft/sec", "speed", FT),
        ("1 rad/sec", "angular speed", Fraction(1)),
        ("1 m·s⁻²", "acceleration", Fraction(1)),
    ],
)
def test_us_units_are_exact(text, kind, exact):
    assert parse_quantity(text, kind) == pytest.approx(float(exact), rel=1e-15, abs=0)


def test_psi():
    from mechsolve.base.units import parse_unit

    assert parse_unit("psi").factor == pytest.approx(float(LBF / IN**2), rel=1e-15)
    assert parse_unit("ksi").factor == pytest.approx(float(1000 * LBF / IN**2), rel=1e-15)
    assert parse_unit("psi").dim == (-1, 1, -2, 0)


@pytest.mark.parametrize(
    "text,kind,msg",
    [
        ("5 lb", "length", "'5 lb' is a mass, but a length is expected"),
        ("5 lbf", "mass", "'5 lbf' is a force, but a mass is expected"),
        ("5 lbm", "force", "'5 lbm' is a mass, but a force is expected"),
        ("5 lb in", "moment of inertia", "but a moment of inertia is expected"),
        ("5 lbs", "mass", "unknown unit 'lbs'"),
    ],
)
def test_us_unit_mistakes(text, kind, msg):
    with pytest.raises(UnitError, match=msg):
        parse_quantity(text, kind)


US = """
name: four-bar in inches
units: {length: in, angle: deg}
ground: {O2: [0, 0], O4: [7, 0]}
links:
  crank: {points: {O2: [0, 0], A: [2, 0]}, mass: 0.8 lb, com: [1, 0], inertia: 0.0012 lb in s^2}
  coupler:
    points: {A: [0, 0], B: [8, 0], P: {length: 4, angle: 30}}
    weight: 1.5 lb
    uniform_bar: [A, B]
  rocker: {points: {O4: [0, 0], B: [5, 0]}, mass: 0.01 slug, uniform_bar: [O4, B]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: [B left of A -> O4]
driver: {joint: O2, speed: 300 rpm, start: 0 deg}
sweep: {range: 360 deg, step: 10 deg}
gravity: 386.09 in/s^2
loads:
  tool: {force: [0, -12 lbf], at: P}
  brake: {torque: -15 lb-in, on: rocker}
  k1: {spring: [P, O4], stiffness: 20 lb/in, free_length: 6 in}
"""

SI = f"""
name: four-bar in SI
units: {{length: m, angle: deg}}
ground: {{O2: [0, 0], O4: [{7 * 0.0254!r}, 0]}}
links:
  crank:
    points: {{O2: [0, 0], A: [{2 * 0.0254!r}, 0]}}
    mass: {0.8 * 0.45359237!r}
    com: [0.0254, 0]
    inertia: {0.0012 * 0.45359237 * 9.80665 * 0.0254!r}
  coupler:
    points: {{A: [0, 0], B: [{8 * 0.0254!r}, 0], P: {{length: {4 * 0.0254!r}, angle: 30}}}}
    weight: {1.5 * 0.45359237 * 9.80665!r} N
    uniform_bar: [A, B]
  rocker:
    points: {{O4: [0, 0], B: [{5 * 0.0254!r}, 0]}}
    mass: {0.01 * 0.45359237 * 9.80665 / 0.3048!r}
    uniform_bar: [O4, B]
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: [B left of A -> O4]
driver: {{joint: O2, speed: {300 * 2 * math.pi / 60!r} rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: 10 deg}}
gravity: {386.09 * 0.0254!r} m/s^2
loads:
  tool: {{force: [0, {-12 * 0.45359237 * 9.80665!r} N], at: P}}
  brake: {{torque: {-15 * 0.45359237 * 9.80665 * 0.0254!r} N m, on: rocker}}
  k1:
    spring: [P, O4]
    stiffness: {20 * 0.45359237 * 9.80665 / 0.0254!r} N/m
    free_length: {6 * 0.0254!r}
"""


def test_a_textbook_file_in_us_units_matches_the_same_file_in_si():
    us, si = ms.loads(US), ms.loads(SI)
    for a, b in zip(us.links, si.links):
        assert a.mass == pytest.approx(b.mass, rel=1e-15)
        assert a.inertia == pytest.approx(b.inertia, rel=1e-15)
    ru, rs = ms.solve(us), ms.solve(si)
    assert ru.ok.all() and rs.ok.all()
    P, Q = ru.point("P"), rs.point("P")
    np.testing.assert_allclose(P.x, Q.x, rtol=0, atol=1e-14)
    np.testing.assert_allclose(P.ay, Q.ay, rtol=1e-12, atol=1e-12)
    scale = np.max(np.abs(rs.driving_effort))
    np.testing.assert_allclose(ru.driving_effort, rs.driving_effort, rtol=0, atol=1e-12 * scale)
    for j in ("O2", "A", "B", "O4"):
        np.testing.assert_allclose(
            ru.reaction(j)["F"], rs.reaction(j)["F"], rtol=0, atol=1e-12 * scale / 0.0254
        )


# --- 4. variants replace exclusive keys ---------------------------------------------------

BASE = """
name: four-bar
ground: {O2: [0, 0], O4: [3.2, 0]}
links:
  crank: {points: {O2: [0, 0], A: [1, 0]}, mass: 1 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [3, 0]}}
  rocker: {points: {O4: [0, 0], B: [2.5, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
driver: {joint: O2, speed: 1 rad/s, start: 0 deg}
sweep: {range: 360 deg, step: 2 deg}
loads: {q: {torque: 2 N m, on: rocker}}
variants:
  steps: {sweep: {steps: 12}}
  to: {sweep: {to: 90 deg}}
  null_step: {sweep: {step: null, steps: 12}}
  both: {sweep: {to: 90 deg, range: 90 deg}}
  bad_steps: {sweep: {steps: 0}}
  by_weight: {links: {crank: {weight: 19.62 N}}}
  force: {loads: {q: {force: [1 N, 0], at: B}}}
"""


def test_variant_steps_replace_the_base_step():
    res = ms.solve(ms.loads(BASE, variant="steps"))
    assert len(res) == 13
    np.testing.assert_allclose(np.degrees(res.u[-1] - res.u[0]), 360)
    assert len(ms.solve(ms.loads(BASE, variant="null_step"))) == 13
    assert len(ms.solve(ms.loads(BASE))) == 181


def test_variant_to_replaces_the_base_range():
    res = ms.solve(ms.loads(BASE, variant="to"))
    assert len(res) == 46
    assert np.degrees(res.u[-1]) == pytest.approx(90)


def test_variant_exclusive_keys_elsewhere():
    mech = ms.loads(BASE, variant="by_weight")
    assert mech.link("crank").mass == pytest.approx(19.62 / 9.81)
    (load,) = ms.loads(BASE, variant="force").loads
    assert (load.link, load.point, load.force) == ("rocker", "B", (1.0, 0.0))


def test_variant_mistakes_still_name_the_variants_line():
    with pytest.raises(InputError) as exc:
        ms.loads(BASE, variant="bad_steps", file="v.yaml")
    assert str(exc.value).startswith("v.yaml:21: variants.bad_steps.sweep.steps: ")
    with pytest.raises(InputError) as exc:
        ms.loads(BASE, variant="both", file="v.yaml")
    assert str(exc.value).startswith("v.yaml:20: variants.both.sweep: ")
    assert "give only one of range, to, duration" in str(exc.value)
