"""The ``mechsolve`` command. Thin: it parses options, calls :mod:`mechsolve.api`, prints.

Heavy modules (numpy, scipy, matplotlib) are imported inside the commands so that
``mechsolve --help`` starts fast. What the commands share is in :mod:`mechsolve.clikit`.
"""

from __future__ import annotations

import sys
from pathlib import Path
from types import ModuleType

import click

from .clikit import (
    EPILOG,
    EXIT_CHECK_FAILED,
    EXIT_CODES,
    EXIT_INPUT,
    EXIT_OK,
    FILE_ARG,
    NO_PLOTS,
    QUIET,
    VARIANT,
    Group,
    finish,
    outdir_option,
    output_folder,
    warn,
    writes_to,
    writing,
)
from .clikit import progress_bar as _progress_bar
from .clikit import stream_above as _stream_above
from .clikit import watch as _watch
from .commands.animate import animate
from .commands.cam import cam
from .commands.polygons import polygons
from .commands.report import report
from .commands.schema import schema
from .commands.sweep import sweep
from .commands.synth import synth
from .errors import InputError

INCOMPLETE = "the results are incomplete: the summary says what is missing, the CSV rows why"
INCOMPLETE_INSTANTS = "some instants are not solved: the table says why"


@click.group(cls=Group, epilog=EXIT_CODES, context_settings={"help_option_names": ["-h", "--help"]})
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
    mechsolve cam mechanisms/shaper-cam.yaml design and check a cam: profile, pressure
                                             angle, curvature, DXF
    mechsolve synth mechanisms/synth/crane-crank-rocker.yaml -o design.yaml
                                             design a linkage (crank-rocker, slider-crank,
                                             guide bar, three positions, input window)
    mechsolve sweep mechanisms/studies/fourbar-study.yaml
                                             a design study: one row per design, on
                                             all cores or a Dask cluster
    mechsolve run FILE --watch               run again whenever FILE is saved
    mechsolve report mechanisms/crane.yaml -o crane.html
                                             one self-contained HTML report
    mechsolve animate mechanisms/crane.yaml -o crane.gif
                                             the mechanism in motion
    mechsolve polygons mechanisms/shaper.yaml --variant graphical --at 7
                                             velocity and acceleration polygons
    mechsolve schema -o mechanism.schema.json
                                             the file format's JSON Schema (editors)
    mechsolve check mechanisms/crane.yaml    validate, count DOF, assemble the start
    mechsolve bench --quick                  speed against error, in one run
    """


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
    "('s=..., v=..., a=...' for a linear driver; θ/φ, ω, α/ε are the same names; signed, "
    "counter-clockwise positive); omega and alpha default to the file's driver; may be "
    "repeated. Prints every quantity and force and writes instants.csv.",
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
@QUIET
def run(file: Path, outdir, step, variant, no_plots, method, at, junit, fmt, watch, quiet) -> None:
    """Solve the sweep of FILE and write results.csv and plots; check its requirements."""
    if outdir is None:
        outdir = Path(file.stem + (f"-{variant}" if variant else ""))
    args = (file, outdir, step, variant, no_plots, method, at, junit, quiet, fmt)
    writes_to(outdir)
    if watch:
        _watch(file, lambda: _run_job(*args), outdir=outdir)
    code, _ = _run_job(*args)
    sys.exit(code)


def _run_job(
    file: Path, outdir: Path, step, variant, no_plots, method, at, junit, quiet, fmt="png"
):
    """One run: solve, write, print; ``(exit code, results or None)``: 5 when a
    requirement failed, else 0 (with a warning on stderr when the results lack
    something). Errors raise."""
    import numpy as np

    from . import api

    # singular positions give inf and NaN on purpose; the summary reports them
    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    mech = api.load(file, variant)
    st = api.parse_step(mech, step) if step is not None else None
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
            if instants_failed:
                warn(INCOMPLETE_INSTANTS)
            return EXIT_OK, None
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
        # drawn from, so that the terminal, the plots and the requirements agree
        text = res.summary(figures=api.for_plots(mech, res, method))
        failed = res.incomplete()
        written = [res.to_csv(outdir / "results.csv")]
    if not no_plots:
        from .writers.plots import write_plots

        # drawn from a sweep at 1 deg or finer with the exact events; the CSV keeps
        # the file's step
        written += write_plots(api.for_plots(mech, res, method), outdir, fmt)
    verdicts = _requirements(mech, res, junit, streamed=streamed)
    if not quiet:
        click.echo(text)
        click.echo(
            f"  wrote {len(written)} file(s) to {outdir}/: " + ", ".join(p.name for p in written)
        )
    if verdicts:
        from .requirements import verdict_table

        click.echo(verdict_table(verdicts))
    if any(not v.passed for v in verdicts):
        return EXIT_CHECK_FAILED, res
    if failed or instants_failed:
        warn(INCOMPLETE)
    return EXIT_OK, res


def _requirements(mech, res, junit: Path | None, streamed: bool) -> list:
    """Check the file's requirements on the run (and write the JUnit report)."""
    from .requirements import check_requirements, junit_xml

    if not mech.requirements:
        if junit is not None:
            raise InputError(f"--junit {junit}: the file has no 'requirements' section")
        return []
    if streamed:
        raise InputError(
            "the requirements are checked on a run held in memory; this sweep is long "
            "enough to be streamed (raise MECHSOLVE_STREAM_ABOVE or use a coarser --step)"
        )
    verdicts = check_requirements(mech, res)
    if junit is not None:
        from .writers.atomic import write_text

        with writing(junit, "--junit"):
            write_text(junit, junit_xml(verdicts, mech.name, str(mech.source.file or "")))
    return verdicts


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
@click.option(
    "--max-steps",
    type=click.IntRange(min=1),
    default=None,
    metavar="N",
    help="Allow up to N integrator steps (output rows) [default: 200000]; a longer run is "
    "refused before it starts, with its estimated size.",
)
@QUIET
def simulate(file: Path, outdir, variant, no_plots, exact, max_steps, quiet) -> None:
    """Simulate the motor-driven machine of FILE (its motor: and simulate: sections):
    write simulation.csv (time, angle, speed, acceleration, J, motor torque, every
    quantity and joint force) and plots."""
    import numpy as np

    from . import api
    from .dynamics import check_size
    from .dynamics import simulate as run_simulation

    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    mech = api.load(file, variant)
    check_size(mech, max_steps)  # before anything is computed or created
    if outdir is None:
        outdir = Path(file.stem + (f"-{variant}" if variant else ""))
    output_folder(outdir)
    sim = mech.simulation
    steps = int(sim.duration / sim.step) if sim is not None and sim.step else 0
    bar = _progress_bar(steps, quiet) if sim is not None and sim.method == "rk4" else None
    try:
        res = run_simulation(
            mech,
            exact=exact,
            progress=None if bar is None else bar.update,
            max_steps=max_steps,
        )
    finally:
        if bar is not None:
            bar.close()
    written = [res.to_csv(outdir / "simulation.csv")]
    if not no_plots:
        from .writers.simulation import write_simulation_plots

        written += write_simulation_plots(res, res.model, outdir)
    tr = res.trajectory
    if not quiet:
        click.echo(res.summary())
        upto = f" with the motion up to t = {tr.t[-1]:.6g} s" if tr.early else ""
        click.echo(
            f"  wrote {len(written)} file(s){upto} to {outdir}/: "
            + ", ".join(p.name for p in written)
        )
    if tr.error is not None:  # the file's motor law stopped it: an input error
        raise tr.error
    if tr.early:
        finish(warning=f"the motion stopped early, at t = {tr.t[-1]:.6g} s: the summary says why")
    finish(warning=INCOMPLETE if res.incomplete() else None)


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
    as textbook flywheel problems give it (a 'torque:' section, no links), or a power
    diagram (a 'power:' section: the driving and resisting powers over the cycle)."""
    import numpy as np

    from . import api
    from .errors import InputError
    from .flywheel import (
        is_power_problem,
        parse_delta,
        read_power_problem,
        size_flywheel,
        size_from_power,
        size_from_torque,
    )
    from .model.parse import is_torque_problem, read_torque_problem
    from .model.source import load_file
    from .units import UnitError, parse_quantity

    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    dl = parse_delta(delta_given if delta_given is not None else "1/40")
    w = None
    if speed is not None:
        try:
            w = parse_quantity(speed, "angular speed")
        except UnitError as exc:
            raise InputError(f"--speed {speed!r}: {exc}") from None
    if outdir is None:
        outdir = Path(file.stem + (f"-{variant}" if variant else ""))
    src = load_file(file)
    if is_power_problem(src.data):  # a power diagram, as course books pose the shaper
        q = read_power_problem(src)
        if delta_given is None and q["delta"] is not None:
            dl = q["delta"]
        output_folder(outdir)
        try:
            res = size_from_power(
                q["driving"], q["resisting"], cycle=q["cycle"], speed=w or q["speed"],
                delta=dl,
            )  # fmt: skip
        except InputError as exc:
            raise q["reader"].fail(("power",), exc.message) from None
        name = q["name"]
    elif is_torque_problem(src):  # a torque curve given directly, as textbooks do
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
    finish(check_failed=res.check_missed())


@main.command(epilog=EPILOG)
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
    from . import api

    mech = api.load(file, variant)
    report = api.check(mech)
    click.echo(report.text())
    if draw is not None:
        from .writers.plots import draw_start

        with writing(draw, "--draw"):
            draw_start(report.analysis, report.assembly.state, draw, f"{mech.name}: start position")
        click.echo(f"  drew the start position to {draw}")
    sys.exit(EXIT_OK)


def _bench_tool() -> ModuleType:
    """The benchmark package ``mechsolve_bench``, imported here and nowhere else in mechsolve.

    The benchmarks (their cases, the hand-written references, the peers' models) are a
    tool beside the solver, not a part of it: this lazy import is the one edge from
    mechsolve to them (tests/test_issue24_bench.py checks it), so that no solver module
    loads them. They are installed with mechsolve; if they are missing, say how to get them.
    """
    try:
        import mechsolve_bench
    except ModuleNotFoundError as exc:
        if exc.name != "mechsolve_bench":
            raise  # something the bench imports is missing: a bug, not the install
        raise InputError(
            "mechsolve bench needs the benchmark package mechsolve_bench, which is not "
            "installed: pip install 'mechsolve[bench]' (from a checkout of the "
            "repository: pip install '.[bench]'; the extra adds the peers pylinkage and exudyn)"
        ) from None
    return mechsolve_bench


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
            "newton-groups",
            "fourbar-kinetostatics",
            "crane-kinetostatics",
            "startup-dynamics",
            "dynamics-work-precision",
            "chain-growth",
            "positions-growth",
            "stream",
            "startup",
            "study",
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
    b = _bench_tool()
    done = b.run(quick=quick, cases=list(cases) or None, echo=click.echo)
    if plot is not None:
        b.plot(done, plot)
        click.echo(f"wrote the work-precision diagram to {plot}")
        dyn = [c for c in done if c.name == "dynamics-work-precision"]
        if dyn:
            p = Path(plot)
            out = b.plot_dynamics(dyn[0], p.with_name(p.stem + "-dynamics" + p.suffix))
            click.echo(f"wrote the integrators' work-precision diagram to {out}")


# commands with a module of their own (mechsolve/commands/)
main.add_command(cam)
main.add_command(synth)
main.add_command(sweep)
main.add_command(report)
main.add_command(animate)
main.add_command(polygons)
main.add_command(schema)

if __name__ == "__main__":  # pragma: no cover
    main()

__all__ = ["main", "EXIT_INPUT"]
