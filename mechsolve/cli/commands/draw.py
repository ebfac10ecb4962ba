"""``mechsolve draw FILE -o linkage.dxf``: the linkage as a dimensioned drawing for CAD."""

from __future__ import annotations

from pathlib import Path

import click

from mechsolve.cli.kit import (
    EPILOG_NO_CHECK,
    FILE_ARG,
    QUIET,
    VARIANT,
    Command,
    finish,
    warn,
    whole_number,
    writes_to,
)

SUFFIXES = (".dxf", ".svg", ".pdf")
ENVELOPE_POSITIONS = 36


@click.command("draw", cls=Command, epilog=EPILOG_NO_CHECK)
@FILE_ARG
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="The drawing: NAME.dxf (layers LINKS, PINS, GROUND, GUIDES, JOINTS, PATHS, "
    "DIMENSIONS, ENVELOPE; needs ezdxf), NAME.svg or NAME.pdf (on A4 at a standard scale).",
)
@click.option(
    "--at",
    "at",
    metavar="POSITION",
    help="The position drawn, as `mechsolve polygons --at` takes it: a number (1 at the "
    "driver's start, --per-turn per turn), a driver angle such as '196.8 deg' or position "
    "such as '20 mm', or a time from the start such as '0.5 s' (default: the start).",
)
@click.option(
    "--per-turn",
    type=whole_number(1),
    default=12,
    show_default=True,
    help="How many numbered positions a turn of the crank (or the sweep) has, for --at N.",
)
@click.option(
    "--envelope",
    is_flag=True,
    help=f"Also outline the links at {ENVELOPE_POSITIONS} positions over the sweep and "
    "dimension the overall extent of the linkage in motion (layer ENVELOPE).",
)
@VARIANT
@QUIET
def draw(file: Path, output, at, per_turn, envelope, variant, quiet) -> None:
    """Draw FILE's linkage for CAD at one position: the links as bars with their pin
    circles, slider blocks and their guides, ground pivots with hatching, gear pitch
    circles and cam profiles, the point paths over the sweep (coupler curves) and the
    aligned dimensions of the link lengths between their joint points, in the file's
    length unit."""
    import numpy as np

    from mechsolve import api
    from mechsolve.base.errors import InputError
    from mechsolve.writers import drawing

    suffix = output.suffix.lower()
    if suffix not in SUFFIXES:
        raise InputError(f"-o {output}: the drawing is a .dxf, .svg or .pdf file")
    if suffix == ".dxf":
        try:
            import ezdxf  # noqa: F401
        except ImportError:
            raise InputError(f"-o {output}: {drawing.DXF_HINT}") from None
    if not output.parent.is_dir():
        raise InputError(f"-o {output}: the folder {output.parent} does not exist")
    writes_to(output)
    mech = api.load(file, variant)
    res = api.solve(mech, forces=False, velocity=False, acceleration=False)
    fine = api.for_plots(mech, res)
    sweep_state = fine.solution.state
    if at is None:
        ok = np.flatnonzero(fine.ok)
        if not len(ok):
            raise InputError(f"{file}: no position of the sweep could be solved to draw")
        an, state, i, where = fine.analysis, sweep_state, int(ok[0]), "at the start"
    else:
        an, state, i, where = _instant(mech, at, per_turn)
    paths = {p: np.column_stack([fine.point(p).x, fine.point(p).y]) for p in fine.point_names()}
    sh = drawing.sheet(
        an,
        state,
        i,
        sweep=sweep_state,
        paths=paths,
        envelope=ENVELOPE_POSITIONS if envelope else 0,
        title=f"{mech.name}, {where}",
        unit=mech.length_unit,
    )
    if suffix == ".dxf":
        drawing.write_dxf(sh, output)
        if drawing.dxf_unit_code(sh.unit) is None:
            from mechsolve.base.units import parse_unit

            warn(
                f"DXF has no unit code for {sh.unit!r} (1 {sh.unit} = "
                f"{parse_unit(sh.unit).factor:.6g} m): {output} is unitless ($INSUNITS 0); "
                f"its dimensions name the unit"
            )
    else:
        drawing.write_figure(sh, output)
    if not quiet:
        click.echo(
            f"{mech.name}: drawn {where}: {len(sh.bars)} bars, {len(sh.blocks)} blocks, "
            f"{len(sh.dimensions)} dimensions [{sh.unit}], {len(sh.paths)} paths"
        )
        click.echo(f"  wrote {output}")
    finish()


def _instant(mech, at: str, per_turn: int):
    """The analysis, the state, its index and the words of the position ``--at`` (in the
    file's units: a linear driver's position in its length unit)."""
    from mechsolve.analyses.instants import solve_instants
    from mechsolve.analyses.polygons.construction import resolve_at
    from mechsolve.base.errors import SolverError
    from mechsolve.core.sweep import Analysis

    an = Analysis(mech)
    inst = resolve_at(an, at, per_turn)
    label = inst.label
    if an.linear:  # the words hold the position in m: in the file's unit instead
        shown = f"driver position {mech.output_units().text(inst.u, 'm')}"
        label = label.replace(an.format_u(inst.u), shown)
    res = solve_instants(mech, [inst], forces=False)
    if not res.ok[0]:
        raise SolverError(
            f"draw --at {at!r}: the mechanism cannot close at {label}: {res.status()[0]}"
        )
    return res.analysis, res.solution.state, 0, f"at {label}"
