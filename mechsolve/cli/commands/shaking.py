"""``mechsolve shaking FILE``: the shaking force and moment on the frame; ``--balance``:
the counterweights of a four-bar or a slider-crank, written into a runnable file."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.base.units import pretty_text
from mechsolve.cli.kit import (
    EPILOG_NO_CHECK,
    FILE_ARG,
    NO_PLOTS,
    QUIET,
    UNITS,
    VARIANT,
    Command,
    finish,
    number,
    outdir_option,
    output_folder,
    output_units,
)


@click.command("shaking", cls=Command, epilog=EPILOG_NO_CHECK)
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
    help="Gravity and the file's loads off: the inertia forces alone (the textbook "
    "shaking force; --balance always compares these).",
)
@click.option(
    "--balance",
    is_flag=True,
    help="Balance a four-bar fully (counterweights on the crank and the rocker) or a "
    "slider-crank partially (a counterweight on the crank), write the balanced file and "
    "the shaking before and after.",
)
@click.option(
    "--fraction",
    type=number(),
    metavar="C",
    help="Slider-crank: the fraction of the reciprocating mass balanced on the crank, in "
    "[0, 1], default 0.5; implies --balance.",
)
@click.option(
    "--rms",
    is_flag=True,
    help="Counterweights that minimise the RMS shaking force over the turn (least "
    "squares): on a slider-crank's crank, where complete balancing is impossible, or on a "
    "four-bar's crank and rocker; implies --balance.",
)
@click.option(
    "--radius",
    multiple=True,
    metavar="LINK=LENGTH",
    help="A counterweight's radius from its pivot, e.g. 'crank=40' (the file's length "
    "unit unless given) [default: the link's length between its pins]; repeatable.",
)
@outdir_option("shaking table, plots and balanced file")
@VARIANT
@NO_PLOTS
@UNITS
@QUIET
def shaking(
    file: Path, about, step, inertia_only, balance, fraction, rms, radius, outdir, variant,
    no_plots, units, quiet,
) -> None:  # fmt: skip
    """The shaking force and moment that the moving links of FILE transmit to the frame
    over the sweep (through its joints and the motor), their peak and RMS, a CSV and the
    polar plot; with --balance, counterweights that cancel it (a four-bar) or balance a
    fraction of the reciprocating mass (a slider-crank)."""
    from mechsolve import api
    from mechsolve.analyses.shaking.files import parse_about, parse_radii, write_text
    from mechsolve.analyses.shaking.plots import write_shaking_plot
    from mechsolve.results.csv import write_csv

    mech = api.load(file, variant)
    shown = output_units(mech, units)
    at, at_name = parse_about(mech, about)
    radii = parse_radii(mech, radius)
    u_step = api.parse_step(mech, step) if step is not None else None
    do_balance = balance or fraction is not None or rms or bool(radii)
    bal = None
    if do_balance:  # the input is checked before anything is written
        bal = api.balanced(
            mech, fraction=fraction, radius=radii, about=at, about_name=at_name,
            step=u_step, variant=variant, rms=rms,
        )  # fmt: skip
    if outdir is None:
        outdir = Path(file.stem + (f"-{variant}" if variant else ""))
    output_folder(outdir)
    sh = api.shaking(mech, about=at, about_name=at_name, step=u_step, inertia=inertia_only)
    paths = [write_csv(sh, outdir / "shaking.csv", shown)]
    if not no_plots:
        paths.append(
            write_shaking_plot([(mech.name, sh)], mech.name, outdir / "shaking.png", units=shown)
        )
    lines = sh.summary_lines(shown)
    if bal is not None:
        stem = file.stem + (f"-{variant}" if variant else "")
        paths.append(write_text(outdir / f"{stem}-balanced.yaml", bal.text))
        paths.append(write_csv(bal.after, outdir / "shaking-balanced.csv", shown))
        if not no_plots:
            paths.append(
                write_shaking_plot(
                    [("before", bal.before), ("after balancing", bal.after)],
                    mech.name,
                    outdir / "balance.png",
                    title="shaking force before and after balancing",
                    units=shown,
                )
            )
        lines += bal.lines(shown)
    if not quiet:
        click.echo(pretty_text("\n".join(lines)))
        click.echo("  wrote " + ", ".join(str(p) for p in paths))
    bad = int((~sh.ok).sum())
    finish(warning=f"the shaking is not determined at {bad} position(s)" if bad else None)
