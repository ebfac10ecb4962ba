"""Keep freed memory for the next sweep instead of returning it to the OS (glibc only).

A sweep of a few thousand positions works on arrays of tens of kilobytes to a few
megabytes, allocated and freed together. With glibc's default heuristics the heap's top
is trimmed after each sweep and the next one faults the same pages in again, which the
kernel zeroes: for a 3600-position four-bar that costs more than the numerical work
(measured by ``mechsolve bench``). Raising the trim and mmap thresholds keeps up to
:data:`TRIM_THRESHOLD` bytes of freed heap for reuse.

This changes a process-wide setting, so the library never calls it on import: the
command line does (``mechsolve run`` and ``mechsolve bench``), and a program using
mechsolve as a library may call :func:`keep_freed_memory` itself, or set glibc's
``MALLOC_TRIM_THRESHOLD_`` and ``MALLOC_MMAP_THRESHOLD_`` environment variables.
"""

from __future__ import annotations

import os
import sys

TRIM_THRESHOLD = 256 << 20  # freed heap kept for reuse (bytes)
MMAP_THRESHOLD = 32 << 20  # larger single allocations still go straight to the OS

_M_TRIM_THRESHOLD = -1  # from glibc's <malloc.h>
_M_MMAP_THRESHOLD = -3

_applied = False


def keep_freed_memory() -> bool:
    """Raise glibc's malloc trim and mmap thresholds for this process.

    Returns True when the setting was applied; False on other C libraries and platforms,
    when ``MECHSOLVE_MALLOC=default`` asks to leave the allocator alone, or when the user
    already set glibc's own ``MALLOC_TRIM_THRESHOLD_`` variable.
    """
    global _applied
    if _applied:
        return True
    if not sys.platform.startswith("linux"):
        return False
    if os.environ.get("MECHSOLVE_MALLOC", "").lower() == "default":
        return False
    if "MALLOC_TRIM_THRESHOLD_" in os.environ or "MALLOC_MMAP_THRESHOLD_" in os.environ:
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    _applied = bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
        mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    )
    return _applied
