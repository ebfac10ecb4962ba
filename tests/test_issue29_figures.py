"""Issue 29, report-ready figures: each property checked on its own, from the figure's
artists (what matplotlib draws) or the written file, against what the drawing must be:
a jump is a gap (NaN) and never a chord; a force scale is 1, 2 or 5 times a power of
ten; no two labels overlap; the cam's sheet has no blank half; a study's axes name
quantities, not key paths, and draw the requirements' limits; the HTML report fits a
1280 px window and names its input without an absolute path; an animation draws the
loads and labels its arrows."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from mechsolve import api
from mechsolve.writers import plots

from conftest import MECH


def _capture(monkeypatch, module) -> list:
    """Keep the figures ``module`` saves (open) instead of writing them."""
    figs: list = []

    def keep(fig, path, dpi):
        figs.append(fig)

    monkeypatch.setattr(module, "save_figure", keep)
    return figs


@pytest.fixture(scope="module")
def crane():
    mech = api.load(MECH / "crane.yaml")
    res = api.solve(mech)
    return mech, api.for_plots(mech, res)


# -- 1. jumps drawn as jumps ---------------------------------------------------------


def test_a_circle_with_a_jump_is_broken_there_and_nowhere_else():
    # a force of constant size turning steadily (a hodograph that is a circle), plus a
    # 50 % step halfway: the only jump is at that step
    t = np.linspace(0, 2 * np.pi, 361)
    r = np.where(t < np.pi, 1.0, 1.5)
    x, y = r * np.cos(t), r * np.sin(t)
    assert plots.jumps(x, y).tolist() == [179]
    bx, by = plots.break_jumps(x, y)
    assert np.isnan(bx[180]) and np.isnan(by[180])
    assert np.count_nonzero(np.isnan(bx)) == 1
    # the smooth circle alone has none
    assert plots.jumps(np.cos(t), np.sin(t)).size == 0


@pytest.mark.slow
def test_the_crane_hodographs_break_where_the_load_switches(crane, monkeypatch):
    # the 50 kN load at K acts only while K moves left: the reactions at the ground jump
    # where it switches (twice a turn); the hodograph's line stops there, so no segment
    # of the drawn line is a chord as long as the jump
    mech, res = crane
    figs = _capture(monkeypatch, plots)
    plots.plot_hodographs(res, "unused.png")
    (fig,) = figs
    switches = plots._switches(res).size
    assert switches == 2
    for ax in fig.axes:
        if not ax.lines:
            continue
        line = ax.lines[0]
        x, y = (np.asarray(v, float) for v in line.get_data())
        assert np.count_nonzero(np.isnan(x)) >= switches, ax.get_title()
        # every drawn segment (both ends finite) is a small step of the 1° sweep: at most
        # a tenth of the 50 kN jump (the jump is the load, 50 kN, seen at the pivot)
        step = np.hypot(np.diff(x), np.diff(y))
        drawn = step[np.isfinite(step)]
        assert drawn.max() < 0.1 * max(np.nanmax(x) - np.nanmin(x), np.nanmax(y) - np.nanmin(y))


# -- 2. round force scales -----------------------------------------------------------


def _in_125(value: float) -> bool:
    """Whether ``value`` is 1, 2 or 5 times a power of ten."""
    mantissa = value / 10.0 ** math.floor(math.log10(value) + 1e-12)
    return any(abs(mantissa - m) < 1e-9 * m for m in (1, 2, 5))


def test_the_125_series_helper():
    assert [plots.round_125(x) for x in (0.7, 1, 1.01, 3, 7.5, 420)] == [1, 1, 2, 5, 10, 500]
    assert [plots.round_125(x, up=False) for x in (0.7, 1.9, 3, 9.99, 420)] == [
        0.5,
        1,
        2,
        5,
        200,
    ]


@pytest.mark.parametrize("big", [0.37, 41.36e3 * 8.6, 2.0, 7.7e6, 123.0])
@pytest.mark.parametrize("size", [0.021, 0.2, 1.0, 34.4, 900.0])
def test_an_arrow_scale_reads_two_round_numbers(big, size):
    from mechsolve.report.animate import ARROW_SHARE, arrow_scale

    per_n, bar = arrow_scale(big, size)
    force = bar / per_n  # what the bar stands for
    assert _in_125(bar) and _in_125(force), (bar, force)
    assert size / 20 * (1 - 1e-9) <= bar <= 0.15 * size
    # the longest arrow fits the share of the drawing, and is not lost in it
    assert 0.1 * size <= big * per_n <= ARROW_SHARE * size * (1 + 1e-9)


# -- 7. animate: the loads, and labelled arrows ---------------------------------------


@pytest.fixture(scope="module")
def crane_frames():
    from mechsolve.report.animate import solve_frames

    return solve_frames(api.load(MECH / "crane.yaml"), 73, forces=True)


@pytest.mark.slow
def test_the_animation_carries_the_load_where_it_acts(crane_frames):
    # the crane's load Q = 50 kN down at K while K moves left (K.vx < 0): the frames
    # turn the crank counter-clockwise at constant speed, so K moves left where K.x
    # falls from one frame to the next
    fr = crane_frames
    assert set(fr.loads) == {"Q"} and fr.load_points["Q"] == "K"
    x, y, fx, fy = fr.loads["Q"]
    kx = fr.points["K"][0]
    assert np.allclose(x, kx) and np.allclose(fx, 0)
    falling = np.diff(kx) < 0
    checked = 0
    for i in range(1, len(kx) - 1):
        if falling[i - 1] != falling[i]:
            continue  # K turns back between these frames: the switch itself
        assert (fy[i] < 0) == falling[i], i
        if falling[i]:
            assert fy[i] == pytest.approx(-50e3, rel=1e-12)
        checked += 1
    assert checked >= 60 and 0 < np.count_nonzero(fy < 0) < len(fy)


@pytest.mark.slow
def test_the_animation_labels_every_arrow_and_draws_a_round_bar(crane_frames):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from mechsolve.report.animate import _render

    fr = crane_frames
    fig = Figure(figsize=(8, 6), dpi=100)
    FigureCanvasAgg(fig)
    next(_render(fr, fig))
    texts = [t.get_text() for t in fig.axes[0].texts]
    for j in ("O1", "A", "B", "O3", "C", "D", "O4"):
        assert f"R {j}" in texts
    assert "Q 50 kN" in texts
    (bar,) = [t for t in texts if " = " in t and t.endswith("N")]
    length, force = bar.split(" = ")
    metres = float(length.split()[0]) * (1e-3 if length.endswith("mm") else 1.0)
    value, unit = force.split()
    newtons = float(value) * {"N": 1, "kN": 1e3, "MN": 1e6}[unit]
    assert _in_125(metres) and _in_125(newtons)
    assert math.isclose(metres / newtons, fr.force_scale, rel_tol=1e-9)


# -- 3. labels without overlap ---------------------------------------------------------


def _saved(monkeypatch, module, tmp_path) -> list:
    """Save for real (labels are placed on saving) and keep each figure."""
    figs: list = []
    real = module.save_figure

    def keep(fig, path, dpi):
        real(fig, tmp_path / Path(path).name, dpi)
        figs.append(fig)

    monkeypatch.setattr(module, "save_figure", keep)
    return figs


def _renderer(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if not hasattr(fig.canvas, "get_renderer"):  # closed by pyplot: draw it again
        FigureCanvasAgg(fig)
    return fig.canvas.get_renderer()


def _label_boxes(fig):
    from matplotlib.text import Text

    renderer = _renderer(fig)
    fig.canvas.draw()  # an annotation's text is positioned when drawn
    ax = fig.axes[0]
    # the text's own box (an annotation's window extent takes in its leader line too)
    return {t.get_text(): Text.get_window_extent(t, renderer) for t in ax.texts if t.get_text()}


def _overlaps(boxes: dict) -> list[tuple[str, str]]:
    names = list(boxes)
    out = []
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            p, q = boxes[a], boxes[b]
            if min(p.x1, q.x1) - max(p.x0, q.x0) > 0.5 and min(p.y1, q.y1) - max(p.y0, q.y0) > 0.5:
                out.append((a, b))
    return out


@pytest.mark.slow
def test_no_two_labels_overlap_in_the_crane_drawing(crane, monkeypatch, tmp_path):
    # near O1 the crank (1.388 m) and the coupler sit among O1, A and B on a 30 m
    # drawing: their names used to lie on each other
    mech, res = crane
    figs = _saved(monkeypatch, plots, tmp_path)
    plots.plot_trajectories(res, tmp_path / "trajectories.png")
    boxes = _label_boxes(figs[0])
    every = {*(lk.name for lk in mech.links), *(p for lk in mech.links for p in lk.points)}
    assert every <= set(boxes)
    assert _overlaps(boxes) == []
    # and no label covers a pin: the joints' markers stay readable
    renderer = _renderer(figs[0])
    ax = figs[0].axes[0]
    for j in mech.joints:
        x, y = res.point(j.point).x[0], res.point(j.point).y[0]
        px, py = ax.transData.transform((x, y))
        for name, box in boxes.items():
            assert not box.contains(px, py), (name, j.point)
    assert renderer is not None


def test_the_placement_moves_a_label_off_another():
    # two points 1 % of the drawing apart: their names, placed at the same offset,
    # would overlap; the placement keeps them apart
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 4), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    for name, x in (("O1", 0.50), ("A", 0.51), ("crank", 0.505)):
        plots._label(ax, name, x, 0.5, fontsize=8, color="k", pin=name != "crank")
    plots.place_labels(fig)
    boxes = _label_boxes(fig)
    assert set(boxes) == {"O1", "A", "crank"}
    assert _overlaps(boxes) == []


# -- 4. the cam's sheet ------------------------------------------------------------------


def _drawn_share(png) -> tuple[float, float]:
    """The share of the image's width and height that the drawn (not white) pixels span."""
    from PIL import Image

    a = np.asarray(Image.open(png).convert("L"), float)
    ink = a < 245
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    return (cols[-1] - cols[0] + 1) / a.shape[1], (rows[-1] - rows[0] + 1) / a.shape[0]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["shaper-cam.yaml"])
def test_the_cam_sheet_has_no_blank_band(name, tmp_path):
    # the drawing (cam, followers, legend) spans the whole sheet: a margin of a few
    # percent, never the blank third a square sheet around a wide drawing had
    from mechsolve.analyses.cam.analysis import analyse
    from mechsolve.analyses.cam.model import load as load_cam
    from mechsolve.analyses.cam.writers import draw_cam

    res = analyse(load_cam(MECH / name, None))
    png = draw_cam(res, tmp_path / "cam.png")
    width, height = _drawn_share(png)
    assert width >= 0.9 and height >= 0.9, (width, height)


