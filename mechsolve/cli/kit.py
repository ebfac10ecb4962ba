"""What the ``mechsolve`` commands share: exit codes, error reporting, output folders,
progress bars and the common options. Every command module imports these from here, so
a new command can live in its own module beside the stages it calls."""

from __future__ import annotations

import os
import sys
import tempfile
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any, NoReturn

import click

from mechsolve.base.atomic import ENVIRONMENT_ERRNOS, committed_mark, committed_since
from mechsolve.base.errors import (
    EXIT_CHECK_FAILED,
    EXIT_INPUT,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    InputError,
    InputWarning,
    MechsolveError,
)

# the reader of the output went away (`mechsolve run ... | head`): the code the shell
# reports for a tool that SIGPIPE ends (128 + 13), as `cat` or `grep` in the same place
EXIT_BROKEN_PIPE = 141
STREAM_ABOVE = 200_000  # positions: longer sweeps are solved and written chunk by chunk
PROGRESS_DELAY = 1.0  # seconds: a streamed run that ends sooner never shows its bar

EXIT_CODES = """\b
Exit codes (the same for every command):
  0    done (a partial result too: positions that cannot close, values
       not determined at singular positions, a simulation stopped early;
       a warning on stderr and the summary say what is missing)
  2    bad input: the file, the command line, a mechanism that cannot be
       assembled where it must be, a full disk or a refused permission
  4    internal error (a bug in mechsolve; please report it)
  5    a design check failed: a requirement (run, report, compare;
       sweep when no design meets them all), a cam's allowances, a
       flywheel whose check misses its delta; everything was written
  130  interrupted (Ctrl-C or SIGTERM); no half-written file is left
  141  the output's reader went away (`... | head`): stopped quietly
"""
# each command's --help points at the rule instead of repeating it, naming only the codes
# the command can give: EPILOG for the commands that check a design (requirements, a cam's
# allowances, a flywheel's check: 5), EPILOG_NO_CHECK for the others
EPILOG = (
    "Exit codes: 0 done, 2 bad input, 4 internal error, 5 a design check failed, "
    "130 interrupted (mechsolve --help lists them)."
)
EPILOG_NO_CHECK = (
    "Exit codes: 0 done, 2 bad input, 4 internal error, 130 interrupted "
    "(mechsolve --help lists them)."
)
# where a command keeps what the error handler needs to know (click's shared ctx.meta)
_OUTDIR = "mechsolve.outdir"
_RECORDED = "mechsolve.outputs_recorded"  # the command records its outputs job by job


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
    removed on the way out; finished ones stay). A Ctrl-C pressed again while the
    interpreter ends (a process pool's or Dask's exit handlers) is ignored: it would only
    turn the exit into a traceback. (An exit handler, so that a caller that catches the
    exit, as click's test runner does, keeps its Ctrl-C.)"""
    import atexit
    import signal

    def ignore() -> None:
        try:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        except ValueError:  # not the main thread
            pass

    atexit.register(ignore)  # runs before the handlers registered earlier (Dask's)
    try:
        click.echo(message, err=True)
    except (OSError, ValueError):
        pass
    sys.exit(EXIT_INTERRUPTED)


def fail(exc: BaseException, outdir: Path | None = None) -> NoReturn:
    """Report ``exc`` in one line and exit with its code, the one mapping of errors to
    exit codes: a mechsolve error its own (2); a full disk or a permission refused, or
    an OS error while writing into ``outdir``, 2; Ctrl-C 130; the reader of the output
    gone 141 (quietly); anything else is a bug, 4. Click's own exits pass through."""
    if isinstance(exc, (click.exceptions.Exit, click.ClickException, SystemExit)):
        raise exc
    if isinstance(exc, BrokenPipeError):
        broken_pipe()
    if isinstance(exc, (KeyboardInterrupt, click.exceptions.Abort)) or _SIGNALLED:
        if outdir is None:
            interrupted()
        interrupted("interrupted: the files not yet finished were not written")
    if isinstance(exc, OSError) and outdir is not None:
        exc = write_error(exc, outdir) or exc
    if isinstance(exc, MechsolveError):
        click.echo(f"error: {exc}", err=True)
        sys.exit(exc.exit_code)
    if isinstance(exc, OSError) and exc.errno in ENVIRONMENT_ERRNOS:
        # the machine refused (a full disk, a quota, permissions): the user can act on it
        names = [str(n) for n in (exc.filename, exc.filename2) if n is not None]
        where = "".join(f"{n}: " for n in names)
        click.echo(f"error: {where}{exc.strerror or exc}", err=True)
        sys.exit(EXIT_INPUT)
    if os.environ.get("MECHSOLVE_DEBUG"):
        import traceback  # only for a bug's report: not imported by every start

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


@contextmanager
def writing(path: Path, option: str | None = None) -> Iterator[None]:
    """Write the one file ``path`` (given by ``option``, such as ``--junit``): an OS error
    meanwhile (a missing folder, a full disk, a refused permission) is an input error
    naming the option and the file, exit 2."""
    try:
        yield
    except OSError as exc:
        why = exc.strerror or str(exc)
        text = (
            f"{option} {path}: cannot write it: {why}" if option else f"cannot write {path}: {why}"
        )
        raise InputError(text) from None


def writes_to(path: Path) -> None:
    """Tell the error handler (:class:`Group`) that the command writes into the folder
    or file ``path``: an OS error there is reported as writing it (exit 2), and Ctrl-C
    says that the files not yet finished were not written."""
    ctx = click.get_current_context(silent=True)
    if ctx is not None:
        ctx.meta[_OUTDIR] = Path(path)


def output_folder(outdir: Path) -> Path:
    """Create ``outdir`` and make sure a file can be written in it, before anything is
    solved (a long sweep must not fail at its end); an OS refusal is an input error."""
    writes_to(outdir)
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
    from mechsolve.base.keyspec import whole
    from mechsolve.base.units import UnitError, read_number

    try:  # read as the file's numbers are
        n = whole(read_number(text))
    except UnitError:
        n = None
    if not isinstance(n, int):
        raise InputError(f"MECHSOLVE_STREAM_ABOVE={text!r}: expected a whole number of positions")
    return n


_SIGNALLED: list[int] = []  # Ctrl-C or SIGTERM received by this process


def interrupt_on_sigterm() -> None:
    """Make SIGTERM unwind like Ctrl-C, so that a half-written file is removed; and
    remember either signal, so that what it turns into on its way up (a C extension
    being imported when it arrives fails with "ImportError: initialization failed")
    still ends as an interruption (130), not as a bug (4)."""
    import signal

    def handler(signum, frame):  # noqa: ARG001
        _SIGNALLED.append(signum)
        raise KeyboardInterrupt

    try:
        signal.signal(signal.SIGTERM, handler)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            signal.signal(signal.SIGINT, handler)
    except ValueError:  # not the main thread (an embedding application): leave it
        pass


def finish(*, check_failed: bool = False, warning: str | None = None) -> NoReturn:
    """End a command that ran to completion: exit 5 when a design check failed (a
    requirement, a cam's allowance, a flywheel's check), else 0. ``warning`` (what the
    result lacks: positions that cannot close, values left blank, a motion stopped
    early) goes to stderr, even under ``-q``; it does not change the code."""
    if warning:
        warn(warning)
    sys.exit(EXIT_CHECK_FAILED if check_failed else EXIT_OK)


def warn(text: str) -> None:
    """One ``warning:`` line on stderr (shown under ``-q`` too): what a finished result
    lacks. It does not change the exit code (0 done; see :func:`finish`)."""
    click.echo(f"warning: {text}", err=True)


def watch(file: Path, job: Any, outdir: Path | None = None) -> NoReturn:
    """``--watch``: run ``job`` now and after every save of ``file`` until Ctrl-C, which
    ends it with 130 (the watcher has said "stopped watching")."""
    from mechsolve.cli.watch import watch_file

    try:
        watch_file(file, job, echo=click.echo, outdir=outdir)
    except KeyboardInterrupt:
        sys.exit(EXIT_INTERRUPTED)
    sys.exit(EXIT_OK)


def end_process(code: object) -> NoReturn:
    """End the process with exit code ``code`` once a command has returned (see
    :func:`mechsolve.cli.main.entry`): at once with :func:`os._exit` after flushing
    standard output and error, unless an ``atexit`` handler or another thread still has
    work to do, or the code is not a number; then by :func:`sys.exit`, as Python
    ends."""
    if code is None:
        code = 0
    if not isinstance(code, int) or not _nothing_left_at_exit():
        sys.exit(code)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError, AttributeError):  # a closed or broken stream, or none:
        sys.exit(code)  # Python's own exit deals with it, as before
    os._exit(code)


