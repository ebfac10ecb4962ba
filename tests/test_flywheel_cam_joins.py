"""The flywheel of a cam linkage integrates its torque piecewise between the cam program's
joins, where the torque jumps (the follower's acceleration jumps there): the energy
excursion equals the range of the driver's cumulative work T + V - W_loads along the
motion (the energy balance, integrated here on a 0.005 deg sweep, where every term is
continuous), and the motor torque of this conservative cycle is zero. Integrating across
the jumps gave 3.2563 J (1.4e-4 high) and a motor torque of -0.238 N mm."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mechsolve as ms
from mechsolve.analyses.flywheel import size_flywheel
from mechsolve.model.parse import load

CAM = Path(__file__).resolve().parents[1] / "mechanisms" / "cam-linkage.yaml"


def test_energy_excursion_across_cam_joins():
    fine = load(CAM)
    fine.sweep.step = np.radians(0.005)
    r = ms.solve(fine)
    assert r.ok.all()
    f = r.forces
    t = r.solution.t
    pl = f.power_loads
    w_loads = np.concatenate([[0.0], np.cumsum(0.5 * (pl[1:] + pl[:-1]) * np.diff(t))])
    e = f.kinetic + f.potential - w_loads  # the driver's cumulative work at constant speed
    expected = float(e.max() - e.min())
    peak = float(np.max(np.abs(r.driving_effort)))

    out = size_flywheel(load(CAM), 0.025, check=False)
    assert abs(out.energy_max - expected) <= 1e-6 * expected, (out.energy_max, expected)
    assert abs(out.motor_torque) <= 1e-9 * peak, out.motor_torque
