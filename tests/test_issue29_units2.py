"""Issue 29 item 2 for the commands beyond run and sweep: a file written in mm and deg gets
the tables and summaries of ``polygons``, ``shaking``, ``compare``, ``report``,
``simulate`` and ``flywheel`` in mm, deg, N*mm..., and ``--units SI`` the SI output.

Each test runs the command twice on the same mm/deg file, once as is and once with
``--units SI``, and checks every number of the output against the SI one multiplied by a
factor written out here by hand (1 mm = 1e-3 m, 1 deg = pi/180 rad, 1 N*mm = 1e-3 N*m),
not by mechsolve's unit table.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

MECH = Path(__file__).resolve().parent.parent / "mechanisms"

MM = 1e-3  # m
DEG = math.pi / 180  # rad
NMM = 1e-3  # N*m
# SI unit -> (the unit a mm/deg file shows, shown value per SI value), written out by hand
BY_HAND = {
    "m": ("mm", 1 / MM),
    "m/s": ("mm/s", 1 / MM),
    "m/s^2": ("mm/s^2", 1 / MM),
    "rad/s": ("deg/s", 1 / DEG),
    "rad/s^2": ("deg/s^2", 1 / DEG),
    "N*m": ("N*mm", 1 / NMM),
    "N": ("N", 1.0),
    "deg": ("deg", 1.0),
    "s": ("s", 1.0),
    "J": ("J", 1.0),
    "W": ("W", 1.0),
    "-": ("-", 1.0),
    "kg*m": ("kg*mm", 1 / MM),
    "kg*m^2": ("kg*m^2", 1.0),  # moments of inertia stay kg*m^2 (no key of units: names them)
}
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?"


def _invoke(*args: str) -> str:
    r = CliRunner().invoke(main, list(args))
    assert r.exit_code == 0, r.output
    return r.output


def _close(shown: float, si: float, factor: float, digits: int) -> None:
    """``shown`` is ``si * factor`` to the ``digits`` significant digits both are printed
    with (each rounded once: half a unit of the last digit of each)."""
    want = si * factor
    tol = 0.5 * 10 ** (1 - digits) * (abs(want) + abs(shown)) * 1.01 + 1e-300
    assert abs(shown - want) <= tol, (shown, si, factor)


TOKEN = re.compile(rf"(?<![\w.^])({NUMBER})(?:[ ]?([A-Za-z°][\w*/^°·²³]*))?")


def _plain(unit: str) -> str:
    """A printed unit in the ASCII form of the CSV headers (N·m -> N*m, s² -> s^2)."""
    return unit.replace("·", "*").replace("²", "^2").replace("³", "^3").replace("°", "deg")


PAIR = re.compile(rf"(?<![\w.^])({NUMBER})( / | \.\. | to )({NUMBER}) ([A-Za-z°][\w*/^°·²³]*)")


def _shared(line: str) -> str:
    """``'0.7 / 1.3 m/s'`` as ``'0.7 m/s / 1.3 m/s'``: a pair's unit named after each
    (also ``a .. b unit`` and ``a to b unit``)."""
    return PAIR.sub(r"\1 \4\2\3 \4", line)


def same_but_units(mine: list[str], si: list[str], digits: int = 6) -> int:
    """Line by line, every number followed by a unit of :data:`BY_HAND` in ``si`` is the
    number of ``mine`` at the same place in the shown unit; every other number and word
    is the same. Returns how many numbers were converted."""
    assert len(mine) == len(si), (mine, si)
    converted = 0
    for a, b in zip(mine, si):
        a, b = _shared(a), _shared(b)
        ta, tb = TOKEN.findall(a), TOKEN.findall(b)
        assert len(ta) == len(tb), (a, b)
        for (va, ua), (vb, ub) in zip(ta, tb):
            if _plain(ub) in BY_HAND and BY_HAND[_plain(ub)][1] != 1.0:
                shown, factor = BY_HAND[_plain(ub)]
                assert _plain(ua) == shown, (a, b)
                _close(float(va), float(vb), factor, digits)
                converted += 1
            else:
                assert (va, _plain(ua)) == (vb, _plain(ub)), (a, b)
        # the words around are the same (a table's columns may be wider)
        assert TOKEN.sub("#", a).split() == TOKEN.sub("#", b).split()
    return converted


HEADER = re.compile(r"^(?P<name>.+?) \[(?P<unit>[^\]]+)\](?P<note>.*)$")


def same_csv_but_units(mine: Path, si: Path) -> int:
    """Column by column, ``mine`` is the SI table converted by the factors of
    :data:`BY_HAND` (to the 12 digits written); columns without a unit are the same.
    Returns how many columns were converted."""
    with open(mine, newline="", encoding="utf-8") as fh:
        ra = list(csv.reader(fh))
    with open(si, newline="", encoding="utf-8") as fh:
        rb = list(csv.reader(fh))
    assert len(ra) == len(rb) and len(ra) > 1
    converted = 0
    for j, (ha, hb) in enumerate(zip(ra[0], rb[0])):
        mb = HEADER.match(hb)
        if mb is None:  # step, status, solver.method: no unit
            assert ha == hb and [r[j] for r in ra] == [r[j] for r in rb]
            continue
        ma = HEADER.match(ha)
        assert ma, f"column {ha!r} names no unit"
        assert (ma["name"], ma["note"]) == (mb["name"], mb["note"])
        shown, factor = BY_HAND[mb["unit"]]
        assert ma["unit"] == shown, (ha, hb)
        for x, y in zip((r[j] for r in ra[1:]), (r[j] for r in rb[1:])):
            assert (x == "") == (y == "")
            if y:
                _close(float(x), float(y), factor, 12)
        converted += factor != 1.0
    return converted


# ---------------------------------------------------------------- polygons


def _polygons(tmp_path: Path, *extra: str) -> list[str]:
    out = tmp_path / ("si" if extra else "file")
    _invoke("polygons", str(MECH / "shaper.yaml"), "--at", "3", "-o", str(out), "-q", *extra)
    return (out / "polygons.txt").read_text(encoding="utf-8").splitlines()


def test_polygons_summary_in_the_files_units(tmp_path):
    mine, si = _polygons(tmp_path), _polygons(tmp_path, "--units", "SI")
    assert len(mine) == len(si)
    checked = 0
    unit_si = unit_mine = None
    for a, b in zip(mine, si):
        # a vector table's header names its unit: [mm/s] in the file's, [m/s] in SI
        hb = re.fullmatch(r"\s+\[mm\]\s+\[(\S+)\]", b)
        if hb:
            unit_si = hb[1]
            unit_mine = re.fullmatch(r"\s+\[mm\]\s+\[(\S+)\]", a)[1]
            assert unit_mine == BY_HAND[unit_si][0]
            continue
        row = re.fullmatch(rf"\s+(\S+)\s+(\S+ -> \S+)\s+({NUMBER})\s+({NUMBER})\s.*", b)
        if row:
            ra = re.fullmatch(rf"\s+(\S+)\s+(\S+ -> \S+)\s+({NUMBER})\s+({NUMBER})\s.*", a)
            assert ra[1] == row[1] and ra[3] == row[3]  # the same vector, drawn as long
            _close(float(ra[4]), float(row[4]), BY_HAND[unit_si][1], 4)
            checked += 1
            continue
        ang = re.fullmatch(rf"\s+([ωα]\d+) .* = ({NUMBER}) / ({NUMBER}) m = ({NUMBER}) (\S+).*", b)
        if ang:
            aa = re.fullmatch(
                rf"\s+([ωα]\d+) .* = ({NUMBER}) / ({NUMBER}) mm = ({NUMBER}) (\S+).*", a
            )
            assert aa, a
            lin = "m/s" if ang[1].startswith("ω") else "m/s^2"
            _close(float(aa[2]), float(ang[2]), BY_HAND[lin][1], 4)
            _close(float(aa[3]), float(ang[3]), 1 / MM, 4)
            assert aa[5] == BY_HAND[ang[5]][0]
            _close(float(aa[4]), float(ang[4]), BY_HAND[ang[5]][1], 4)
            checked += 1
            continue
        sc = re.fullmatch(
            rf"\s+scales: μl = ({NUMBER}) m/mm, μv = ({NUMBER}) \(m/s\)/mm, "
            rf"μa = ({NUMBER}) \(m/s\^2\)/mm",
            b,
        )
        if sc:
            sa = re.fullmatch(
                rf"\s+scales: μl = ({NUMBER}) mm/mm, μv = ({NUMBER}) \(mm/s\)/mm, "
                rf"μa = ({NUMBER}) \(mm/s\^2\)/mm",
                a,
            )
            assert sa, a
            for k in (1, 2, 3):
                _close(float(sa[k]), float(sc[k]), 1 / MM, 6)
            checked += 1
            continue
        if b.startswith("check against"):
            na = re.findall(rf"({NUMBER}) (\S+?)[ ,)]", a + " ")
            nb = re.findall(rf"({NUMBER}) (\S+?)[ ,)]", b + " ")
            assert len(na) == len(nb)
            for (va, ua), (vb, ub) in zip(na, nb):
                assert ua == BY_HAND[ub][0] if ub in BY_HAND else ua == ub
                f = BY_HAND[ub][1] if ub in BY_HAND else 1.0
                _close(float(va), float(vb), f, 2)
            checked += 1
            continue
        assert a == b  # the rest (names, equations) does not depend on the units
    assert checked >= 20


# ---------------------------------------------------------------- shaking


@pytest.mark.parametrize("file", ["fourbar.yaml", "slider-crank.yaml"])
def test_shaking_table_and_summary_in_the_files_units(tmp_path, file):
    """The moment in N*mm, the counterweights' m*r in kg*mm and radius in mm; forces stay
    N (the file has no force unit); before and after balancing."""
    outs = []
    for name, extra in (("file", ()), ("si", ("--units", "SI"))):
        out = tmp_path / name
        text = _invoke("shaking", str(MECH / file), "--balance", "--no-plots", "-o", str(out),
                       *extra)  # fmt: skip
        outs.append((out, [ln for ln in text.splitlines() if "wrote" not in ln]))
    (a, ta), (b, tb) = outs
    assert same_but_units(ta, tb) >= 8  # four moments, two before/after pairs, m*r, r
    for csv_name in ("shaking.csv", "shaking-balanced.csv"):
        assert same_csv_but_units(a / csv_name, b / csv_name) == 1  # shaking.M


# ---------------------------------------------------------------- compare


def test_compare_table_and_csv_in_the_first_files_units(tmp_path):
    """Two shaper schemes in mm: velocities in mm/s, the crank speed in deg/s, torques in
    N*mm; in the text and in compare.csv."""
    files = [str(MECH / "shaper.yaml"), str(MECH / "shaper-scheme3.yaml")]
    texts = []
    for name, extra in (("file", ()), ("si", ("--units", "SI"))):
        text = _invoke("compare", *files, "--no-plots", "-o", str(tmp_path / name), *extra)
        texts.append([ln for ln in text.splitlines() if "wrote" not in ln])
    assert same_but_units(*texts, digits=4) >= 10
    assert any("N*mm" in _plain(ln) for ln in texts[0])
    n = same_csv_but_units(tmp_path / "file" / "compare.csv", tmp_path / "si" / "compare.csv")
    assert n >= 10  # crank speed, stroke, velocities, torques


# ---------------------------------------------------------------- report


def _decimals(text: str) -> int:
    mant = text.lower().split("e")[0]
    return len(mant.split(".")[1]) if "." in mant else 0


def _cell_close(shown: str, si: str, factor: float) -> None:
    """Two printed cells: ``shown`` is ``si * factor``, each rounded to its own decimals."""
    if "–" in (si, shown):  # not determined
        assert shown == si, (shown, si)
        return
    x, y = float(shown), float(si)
    if "e" in shown.lower() or "e" in si.lower():
        _close(x, y, factor, 4)
        return
    tol = 0.5 * 10.0 ** -_decimals(shown) + 0.5 * 10.0 ** -_decimals(si) * factor
    assert abs(x - y * factor) <= tol * 1.001, (shown, si, factor)


def _report_units(text: str) -> str:
    """The report writes N*m as 'N m' and m/s^2 as 'm/s²': back to the CSV's form."""
    return re.sub(r"\b(k?N) (m|mm)\b", r"\1*\2", text)


