"""The ``mechsolve`` command. Thin: it parses options, calls :mod:`mechsolve.api`, prints.

Heavy modules (numpy, scipy, matplotlib) are imported inside the commands so that
``mechsolve --help`` starts fast.
"""

from __future__ import annotations

import os
import sys
import tempfile
import traceback
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any

import click

from .errors import EXIT_INPUT, EXIT_OK, EXIT_WARNINGS, InputError, MechsolveError

EXIT_INTERNAL = 4
EXIT_INTERRUPTED = 130  # the shell's convention for Ctrl-C
STREAM_ABOVE = 200_000  # positions: longer sweeps are solved and written chunk by chunk
PROGRESS_DELAY = 1.0  # seconds: a streamed run that ends sooner never shows its bar

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


def _ancestor_problem(path: Path) -> str | None:
    """Why a folder cannot be created at ``path`` when one of its parents is a file."""
    for parent in [path, *path.parents]:
        if parent.exists() or parent.is_symlink():
            if not parent.is_dir():
                return f"{parent} is a file, not a folder"
            return None
    return None


def output_folder(outdir: Path) -> Path:
    """Create ``outdir`` and make sure a file can be written in it, before anything is
    solved (a long sweep must not fail at its end); an OS refusal is an input error."""
    try:
        outdir.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".mechsolve-", suffix=".probe", dir=outdir)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        why = _ancestor_problem(outdir) or exc.strerror or str(exc)
        raise InputError(f"-o {outdir}: the output folder cannot be written: {why}") from None
    return outdir


def _write_error(exc: OSError, outdir: Path) -> InputError | None:
    """An OS error while writing into ``outdir`` (full disk, permissions changed under
    us) as a message, or None when it concerns some other file."""
    name = exc.filename
    if not isinstance(name, (str, os.PathLike)):
        return None
    try:
        Path(name).resolve().relative_to(outdir.resolve())
    except ValueError:
        return None
    return InputError(f"cannot write {name}: {exc.strerror or exc}")


def progress_wanted(
    quiet: bool, stream: IO[str] | None = None, environ: Mapping[str, str] | None = None
) -> bool:
    """Whether to show a progress bar: on a terminal, not under ``-q``, not in CI (the
    ``CI`` environment variable set to anything but empty, 0, false or no), and only
    when tqdm is installed (it is optional: ``pip install "mechsolve[progress]"``)."""
    stream = sys.stderr if stream is None else stream
    environ = os.environ if environ is None else environ
    if quiet or environ.get("CI", "").strip().lower() not in ("", "0", "false", "no"):
        return False
    try:
        if not stream.isatty():
            return False
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False
    try:
        import tqdm  # noqa: F401
    except ImportError:
        return False
    return True


def _progress_bar(total: int, quiet: bool) -> Any | None:
    """A tqdm bar over ``total`` positions on stderr, or None (see :func:`progress_wanted`)."""
    if not progress_wanted(quiet):
        return None
    from tqdm import tqdm

    return tqdm(
        total=total,
        desc="solving",
        unit=" positions",
        unit_scale=True,
        delay=PROGRESS_DELAY,
        leave=False,  # the summary follows; the bar has done its job
        dynamic_ncols=True,
        file=sys.stderr,
    )


