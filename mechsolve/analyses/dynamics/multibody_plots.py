"""Plots of a motion integrated in body coordinates (``mechsolve simulate``'s general
path): the driver coordinate and its rate, the energies with their balance, and the
constraint violation over time."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.writers.fonts import pyplot

if TYPE_CHECKING:
    from mechsolve.analyses.dynamics.multibody_run import MultibodyResults


def write_multibody_plots(res: MultibodyResults, outdir) -> list[Path]:
    """``simulation-motion.png`` and ``simulation-energy.png`` in ``outdir``."""
    from mechsolve.writers.plots import names_of, save_figure

    plt = pyplot(names_of(res.mechanism))
    outdir = Path(outdir)
    tr = res.trajectory
    lin = getattr(res, "linear", False)
    name = res.mechanism.name
    out = []

    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    if tr.u is None:  # placed by its pose: every link's angle and rates
        mb = res.multibody
        for lk in res.mechanism.links:
            k = 3 * mb.system.index[lk.name] + 2
            axes[0].plot(tr.t, np.degrees(tr.q[:, k]), lw=1.2, label=lk.name)
            axes[1].plot(tr.t, tr.qd[:, k], lw=1.2)
            axes[2].plot(tr.t, tr.qdd[:, k], lw=1.0)
        axes[0].legend(fontsize=8)
        axes[0].set_ylabel("link angle [deg]")
        axes[1].set_ylabel("angular speed [rad/s]")
        axes[2].set_ylabel("angular acceleration [rad/s^2]")
    else:
        axes[0].plot(tr.t, tr.u if lin else np.degrees(tr.u), lw=1.2)
        axes[0].set_ylabel(f"{res.mechanism.driver.joint} [{'m' if lin else 'deg'}]")
        axes[1].plot(tr.t, tr.ud, lw=1.2, color="C1")
        axes[1].set_ylabel(f"its rate [{'m/s' if lin else 'rad/s'}]")
        axes[2].plot(tr.t, tr.udd, lw=1.0, color="C2")
        axes[2].set_ylabel(f"its acceleration [{'m/s^2' if lin else 'rad/s^2'}]")
    axes[2].set_xlabel("t [s]")
    axes[0].set_title(f"{name}: motion (multibody)")
    for ax in axes:
        ax.grid(alpha=0.3)
    path = outdir / "simulation-motion.png"
    save_figure(fig, path, 100)
    plt.close(fig)
    out.append(path)

    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    axes[0].plot(tr.t, tr.kinetic, label="kinetic T")
    axes[0].plot(tr.t, tr.potential - tr.potential[0], label="potential V - V0")
    axes[0].plot(tr.t, tr.work, label="work of the other forces W")
    axes[0].set_ylabel("energy [J]")
    axes[0].legend(fontsize=8)
    axes[1].plot(tr.t, tr.energy_residual, color="C3")
    axes[1].set_ylabel("T + V - W - (T0 + V0) [J]")
    axes[2].semilogy(tr.t, np.maximum(tr.violation, 1e-300), label="position [m]")
    axes[2].semilogy(tr.t, np.maximum(tr.velocity_violation, 1e-300), label="velocity [m/s]")
    axes[2].set_ylabel("largest constraint violation")
    axes[2].legend(fontsize=8)
    axes[2].set_xlabel("t [s]")
    axes[0].set_title(f"{name}: energy balance and constraints")
    for ax in axes:
        ax.grid(alpha=0.3)
    path = outdir / "simulation-energy.png"
    save_figure(fig, path, 100)
    plt.close(fig)
    out.append(path)
    return out
