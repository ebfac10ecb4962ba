"""mechsolve polygons: the graphical velocity and acceleration polygons at one position.

References, none of them mechsolve's own output:
* seed 001 (the shaper) position 7: the values printed in the seed's graphical solution
  and the independent re-solution of the founding material
  (tests/data/polygons_001_position7.json);
* closed forms written from the textbook (tests/closed_form.py): the four-bar
  (Freudenstein), the offset slider-crank, the slotted bar (inverted slider-crank);
* a two-slider (PRP) linkage whose pin is where a turning slotted crank crosses a fixed
  horizontal guide: x = h / tan(theta), differentiated by hand below.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve import api
from mechsolve.analyses.polygons import build_polygons, draw_polygons, round_scale
from mechsolve.base.errors import InputError
from mechsolve.cli.commands.polygons import polygons
from tests.closed_form import fourbar, slider_crank, slotted_bar

ROOT = Path(__file__).resolve().parent.parent
SHAPER = ROOT / "mechanisms" / "shaper.yaml"
DATA = json.loads((Path(__file__).parent / "data" / "polygons_001_position7.json").read_text())


@pytest.fixture(scope="module")
def shaper7():
    return build_polygons(api.load(SHAPER, "graphical"), 7)


def seed_names(r) -> dict[str, float]:
    """The seed's names for what the polygons show (magnitudes; vC and aC along +x)."""
    return {
        "vA3": r.value("v_A3"),
        "vA4A3": r.value("v_A3A4"),
        "vA4": r.value("v_A4"),
        "w4": abs(r.angular("ω4").value),
        "vB": r.value("v_B"),
        "vCB": r.value("v_CB"),
        "w5": abs(r.angular("ω5").value),
        "vC": r.arrow("v_C").along,
        "aA4n": r.value("a^n_A4"),
        "aA3": r.value("a_A3"),
        "aK": r.value("a^k_A3A4"),
        "aA4": r.value("a_A4"),
        "aB": r.value("a_B"),
        "aS4": r.value("a_S4"),
        "aA4t": r.value("a^t_A4"),
        "alpha4": abs(r.angular("α4").value),
        "aCBn": r.value("a^n_CB"),
        "aCBt": r.value("a^t_CB"),
        "alpha5": abs(r.angular("α5").value),
        "aC": r.arrow("a_C").along,
        "LO4A4": r.angular("ω4").length,
    }


def last_digit(x: float) -> float:
    """One unit of the last digit printed: 0.01 for 4.34, 0.001 for 0.454."""
    text = repr(x).rstrip("0")
    decimals = len(text.partition(".")[2])
    return 10.0**-decimals


def test_seed_001_position_7_printed_values(shaper7):
    """Every graphical value the seed prints, at its printed precision: within one unit
    of the last printed digit or 0.5 % (the graphical reading; e.g. vC = 0.4446 was read
    0.444). The values the seed itself has wrong are compared with the re-solution."""
    ours = seed_names(shaper7)
    printed, off = DATA["printed"], DATA["known_off_in_seed"]
    assert set(off) == {"vCB", "w5", "aCBn", "aCBt", "alpha5"}
    for key, want in printed.items():
        if key in off:
            # the printed value is off; the independent re-solution holds
            assert ours[key] == pytest.approx(DATA["resolution"][key], rel=1e-9), key
            assert abs(ours[key] - want) > max(last_digit(want), 0.005 * abs(want)), key
            continue
        tol = max(last_digit(want), 0.005 * abs(want))
        assert abs(ours[key] - want) <= tol, (key, ours[key], want)


def test_seed_001_position_7_against_the_resolution(shaper7):
    ours = seed_names(shaper7)
    for key, want in DATA["resolution"].items():
        assert ours[key] == pytest.approx(want, rel=1e-9), key
    # the working stroke runs to the right and the ram slows down; the crank turns cw
    assert ours["vC"] > 0 and ours["aC"] < 0
    assert shaper7.angular("ω2").value == pytest.approx(-2 * math.pi)


