"""``mechsolve sweep FILE``: vary numbers of a mechanism file, solve every design, and
tabulate the figures that decide it (see :mod:`mechsolve.analyses.study`)."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.cli import kit as clikit
from mechsolve.cli.kit import (
    EPILOG,
    FILE_ARG,
    NO_PLOTS,
    QUIET,
    UNITS,
    VARIANT,
    Command,
    outdir_option,
    output_folder,
    output_units,
    whole_number,
)

MAX_DESIGNS = 100_000  # default --max-designs: about 0.4 GB of rows for a four-bar study
MAX_TIME = "1 h"  # default --max-time

SWEEP_EPILOG = (
    EPILOG + " A study's design check: 5 when the file has requirements and no design "
    "meets them all; Ctrl-C (130) keeps the rows already finished."
)


def _round_up(seconds: float) -> str:
    """A --max-time above ``seconds``: whole minutes or hours, e.g. ``'3 h'``."""
    import math

    if seconds < 3600:
        return f"'{max(1, math.ceil(seconds * 1.2 / 60))} min'"
    return f"'{math.ceil(seconds * 1.2 / 3600)} h'"


def _bar(total: int, quiet: bool):
    return clikit.progress_bar(total, quiet, desc="designs", unit=" designs")


@click.command(cls=Command, epilog=SWEEP_EPILOG)
@FILE_ARG
@click.option(
    "-p",
    "--param",
    "params",
    multiple=True,
    metavar="KEYPATH=VALUES",
    help="Vary a number of FILE (may be repeated), e.g. "
    '-p "links.crank.points.A[0]=20..30 mm:5" (a range with a count), '
    '-p "ground.O4[1]=8, 8.1, 8.2" (a list), -p "links.jib.mass=normal(3500 kg, 100 kg)". '
    "Adds to the file's study.parameters (replacing one of the same key path).",
)
@click.option(
    "--design",
    help="grid (every combination; the default), one-at-a-time (each parameter on its own, "
    "the others at the file's value), random or latin-hypercube (--samples designs).",
)
@click.option(
    "--samples", type=whole_number(), help="Designs of a random or Latin-hypercube study (50)."
)
@click.option(
    "--seed",
    type=whole_number(),
    help="Seed of the random designs (0): the same designs each time.",
)
@click.option(
    "--best",
    metavar='"min|max EXPR"',
    help='Pick the best design, e.g. --best "min range(K.y)", and write it as best.yaml.',
)
@click.option(
    "--figure",
    "figures",
    multiple=True,
    metavar="EXPR",
    help='An extra figure per design, e.g. --figure "range(K.y)" (may be repeated).',
)
@click.option("--step", help="Sweep step of every design, e.g. '5 deg' (overrides the file).")
@VARIANT
@click.option(
    "-j",
    "--jobs",
    type=whole_number(),
    help="Worker processes (default: all cores; 1: in this process).",
)
@click.option(
    "--dask", "use_dask", is_flag=True, help="Run on a Dask local cluster (--jobs workers)."
)
@click.option(
    "--scheduler",
    metavar="tcp://HOST:PORT",
    help="Run on the Dask scheduler at this address (workers must have mechsolve installed).",
)
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["csv", "parquet"]),
    default="csv",
    show_default=True,
    help="The table's format (parquet needs pyarrow).",
)
@click.option(
    "--keep-results",
    is_flag=True,
    help="Also write each design's full results CSV to OUTDIR/designs/.",
)
@click.option(
    "--max-designs",
    type=whole_number(),
    default=MAX_DESIGNS,
    show_default=True,
    help="Refuse a study of more designs (their rows are kept in memory until the table "
    "is written); raise it to run a larger one.",
)
@click.option(
    "--max-time",
    default=MAX_TIME,
    show_default=True,
    metavar="DURATION",
    help="Refuse a study estimated (from its first designs, timed) to take longer, e.g. "
    "'30 min', '8 h'.",
)
@outdir_option("study's table and plots")
@NO_PLOTS
@UNITS
@QUIET
def sweep(
    file: Path,
    params,
    design,
    samples,
    seed,
    best,
    figures,
    step,
    variant,
    jobs,
    use_dask,
    scheduler,
    fmt,
    keep_results,
    max_designs,
    max_time,
    outdir,
    no_plots,
    units,
    quiet,
) -> None:
    """Solve every design of a study of FILE and write one row per design to
    OUTDIR/study.csv: the parameters, a status, and the figures that decide a design
    (swing or stroke, time ratio, minimum transmission angle, peak driving torque, peak
    reactions, work per cycle, whether it assembles at every position), with the
    requirements' values and verdicts when FILE has requirements.

    \b
    Parameters come from -p options and/or FILE's study section:
      study:
        design: grid          # or one-at-a-time, random, latin-hypercube
        parameters:
          links.crank.points.A[0]: 20..30 mm:5     # 5 values, ends included
          ground.O4[1]: 80, 85, 90 mm              # a list
          links.jib.mass: normal(3500 kg, 100 kg)  # random studies
        best: min range(K.y)
    """
    import numpy as np

    from mechsolve import api
    from mechsolve.analyses.study.execute import precheck, results_kept, time_first_chunk

    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    limit_s = _check_options(jobs, use_dask, scheduler, max_designs, max_time)
    study, nominal = _load_study(file, params, variant, design, samples, seed, best, figures)
    study.units = output_units(nominal, units)
    if step is not None:
        study.step = api.parse_step(nominal, step)
    precheck(study, nominal)
    if outdir is None:
        outdir = Path(file.stem + (f"-{variant}" if variant else "") + "-study")
    results_dir = None
    if keep_results:  # the first designs, timed, write theirs too
        output_folder(outdir)
        results_dir = output_folder(outdir / "designs")
    n = len(study)
    if not quiet:
        _echo_study(study, nominal)
    # the first chunk of designs, solved here and timed: what the rest will cost
    workers, where = _workers(n, jobs, use_dask, scheduler)
    est = time_first_chunk(study, workers, results_dir=results_dir)
    if est.timed < n and est.unwritten is None:
        _check_estimate(est, n, where, max_designs, max_time, limit_s, quiet)
    output_folder(outdir)
    outcome = _execute(study, est, jobs, use_dask, scheduler, results_dir, quiet)
    written, pick = _write_outputs(study, outcome, outdir, fmt, no_plots)
    counts = _Counts(outcome.rows, n)
    if not quiet:
        kept = results_kept(outcome.rows) if keep_results else None
        _echo_outcome(study, outcome, counts, pick, written, outdir, kept)
    clikit.finish(
        check_failed=counts.has_req and counts.passing == 0,
        warning=f"{n - counts.ok} of {n} designs are invalid or do not assemble at every "
        "position: their rows say why"
        if counts.ok < n
        else None,
    )


def _check_options(jobs, use_dask, scheduler, max_designs: int, max_time: str) -> float:
    """Refuse contradictory or out-of-range options; return --max-time in seconds."""
    from mechsolve.base.errors import InputError
    from mechsolve.base.units import UnitError, parse_quantity

    if jobs is not None and jobs < 1:
        raise InputError(f"--jobs {jobs}: give 1 or more workers")
    if use_dask and scheduler:
        raise InputError("give --dask (a local cluster) or --scheduler ADDRESS, not both")
    if max_designs < 1:
        raise InputError(f"--max-designs {max_designs}: give 1 or more")
    try:
        limit_s = parse_quantity(max_time, "time", "s")
    except UnitError as exc:
        raise InputError(f"--max-time {max_time!r}: {exc}") from None
    if not limit_s > 0:
        raise InputError(f"--max-time {max_time!r}: give a positive duration")
    return limit_s


def _load_study(file: Path, params, variant, design, samples, seed, best, figures):
    """The study of ``file`` with the -p options added, and its nominal mechanism (the
    file itself must be valid)."""
    from mechsolve.analyses.study.designs import make_study
    from mechsolve.model.parse import from_source
    from mechsolve.model.source import load_file

    src = load_file(file)
    study = make_study(
        src,
        list(params),
        variant=variant,
        design=design,
        samples=samples,
        seed=seed,
        best=best,
        figures=list(figures),
    )
    return study, from_source(study.source)


def _echo_study(study, nominal) -> None:
    """One line: how many designs, of which design kind, varying which parameters."""
    n = len(study)
    shape = " x ".join(str(len(p.values)) for p in study.params)
    what = f"a grid of {shape}" if study.design == "grid" else study.design
    click.echo(
        f"{nominal.name}: {n} designs ({what}) of " + ", ".join(p.name for p in study.params)
    )


def _workers(n: int, jobs, use_dask, scheduler) -> tuple[int, str]:
    """How many workers will share the designs, and where they run (for the estimate)."""
    from mechsolve.analyses.study.execute import cpu_count

    if scheduler is not None:
        return 1, "one worker of the scheduler"
    workers = 1 if jobs == 1 else min(jobs or cpu_count(), n)
    kind = "a Dask local cluster of {} workers" if use_dask else "a pool of {} processes"
    return workers, "this process" if workers == 1 else kind.format(workers)


def _check_estimate(est, n: int, where: str, max_designs, max_time, limit_s, quiet) -> None:
    """Show the estimate from the timed designs; refuse a study over --max-designs or
    --max-time."""
    from mechsolve.base.errors import InputError

    if not quiet:
        click.echo(f"  estimate: {est.text(where)}")
    if n > max_designs:
        raise InputError(
            f"{n} designs are more than --max-designs {max_designs}: "
            f"{est.text(where)}; give --max-designs {n} to run them, or fewer values"
        )
    if est.seconds > limit_s:
        raise InputError(
            f"{n} designs would take more than --max-time {max_time}: "
            f"{est.text(where)}; give --max-time {_round_up(est.seconds)} to run "
            "them, or fewer values or a larger --step"
        )


def _execute(study, est, jobs, use_dask, scheduler, results_dir, quiet):
    """Solve the designs not yet timed, with a progress bar that starts at the timed ones
    (none when a results file could not be written in those: the study stops there).
    The designs' results that workers wrote (not this process) are added to what the
    command wrote, for the output folder's record, and those of designs without a row
    (finished after a stop) to the outcome's ``late``."""
    from mechsolve.analyses.study import execute as ex
    from mechsolve.base.atomic import note_committed

    if est.unwritten is not None:
        return ex.Outcome(est.rows, len(study), False, "this process", est.unwritten)
    bar = _bar(len(study), quiet)
    if bar is not None:
        bar.update(est.timed)
    before = None if results_dir is None else ex.design_files(results_dir)
    written: list[Path] = []
    try:
        outcome = ex.execute(
            study,
            jobs=jobs,
            dask=use_dask,
            scheduler=scheduler,
            progress=None if bar is None else bar.update,
            results_dir=results_dir,
            first=est.rows,
        )
    finally:  # whatever ends the study (errors: the group's one handler)
        if bar is not None:
            bar.close()
        if before is not None:
            written = ex.written_since(results_dir, before)
            note_committed(written)
    outcome.late = ex.rowless(outcome.rows, written)
    return outcome


