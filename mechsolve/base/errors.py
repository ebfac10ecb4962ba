"""Errors mechsolve raises for user mistakes and solver failures.

Every error a user can cause derives from :class:`MechsolveError`. The CLI turns
them into one clear message and an exit code, never a traceback.

Exit codes: one rule for every command (also in ``mechsolve --help`` and
docs/reference/exit-codes.md; :mod:`mechsolve.cli.kit` maps errors to them in one place):

=====  ==============================================================
code   meaning
=====  ==============================================================
0      done (a partial result, such as positions that cannot close or
       values not determined at singular positions, is done: the
       summary and a warning on stderr say what is missing, the CSV
       rows say why)
2      bad input: the file, the command line, a mechanism that cannot
       be assembled where it must be, an output that cannot be written
       (a full disk, a refused permission)
4      internal error: a bug in mechsolve (``MECHSOLVE_DEBUG=1`` shows
       the traceback)
5      a design check failed: a requirement of the file (run, report,
       sweep: no design meets them all), a cam's allowances, a flywheel
       whose checking simulation misses its delta; everything was written
130    interrupted (Ctrl-C or SIGTERM); no half-written file is left
141    the reader of standard output went away (``... | head``)
=====  ==============================================================
"""

from __future__ import annotations

import difflib

EXIT_OK = 0
EXIT_INPUT = 2
EXIT_INTERNAL = 4
EXIT_CHECK_FAILED = 5  # the command completed and a design check failed
EXIT_INTERRUPTED = 130  # the shell's convention for Ctrl-C


class InputWarning(UserWarning):
    """Input read as written that was probably not meant so (a plain number in a
    condition read in metres in a file whose plain lengths are millimetres). The command
    line prints it as a ``warning:`` line; the API raises it as a Python warning."""


class MechsolveError(Exception):
    """Base class of every error caused by the user's input or mechanism."""

    exit_code = EXIT_INPUT


class InputError(MechsolveError):
    """A mistake in a mechanism file or in a model built in code.

    Parameters
    ----------
    message
        What is wrong, in plain words.
    file
        The file the mistake is in, if any.
    keypath
        Where in the file, as dotted keys (``links.crank.points.A``).
    line
        The 1-based line number of that key, if known.
    """

    exit_code = EXIT_INPUT

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        keypath: str | None = None,
        line: int | None = None,
    ) -> None:
        self.message = message
        self.file = file
        self.keypath = keypath
        self.line = line
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = ""
        if self.file:
            where = self.file + (f":{self.line}" if self.line else "") + ": "
        elif self.line:
            where = f"line {self.line}: "
        key = f"{self.keypath}: " if self.keypath else ""
        return f"{where}{key}{self.message}"


class AssemblyError(MechsolveError):
    """The mechanism cannot be closed (assembled) where it must be: the file describes
    a mechanism that cannot be built there, a mistake in the input (exit 2)."""

    exit_code = EXIT_INPUT


class CannotCloseAtStart(AssemblyError):
    """The mechanism cannot close at the first position of a sweep (a dead zone there).

    ``group`` names the loop and ``reason`` says why; ``first_ok`` is the index of the
    first position where that loop closes, when the sweep knows it (else None)."""

    def __init__(self, message: str, group: str, reason: str, first_ok: int | None = None):
        super().__init__(message)
        self.group = group
        self.reason = reason
        self.first_ok = first_ok


class SolverError(MechsolveError):
    """A solver could not produce a trustworthy answer where the input asks for one (no
    position closes, a branch that needs a smaller step, a polygon asked for at a
    dead-centre): the message says what to change in the input (exit 2)."""

    exit_code = EXIT_INPUT


def suggest(name: str, choices: list[str]) -> str:
    """A ``" (did you mean 'x'?)"`` hint, or an empty string."""
    close = difflib.get_close_matches(name, choices, n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""