# -- 5. study plots ----------------------------------------------------------------------

KEY_PATH = re.compile(r"[A-Za-z_]\w*\.[A-Za-z_]\w*|\[\d+\]")  # links.crank, A[0]


@pytest.fixture(scope="module")
def fourbar_study():
    from mechsolve.analyses.study.designs import make_study
    from mechsolve.analyses.study.execute import execute
    from mechsolve.model.source import load_file

    # the example study on a 3 x 3 grid (its file asks for 7 x 8): the same columns
    options = ["links.crank.points.A[0]=20..32 mm:3", "links.coupler.points.B[0]=90..110 mm:3"]
    study = make_study(load_file(MECH / "studies" / "fourbar-study.yaml"), options)
    return study, execute(study, jobs=1).rows


@pytest.mark.slow
def test_study_plots_name_quantities_repeat_no_panel_and_draw_the_limits(
    fourbar_study, monkeypatch, tmp_path
):
    from mechsolve.analyses.study import plots as study_plots

    study, rows = fourbar_study
    figs = _capture(monkeypatch, study_plots)
    study_plots.write_plots(study, rows, tmp_path)
    assert len(figs) == 3  # against each parameter, and the pass/fail map
    for fig in figs:
        title = fig._suptitle.get_text() if fig._suptitle else fig.axes[0].get_title()
        assert "/" not in title.split(":")[0]  # the file by its name, no folder
        for ax in fig.axes:
            for label in (ax.get_xlabel(), ax.get_ylabel()):
                if label:
                    assert not KEY_PATH.search(label), label
                    assert label.endswith("]"), label  # with its unit
    against = figs[0]
    panels = [ax for ax in against.axes if ax.lines]
    # no panel repeats another: the curves of any two differ
    data = [np.concatenate([ln.get_ydata() for ln in ax.lines if ln.get_linestyle() != "--"])
            for ax in panels]  # fmt: skip
    for i in range(len(data)):
        for k in range(i + 1, len(data)):
            same = data[i].shape == data[k].shape and np.allclose(data[i], data[k], equal_nan=True)
            assert not same, (panels[i].get_ylabel(), panels[k].get_ylabel())
    # the three requirements with a limit each draw it where the file puts it
    drawn = {}
    for ax in panels:
        for ln in ax.lines:
            y = np.asarray(ln.get_ydata(), float)
            if ln.get_linestyle() == "--" and y.size == 2 and y[0] == y[1]:
                drawn[ax.get_ylabel()] = float(y[0])
    assert drawn == {
        "min transmission angle B [deg]": pytest.approx(30),
        "rocker swing [deg]": pytest.approx(55),
        # on the requirement's own (located) value: the peak column is the samples'
        "torque (requirement) [N m]": pytest.approx(0.07),
    }