def _write_outputs(study, outcome, outdir: Path, fmt: str, no_plots: bool):
    """Write the table (then exit 130 if the study was interrupted, 2 if a design's results
    could not be written), the best design and the plots; return the files written and
    the best design's pick (or None)."""
    from mechsolve.analyses.study.best import pick_best, write_best
    from mechsolve.analyses.study.table import rows_in_units, write_table

    rows = rows_in_units(study, outcome.rows, study.units)
    written = [write_table(study, rows, outdir, fmt)]
    if outcome.interrupted:
        click.echo(
            f"interrupted: {len(rows)} of {len(study)} designs were finished; their rows "
            f"are in {written[0]}",
            err=True,
        )
        _echo_late(outcome, outdir, written[0])
        clikit.interrupted()
    if outcome.unwritten is not None:  # a full disk: the error names the design's file
        click.echo(
            f"stopped after {len(rows)} of {len(study)} designs: a design's results could "
            f"not be written; the rows of the designs solved are in {written[0]}",
            err=True,
        )
        _echo_late(outcome, outdir, written[0])
        raise outcome.unwritten
    pick = pick_best(study, rows) if study.best is not None else None
    if pick is not None:
        written.append(write_best(study, pick, outdir / "best.yaml"))
    if not no_plots:
        from mechsolve.analyses.study.plots import write_plots

        written += write_plots(study, rows, outdir)
    return written, pick


