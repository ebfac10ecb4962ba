"""Files that appear whole or not at all.

A run can be interrupted (Ctrl-C, SIGTERM, a full disk) while it writes: every writer
writes into a temporary file beside its target (a unique name, so that two runs into
one folder never share one), flushes it to the disk (``fsync``) and moves it into place
when it is complete, so a half-written CSV, image, report or drawing is never left
behind; on any failure the temporary is removed and the target is left as it was.

An output named through a symbolic link is written where the link points (the target
is replaced, the link kept). An output that is a character device or a pipe (FIFO)
(``/dev/null``, ``/dev/stdout``, a terminal, a process reading a named pipe) is written
through, as a shell's ``>`` would: it has no contents to replace, and replacing its name
with a regular file would destroy the device; the data is still complete in a temporary
before it is sent. A pipe that no process reads is refused after a bounded wait
(:data:`PIPE_WAIT`) instead of blocking for good; a block device or a socket is refused.

A file that cannot be written (a full disk, a quota, no permission, a read-only file
system) raises :class:`WriteFailed`: an input error (exit code 2) that names the file
and gives the system's reason, and an :class:`OSError` with its ``errno`` for callers
that catch those.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

from mechsolve.base.errors import InputError

__all__ = [
    "ENVIRONMENT_ERRNOS",
    "PIPE_WAIT",
    "WriteFailed",
    "commit",
    "committed_mark",
    "committed_since",
    "note_committed",
    "destination",
    "new_temporary",
    "opened",
    "replacing",
    "write_bytes",
    "write_text",
]

PIPE_WAIT = 5.0  # s: the longest wait for a process to open a named pipe written to

# every regular file this process has moved into place, in order: the output folder's
# record of what a command wrote is made from it (mechsolve.base.manifest)
_COMMITTED: list[Path] = []


def committed_mark() -> int:
    """A mark in the list of the files this process has written (see
    :func:`committed_since`)."""
    return len(_COMMITTED)


def committed_since(mark: int) -> list[Path]:
    """The files this process has moved into place since :func:`committed_mark` gave
    ``mark`` (not those written through to a device or a pipe)."""
    return list(_COMMITTED[mark:])


def note_committed(paths: Iterable[str | os.PathLike]) -> None:
    """Count ``paths``, files that this process's workers (a process pool) moved into
    place, among the files this process wrote (:func:`committed_since`): the output
    folder's record lists them as the command's own."""
    _COMMITTED.extend(Path(p) for p in paths)


# errors of the machine, not of mechsolve: the user can act on them (free space, fix the
# permissions, choose another folder)
ENVIRONMENT_ERRNOS = frozenset(
    e
    for e in (
        errno.ENOSPC,
        getattr(errno, "EDQUOT", None),
        errno.EFBIG,
        errno.EROFS,
        errno.EACCES,
        errno.EPERM,
        errno.EIO,
    )
    if e is not None
)


class WriteFailed(InputError, OSError):
    """``path`` could not be written: the system's reason (``cause``) with the file named.

    It is an :class:`~mechsolve.base.errors.InputError` (exit code 2: the user can act on it)
    and an :class:`OSError` carrying ``errno``, ``strerror`` and ``filename``."""

    def __init__(self, path: str | os.PathLike, cause: OSError) -> None:
        reason = cause.strerror or str(cause) or type(cause).__name__
        InputError.__init__(self, f"cannot write {os.fspath(path)}: {reason}")
        self.errno = cause.errno
        self.strerror = reason
        self.filename = os.fspath(path)
        self.cause = cause

    def __reduce__(self):  # through a process pool: rebuilt from its path and cause
        return (type(self), (self.filename, OSError(self.errno, self.strerror)))


def _failed(path: Path, exc: OSError, tmp: str | None = None) -> OSError:
    """``exc`` as a :class:`WriteFailed` about ``path`` when it is about writing there
    (a full disk, permissions, the temporary's name or no name at all), else ``exc``."""
    if isinstance(exc, WriteFailed) or isinstance(exc, BrokenPipeError):
        return exc
    mine = exc.filename in (None, tmp, str(path), os.fspath(path))
    if mine or exc.errno in ENVIRONMENT_ERRNOS:
        return WriteFailed(path, exc)
    return exc


def _unlink(tmp: str) -> None:
    try:
        os.unlink(tmp)
    except OSError:
        pass


def destination(path: str | os.PathLike) -> tuple[Path, bool]:
    """Where writing ``path`` goes: ``(target, through)``.

    ``through`` is True for a character device or a pipe (FIFO), possibly reached through
    symbolic links: it is written in place (``target`` is ``path`` itself, which the
    system opens through its links, ``/dev/stdout`` included). Otherwise ``target`` is the
    file to replace: ``path``, or what it points to when it is a symbolic link (a link to
    nothing yet names the file to create). A block device or a socket raises
    :class:`WriteFailed`."""
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except OSError:
        mode = None  # absent, or a link to nothing: a new file (its folder says if not)
    if mode is not None and not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
            return path, True
        what = "a block device (a disk)" if stat.S_ISBLK(mode) else "a socket"
        raise WriteFailed(
            path, OSError(errno.EINVAL, f"it is {what}, not a file: give a file to write")
        )
    if path.is_symlink():
        return Path(os.path.realpath(path)), False
    return path, False


def new_temporary(path: str | os.PathLike, suffix: str = ".part") -> tuple[int, str]:
    """A new, uniquely named temporary file beside ``path`` (beside the file a symbolic
    link points to; in the system's temporary folder for a device or a pipe, see
    :func:`destination`): ``(fd, name)``; the name is ``.<target name>.<random><suffix>``.
    Raises :class:`WriteFailed`."""
    path = Path(path)
    target, through = destination(path)
    folder = tempfile.gettempdir() if through else (target.parent or ".")
    try:
        return tempfile.mkstemp(prefix=f".{target.name}.", suffix=suffix, dir=folder)
    except OSError as exc:
        raise WriteFailed(path, exc) from None


def _open_through(target: Path) -> int:
    """A descriptor to write ``target`` (a character device or a pipe) in place. A pipe
    is opened without blocking, retried for :data:`PIPE_WAIT` seconds while no process
    reads it (then ``ENXIO``), and then set to block as usual."""
    if not stat.S_ISFIFO(os.stat(target).st_mode) or not hasattr(os, "O_NONBLOCK"):
        return os.open(target, os.O_WRONLY)
    deadline = time.monotonic() + PIPE_WAIT
    while True:
        try:
            fd = os.open(target, os.O_WRONLY | os.O_NONBLOCK)
            break
        except OSError as exc:
            if exc.errno != errno.ENXIO:
                raise
            if time.monotonic() > deadline:
                raise OSError(
                    errno.ENXIO,
                    f"it is a pipe (FIFO) that no process reads (waited {PIPE_WAIT:g} s)",
                ) from None
            time.sleep(0.02)
    os.set_blocking(fd, True)
    return fd


def _write_through(tmp: str, target: Path) -> None:
    """Send the finished temporary ``tmp`` to the device or pipe ``target``."""
    fd = _open_through(target)
    try:
        with open(tmp, "rb") as src:
            while chunk := src.read(1 << 16):
                view = memoryview(chunk)
                while view:
                    view = view[os.write(fd, view) :]
    finally:
        os.close(fd)


def commit(tmp: str, path: str | os.PathLike) -> None:
    """Flush the finished temporary ``tmp`` to the disk and move it onto ``path`` (onto
    the file a symbolic link ``path`` points to) with the mode a new file would get; a
    character device or a pipe is written through instead (see :func:`destination`).
    On failure remove the temporary and raise :class:`WriteFailed` about ``path``."""
    path = Path(path)
    try:
        target, through = destination(path)
        if through:
            _write_through(tmp, target)
            _unlink(tmp)
            return
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)  # the data is on the disk before the name points at it
        finally:
            os.close(fd)
        mask = os.umask(0)  # mkstemp makes the file private; give it the usual mode
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)
        os.replace(tmp, target)
    except BaseException as exc:
        _unlink(tmp)
        if isinstance(exc, OSError):
            raise _failed(path, exc, tmp) from None
        raise
    _COMMITTED.append(path)  # the name written (a link keeps its name: see manifest)
    try:  # and the rename itself survives a crash (not every file system allows this)
        dfd = os.open(target.parent or ".", os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dfd)
    except OSError:
        pass
    finally:
        os.close(dfd)


