"""``mechsolve animate FILE -o crane.gif``: the mechanism in motion as a GIF or an MP4."""

from __future__ import annotations

from pathlib import Path

import click

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
    writing,
)


def _size(text: str) -> tuple[int, int]:
    from mechsolve.base.errors import InputError
    from mechsolve.base.keyspec import whole
    from mechsolve.base.units import UnitError, read_number

    w, sep, h = text.lower().partition("x")
    try:  # read as the file's numbers are (no full-width digits, no 1_000)
        size = (whole(read_number(w)), whole(read_number(h)))
    except UnitError:
        size = (0, 0)
    if not all(isinstance(n, int) for n in size):
        size = (0, 0)
    if not sep or not (64 <= size[0] <= 4096 and 64 <= size[1] <= 4096):
        raise InputError(f"--size {text!r}: width x height in pixels, e.g. 800x600 (64 to 4096)")
    return size


@click.command("animate", cls=Command, epilog=EPILOG_NO_CHECK)
@FILE_ARG
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False, path_type=Path),
    help="The animation: NAME.gif, or NAME.mp4 when ffmpeg is installed "
    "(default: FILE's name with .gif, in the current directory).",
)
@VARIANT
@click.option(
    "--frames",
    type=whole_number(2),
    help="Number of frames over the file's sweep (default: one per degree of a revolute "
    "driver, 361 for a linear driver or a sweep in time), whatever step the file tabulates.",
)
@click.option("--fps", type=number(0, low_open=True), default=30.0,
              show_default=True, help="Frames per second.")  # fmt: skip
@click.option(
    "--forces",
    is_flag=True,
    help="Draw the reaction at each joint as an arrow (the force on the joint's second "
    "link by its first), all on one scale (needs masses or loads in the file).",
)
@click.option("--size", "size_text", default="800x600", show_default=True,
              help="Image size in pixels, WIDTHxHEIGHT.")  # fmt: skip
@UNITS
@QUIET
def animate(file: Path, output, variant, frames, fps, forces, size_text, units, quiet) -> None:
    """Animate FILE: the mechanism to scale over its sweep, the paths of its output points
    traced, the driver's angle (or position) and the time shown; frames from a fine sweep
    (1 degree by default) whatever the file's step. The axes, the force scale and the
    driver's value are in the file's units (--units to change them)."""
    import numpy as np

    from mechsolve import api
    from mechsolve.base.errors import InputError
    from mechsolve.report.animate import (
        FFMPEG_HINT,
        check_frame_count,
        ffmpeg_available,
        solve_frames,
        write_animation,
    )

    np.seterr(divide="ignore", invalid="ignore", over="ignore")
    check_frame_count(frames)  # before loading or solving anything
    size = _size(size_text)
    if output is None:
        output = Path(file.stem + (f"-{variant}" if variant else "") + ".gif")
    if output.suffix.lower() not in (".gif", ".mp4"):
        raise InputError(f"-o {output}: the animation is written as .gif or .mp4")
    if output.suffix.lower() == ".mp4" and not ffmpeg_available():
        raise InputError(f"-o {output}: {FFMPEG_HINT}")
    if not output.parent.is_dir():
        raise InputError(f"-o {output}: the folder {output.parent} does not exist")
    mech = api.load(file, variant)
    shown = output_units(mech, units)
    writes_to(output)
    fr = solve_frames(mech, frames, forces=forces, units=shown)
    with writing(output, "-o"):
        write_animation(fr, output, fps=fps, size=size)
    missing = int(np.count_nonzero(~fr.ok))
    if not quiet:
        seconds = len(fr) / fps
        click.echo(
            f"{mech.name}: {len(fr)} frames ({fr.label(0)} to {fr.label(len(fr) - 1)}), "
            f"{seconds:.3g} s at {fps:g} frames/s, {size[0]}x{size[1]} pixels"
        )
        click.echo(f"  wrote {output}")
    finish(
        warning=f"the mechanism cannot close in {missing} of {len(fr)} frames "
        "(drawn empty; `mechsolve run` says where and why)"
        if missing
        else None
    )
