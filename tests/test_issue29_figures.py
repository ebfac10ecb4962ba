"""Issue 29, report-ready figures: each property checked on its own, from the figure's
artists (what matplotlib draws) or the written file, against what the drawing must be:
a jump is a gap (NaN) and never a chord; a force scale is 1, 2 or 5 times a power of
ten; no two labels overlap; the cam's sheet has no blank half; a study's axes name
quantities, not key paths, and draw the requirements' limits; the HTML report fits a
1280 px window and names its input without an absolute path; an animation draws the
loads and labels its arrows."""

from __future__ import annotations

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