def test_the_words_of_a_figure():
    from mechsolve.analyses.study.plots import figure_label

    assert figure_label("min(transmission_angle.B) [deg]") == "min transmission angle B [deg]"
    assert figure_label("max(abs(input.torque)) [N*m]") == "max |input torque| [N*m]"
    assert figure_label("max(O2.F) [N]") == "max O2 reaction F [N]"
    assert figure_label("rocker.time_ratio [-]") == "rocker time ratio [-]"
    assert figure_label("range(K.y) [m]") == "range K y [m]"
    assert figure_label("cycle.work [J]") == "work per cycle [J]"


# -- 6. the HTML report ------------------------------------------------------------------

WIDTHS = """<script>
window.addEventListener("load", function () {
  var doc = document.documentElement, out = {page: doc.scrollWidth, window: doc.clientWidth,
    scrolls: []};
  document.querySelectorAll("*").forEach(function (e) {
    var visible = e.offsetParent !== null || e === document.body;
    var clipped = getComputedStyle(e).overflowX !== "visible";
    if (visible && clipped && e.scrollWidth > e.clientWidth + 1) {
      out.scrolls.push(e.tagName + "." + e.className + " " + e.scrollWidth + " > " + e.clientWidth);
    }
  });
  var pre = document.createElement("pre");
  pre.id = "widths";
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


@pytest.fixture(scope="module")
def crane_html(tmp_path_factory):
    from mechsolve.report import write_report

    out = tmp_path_factory.mktemp("report") / "crane.html"
    write_report(MECH / "crane.yaml", out=out, frames=24)  # the input by its absolute path
    return out


@pytest.mark.slow
def test_the_report_embeds_no_absolute_path(crane_html):
    text = crane_html.read_text(encoding="utf-8")
    for folder in {str(MECH), str(MECH.parent), str(crane_html.parent), str(Path.home())}:
        assert folder not in text
    assert "File <code>crane.yaml</code>" in text


def test_the_report_names_its_input_relative_to_itself(tmp_path):
    from mechsolve.report import shown_name

    (tmp_path / "mechanisms").mkdir()
    inside = tmp_path / "mechanisms" / "crane.yaml"
    assert shown_name(inside, tmp_path / "crane.html") == "mechanisms/crane.yaml"
    assert shown_name(inside, tmp_path / "out" / "crane.html") == "crane.yaml"
    assert shown_name(MECH / "crane.yaml", "/elsewhere/r.html") == "crane.yaml"


@pytest.mark.slow
def test_the_report_fits_a_1280_px_window(crane_html, tmp_path):
    # in Chromium at 1280 px: the page is no wider than the window and no table, summary
    # or other box scrolls sideways (the crane's tables have up to 22 columns)
    import json
    import subprocess
    import tempfile

    from mechsolve.report.browser import find_browser, headless_command

    browser = find_browser()
    if browser is None:
        pytest.skip("no Chromium-based browser (apt-get install -y chromium)")
    copy = tmp_path / "widths.html"
    copy.write_text(
        crane_html.read_text(encoding="utf-8").replace("</body>", WIDTHS + "</body>", 1),
        encoding="utf-8",
    )
    with tempfile.TemporaryDirectory() as profile:
        cmd = headless_command(
            browser, profile, "--window-size=1280,900", "--virtual-time-budget=5000",
            "--hide-scrollbars", "--dump-dom", copy.as_uri(),
        )  # fmt: skip
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    m = re.search(r'<pre id="widths">(.*?)</pre>', p.stdout, re.S)
    assert m, p.stderr[-2000:]
    import html as _html

    found = json.loads(_html.unescape(m.group(1)))
    assert found["window"] >= 1260  # the window is the width asked for
    assert found["page"] <= found["window"], found
    assert found["scrolls"] == []


def test_a_curve_along_the_motion_breaks_where_a_load_switches():
    t = np.linspace(0, 1, 11)
    on = t >= 0.45  # the load acts from the 6th sample on
    bt, bf = plots.break_at_switches({"cut": on}, t, np.where(on, 100.0, 1.0))
    assert np.flatnonzero(np.isnan(bt)).tolist() == [5] and np.isnan(bf[5])
    assert np.array_equal(bt[~np.isnan(bt)], t)


@pytest.mark.slow
def test_the_simulation_reactions_break_where_the_cut_starts_and_ends(monkeypatch, tmp_path):
    # the shaper's cutting force acts over part of the ram's stroke: the reactions jump
    # where it starts and ends, and the start-up's plot leaves a gap there
    from mechsolve.analyses.dynamics import plots as dyn_plots
    from mechsolve.analyses.dynamics import simulate

    mech = api.load(MECH / "shaper.yaml")
    sim = simulate(mech)
    figs: list = []
    monkeypatch.setattr(dyn_plots, "_save", lambda fig, path: figs.append(fig) or path)
    dyn_plots.write_simulation_plots(sim, sim.model, tmp_path)
    (ax,) = [f.axes[0] for f in figs if "reactions" in f.axes[0].get_title()]
    switches = sum(
        int(np.count_nonzero(np.diff(np.asarray(on, int)))) for on in sim.forces.active.values()
    )
    assert switches >= 4  # twice a turn over the start-up's turns
    for line in ax.lines:
        assert np.count_nonzero(np.isnan(np.asarray(line.get_xdata(), float))) == switches