@pytest.fixture(scope="module")
def report_contents():
    from mechsolve.report import build

    file = MECH / "slider-crank.yaml"
    return build(file, frames=4), build(file, frames=4, units="SI")


def test_report_summary_and_figures_in_the_files_units(report_contents):
    mine, si = report_contents
    assert same_but_units(mine.summary_text.splitlines(), si.summary_text.splitlines(), 4) >= 10
    ta = [_report_units("  ".join(r)) for r in mine.figures.rows]
    tb = [_report_units("  ".join(r)) for r in si.figures.rows]
    assert same_but_units(ta, tb, 4) >= 5  # the limit positions, stroke, torques
    assert any("N*mm" in t for t in ta) and not any("N*m " in t for t in ta)


def test_report_position_tables_in_the_files_units(report_contents):
    mine, si = report_contents
    assert [t.caption for t in mine.tables] == [t.caption for t in si.tables]
    converted = 0
    for ta, tb in zip(mine.tables, si.tables):
        assert len(ta.rows) == len(tb.rows) and len(ta.header) == len(tb.header)
        for j, (ha, hb) in enumerate(zip(ta.header, tb.header)):
            if j == 0:  # the position number
                assert ha == hb
                continue
            pa, pb = (
                HEADER.match(_plain(_report_units(ha))),
                HEADER.match(_plain(_report_units(hb))),
            )
            assert pa and pb and pa["name"] == pb["name"], (ha, hb)
            shown, factor = BY_HAND[pb["unit"]]
            assert pa["unit"] == shown, (ha, hb)
            for ra, rb in zip(ta.rows, tb.rows):
                _cell_close(ra[j], rb[j], factor)
            converted += factor != 1.0
    assert converted >= 20


