"""The comparison's overlaid curves, one line per scheme, against the crank angle from the
start of each scheme's working stroke (so that the working strokes line up at 0°):

* ``compare_velocity``: the output's velocity along its working stroke (positive while it
  works), with the middle band where the uniformity is measured;
* ``compare_displacement``: the output's displacement from the start of its working stroke;
* ``compare_torque``: the driving torque along the crank's motion (schemes with forces).

Schemes whose outputs are of different kinds (a length, a rocker's angle) get a figure of
each kind (``compare_velocity.png`` and ``compare_velocity_rocker.png``). Written through
:func:`mechsolve.writers.plots.save_figure` (atomic); every axis names its unit, the
units of the comparison's table (an :class:`~mechsolve.base.units.OutputUnits`; None: the
SI figures, a stroke in mm and a torque from 1e4 N·m on in kN·m).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.units import SI_OUTPUT, OutputUnits, pretty_unit
from mechsolve.writers.plots import PLOT_FORMATS, _scaled, save_figure

if TYPE_CHECKING:
    from mechsolve.analyses.compare import Comparison
    from mechsolve.analyses.compare.figures import SchemeFigures

XLABEL = "crank angle from the start of the working stroke [{unit}]"


def _pyplot(c: Comparison):
    from mechsolve.writers.fonts import pyplot

    return pyplot([s.name for s in c.schemes])


def _divisor(U: OutputUnits | None, unit: str) -> tuple[float, str]:
    """(divisor, shown unit) of SI values in ``unit``, in ``U`` (None: SI)."""
    k, target = (U or SI_OUTPUT).convert(unit)
    return 1.0 / k, pretty_unit(target)


def _plot(
    c: Comparison,
    schemes: list[SchemeFigures],
    path: Path,
    what: str,
    units: OutputUnits | None = None,
) -> Path:
    plt = _pyplot(c)
    fig, ax = plt.subplots(figsize=(9, 4.8))
    angular = schemes[0].output.angular
    U = units or SI_OUTPUT
    if what == "torque":
        scale, unit = _scaled(np.concatenate([s.torque for s in schemes]), "N*m", U)
        ylabel = f"driving torque along the crank's motion [{unit}]"
        title = "Driving torque"
    elif what == "velocity":
        scale, unit = _divisor(units, "rad/s" if angular else "m/s")  # the table's units
        ylabel = f"output velocity along the working stroke [{unit}]"
        title = "Output velocity"
    else:
        if angular:
            scale, unit = _divisor(units, "deg")
            scale *= math.pi / 180  # the displacement is in rad
        elif units is None:  # the SI table's stroke: mm
            scale, unit = 1e-3, "mm"
        else:
            scale, unit = _divisor(units, "m")
        ylabel = f"output displacement from the working stroke's start [{unit}]"
        title = "Output displacement"
    xk, xu = U.convert("deg")
    for s in schemes:
        k = c.schemes.index(s)  # one colour per scheme in every figure
        y = {"torque": s.torque, "velocity": s.velocity, "displacement": s.displacement}[what]
        label = f"{s.name} ({s.output.spec})" if what != "torque" else s.name
        ax.plot(np.degrees(s.x) * xk, y / scale, lw=1.5, color=f"C{k}", label=label)
        if what == "velocity":  # where the uniformity is measured: the speed's range there
            lo, hi = s.v_band
            if math.isfinite(lo):
                ax.hlines(
                    [lo / scale, hi / scale],
                    0,
                    math.degrees(s.work_travel) * xk,
                    colors=f"C{k}",
                    linestyles=":",
                    lw=0.9,
                )
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlim(0, 360 * xk)
    if xk == 1.0:
        ax.set_xticks(np.arange(0, 361, 30))
    ax.set_xlabel(XLABEL.format(unit=pretty_unit(xu)))
    ax.set_ylabel(ylabel)
    sub = {
        "velocity": f"dotted: the speed's range over the middle {c.middle * 100:g} % of the "
        "working stroke",
        "torque": "positive: the motor drives",
        "displacement": "the working stroke rises from 0",
    }[what]
    ax.set_title(f"{title}, one line per scheme ({sub})", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, 110)
    plt.close(fig)
    return path


def write_plots(
    c: Comparison, outdir: Path, fmt: str = "png", units: OutputUnits | None = None
) -> list[Path]:
    """Write the overlaid curves into ``outdir`` as ``fmt``, in ``units`` (None: the SI
    figures); return the files written."""
    if fmt not in PLOT_FORMATS:
        raise ValueError(f"plot format {fmt!r}: one of {', '.join(PLOT_FORMATS)}")
    outdir.mkdir(parents=True, exist_ok=True)
    written = []
    kinds = [
        ("", [s for s in c.schemes if not s.output.angular]),
        ("_rocker", [s for s in c.schemes if s.output.angular]),
    ]
    for suffix, group in kinds:
        if not group:
            continue
        for what in ("velocity", "displacement"):
            path = outdir / f"compare_{what}{suffix}.{fmt}"
            written.append(_plot(c, group, path, what, units))
    with_torque = [s for s in c.schemes if s.torque is not None]
    if with_torque:
        written.append(_plot(c, with_torque, outdir / f"compare_torque.{fmt}", "torque", units))
    return written
