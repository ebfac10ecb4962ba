"""The shaking figures: the polar plot of the shaking force (the path of its vector's tip
over the turn) and the shaking moment against the driver, one sweep or before and after
balancing; in the units of the shaking table (an :class:`~mechsolve.base.units.OutputUnits`,
SI by default)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.units import SI_OUTPUT, OutputUnits
from mechsolve.writers.fonts import pyplot
from mechsolve.writers.plots import names_of, save_figure, shown

if TYPE_CHECKING:
    from mechsolve.analyses.shaking.frame import Shaking


def write_shaking_plot(
    cases: list[tuple[str, Shaking]],
    name: str,
    path: Path,
    title: str = "shaking force",
    units: OutputUnits = SI_OUTPUT,
) -> Path:
    """Left: the tip of the shaking force vector on the frame (Fx, Fy in the force unit
    of ``units``, equal scales, the origin marked); right: the shaking moment (its torque
    unit) against the driver (its angle or length unit). ``cases``: (label, shaking)
    drawn over each other (before / after balancing)."""
    U = units
    first = cases[0][1]
    fu = shown(U, 0.0, "N")[1]
    plt = pyplot(names_of(first.results.mechanism) + [name])
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 5.5))
    for k, (label, sh) in enumerate(cases):
        r = sh.results
        col = f"C{k}"
        peak = float(np.nanmax(sh.force)) if np.any(sh.ok) else float("nan")
        if k == 0:
            top = peak
        # a residual below 1e-12 of the first case's peak is rounding: no figure for it
        said = (
            "zero to rounding" if k and peak <= 1e-12 * top else f"peak {U.text(peak, 'N', '.4g')}"
        )
        fx, fy = shown(U, sh.fx, "N")[0], shown(U, sh.fy, "N")[0]
        ax.plot(fx, fy, color=col, lw=2.2 - k, label=f"{label} ({said})")
        ok = np.flatnonzero(sh.ok)
        if ok.size:  # the start, and the direction of motion
            i = ok[0]
            ax.plot(fx[i], fy[i], "o", color=col, ms=4)
        x, xu = shown(U, r.driver_value, "m" if r.linear else "deg")
        moment, mu = shown(U, sh.moment, "N*m")
        bx.plot(x, moment, color=col, label=label)
    ax.plot(0, 0, "+", color="k", ms=12)
    ax.set_aspect("equal", adjustable="datalim")
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(6))
    ax.set_xlabel(f"Fx on the frame [{fu}]")
    ax.set_ylabel(f"Fy on the frame [{fu}]")
    ax.set_title(f"{title}:\ntip of the force vector (dot: start, +: zero)", fontsize=11)
    r = first.results
    bx.set_xlabel(f"driver position [{xu}]" if r.linear else f"driver angle [{xu}]")
    bx.set_ylabel(f"shaking moment about {first.about_name} [{mu}] (ccw)")
    bx.set_title("shaking moment on the frame")
    for a in (ax, bx):
        a.grid(alpha=0.3)
    ax.legend(fontsize=8)
    if len(cases) > 1:
        bx.legend(fontsize=8)
    fig.suptitle(name + (" (inertia forces only)" if first.inertia_only else ""))
    fig.tight_layout()
    save_figure(fig, path, 100)
    plt.close(fig)
    return path