def _stream_above() -> int:
    text = os.environ.get("MECHSOLVE_STREAM_ABOVE")
    if text is None:
        return STREAM_ABOVE
    try:
        return int(text)
    except ValueError:
        raise InputError(
            f"MECHSOLVE_STREAM_ABOVE={text!r}: expected a whole number of positions"
        ) from None


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
    mechsolve run FILE --at "theta=30 deg, omega=10 rad/s, alpha=5 rad/s^2"
                                             every quantity and force at an instant
    mechsolve simulate mechanisms/motor-linkage.yaml
                                             a motor-driven start-up (forward dynamics)
    mechsolve flywheel mechanisms/shaper.yaml --delta 1/40
                                             size a flywheel by the energy method
    mechsolve check mechanisms/crane.yaml    validate, count DOF, assemble the start
    mechsolve bench --quick                  speed against error, in one run
    """


# options that several commands share
FILE_ARG = click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
VARIANT = click.option("--variant", help="Apply the named entry of the file's 'variants' section.")
NO_PLOTS = click.option("--no-plots", is_flag=True, help="Write the CSV only.")
QUIET = click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")


def outdir_option(what: str = "results"):
    return click.option(
        "-o",
        "--outdir",
        type=click.Path(file_okay=False, path_type=Path),
        help=f"Output folder for the {what} (default: a folder named after FILE in the "
        "current directory).",
    )


@main.command(epilog=EPILOG)
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
    "('s=..., v=..., a=...' for a linear driver; alpha defaults to 0); may be repeated. "
    "Prints every quantity and force and writes instants.csv.",
)
@QUIET
def run(file: Path, outdir, step, variant, no_plots, method, at, quiet) -> None:
    """Solve the sweep of FILE and write results.csv and plots."""
    _interrupt_on_sigterm()
    bar = None
    try:
        import numpy as np

        from . import api

        # singular positions give inf and NaN on purpose; the summary reports them
        np.seterr(divide="ignore", invalid="ignore", over="ignore")
        mech = api.load(file, variant)
        st = api.parse_step(mech, step) if step is not None else None
        if outdir is None:
            outdir = Path(file.stem + (f"-{variant}" if variant else ""))
        output_folder(outdir)
        n = api.positions(mech, st)
        instants_failed = False
        if at or mech.instants:
            from .instants import Instant, instants_table, parse_instant, solve_instants

            todo = [parse_instant(mech, a) for a in at] or [Instant(*i) for i in mech.instants]
            ires = solve_instants(mech, todo, method=method)
            path = ires.to_csv(outdir / "instants.csv")
            instants_failed = ires.incomplete()
            if not quiet:
                click.echo(instants_table(ires))
                click.echo(f"  wrote {path}")
            if at:  # only the instants asked for
                sys.exit(EXIT_WARNINGS if instants_failed else EXIT_OK)
        if n > _stream_above() and mech.driver.motion is None:
            # a long sweep: solved chunk by chunk, the CSV streamed, plots from a coarse
            # sweep of the same range; a bar on a terminal, moved on after each chunk
            bar = _progress_bar(n, quiet)
            summary, res = api.stream(
                mech,
                outdir / "results.csv",
                step=st,
                method=method,
                progress=None if bar is None else bar.update,
            )
            if bar is not None:
                bar.close()
                bar = None
            text, failed = summary.text(res), summary.incomplete()
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
        sys.exit(EXIT_WARNINGS if failed or instants_failed else EXIT_OK)
    except KeyboardInterrupt:
        # Ctrl-C or SIGTERM: partial files were removed on the way out; finished ones stay
        if bar is not None:
            bar.close()
        click.echo("interrupted: the files not yet finished were not written", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except OSError as exc:
        if bar is not None:
            bar.close()
        _fail((outdir is not None and _write_error(exc, outdir)) or exc)
    except Exception as exc:  # noqa: BLE001 - every error becomes a message
        if bar is not None:
            bar.close()
        _fail(exc)


@main.command(epilog=EPILOG)
@FILE_ARG
@outdir_option("simulation's files")
@VARIANT
@NO_PLOTS
@click.option(
    "--exact",
    is_flag=True,
    help="Solve the equation of motion at every integrator stage (no tabulation).",
)
@QUIET
def simulate(file: Path, outdir, variant, no_plots, exact, quiet) -> None:
    """Simulate the motor-driven machine of FILE (its motor: and simulate: sections):
    write simulation.csv (time, angle, speed, acceleration, J, motor torque, every
    quantity and joint force) and plots."""
    _interrupt_on_sigterm()
    try:
        import numpy as np

        from . import api
        from .dynamics import simulate as run_simulation

        np.seterr(divide="ignore", invalid="ignore", over="ignore")
        mech = api.load(file, variant)
        if outdir is None:
            outdir = Path(file.stem + (f"-{variant}" if variant else ""))
        output_folder(outdir)
        sim = mech.simulation
        steps = int(sim.duration / sim.step) if sim is not None and sim.step else 0
        bar = _progress_bar(steps, quiet) if sim is not None and sim.method == "rk4" else None
        try:
            res = run_simulation(mech, exact=exact, progress=None if bar is None else bar.update)
        finally:
            if bar is not None:
                bar.close()
        written = [res.to_csv(outdir / "simulation.csv")]
        if not no_plots:
            from .writers.simulation import write_simulation_plots

            written += write_simulation_plots(res, res.model, outdir)
        if not quiet:
            click.echo(res.summary())
            click.echo(
                f"  wrote {len(written)} file(s) to {outdir}/: "
                + ", ".join(p.name for p in written)
            )
        sys.exit(EXIT_WARNINGS if res.incomplete() else EXIT_OK)
    except KeyboardInterrupt:
        click.echo("interrupted: the files not yet finished were not written", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except OSError as exc:
        _fail((outdir is not None and _write_error(exc, outdir)) or exc)
    except Exception as exc:  # noqa: BLE001 - every error becomes a message
        _fail(exc)


@main.command(epilog=EPILOG)
@FILE_ARG
@click.option(
    "--delta",
    "delta_given",
    default=None,
    help="Coefficient of speed fluctuation (omega_max - omega_min) / omega_mean "
    "[default: the file's, else 1/40].",
)
@click.option(
    "--speed",
    help="Mean speed (default: the steady speed with the file's motor, "
    "else the driver's speed), e.g. '60 rpm'.",
)
@outdir_option("energy plots")
@VARIANT
@click.option("--no-check", is_flag=True, help="Do not verify the flywheel by simulation.")
def flywheel(file: Path, delta_given, speed, outdir, variant, no_check) -> None:
    """Size a flywheel on the crank's shaft for a coefficient of fluctuation DELTA, by the
    energy method over the steady cycle (with a motor and a simulate: section, checked by
    simulating the machine with it); FILE is a mechanism, or a torque curve over a cycle
    as textbook flywheel problems give it (a 'torque:' section, no links)."""
    try:
        import numpy as np

        from . import api
        from .errors import InputError
        from .flywheel import size_flywheel, size_from_torque
        from .model.parse import is_torque_problem, read_torque_problem
        from .model.source import load_file
        from .units import UnitError, parse_quantity

        np.seterr(divide="ignore", invalid="ignore", over="ignore")
        delta = delta_given if delta_given is not None else "1/40"
        try:
            num, _, den = str(delta).partition("/")
            dl = float(num) / float(den) if den else float(num)
        except ValueError:
            raise InputError(f"--delta {delta!r}: a number such as 0.025 or 1/40") from None
        w = None
        if speed is not None:
            try:
                w = parse_quantity(speed, "angular speed")
            except UnitError as exc:
                raise InputError(f"--speed {speed!r}: {exc}") from None
        if outdir is None:
            outdir = Path(file.stem + (f"-{variant}" if variant else ""))
        src = load_file(file)
        if is_torque_problem(src):  # a torque curve given directly, as textbooks do
            p = read_torque_problem(src)
            if delta_given is None and p["delta"] is not None:
                dl = p["delta"]
            output_folder(outdir)
            res = size_from_torque(
                p["angles"], p["torque"], speed=w or p["speed"], delta=dl, resisting=p["resisting"]
            )
            name = p["name"]
        else:
            mech = api.load(file, variant)
            output_folder(outdir)
            res = size_flywheel(mech, dl, omega_mean=w, check=not no_check)
            name = mech.name
        from .writers.simulation import write_energy_mass_plot, write_energy_plot

        paths = [write_energy_plot(res, name, outdir), write_energy_mass_plot(res, name, outdir)]
        click.echo(res.text())
        click.echo("  wrote " + ", ".join(str(p) for p in paths if p is not None))
        sys.exit(EXIT_OK)
    except Exception as exc:  # noqa: BLE001 - every error becomes a message
        _fail(exc)


@main.command(epilog=EPILOG)
@FILE_ARG
@VARIANT
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

            try:
                draw_start(
                    report.analysis, report.assembly.state, draw, f"{mech.name}: start position"
                )
            except OSError as exc:
                raise InputError(f"--draw {draw}: cannot write it: {exc.strerror or exc}") from None
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
            "startup-dynamics",
            "dynamics-work-precision",
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
            dyn = [c for c in done if c.name == "dynamics-work-precision"]
            if dyn:
                p = Path(plot)
                out = b.plot_dynamics(dyn[0], p.with_name(p.stem + "-dynamics" + p.suffix))
                click.echo(f"wrote the integrators' work-precision diagram to {out}")
    except Exception as exc:  # noqa: BLE001
        _fail(exc)


if __name__ == "__main__":  # pragma: no cover
    main()

__all__ = ["main", "EXIT_INPUT"]
