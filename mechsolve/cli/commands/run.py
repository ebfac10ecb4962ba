"""``mechsolve run FILE``: solve the sweep (or instants with ``--at``), write the CSV and
the plots, check the requirements."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from mechsolve.base.errors import InputError, SolverError
from mechsolve.base.units import pretty_text
from mechsolve.cli.kit import (
    EPILOG,
    EXIT_CHECK_FAILED,
    EXIT_OK,
    FILE_ARG,
    NO_PLOTS,
    QUIET,
    UNITS,
    VARIANT,
    Command,
    outdir_option,
    output_folder,
    output_units,
    recorded_outputs,
    warn,
    writes_to,
    writing,
)
from mechsolve.cli.kit import progress_bar as _progress_bar
from mechsolve.cli.kit import stream_above as _stream_above
from mechsolve.cli.kit import watch as _watch

INCOMPLETE = "the results are incomplete: the summary says what is missing, the CSV rows why"


INCOMPLETE_INSTANTS = "some instants are not solved: the table says why"


@click.command("run", cls=Command, epilog=EPILOG)
@FILE_ARG
@outdir_option("results")
@click.option("--step", help="Sweep step, e.g. '1 deg', '2 mm' or '0.01 s' (overrides the file).")
@VARIANT
@NO_PLOTS
@click.option(
    "--method",
    type=click.Choice(["auto", "newton", "split-newton"]),
    help="auto: closed-form Assur groups where recognised (default); newton: Newton-Raphson "
    "on the whole constraint system; split-newton: the same groups as auto, each by "
    "Newton-Raphson.",
)
@click.option(
    "--at",
    "at",
    multiple=True,
    metavar="STATE",
    help="Solve only this instant, e.g. 'theta=30 deg, omega=10 rad/s, alpha=5 rad/s^2' "
    "('s=..., v=..., a=...' for a linear driver; θ/φ, ω, α/ε are the same names; signed, "
    "counter-clockwise positive); omega and alpha default to the file's driver; may be "
    "repeated. A bare number is read as in the file's instants: a position in the file's "
    "length or angle unit (m and deg where its units: names none), a rate in SI (rad/s, "
    "m/s, rad/s^2, m/s^2). Prints every quantity and force and writes instants.csv.",
)
@click.option(
    "--junit",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write the file's requirements as a JUnit XML report (one test case each).",
)
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["png", "svg"]),
    default="png",
    show_default=True,
    help="Image format of the plots (svg keeps the text as text).",
)
@click.option(
    "--watch",
    is_flag=True,
    help="Run again whenever FILE is saved, printing what changed; Ctrl-C stops "
    '(needs watchfiles: pip install "mechsolve[watch]").',
)
@UNITS
@QUIET
def run(
    file: Path, outdir, step, variant, no_plots, method, at, junit, fmt, watch, units, quiet
) -> None:
    """Solve the sweep of FILE and write results.csv and plots; check its requirements."""
    if outdir is None:
        outdir = Path(file.stem + (f"-{variant}" if variant else ""))
    args = (file, outdir, step, variant, no_plots, method, at, junit, quiet, fmt, units)
    writes_to(outdir)
    if watch:
        # each save's run is recorded on its own: a good save tidies what the last
        # complete one wrote and this one does not (a point's plot, instants.csv...)
        _watch(file, lambda: _recorded_job(outdir, quiet, args), outdir=outdir)
    try:
        code = _recorded_job(outdir, quiet, args)[0]
    except SolverError as exc:  # raised deep in a solver, which does not know the file
        raise SolverError(f"{file}: {exc}") from None
    sys.exit(code)


def _recorded_job(outdir: Path, quiet: bool, args: tuple):
    """:func:`_run_job`, its outputs recorded in the folder (:mod:`mechsolve.base.manifest`):
    a complete run names what the last one wrote there and this one does not. A run
    ``--at`` (instants only) is recorded apart, so that it leaves the sweep's files."""
    at = args[6]
    with recorded_outputs(outdir, "run --at" if at else "run", quiet):
        return _run_job(*args)


