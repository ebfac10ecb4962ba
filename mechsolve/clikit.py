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
from typing import IO, Any, NoReturn

import click

from .errors import EXIT_INPUT, EXIT_OK, EXIT_WARNINGS, InputError, MechsolveError
from .writers.atomic import ENVIRONMENT_ERRNOS

EXIT_INTERNAL = 4
EXIT_INTERRUPTED = 130  # the shell's convention for Ctrl-C
# the reader of the output went away (`mechsolve run ... | head`): the code the shell
# reports for a tool that SIGPIPE ends (128 + 13), as `cat` or `grep` in the same place
EXIT_BROKEN_PIPE = 141
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
  141  the output's reader went away (`... | head`): stopped quietly
A full disk or a file that cannot be written for want of permission
is an input error (2); every file is written whole or not at all.
"""


def broken_pipe() -> NoReturn:
    """Stop quietly because the reader of standard output went away (``mechsolve run
    FILE | head``), as Unix tools do: no message, no traceback. Python's recipe (the
    ``signal`` module's "Note on SIGPIPE"): point standard output at /dev/null, so that
    the flush at exit cannot fail again, and exit; with 141, the code the shell gives a
    tool that SIGPIPE ends (``cat``, ``grep``), so ``set -o pipefail`` sees the same
    thing for mechsolve as for them. Files already written stay; none is half-written."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # no real stdout (an embedding, a test)
        pass
    sys.exit(EXIT_BROKEN_PIPE)


def interrupted(message: str = "interrupted") -> NoReturn:
    """Ctrl-C or SIGTERM: one line on stderr, exit 130 (files not yet finished were
    removed on the way out; finished ones stay)."""
    try:
        click.echo(message, err=True)
    except (OSError, ValueError):
        pass
    sys.exit(EXIT_INTERRUPTED)


def fail(exc: BaseException) -> NoReturn:
    """Report ``exc`` in one line and exit with its code: a mechsolve error its own
    (2 input, 3 solver...); a full disk or a permission refused 2; the reader of the
    output gone 141 (quietly); anything else is a bug, 4."""
    if isinstance(exc, BrokenPipeError):
        broken_pipe()
    if isinstance(exc, KeyboardInterrupt):
        interrupted()
    if isinstance(exc, MechsolveError):
        click.echo(f"error: {exc}", err=True)
        sys.exit(exc.exit_code)
    if isinstance(exc, (click.exceptions.Exit, click.ClickException, SystemExit)):
        raise exc
    if isinstance(exc, OSError) and exc.errno in ENVIRONMENT_ERRNOS:
        # the machine refused (a full disk, a quota, permissions): the user can act on it
        names = [str(n) for n in (exc.filename, exc.filename2) if n is not None]
        where = "".join(f"{n}: " for n in names)
        click.echo(f"error: {where}{exc.strerror or exc}", err=True)
        sys.exit(EXIT_INPUT)
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


class Group(click.Group):
    """The ``mechsolve`` command group: the rules every command shares, in one place.
    SIGTERM unwinds like Ctrl-C; Ctrl-C is exit 130 with "interrupted" (not click's
    "Aborted!" and 1); a closed output pipe stops quietly (:func:`broken_pipe`); a full
    disk or a refused permission that escapes a command is exit 2 in one line."""

    def invoke(self, ctx: click.Context) -> Any:
        interrupt_on_sigterm()
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            interrupted()
        except BrokenPipeError:
            broken_pipe()
        except OSError as exc:
            fail(exc)


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
    "EXIT_BROKEN_PIPE",
    "EXIT_INPUT",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "EXIT_WARNINGS",
    "FILE_ARG",
    "NO_PLOTS",
    "QUIET",
    "VARIANT",
    "Group",
    "broken_pipe",
    "fail",
    "interrupt_on_sigterm",
    "interrupted",
    "outdir_option",
    "output_folder",
    "progress_bar",
    "progress_wanted",
    "stream_above",
    "write_error",
]
