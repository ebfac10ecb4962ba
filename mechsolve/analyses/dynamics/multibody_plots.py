"""Plots of a motion integrated in body coordinates (``mechsolve simulate``'s general
path): the driver coordinate and its rate, the energies with their balance, and the
constraint violation over time; every axis in the units of the command's table (an
:class:`~mechsolve.base.units.OutputUnits`, SI by default). Legends stand beside their
axes, placed at once: Matplotlib's ``loc="best"`` searched a long simulation's samples
for a free corner, which took seconds and printed its UserWarning on stderr."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.analyses.dynamics.plots import _BESIDE
from mechsolve.base.units import SI_OUTPUT, OutputUnits
from mechsolve.writers.fonts import pyplot
from mechsolve.writers.plots import shown

if TYPE_CHECKING:
    from mechsolve.analyses.dynamics.multibody_run import MultibodyResults


def write_multibody_plots(
    res: MultibodyResults, outdir, units: OutputUnits = SI_OUTPUT
) -> list[Path]:
    """``simulation-motion.png`` and ``simulation-energy.png`` in ``outdir``, in
    ``units``."""
    from mechsolve.writers.plots import names_of, save_figure

    plt = pyplot(names_of(res.mechanism))
    outdir = Path(outdir)
    tr = res.trajectory
    lin = getattr(res, "linear", False)
    name = res.mechanism.name
    out = []
    U = units
    t, tu = shown(U, tr.t, "s")

    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    if tr.u is None:  # placed by its pose: every link's angle and rates
        mb = res.multibody
        for lk in res.mechanism.links:
            k = 3 * mb.system.index[lk.name] + 2
            axes[0].plot(t, shown(U, np.degrees(tr.q[:, k]), "deg")[0], lw=1.2, label=lk.name)
            axes[1].plot(t, shown(U, tr.qd[:, k], "rad/s")[0], lw=1.2)
            axes[2].plot(t, shown(U, tr.qdd[:, k], "rad/s^2")[0], lw=1.0)
        axes[0].legend(fontsize=8, **_BESIDE)
        axes[0].set_ylabel(f"link angle [{shown(U, 0.0, 'deg')[1]}]")
        axes[1].set_ylabel(f"angular speed [{shown(U, 0.0, 'rad/s')[1]}]")
        axes[2].set_ylabel(f"angular acceleration [{shown(U, 0.0, 'rad/s^2')[1]}]")
    else:
        u, uu = shown(U, tr.u, "m") if lin else shown(U, np.degrees(tr.u), "deg")
        axes[0].plot(t, u, lw=1.2)
        axes[0].set_ylabel(f"{res.mechanism.driver.joint} [{uu}]")
        ud, udu = shown(U, tr.ud, "m/s" if lin else "rad/s")
        axes[1].plot(t, ud, lw=1.2, color="C1")
        axes[1].set_ylabel(f"its rate [{udu}]")
        udd, uddu = shown(U, tr.udd, "m/s^2" if lin else "rad/s^2")
        axes[2].plot(t, udd, lw=1.0, color="C2")
        axes[2].set_ylabel(f"its acceleration [{uddu}]")
    axes[2].set_xlabel(f"t [{tu}]")
    axes[0].set_title(f"{name}: motion (multibody)")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()  # room for the legend beside the axes
    path = outdir / "simulation-motion.png"
    save_figure(fig, path, 100)
    plt.close(fig)
    out.append(path)

    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    kE, eu = shown(U, 1.0, "J")
    axes[0].plot(t, tr.kinetic * kE, label="kinetic T")
    axes[0].plot(t, (tr.potential - tr.potential[0]) * kE, label="potential V - V0")
    axes[0].plot(t, tr.work * kE, label="work of the other forces W")
    axes[0].set_ylabel(f"energy [{eu}]")
    axes[0].legend(fontsize=8, **_BESIDE)
    axes[1].plot(t, tr.energy_residual * kE, color="C3")
    axes[1].set_ylabel(f"T + V - W - (T0 + V0) [{eu}]")
    pos, pu = shown(U, np.maximum(tr.violation, 1e-300), "m")
    vel, vu = shown(U, np.maximum(tr.velocity_violation, 1e-300), "m/s")
    axes[2].semilogy(t, pos, label=f"position [{pu}]")
    axes[2].semilogy(t, vel, label=f"velocity [{vu}]")
    axes[2].set_ylabel("largest constraint violation")
    axes[2].legend(fontsize=8, **_BESIDE)
    axes[2].set_xlabel(f"t [{tu}]")
    axes[0].set_title(f"{name}: energy balance and constraints")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    path = outdir / "simulation-energy.png"
    save_figure(fig, path, 100)
    plt.close(fig)
    out.append(path)
    return out