def _echo_late(outcome, outdir: Path, table: Path) -> None:
    """Name the designs a worker finished after the study stopped (a full disk, Ctrl-C):
    their results files are whole, their rows are not in the table; no result is lost."""
    if not outcome.late:
        return
    names = ", ".join(_shown(p, outdir) for p in outcome.late)
    click.echo(
        f"  {len(outcome.late)} design(s) finished after the stop have no row in "
        f"{table.name}, only their results (kept) in {outdir}/: {names}",
        err=True,
    )


def _shown(path: Path, outdir: Path) -> str:
    try:
        return path.relative_to(outdir).as_posix()
    except ValueError:
        return str(path)


class _Counts:
    """How the designs of a finished study ended."""

    def __init__(self, rows, n: int) -> None:
        self.n = n
        self.ok = sum(r["status"] == "ok" for r in rows)
        self.invalid = sum(r["status"].startswith("invalid") for r in rows)
        self.has_req = any("requirements.pass [-]" in r for r in rows)
        self.passing = sum(r.get("requirements.pass [-]") is True for r in rows)


def _echo_outcome(study, outcome, counts: _Counts, pick, written, outdir, kept) -> None:
    """The closing lines: designs that assemble, requirements met, the best design, files
    (``kept``: how many designs' results were written, None without --keep-results)."""
    n, ok, invalid = counts.n, counts.ok, counts.invalid
    click.echo(
        f"  solved on {outcome.executor}: {ok} of {n} designs assemble at every "
        f"position"
        + (f", {invalid} invalid" if invalid else "")
        + (f", {n - ok - invalid} do not assemble or fail" if n - ok - invalid else "")
    )
    if counts.has_req:
        click.echo(f"  requirements: {counts.passing} of {n} designs meet every requirement")
    if study.best is not None:
        sense, expr = study.best
        if pick is None:
            click.echo(f"  best ({sense} {expr}): no design has this figure")
        else:
            click.echo(
                f"  best ({sense} {expr}): design {pick.design}, {pick.column} = "
                f"{pick.value:.6g}: {study.describe(pick.design)}"
                + (f" ({pick.note})" if pick.note else "")
            )
    click.echo(
        f"  wrote {len(written)} file(s) to {outdir}/: "
        + ", ".join(p.name for p in written)
        + (f" and {kept} design results in {outdir}/designs/" if kept is not None else "")
    )
