"""Plots of a simulated motion (``mechsolve simulate``): the driver's speed with its mean
over each revolution, its acceleration, the motor's torque with its mean, the reduced
inertia J(phi) and J'(phi) over a turn, and the reaction magnitudes over time; and the
flywheel's energy figures (``mechsolve flywheel``).

Every axis is in the units the command's tables use (an
:class:`~mechsolve.base.units.OutputUnits`, SI by default): the results stay SI and are
converted here, where they are drawn (:func:`mechsolve.writers.plots.shown`). Inertias
stay kg·m², as ``units:`` has no key for them."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.units import SI_OUTPUT, OutputUnits
from mechsolve.writers.fonts import pyplot
from mechsolve.writers.plots import break_at_switches, shown

if TYPE_CHECKING:
    from mechsolve.analyses.dynamics import ReducedModel, SimulationResults


def _save(fig, path: Path) -> Path:
    from mechsolve.writers.plots import save_figure

    save_figure(fig, path, 100)  # atomic, under a unique temporary name
    return path


# a legend beside the axes, at their top right: it hides no curve, and it is placed at
# once (loc="best" searches the curves for a free corner, which over the hundreds of
# thousands of samples of a long simulation takes seconds and makes Matplotlib warn)
_BESIDE = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "borderaxespad": 0.0}


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


def write_simulation_plots(
    res: SimulationResults, model: ReducedModel, outdir, units: OutputUnits = SI_OUTPUT
) -> list[Path]:
    """``simulation-motion.png``, ``simulation-inertia.png`` (a revolute driver) and
    ``simulation-reactions.png`` (with forces) in ``outdir``, in ``units``."""
    from mechsolve.writers.plots import names_of

    U = units

    plt = pyplot(names_of(res.mechanism))

    outdir = Path(outdir)
    tr = res.trajectory
    name = res.mechanism.name
    lin = res.linear
    t, tu = shown(U, tr.t, "s")
    out = []

    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    w, wu = shown(U, tr.omega, "m/s" if lin else "rad/s")
    axes[0].plot(t, w, lw=1.2, label="speed")
    tm, wm = revolution_means(tr.t, tr.phi, tr.omega)
    if len(tm):
        axes[0].plot(shown(U, tm, "s")[0], shown(U, wm, "m/s" if lin else "rad/s")[0], "o-",
                     ms=3, color="C3", label="time mean over each revolution")  # fmt: skip
    axes[0].set_ylabel(f"driver speed [{wu}]")
    axes[0].legend(loc="lower right", fontsize=8)
    eps, au = shown(U, tr.eps, "m/s^2" if lin else "rad/s^2")
    axes[1].plot(t, eps, lw=1.0, color="C1")
    axes[1].set_ylabel(f"driver acceleration [{au}]")
    M, unit = shown(U, res.motor_torque(), "N" if lin else "N*m")
    axes[2].plot(t, M, lw=1.2, color="C2", label="motor")
    mean = res.time_mean(M)  # the summary's mean, in the shown unit (written as the
    # summary writes it; the figure's texts take the report's symbols when it is saved)
    said = U.convert("N" if lin else "N*m")[1]
    axes[2].axhline(mean, ls="--", color="C3", label=f"time mean {mean:.6g} {said}")
    axes[2].set_ylabel(f"motor force [{unit}]" if lin else f"motor torque [{unit}]")
    axes[2].set_xlabel(f"time [{tu}]")
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
        x, xu = shown(U, np.degrees(np.abs(phi - phi[0])), "deg")
        ax.plot(x, J, label="J [kg*m^2]")
        ax.plot(x, dJ, label="J' [kg*m^2/rad]")
        ax.set_xlabel(f"driver angle travelled from the start [{xu}]")
        ax.set_ylabel("reduced moment of inertia J [kg*m^2], J' [kg*m^2/rad]")
        ax.set_title(f"{name}: reduced moment of inertia over a turn")
        ax.grid(alpha=0.3)
        ax.legend(**_BESIDE)
        fig.tight_layout()
        out.append(_save(fig, outdir / "simulation-inertia.png"))
        plt.close(fig)

    if res.forces is not None:
        fig, ax = plt.subplots(figsize=(10, 4.5))
        for j, comp in res.forces.reactions.items():
            F = comp.get("F")
            if F is not None:  # a load switching on or off: a gap, not a slope
                ax.plot(*break_at_switches(res.forces.active, t, shown(U, F, "N")[0]),
                        lw=1.0, label=j)  # fmt: skip
        ax.set_xlabel(f"time [{tu}]")
        ax.set_ylabel(f"reaction magnitude [{shown(U, 0.0, 'N')[1]}]")
        ax.set_title(f"{name}: joint reactions along the motion")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, **_BESIDE)
        fig.tight_layout()
        out.append(_save(fig, outdir / "simulation-reactions.png"))
        plt.close(fig)
    return out


def write_energy_plot(sizing, name: str, outdir, units: OutputUnits = SI_OUTPUT) -> Path:
    """The energy excursion over the cycle (the flywheel's energy method), in ``units``
    (the flywheel's J_F stays kg·m²)."""
    plt = pyplot([name])
    U = units

    x, xu = shown(U, np.degrees(np.abs(sizing.phi - sizing.phi[0])), "deg")
    fig, axes = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    torque, tu = shown(U, sizing.torque, "N*m")
    axes[0].plot(x, torque, label=sizing.torque_label)
    axes[0].axhline(shown(U, sizing.motor_torque, "N*m")[0], ls="--", color="C3",
                    label=sizing.constant_label)  # fmt: skip
    axes[0].set_ylabel(f"torque [{tu}]")
    axes[0].legend(fontsize=8)
    energy, eu = shown(U, sizing.energy, "J")
    axes[1].plot(x, energy, color="C2")
    axes[1].set_ylabel(f"energy excursion dE [{eu}]")
    axes[1].set_xlabel(f"driver angle travelled from the start [{xu}]")
    k_hi, k_lo = int(np.argmax(energy)), int(np.argmin(energy))
    axes[1].plot([x[k_hi], x[k_lo]], [energy[k_hi], energy[k_lo]], "o", color="C3")
    axes[1].set_title(
        f"dE_max = {U.text(sizing.energy_max, 'J')}; J_F = {sizing.J_flywheel:.6g} kg*m^2"
    )
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title(f"{name}: flywheel by the energy method, delta = {sizing.delta:.4g}")
    fig.tight_layout()
    out = _save(fig, Path(outdir) / "flywheel.png")
    plt.close(fig)
    return out


def write_energy_mass_plot(
    sizing, name: str, outdir, units: OutputUnits = SI_OUTPUT
) -> Path | None:
    """The energy-mass (Wittenbauer) diagram: the work W(phi) against the reduced inertia
    J(phi), with the lines of slopes omega_max^2 / 2 and omega_min^2 / 2 that touch it;
    the work in ``units``' energy unit, J in kg·m²."""
    if sizing.energy_mass is None:
        return None
    plt = pyplot([name])

    J, W = sizing.energy_mass
    kE, eu = shown(units, 1.0, "J")
    w, dl = sizing.omega_mean, sizing.delta
    fig, ax = plt.subplots(figsize=(8, 6))
    ax.plot(J, W * kE, color="C0", label="W(phi) against J(phi) over a turn")
    for w2, col, lab in (
        ((w * (1 + dl / 2)) ** 2, "C3", "max"),
        ((w * (1 - dl / 2)) ** 2, "C2", "min"),
    ):
        c = 0.5 * w2 * J - W  # the touching line: W = 1/2 w2 (J + J_F) - T0
        k = int(np.argmin(c)) if lab == "max" else int(np.argmax(c))
        jj = np.linspace(np.min(J), np.max(J), 50)
        ax.plot(
            jj,
            (W[k] + 0.5 * w2 * (jj - J[k])) * kE,
            "--",
            color=col,
            label=f"slope omega_{lab}^2 / 2",
        )
    ax.set_xlabel("reduced moment of inertia J [kg*m^2]")
    ax.set_ylabel(f"work of the motor and the loads W [{eu}]")
    ax.set_title(f"{name}\nenergy-mass diagram: J_F = {sizing.J_exact:.6g} kg*m^2", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    out = _save(fig, Path(outdir) / "energy-mass.png")
    plt.close(fig)
    return out