def _nothing_left_at_exit() -> bool:
    """No ``atexit`` handler registered and no other Python thread alive (CPython's
    ``atexit._ncallbacks``; elsewhere, assume there is)."""
    import atexit
    import threading

    count = getattr(atexit, "_ncallbacks", None)
    return count is not None and count() == 0 and threading.active_count() == 1


def _guarded(invoke: Any, ctx: click.Context) -> Any:
    """``invoke(ctx)`` under the rules every command shares, in one place, and the one
    mapping of errors to exit codes (:func:`fail`), so that no command catches errors
    itself. SIGTERM unwinds like Ctrl-C; Ctrl-C is exit 130 with "interrupted" (not
    click's "Aborted!" and 1); a closed output pipe stops quietly (:func:`broken_pipe`); a
    mechsolve error, a full disk or a refused permission is exit 2 in one line; anything
    else is a bug, 4. Click's own exits (usage errors: 2) pass through."""
    _SIGNALLED.clear()  # a signal an earlier command of this process received is its own
    interrupt_on_sigterm()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default", InputWarning)
            shown = warnings.showwarning

            def show(message, category, *args, **kwargs) -> None:
                if issubclass(category, InputWarning):  # a "warning:" line, under -q too
                    warn(str(message))
                else:
                    shown(message, category, *args, **kwargs)

            warnings.showwarning = show
            return invoke(ctx)
    except (click.exceptions.Exit, click.ClickException, SystemExit):
        raise
    except BaseException as exc:  # noqa: BLE001 - every error becomes its exit code
        fail(exc, ctx.meta.get(_OUTDIR))


