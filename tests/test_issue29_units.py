"""Results in the file's units: a file written in mm and deg gets its CSV, summary and plots
in mm and deg (mm/s, deg/s, N*mm...), ``--units SI`` the SI output, a units map its own.

The conversions checked here are written out by hand (1 m = 1000 mm, 1 rad = 180/pi deg),
independently of mechsolve's unit table; the geometry from the files' own numbers.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from mechsolve import api
from mechsolve.cli.main import main

MECH = Path(__file__).resolve().parent.parent / "mechanisms"

# (SI unit, unit in a file of mm and deg) -> factor, written out by hand
BY_HAND = {
    ("s", "s"): 1.0,
    ("m", "mm"): 1000.0,
    ("m/s", "mm/s"): 1000.0,
    ("m/s^2", "mm/s^2"): 1000.0,
    ("deg", "deg"): 1.0,
    ("rad/s", "deg/s"): 180.0 / math.pi,
    ("rad/s^2", "deg/s^2"): 180.0 / math.pi,
    ("N", "N"): 1.0,
    ("N*m", "N*mm"): 1000.0,
    ("J", "J"): 1.0,
    ("W", "W"): 1.0,
    ("-", "-"): 1.0,
}
HEADER = re.compile(r"^(?P<name>.+?) \[(?P<unit>[^\]]+)\](?P<note>.*)$")


def _run(tmp_path: Path, file: str, *extra: str, name: str = "out") -> tuple[int, str, Path]:
    out = tmp_path / name
    r = CliRunner().invoke(main, ["run", str(MECH / file), "-o", str(out), "--no-plots", *extra])
    return r.exit_code, r.output, out / "results.csv"


def _table(path: Path) -> tuple[list[str], list[list[str]]]:
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def _split(header: str) -> tuple[str, str, str]:
    m = HEADER.match(header)
    assert m, f"column {header!r} names no unit"
    return m["name"], m["unit"], m["note"]


def _values(rows: list[list[str]], k: int) -> np.ndarray:
    return np.array([float(r[k]) if r[k] != "" else np.nan for r in rows])


@pytest.mark.parametrize("file", ["slider-crank.yaml", "fourbar.yaml"])
def test_a_mm_deg_file_writes_every_column_in_mm_and_deg(tmp_path, file):
    code, _, shown = _run(tmp_path, file, name="file")
    assert code == 0
    code, _, si = _run(tmp_path, file, "--units", "SI", name="si")
    assert code == 0
    h_file, rows_file = _table(shown)
    h_si, rows_si = _table(si)
    assert len(h_file) == len(h_si) and len(rows_file) == len(rows_si)
    seen = set()
    for k, (a, b) in enumerate(zip(h_file, h_si)):
        if a in ("step", "status", "solver.method"):
            assert a == b
            assert [r[k] for r in rows_file] == [r[k] for r in rows_si]
            continue
        name_a, unit_a, note_a = _split(a)
        name_b, unit_b, note_b = _split(b)
        assert (name_a, note_a) == (name_b, note_b)
        assert (unit_b, unit_a) in BY_HAND, f"{b} -> {a}: no conversion expected"
        seen.add(unit_a)
        x, y = _values(rows_file, k), _values(rows_si, k) * BY_HAND[(unit_b, unit_a)]
        assert np.array_equal(np.isnan(x), np.isnan(y)), a
        ok = ~np.isnan(x)
        # both printed with 12 significant digits: up to 5e-12 apart each
        assert np.allclose(x[ok], y[ok], rtol=1e-11, atol=0), a
    # the file's units are there, not SI
    assert {"mm", "mm/s", "mm/s^2", "deg", "deg/s", "deg/s^2"} <= seen
    assert "m" not in seen and "rad/s" not in seen
    if file == "slider-crank.yaml":
        assert "N*mm" in seen


def test_mm_columns_are_the_file_geometry(tmp_path):
    """The crank pin A of the slider-crank (crank 50 mm) runs -50 .. 50 mm in its CSV; the
    stroke of its piston is the offset slider-crank's closed form."""
    code, _, path = _run(tmp_path, "slider-crank.yaml")
    assert code == 0
    h, rows = _table(path)
    ax = _values(rows, h.index("A.x [mm]"))
    assert np.nanmax(ax) == pytest.approx(50.0, rel=1e-12)
    assert np.nanmin(ax) == pytest.approx(-50.0, rel=1e-12)
    w = _values(rows, h.index("crank.omega [deg/s]"))
    assert np.allclose(w, 1500 * 360 / 60, rtol=1e-12)  # 1500 rpm in deg/s