def test_seed_001_scale_and_drawn_lengths(shaper7):
    """At the seed's μv = 0.01 (m/s)/mm, chosen here automatically, vB is 45.4 mm long."""
    assert shaper7.velocity.scale == DATA["printed_scale_v"]
    assert shaper7.acceleration.scale == 0.05
    vb = shaper7.arrow("v_B")
    assert shaper7.velocity.mm(vb) == pytest.approx(45.44, abs=0.01)
    text = shaper7.text()
    assert "μv = 0.01 (m/s)/mm" in text and "μa = 0.05 (m/s^2)/mm" in text
    assert "v_A3 = v_A4 (⟂ O4A) + v_A3A4 (∥ slot)" in text
    assert "a_A3 = a^n_A4 + a^t_A4 (⟂ O4A) + a^k_A3A4 + a^r_A3A4 (∥ slot)" in text
    assert "ω4 (guide_bar) = v_A4 / l_O4A4 = 0.3577 / 0.4251 m = -0.8415 rad/s clockwise" in text
    assert "a^k_A3A4  A4' -> k3'" in text
    # the construction agrees with the analytic solution to rounding
    assert shaper7.check["velocity"] < 1e-12 and shaper7.check["acceleration"] < 1e-12
    assert shaper7.check["omega"] < 1e-12 and shaper7.check["alpha"] < 1e-12


def test_position_angle_and_time_name_the_same_instant(shaper7):
    mech = api.load(SHAPER, "graphical")
    by_angle = build_polygons(mech, "16.8264 deg")
    by_time = build_polygons(mech, "0.5 s")
    for r in (by_angle, by_time):
        assert r.value("v_C") == pytest.approx(shaper7.value("v_C"), rel=1e-5)
        assert r.value("a_C") == pytest.approx(shaper7.value("a_C"), rel=1e-5)
    # position 1 is the ram's left limit: the ram is at rest there
    first = build_polygons(mech, 1)
    assert abs(first.arrow("v_C").along) < 1e-9


FOURBAR = """
name: four-bar
units: {length: mm, angle: deg}
ground: {O2: [0, 0], O4: [87.5, 0]}
links:
  crank: {points: {O2: [0, 0], A: [26.5, 0]}}
  coupler: {points: {A: [0, 0], B: [105.6, 0]}}
  rocker: {points: {O4: [0, 0], B: [59, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly: [B left of A -> O4]
driver: {joint: O2, speed: 12 rad/s, start: 0 deg}
"""


@pytest.mark.parametrize("at", ["40 deg", "250 deg", 3])
def test_fourbar_against_freudenstein(at):
    mech = api.loads(FOURBAR)
    r = build_polygons(mech, at)
    th2 = r.u
    a, b, c, d, w2 = 0.0265, 0.1056, 0.059, 0.0875, 12.0
    bx = float(r.state.x[2, 0] + c * math.cos(r.state.th[2, 0]))  # the rocker's B (geometry)
    for branch in (1, -1):
        th3, th4, w3, w4, al3, al4 = fourbar(a, b, c, d, th2, w2, branch)
        if abs(d + c * math.cos(th4) - bx) < 1e-9:
            break
    else:
        raise AssertionError("no closed-form branch has B where the drawing has it")
    assert r.angular("ω3").value == pytest.approx(w3, rel=1e-9)
    assert r.angular("ω4").value == pytest.approx(w4, rel=1e-9)
    assert r.angular("α3").value == pytest.approx(al3, rel=1e-9)
    assert r.angular("α4").value == pytest.approx(al4, rel=1e-9)
    assert r.value("v_A") == pytest.approx(a * w2, rel=1e-12)
    assert r.value("v_B") == pytest.approx(c * abs(w4), rel=1e-9)
    assert r.value("v_BA") == pytest.approx(b * abs(w3), rel=1e-9)
    assert r.value("a^n_BA") == pytest.approx(b * w3**2, rel=1e-9)
    assert r.value("a^t_B") == pytest.approx(c * abs(al4), rel=1e-9)
    assert r.value("a_B") == pytest.approx(c * math.hypot(al4, w4**2), rel=1e-9)
    text = r.text()
    assert "v_B = v_A + v_BA (⟂ AB) = v_B (⟂ O4B)" in text


SLIDER_CRANK = """
name: slider-crank
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [50, 0]}}
  rod: {points: {A: [0, 0], C: [200, 0]}}
  piston: {points: {C: [0, 0]}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cylinder: {slider: [ground, piston], point: C, line: {through: [0, 10], angle: 0}}
assembly: [C.x > A.x]
driver: {joint: O, speed: 1500 rpm, start: 0 deg}
"""


