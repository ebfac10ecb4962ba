"""Names in the users' languages: Chinese, Japanese, Korean and Cyrillic on plots."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import mechsolve as ms
from mechsolve.writers import fonts

from conftest import MECH


def cjk_font() -> bool:
    return len(fonts.configure()) > 1


def need_cjk_font():
    if cjk_font():
        return
    if os.environ.get("CI", "").lower() not in ("", "0", "false", "no"):
        pytest.fail("CI must install a CJK font (.ci/run: fonts-wqy-microhei)")
    pytest.skip("no CJK font installed here (apt-get install fonts-wqy-microhei)")


def render(text: str, families: list[str]) -> np.ndarray:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1, 1), dpi=50)
    FigureCanvasAgg(fig)
    fig.text(0.1, 0.3, text, family=families, fontsize=30)
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., 0].copy()


def test_the_chinese_crane_runs_without_a_warning_and_keeps_its_names(tmp_path):
    """A real process on the Chinese-named crane: no per-glyph warning, no font note, and
    the CSV keeps the names as written."""
    need_cjk_font()
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "mechsolve",
            "run",
            str(MECH / "crane-zh.yaml"),
            "-o",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    assert "Glyph" not in p.stderr and "missing" not in p.stderr and "note:" not in p.stderr
    head = (tmp_path / "results.csv").read_text(encoding="utf-8").splitlines()[0]
    # the file's units (m, deg): angular speeds in deg/s
    assert "曲柄.angle [deg]" in head and "拉杆.omega [deg/s]" in head
    assert (tmp_path / "links.png").stat().st_size > 20_000


def test_cjk_glyphs_are_drawn_not_boxes():
    """Two different characters drawn with the configured fonts differ; with DejaVu Sans
    alone both are the same empty box."""
    need_cjk_font()
    fams = fonts.configure()
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Glyph", category=UserWarning)  # on purpose
        boxes = [render(ch, ["DejaVu Sans"]) for ch in "码头"]

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "Glyph missing" with the fallback in place
        drawn = [render(ch, fams) for ch in "码头"]
        render("クランク 크랭크", fams)
    assert np.array_equal(boxes[0], boxes[1])
    assert not np.array_equal(drawn[0], drawn[1])
    assert fonts.missing_characters(["码头吊车机构", "クランク", "크랭크"]) == []


def test_cyrillic_needs_no_extra_font():
    assert fonts.missing_characters(["Кривошип", "шатун", "ползун"]) == []


def test_without_a_cjk_font_one_note_says_what_to_install(monkeypatch, capsys):
    monkeypatch.setattr(fonts, "FALLBACKS", ())
    monkeypatch.setattr(fonts, "_state", {"families": None, "charmaps": None, "noted": set()})
    import matplotlib

    monkeypatch.setitem(matplotlib.rcParams, "font.family", ["sans-serif"])
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plt = fonts.pyplot(["码头吊车机构", "曲柄"])
        fonts.pyplot(["码头吊车机构", "曲柄"])  # the same names: no second note
        fig, ax = plt.subplots()
        ax.set_title("码头吊车机构")
        fig.canvas.draw()
        plt.close(fig)
    err = capsys.readouterr().err
    assert err.count("note:") == 1 and "fonts-noto-cjk" in err and "码头吊车机构" in err
    assert not [w for w in caught if "Glyph" in str(w.message)]


def test_names_in_any_script_in_conditions_and_requirements():
    text = (MECH / "crane-zh.yaml").read_text(encoding="utf-8")
    text += (
        "\nrequirements:\n  臂架摆角: 臂架.swing >= 40 deg\n  转速: max(曲柄.omega) > 0.1 rad/s\n"
    )
    mech = ms.loads(text)
    from mechsolve.results.requirements import check_requirements

    v = check_requirements(mech, ms.solve(mech))
    assert [x.passed for x in v] == [True, True], [x.message for x in v]


def test_svg_plots_keep_names_as_text(tmp_path):
    """--format svg: every plot as SVG whose text is text (a browser draws the names with
    its own fonts, whatever this machine has)."""
    from click.testing import CliRunner

    from mechsolve.cli.main import main

    r = CliRunner().invoke(
        main, ["run", str(MECH / "crane-zh.yaml"), "--format", "svg", "-o", str(tmp_path), "-q"]
    )
    assert r.exit_code == 0, r.output
    svgs = sorted(p.name for p in tmp_path.glob("*.svg"))
    assert "links.svg" in svgs and "torque.svg" in svgs and not list(tmp_path.glob("*.png"))
    import xml.etree.ElementTree as ET

    root = ET.parse(tmp_path / "links.svg").getroot()
    texts = "".join(t.text or "" for t in root.iter("{http://www.w3.org/2000/svg}text"))
    assert "码头吊车机构" in texts and "曲柄" in texts
