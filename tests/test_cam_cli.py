"""mechsolve cam through its click command: seed 001's table 5-2 and pressure angles,
the files it writes, the exit codes, and the messages for bad input."""

from __future__ import annotations

import csv
import json
import math
import shutil
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve.cli.commands.cam import cam

ROOT = Path(__file__).parent.parent
DATA = Path(__file__).parent / "data"
SEED = ROOT / "mechanisms" / "shaper-cam.yaml"


def run(args):
    return CliRunner().invoke(cam, [str(a) for a in args])


def rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_seed_001_table_5_2(tmp_path):
    """Table 5-2, corrected, at every printed digit; the four misprints differ."""
    r = run([SEED, "-o", tmp_path, "--no-plots"])
    assert r.exit_code == 5, r.output  # the rise exceeds the common data set's 40 deg
    ref = json.loads((DATA / "cam_001_table5_2.json").read_text())
    table = {round(float(x["cam angle [deg]"]), 6): float(x["swing [deg]"])
             for x in rows(tmp_path / "cam_motion.csv")}  # fmt: skip
    rise = [table[dl] for dl in ref["delta_deg"][:-1]] + [table[75.0 + 0.0]]
    # 75 deg is the start of the far dwell, at the full swing
    ret = [table[85.0 + dl] for dl in ref["delta_deg"]]
    printed = {"rise": ref["printed_rise_deg"], "return": ref["printed_return_deg"]}
    for name, got, want in (("rise", rise, ref["recomputed_rise_deg"]),
                            ("return", ret, ref["recomputed_return_deg"])):  # fmt: skip
        assert [round(x, 3) for x in got] == [round(x, 3) for x in want]
        wrong = [i for i, (g, p) in enumerate(zip(got, printed[name])) if round(g, 3) != p]
        assert wrong == ([13, 14] if name == "rise" else [1, 2])
    # the summary prints the table and the pressure angles of both senses
    assert "14.467   14.867   15.000" in r.output
    assert "cw (as given):       48.32 deg at   37.5     46.20 deg at  122.5" in r.output
    assert "ccw (reversed):       46.20 deg at   37.5     48.32 deg at  122.5" in r.output
    assert "better sense: ccw" in r.output
    assert "r0 = 30.0002 mm" in r.output
    assert "over the allowed 40 deg" in r.output
    assert "undercut (margin 3 mm): no" in r.output


def test_seed_001_variants(tmp_path):
    r = run([SEED, "-o", tmp_path / "a", "--no-plots", "--variant", "as-seed"])
    assert r.exit_code == 0, r.output
    r = run([SEED, "-o", tmp_path / "b", "--no-plots", "--variant", "printed"])
    assert r.exit_code == 5
    assert "give r0 = 28.2011 mm (given 28.2 mm)" in r.output
    assert "49.37 deg" in r.output


def test_files_and_units(tmp_path):
    pytest.importorskip("ezdxf")
    r = run([DATA / "cam_translating.yaml", "-o", tmp_path])
    assert r.exit_code == 0, r.output
    names = {p.name for p in tmp_path.iterdir()}
    assert {"cam_motion.csv", "cam_profile.csv", "cam_profile.dxf", "motion.png",
            "pressure.png", "cam.png"} <= names  # fmt: skip
    head = next(csv.reader(open(tmp_path / "cam_motion.csv")))
    assert all("[" in h and h.endswith("]") for h in head), head
    assert "jerk [m/s^3]" in head and "pressure angle ccw [deg]" in head
    import ezdxf

    doc = ezdxf.readfile(tmp_path / "cam_profile.dxf")
    poly = [e for e in doc.modelspace() if e.dxftype() == "LWPOLYLINE"]
    prof = [e for e in poly if e.dxf.layer == "PROFILE"][0]
    assert prof.closed and len(prof) == 3600
    pts = rows(tmp_path / "cam_profile.csv")
    assert float(pts[10]["profile x [mm]"]) == pytest.approx(prof[10][0], abs=1e-9)
    # designed: the rise reaches its 30 deg allowance, the summary says so
    assert "base values (designed)" in r.output
    assert "30.00 deg" in r.output
    # cycloidal and 3-4-5 laws start and end at rest with no acceleration
    assert "velocity and acceleration continuous over the whole cycle" in r.output
    assert "design: acceptable" in r.output


def test_without_ezdxf(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "ezdxf", None)  # import ezdxf raises ImportError
    r = run([DATA / "cam_translating.yaml", "-o", tmp_path, "--no-plots"])
    assert r.exit_code == 0
    assert 'pip install "mechsolve[cam]"' in r.output
    assert (tmp_path / "cam_motion.csv").exists() and (tmp_path / "cam_profile.csv").exists()
    assert not (tmp_path / "cam_profile.dxf").exists()