# ---------------------------------------------------------------- simulate


def test_simulate_table_and_summary_in_the_files_units(tmp_path):
    """The shaper's motor start-up: speeds in deg/s, torques in N*mm, lengths in mm."""
    texts = []
    for name, extra in (("file", ()), ("si", ("--units", "SI"))):
        out = str(tmp_path / name)
        text = _invoke("simulate", str(MECH / "shaper.yaml"), "--no-plots", "-o", out, *extra)
        texts.append([ln for ln in text.splitlines() if "wrote" not in ln])
    mine, si = texts
    # the motor's law is quoted as the file gives it (its slope is per rad/s)
    law = [k for k, ln in enumerate(si) if ln.startswith("  simulation:")]
    assert len(law) == 1 and mine[law[0]] == si[law[0]]
    del mine[law[0]], si[law[0]]
    assert same_but_units(mine, si, 5) >= 20
    n = same_csv_but_units(tmp_path / "file" / "simulation.csv", tmp_path / "si" / "simulation.csv")
    assert n >= 20


# ---------------------------------------------------------------- flywheel


def test_flywheel_summary_in_the_files_units(tmp_path):
    """The shaper's flywheel: the mean speed in deg/s and the motor torque in N*mm; the
    energy (J) and the inertias (kg*m^2) as before."""
    texts = []
    for name, extra in (("file", ()), ("si", ("--units", "SI"))):
        text = _invoke("flywheel", str(MECH / "shaper.yaml"), "-o", str(tmp_path / name), *extra)
        texts.append([ln for ln in text.splitlines() if "wrote" not in ln])
    assert same_but_units(*texts) == 2
    assert "°/s" in texts[0][0] and "N·mm" in texts[0][1]
