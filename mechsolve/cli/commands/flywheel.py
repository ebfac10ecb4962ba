"""``mechsolve flywheel FILE``: size a flywheel by the energy method, checked by
simulation."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.base.units import pretty_text
from mechsolve.cli.kit import (
    EPILOG,
    FILE_ARG,
    UNITS,
    VARIANT,
    Command,
    finish,
    outdir_option,
    output_folder,
    output_units,
)


@click.command("flywheel", cls=Command, epilog=EPILOG)
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
@UNITS
def flywheel(file: Path, delta_given, speed, outdir, variant, no_check, units) -> None:
    """Size a flywheel on the driver's shaft for a coefficient of fluctuation DELTA, by the
    energy method over the steady cycle (with a motor and a simulate: section, checked by
    simulating the machine with it); FILE is a mechanism, or a torque curve over a cycle
    as textbook flywheel problems give it (a 'torque:' section, no links), or a power
    diagram (a 'power:' section: the driving and resisting powers over the cycle)."""
    import numpy as np

    from mechsolve import api
    from mechsolve.analyses.flywheel import (
        is_power_problem,
        parse_delta,
        read_power_problem,
        size_flywheel,
        size_from_power,
        size_from_torque,
    )
    from mechsolve.base.errors import InputError
    from mechsolve.base.units import UnitError, parse_quantity
    from mechsolve.model.parse import is_torque_problem, read_torque_problem
    from mechsolve.model.source import load_file

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
    # a torque curve or a power diagram has no mechanism: SI unless --units says else
    shown = output_units(_NoMechanism, units)
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
        shown = output_units(mech, units)
        output_folder(outdir)
        res = size_flywheel(mech, dl, omega_mean=w, check=not no_check)
        name = mech.name
    from mechsolve.analyses.dynamics.plots import write_energy_mass_plot, write_energy_plot

    paths = [
        write_energy_plot(res, name, outdir, shown),
        write_energy_mass_plot(res, name, outdir, shown),
    ]
    click.echo(pretty_text(res.text(shown)))
    click.echo("  wrote " + ", ".join(str(p) for p in paths if p is not None))
    finish(check_failed=res.check_missed())


class _NoMechanism:
    """The units of a file without a mechanism (a torque curve, a power diagram): SI."""

    @staticmethod
    def output_units():
        from mechsolve.base.units import SI_OUTPUT

        return SI_OUTPUT