def test_undercut_exits_5(tmp_path):
    text = (DATA / "cam_translating.yaml").read_text()
    text = text.replace("roller_radius: 8 mm", "roller_radius: 30 mm")
    text = text.replace("  min_curvature_radius: 2 mm\n", "  base_radius: 25 mm\n")
    text = text.replace("{rise: 30 deg, return: 45 deg}", "{rise: 60 deg, return: 60 deg}")
    f = tmp_path / "under.yaml"
    f.write_text(text)
    r = run([f, "-o", tmp_path / "out", "--no-plots"])
    assert r.exit_code == 5, r.output
    assert "undercut: YES at" in r.output
    assert "THE DESIGN FAILS" in r.output


BAD = [
    ("law: cycloidal}", "law: spline}", ":9: cam.motion[0].law: unknown motion law 'spline'"),
    ("{dwell: 90 deg}", "{dwell: 80 deg}", ":8: cam.motion: the segments cover 350 deg"),
    ("roller_radius: 8 mm", "roller_radius: -8 mm", ":5: cam.follower.roller_radius: must be"),
    ("  speed: 120 rpm\n", "", ":4: cam: 'cam' needs the key 'speed'"),
    ("lift: 25 mm", "swing: 25 deg", "cam.motion[0].swing: a translating follower's stroke"),
    ("translating roller", "rotating roller", "cam.follower.type: unknown follower type"),
    ("rotation: ccw", "rotation: left", ":6: cam.rotation: expected cw or ccw"),
]


@pytest.mark.parametrize("old,new,msg", BAD)
def test_bad_input(tmp_path, old, new, msg):
    text = (DATA / "cam_translating.yaml").read_text()
    assert old in text
    f = tmp_path / "bad.yaml"
    f.write_text(text.replace(old, new))
    r = run([f, "-o", tmp_path / "out"])
    assert r.exit_code == 2, r.output
    assert msg in r.output
    assert "Traceback" not in r.output


def test_base_values_that_disagree(tmp_path):
    text = SEED.read_text().replace("base_radius: 30 mm", "base_radius: 32 mm")
    f = tmp_path / "bad.yaml"
    f.write_text(text)
    r = run([f, "-o", tmp_path / "out"])
    assert r.exit_code == 2
    assert "cam.base_radius: pivot_distance, start_angle and base_radius disagree" in r.output
    assert "r0 = 30.0002 mm" in r.output


def test_no_cam_section(tmp_path):
    shutil.copy(ROOT / "mechanisms" / "fourbar.yaml", tmp_path / "m.yaml")
    r = run([tmp_path / "m.yaml", "-o", tmp_path / "out"])
    assert r.exit_code == 2
    assert "no 'cam:' section" in r.output
    assert math.isfinite(1.0)


def test_dxf_in_inch_and_micrometre(tmp_path):
    """A cam file in inch (or µm) gets a DXF in that unit, named in its header (1 inch,
    13 micron; imperial measurement for inch), its numbers the CSV's: the base circle of
    the same cam given in mm is 25.4 times the inch one's."""
    pytest.importorskip("ezdxf")
    import ezdxf

    text = (DATA / "cam_translating.yaml").read_text()
    radii = {}
    for unit, code, measurement, per_mm in (("inch", 1, 0, 1 / 25.4), ("µm", 13, 1, 1000.0),
                                            ("mm", 4, 1, 1.0)):  # fmt: skip
        f = tmp_path / f"cam_{code}.yaml"
        f.write_text(text.replace("length: mm", f"length: {unit}"), encoding="utf-8")
        out = tmp_path / f"out_{code}"
        r = run([f, "-o", out, "--no-plots"])
        assert r.exit_code == 0, r.output
        doc = ezdxf.readfile(out / "cam_profile.dxf")
        assert doc.header["$INSUNITS"] == code
        assert doc.header["$MEASUREMENT"] == measurement
        base = [e for e in doc.modelspace() if e.dxftype() == "CIRCLE" and e.dxf.layer == "BASE"]
        radii[unit] = base[0].dxf.radius / per_mm  # back in mm
        prof = [e for e in doc.modelspace() if e.dxf.layer == "PROFILE"][0]
        key = {"inch": "in", "µm": "µm", "mm": "mm"}[unit]
        pts = rows(out / "cam_profile.csv")
        col = [c for c in pts[0] if c.startswith("profile x [")][0]
        assert key in col or unit in col, col
        assert float(pts[10][col]) == pytest.approx(prof[10][0], rel=1e-9)
    assert radii["inch"] == pytest.approx(radii["mm"], rel=1e-9)
    assert radii["µm"] == pytest.approx(radii["mm"], rel=1e-9)
