"""Issue 28, items 3 and bad input: balancing by counterweights.

References: the hand values of the linearly independent vectors method for the docs'
four-bar (uniform bars), the stationary total centre of mass of the balanced file (from
positions alone), and the textbook residual of a partially balanced in-line
slider-crank (primary (1 - c) m_rec r w^2 cos th, secondary m_rec r w^2 (r/l) cos 2th,
vertical c m_rec r w^2 sin th).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve import api
from mechsolve.cli.main import main

FOURBAR = "mechanisms/fourbar.yaml"


def centre_of_mass(res):
    """The total first moment of mass sum m r_G (kg m) from the positions alone."""
    mech, an, st = res.mechanism, res.analysis, res.solution.state
    sx = sy = 0.0
    for lk in mech.links:
        x, y = st.point(an.system.index[lk.name], np.asarray(lk.com, float))
        sx, sy = sx + lk.mass * x, sy + lk.mass * y
    return sx, sy


def test_fourbar_counterweights_by_hand_and_zero_shaking():
    bal = api.balanced(ms.load(FOURBAR))
    crank, rocker = bal.balance.counterweights
    # uniform bars: crank 50 g over 26.5 mm, coupler 200 g (100 g to each pin), rocker
    # 110 g over 59 mm; each counterweight opposite its link's other pin
    assert crank.mr == pytest.approx((0.05 / 2 + 0.1) * 0.0265, rel=1e-12)
    assert rocker.mr == pytest.approx((0.11 / 2 + 0.1) * 0.059, rel=1e-12)
    for cw in (crank, rocker):
        assert abs(abs(math.degrees(cw.angle)) - 180) < 1e-9
    assert bal.after.results.mechanism.link("crank").mass == pytest.approx(0.05 + 0.125)
    before = np.nanmax(bal.before.force)
    assert before > 1e-3
    assert np.nanmax(bal.after.force) < 1e-12 * before
    sx, sy = centre_of_mass(bal.after.results)  # the balanced file's centre stays put
    assert np.ptp(sx) < 1e-12 and np.ptp(sy) < 1e-12
    assert np.ptp(centre_of_mass(bal.before.results)[0]) > 1e-4  # and it moved before
    text = "\n".join(bal.lines())
    assert "after 0 N to rounding" in text  # no figure printed for rounding noise


def test_fourbar_with_the_coupler_centre_off_its_line():
    text = open(FOURBAR).read()
    coupler = "    mass: 0.2 kg\n    uniform_bar: [A, B]\n"
    assert coupler in text
    text = text.replace(coupler, "    mass: 0.2 kg\n    com: P\n    inertia: 0.0002 kg m^2\n")
    bal = api.balanced(ms.loads(text, file="off-line.yaml"))
    shares = list(bal.balance.shares.values())
    assert abs(shares[0].imag) > 1e-3  # a complex share: the centre is off A-B
    assert sum(shares) == pytest.approx(0.2)
    assert np.nanmax(bal.after.force) < 1e-12 * np.nanmax(bal.before.force)
    sx, sy = centre_of_mass(bal.after.results)
    assert np.ptp(sx) < 1e-12 and np.ptp(sy) < 1e-12


SLIDER = """
name: in-line slider-crank
units: {{length: mm, angle: deg}}
ground: {{O: [0, 0]}}
links:
  crank:
    points: {{O: [0, 0], A: [50, 0], G2: [12, 0]}}
    mass: 1.3 kg
    com: G2
    inertia: 0.002 kg m^2
  rod:
    points: {{A: [0, 0], B: [200, 0], G3: [70, 0]}}
    mass: 0.9 kg
    com: G3
    inertia: 0.004 kg m^2
  piston:
    points: {{B: [0, 0]}}
    mass: 0.6 kg
    com: B
joints:
  O: [ground, crank]
  A: [crank, rod]
  B: [rod, piston]
  cylinder: {{slider: [ground, piston], point: B, line: {{through: [0, 0], angle: 0}}}}
assembly:
  - B.x > A.x