def _record_outputs(
    outdir: Path | None,
    command: str,
    start: int,
    complete: bool,
    quiet: bool,
    inputs: list[Path] | None = None,
) -> None:
    """Record the files written since ``start`` into the output folder ``outdir`` and,
    after a complete run, name in one line those an earlier run of ``command`` wrote
    there that this one did not (:mod:`mechsolve.base.manifest`: nothing is removed).
    ``inputs``: the files the command read (never named). A folder's record that cannot
    be written is left as it was: the results are written."""
    if outdir is None or not Path(outdir).is_dir():
        return  # the command writes one file (draw -o x.dxf), or wrote nothing
    from mechsolve.base.manifest import record

    written = committed_since(start)
    if not written:
        return
    try:
        done = record(Path(outdir), command, written, complete, inputs or ())
    except OSError:
        return
    if quiet or not complete:
        return
    if done.earlier:
        click.echo(
            f"  {len(done.earlier)} file(s) in {outdir}/ are from an earlier {command}, not "
            "from this one (kept; delete them if they are not needed): " + ", ".join(done.earlier)
        )
    if done.left:
        click.echo(
            f"  {len(done.left)} file(s) in {outdir}/ from an earlier {command} were changed "
            "since it wrote them (kept, no longer in its record): " + ", ".join(done.left)
        )


def _input_files(ctx: click.Context | None) -> list[Path]:
    """The existing files among a command's parameters (what it reads)."""
    out: list[Path] = []
    for v in ctx.params.values() if ctx is not None else ():
        for x in v if isinstance(v, (list, tuple)) else (v,):
            if isinstance(x, Path) and x.is_file():
                out.append(x)
    return out


def _completed(exc: SystemExit) -> bool:
    """Whether a command that ended with ``exc`` wrote all its outputs (0, or 5: a
    design check failed on complete results)."""
    return exc.code in (None, EXIT_OK, EXIT_CHECK_FAILED)


@contextmanager
def recorded_outputs(outdir: Path, command: str, quiet: bool = False) -> Iterator[None]:
    """Record what the block writes into ``outdir`` as one run of ``command`` (for a
    command that runs several jobs, such as ``run --watch``; every other command is
    recorded as a whole by :class:`Command`)."""
    ctx = click.get_current_context(silent=True)
    if ctx is not None:
        ctx.meta[_RECORDED] = True
    start = committed_mark()
    complete = False
    try:
        yield
        complete = True
    except SystemExit as exc:
        complete = _completed(exc)
        raise
    finally:
        _record_outputs(outdir, command, start, complete, quiet, _input_files(ctx))


class Command(click.Command):
    """Every ``mechsolve`` command (``@click.command(cls=Command)``, or ``@main.command``):
    its errors become exit codes by :func:`_guarded`, also when it is invoked on its own
    (a test, an embedding application) rather than through the group. What it writes
    into its output folder is recorded there, and what an earlier run of it wrote there
    and this one does not is named (:mod:`mechsolve.base.manifest`)."""

    def invoke(self, ctx: click.Context) -> Any:
        start = committed_mark()
        complete = False
        try:
            out = _guarded(super().invoke, ctx)
            complete = True
            return out
        except SystemExit as exc:
            complete = _completed(exc)
            raise
        finally:
            if not ctx.meta.get(_RECORDED):
                quiet = bool(ctx.params.get("quiet"))
                _record_outputs(
                    ctx.meta.get(_OUTDIR),
                    self.name or "",
                    start,
                    complete,
                    quiet,
                    _input_files(ctx),
                )