def test_the_summary_is_in_the_file_units(tmp_path):
    code, out, _ = _run(tmp_path, "slider-crank.yaml")
    assert code == 0
    assert "A: x -50 .. 50 mm, y -50 .. 50 mm" in out
    # the stroke of an offset slider-crank: sqrt((l+r)^2 - e^2) - sqrt((l-r)^2 - e^2)
    r, ln, e = 50.0, 200.0, 10.0
    stroke = math.sqrt((ln + r) ** 2 - e**2) - math.sqrt((ln - r) ** 2 - e**2)
    m = re.search(r"\(stroke ([0-9.]+) mm\)", out)
    assert m and float(m.group(1)) == pytest.approx(stroke, abs=0.5e-3)
    assert re.search(r"driving torque .* N·mm", out)
    assert " m," not in out and "m/s^2" not in out


def test_units_si_is_the_si_table(tmp_path):
    """``--units SI`` writes what the Python API writes (SI, unconverted) byte for byte;
    a file without ``units:`` writes it by default."""
    code, _, si = _run(tmp_path, "slider-crank.yaml", "--units", "SI")
    assert code == 0
    ref = api.run(MECH / "slider-crank.yaml").to_csv(tmp_path / "api.csv")
    assert si.read_bytes() == ref.read_bytes()
    h, rows = _table(si)
    assert "A.x [m]" in h and "crank.omega [rad/s]" in h and "input.torque [N*m]" in h
    assert np.nanmax(_values(rows, h.index("A.x [m]"))) == pytest.approx(0.05, rel=1e-12)
    # a file without units: the same with or without --units SI
    src = MECH / "slider-crank.yaml"
    bare = tmp_path / "bare.yaml"
    text = src.read_text().replace("units: {length: mm, angle: deg}", "")
    text = re.sub(r"\[(-?\d+), (-?\d+)\]", lambda m: f"[{m[1]} mm, {m[2]} mm]", text)
    bare.write_text(text)
    assert api.load(bare).output_units().is_si
    a = CliRunner().invoke(main, ["run", str(bare), "-o", str(tmp_path / "a"), "--no-plots"])
    b = CliRunner().invoke(
        main, ["run", str(bare), "-o", str(tmp_path / "b"), "--no-plots", "--units", "SI"]
    )
    assert a.exit_code == 0 and b.exit_code == 0, a.output + b.output
    assert (tmp_path / "a/results.csv").read_bytes() == (tmp_path / "b/results.csv").read_bytes()


def test_a_units_map(tmp_path):
    code, out, path = _run(
        tmp_path, "slider-crank.yaml", "--units", "length=cm, force=kN, torque=kN*m"
    )
    assert code == 0, out
    h, rows = _table(path)
    _, _, si = _run(tmp_path, "slider-crank.yaml", "--units", "SI", name="si")
    hs, rs = _table(si)
    x = _values(rows, h.index("A.x [cm]"))
    assert np.allclose(x, _values(rs, hs.index("A.x [m]")) * 100, rtol=1e-11)
    t = _values(rows, h.index("input.torque [kN*m]"))
    assert np.allclose(t, _values(rs, hs.index("input.torque [N*m]")) / 1000, rtol=1e-11)
    assert "crank.omega [deg/s]" in h  # the file's angle unit stays
    f = _values(rows, h.index("O(ground->crank).F [kN]"))
    assert np.allclose(f, _values(rs, hs.index("O(ground->crank).F [N]")) / 1000, rtol=1e-11)


@pytest.mark.parametrize(
    "units, words",
    [
        ("length=kg", "not a unit of length"),
        ("speed=mm/s", "unknown key 'speed'"),
        ("length", "KEY=UNIT"),
        ("length=furlong", "unknown unit"),
        ("length=mm,length=cm", "given twice"),
    ],
)
def test_a_bad_units_map_is_bad_input(tmp_path, units, words):
    code, out, _ = _run(tmp_path, "fourbar.yaml", "--units", units)
    assert code == 2
    assert "--units" in out and words in out
    assert "Traceback" not in out


@pytest.mark.slow  # seconds on the 2-core machine: plots or a study
def test_plots_name_the_file_units(tmp_path):
    out = tmp_path / "svg"
    r = CliRunner().invoke(
        main, ["run", str(MECH / "slider-crank.yaml"), "-o", str(out), "--format", "svg"]
    )
    assert r.exit_code == 0, r.output
    point = (out / "point_C.svg").read_text(encoding="utf-8")
    assert "C.ax [mm/s²]" in point and "C.vx [mm/s]" in point
    torque = (out / "torque.svg").read_text(encoding="utf-8")
    assert "[N·mm]" in torque and "N*m" not in torque
    links = (out / "links.svg").read_text(encoding="utf-8")
    assert "[°/s²]" in links and "[°]" in links


