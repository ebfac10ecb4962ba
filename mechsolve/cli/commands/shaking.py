"""``mechsolve shaking FILE``: the shaking force and moment on the frame."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.cli.kit import (
    EPILOG,
    FILE_ARG,
    NO_PLOTS,
    QUIET,
    VARIANT,
    Command,
    finish,
    outdir_option,
    output_folder,
)


@click.command("shaking", cls=Command, epilog=EPILOG)
@FILE_ARG
@click.option(
    "--about",
    metavar="POINT",
    help="The shaking moment's point: a point of the frame by name, or 'x, y' in the "
    "file's length unit [default: the frame's origin].",
)
@click.option("--step", help="Sweep step, e.g. '1 deg' [default: the file's].")
@click.option(
    "--inertia-only",
    is_flag=True,
    help="Gravity and the file's loads off: the inertia forces alone (the textbook shaking force).",
)
@outdir_option("shaking table and plot")
@VARIANT
@NO_PLOTS
@QUIET
def shaking(
    file: Path, about, step, inertia_only, outdir, variant,
    no_plots, quiet,
) -> None:  # fmt: skip
    """The shaking force and moment that the moving links of FILE transmit to the frame
    over the sweep (through its joints and the motor), their peak and RMS, a CSV and the
    polar plot."""
    from mechsolve import api
    from mechsolve.analyses.shaking.files import parse_about
    from mechsolve.analyses.shaking.plots import write_shaking_plot
    from mechsolve.results.csv import write_csv

    mech = api.load(file, variant)
    at, at_name = parse_about(mech, about)
    u_step = api.parse_step(mech, step) if step is not None else None
    if outdir is None:
        outdir = Path(file.stem + (f"-{variant}" if variant else ""))
    output_folder(outdir)
    sh = api.shaking(mech, about=at, about_name=at_name, step=u_step, inertia=inertia_only)
    paths = [write_csv(sh, outdir / "shaking.csv")]
    if not no_plots:
        paths.append(write_shaking_plot([(mech.name, sh)], mech.name, outdir / "shaking.png"))
    lines = sh.summary_lines()
    if not quiet:
        click.echo("\n".join(lines))
        click.echo("  wrote " + ", ".join(str(p) for p in paths))
    bad = int((~sh.ok).sum())
    finish(warning=f"the shaking is not determined at {bad} position(s)" if bad else None)