@contextmanager
def replacing(path: str | Path, suffix: str = ".part") -> Iterator[str]:
    """A temporary file name beside ``path`` to write to; when the block ends without an
    error it is flushed to the disk and moved onto ``path`` (with the mode a new file
    would get; onto the file a symbolic link points to; a device or a pipe is written
    through: see :func:`destination`), otherwise it is removed. The name is unique (two
    runs writing the same file never share it) and ends in ``suffix`` (``.part``: give
    writers the format explicitly; or the target's own suffix for tools that go by it).
    A failure to write (a full disk, permissions) is raised as :class:`WriteFailed`."""
    path = Path(path)
    fd, tmp = new_temporary(path, suffix)
    os.close(fd)
    try:
        yield tmp
    except BaseException as exc:
        _unlink(tmp)
        if isinstance(exc, OSError):
            err = _failed(path, exc, tmp)
            if err is not exc:
                raise err from None
        raise
    commit(tmp, path)


@contextmanager
def opened(
    path: str | os.PathLike, mode: str = "w", encoding: str | None = "utf-8", **kwargs: Any
) -> Iterator[IO[Any]]:
    """``open(path, mode)`` that writes atomically (see :func:`replacing`)."""
    if "b" in mode:
        encoding = None
    with replacing(path) as tmp:
        with open(tmp, mode, encoding=encoding, **kwargs) as fh:
            yield fh


def write_text(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; return the path."""
    with opened(path, "w", encoding=encoding, newline="") as fh:
        fh.write(text)
    return Path(path)


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; return the path."""
    with opened(path, "wb") as fh:
        fh.write(data)
    return Path(path)