@pytest.mark.parametrize("at", [4, "130 deg", "300 deg"])
def test_slider_crank_against_the_sine_rule(at):
    r = build_polygons(api.loads(SLIDER_CRANK), at)
    w = 1500 * 2 * math.pi / 60
    x, xd, xdd, phi, phid, phidd = slider_crank(0.05, 0.2, 0.01, r.u, w)
    assert r.arrow("v_C").along == pytest.approx(float(xd), rel=1e-9, abs=1e-12)
    assert r.arrow("a_C").along == pytest.approx(float(xdd), rel=1e-9)
    assert r.angular("ω3").value == pytest.approx(float(phid), rel=1e-9)
    assert r.angular("α3").value == pytest.approx(float(phidd), rel=1e-9)
    assert r.value("v_CA") == pytest.approx(0.2 * abs(float(phid)), rel=1e-9)
    assert r.value("a^n_CA") == pytest.approx(0.2 * float(phid) ** 2, rel=1e-9)


SLOTTED = """
name: slotted bar
units: {length: mm, angle: deg}
ground: {O4: [0, 0], O2: [0, 300]}
links:
  crank: {points: {O2: [0, 0], A: [120, 0]}}
  block: {points: {A: [0, 0]}}
  bar: {points: {O4: [0, 0], B: [500, 0]}}
joints:
  O2: [ground, crank]
  A: [crank, block]
  slot: {slider: [bar, block], point: A, line: [O4, B]}
  O4: [ground, bar]
driver: {joint: O2, speed: 5 rad/s, start: 10 deg}
"""


@pytest.mark.parametrize("at", [1, 5, "200 deg"])
def test_slotted_bar_coriolis_against_polar_coordinates(at):
    r = build_polygons(api.loads(SLOTTED), at)
    psi, psid, psidd, s, sd, sdd = slotted_bar(0.12, 0.3, r.u, 5.0)
    assert r.angular("ω4").value == pytest.approx(float(psid), rel=1e-9)
    assert r.angular("α4").value == pytest.approx(float(psidd), rel=1e-9)
    assert r.arrow("v_A3A4").along == pytest.approx(float(sd), rel=1e-9)
    assert r.arrow("a^r_A3A4").along == pytest.approx(float(sdd), rel=1e-9)
    assert r.value("a^k_A3A4") == pytest.approx(2 * abs(float(psid * sd)), rel=1e-9)
    assert r.value("v_A4") == pytest.approx(float(s) * abs(float(psid)), rel=1e-9)


PRP = """
name: two sliders
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], E: [100, 0]}}
  shoe: {points: {M: [0, 0]}}
  slide: {points: {M: [0, 0]}}
joints:
  O: [ground, crank]
  on_crank: {slider: [crank, shoe], point: M, line: [O, E]}
  M: [shoe, slide]
  guide: {slider: [ground, slide], point: M, line: {through: [0, 80], angle: 0}}
assembly: [M.x > 0]
driver: {joint: O, speed: 4 rad/s, start: 50 deg}
"""


def test_two_sliders_prp_against_hand_derivatives():
    """M = (h cot θ, h): ẋ = -h θ̇ / sin²θ, ẍ = 2 h θ̇² cos θ / sin³θ; along the crank
    s = h / sin θ, ṡ = -h θ̇ cos θ / sin²θ."""
    r = build_polygons(api.loads(PRP), "70 deg")
    h, th, w = 0.08, math.radians(70), 4.0
    assert r.arrow("v_M3").along == pytest.approx(-h * w / math.sin(th) ** 2, rel=1e-9)
    assert r.arrow("a_M3").along == pytest.approx(
        2 * h * w**2 * math.cos(th) / math.sin(th) ** 3, rel=1e-9
    )
    sd = -h * w * math.cos(th) / math.sin(th) ** 2
    slide = [s for s in r.sliding if s[0] == "on_crank"][0]
    assert slide[1] == pytest.approx(sd, rel=1e-9)
    assert r.value("a^k_M3M2") == pytest.approx(2 * w * abs(sd), rel=1e-9)
    assert "v_M3 = v_M2 + v_M3M2 (∥ on_crank) = v_M3 (∥ guide)" in r.text()


@pytest.mark.parametrize(
    "file,variant",
    [(f, None) for f in ("fourbar", "crane", "sixbar", "motor-linkage", "slider-crank")]
    + [("shaper", None), ("crane-zh", None)],
)
def test_every_example_closes_its_polygons(file, variant):
    mech = api.load(ROOT / "mechanisms" / f"{file}.yaml", variant)
    for at in (2, 9):
        r = build_polygons(mech, at)
        v_size = max(r.velocity.extent(), 1e-300)
        a_size = max(r.acceleration.extent(), 1e-300)
        assert r.check["velocity"] <= 1e-9 * v_size, (file, at, r.check)
        assert r.check["acceleration"] <= 1e-9 * a_size, (file, at, r.check)
        assert r.omegas, file


