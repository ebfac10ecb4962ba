"""Issue 23, `mechsolve report` (and `animate`): an impossible --frames is refused before
any work; a default polygon position the mechanism cannot reach does not cost the report;
the PDF is A4 (or Letter) with every table complete; one value per figure."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import time
import unicodedata
from html import unescape
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from test_report import Page

import mechsolve
import mechsolve.api
from mechsolve.cli.commands.animate import animate
from mechsolve.cli.commands.report import report
from mechsolve.report.browser import find_browser

from conftest import MECH, ref

# A four-bar whose input link cannot turn fully: |A O4| exceeds coupler + rocker
# (60 + 59 mm) past 117.2 deg of the input (hand calculation below). Started at 95 deg
# and swept over 20 deg, it never leaves the range where it closes, but the report's
# default polygon position (position 2 of 12 per turn, 30 deg after the start) is outside.
DOUBLE_ROCKER = """\
name: double rocker
units: {length: mm, angle: deg}
ground:
  O2: [0, 0]
  O4: [87.5, 0]
links:
  crank:
    points: {O2: [0, 0], A: [50, 0]}
  coupler:
    points: {A: [0, 0], B: [60, 0]}
  rocker:
    points: {O4: [0, 0], B: [59, 0]}
joints:
  O2: [ground, crank]
  A: [crank, coupler]
  B: [coupler, rocker]
  O4: [ground, rocker]
assembly:
  - B left of A -> O4
driver: {joint: O2, speed: 1 rad/s, start: 95 deg}
sweep: {range: 20 deg, step: 2 deg}
"""


def _no_solving(monkeypatch) -> list[str]:
    """Make loading a mechanism fail the test: the options must be refused before."""
    called: list[str] = []

    def refuse(*args, **kwargs):
        called.append("load")
        raise AssertionError("the file was loaded before the options were checked")

    monkeypatch.setattr(mechsolve.api, "load", refuse)
    return called


@pytest.mark.parametrize("frames", ["10000000", "20001"])
def test_report_refuses_too_many_frames_before_any_work(frames, tmp_path, monkeypatch):
    """`report --frames 1e7` was refused only after the whole report was solved (8 to
    14 s); it is refused first, with animate's bound and message."""
    called = _no_solving(monkeypatch)
    out = tmp_path / "r.html"
    t0 = time.perf_counter()
    r = CliRunner().invoke(report, [str(MECH / "crane.yaml"), "-o", str(out), "--frames", frames])
    took = time.perf_counter() - t0
    a = CliRunner().invoke(
        animate, [str(MECH / "crane.yaml"), "-o", str(tmp_path / "a.gif"), "--frames", frames]
    )
    assert called == []
    assert r.exit_code == a.exit_code == 2, (r.output, a.output)
    assert r.output == a.output == f"error: --frames {frames}: at most 20000 frames\n"
    assert took < 2.0
    assert not out.exists()


def test_write_report_refuses_too_many_frames_before_any_work(tmp_path, monkeypatch):
    from mechsolve.base.errors import InputError
    from mechsolve.report import write_report

    _no_solving(monkeypatch)
    with pytest.raises(InputError, match="at most 20000 frames"):
        write_report(MECH / "crane.yaml", out=tmp_path / "r.html", frames=10**7)


def _section(html: str, ident: str) -> str:
    m = re.search(rf'<section id="{ident}">(.*?)</section>', html, re.S)
    assert m, f"no section {ident}"
    return m.group(1)


def test_default_polygon_position_that_cannot_close(tmp_path):
    """The report was not written at all (exit 3) when position 2, the polygons' default,
    lies where the mechanism cannot close: it is written, the polygons section says which
    position and which loop, and the exit status is that of the rest (0)."""
    # hand calculation: at 125 deg of the input, A is farther from O4 than the coupler
    # and the rocker can reach together
    a = (50 * math.cos(math.radians(125)), 50 * math.sin(math.radians(125)))
    assert math.hypot(a[0] - 87.5, a[1]) > 60 + 59
    src = tmp_path / "rocker.yaml"
    src.write_text(DOUBLE_ROCKER)
    out = tmp_path / "rocker.html"
    r = CliRunner().invoke(report, [str(src), "-o", str(out), "--frames", "6"])
    assert r.exit_code == 0, r.output
    html = out.read_text(encoding="utf-8")
    text = _section(html, "polygons")
    assert "position 2 of 12 per turn" in text and "driver angle 125°" in text
    assert "cannot close" in text and "loop B" in text
    assert "--polygons-at" in text  # what to do about it
    assert "no polygons" in r.output.lower()  # the terminal says it too
    # the rest of the report is all there
    page = Page(html)
    assert len(page.table("Positions of the points")["rows"]) == 11


