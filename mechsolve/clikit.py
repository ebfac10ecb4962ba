"""What the ``mechsolve`` commands share: exit codes, error reporting, output folders,
progress bars and the common options. Every command module imports these from here, so
a new command can live in its own module beside the stages it calls."""

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
  5  a requirement of the file failed (run: its table says which;
     everything was written)
  130  interrupted (Ctrl-C or SIGTERM); no half-written file is left
"""


def fail(exc: BaseException) -> None:
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


def write_error(exc: OSError, outdir: Path) -> InputError | None:
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


def progress_bar(
    total: int, quiet: bool, desc: str = "solving", unit: str = " positions"
) -> Any | None:
    """A tqdm bar over ``total`` items (positions, designs) on stderr, or None (see
    :func:`progress_wanted`)."""
    if not progress_wanted(quiet):
        return None
    from tqdm import tqdm

    return tqdm(
        total=total,
        desc=desc,
        unit=unit,
        unit_scale=True,
        delay=PROGRESS_DELAY,
        leave=False,  # the summary follows; the bar has done its job
        dynamic_ncols=True,
        file=sys.stderr,
    )


def stream_above() -> int:
    text = os.environ.get("MECHSOLVE_STREAM_ABOVE")
    if text is None:
        return STREAM_ABOVE
    try:
        return int(text)
    except ValueError:
        raise InputError(
            f"MECHSOLVE_STREAM_ABOVE={text!r}: expected a whole number of positions"
        ) from None


def interrupt_on_sigterm() -> None:
    """Make SIGTERM unwind like Ctrl-C, so that a half-written file is removed."""
    import signal

    def handler(signum, frame):  # noqa: ARG001
        raise KeyboardInterrupt

    try:
        signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread (an embedding application): leave it
        pass


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


__all__ = [
    "EPILOG",
    "EXIT_INPUT",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_WARNINGS",
    "FILE_ARG",
    "NO_PLOTS",
    "QUIET",
    "VARIANT",
    "fail",
    "interrupt_on_sigterm",
    "outdir_option",
    "output_folder",
    "progress_bar",
    "progress_wanted",
    "stream_above",
    "write_error",
]