class Group(click.Group):
    """The ``mechsolve`` command group: its commands are :class:`Command`, and what
    escapes them or the group itself is mapped the same way (:func:`_guarded`)."""

    command_class = Command

    def invoke(self, ctx: click.Context) -> Any:
        return _guarded(super().invoke, ctx)


# options that several commands share
class _ReadAsTheFile:
    """The reading of a command-line number by the rule of the file's numbers
    (:func:`mechsolve.base.units.read_number`: ``1_000``, ``1:45``, ``1,5`` and full-width
    digits are refused, where Python's ``int`` and ``float`` would take some of them);
    ``whole``: a whole number, ``10.0`` being 10 as in the file. Then click's own type
    (its range, its help); a refusal is click's usage error naming the option and the
    value: exit 2."""

    whole = False

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        if isinstance(value, str):
            from mechsolve.base.keyspec import whole
            from mechsolve.base.units import UnitError, read_number

            try:
                x: Any = read_number(value)
            except UnitError as exc:
                self.fail(str(exc), param, ctx)  # type: ignore[attr-defined]
            if self.whole:
                x = whole(x)
                if not isinstance(x, int):
                    self.fail(f"{value!r} is not a whole number", param, ctx)  # type: ignore[attr-defined]
            value = x
        return super().convert(value, param, ctx)  # type: ignore[misc]


class _Whole(_ReadAsTheFile, click.types.IntParamType):
    whole = True


class _WholeRange(_ReadAsTheFile, click.IntRange):
    whole = True


class _Number(_ReadAsTheFile, click.types.FloatParamType):
    pass


class _NumberRange(_ReadAsTheFile, click.FloatRange):
    pass


def number(
    low: float | None = None, high: float | None = None, low_open: bool = False
) -> click.ParamType:
    """A command-line number read as the file's numbers are (see :class:`_ReadAsTheFile`),
    ``low`` (excluded with ``low_open``) to ``high``."""
    if low is None and high is None:
        return _Number()
    return _NumberRange(min=low, max=high, min_open=low_open)


def whole_number(low: int | None = None, high: int | None = None) -> click.ParamType:
    """A command-line whole number read as the file's are (``10.0`` is 10; see
    :class:`_ReadAsTheFile`), ``low`` to ``high``."""
    if low is None and high is None:
        return _Whole()
    return _WholeRange(min=low, max=high)


FILE_ARG = click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
VARIANT = click.option("--variant", help="Apply the named entry of the file's 'variants' section.")
NO_PLOTS = click.option("--no-plots", is_flag=True, help="Write the CSV only.")
QUIET = click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
UNITS = click.option(
    "--units",
    "units",
    metavar="SI|file|MAP",
    help="Units of the CSV, the plots and the summary: 'file' (the default: the file's "
    "'units:', e.g. mm and deg, with mm/s, deg/s, N*mm), 'SI' (m, m/s, deg, rad/s, N, "
    "N*m, J, W) or a map such as 'length=mm,angle=deg,force=kN' (keys length, angle, "
    "force, time, torque, energy, power) over the file's.",
)


def output_units(mech, text: str | None):
    """The :class:`~mechsolve.base.units.OutputUnits` of ``--units text`` for ``mech``
    (its file's units when not given); a bad map is an :class:`InputError`."""
    from mechsolve.base.units import UnitError, parse_output_units

    base = mech.output_units()
    if text is None:
        return base
    try:
        return parse_output_units(text, base)
    except UnitError as exc:
        raise InputError(f"--units {text!r}: {exc}") from None


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
    "EPILOG_NO_CHECK",
    "EXIT_BROKEN_PIPE",
    "EXIT_CHECK_FAILED",
    "EXIT_CODES",
    "EXIT_INPUT",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "FILE_ARG",
    "NO_PLOTS",
    "QUIET",
    "VARIANT",
    "Command",
    "Group",
    "broken_pipe",
    "end_process",
    "fail",
    "finish",
    "interrupt_on_sigterm",
    "interrupted",
    "outdir_option",
    "output_folder",
    "progress_bar",
    "progress_wanted",
    "stream_above",
    "warn",
    "watch",
    "write_error",
    "writes_to",
    "writing",
]
