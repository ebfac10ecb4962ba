"""Issue 29: the figures of ``simulate``, ``flywheel``, ``shaking``, ``compare``,
``polygons`` and ``animate`` are drawn in the units their tables use (the file's by
default, ``--units`` when given), as ``run``'s are.

Each test captures the matplotlib figures a command saves and compares what is drawn
(a line's data, or the tick labels against the tick positions) with the same command's
``--units SI`` figure multiplied by a factor written out here by hand (1 mm = 1e-3 m,
1 deg = pi/180 rad, 1 N*mm = 1e-3 N*m, 1 kN = 1e3 N), not by mechsolve's unit table;
and checks that each axis names the unit.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve.writers.plots as plots
from mechsolve.cli.main import main

MECH = Path(__file__).resolve().parent.parent / "mechanisms"

MM = 1e-3  # m
DEG = math.pi / 180  # rad
NMM = 1e-3  # N*m
_PRETTY = plots.pretty_figure


def _figures(monkeypatch, *args: str) -> list:
    """The figures the command ``args`` saves, in the order saved (their texts as
    written: the report's units, ``N·mm``)."""
    figs = []
    real = _PRETTY  # the function itself, not a spy of an earlier call

    def keep(fig):
        real(fig)
        if fig not in figs:  # a figure saved twice (png and svg) counts once
            figs.append(fig)

    monkeypatch.setattr(plots, "pretty_figure", keep)
    r = CliRunner().invoke(main, list(args))
    assert r.exit_code == 0, r.output
    assert figs
    return figs


def _by_title(figs, words: str):
    """The figure whose axes' or suptitle's text contains ``words``."""
    for f in figs:
        texts = [a.get_title() for a in f.axes]
        if f._suptitle is not None:
            texts.append(f._suptitle.get_text())
        if any(words in t for t in texts):
            return f
    raise AssertionError(f"no figure titled {words!r}")


def _y(ax, k: int = 0) -> np.ndarray:
    return np.asarray(ax.get_lines()[k].get_ydata(), float)


def _x(ax, k: int = 0) -> np.ndarray:
    return np.asarray(ax.get_lines()[k].get_xdata(), float)


def _same(shown, si, factor: float) -> None:
    np.testing.assert_allclose(shown, np.asarray(si) * factor, rtol=1e-12, atol=1e-300)


def _tick_values(axis) -> list[tuple[float, float]]:
    """(the label read as a number, the tick's position) of each labelled tick."""
    axis.axes.figure.canvas.draw()
    labels = [t.get_text().replace("\u2212", "-") for t in axis.get_ticklabels()]
    return [(float(t), v) for t, v in zip(labels, axis.get_ticklocs()) if t]


# --- simulate -----------------------------------------------------------------------------


def test_simulate_figures_in_the_files_units(monkeypatch, tmp_path):
    """shaper.yaml is in mm and deg: the driver's speed in deg/s, its acceleration in
    deg/s^2 and the motor torque in N*mm (the summary's units); the reactions with a
    force unit given."""
    f = str(MECH / "shaper.yaml")
    mm = _figures(monkeypatch, "simulate", f, "-o", str(tmp_path / "a"), "-q",
                  "--units", "force=kN")  # fmt: skip
    si = _figures(monkeypatch, "simulate", f, "-o", str(tmp_path / "b"), "-q", "--units", "SI")
    m_mm, m_si = (_by_title(x, "simulated motion") for x in (mm, si))
    speed, acc, torque = m_mm.axes
    _same(_y(speed), _y(m_si.axes[0]), 1 / DEG)
    _same(_y(speed, 1), _y(m_si.axes[0], 1), 1 / DEG)  # the mean over each revolution
    _same(_y(acc), _y(m_si.axes[1]), 1 / DEG)
    assert speed.get_ylabel() == "driver speed [°/s]"
    assert acc.get_ylabel() == "driver acceleration [°/s²]"
    assert m_si.axes[0].get_ylabel() == "driver speed [rad/s]"
    assert m_si.axes[2].get_ylabel() == "motor torque [N·m]"
    assert torque.get_ylabel() == "motor torque [kN·mm]"
    _same(_y(torque), _y(m_si.axes[2]), 1 / (1e3 * MM))  # 1 kN*mm = 1 N*m
    _same(_x(torque), _x(m_si.axes[2]), 1.0)  # time stays s
    r_mm, r_si = (_by_title(x, "joint reactions") for x in (mm, si))
    assert r_mm.axes[0].get_ylabel() == "reaction magnitude [kN]"
    assert r_si.axes[0].get_ylabel() == "reaction magnitude [N]"
    _same(_y(r_mm.axes[0]), _y(r_si.axes[0]), 1e-3)
    i_mm, i_si = (_by_title(x, "reduced moment of inertia") for x in (mm, si))
    _same(_y(i_mm.axes[0]), _y(i_si.axes[0]), 1.0)  # J stays kg*m^2


def test_simulate_torque_in_newton_millimetres_by_default(monkeypatch, tmp_path):
    f = str(MECH / "shaper.yaml")
    mm = _figures(monkeypatch, "simulate", f, "-o", str(tmp_path / "a"), "-q")
    si = _figures(monkeypatch, "simulate", f, "-o", str(tmp_path / "b"), "-q", "--units", "SI")
    t_mm = _by_title(mm, "simulated motion").axes[2]
    t_si = _by_title(si, "simulated motion").axes[2]
    assert t_mm.get_ylabel() == "motor torque [N·mm]"
    _same(_y(t_mm), _y(t_si), 1 / NMM)
    _same(_y(t_mm, 1), _y(t_si, 1), 1 / NMM)  # the time mean's line
    mean_si = float(_y(t_si, 1)[0])
    assert t_mm.get_legend().get_texts()[1].get_text() == f"time mean {mean_si / NMM:.6g} N·mm"


def test_multibody_figures_in_the_files_units(monkeypatch, tmp_path):
    """nfourbar-2.yaml (m and deg) is integrated in body coordinates: the driver's angle
    in deg, its rate in deg/s; with a map, the energies in kJ and the constraint
    violation in mm."""
    f = str(MECH / "nfourbar-2.yaml")
    mm = _figures(monkeypatch, "simulate", f, "-o", str(tmp_path / "a"), "-q",
                  "--units", "length=mm,energy=kJ")  # fmt: skip
    si = _figures(monkeypatch, "simulate", f, "-o", str(tmp_path / "b"), "-q", "--units", "SI")
    m_mm, m_si = (_by_title(x, "motion (multibody)") for x in (mm, si))
    assert m_mm.axes[1].get_ylabel() == "its rate [°/s]"
    assert m_si.axes[1].get_ylabel() == "its rate [rad/s]"
    _same(_y(m_mm.axes[1]), _y(m_si.axes[1]), 1 / DEG)
    _same(_y(m_mm.axes[2]), _y(m_si.axes[2]), 1 / DEG)
    _same(_y(m_mm.axes[0]), _y(m_si.axes[0]), 1.0)  # the angle: deg either way
    e_mm, e_si = (_by_title(x, "energy balance") for x in (mm, si))
    assert e_mm.axes[0].get_ylabel() == "energy [kJ]"
    _same(_y(e_mm.axes[0]), _y(e_si.axes[0]), 1e-3)
    _same(_y(e_mm.axes[2]), _y(e_si.axes[2]), 1 / MM)  # the position violation
    assert [t.get_text() for t in e_mm.axes[2].get_legend().get_texts()] == [
        "position [mm]",
        "velocity [mm/s]",
    ]


# --- flywheel -----------------------------------------------------------------------------


def test_flywheel_figures_in_the_files_units(monkeypatch, tmp_path):
    """The torque in N*mm (the summary's motor torque), the energies in the energy unit."""
    f = str(MECH / "shaper.yaml")
    mm = _figures(monkeypatch, "flywheel", f, "-o", str(tmp_path / "a"), "--no-check",
                  "--units", "energy=kJ")  # fmt: skip
    si = _figures(monkeypatch, "flywheel", f, "-o", str(tmp_path / "b"), "--no-check",
                  "--units", "SI")  # fmt: skip
    e_mm, e_si = (_by_title(x, "energy method") for x in (mm, si))
    assert e_mm.axes[0].get_ylabel() == "torque [N·mm]"
    assert e_si.axes[0].get_ylabel() == "torque [N·m]"
    _same(_y(e_mm.axes[0]), _y(e_si.axes[0]), 1 / NMM)
    _same(_y(e_mm.axes[0], 1), _y(e_si.axes[0], 1), 1 / NMM)  # the constant motor torque
    assert e_mm.axes[1].get_ylabel() == "energy excursion dE [kJ]"
    _same(_y(e_mm.axes[1]), _y(e_si.axes[1]), 1e-3)
    _same(_x(e_mm.axes[1]), _x(e_si.axes[1]), 1.0)  # deg either way
    w_mm, w_si = (_by_title(x, "energy-mass") for x in (mm, si))
    assert w_mm.axes[0].get_ylabel() == "work of the motor and the loads W [kJ]"
    for k in range(3):  # the curve and the two touching lines
        _same(_y(w_mm.axes[0], k), _y(w_si.axes[0], k), 1e-3)
        _same(_x(w_mm.axes[0], k), _x(w_si.axes[0], k), 1.0)  # J stays kg*m^2


# --- shaking ------------------------------------------------------------------------------


def test_shaking_figures_in_the_files_units(monkeypatch, tmp_path):
    """fourbar.yaml is in mm and deg: the shaking moment in N*mm (the table's), before
    and after balancing; the force in the force unit asked for."""
    f = str(MECH / "fourbar.yaml")
    mm = _figures(monkeypatch, "shaking", f, "-o", str(tmp_path / "a"), "-q", "--balance")
    kn = _figures(monkeypatch, "shaking", f, "-o", str(tmp_path / "k"), "-q", "--balance",
                  "--units", "force=kN,torque=N*mm")  # fmt: skip
    si = _figures(monkeypatch, "shaking", f, "-o", str(tmp_path / "b"), "-q", "--balance",
                  "--units", "SI")  # fmt: skip
    assert len(mm) == len(si) == len(kn) == 2  # shaking.png and balance.png
    for a, k, b in zip(mm, kn, si):
        force, moment = a.axes
        assert moment.get_ylabel().endswith("[N·mm] (ccw)")
        assert b.axes[1].get_ylabel().endswith("[N·m] (ccw)")
        assert moment.get_xlabel() == "driver angle [°]"
        for line in range(len(moment.get_lines())):  # before and after balancing
            _same(_y(moment, line), _y(b.axes[1], line), 1 / NMM)
            _same(_x(moment, line), _x(b.axes[1], line), 1.0)
        _same(_y(force), _y(b.axes[0]), 1.0)  # N in a mm file: no key names a force unit
        assert force.get_xlabel() == "Fx on the frame [N]"
        assert k.axes[0].get_xlabel() == "Fx on the frame [kN]"
        assert k.axes[0].get_ylabel() == "Fy on the frame [kN]"
        _same(_y(k.axes[0]), _y(b.axes[0]), 1e-3)
        _same(_x(k.axes[0]), _x(b.axes[0]), 1e-3)
        _same(_y(k.axes[1]), _y(b.axes[1]), 1 / NMM)
    peak_si = float(np.nanmax(np.hypot(_x(si[0].axes[0]), _y(si[0].axes[0]))))
    legend = kn[0].axes[0].get_legend().get_texts()[0].get_text()
    assert legend.endswith(f"(peak {peak_si * 1e-3:.4g} kN)"), legend


# --- compare ------------------------------------------------------------------------------


def test_compare_figures_in_the_first_files_units(monkeypatch, tmp_path):
    """The shaper schemes are in mm and deg: the velocities in mm/s and the torques in
    N*mm, as compare.csv and the printed table; the strokes in mm either way (the SI
    table's strokes are in mm too)."""
    files = [str(MECH / f"shaper-scheme{k}.yaml") for k in (2, 3)]
    mm = _figures(monkeypatch, "compare", *files, "-o", str(tmp_path / "a"), "-q")
    si = _figures(monkeypatch, "compare", *files, "-o", str(tmp_path / "b"), "-q",
                  "--units", "SI")  # fmt: skip
    v_mm, v_si = (_by_title(x, "Output velocity").axes[0] for x in (mm, si))
    t_mm, t_si = (_by_title(x, "Driving torque").axes[0] for x in (mm, si))
    d_mm, d_si = (_by_title(x, "Output displacement").axes[0] for x in (mm, si))
    assert v_mm.get_ylabel() == "output velocity along the working stroke [mm/s]"
    assert v_si.get_ylabel() == "output velocity along the working stroke [m/s]"
    assert t_mm.get_ylabel() == "driving torque along the crank's motion [N·mm]"
    assert t_si.get_ylabel() == "driving torque along the crank's motion [N·m]"
    assert d_mm.get_ylabel() == d_si.get_ylabel()
    assert d_mm.get_ylabel().endswith("[mm]")
    assert v_mm.get_xlabel() == "crank angle from the start of the working stroke [°]"
    for k in range(2):  # one line per scheme
        _same(_y(v_mm, k), _y(v_si, k), 1 / MM)
        _same(_y(t_mm, k), _y(t_si, k), 1 / NMM)
        _same(_y(d_mm, k), _y(d_si, k), 1.0)
        _same(_x(t_mm, k), _x(t_si, k), 1.0)
    # the dotted band: the printed "velocity range there", in mm/s
    bands = [c for c in v_mm.collections if len(c.get_segments()) == 2]
    assert bands
    bands_si = [c for c in v_si.collections if len(c.get_segments()) == 2]
    for a, b in zip(bands, bands_si):
        ya = [seg[0][1] for seg in a.get_segments()]
        yb = [seg[0][1] for seg in b.get_segments()]
        _same(ya, yb, 1 / MM)


# --- polygons -----------------------------------------------------------------------------


def _mu(title: str) -> float:
    """The scale a polygon's (or the mechanism's) title states: ``μv = 0.2 (mm/s)/mm``."""
    return float(title.split(" = ")[1].split()[0])


def test_polygons_figures_in_the_files_units(monkeypatch, tmp_path):
    """fourbar.yaml is in mm: the mechanism's axes in mm, the polygons' scales and vector
    axes in mm/s and mm/s^2 (polygons.txt's units); the polygons themselves, drawn in mm
    of the drawing, are the same."""
    f = str(MECH / "fourbar.yaml")
    mm = _figures(monkeypatch, "polygons", f, "--at", "2", "-o", str(tmp_path / "a"), "-q")
    si = _figures(monkeypatch, "polygons", f, "--at", "2", "-o", str(tmp_path / "b"), "-q",
                  "--units", "SI")  # fmt: skip
    sheet_mm, sheet_si = mm[-1], si[-1]  # the sheet: the mechanism beside both polygons
    mech_mm, mech_si = sheet_mm.axes[0], sheet_si.axes[0]
    assert (mech_mm.get_xlabel(), mech_mm.get_ylabel()) == ("x [mm]", "y [mm]")
    assert (mech_si.get_xlabel(), mech_si.get_ylabel()) == ("x [m]", "y [m]")
    for axis in (mech_mm.xaxis, mech_mm.yaxis):  # a label is its tick's position (m) in mm
        ticks = _tick_values(axis)
        assert len(ticks) >= 3
        for text, loc in ticks:
            assert text == pytest.approx(loc / MM, abs=1e-9)
    for text, loc in _tick_values(mech_si.xaxis):
        assert abs(text - loc) < 1e-12
    assert _mu(mech_mm.get_title()) == _mu(mech_si.get_title()) / MM
    assert mech_mm.get_title().endswith("mm/mm")
    for k, unit in ((1, "mm/s"), (2, "mm/s²")):
        p_mm, p_si = sheet_mm.axes[k], sheet_si.axes[k]
        assert p_mm.get_xlim() == p_si.get_xlim()  # the same drawing, in mm of paper
        mu_si = _mu(p_si.get_title())  # (m/s)/mm or (m/s^2)/mm
        assert _mu(p_mm.get_title()) == pytest.approx(mu_si / MM, rel=1e-12)
        assert p_mm.get_title().endswith(f"({unit})/mm")
        top, right = p_mm.child_axes
        assert top.get_xlabel().endswith(f"[{unit}]") and right.get_ylabel().endswith(f"[{unit}]")
        sheet_mm.canvas.draw()
        np.testing.assert_allclose(top.get_xlim(), np.array(p_mm.get_xlim()) * mu_si / MM)
        np.testing.assert_allclose(right.get_ylim(), np.array(p_mm.get_ylim()) * mu_si / MM)
    # the separate polygon drawings say the same
    assert _mu(mm[0].axes[0].get_title()) == _mu(sheet_mm.axes[1].get_title())


# --- animate ------------------------------------------------------------------------------


def _animated(monkeypatch, tmp_path: Path, *args: str):
    """(frames, figure) of ``mechsolve animate`` on fourbar.yaml (mm), 6 frames."""
    import mechsolve.report.animate as animate

    kept = []
    real = animate._render

    def spy(fr, fig):
        kept.append((fr, fig))
        yield from real(fr, fig)

    monkeypatch.setattr(animate, "_render", spy)
    out = tmp_path / f"a{len(list(tmp_path.iterdir()))}.gif"
    r = CliRunner().invoke(
        main, ["animate", str(MECH / "fourbar.yaml"), "-o", str(out), "--frames", "6", *args]
    )
    assert r.exit_code == 0, r.output
    assert out.exists() and len(kept) == 1
    return kept[0]


def _scale_bar(ax) -> tuple[float, float, str, float, str]:
    """(the bar's drawn length in m, its length as read, its unit, the force as read,
    its unit) of the force scale bar."""
    import re

    bar_text = re.compile(r"([\d.e+-]+) (\w+) = ([\d.e+-]+) (\w+)")
    (m,) = [m for t in ax.texts if (m := bar_text.fullmatch(t.get_text()))]
    (bar,) = [ln for ln in ax.get_lines() if ln.get_linewidth() == 2 and ln.get_color() == "k"]
    xs = bar.get_xdata()
    return float(xs[1] - xs[0]), float(m[1]), m[2], float(m[3]), m[4]


def test_animate_axes_and_scale_in_the_files_units(monkeypatch, tmp_path):
    """fourbar.yaml is in mm: the axes read mm (the tick labels are the tick positions,
    metres inside, times 1000); with a map the scale bar reads cm and kN, and stands for
    the same force per metre of arrow as the SI one."""
    fr_mm, fig_mm = _animated(monkeypatch, tmp_path)
    fr_si, fig_si = _animated(monkeypatch, tmp_path, "--units", "SI")
    fr_cm, fig_cm = _animated(monkeypatch, tmp_path, "--units", "length=cm,force=kN")
    ax_mm, ax_si, ax_cm = fig_mm.axes[0], fig_si.axes[0], fig_cm.axes[0]
    assert (ax_mm.get_xlabel(), ax_mm.get_ylabel()) == ("x [mm]", "y [mm]")
    assert (ax_si.get_xlabel(), ax_si.get_ylabel()) == ("x [m]", "y [m]")
    assert ax_cm.get_xlabel() == "x [cm]"
    for axis in (ax_mm.xaxis, ax_mm.yaxis):
        ticks = _tick_values(axis)
        assert len(ticks) >= 3
        for text, loc in ticks:
            assert text == pytest.approx(loc / MM, abs=1e-9)
    for text, loc in _tick_values(ax_cm.xaxis):
        assert text == pytest.approx(loc * 100, abs=1e-9)
    for text, loc in _tick_values(ax_si.xaxis):
        assert text == pytest.approx(loc, abs=1e-12)
    drawn_mm, read_mm, unit_mm, force_mm, f_unit_mm = _scale_bar(ax_mm)
    assert (unit_mm, f_unit_mm) == ("mm", "N") and read_mm == pytest.approx(drawn_mm / MM)
    drawn_si, read_si, unit_si, force_si, f_unit_si = _scale_bar(ax_si)
    assert f_unit_si == "N"
    drawn_cm, read_cm, unit_cm, force_cm, f_unit_cm = _scale_bar(ax_cm)
    assert (unit_cm, f_unit_cm) == ("cm", "kN") and read_cm == pytest.approx(drawn_cm * 100)
    # one arrow scale: metres of arrow per newton, whatever the units it is read in
    assert drawn_cm / (force_cm * 1e3) == pytest.approx(drawn_si / force_si, rel=1e-12)
    assert drawn_mm / force_mm == pytest.approx(drawn_si / force_si, rel=1e-12)
    # the load's tag: 2 N as the force unit reads it
    from mechsolve.report.animate import arrow_labels

    assert arrow_labels(fr_cm)["pull"] == "pull 0.002 kN"
    assert arrow_labels(fr_mm)["pull"] == "pull 2 N"
    # the HTML player's texts (its coordinates stay metres, unlabelled)
    js = fr_cm.to_json()
    assert js["bar"]["text"] == f"{read_cm:g} cm = {force_cm:g} kN"
    assert js["loads"]["pull"]["text"] == "pull 0.002 kN"
    assert js["bounds"] == fr_si.to_json()["bounds"]


# --- report -------------------------------------------------------------------------------


def test_report_polygons_drawn_in_the_files_units(monkeypatch, tmp_path):
    """The report's polygons are drawn in the units of its text, as ``polygons``'s."""
    f = str(MECH / "fourbar.yaml")
    mm = _figures(monkeypatch, "report", f, "-o", str(tmp_path / "a.html"), "--frames", "3")
    titles = [a.get_title() for fig in mm for a in fig.axes]
    mu_v = [t for t in titles if t.startswith("velocity polygon")]
    assert mu_v and all(t.endswith("(mm/s)/mm") for t in mu_v), titles
    mech = [t for t in titles if t.startswith("mechanism, μl")]
    assert mech and all(t.endswith(" mm/mm") for t in mech), titles


def test_report_start_up_plots_in_the_files_units(monkeypatch, tmp_path):
    """The report's start-up plots are in the units of its start-up summary."""
    f = str(MECH / "shaper.yaml")
    figs = _figures(monkeypatch, "report", f, "-o", str(tmp_path / "a.html"), "--frames", "3")
    speed, _, torque = _by_title(figs, "simulated motion").axes
    assert speed.get_ylabel() == "driver speed [°/s]"
    assert torque.get_ylabel() == "motor torque [N·mm]"