def _sweep(tmp_path: Path, name: str, *extra: str) -> tuple[list[str], list[list[str]]]:
    study = Path(__file__).resolve().parent / "data" / "study_fourbar.yaml"
    out = tmp_path / name
    r = CliRunner().invoke(
        main,
        ["sweep", str(study), "-o", str(out), "--no-plots", "-j", "1", "--figure",
         "range(B.y)", "-q", *extra],
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    return _table(out / "study.csv")


@pytest.mark.slow  # seconds on the 2-core machine: plots or a study
def test_sweep_writes_the_file_units(tmp_path):
    """The study of a mm file: its figures in mm and N*mm, equal to the SI table
    converted; the parameters and the requirements' values keep their own units; the
    designs' CSVs (--keep-results) are in mm too."""
    h, rows = _sweep(tmp_path, "file", "--keep-results")
    hs, rs = _sweep(tmp_path, "si", "--units", "SI")
    assert len(h) == len(hs)
    for k, (a, b) in enumerate(zip(h, hs)):
        if a == "status":
            continue
        name_a, unit_a, _ = _split(a)
        name_b, unit_b, _ = _split(b)
        assert name_a == name_b
        assert (unit_b, unit_a) in BY_HAND or unit_a == unit_b == "mm", (a, b)
        if unit_a == unit_b == "mm":  # a parameter, in its own unit
            assert [r[k] for r in rows] == [r[k] for r in rs]
            continue
        f = BY_HAND.get((unit_b, unit_a), 1.0)
        for r, s in zip(rows, rs):
            if r[k] in ("true", "false", "") or unit_a == "-":
                assert r[k] == s[k]
            else:  # 10 significant digits each
                assert float(r[k]) == pytest.approx(float(s[k]) * f, rel=1e-9)
    assert "range(B.y) [mm]" in h and "max(abs(input.torque)) (samples) [N*mm]" in h
    assert "req.swing [deg]" in h  # the requirement's own unit
    head = (tmp_path / "file" / "designs" / "design-00000.csv").read_text().splitlines()[0]
    assert "B.y [mm]" in head and "rocker.omega [deg/s]" in head


# --- synth writes the problem's units -------------------------------------------------


def _numbers(text: str) -> list[str]:
    """The numbers of a written file's geometry (its ground and links lines)."""
    body = [
        ln for ln in text.splitlines() if ln.startswith("  ") and not ln.lstrip().startswith("-")
    ]
    return re.findall(r"(?<![\w.])-?\d+\.?\d*(?:e-?\d+)?", "\n".join(body))


def test_synth_writes_a_mm_problem_in_mm_with_six_digits(tmp_path):
    """The slider-crank problem (stroke 100 mm, K = 1.4, offset 20 mm, in mm), with
    --digits 6: the file is in mm, its numbers have at most 6 significant digits, and
    solved by mechsolve it gives the stroke (to the rounding of its lengths) and the
    offset slider-crank's closed form of its own written lengths."""
    from mechsolve.cli.commands.synth import synth

    out = tmp_path / "sc.yaml"
    r = CliRunner().invoke(
        synth, [str(MECH / "synth" / "slider-crank.yaml"), "-o", str(out), "--digits", "6"]
    )
    assert r.exit_code == 0, r.output
    text = out.read_text()
    assert "units: {length: mm, angle: deg}" in text
    nums = _numbers(text)
    assert nums and all(len(re.sub(r"[-.]|e-?\d+", "", n).lstrip("0")) <= 6 for n in nums)
    crank = float(re.search(r"crank: .*A: \[([\d.]+), 0\]", text)[1])
    rod = float(re.search(r"C: \[([\d.]+), 0\]", text)[1])
    e = 20.0
    assert 40 < crank < 60 and 60 < rod < 100  # mm, not m
    stroke = math.sqrt((crank + rod) ** 2 - e**2) - math.sqrt((rod - crank) ** 2 - e**2)
    res = api.run(out)
    (lp,) = res.limit_positions()
    assert lp.swing * 1000 == pytest.approx(stroke, abs=1e-9)
    # 6 digits of lengths near 50 and 80 mm: each within 5e-5 mm
    assert stroke == pytest.approx(100.0, abs=1e-3)
    assert lp.time_ratio == pytest.approx(1.4, abs=1e-4)
    # printed to the micrometre, in mm
    assert "(stroke 100.000 mm)" in r.output and "crank 47.245 mm" in r.output


def test_synth_digits_17_keeps_every_digit(tmp_path):
    from mechsolve.cli.commands.synth import synth

    out = tmp_path / "sc.yaml"
    r = CliRunner().invoke(
        synth, [str(MECH / "synth" / "slider-crank.yaml"), "-o", str(out), "--digits", "17"]
    )
    assert r.exit_code == 0, r.output
    assert "units: {length: mm, angle: deg}" in out.read_text()
    (lp,) = api.run(out).limit_positions()
    assert lp.swing == pytest.approx(0.1, rel=1e-12)
    assert lp.time_ratio == pytest.approx(1.4, rel=1e-9)


# --- Unicode units in figures and printed summaries ----------------------------------


@pytest.mark.parametrize(
    "ascii_, shown",
    [
        ("torque [N*m]", "torque [N·m]"),
        ("J [kg*m^2], J' [kg*m^2/rad]", "J [kg·m²], J' [kg·m²/rad]"),
        ("slope omega_max^2 / 2", "slope ωₘₐₓ² / 2"),
        ("dE_max / (omega_m^2 delta) = 5 kg*m^2", "ΔEₘₐₓ / (ωₘ² delta) = 5 kg·m²"),
        ("900 dE_max / (pi^2 n^2 delta)", "900 ΔEₘₐₓ / (π² n² delta)"),
        ("W(phi) against J(phi)", "W(φ) against J(φ)"),
        ("angle [deg], rate [deg/s^2]", "angle [°], rate [°/s²]"),
        ("max 12 kN*m, a 3 rad/s^2", "max 12 kN·m, a 3 rad/s²"),
        # names and words that are not units stay as written
        ("links.crank.points.A[0] [mm]", "links.crank.points.A[0] [mm]"),
        ("crank/ground.angle, a*b, omega [rad/s]", "crank/ground.angle, a*b, omega [rad/s]"),
        ("[-]", "[-]"),
    ],
)
def test_pretty_text(ascii_, shown):
    from mechsolve.base.units import pretty_text

    assert pretty_text(ascii_) == shown


@pytest.mark.slow  # seconds on the 2-core machine: plots or a study
def test_every_saved_figure_writes_report_units(tmp_path):
    """save_figure, which every plot of mechsolve goes through, writes its texts with
    Unicode units: an SVG keeps its text as text, so it can be read back."""
    from mechsolve.writers.fonts import pyplot
    from mechsolve.writers.plots import save_figure

    plt = pyplot()
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label="slope omega_max^2 / 2")
    ax.set_ylabel("reduced moment of inertia J [kg*m^2]")
    ax.set_xlabel("torque [N*m]")
    ax.set_title("J_F = 3 kg*m^2")
    ax.legend()
    path = save_figure(fig, tmp_path / "f.svg", 100) or tmp_path / "f.svg"
    plt.close(fig)
    svg = path.read_text(encoding="utf-8")
    for want in ("[kg·m²]", "[N·m]", "ωₘₐₓ²", "J_F = 3 kg·m²"):
        assert want in svg, want
    assert "N*m" not in svg and "^2" not in svg


