"""The shaking figures: the polar plot of the shaking force (the path of its vector's tip
over the turn) and the shaking moment against the driver, one sweep or before and after
balancing."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.writers.fonts import pyplot
from mechsolve.writers.plots import names_of, save_figure

if TYPE_CHECKING:
    from mechsolve.analyses.shaking.frame import Shaking


def write_shaking_plot(
    cases: list[tuple[str, Shaking]], name: str, path: Path, title: str = "shaking force"
) -> Path:
    """Left: the tip of the shaking force vector on the frame (Fx, Fy in N, equal
    scales, the origin marked); right: the shaking moment (N m) against the driver.
    ``cases``: (label, shaking) drawn over each other (before / after balancing)."""
    first = cases[0][1]
    plt = pyplot(names_of(first.results.mechanism) + [name])
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 5.5))
    for k, (label, sh) in enumerate(cases):
        r = sh.results
        col = f"C{k}"
        peak = float(np.nanmax(sh.force)) if np.any(sh.ok) else float("nan")
        if k == 0:
            top = peak
        # a residual below 1e-12 of the first case's peak is rounding: no figure for it
        said = "zero to rounding" if k and peak <= 1e-12 * top else f"peak {peak:.4g} N"
        ax.plot(sh.fx, sh.fy, color=col, lw=2.2 - k, label=f"{label} ({said})")
        ok = np.flatnonzero(sh.ok)
        if ok.size:  # the start, and the direction of motion
            i = ok[0]
            ax.plot(sh.fx[i], sh.fy[i], "o", color=col, ms=4)
        x = r.driver_value
        bx.plot(x, sh.moment, color=col, label=label)
    ax.plot(0, 0, "+", color="k", ms=12)
    ax.set_aspect("equal", adjustable="datalim")
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(6))
    ax.set_xlabel("Fx on the frame [N]")
    ax.set_ylabel("Fy on the frame [N]")
    ax.set_title(f"{title}:\ntip of the force vector (dot: start, +: zero)", fontsize=11)
    r = first.results
    bx.set_xlabel("driver position [m]" if r.linear else "driver angle [deg]")
    bx.set_ylabel(f"shaking moment about {first.about_name} [N*m] (ccw)")
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