def test_requested_polygon_position_that_cannot_close(tmp_path):
    """A position asked for with --polygons-at that cannot close: the report is still
    written, with the reason, and the command exits 0 with a warning (something asked for
    is missing; issue 24: one rule, no 1)."""
    src = tmp_path / "rocker.yaml"
    src.write_text(DOUBLE_ROCKER)
    out = tmp_path / "rocker.html"
    r = CliRunner().invoke(
        report, [str(src), "-o", str(out), "--frames", "6", "--polygons-at", "130 deg"]
    )
    assert r.exit_code == 0 and "warning: the report is incomplete" in r.output, r.output
    text = _section(out.read_text(encoding="utf-8"), "polygons")
    assert "driver angle 130°" in text and "loop B" in text
    # a position it reaches is drawn
    r = CliRunner().invoke(
        report, [str(src), "-o", str(out), "--frames", "6", "--polygons-at", "100 deg"]
    )
    assert r.exit_code == 0, r.output
    text = _section(out.read_text(encoding="utf-8"), "polygons")
    assert "<img" in text and "cannot close" not in text


# -- the PDF --------------------------------------------------------------------------
A4 = (595.276, 841.89)  # 210 x 297 mm in points
LETTER = (612.0, 792.0)


def pdf_pages(path: Path) -> list[tuple[float, float, str]]:
    """(width, height, text) of each page, read back with pypdf (the test extra), else
    with poppler's pdfinfo/pdftotext; skipped when neither is there."""
    try:
        from pypdf import PdfReader
    except ImportError:
        PdfReader = None
    if PdfReader is not None:
        pages = []
        for p in PdfReader(str(path)).pages:
            box = p.mediabox
            pages.append((float(box.width), float(box.height), p.extract_text() or ""))
        return pages
    if not (shutil.which("pdftotext") and shutil.which("pdfinfo")):
        pytest.skip("no PDF reader (pip install pypdf, or poppler-utils)")
    info = subprocess.run(
        ["pdfinfo", "-f", "1", "-l", "9999", str(path)], capture_output=True, text=True
    ).stdout
    sizes = [
        (float(w), float(h)) for w, h in re.findall(r"Page\s+\d+ size:\s+([\d.]+) x ([\d.]+)", info)
    ]
    pages = []
    for k, (w, h) in enumerate(sizes, start=1):
        text = subprocess.run(
            ["pdftotext", "-f", str(k), "-l", str(k), str(path), "-"],
            capture_output=True,
            text=True,
        ).stdout
        pages.append((w, h, text))
    return pages


def _pre_text(html: str) -> str:
    """The text of the first ``pre`` of ``html`` (its lines may be spans, each with its
    indent as a style)."""
    body = re.search(r"<pre[^>]*>(.*?)</pre>", html, re.S).group(1)
    return unescape(re.sub(r"<[^>]+>", "", body))


def squash(text: str) -> str:
    """The text without white space, its ligatures (ﬁ) as letters."""
    return re.sub(r"\s+", "", unicodedata.normalize("NFKC", text))


needs_browser = pytest.mark.skipif(
    find_browser() is None, reason="no Chromium-based browser (apt-get install -y chromium)"
)


@pytest.fixture(scope="module")
def shaper_pdf(tmp_path_factory):
    d = tmp_path_factory.mktemp("pdf")
    out = d / "shaper.html"
    r = CliRunner().invoke(
        report, [str(MECH / "shaper.yaml"), "-o", str(out), "--frames", "6", "--pdf", "-q"]
    )
    assert r.exit_code == 0, r.output
    return out, out.with_suffix(".pdf")


