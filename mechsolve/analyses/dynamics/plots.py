"""Plots of a simulated motion (``mechsolve simulate``): the driver's speed with its mean
over each revolution, its acceleration, the motor's torque with its mean, the reduced
inertia J(phi) and J'(phi) over a turn, and the reaction magnitudes over time."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.writers.fonts import pyplot
from mechsolve.writers.plots import break_at_switches

if TYPE_CHECKING:
    from mechsolve.analyses.dynamics import ReducedModel, SimulationResults


def _save(fig, path: Path) -> Path:
    from mechsolve.writers.plots import save_figure

    save_figure(fig, path, 100)  # atomic, under a unique temporary name
    return path


def revolution_means(t: np.ndarray, phi: np.ndarray, w: np.ndarray):
    """(t, mean speed) over each full revolution of the driver (time mean)."""
    turns = np.floor(np.abs(phi - phi[0]) / (2 * math.pi))
    out_t, out_w = [], []
    for k in np.unique(turns)[:-1]:
        sel = turns == k
        ts, ws = t[sel], w[sel]
        if len(ts) > 1 and ts[-1] > ts[0]:
            out_t.append(0.5 * (ts[0] + ts[-1]))
            out_w.append(float(np.trapezoid(ws, ts) / (ts[-1] - ts[0])))
    return np.array(out_t), np.array(out_w)


def write_simulation_plots(res: SimulationResults, model: ReducedModel, outdir) -> list[Path]:
    from mechsolve.writers.plots import names_of

    plt = pyplot(names_of(res.mechanism))

    outdir = Path(outdir)
    tr = res.trajectory
    name = res.mechanism.name
    lin = res.linear
    wu, au = ("m/s", "m/s^2") if lin else ("rad/s", "rad/s^2")
    out = []

    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    axes[0].plot(tr.t, tr.omega, lw=1.2, label="speed")
    tm, wm = revolution_means(tr.t, tr.phi, tr.omega)
    if len(tm):
        axes[0].plot(tm, wm, "o-", ms=3, color="C3", label="time mean over each revolution")
    axes[0].set_ylabel(f"driver speed [{wu}]")
    axes[0].legend(loc="lower right", fontsize=8)
    axes[1].plot(tr.t, tr.eps, lw=1.0, color="C1")
    axes[1].set_ylabel(f"driver acceleration [{au}]")
    M = res.motor_torque()
    axes[2].plot(tr.t, M, lw=1.2, color="C2", label="motor")
    mean, unit = res.time_mean(M), ("N" if lin else "N*m")  # the summary's mean
    axes[2].axhline(mean, ls="--", color="C3", label=f"time mean {mean:.6g} {unit}")
    axes[2].set_ylabel(f"motor force [{unit}]" if lin else f"motor torque [{unit}]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="upper right", fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title(f"{name}: simulated motion")
    fig.tight_layout()
    out.append(_save(fig, outdir / "simulation-motion.png"))
    plt.close(fig)

    if not lin:
        phi, J, dJ = model.inertia_curve()
        fig, ax = plt.subplots(figsize=(10, 4.5))
        x = np.degrees(np.abs(phi - phi[0]))
        ax.plot(x, J, label="J [kg*m^2]")
        ax.plot(x, dJ, label="J' [kg*m^2/rad]")
        ax.set_xlabel("driver angle travelled from the start [deg]")
        ax.set_ylabel("reduced moment of inertia J [kg*m^2], J' [kg*m^2/rad]")
        ax.set_title(f"{name}: reduced moment of inertia over a turn")
        ax.grid(alpha=0.3)
        ax.legend()
        fig.tight_layout()
        out.append(_save(fig, outdir / "simulation-inertia.png"))
        plt.close(fig)

    if res.forces is not None:
        fig, ax = plt.subplots(figsize=(10, 4.5))
        for j, comp in res.forces.reactions.items():
            F = comp.get("F")
            if F is not None:  # a load switching on or off: a gap, not a slope
                ax.plot(*break_at_switches(res.forces.active, tr.t, F), lw=1.0, label=j)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("reaction magnitude [N]")
        ax.set_title(f"{name}: joint reactions along the motion")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, ncol=4)
        fig.tight_layout()
        out.append(_save(fig, outdir / "simulation-reactions.png"))
        plt.close(fig)
    return out


def write_energy_plot(sizing, name: str, outdir) -> Path:
    """The energy excursion over the cycle (the flywheel's energy method)."""
    plt = pyplot([name])

    x = np.degrees(np.abs(sizing.phi - sizing.phi[0]))
    fig, axes = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    axes[0].plot(x, sizing.torque, label=sizing.torque_label)
    axes[0].axhline(sizing.motor_torque, ls="--", color="C3", label=sizing.constant_label)
    axes[0].set_ylabel("torque [N*m]")
    axes[0].legend(fontsize=8)
    axes[1].plot(x, sizing.energy, color="C2")
    axes[1].set_ylabel("energy excursion dE [J]")
    axes[1].set_xlabel("driver angle travelled from the start [deg]")
    k_hi, k_lo = int(np.argmax(sizing.energy)), int(np.argmin(sizing.energy))
    axes[1].plot([x[k_hi], x[k_lo]], [sizing.energy[k_hi], sizing.energy[k_lo]], "o", color="C3")
    axes[1].set_title(f"dE_max = {sizing.energy_max:.6g} J; J_F = {sizing.J_flywheel:.6g} kg*m^2")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title(f"{name}: flywheel by the energy method, delta = {sizing.delta:.4g}")
    fig.tight_layout()
    out = _save(fig, Path(outdir) / "flywheel.png")
    plt.close(fig)
    return out


def write_energy_mass_plot(sizing, name: str, outdir) -> Path | None:
    """The energy-mass (Wittenbauer) diagram: the work W(phi) against the reduced inertia
    J(phi), with the lines of slopes omega_max^2 / 2 and omega_min^2 / 2 that touch it."""
    if sizing.energy_mass is None:
        return None
    plt = pyplot([name])

    J, W = sizing.energy_mass
    w, dl = sizing.omega_mean, sizing.delta
    fig, ax = plt.subplots(figsize=(8, 6))
    ax.plot(J, W, color="C0", label="W(phi) against J(phi) over a turn")
    for w2, col, lab in (
        ((w * (1 + dl / 2)) ** 2, "C3", "max"),
        ((w * (1 - dl / 2)) ** 2, "C2", "min"),
    ):
        c = 0.5 * w2 * J - W  # the touching line: W = 1/2 w2 (J + J_F) - T0
        k = int(np.argmin(c)) if lab == "max" else int(np.argmax(c))
        jj = np.linspace(np.min(J), np.max(J), 50)
        ax.plot(
            jj, W[k] + 0.5 * w2 * (jj - J[k]), "--", color=col, label=f"slope omega_{lab}^2 / 2"
        )
    ax.set_xlabel("reduced moment of inertia J [kg*m^2]")
    ax.set_ylabel("work of the motor and the loads W [J]")
    ax.set_title(f"{name}\nenergy-mass diagram: J_F = {sizing.J_exact:.6g} kg*m^2", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    out = _save(fig, Path(outdir) / "energy-mass.png")
    plt.close(fig)
    return out
