"""``mechsolve compare A.yaml B.yaml ...``: several schemes of one machine side by side
(stroke, time ratio, velocity and its uniformity, transmission, torque, reactions,
flywheel, requirements), a tidy CSV, overlaid plots and, with ``--report``, an HTML page."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.base.units import pretty_text
from mechsolve.cli.kit import (
    EPILOG,
    NO_PLOTS,
    QUIET,
    UNITS,
    Command,
    finish,
    output_folder,
    output_units,
    writing,
)


@click.command("compare", cls=Command, epilog=EPILOG)
@click.argument("schemes", nargs=-1, required=True, metavar="SCHEME...")
@click.option(
    "-o",
    "--outdir",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("compare"),
    show_default=True,
    help="Output folder for compare.csv and the plots.",
)
@click.option(
    "--output",
    "outputs",
    multiple=True,
    metavar="NAME",
    help="The output of the schemes: a point's coordinate (C.x), a point (the coordinate "
    "that travels further), a slider (its displacement along its guide) or a rocker link "
    "(its angle). Once for all schemes, or once per scheme in their order [default: each "
    "file's first output point, else its first output slider, else its first slider on "
    "the ground].",
)
@click.option(
    "--variants",
    "all_variants",
    is_flag=True,
    help="Compare each FILE and each of its variants (FILE@VARIANT names one).",
)
@click.option(
    "--delta",
    default="1/40",
    show_default=True,
    help="Coefficient of speed fluctuation the flywheel is sized for.",
)
@click.option(
    "--middle",
    default="80%",
    show_default=True,
    help="The centred part of the working stroke over which the velocity's uniformity "
    "(coefficient of variation) is measured.",
)
@click.option(
    "--method",
    type=click.Choice(["auto", "newton", "split-newton"]),
    help="The position solver (as for run).",
)
@click.option(
    "--report",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Also write the comparison as one self-contained HTML page (NAME.html).",
)
@NO_PLOTS
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["png", "svg"]),
    default="png",
    show_default=True,
    help="Image format of the plots.",
)
@UNITS
@QUIET
def compare(
    schemes, outdir, outputs, all_variants, delta, middle, method, report, no_plots, fmt, units,
    quiet,
) -> None:  # fmt: skip
    """Compare SCHEMEs (mechanism files, or FILE@VARIANT) of one machine: each is solved
    over one turn of its crank (all at the same speed) and the same figures are printed
    side by side, each with its unit: the output's stroke (a rocker's swing), the time
    ratio K, the output's mean and peak velocity over the working stroke (the slower)
    and its uniformity, the smallest transmission (largest pressure) angle, the peak and
    RMS driving torque, the peak joint reaction, the flywheel needed for DELTA and the
    requirements' verdicts. Writes compare.csv (one row per scheme) and overlaid plots;
    exit 5 when a requirement of any scheme fails. The figures are in the units of the
    first scheme's file (--units to change them)."""
    import numpy as np

    from mechsolve import api
    from mechsolve.analyses.compare import expand_schemes, parse_middle
    from mechsolve.analyses.flywheel import parse_delta

    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    dl = parse_delta(delta)
    mid = parse_middle(middle)
    first, first_variant = expand_schemes(list(schemes[:1]))[0]
    shown = output_units(api.load(first, first_variant), units)
    text_units = None if shown.is_si else shown  # None: the SI text as it always was
    output_folder(outdir)
    if report is not None:  # before anything is solved
        from mechsolve.report.compare import check_report_path

        check_report_path(report)
    result = api.compare(
        list(schemes),
        outputs=list(outputs),
        delta=dl,
        middle=mid,
        method=method,
        all_variants=all_variants,
    )
    written = [result.to_csv(outdir / "compare.csv", shown)]
    if not no_plots:
        written += result.write_plots(outdir, fmt, text_units)
    if report is not None:
        from mechsolve.report.compare import write_compare_report

        with writing(report, "--report"):
            written.append(write_compare_report(result, report, units=text_units))
    if not quiet:
        click.echo(pretty_text(result.text(text_units)))
        click.echo("  wrote " + ", ".join(str(p) for p in written))
    finish(check_failed=result.check_failed)