@pytest.mark.slow  # seconds on the 2-core machine: plots or a study
def test_printed_summaries_write_report_units(tmp_path):
    """The flywheel's printed summary: ΔEₘₐₓ, ωₘ², kg·m², N·m instead of ASCII."""
    r = CliRunner().invoke(
        main, ["flywheel", str(MECH / "shaper.yaml"), "-o", str(tmp_path / "fw")]
    )
    assert r.exit_code == 0, r.output
    assert "ΔEₘₐₓ = " in r.output and "kg·m²" in r.output and "N·m" in r.output
    assert "kg*m^2" not in r.output and "N*m" not in r.output and "omega_m^2" not in r.output


def test_instants_are_in_the_file_units(tmp_path):
    """``run --at``: the instants table and instants.csv of a mm file in mm (A at 30 deg
    of a 50 mm crank: 50 cos 30 deg, 50 sin 30 deg)."""
    out = tmp_path / "i"
    r = CliRunner().invoke(
        main, ["run", str(MECH / "slider-crank.yaml"), "--at", "theta=30 deg", "-o", str(out)]
    )
    assert r.exit_code == 0, r.output
    h, rows = _table(out / "instants.csv")
    x = float(rows[0][h.index("A.x [mm]")])
    y = float(rows[0][h.index("A.y [mm]")])
    assert (x, y) == (pytest.approx(50 * math.cos(math.pi / 6)), pytest.approx(25.0))
    assert re.search(r"A\.x \[mm\] +43\.3013", r.output)
