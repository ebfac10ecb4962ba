"""``mechsolve check FILE``: validate a file, count its degrees of freedom, assemble the
start."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mechsolve.cli.kit import EPILOG_NO_CHECK, EXIT_OK, FILE_ARG, VARIANT, Command, writing


@click.command("check", cls=Command, epilog=EPILOG_NO_CHECK)
@FILE_ARG
@VARIANT
@click.option(
    "--draw",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Draw the assembled start position to this PNG file.",
)
def check(file: Path, variant, draw) -> None:
    """Validate FILE, report its degrees of freedom and assemble the start position (a
    mechanism that cannot be assembled there is an input error, 2)."""
    from mechsolve import api

    mech = api.load(file, variant)
    report = api.check(mech)
    click.echo(report.text())
    if draw is not None:
        from mechsolve.writers.plots import draw_start

        with writing(draw, "--draw"):
            draw_start(report.analysis, report.assembly.state, draw, f"{mech.name}: start position")
        click.echo(f"  drew the start position to {draw}")
    sys.exit(EXIT_OK)
