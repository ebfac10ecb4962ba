"""The ``mechsolve`` command. Thin: it parses options, calls :mod:`mechsolve.api`, prints.

Heavy modules (numpy, scipy, matplotlib) are imported inside the commands so that
``mechsolve --help`` starts fast.
"""

from __future__ import annotations

import os
import sys
import traceback
from pathlib import Path

import click

from .errors import EXIT_INPUT, EXIT_OK, EXIT_WARNINGS, MechsolveError

EXIT_INTERNAL = 4
EXIT_INTERRUPTED = 130  # the shell's convention for Ctrl-C
STREAM_ABOVE = 200_000  # positions: longer sweeps are solved and written chunk by chunk

EPILOG = """\b
Exit codes:
  0  success
  1  completed with warnings: some positions could not be solved, or
     some values are not determined at singular positions (their CSV
     rows say why), or a check failed; everything else was written
  2  input error: the file or the command line is wrong
  3  solver failure: the mechanism cannot be assembled or solved
  4  internal error (a bug in mechsolve; please report it)
  130  interrupted (Ctrl-C or SIGTERM); no half-written file is left
"""


def _fail(exc: BaseException) -> None:
    if isinstance(exc, MechsolveError):
        click.echo(f"error: {exc}", err=True)
        sys.exit(exc.exit_code)
    if isinstance(exc, (click.exceptions.Exit, click.ClickException, SystemExit)):
        raise exc
    if os.environ.get("MECHSOLVE_DEBUG"):
        traceback.print_exc()
    else:
        click.echo(
            f"internal error: {type(exc).__name__}: {exc}\n"
            "This is a bug in mechsolve. Set MECHSOLVE_DEBUG=1 to see the traceback.",
            err=True,
        )
    sys.exit(EXIT_INTERNAL)


def _interrupt_on_sigterm() -> None:
    """Make SIGTERM unwind like Ctrl-C, so that a half-written file is removed."""
    import signal

    def handler(signum, frame):  # noqa: ARG001
        raise KeyboardInterrupt

    try:
        signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread (an embedding application): leave it
        pass


@click.group(epilog=EPILOG, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="mechsolve")
def main() -> None:
    """Solve planar mechanisms described in YAML files.

    \b
    mechsolve run mechanisms/crane.yaml      solve the sweep, write CSV and plots
    mechsolve check mechanisms/crane.yaml    validate, count DOF, assemble the start
    mechsolve bench --quick                  speed against error, in one run
    """


@main.command(epilog=EPILOG)
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option(
    "-o",
    "--outdir",
    type=click.Path(file_okay=False, path_type=Path),
    help="Output folder (default: a folder named after FILE in the current directory).",
)
@click.option("--step", help="Sweep step, e.g. '1 deg', '2 mm' or '0.01 s' (overrides the file).")
@click.option("--variant", help="Apply the named entry of the file's 'variants' section.")
@click.option("--no-plots", is_flag=True, help="Write the CSV only.")
@click.option(
    "--method",
    type=click.Choice(["auto", "newton", "split-newton"]),
    help="auto: closed-form Assur groups where recognised (default); newton: Newton-Raphson "
    "on the whole constraint system; split-newton: the same groups as auto, each by "
    "Newton-Raphson.",
)
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
def run(file: Path, outdir, step, variant, no_plots, method, quiet) -> None:
    """Solve the sweep of FILE and write results.csv and plots."""
    _interrupt_on_sigterm()
    try:
        import numpy as np

        from . import api

        # singular positions give inf and NaN on purpose; the summary reports them
        np.seterr(divide="ignore", invalid="ignore", over="ignore")
        mech = api.load(file, variant)
        st = api.parse_step(mech, step) if step is not None else None
        if outdir is None:
            outdir = Path(file.stem + (f"-{variant}" if variant else ""))
        outdir.mkdir(parents=True, exist_ok=True)
        stream_above = int(os.environ.get("MECHSOLVE_STREAM_ABOVE", STREAM_ABOVE))
        if api.positions(mech, st) > stream_above:
            # a long sweep: solved chunk by chunk, the CSV streamed, plots from a coarse
            # sweep of the same range
            summary, res = api.stream(mech, outdir / "results.csv", step=st, method=method)
            text, failed = summary.text(res), bool(summary.failures)
            written = [summary.path]
        else:
            res = api.solve(mech, step=st, method=method)
            text = res.summary()
            failed = res.incomplete()
            written = [res.to_csv(outdir / "results.csv")]
        if not no_plots:
            from .writers.plots import write_plots

            written += write_plots(res, outdir)
        if not quiet:
            click.echo(text)
            click.echo(
                f"  wrote {len(written)} file(s) to {outdir}/: "
                + ", ".join(p.name for p in written)
            )
        sys.exit(EXIT_WARNINGS if failed else EXIT_OK)
    except KeyboardInterrupt:
        # Ctrl-C or SIGTERM: partial files were removed on the way out; finished ones stay
        click.echo("interrupted: the files not yet finished were not written", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except Exception as exc:  # noqa: BLE001 - every error becomes a message
        _fail(exc)


@main.command(epilog=EPILOG)
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--variant", help="Apply the named entry of the file's 'variants' section.")
@click.option(
    "--draw",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Draw the assembled start position to this PNG file.",
)
def check(file: Path, variant, draw) -> None:
    """Validate FILE, report its degrees of freedom and assemble the start position."""
    try:
        from . import api

        mech = api.load(file, variant)
        report = api.check(mech)
        click.echo(report.text())
        if draw is not None:
            from .writers.plots import draw_start

            draw_start(report.analysis, report.assembly.state, draw, f"{mech.name}: start position")
            click.echo(f"  drew the start position to {draw}")
        sys.exit(EXIT_OK)
    except Exception as exc:  # noqa: BLE001
        _fail(exc)


@main.command()
@click.option("--quick", is_flag=True, help="Few repetitions and small sizes (as CI runs it).")
@click.option(
    "--case",
    "cases",
    multiple=True,
    type=click.Choice(
        [
            "fourbar-kinematics",
            "crane-kinematics",
            "fourbar-kinetostatics",
            "crane-kinetostatics",
            "chain-growth",
            "positions-growth",
            "stream",
            "startup",
            "peers",
        ]
    ),
    help="Run only these cases (repeatable).",
)
@click.option(
    "--plot",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Write a work-precision diagram (time against error, log-log) to this file.",
)
def bench(quick, cases, plot) -> None:
    """Measure speed against error: mechsolve against hand-written closed forms.

    \b
    Each case prints its settings with their median wall time and largest error
    against an independent reference, then the ratio to the hand-written closed form.
    Results measured on this project's machine are in benchmarks/README.md.
    """
    try:
        from . import bench as b

        done = b.run(quick=quick, cases=list(cases) or None, echo=click.echo)
        if plot is not None:
            b.plot(done, plot)
            click.echo(f"wrote the work-precision diagram to {plot}")
    except Exception as exc:  # noqa: BLE001
        _fail(exc)


if __name__ == "__main__":  # pragma: no cover
    main()

__all__ = ["main", "EXIT_INPUT"]
