"""Errors mechsolve raises for user mistakes and solver failures.

Every error a user can cause derives from :class:`MechsolveError`. The CLI turns
them into one clear message and an exit code, never a traceback.

Exit codes (also listed in ``mechsolve --help`` and the README):

=====  ==============================================================
code   meaning
=====  ==============================================================
0      success
1      completed with warnings: some positions could not be solved, or
       some values are not determined at singular positions, or a check
       such as the power balance failed (the CSV rows say why); the
       rest was written
2      input error: the file, the command line, an output folder that
       cannot be written
3      solver failure: the mechanism cannot be assembled or solved
4      internal error: a bug in mechsolve (``MECHSOLVE_DEBUG=1`` shows
       the traceback)
130    interrupted (Ctrl-C or SIGTERM); no half-written file is left
=====  ==============================================================
"""

from __future__ import annotations

EXIT_OK = 0
EXIT_WARNINGS = 1
EXIT_INPUT = 2
EXIT_SOLVER = 3
EXIT_REQUIREMENTS = 5  # the run completed and a requirement of the file failed


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
    """The mechanism cannot be closed (assembled) where it must be."""

    exit_code = EXIT_SOLVER


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
    """A solver could not produce a trustworthy answer."""

    exit_code = EXIT_SOLVER
