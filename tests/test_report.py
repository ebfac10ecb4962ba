"""mechsolve report: every example through CliRunner (and one real process), the page's
content parsed back (tables against the seed's printed numbers, images decodable, no
network reference, the animation's frames), autoescaping, exit codes, --pdf without a
browser, a cam file. The page in a real browser is tests/test_report_browser.py."""

from __future__ import annotations

import base64
import io
import json
import math
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import mechsolve as ms
from mechsolve.cli.commands.report import report

from conftest import MECH, MECHANISMS, ref

FRAMES = 12


def _header(rows: list[list[tuple[str, tuple[int, int]]]]) -> list[str]:
    """A table's column headers from its header rows: one row as it is; two, as the report
    prints a wide table's part, a name over its columns (``K`` over ``vx [m/s]``) joined
    back to ``K.vx [m/s]``."""
    if len(rows) == 1:
        return [text for text, _ in rows[0]]
    subs = iter(text for text, _ in rows[1])
    out = []
    for text, (colspan, rowspan) in rows[0]:
        if rowspan > 1:
            out.append(text)
        else:
            out += [f"{text}.{next(subs)}" for _ in range(colspan)]
    return out


class Page(HTMLParser):
    """What a reader sees: headings, images, tables (with the caption before them), the
    animation's data, and every URL the page would fetch."""

    def __init__(self, text: str) -> None:
        super().__init__(convert_charrefs=True)
        self.h1: list[str] = []
        self.h2: list[str] = []
        self.images: list[dict] = []
        self.tables: list[dict] = []
        self.urls: list[str] = []
        self.scripts: list[tuple[str, str]] = []
        self.ids: set[str] = set()
        self._text: list[str] | None = None
        self._caption = ""
        self._row: list[str] | None = None
        self._spans: list[tuple[int, int]] = []  # (colspan, rowspan) of the row's cells
        self._head = False  # inside a thead
        self._script: str | None = None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        for k in ("src", "href"):
            if k in a and not a[k].startswith(("#", "data:")):
                self.urls.append(a[k])
        if tag == "img":
            self.images.append(a)
        elif tag in ("h1", "h2", "figcaption", "th", "td"):
            self._text = []
        if tag == "table":
            self.tables.append({"caption": self._caption, "header": [], "rows": [], "head": []})
        elif tag == "thead":
            self._head = True
        elif tag == "tr":
            self._row = []
            self._spans = []
        if tag == "th":
            self._spans.append((int(a.get("colspan", 1)), int(a.get("rowspan", 1))))
        elif tag == "script":
            self._script = a.get("type", "")
            self._text = []

    def handle_endtag(self, tag):
        text = "".join(self._text or []).strip()
        if tag == "h1":
            self.h1.append(text)
        elif tag == "h2":
            self.h2.append(text)
        elif tag == "figcaption":
            self._caption = text
        elif tag in ("th", "td") and self._row is not None:
            self._row.append(text)
        elif tag == "thead":
            self._head = False
        elif tag == "tr" and self._row is not None and self.tables:
            t = self.tables[-1]
            if self._head:  # a table shown in parts has two header rows: a name over
                t["head"].append(list(zip(self._row, self._spans)))  # its columns
                t["header"] = _header(t["head"])
            elif t["header"]:
                t["rows"].append(self._row)
            else:
                t["header"] = self._row
            self._row = None
        elif tag == "script":
            self.scripts.append((self._script or "", "".join(self._text or [])))
            self._script = None
        if tag in ("h1", "h2", "figcaption", "th", "td", "script"):
            self._text = None

    def handle_data(self, data):
        if self._text is not None:
            self._text.append(data)

    def table(self, caption_start: str) -> dict:
        found = [t for t in self.tables if t["caption"].startswith(caption_start)]
        assert found, f"no table {caption_start!r} in {[t['caption'] for t in self.tables]}"
        m = re.search(r" \(part 1 of (\d+)\)$", found[0]["caption"])
        if not m:
            return found[0]
        # a wide table shown in parts, each led by the same columns: joined again
        parts = found[: int(m.group(1))]
        whole = {"caption": found[0]["caption"][: m.start()], **{k: [] for k in ("header", "rows")}}
        lead = 0
        while all(lead < len(p["header"]) and p["header"][lead] == parts[0]["header"][lead]
                  for p in parts):  # fmt: skip
            lead += 1
        whole["header"] = parts[0]["header"][:lead] + [h for p in parts for h in p["header"][lead:]]
        whole["rows"] = [
            rows[0][:lead] + [c for r in rows for c in r[lead:]]
            for rows in zip(*(p["rows"] for p in parts))
        ]
        return whole

    def column(self, caption_start: str, header: str) -> np.ndarray:
        t = self.table(caption_start)
        k = t["header"].index(header)
        return np.array([float(r[k]) if r[k] != "–" else np.nan for r in t["rows"]])

    def animation(self) -> dict:
        (text,) = [s for t, s in self.scripts if t == "application/json"]
        return json.loads(text)


