"""Issue 30: the DXF of ``mechsolve draw`` (dimensions that measure true, the units
header, the motion envelope), ``run --watch``'s stale marker and changed figures, and
texts in the user's units.

The DXF is read back with ezdxf and checked against the files' own numbers (a crank of
50 mm, a rod of 200 mm) and ezdxf's table of units; the envelope against the extent of
a fine sweep's points; the watch's figures against the run's own summary text."""

from __future__ import annotations

import math
import re

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

from conftest import MECH

ezdxf = pytest.importorskip("ezdxf")

SC = MECH / "slider-crank.yaml"  # crank O-A 50 mm, rod A-C 200 mm


def draw(*args):
    return CliRunner().invoke(main, ["draw", *map(str, args)])


def _lfac(doc, dim) -> float:
    """The length factor a CAD program applies to ``dim``'s measurement: its own
    override, else its style's."""
    style = doc.dimstyles.get(dim.dxf.dimstyle)
    return float(dim.override().get("dimlfac", style.dxf.get("dimlfac", 1.0)))


def _block_texts(doc, dim) -> list[str]:
    block = doc.blocks.get(dim.dxf.geometry)
    return [e.plain_text() for e in block if e.dxftype() == "MTEXT"] + [
        e.dxf.text for e in block if e.dxftype() == "TEXT"
    ]


def test_dimensions_measure_true_in_the_drawing_unit(tmp_path):
    out = tmp_path / "sc.dxf"
    r = draw(SC, "-o", out, "--at", "40 deg")
    assert r.exit_code == 0, r.output
    doc = ezdxf.readfile(out)
    # no scale between the drawing's unit and what its dimensions read
    assert doc.header["$DIMLFAC"] == 1.0
    current = doc.dimstyles.get(doc.header["$DIMSTYLE"])
    assert current.dxf.get("dimlfac", 1.0) == 1.0
    msp = doc.modelspace()
    dims = list(msp.query("DIMENSION"))
    shown = sorted(d.get_measurement() * _lfac(doc, d) for d in dims)
    assert shown == pytest.approx([50.0, 200.0], abs=1e-9)
    for d in dims:
        # the text is the measurement (associative), not a typed-in override
        assert d.dxf.get("text", "") in ("", "<>")
        want = f"{d.get_measurement() * _lfac(doc, d):g} mm"
        assert _block_texts(doc, d) == [want]
    # a new dimension of the 50 mm crank in the drawing's current style reads 50 (the
    # unit's suffix is the header's $DIMPOST, which ezdxf does not read)
    assert doc.header["$DIMPOST"] == "<> mm"
    a = (50 * math.cos(math.radians(40)), 50 * math.sin(math.radians(40)))
    new = msp.add_aligned_dim(p1=(0, 0), p2=a, distance=5, dimstyle=doc.header["$DIMSTYLE"])
    new.render()
    (text,) = _block_texts(doc, new.dimension)
    assert float(text.split()[0]) == pytest.approx(50.0, abs=1e-9)


def _sc_in(tmp_path, unit: str, scale: float):
    """The slider-crank with ``units.length: unit``, its lengths the same in metres."""
    text = SC.read_text()
    text = text.replace("length: mm", f"length: {unit}")
    src = tmp_path / "sc.yaml"
    # the crank 50 mm and rod 200 mm written in the unit
    text = text.replace("A: [50, 0]", f"A: [{50 * scale:.12g}, 0]")
    text = text.replace("C: [200, 0]", f"C: [{200 * scale:.12g}, 0]")
    text = text.replace("G: [60, 0]", f"G: [{60 * scale:.12g}, 0]")
    text = text.replace("G1: [-5, 0]", f"G1: [{-5 * scale:.12g}, 0]")
    text = text.replace("through: [0, 10]", f"through: [0, {10 * scale:.12g}]")
    src.write_text(text, encoding="utf-8")
    return src


