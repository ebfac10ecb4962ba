"""Plots are drawn from a fine sweep with the exact events, whatever the file's step."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from click.testing import CliRunner

import mechsolve as ms
from mechsolve.api import for_plots
from mechsolve.cli.main import main

from conftest import MECH


def test_a_coarse_table_is_plotted_from_a_fine_sweep_with_exact_limits(tmp_path):
    """The crane's file steps 10 deg: the plots' sweep is 1 deg plus the jib's exact limit
    positions, and its torque peak is the true one (a 0.05 deg sweep's) where the table's
    samples miss it; the CSV keeps the file's 37 rows."""
    mech = ms.load(MECH / "crane.yaml")
    res = ms.solve(mech)
    fine = for_plots(mech, res)
    assert len(res.u) == 37 and len(fine.u) >= 361
    got = {lp.name: lp for lp in fine.limit_positions()}
    for lp in res.limit_positions():  # the same extremes, sampled exactly
        assert got[lp.name].low == pytest.approx(lp.low, abs=1e-12)
        assert got[lp.name].high == pytest.approx(lp.high, abs=1e-12)
        for u in (got[lp.name].u_low, got[lp.name].u_high):
            assert np.min(np.abs(fine.u - u)) < 1e-12
    dense = ms.solve(ms.load(MECH / "crane.yaml"), step=math.radians(0.05))
    peak = np.nanmax(np.abs(dense.driving_effort))
    assert np.nanmax(np.abs(res.driving_effort)) < peak * 0.999  # the table misses it
    assert np.nanmax(np.abs(fine.driving_effort)) > peak * (1 - 2e-4)
    r = CliRunner().invoke(main, ["run", str(MECH / "crane.yaml"), "-o", str(tmp_path)])
    assert r.exit_code == 0, r.output
    with open(tmp_path / "results.csv") as fh:
        assert sum(1 for _ in csv.reader(fh)) == 1 + 37


def test_a_load_switch_is_a_jump_at_its_exact_angle():
    """The shaper's cutting force starts and stops at 5 % and 95 % of the ram's stroke
    (moving right): the plots' sweep has samples 2e-9 rad apart on both sides of each
    switch, where the ram's stroke fraction (from its own extremes) is 0.05 and 0.95,
    and the torque jumps between them by the cutting force's share."""
    mech = ms.load(MECH / "shaper.yaml")
    res = ms.solve(mech)
    fine = for_plots(mech, res)
    on = fine.forces.active["cutting"]
    k = np.flatnonzero(on[1:] != on[:-1])
    assert len(k) == 2
    assert np.all(np.abs(fine.u[k + 1] - fine.u[k]) < 3e-9)
    x = fine.point("C").x
    lo, hi = np.nanmin(x), np.nanmax(x)
    assert hi - lo == np.float64(hi - lo)
    frac = (x[k] - lo) / (hi - lo)
    np.testing.assert_allclose(np.sort(frac), [0.05, 0.95], atol=2e-5)
    jump = np.abs(fine.driving_effort[k + 1] - fine.driving_effort[k])
    assert np.all(jump > 300)  # N m: 7000 N times the ram's speed ratio there