def _run_job(
    file: Path,
    outdir: Path,
    step,
    variant,
    no_plots,
    method,
    at,
    junit,
    quiet,
    fmt="png",
    units: str | None = None,
):
    """One run: solve, write, print; ``(exit code, results or None, the units shown)``:
    5 when a requirement failed, else 0 (with a warning on stderr when the results lack
    something). Errors raise."""
    import numpy as np

    from mechsolve import api

    # singular positions give inf and NaN on purpose; the summary reports them
    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    mech = api.load(file, variant)
    shown = output_units(mech, units)
    st = api.parse_step(mech, step) if step is not None else None
    output_folder(outdir)
    n = api.positions(mech, st)
    instants_failed = False
    if at or mech.instants:
        from mechsolve.analyses.instants import (
            Instant,
            instants_table,
            parse_instant,
            solve_instants,
        )

        todo = [parse_instant(mech, a) for a in at] or [Instant(*i) for i in mech.instants]
        ires = solve_instants(mech, todo, method=method)
        path = ires.to_csv(outdir / "instants.csv", shown)
        instants_failed = ires.incomplete()
        if not quiet:
            click.echo(pretty_text(instants_table(ires, shown)))
            click.echo(f"  wrote {path}")
        if at:  # only the instants asked for
            if instants_failed:
                warn(INCOMPLETE_INSTANTS)
            return EXIT_OK, None, shown
    if n > _stream_above() and mech.driver.motion is None:
        # a long sweep: solved chunk by chunk, the CSV streamed, plots from a coarse
        # sweep of the same range; a bar on a terminal, moved on after each chunk
        bar = _progress_bar(n, quiet)
        try:
            summary, res = api.stream(
                mech,
                outdir / "results.csv",
                step=st,
                method=method,
                progress=None if bar is None else bar.update,
                units=shown,
            )
        finally:
            if bar is not None:
                bar.close()
        text, failed = summary.text(res), summary.incomplete()
        written = [summary.path]
        streamed = True
    else:
        streamed = False
        res = api.solve(mech, step=st, method=method)
        # the figures (extremes, limit positions, work) from the sweep the plots are
        # drawn from, so that the terminal, the plots and the requirements agree; that
        # finer sweep is made only when something reads it (quiet, no plots and no
        # requirements: the CSV alone, at the file's step)
        text = None if quiet else res.summary(figures=api.for_plots(mech, res, method), units=shown)
        failed = res.incomplete()
        written = [res.to_csv(outdir / "results.csv", shown)]
    if not no_plots:
        from mechsolve.writers.plots import write_plots

        # drawn from a sweep at 1 deg or finer with the exact events; the CSV keeps
        # the file's step
        written += write_plots(api.for_plots(mech, res, method), outdir, fmt, shown)
    verdicts = _requirements(mech, res, junit, streamed=streamed)
    if not quiet:
        click.echo(pretty_text(text))
        click.echo(
            f"  wrote {len(written)} file(s) to {outdir}/: " + ", ".join(p.name for p in written)
        )
    if verdicts:
        from mechsolve.results.requirements import verdict_table

        click.echo(pretty_text(verdict_table(verdicts)))
    if any(not v.passed for v in verdicts):
        return EXIT_CHECK_FAILED, res, shown
    if failed or instants_failed:
        warn(INCOMPLETE)
    return EXIT_OK, res, shown


def _requirements(mech, res, junit: Path | None, streamed: bool) -> list:
    """Check the file's requirements on the run (and write the JUnit report)."""
    if not mech.requirements:
        if junit is not None:
            raise InputError(f"--junit {junit}: the file has no 'requirements' section")
        return []
    from mechsolve.results.requirements import check_requirements, junit_xml

    if streamed:
        raise InputError(
            "the requirements are checked on a run held in memory; this sweep is long "
            "enough to be streamed (raise MECHSOLVE_STREAM_ABOVE or use a coarser --step)"
        )
    verdicts = check_requirements(mech, res)
    if junit is not None:
        from mechsolve.base.atomic import write_text

        with writing(junit, "--junit"):
            write_text(junit, junit_xml(verdicts, mech.name, str(mech.source.file or "")))
    return verdicts