# each unit the parser takes for lengths, with its metres (written here by hand) and
# the name of its $INSUNITS code in ezdxf's table (ezdxf.units.unit_name)
UNITS = [
    ("mm", 1e-3, "Millimeters"),
    ("cm", 1e-2, "Centimeters"),
    ("dm", 1e-1, "Decimeters"),
    ("m", 1.0, "Meters"),
    ("km", 1e3, "Kilometers"),
    ("um", 1e-6, "Microns"),
    ("µm", 1e-6, "Microns"),
    ("in", 0.0254, "Inches"),
    ("inch", 0.0254, "Inches"),
    ("ft", 0.3048, "Feet"),
    ("yd", 0.9144, "Yards"),
]


@pytest.mark.parametrize("unit, metres, name", UNITS)
def test_units_header_names_the_files_length_unit(tmp_path, unit, metres, name):
    from ezdxf.units import IMPERIAL_UNITS, InsertUnits, unit_name

    src = _sc_in(tmp_path, unit, 1e-3 / metres)
    out = tmp_path / "u.dxf"
    r = draw(src, "-o", out)
    assert r.exit_code == 0, r.output
    doc = ezdxf.readfile(out)
    code = doc.header["$INSUNITS"]
    assert unit_name(code) == name
    imperial = InsertUnits(code) in IMPERIAL_UNITS
    assert doc.header["$MEASUREMENT"] == (0 if imperial else 1)
    assert imperial == (unit in ("in", "inch", "ft", "yd"))
    # the crank and the rod measure 50 and 200 mm in the drawing's unit
    dims = sorted(doc.modelspace().query("DIMENSION"), key=lambda d: d.get_measurement())
    want = [0.05 / metres, 0.2 / metres]
    assert [d.get_measurement() for d in dims] == pytest.approx(want, rel=1e-9)
    for d, length in zip(dims, want):  # the text: the measurement and the file's unit
        ((number, suffix),) = [t.split(" ", 1) for t in _block_texts(doc, d)]
        assert float(number) == pytest.approx(length, rel=1e-5)
        assert suffix == unit


def test_a_unit_dxf_has_no_code_for_is_said(tmp_path):
    # 1 in*in/mm = 0.64516 m: a length the parser takes and DXF has no code for
    src = _sc_in(tmp_path, "in*in/mm", 1e-3 / 0.64516)
    out = tmp_path / "u.dxf"
    r = draw(src, "-o", out)
    assert r.exit_code == 0, r.output
    assert "no unit code for 'in*in/mm'" in r.output and "0.64516 m" in r.output
    doc = ezdxf.readfile(out)
    assert doc.header["$INSUNITS"] == 0


def _overall(out):
    """The envelope's two overall dimensions (the last two), as measured."""
    doc = ezdxf.readfile(out)
    dims = list(doc.modelspace().query("DIMENSION"))
    return sorted(d.get_measurement() for d in dims[-2:])


def test_envelope_is_the_motions_extent_at_any_drawn_position(tmp_path):
    import numpy as np

    from mechsolve import api
    from mechsolve.writers.drawing import BAR, BLOCK

    got = []
    for at in ("0 deg", "90 deg", "233 deg"):
        out = tmp_path / "env.dxf"
        r = draw(SC, "-o", out, "--at", at, "--envelope")
        assert r.exit_code == 0, r.output
        got.append(_overall(out))
    # the extent over a 0.25 deg sweep of the links' points (mm): the bars' outlines
    # reach their radius past the points, the piston's block (on a horizontal guide)
    # its half length along and 0.6 of it across
    mech = api.load(SC)
    fine = api.solve(mech, step="0.25 deg", forces=False, velocity=False, acceleration=False)
    size = fine.analysis.scale * 1e3
    r, h = BAR * size, BLOCK * size
    xs = np.concatenate([fine.point(p).x for p in ("O", "A", "G1", "C", "G")]) * 1e3
    ys = np.concatenate([fine.point(p).y for p in ("O", "A", "G1", "C", "G")]) * 1e3
    c = fine.point("C")
    x_lo, x_hi = min(xs.min() - r, c.x.min() * 1e3 - h), max(xs.max() + r, c.x.max() * 1e3 + h)
    y_lo = min(ys.min() - r, c.y.min() * 1e3 - 0.6 * h)
    y_hi = max(ys.max() + r, c.y.max() * 1e3 + 0.6 * h)
    want = sorted([x_hi - x_lo, y_hi - y_lo])
    # the crank reaches 50 mm above and below O: the height is 100 mm and two radii
    assert want[0] == pytest.approx(100 + 2 * r, abs=1e-6)
    for g in got:
        assert g == pytest.approx(want, abs=1e-3)


