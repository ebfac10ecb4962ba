"""``mechsolve polygons FILE --at 7``: the graphical velocity and acceleration polygons."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.base.units import pretty_text
from mechsolve.cli.kit import (
    EPILOG_NO_CHECK,
    FILE_ARG,
    QUIET,
    UNITS,
    VARIANT,
    Command,
    finish,
    number,
    output_units,
    whole_number,
    writes_to,
)

SHEET_SUFFIXES = (".png", ".svg")


@click.command("polygons", cls=Command, epilog=EPILOG_NO_CHECK)
@FILE_ARG
@click.option(
    "--at",
    "at",
    required=True,
    metavar="POSITION",
    help="The position: a number (1 at the file's driver start, --per-turn positions per "
    "turn of the crank in its direction of motion, as course designs number them), a "
    "driver angle such as '196.8 deg', or a time from the start such as '0.5 s'.",
)
@VARIANT
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path),
    help="A folder for velocity-polygon.png, acceleration-polygon.png, polygons.png (the "
    "sheet: the mechanism beside both polygons) and polygons.txt; or a file NAME.png or "
    "NAME.svg for the sheet alone (default: a folder named after FILE).",
)
@click.option(
    "--scale-v",
    type=number(),
    metavar="MU",
    help="μv, the velocity scale in (m/s)/mm (default: a round number that fits the polygon "
    "in about 120 mm).",
)
@click.option(
    "--scale-a",
    type=number(),
    metavar="MU",
    help="μa, the acceleration scale in (m/s^2)/mm (default: as for --scale-v).",
)
@click.option(
    "--per-turn",
    type=whole_number(1),
    default=12,
    show_default=True,
    help="How many numbered positions a turn of the crank has.",
)
@click.option("--svg", is_flag=True, help="Also write the drawings as SVG (text kept as text).")
@UNITS
@QUIET
def polygons(
    file: Path, at, variant, output, scale_v, scale_a, per_turn, svg, units, quiet
) -> None:
    """Draw the velocity and acceleration polygons of FILE at one position, to a stated
    scale, as the graphical method builds them (Assur group by group, each unknown point at
    the intersection of two direction lines), print the vectors read from them with the
    links' angular velocities and accelerations, and check them against mechsolve's
    analytic solution."""
    from mechsolve import api
    from mechsolve.analyses.polygons import draw_polygons
    from mechsolve.base.atomic import write_text
    from mechsolve.base.errors import InputError
    from mechsolve.cli.kit import output_folder

    sheet = None
    if output is not None and output.suffix.lower() in SHEET_SUFFIXES:
        sheet = output
        if not output.parent.is_dir():
            raise InputError(f"-o {output}: the folder {output.parent} does not exist")
        outdir = output.parent
        writes_to(output)
    else:
        outdir = output or Path(file.stem + (f"-{variant}" if variant else ""))
    mech = api.load(file, variant)
    shown = output_units(mech, units)
    if sheet is None:
        output_folder(outdir)
    res = draw_polygons(
        mech,
        at,
        outdir,
        scale_v=scale_v,
        scale_a=scale_a,
        per_turn=per_turn,
        svg=svg,
        sheet=sheet,
        units=shown,
    )
    text = res.text(shown)
    written = list(res.images)
    if sheet is None:
        txt = outdir / "polygons.txt"
        write_text(txt, text + "\n")
        written.append(txt)
    if not quiet:
        click.echo(pretty_text(text))
        where = f"{outdir}/: " if sheet is None else ""
        click.echo(f"  wrote {where}" + ", ".join(str(p.name) for p in written))
    finish()
