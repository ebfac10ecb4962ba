"""``mechsolve simulate FILE``: the motor-driven machine's motion (forward dynamics)."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.base.units import pretty_text
from mechsolve.cli.commands.run import INCOMPLETE
from mechsolve.cli.kit import (
    EPILOG_NO_CHECK,
    FILE_ARG,
    NO_PLOTS,
    QUIET,
    UNITS,
    VARIANT,
    Command,
    finish,
    outdir_option,
    output_folder,
    output_units,
    whole_number,
)
from mechsolve.cli.kit import progress_bar as _progress_bar


@click.command("simulate", cls=Command, epilog=EPILOG_NO_CHECK)
@FILE_ARG
@outdir_option("simulation's files")
@VARIANT
@NO_PLOTS
@click.option(
    "--exact",
    is_flag=True,
    help="Solve the equation of motion at every integrator stage (no tabulation).",
)
@click.option(
    "--max-steps",
    type=whole_number(1),
    default=None,
    metavar="N",
    help="Allow up to N integrator steps (output rows) [default: 200000]; a longer run is "
    "refused before it starts, with its estimated size.",
)
@UNITS
@QUIET
def simulate(file: Path, outdir, variant, no_plots, exact, max_steps, units, quiet) -> None:
    """Simulate the machine of FILE (its simulate: section, with its motor: or free):
    write simulation.csv (time, angle, speed, acceleration, J or the energy balance and
    the constraint violation, motor torque, every quantity and joint force) and plots."""
    import numpy as np

    from mechsolve import api
    from mechsolve.analyses.dynamics import check_size
    from mechsolve.analyses.dynamics import simulate as run_simulation

    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    mech = api.load(file, variant)
    shown = output_units(mech, units)
    check_size(mech, max_steps)  # before anything is computed or created
    if outdir is None:
        outdir = Path(file.stem + (f"-{variant}" if variant else ""))
    output_folder(outdir)
    sim = mech.simulation
    steps = int(sim.duration / sim.step) if sim is not None and sim.step else 0
    bar = _progress_bar(steps, quiet) if sim is not None and sim.method == "rk4" else None
    try:
        res = run_simulation(
            mech,
            exact=exact,
            progress=None if bar is None else bar.update,
            max_steps=max_steps,
        )
    finally:
        if bar is not None:
            bar.close()
    written = [res.to_csv(outdir / "simulation.csv", shown)]
    if not no_plots and getattr(res, "multibody", None) is not None:
        from mechsolve.analyses.dynamics.multibody_plots import write_multibody_plots

        written += write_multibody_plots(res, outdir, shown)
    elif not no_plots:
        from mechsolve.analyses.dynamics.plots import write_simulation_plots

        written += write_simulation_plots(res, res.model, outdir, shown)
    tr = res.trajectory
    if not quiet:
        click.echo(pretty_text(res.summary(units=shown)))
        upto = f" with the motion up to t = {tr.t[-1]:.6g} s" if tr.early else ""
        click.echo(
            f"  wrote {len(written)} file(s){upto} to {outdir}/: "
            + ", ".join(p.name for p in written)
        )
    if tr.error is not None:  # the file's motor law stopped it: an input error
        raise tr.error
    if tr.early:
        finish(warning=f"the motion stopped early, at t = {tr.t[-1]:.6g} s: the summary says why")
    finish(warning=INCOMPLETE if res.incomplete() else None)