# -- run --watch ------------------------------------------------------------------------
def _fake_watchfiles(monkeypatch, saves):
    """``watchfiles.watch`` replaced by one that makes each save of ``saves`` (a function
    that edits the file) and reports it, as the real one does after a save."""
    import sys
    import types

    def watch(folder, **kw):
        for save in saves:
            save()
            yield {("modified", str(folder))}

    monkeypatch.setitem(sys.modules, "watchfiles", types.SimpleNamespace(watch=watch))


def _watch(tmp_path, monkeypatch, text, saves, no_plots=True, units=None):
    """``run FILE --watch`` in this process on a file holding ``text``, making ``saves``;
    its lines."""
    from mechsolve.cli.commands.run import _run_job
    from mechsolve.cli.watch import watch_file

    f = tmp_path / "m.yaml"
    f.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    _fake_watchfiles(monkeypatch, [lambda s=s: s(f) for s in saves])
    lines: list[str] = []

    def job():
        return _run_job(f, out, None, None, no_plots, None, (), None, False, "png", units)

    watch_file(f, job, echo=lines.append, outdir=out)
    return f, out, lines


SC30 = SC.read_text().replace("step: 5 deg", "step: 30 deg")
BAD_REQUIREMENT = "requirements:\n  stroke ok: stroke(cylinderx) > 90 mm\n"


def _longer_crank_and_bad_requirement(f):
    f.write_text(f.read_text().replace("A: [50, 0]", "A: [60, 0]") + BAD_REQUIREMENT)


def test_watch_files_written_before_a_failed_check_are_not_called_stale(
    tmp_path, monkeypatch, capsys
):
    f, out, lines = _watch(tmp_path, monkeypatch, SC30, [_longer_crank_and_bad_requirement])
    text = "\n".join(lines)
    assert "cylinderx" in text  # the failure, named
    # the table is the save's: the crank pin A at 60 mm at the start
    header, first = (out / "results.csv").read_text().splitlines()[:2]
    col = header.split(",").index(next(h for h in header.split(",") if h.startswith("A.x")))
    assert float(first.split(",")[col]) == 60.0
    assert f"this save's run wrote results.csv in {out}/ before it failed" in text
    assert "from the last good run" not in text
    assert not (out / "STALE.txt").exists()  # every file there is the save's


def test_watch_marker_names_only_the_files_the_failed_save_left_old(tmp_path, monkeypatch):
    withinst = SC30 + "instants: [{theta: 30 deg, omega: 157 rad/s}]\n"
    seen = {}

    def drop_instants_bad_requirement(f):
        f.write_text(
            f.read_text().replace("instants: [{theta: 30 deg, omega: 157 rad/s}]\n", "")
            + BAD_REQUIREMENT
        )

    def parse_error(f):  # (and what the save before it left)
        seen["stale"] = (f.parent / "out" / "STALE.txt").read_text()
        f.write_text(f.read_text().replace("joints:", "joints: [", 1))

    f, out, lines = _watch(
        tmp_path, monkeypatch, withinst, [drop_instants_bad_requirement, parse_error]
    )
    # the failed save wrote results.csv, not instants.csv (the file has none now)
    first = seen["stale"]
    assert "not from the file as\nit is now: instants.csv." in first
    assert "The others (results.csv) were written by its last save" in first
    assert "cylinderx" in first
    # a save that cannot be run at all: every file is the last good run's
    stale = (out / "STALE.txt").read_text()
    assert "could not be run" in stale and "last good run" in stale