def test_round_scale():
    assert round_scale(0.6912) == 0.01  # 0.6912 / 120 mm = 0.00576 -> 0.01
    assert round_scale(4.34) == 0.05
    assert round_scale(1.2) == 0.01
    assert round_scale(250.0) == 5.0
    assert round_scale(0.0) == 1.0


def test_given_scale_sets_the_drawn_lengths():
    r = build_polygons(api.load(SHAPER, "graphical"), 7, scale_v=0.005, scale_a=0.02)
    assert r.velocity.mm(r.arrow("v_A3")) == pytest.approx(0.69115 / 0.005, rel=1e-4)
    assert r.acceleration.mm(r.arrow("a_A3")) == pytest.approx(4.3426 / 0.02, rel=1e-4)


def test_draw_polygons_writes_the_images(tmp_path):
    r = draw_polygons(api.load(SHAPER, "graphical"), 7, tmp_path, svg=True)
    names_ = sorted(p.name for p in r.images)
    assert names_ == sorted(
        f"{s}.{e}"
        for s in ("velocity-polygon", "acceleration-polygon", "polygons")
        for e in ("png", "svg")
    )
    from PIL import Image

    with Image.open(tmp_path / "polygons.png") as im:
        assert im.size[0] > 1500 and im.size[1] > 600
    svg = (tmp_path / "velocity-polygon.svg").read_text()
    assert "velocity polygon" in svg and "(m/s)/mm" in svg  # text kept as text


def test_cli(tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(
        polygons, [str(SHAPER), "--variant", "graphical", "--at", "7", "-o", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert "position 7 of 12 per turn" in res.output
    assert "check against mechsolve's analytic solution" in res.output
    for name in ("velocity-polygon.png", "acceleration-polygon.png", "polygons.png"):
        assert (out / name).stat().st_size > 10_000
    assert "a^k_A3A4" in (out / "polygons.txt").read_text(encoding="utf-8")
    sheet = tmp_path / "sheet.svg"
    res = CliRunner().invoke(
        polygons, [str(SHAPER), "--at", "196.8 deg", "-o", str(sheet), "-q", "--scale-v", "0.01"]
    )
    assert res.exit_code == 0 and res.output == "" and sheet.stat().st_size > 10_000


@pytest.mark.parametrize(
    "args,message",
    [
        (["--at", "13"], "positions are numbered 1 to 12"),
        (["--at", "196.8"], "give the angle with its unit"),
        (["--at", "fast"], "expected a position number"),
        (["--at", "7", "--scale-a", "0"], "--scale-a"),
        (["--at", "7", "--variant", "nope"], "nope"),
        (["--at", "7", "-o", "/nonexistent-dir/x.png"], "does not exist"),
    ],
)
def test_cli_bad_input(args, message):
    res = CliRunner().invoke(polygons, [str(SHAPER), *args])
    assert res.exit_code == 2, res.output
    assert message in res.output and "Traceback" not in res.output


def test_a_group_the_method_does_not_draw_is_refused():
    """A Scotch yoke's block-and-yoke group (RPP) is not one of the drawn kinds."""
    text = """
name: yoke
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [40, 0]}}
  block: {points: {A: [0, 0]}}
  yoke: {points: {Y: [0, 0], Z: [0, 100]}}
joints:
  O: [ground, crank]
  A: [crank, block]
  slot: {slider: [yoke, block], point: A, line: [Y, Z]}
  rail: {slider: [ground, yoke], point: Y, line: {through: [0, 0], angle: 0}}
driver: {joint: O, speed: 1 rad/s, start: 30 deg}
"""
    with pytest.raises(InputError, match="driver link, RRR, RRP, RPR and PRP"):
        build_polygons(api.loads(text), 2)


def test_a_real_process(tmp_path):
    code = (
        "import sys; from mechsolve.cli.commands.polygons import polygons; "
        "sys.argv = ['mechsolve polygons'] + sys.argv[1:]; polygons()"
    )
    out = tmp_path / "p"
    proc = subprocess.run(
        [sys.executable, "-c", code, str(SHAPER), "--at", "7", "--variant", "graphical",
         "-o", str(out), "--units", "SI"],
        capture_output=True, text=True, timeout=120, cwd=ROOT,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "ω4 (guide_bar)" in proc.stdout
    assert "+0.4446" in proc.stdout and "-3.368" in proc.stdout
