"""The optional compiled path of the Newton groups' sweep (numba, the ``fast`` extra).

Opt-in, never automatic: importing numba costs about half a second, which a command
that needs no Newton group must not pay. It is asked for by ``solver: {compiled: true}``
in the mechanism file (``SolverOptions.compiled`` in code) or by the environment
variable ``MECHSOLVE_COMPILED=1``; either makes every batched sweep of a small revolute
Newton group take its coarse continuation through :mod:`mechsolve.groups.kernels`. The
results are those of the NumPy path (the same steps, the same arithmetic); the first
call compiles the kernels (numba caches them on disk for later processes).
"""

from __future__ import annotations

import os
from types import ModuleType

from mechsolve.base.errors import MechsolveError

ENV = "MECHSOLVE_COMPILED"
KEY = "solver.compiled"
HINT = "pip install 'mechsolve[fast]' (numba), or leave the compiled path off"

_kernels: ModuleType | None = None


class CompiledUnavailable(MechsolveError):
    """The compiled path was asked for and numba cannot be imported (exit 2)."""


def requested() -> bool:
    """Whether the environment asks for the compiled path (``MECHSOLVE_COMPILED`` set
    to anything but empty, ``0``, ``false`` or ``no``)."""
    return os.environ.get(ENV, "").strip().lower() not in ("", "0", "false", "no", "off")


def available() -> bool:
    """Whether numba can be found (without importing it)."""
    import importlib.util  # (here: a command that never asks pays nothing)

    try:
        return importlib.util.find_spec("numba") is not None
    except (ImportError, ValueError):
        return False


def kernels(asked_by: str = ENV) -> ModuleType:
    """The compiled kernels' module, imported (and numba with it) on first use.

    Raises
    ------
    CompiledUnavailable
        numba cannot be imported; the message names what asked for it (``asked_by``:
        the environment variable or the file's key).
    """
    global _kernels
    if _kernels is None:
        import importlib

        try:
            k = importlib.import_module("mechsolve.groups.kernels")
        except ImportError as exc:
            raise CompiledUnavailable(
                f"{asked_by} asks for the compiled Newton sweep, but numba cannot be "
                f"imported ({exc}): {HINT}"
            ) from None
        _kernels = k
    return _kernels