def _longer_crank(f):
    f.write_text(f.read_text().replace("A: [50, 0]", "A: [60, 0]"))


def _after(lines, name):
    """The new value and unit of figure ``name`` in the watch's "changed" lines."""
    for line in lines:
        m = re.match(rf"  {re.escape(name)}: \S+ -> (\S+?)(°| \S+)?( \(|$)", line)
        if m:
            return float(m.group(1)), (m.group(2) or "").strip()
    raise AssertionError(f"no {name!r} in\n" + "\n".join(lines))


def _last(text, pattern):
    return re.findall(pattern, text)[-1]


@pytest.mark.parametrize(
    "units, mm, torque", [(None, 1.0, "N·mm"), ("length=in,force=lbf", 25.4, "lbf·in")]
)
def test_watch_changes_are_the_summarys_figures_in_its_units(
    tmp_path, monkeypatch, capsys, units, mm, torque
):
    f, out, lines = _watch(tmp_path, monkeypatch, SC30, [_longer_crank], units=units)
    summary = capsys.readouterr().out
    unit = "mm" if mm == 1.0 else "in"
    # the stroke of the offset slider-crank (crank 60, rod 200, offset 10 mm) by hand
    stroke = (math.sqrt(260**2 - 10**2) - math.sqrt(140**2 - 10**2)) / mm
    assert _after(lines, "cylinder stroke") == (pytest.approx(stroke, rel=5e-6), unit)
    s = _last(summary, rf"\(stroke (\S+) {unit}\)")
    assert float(s) == pytest.approx(stroke, rel=5e-6)
    # the driving torque's max, the work and the peak reactions: the summary's numbers
    tmax = _last(summary, rf"driving torque \(1° samples\): max (\S+) {torque}")
    assert _after(lines, "driving torque, max") == (pytest.approx(float(tmax), rel=1e-6), torque)
    tmin = _last(summary, rf", min (\S+) {torque}")
    assert _after(lines, "driving torque, min") == (pytest.approx(float(tmin), rel=1e-6), torque)
    work, wunit = _last(summary, r"work of the driver per cycle: (\S+) (\S+)")
    assert _after(lines, "work of the driver") == (pytest.approx(float(work), rel=1e-6), wunit)
    force = "N" if units is None else "lbf"
    peaks = _last(summary, r"peak reactions \(1° samples\): (.*)")
    for joint in ("O", "A", "C"):
        v = re.search(rf"(?:^|; ){joint} (\S+) {force} ", peaks).group(1)
        assert _after(lines, f"peak reaction {joint}") == (pytest.approx(float(v), rel=1e-3), force)


# -- texts in the user's units ------------------------------------------------------------
BAR_ON_MOTOR = """
name: bar on a motor
ground: {O: [0, 0]}
links:
  bar: {points: {O: [0, 0], A: [0.8, 0]}, mass: 3 kg, uniform_bar: [O, A]}
joints: {O: [ground, bar]}
driver: {joint: O, start: 0 deg}
gravity: 9.81 m/s^2
motor: {stall: 50 N m, slope: 3 N m s}
simulate: {duration: 0.5 s, step: 0.002 s, method: rk4, from: rest}
"""


def test_simulate_says_its_times_in_the_time_unit_asked_for(tmp_path):
    f = tmp_path / "bar.yaml"
    f.write_text(BAR_ON_MOTOR)
    texts = []
    for units in ([], ["--units", "time=ms"]):
        r = CliRunner().invoke(
            main, ["simulate", str(f), "-o", str(tmp_path / "o"), "--no-plots", *units]
        )
        assert r.exit_code == 0, r.output
        texts.append(r.output)
    si, ms = texts
    seconds = [float(x) for x in re.findall(r"t = (\S+) s\b", si)]
    assert len(seconds) >= 5  # where the extremes are, the fastest, the end
    assert not re.findall(r"t = \S+ s\b", ms)
    assert [float(x) for x in re.findall(r"t = (\S+) ms\b", ms)] == pytest.approx(
        [1e3 * x for x in seconds], rel=1e-6
    )
    assert "250 steps of 2 ms to t = 500 ms" in ms  # 0.002 s each, to the 0.5 s asked for