@needs_browser
def test_pdf_is_a4_and_nothing_is_cut(shaper_pdf):
    """The shaper's PDF was US Letter, its reactions table stopped at the first joints (C,
    D and O4 missing), the summary's long lines were cut and a scrollbar printed. Read
    back: A4 pages; every joint's reaction columns with the values of the last position;
    the summary and the polygons' text whole."""
    html_path, pdf_path = shaper_pdf
    pages = pdf_pages(pdf_path)
    assert len(pages) >= 5
    for w, h, _ in pages:
        assert (w, h) == pytest.approx(A4, abs=1.0)
    text = "\n".join(t for _, _, t in pages)
    flat = squash(text)
    page = Page(html_path.read_text(encoding="utf-8"))
    forces = page.table("Driving effort and joint reactions")
    mech = mechsolve.load(MECH / "shaper.yaml")
    assert len(mech.joints) == 7
    last = forces["rows"][-1]
    for j in mech.joints:
        label = f"{j.name}({j.links[0]}->{j.links[1]})"
        assert label in flat, f"joint {j.name} is missing from the PDF"
        cols = [k for k, h in enumerate(forces["header"]) if h.startswith(label + ".")]
        assert cols, label
        for k in cols:  # its values at the last position are printed
            assert re.search(rf"(?<![\d.]){re.escape(last[k])}(?![\d])", text), (
                f"{forces['header'][k]} = {last[k]} at the last position is not in the PDF"
            )
    # every table of positions reaches the last position, 73
    assert len(forces["rows"]) == 73
    # every table (as on the screen) is printed whole: each cell of its last row is there
    tables = [t for t in page.tables if "(part " not in t["caption"]]
    wide = {
        t["caption"].split(" (part 1 of")[0] for t in page.tables if "(part 1 of" in t["caption"]
    }
    tables += [page.table(c) for c in sorted(wide)]  # shown in parts on screen too
    assert len(tables) >= 10
    for t in tables:
        for cell in t["rows"][-1]:
            assert squash(cell) in flat, f"{t['caption']}: {cell!r} is not in the PDF"
    # the summary and the polygons' text are not cut at the right margin
    html = html_path.read_text(encoding="utf-8")
    for section in ("summary", "polygons"):
        pre = squash(_pre_text(_section(html, section)))
        assert pre and pre in flat, f"the {section} text is cut in the PDF"


def image_boxes(path: Path) -> list[tuple[int, float, float, float, float]]:
    """(page, x0, y0, x1, y1) in points of every image drawn in the PDF, from the page's
    content stream (the transformation in force at each image's ``Do``). An image split
    over two pages is drawn on both, partly outside each."""
    pypdf = pytest.importorskip("pypdf")
    out = []
    for n, page in enumerate(pypdf.PdfReader(str(path)).pages, start=1):
        res = page.get("/Resources")
        xobj = res.get_object().get("/XObject", {}) if res is not None else {}
        xobj = xobj.get_object() if hasattr(xobj, "get_object") else xobj
        ctm, stack = [1.0, 0.0, 0.0, 1.0, 0.0, 0.0], []
        for operands, op in page.get_contents().operations:
            if op == b"q":
                stack.append(list(ctm))
            elif op == b"Q":
                ctm = stack.pop()
            elif op == b"cm":
                a, b, c, d, e, f = (float(v) for v in operands)
                A, B, C, D, E, F = ctm
                ctm = [a * A + b * C, a * B + b * D, c * A + d * C, c * B + d * D,
                       e * A + f * C + E, e * B + f * D + F]  # fmt: skip
            elif op == b"Do" and xobj[operands[0]].get_object().get("/Subtype") == "/Image":
                A, B, C, D, E, F = ctm
                xs, ys = (E, E + A, E + C, E + A + C), (F, F + B, F + D, F + B + D)
                out.append((n, min(xs), min(ys), max(xs), max(ys)))
    return out


@needs_browser
def test_pdf_images_are_never_split(tmp_path):
    """The six-bar's acceleration polygon is taller than a page: it was printed split over
    two pages (its lower part on the next). Every image lies within one page."""
    out = tmp_path / "sixbar.html"
    r = CliRunner().invoke(
        report, [str(MECH / "sixbar.yaml"), "-o", str(out), "--frames", "6", "--pdf", "-q"]
    )
    assert r.exit_code == 0, r.output
    pdf = out.with_suffix(".pdf")
    boxes = image_boxes(pdf)
    assert len(boxes) >= out.read_text(encoding="utf-8").count("<img ")
    w, h = A4
    for page, x0, y0, x1, y1 in boxes:
        assert -0.5 <= x0 and x1 <= w + 0.5 and -0.5 <= y0 and y1 <= h + 0.5, (
            f"an image on page {page} runs off it: ({x0:.0f}, {y0:.0f}) to ({x1:.0f}, {y1:.0f})"
        )


@needs_browser
def test_pdf_on_letter_paper(tmp_path):
    out = tmp_path / "fourbar.html"
    r = CliRunner().invoke(
        report,
        [
            str(MECH / "fourbar.yaml"),
            "-o",
            str(out),
            "--frames",
            "6",
            "--pdf",
            "--paper",
            "letter",
            "-q",
        ],  # fmt: skip
    )
    assert r.exit_code == 0, r.output
    pages = pdf_pages(out.with_suffix(".pdf"))
    assert pages
    for w, h, _ in pages:
        assert (w, h) == pytest.approx(LETTER, abs=1.0)


