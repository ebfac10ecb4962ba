"""``mechsolve synth PROBLEM``: design a linkage from what it must do."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.base.units import pretty_text
from mechsolve.cli.kit import (
    EPILOG_NO_CHECK,
    FILE_ARG,
    QUIET,
    Command,
    number,
    whole_number,
    writing,
)


@click.command(cls=Command, epilog=EPILOG_NO_CHECK)
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
    type=whole_number(),
    metavar="N",
    help="Write the N-th solution listed (from 1) instead of the one the rule picks.",
)
@click.option(
    "--plot",
    type=click.Path(dir_okay=False, path_type=Path),
    help="function and path problems: a PNG of the target against what the written "
    "design achieves in mechsolve's run; four-positions: the centre-point and circle-point "
    "curves; five-positions: the two centre-point curves and their Burmester points.",
)
@click.option(
    "--seed",
    type=whole_number(),
    default=0,
    show_default=True,
    help="function and path problems: the optimiser's seed (the same seed, the same result).",
)
@click.option(
    "--max-time",
    type=number(0, low_open=True),
    metavar="SECONDS",
    help="function and path problems: stop the search after this long and keep the best "
    "design found (Ctrl-C does the same, then exits with 130).",
)
@click.option(
    "--digits",
    type=whole_number(3, 17),
    help="Round the written file's lengths and angles to N significant digits (in the "
    "problem's units). Default: every digit (the shortest decimal that reads back the "
    "same), so that the file reproduces the design; 17 does the same. A 'round' in FILE "
    "rounds the lengths instead. The file's header states the errors of its numbers as "
    "written.",
)
@QUIET
def synth(file: Path, output, pick, solution, plot, seed, max_time, digits, quiet) -> None:
    """Solve the synthesis problem in FILE: list every solution, pick one, and with -o
    write it as a mechanism file, checked by solving it (its limit positions).

    \b
    Methods (one section of FILE): crank-rocker (extreme distances, time ratio with both
    limits, or time ratio with one limit and the frame: two solutions), slider-crank,
    guide-bar, three-positions (motion generation), four-positions (Burmester's
    centre-point curve), five-positions (Burmester's points: every pair a four-bar),
    window (the input window that makes a point's path straightest), function
    (psi = f(phi): Freudenstein's precision points, then differential evolution over the
    range) and path (a coupler point through target
    points, by differential evolution on design batches). See mechanisms/synth/.
    """
    from mechsolve.analyses.synth.problem import confirm, solve_problem

    if solution is not None and pick is not None:
        from mechsolve.base.errors import InputError

        raise InputError("--solution and --pick: give one of them")
    from mechsolve.cli.kit import progress_bar

    # the number of generations is not known before convergence: a counter, not a bar
    bar = progress_bar(None, quiet, desc="synthesis", unit=" generations")  # type: ignore[arg-type]

    def progress(generation: int, best: float) -> None:
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"best {best:.3e}")

    try:
        out = solve_problem(
            file,
            pick,
            solution,
            seed=seed,
            max_time=max_time,
            progress=progress,
            digits=None if digits in (None, 17) else digits,
        )
    finally:
        if bar is not None:
            bar.close()
    found = out.check.get("search") if isinstance(out.check, dict) else None
    if plot is not None and out.method not in ("function", "path", "four-positions",
                                               "five-positions"):  # fmt: skip
        from mechsolve.base.errors import InputError

        raise InputError(
            "--plot: only function, path, four-positions and five-positions problems draw a plot"
        )
    if not quiet:
        click.echo(pretty_text(out.text))
    if out.yaml is not None:
        if not quiet or plot is not None:
            text = confirm(out)
            if not quiet:
                click.echo(pretty_text(text))
        if plot is not None:
            from mechsolve.analyses.synth.optproblem import write_plot

            with writing(plot, "--plot"):
                write_plot(out, plot)
            if not quiet:
                click.echo(f"  wrote {plot}")
        if output is not None:
            from mechsolve.base.atomic import write_text

            with writing(output, "-o"):
                write_text(output, out.yaml)
            if not quiet:
                click.echo(f"  wrote {output}")
        if found is not None and found.interrupted:
            # the best design so far is printed (and written): the run still ends as an
            # interruption (130)
            raise KeyboardInterrupt
    elif output is not None:
        from mechsolve.base.errors import InputError

        raise InputError("-o: a window problem chooses a range and writes no mechanism")
