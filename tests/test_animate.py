"""mechsolve animate: frames from a fine sweep, the GIF's frame count, size and timing,
the frames' coordinates against closed forms, MP4 with or without ffmpeg, bad options."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import mechsolve as ms
from mechsolve.cli.commands.animate import animate
from mechsolve.report.animate import fine_step, frames_of, solve_frames

from closed_form import slider_crank
from conftest import MECH, MECHANISMS


def gif(path):
    im = Image.open(path)
    return im, im.n_frames, im.size


@pytest.mark.parametrize("name", MECHANISMS)
def test_every_example_animates(name, tmp_path):
    out = tmp_path / "a.gif"
    r = CliRunner().invoke(
        animate, [str(MECH / name), "-o", str(out), "--frames", "9", "--size", "240x180"]
    )
    assert r.exit_code == 0, r.output
    im, n, size = gif(out)
    assert (n, size) == (9, (240, 180))
    assert "wrote" in r.output and "9 frames" in r.output


def test_default_frames_one_per_degree_whatever_the_step():
    crane = ms.load(MECH / "crane.yaml")  # tabulated every 10 deg
    assert crane.sweep.step == pytest.approx(math.radians(10))
    step, n = fine_step(crane, None)
    assert n == 361 and step == pytest.approx(math.radians(1))
    jib = ms.load(MECH / "crane.yaml", "jib-driven")  # 93 .. 134 deg
    step, n = fine_step(jib, None)
    assert n == 42 and step == pytest.approx(math.radians(1))
    step, n = fine_step(crane, 73)
    assert n == 73 and step == pytest.approx(math.radians(5))


def test_frames_against_the_closed_form_slider_crank():
    """The piston and the crank pin in every frame where the textbook puts them: crank
    r = 50 mm, rod l = 200 mm, the line 10 mm above the pivot, one frame per 10 deg."""
    mech = ms.load(MECH / "slider-crank.yaml")
    fr = solve_frames(mech, 37)
    data = fr.to_json()  # rounded to 1e-5 of the drawing's size (0.3 m)
    th = np.radians(np.arange(37) * 10.0) + mech.driver.start * 1.0
    x, *_ = slider_crank(0.05, 0.2, 0.01, th, 1.0)
    np.testing.assert_allclose(data["points"]["C"][0], x, atol=6e-6)
    np.testing.assert_allclose(data["points"]["C"][1], 0.01, atol=6e-6)
    np.testing.assert_allclose(data["points"]["A"][0], 0.05 * np.cos(th), atol=6e-6)
    np.testing.assert_allclose(data["points"]["A"][1], 0.05 * np.sin(th), atol=6e-6)
    assert len(data["labels"]) == 37
    # the label shows the driver angle and the time (angle / speed)
    w = abs(mech.driver.speed)
    assert data["labels"][9] == f"driver O = 90.0°, t = {math.radians(90) / w:.3f} s"


def test_gif_timing_and_forces(tmp_path):
    """--fps sets each frame's duration; --forces draws red arrows the plain drawing of
    the four-bar (three links, three paths: no red) does not have."""
    plain, forced = tmp_path / "plain.gif", tmp_path / "forces.gif"
    for out, extra in ((plain, []), (forced, ["--forces"])):
        r = CliRunner().invoke(
            animate,
            [str(MECH / "fourbar.yaml"), "-o", str(out), "--frames", "5", "--fps", "20", *extra],
        )
        assert r.exit_code == 0, r.output
    red = np.array([0xD6, 0x27, 0x28])

    def reds(path):
        im = Image.open(path)
        assert im.info["duration"] == 50  # ms: 20 frames per second
        counts = []
        for k in range(im.n_frames):
            im.seek(k)
            a = np.asarray(im.convert("RGB"), int)
            counts.append(int(np.sum(np.all(np.abs(a - red) < 30, axis=2))))
        return counts

    assert max(reds(plain)) == 0
    assert min(reds(forced)) > 50


def test_forces_need_masses_or_loads(tmp_path):
    r = CliRunner().invoke(
        animate, [str(MECH / "sixbar.yaml"), "--forces", "-o", str(tmp_path / "s.gif")]
    )
    assert r.exit_code == 2
    assert "no masses or loads" in r.output
    assert not (tmp_path / "s.gif").exists()


def test_mp4_without_ffmpeg_says_what_to_install(tmp_path, monkeypatch):
    import mechsolve.report.animate as an

    monkeypatch.setattr(an, "ffmpeg_available", lambda: False)
    out = tmp_path / "a.mp4"
    r = CliRunner().invoke(animate, [str(MECH / "fourbar.yaml"), "-o", str(out), "--frames", "6"])
    assert r.exit_code == 2
    assert "ffmpeg" in r.output and "apt-get install ffmpeg" in r.output
    assert ".gif" in r.output
    assert not out.exists()


def test_mp4_with_ffmpeg(tmp_path):
    if shutil.which("ffmpeg") is None:
        if os.environ.get("CI", "").lower() not in ("", "0", "false", "no"):
            pytest.fail("CI must install ffmpeg (.ci/run)")
        pytest.skip("ffmpeg is not installed here")
    out = tmp_path / "a.mp4"
    r = CliRunner().invoke(
        animate, [str(MECH / "fourbar.yaml"), "-o", str(out), "--frames", "6", "--size", "200x150"]
    )
    assert r.exit_code == 0, r.output
    assert out.read_bytes()[4:8] == b"ftyp"
    probe = subprocess.run(
        ["ffmpeg", "-v", "error", "-i", str(out), "-f", "null", "-"], capture_output=True
    )
    assert probe.returncode == 0, probe.stderr  # ffmpeg decodes every frame back


@pytest.mark.parametrize(
    "args, message",
    [
        (["-o", "x.png"], ".gif or .mp4"),
        (["--size", "10"], "--size"),
        (["--frames", "1"], "--frames"),
        (["--fps", "0"], "--fps"),
        (["-o", "no/such/folder/a.gif"], "does not exist"),
    ],
)
def test_bad_options(args, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(animate, [str(MECH / "fourbar.yaml"), *args])
    assert r.exit_code == 2
    assert message in r.output
    assert "Traceback" not in r.output


def test_a_file_that_is_not_a_mechanism(tmp_path):
    r = CliRunner().invoke(animate, [str(MECH / "shaper-cam.yaml"), "-o", str(tmp_path / "a.gif")])
    assert r.exit_code == 2
    assert "mechsolve cam" in r.output


def test_frames_where_it_cannot_close_are_drawn_empty():
    """A four-bar whose coupler (40 mm) is too short to close with the crank away from
    the rocker (|O4A| up to 114 mm > 40 + 59): those frames are marked not solved and
    have no coordinates."""
    text = (MECH / "fourbar.yaml").read_text().replace("B: [105.6, 0]", "B: [40, 0]")
    mech = ms.loads(text)
    res = ms.solve(mech, step=math.radians(10), velocity=False, acceleration=False, forces=False)
    fr = frames_of(res)
    assert not fr.ok.all() and fr.ok.any()
    data = fr.to_json()
    bad = int(np.flatnonzero(~fr.ok)[0])
    assert data["points"]["B"][0][bad] is None
    assert fr.ok[0] and data["points"]["B"][0][0] is not None


def test_real_process(tmp_path):
    out = tmp_path / "crane.gif"
    p = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from mechsolve.cli.commands.animate import animate; "
            "animate.main(sys.argv[1:], prog_name='mechsolve animate')",
            str(MECH / "crane.yaml"),
            "-o",
            str(out),
            "--frames",
            "7",
            "--size",
            "300x200",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 0, p.stderr
    assert "7 frames" in p.stdout
    assert gif(out)[1:] == (7, (300, 200))
