"""``mechsolve synth PROBLEM``: design a linkage from what it must do."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.cli.kit import EPILOG, FILE_ARG, QUIET, Command, writing


@click.command(cls=Command, epilog=EPILOG)
@FILE_ARG
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write the chosen design as a mechanism file (for mechsolve run).",
)
@click.option(
    "--pick",
    type=click.Choice(["transmission", "shortest-crank", "smallest"]),
    help="Rule choosing among the solutions: the largest minimum transmission angle "
    "(default, or the file's 'pick'), the shortest input link, the smallest sum of lengths.",
)
@click.option(
    "--solution",
    type=int,
    metavar="N",
    help="Write the N-th solution listed (from 1) instead of the one the rule picks.",
)
@QUIET
def synth(file: Path, output, pick, solution, quiet) -> None:
    """Solve the synthesis problem in FILE: list every solution, pick one, and with -o
    write it as a mechanism file, checked by solving it (its limit positions).

    \b
    Methods (one section of FILE): crank-rocker (extreme distances, time ratio with both
    limits, or time ratio with one limit and the frame: two solutions), slider-crank,
    guide-bar, three-positions (motion generation), window (the input window that makes a
    point's path straightest). See mechanisms/synth/.
    """
    from mechsolve.analyses.synth.problem import confirm, solve_problem

    if solution is not None and pick is not None:
        from mechsolve.base.errors import InputError

        raise InputError("--solution and --pick: give one of them")
    out = solve_problem(file, pick, solution)
    if not quiet:
        click.echo(out.text)
    if out.yaml is not None:
        if not quiet:
            click.echo(confirm(out))
        if output is not None:
            from mechsolve.base.atomic import write_text

            with writing(output, "-o"):
                write_text(output, out.yaml)
            if not quiet:
                click.echo(f"  wrote {output}")
    elif output is not None:
        from mechsolve.base.errors import InputError

        raise InputError("-o: a window problem chooses a range and writes no mechanism")
