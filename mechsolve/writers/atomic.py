"""Files that appear whole or not at all.

A run can be interrupted (Ctrl-C, SIGTERM, a full disk) while it writes: every writer
writes into a temporary file beside its target and moves it into place when it is
complete, so a half-written CSV, image, report or drawing is never left behind.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["replacing"]


@contextmanager
def replacing(path: str | Path, suffix: str = ".part") -> Iterator[str]:
    """A temporary file name beside ``path`` to write to; when the block ends without an
    error it is moved onto ``path`` (with the mode a new file would get), otherwise it is
    removed. The name ends in ``suffix`` (``.part``: give writers the format
    explicitly; or the target's own suffix for tools that go by it)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent or ".")
    os.close(fd)
    try:
        yield tmp
        mask = os.umask(0)  # mkstemp makes the file private; give it the usual mode
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
