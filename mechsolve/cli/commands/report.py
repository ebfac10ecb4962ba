"""``mechsolve report FILE``: one self-contained HTML report (and a PDF with --pdf)."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mechsolve.base.units import pretty_text
from mechsolve.cli.kit import (
    EPILOG,
    EXIT_CHECK_FAILED,
    EXIT_OK,
    FILE_ARG,
    QUIET,
    UNITS,
    VARIANT,
    Command,
    warn,
    whole_number,
    writes_to,
)
from mechsolve.cli.kit import watch as watch_file


@click.command("report", cls=Command, epilog=EPILOG)
@FILE_ARG
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, path_type=Path),
    help="The HTML file (default: FILE's name with .html, in the current directory).",
)
@VARIANT
@click.option(
    "--pdf",
    is_flag=True,
    help="Also print the report to PDF beside the HTML, with a headless Chromium or Chrome "
    "(MECHSOLVE_BROWSER names another).",
)
@click.option(
    "--paper",
    type=click.Choice(["a4", "letter"], case_sensitive=False),
    default="a4",
    show_default=True,
    help="The page size of the PDF (and of the HTML printed from a browser).",
)
@click.option(
    "--frames",
    type=whole_number(2),
    help="Frames of the embedded animation (default: one per degree of the driver).",
)
@click.option(
    "--polygons-at",
    help="Position of the velocity and acceleration polygons: a position number (12 per "
    "turn from the start, as course designs count them) or a driver angle such as "
    "'196.8 deg' [default: position 2].",
)
@click.option(
    "--watch",
    is_flag=True,
    help="Write the report again whenever FILE is saved; Ctrl-C stops (needs watchfiles).",
)
@UNITS
@QUIET
def report(
    file: Path, output, variant, pdf, paper, frames, polygons_at, watch, units, quiet
) -> None:
    """Write one HTML file about FILE that opens in any browser without a network: the
    model's tables with units, degrees of freedom and Assur groups with their branches,
    the mechanism drawn to scale, the figures of the motion, the position tables at the
    file's step, every plot of `run`, the requirements, the dynamics (with a motor), the
    cam (a cam file) and the mechanism in motion (play, pause, a slider)."""
    import numpy as np

    from mechsolve.report import write_report
    from mechsolve.report.animate import check_frame_count

    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    check_frame_count(frames)  # before loading or solving anything (as animate does)
    if output is None:
        output = Path(file.stem + (f"-{variant}" if variant else "") + ".html")
    writes_to(output)

    def once():
        index = polygons_at and polygons_at.strip().isascii() and polygons_at.strip().isdigit()
        at = int(polygons_at) if index else polygons_at
        done = write_report(
            file, variant, output, pdf=pdf, frames=frames, polygons_at=at, paper=paper,
            units=units,
        )  # fmt: skip
        if not quiet:
            click.echo(pretty_text(done.text()))
            click.echo(f"  wrote {done.html}" + (f" and {done.pdf}" if done.pdf else ""))
        if done.incomplete:
            warn("the report is incomplete: its summary says what is missing")
        return (EXIT_CHECK_FAILED if done.check_failed else EXIT_OK), None

    if watch:
        watch_file(file, once)
    sys.exit(once()[0])