def _is_125(x: float) -> bool:
    e = math.floor(math.log10(x) + 1e-12)
    return any(math.isclose(x, b * 10.0**e, rel_tol=1e-9) for b in (1, 2, 5))


@pytest.mark.parametrize("units", ["length=in,force=lbf", "force=kgf", "force=kN"])
def test_animation_scale_bar_reads_round_numbers_in_the_shown_units(units):
    from mechsolve import api
    from mechsolve.base.units import parse_output_units
    from mechsolve.report.animate import solve_frames

    mech = api.load(SC)
    U = parse_output_units(units, mech.output_units())
    fr = solve_frames(mech, count=24, forces=True, units=U)
    length, force = fr.bar_text.split(" = ")
    (lv, lu), (fv, fu) = length.split(" "), force.split(" ")
    assert (lu, fu) == (U.length, U.force)
    assert _is_125(float(lv)) and _is_125(float(fv)), fr.bar_text
    # what the bar reads is what it draws: its length over the arrows' m per N
    assert float(lv) == pytest.approx(U.show(fr.bar, "m")[0], rel=1e-9)
    assert float(fv) == pytest.approx(U.show(fr.bar / fr.force_scale, "N")[0], rel=1e-9)


def test_animation_time_label_tells_frames_apart_at_1500_rpm():
    from mechsolve import api
    from mechsolve.report.animate import solve_frames

    fr = solve_frames(api.load(SC))  # 1 deg a frame: 1/9000 s at 1500 rpm
    assert fr.t[1] - fr.t[0] == pytest.approx(1 / 9000, rel=1e-9)
    times = [re.search(r"t = (\S+) s$", fr.label(i)).group(1) for i in range(len(fr))]
    assert len(set(times)) == len(times)  # no two frames read the same time
    for text, t in zip(times, fr.t):  # each the frame's time, to its last digit
        assert abs(float(text) - t) <= 0.5 * 10.0 ** -len(text.split(".")[1]) + 1e-15


def test_check_prints_the_start_in_the_files_length_unit():
    r = CliRunner().invoke(main, ["check", str(SC)])
    assert r.exit_code == 0, r.output
    assert "global coordinates [mm]:" in r.output
    # crank 50 mm along x; the piston on y = 10 mm, 200 mm from A
    c = re.search(r"\n\s+C: \((\S+), (\S+)\)", r.output)
    assert float(c.group(1)) == pytest.approx(50 + math.sqrt(200**2 - 10**2), rel=1e-5)
    assert float(c.group(2)) == pytest.approx(10.0, abs=1e-9)
    assert re.search(r"\n\s+A: \(50, 0\)", r.output)


LINEAR_MM = """
name: lin
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
  cylinder: {slider: [ground, piston], point: C, line: {through: [0, 0], angle: 0}}
assembly: [A.y > 0]
driver: {joint: cylinder, speed: 0.5 m/s, start: 240}
sweep: {range: 80, step: 10}
"""


def test_draw_at_a_linear_position_says_it_in_the_users_unit(tmp_path):
    f = tmp_path / "lin.yaml"
    f.write_text(LINEAR_MM)
    out = tmp_path / "l.dxf"
    r = draw(f, "-o", out, "--at", "200 mm")
    assert r.exit_code == 0, r.output
    assert "drawn at driver position 200 mm" in r.output
    # C beyond crank + rod (250 mm) cannot close: said at the user's 300 mm, not 0.3 m
    r = draw(f, "-o", out, "--at", "300 mm")
    assert r.exit_code != 0
    assert "--at '300 mm'" in r.output and "driver position 300 mm" in r.output
    assert "0.3 m" not in r.output