# -- one value per figure ---------------------------------------------------------------
def _circle_meet(p, r1, q, r2):
    """The meeting point of circles (p, r1) and (q, r2) to the left of p -> q (arrays)."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    d = np.hypot(dx, dy)
    a = (r1**2 - r2**2 + d**2) / (2 * d)
    h = np.sqrt(r1**2 - a**2)
    ex, ey = dx / d, dy / d
    return p[0] + a * ex - h * ey, p[1] + a * ey + h * ex


def crane_tie_angle(theta):
    """The crane's tie angle O4 -> D (deg) at crank angles ``theta`` (rad), by hand from
    mechanisms/crane.yaml: B where the coupler (2.780 m from A) meets the jib (4.0 m from
    O3) left of O3 -> A; C on the jib 28.525 m from O3 at 25 deg from O3 -> B; D where the
    boom (3.625 m from C) meets the tie (25.15 m from O4) left of C -> O4."""
    o1, o4 = (2.86, 4.0), (5.6, 8.1)
    a = (o1[0] + 1.388 * np.cos(theta), o1[1] + 1.388 * np.sin(theta))
    zero = np.zeros_like(theta)
    b = _circle_meet((zero, zero), 4.0, a, 2.780)
    psi = np.arctan2(b[1], b[0]) + math.radians(25)
    c = (28.525 * np.cos(psi), 28.525 * np.sin(psi))
    d = _circle_meet(c, 3.625, (o4[0] + zero, o4[1] + zero), 25.15)
    return np.degrees(np.arctan2(d[1] - o4[1], d[0] - o4[0]))


def crane_tie_minima() -> tuple[float, list[float]]:
    """The tie's smallest angle (deg) and every crank angle (deg) where it is reached:
    the local minima of a 0.001-degree sweep, each refined by golden-section search."""
    from scipy.optimize import minimize_scalar

    th = np.radians(np.arange(0.0, 360.0, 0.001))
    tie = crane_tie_angle(th)
    k = np.flatnonzero((tie < np.roll(tie, 1)) & (tie <= np.roll(tie, -1)))
    found = []
    for i in k:
        r = minimize_scalar(
            lambda x: float(crane_tie_angle(np.array([x]))[0]),
            bracket=(th[i] - 1e-4, th[i], th[i] + 1e-4),
            tol=1e-12,
        )
        found.append((float(r.fun), math.degrees(r.x) % 360))
    low = min(v for v, _ in found)
    return low, sorted(x for v, x in found if v - low < 1e-9)


def test_the_crane_tie_reaches_its_lower_limit_twice():
    """Why the report said 355.18 deg in one place and 27.49 deg in another: the tie's
    angle has the same minimum at both (the jib passes the same angle on its way down and
    back up, and the tie's extreme lies inside the jib's swing). The independent
    computation finds both; so do the 10-degree and the 1-degree sweeps, in sweep order."""
    low, where = crane_tie_minima()
    assert len(where) == 2
    assert where == pytest.approx([27.487, 355.182], abs=1e-3)
    mech = mechsolve.load(MECH / "crane.yaml")
    res = mechsolve.api.solve(mech)
    fine = mechsolve.api.for_plots(mech, res)
    for r in (res, fine):
        (tie,) = [lp for lp in r.limit_positions() if lp.name == "tie"]
        assert math.degrees(tie.low) == pytest.approx(low, abs=1e-8)
        got = [math.degrees(u) % 360 for u in tie.u_lows]
        # a search of the angle itself places a flat minimum to about the square root of
        # the rounding (5e-8 rad); the solver finds the root of the tie's rate, sharper
        assert got == pytest.approx(where, abs=2e-5)
        assert tie.u_low == tie.u_lows[0]


@pytest.fixture(scope="module")
def crane_page(tmp_path_factory):
    out = tmp_path_factory.mktemp("crane") / "crane.html"
    r = CliRunner().invoke(report, [str(MECH / "crane.yaml"), "-o", str(out), "--frames", "6"])
    assert r.exit_code == 0, r.output
    html = out.read_text(encoding="utf-8")
    summary = _pre_text(_section(html, "summary"))
    return Page(html), summary, r.output


def _angles(text: str) -> list[float]:
    return [float(x) for x in re.findall(r"driver angle (-?[\d.]+)°", text)]


def test_report_gives_one_value_per_figure(crane_page):
    """The summary said the tie's lower limit is at 355.18 deg and the figures table 27.49
    deg (two sweeps, each picking one of two equal minima); the summary's torque extremes
    were the 10-degree table's (-292.914 kN m) beside the figures' -295.108. Now every
    figure the two share is the same number, and the tie's limit is at both angles; the
    torque's extremes are the summary's 1° samples (said so) located in the table."""
    page, summary, terminal = crane_page
    low, where = crane_tie_minima()
    rows = {r[0]: r for r in page.table("Figures of the motion")["rows"]}
    row = rows["limit positions of rocker tie"]
    assert row[1].startswith(f"{low:.6g}°")
    for x in where:  # both positions of the lower limit
        assert any(abs(x - y) < 1e-3 for y in _angles(row[2])), (x, row[2])
    lower, higher = row[2].split(";")
    assert _angles(lower) == pytest.approx(where, abs=1e-3)
    (tie,) = re.findall(r"rocker tie ([^;\n]*)", summary)
    at_low, at_high = tie.split(" to ")
    assert at_low.startswith(f"{low:.6g}°")
    assert _angles(at_low) == pytest.approx(where, abs=1e-3)
    assert _angles(at_high) == _angles(higher)
    assert summary in terminal  # the terminal prints the same summary
    # the driving torque's extremes: the same numbers in the summary and the figures
    m = re.search(
        r"driving torque \(.*? samples\): max (-?[\d.]+) kN·m at (.*?), "
        r"min (-?[\d.]+) kN·m at (.*?),",
        summary,
    )
    assert m, summary
    # the summary gives the 1° samples' and says so; the figures table locates each
    # extreme between them (issue 30, review 8): never short of the samples, within 1e-4
    big, unit = rows["largest driving torque"][1].split(" ", 1)
    small = rows["smallest driving torque"][1].split(" ", 1)[0]
    assert unit == "kN m" and rows["smallest driving torque"][1].endswith(" kN m")
    assert float(m.group(1)) <= float(big) <= float(m.group(1)) + 1e-4 * abs(float(big))
    assert float(m.group(3)) - 1e-4 * abs(float(small)) <= float(small) <= float(m.group(3))
    assert _angles(rows["largest driving torque"][2]) == pytest.approx(_angles(m.group(2)), abs=0.5)
    # the true extreme (seed's fine recomputation), not the 10-degree table's -292.914
    fine = np.array(ref("000_crane_kinetostatics.json")["fine_1deg"])
    assert float(m.group(3)) == pytest.approx(fine[:, 1].min() / 1e3, abs=0.2)


def test_a_wide_table_is_printed_in_parts_of_whole_groups():
    """Each part fits the printed page's width, repeats the leading columns, and together
    the parts hold every other column once, in order, a joint's components together."""
    from mechsolve.report.build import PRINT_CHAR, PRINT_PAD, PRINT_WIDTH, Table

    header = ["#", "t [s]", "input.angle [deg]", "input.torque [N m]"]
    header += [f"J{i}(link{i}->link{i + 1}).{c} [N]" for i in range(9) for c in ("Fx", "Fy", "F")]
    rows = [[str(n), "0.0125", "-163.17"] + ["-123456.7"] * (len(header) - 3) for n in (1, 2)]
    t = Table("Driving effort and joint reactions", header, rows, [True] * len(header), lead=3)
    parts = t.print_parts()
    assert len(parts) >= 2
    seen = []
    for i, p in enumerate(parts, start=1):
        assert p.caption == f"Driving effort and joint reactions (part {i} of {len(parts)})"
        assert [g.text for g in p.groups[:3]] == header[:3]
        assert all(g.rowspan == 2 for g in p.groups[:3])
        for g in p.groups[3:]:
            # a joint's three components under its name, never split between parts
            assert g.colspan == 3 if g.text.startswith("J") else g.colspan == 1
        cell = len("-123456.7") * PRINT_CHAR + PRINT_PAD  # the widest text of a column
        width = sum(t.column_width(k) for k in range(3)) + sum(
            g.colspan * cell for g in p.groups[3:]
        )
        assert width <= PRINT_WIDTH + 1e-9
        assert all(len(r) == 3 + len(p.sub) for r in p.rows)
        seen += [g.text for g in p.groups[3:]]
    assert seen == ["input"] + [f"J{i}(link{i}->link{i + 1})" for i in range(9)]
    # a table that fits is printed as it is
    assert Table("Fixed points", ["point", "x [mm]"], [["O2", "0"]]).print_parts() == []