def make_report(path: Path, out: Path, *args: str):
    r = CliRunner().invoke(report, [str(path), "-o", str(out), "--frames", str(FRAMES), *args])
    return r


class _Pages(dict):
    """Each example's report, written when a test first asks for it (the fast tier asks
    for the crane's alone)."""

    def __init__(self, folder: Path) -> None:
        super().__init__()
        self.folder = folder

    def __missing__(self, name: str):
        html = self.folder / (Path(name).stem + ".html")
        self[name] = (make_report(MECH / name, html, "-q"), html)
        return self[name]


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """The report of every example, written once for the tests below."""
    return _Pages(tmp_path_factory.mktemp("reports"))


@pytest.mark.parametrize("name", MECHANISMS)
def test_every_example(name, pages):
    r, html = pages[name]
    assert r.exit_code == 0, r.output
    page = Page(html.read_text(encoding="utf-8"))
    mech = ms.load(MECH / name)
    assert page.h1 == [mech.name]
    # self-contained: nothing to fetch, every image embedded and decodable
    assert page.urls == []
    assert len(page.images) >= 3
    for img in page.images:
        assert img["src"].startswith("data:image/png;base64,")
        im = Image.open(io.BytesIO(base64.b64decode(img["src"].split(",", 1)[1])))
        assert im.size[0] > 100 and im.size[1] > 100
        assert img["alt"]
    # the model's tables name every link and joint, with units in the headers
    links = page.table("Links")
    assert {r[0] for r in links["rows"]} - {""} == {lk.name for lk in mech.links}
    assert f"x [{mech.length_unit}]" in links["header"]
    assert [r[0] for r in page.table("Joints")["rows"]] == [j.name for j in mech.joints]
    # a plot for every output point, the start drawing, the animation's frames
    res = ms.solve(mech)
    alts = " | ".join(i["alt"] for i in page.images)
    for p in res.point_names():
        assert f"Point {p}:" in alts
    assert "start position" in alts
    anim = page.animation()
    assert len(anim["labels"]) == FRAMES
    assert set(anim["paths"]) == set(res.point_names())
    assert ("Dynamics: the motor-driven machine" in page.h2) == (
        mech.motor is not None and mech.simulation is not None
    )
    assert ("Requirements" in page.h2) == bool(mech.requirements)
    # the position table has the file's positions
    assert len(page.table("Positions of the points")["rows"]) == len(res.u)


def test_crane_table_is_the_seeds_printed_table(pages):
    """Seed 000's table 2 (K every 10 deg of crank): the report's columns give every
    printed digit (3 decimals)."""
    page = Page(pages["crane.yaml"][1].read_text(encoding="utf-8"))
    table = np.array(ref("000_crane_table2_K_kinematics.json")["printed_in_seed"])
    assert len(page.table("Positions of the points")["rows"]) == 37
    np.testing.assert_allclose(
        page.column("Positions of the points", "input.angle [deg]"), table[:, 0]
    )
    for caption, header, col in (
        ("Positions of the points", "K.y [m]", 1),
        ("Positions of the points", "K.x [m]", 2),
        ("Velocities of the points", "K.vx [m/s]", 3),
        ("Accelerations of the points", "K.ax [m/s²]", 4),
    ):
        got = page.column(caption, header)
        assert np.all(np.abs(got - table[:, col]) <= 0.0005 + 1e-9 + 5e-6), header


