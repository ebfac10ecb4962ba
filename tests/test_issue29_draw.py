"""``mechsolve draw``: the linkage as a drawing for CAD (issue 29, item 4).

The lengths are the files' own numbers (and, for the crane's bell crank, the law of
cosines by hand), never the drawing's earlier output."""

from __future__ import annotations

import math
import sys
import xml.etree.ElementTree as ET

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

from conftest import MECH

ezdxf = pytest.importorskip("ezdxf")

LAYERS = {"LINKS", "PINS", "GROUND", "GUIDES", "PATHS", "DIMENSIONS"}
# the four-bar: crank O2A, coupler AB, rocker O4B, mm (mechanisms/fourbar.yaml)
FOURBAR = [26.5, 59.0, 105.6]
# the crane, m: crank, coupler, jib O3B, O3C and BC (28.525 m at 25 deg from O3B), boom, tie
CRANE = sorted(
    [
        1.388,
        2.780,
        4.0,
        28.525,
        math.sqrt(4.0**2 + 28.525**2 - 2 * 4.0 * 28.525 * math.cos(math.radians(25))),
        3.625,
        25.15,
    ]  # fmt: skip
)


def draw(*args):
    return CliRunner().invoke(main, ["draw", *map(str, args)])


def _read(path):
    doc = ezdxf.readfile(path)
    msp = doc.modelspace()
    bars = sorted(
        math.dist(tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2])
        for e in msp.query("LINE")
        if e.dxf.layer == "LINKS"
    )
    dims = sorted(d.get_measurement() for d in msp.query("DIMENSION"))
    return doc, msp, bars, dims


@pytest.mark.parametrize("name, lengths, insunits", [("fourbar", FOURBAR, 4), ("crane", CRANE, 6)])
def test_dxf_lengths_layers_and_dimensions(tmp_path, name, lengths, insunits):
    out = tmp_path / f"{name}.dxf"
    r = draw(MECH / f"{name}.yaml", "-o", out)
    assert r.exit_code == 0, r.output
    doc, msp, bars, dims = _read(out)
    assert doc.header["$INSUNITS"] == insunits  # the file's unit: mm, m
    assert LAYERS <= {layer.dxf.name for layer in doc.layers}
    assert len(bars) == len(lengths)
    for got, want in zip(bars, lengths):
        assert got == pytest.approx(want, abs=1e-9)
    assert len(dims) == len(lengths)
    for got, want in zip(dims, lengths):
        assert got == pytest.approx(want, abs=1e-9)
    # every pin's circle, every ground pivot hatched
    pins = list(msp.query("CIRCLE"))
    assert pins and all(c.dxf.layer == "PINS" for c in pins)
    assert any(e.dxf.layer == "GROUND" for e in msp.query("LWPOLYLINE"))
    assert any(e.dxf.layer == "PATHS" for e in msp.query("LWPOLYLINE"))


def test_at_a_position_and_slider_guides(tmp_path):
    # the four-bar's crank at 90 deg: A straight above O2 (0, 26.5) mm
    out = tmp_path / "fb.dxf"
    r = draw(MECH / "fourbar.yaml", "-o", out, "--at", "90 deg")
    assert r.exit_code == 0, r.output
    _, msp, bars, _ = _read(out)
    ends = {
        tuple(round(v, 9) for v in tuple(p)[:2])
        for e in msp.query("LINE")
        if e.dxf.layer == "LINKS"
        for p in (e.dxf.start, e.dxf.end)
    }
    assert (0.0, 26.5) in ends
    for got, want in zip(bars, FOURBAR):
        assert got == pytest.approx(want, abs=1e-9)
    # the slider-crank: crank 50 mm, rod 200 mm, a block on a ground guide
    out = tmp_path / "sc.dxf"
    r = draw(MECH / "slider-crank.yaml", "-o", out)
    assert r.exit_code == 0, r.output
    _, msp, bars, dims = _read(out)
    assert bars == pytest.approx([50.0, 200.0], abs=1e-9)
    assert dims == pytest.approx([50.0, 200.0], abs=1e-9)
    assert any(e.dxf.layer == "GUIDES" for e in msp.query("LWPOLYLINE"))
    assert "1 blocks" in r.output


def test_svg_is_xml_with_one_group_per_bar_and_pdf(tmp_path):
    out = tmp_path / "fb.svg"
    r = draw(MECH / "fourbar.yaml", "-o", out, "--envelope")
    assert r.exit_code == 0, r.output
    root = ET.parse(out).getroot()
    ids = [e.get("id") for e in root.iter() if (e.get("id") or "").startswith("bar-")]
    assert sorted(ids) == ["bar-coupler", "bar-crank", "bar-rocker"]
    text = out.read_text()
    assert "26.5 mm" in text and "105.6 mm" in text and "scale 1:" in text
    pdf = tmp_path / "fb.pdf"
    assert draw(MECH / "fourbar.yaml", "-o", pdf).exit_code == 0
    assert pdf.read_bytes()[:5] == b"%PDF-"


def test_envelope_holds_the_crank_circle(tmp_path):
    out = tmp_path / "env.dxf"
    r = draw(MECH / "fourbar.yaml", "-o", out, "--envelope")
    assert r.exit_code == 0, r.output
    _, msp, _, dims = _read(out)
    assert any(e.dxf.layer == "ENVELOPE" for e in msp.query("LWPOLYLINE"))
    # the crank pin's circle (diameter 53 mm) lies inside the overall extent
    width, height = dims[-2:]
    assert min(width, height) > 53.0


def test_without_ezdxf_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ezdxf", None)  # import ezdxf raises ImportError
    r = draw(MECH / "fourbar.yaml", "-o", tmp_path / "x.dxf")
    assert r.exit_code == 2
    assert 'pip install "mechsolve[cad]"' in r.output
    assert not (tmp_path / "x.dxf").exists()


@pytest.mark.parametrize("at", ["99", "banana", "45"])
def test_bad_at_is_exit_2(tmp_path, at):
    r = draw(MECH / "fourbar.yaml", "-o", tmp_path / "x.dxf", "--at", at)
    assert r.exit_code == 2, r.output
    assert "--at" in r.output and "Traceback" not in r.output
    assert not (tmp_path / "x.dxf").exists()


def test_bad_suffix_is_exit_2(tmp_path):
    r = draw(MECH / "fourbar.yaml", "-o", tmp_path / "x.png")
    assert r.exit_code == 2 and ".dxf, .svg or .pdf" in r.output
