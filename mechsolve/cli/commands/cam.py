"""``mechsolve cam FILE``: design and check a cam from its file, write its motion table,
profile (CSV and DXF) and plots."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.base.units import pretty_text
from mechsolve.cli.kit import (
    EPILOG,
    FILE_ARG,
    NO_PLOTS,
    QUIET,
    VARIANT,
    Command,
    finish,
    outdir_option,
    output_folder,
)


@click.command("cam", cls=Command, epilog=EPILOG)
@FILE_ARG
@outdir_option("cam's files")
@VARIANT
@NO_PLOTS
@click.option("--no-dxf", is_flag=True, help="Do not write the profile as DXF.")
@QUIET
def cam(file: Path, outdir, variant, no_plots, no_dxf, quiet) -> None:
    """Design and check the cam of FILE (its cam: section): motion law, base size for the
    allowable pressure angle, profile by inversion, pressure angle for both senses,
    curvature and undercutting. Writes cam_motion.csv, cam_profile.csv, cam_profile.dxf
    and plots; exits 5 (a design check failed) when the design exceeds its allowances
    (pressure angle, curvature) or undercuts."""
    import numpy as np

    from mechsolve.analyses.cam.analysis import analyse
    from mechsolve.analyses.cam.model import load
    from mechsolve.analyses.cam.writers import (
        DXF_HINT,
        write_dxf,
        write_motion_csv,
        write_plots,
        write_profile_csv,
    )

    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    model = load(file, variant)
    if outdir is None:
        outdir = Path(file.stem + (f"-{variant}" if variant else ""))
    output_folder(outdir)
    try:
        res = analyse(model)
    except ValueError as exc:  # a base size that leaves no cam, no design asked
        from mechsolve.base.errors import InputError

        raise InputError(str(exc), file=model.file, keypath="cam") from None
    written = [
        write_motion_csv(res, outdir / "cam_motion.csv"),
        write_profile_csv(res, outdir / "cam_profile.csv"),
    ]
    notes = []
    if not no_dxf:
        dxf = write_dxf(res, outdir / "cam_profile.dxf")
        if dxf is None:
            notes.append(f"  note: no cam_profile.dxf: {DXF_HINT}")
        else:
            written.append(dxf)
    if not no_plots:
        written += write_plots(res, outdir)
    if not quiet:
        click.echo(pretty_text(res.summary()))
        click.echo(
            f"  wrote {len(written)} file(s) to {outdir}/: " + ", ".join(p.name for p in written)
        )
    for n in notes:
        click.echo(n, err=True)
    finish(check_failed=bool(res.problems))