def test_crane_figures_peak_torque_from_the_fine_sweep(pages):
    """The figures come from the 1-degree sweep with the exact events, so the torque's
    extreme is the one an independent 1-degree recomputation finds (-295.1 kN m), not
    the 10-degree table's -292.9 kN m."""
    page = Page(pages["crane.yaml"][1].read_text(encoding="utf-8"))
    rows = {r[0]: r for r in page.table("Figures of the motion")["rows"]}
    value, unit = rows["smallest driving torque"][1].split(" ", 1)
    assert unit == "kN m"
    fine = np.array(ref("000_crane_kinetostatics.json")["fine_1deg"])
    lowest = fine[:, 1].min() / 1e3
    assert float(value) <= lowest + 1e-3
    assert float(value) == pytest.approx(lowest, abs=0.2)
    # the jib's swing: the seed's O3C window for the rounded l1, l2 (92.993 .. 134.000 deg)
    lo, hi = ref("000_crane_design.json")["recomputed"]["O3C_swing_with_rounded_l1_l2_deg"]
    assert float(rows["swing of jib"][1].rstrip("°")) == pytest.approx(hi - lo, abs=6e-4)


def test_names_are_escaped_and_a_failing_requirement_exits_5(tmp_path):
    """A name and description written as HTML are shown as text (autoescape), and a
    requirement that fails gives exit code 5 and a FAIL row; the report is written."""
    text = (MECH / "fourbar.yaml").read_text()
    text = text.replace(
        "name: four-bar crank-rocker",
        'name: "<script>alert(1)</script> & <b>bold</b>"\n'
        'description: "uses <img src=x onerror=alert(2)>"',
    )
    text += "\nrequirements:\n  torque: max(abs(input.torque)) <= 0.001 N m\n"
    src = tmp_path / "hostile.yaml"
    src.write_text(text)
    out = tmp_path / "hostile.html"
    r = make_report(src, out)
    assert r.exit_code == 5, r.output
    html = out.read_text(encoding="utf-8")
    assert "<script>alert(1)" not in html and "<img src=x" not in html
    assert "&lt;script&gt;alert(1)&lt;/script&gt; &amp; &lt;b&gt;bold&lt;/b&gt;" in html
    page = Page(html)
    assert page.h1 == ["<script>alert(1)</script> & <b>bold</b>"]
    (row,) = page.table("Requirements")["rows"]
    assert row[0] == "torque" and row[-1] == "FAIL"
    assert "FAIL" in r.output


def test_pdf_without_a_browser_says_what_to_install(tmp_path, monkeypatch):
    monkeypatch.setenv("MECHSOLVE_BROWSER", str(tmp_path / "no-such-browser"))
    out = tmp_path / "r.html"
    r = make_report(MECH / "sixbar.yaml", out, "--pdf", "-q")
    assert r.exit_code == 2
    assert "apt-get install chromium" in r.output
    assert "is written" in r.output and out.exists()
    assert not out.with_suffix(".pdf").exists()


def test_a_cam_file(tmp_path):
    out = tmp_path / "cam.html"
    r = make_report(MECH / "shaper-cam.yaml", out, "-q")
    # as `mechsolve cam` does: the file's adopted base exceeds its allowed 40 deg
    assert r.exit_code == 5, r.output
    page = Page(out.read_text(encoding="utf-8"))
    assert "Cam" in page.h2 and len(page.images) >= 2
    assert page.h1 == ["shaper feed cam (seed 001)"]
    # the seed's maximum pressure angle on the rise, as the cam summary prints it
    text = out.read_text(encoding="utf-8")
    assert re.search(r"reaches 48\.3\d deg", text) and "THE DESIGN FAILS" in text


@pytest.mark.parametrize(
    "args, message",
    [
        (["-o", "r.txt"], "HTML file"),
        (["-o", "no/such/dir/r.html"], "does not exist"),
        (["--variant", "nope"], "nope"),
    ],
)
def test_bad_options(args, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(report, [str(MECH / "fourbar.yaml"), *args])
    assert r.exit_code == 2, r.output
    assert message in r.output and "Traceback" not in r.output


def test_real_process(tmp_path):
    out = tmp_path / "slider-crank.html"
    p = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from mechsolve.cli.commands.report import report; "
            "report.main(sys.argv[1:], prog_name='mechsolve report')",
            str(MECH / "slider-crank.yaml"),
            "-o",
            str(out),
            "--frames",
            "6",
            "--units",
            "SI",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    assert f"wrote {out}" in p.stdout
    page = Page(out.read_text(encoding="utf-8"))
    # the piston's stroke in the figures against the offset slider-crank's closed form
    r, l, e = 0.05, 0.2, 0.01
    stroke = math.sqrt((l + r) ** 2 - e**2) - math.sqrt((l - r) ** 2 - e**2)
    rows = {row[0]: row for row in page.table("Figures of the motion")["rows"]}
    (key,) = [k for k in rows if k.startswith("stroke of")]
    assert float(rows[key][1].split()[0]) == pytest.approx(stroke, abs=5e-7)