driver: {{joint: O, speed: {w} rad/s, start: 0 deg}}
sweep: {{range: 360 deg, step: 2 deg}}
gravity: 9.81 m/s^2
"""


@pytest.mark.parametrize("c", [0.0, 0.5, 0.7, 1.0])
def test_slider_crank_partial_balance_has_the_textbook_residual(c):
    w, r, lam = 120.0, 0.05, 0.25
    bal = api.balanced(ms.loads(SLIDER.format(w=w), file="sc.yaml"), fraction=c)
    m_rec = 0.6 + 0.9 * 70 / 200  # the piston and the rod's share at the piston
    assert bal.balance.m_rec == pytest.approx(m_rec, rel=1e-12)
    assert bal.balance.inline
    sh = bal.after
    th = sh.results.u
    a = m_rec * r * w * w
    assert np.max(np.abs(sh.fy - (-c * a * np.sin(th)))) < 1e-9 * a  # exact
    n = len(th) - 1  # one turn, the last sample repeating the first
    h = np.fft.rfft(sh.fx[:n]) * 2 / n
    assert h[1].real == pytest.approx((1 - c) * a, rel=1e-9, abs=1e-9 * a)  # primary
    assert abs(h[1].imag) < 1e-9 * a
    assert h[2].real == pytest.approx(a * lam, rel=lam * lam / 2)  # secondary, a series
    assert np.max(np.abs(h[3::2])) < 1e-9 * a  # no odd harmonics beyond the first
    text = "\n".join(bal.lines())
    assert f"c = {c:.6g}" in text and "primary" in text


def test_balanced_file_is_written_in_the_files_units(tmp_path):
    src = tmp_path / "sc.yaml"
    src.write_text(SLIDER.format(w=100.0))
    out = tmp_path / "out"
    r = CliRunner().invoke(
        main,
        ["shaking", str(src), "--fraction", "0.5", "--radius", "crank=40", "-o", str(out)]
        + ["--units", "SI"],
    )
    assert r.exit_code == 0, r.output
    text = (out / "sc-balanced.yaml").read_text()
    mech = ms.load(out / "sc-balanced.yaml")
    cw = mech.link("crank").local("CW_crank")
    assert math.hypot(*cw) == pytest.approx(0.040, rel=1e-12)  # 40 mm
    assert "CW_crank: [-40.0, 0.0]" in text
    for name in ("shaking.csv", "shaking-balanced.csv", "shaking.png", "balance.png"):
        assert (out / name).stat().st_size > 0
    head = (out / "shaking.csv").read_text().splitlines()[0]
    assert "shaking.Fx [N]" in head and "shaking.M [N*m]" in head
    assert "before" in r.output and "after" in r.output and " N" in r.output


@pytest.mark.parametrize(
    "file, args, words",
    [
        (FOURBAR, ["--fraction", "0.5"], "for a slider-crank"),
        ("SC", ["--fraction", "1.5"], "must be in [0, 1]"),
        ("SC", ["--fraction", "-0.1"], "must be in [0, 1]"),
        ("SC", ["--radius", "ground=10"], "the frame (ground) cannot carry a counterweight"),
        ("SC", ["--radius", "rod=10"], "no counterweight goes on 'rod'"),
        ("SC", ["--radius", "crank=-3"], "must be positive"),
        ("SC", ["--radius", "crankshaft=10"], "no link named 'crankshaft'"),
        (FOURBAR, ["--about", "Q7"], "give a point of the frame (O2, O4)"),
        ("mechanisms/sixbar.yaml", ["--balance"], "four-bar or a slider-crank"),
        ("MASSLESS", ["--balance"], "the links have no mass, nothing shakes"),
    ],
)
def test_bad_input_is_exit_2_with_a_clear_message(tmp_path, file, args, words):
    if file == "MASSLESS":
        file = tmp_path / "fb.yaml"
        lines = open(FOURBAR).read().split("gravity:")[0].splitlines(keepends=True)
        file.write_text("".join(ln for ln in lines if "mass:" not in ln and "uniform" not in ln))
    if file == "SC":
        file = tmp_path / "sc.yaml"
        file.write_text(SLIDER.format(w=100.0))
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["shaking", str(file), *args, "-o", str(out)])
    assert r.exit_code == 2, r.output
    assert words in r.output
    assert "Traceback" not in r.output
    assert not out.exists()  # nothing written


def test_a_variant_is_balanced_as_applied():
    text = open(FOURBAR).read() + "variants:\n  heavy:\n    links: {crank: {mass: 0.5 kg}}\n"
    bal = api.balanced(ms.loads(text, "heavy", file="fb.yaml"), variant="heavy")
    assert bal.balance.counterweights[0].mr == pytest.approx((0.5 / 2 + 0.1) * 0.0265)
    assert "variants" not in bal.text and "variant 'heavy'" in bal.text
    assert np.nanmax(bal.after.force) < 1e-12 * np.nanmax(bal.before.force)


@pytest.mark.parametrize(
    "target",
    [
        "shaking.csv",
        "shaking.png",
        "fourbar-balanced.yaml",
        "shaking-balanced.csv",
        "balance.png",
    ],
)
def test_a_full_disk_is_exit_2_and_leaves_no_part(monkeypatch, tmp_path, target):
    """Every file goes through the atomic writer: a full disk while one is written is
    exit 2 naming it, with no temporary left and that file not there."""
    import errno
    import os

    real = os.fsync

    def fsync(fd):
        try:
            name = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            name = ""
        if target in os.path.basename(name):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["shaking", FOURBAR, "--balance", "-q", "-o", str(out)])
    assert r.exit_code == 2, r.output
    assert "No space left on device" in r.output and target in r.output
    assert "Traceback" not in r.output and "internal error" not in r.output
    temporaries = [p for p in tmp_path.rglob("*") if p.name.startswith(".")]
    assert [p for p in temporaries if p.name != ".mechsolve-outputs.json"] == []
    assert list(tmp_path.rglob(target)) == []
