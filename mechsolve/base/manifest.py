"""The record of what a command wrote into its output folder, and the tidying of what an
earlier run of the same command wrote there that this run does not write again.

A run into a folder that an earlier run used leaves the earlier run's other files there:
``point_G.png`` after the point G is removed from the file, ``torque.png`` and
``instants.csv`` after the loads and the instants are. Nothing would mark them as
old. So each command that ends in an output folder records the files it wrote (their
names relative to the folder, sizes and modification times) in :data:`NAME` there,
written atomically, one record per command (``run``, ``simulate``, ``sweep``...); the
next complete run of the same command removes the files of its previous record that it
did not write again.

Only a file mechsolve wrote is ever removed: one the record names, a regular file
inside the folder, with the size and modification time it had when mechsolve wrote it.
A file changed since (edited, replaced, touched) is left in place and named as left.
A run that fails removes nothing: its record keeps the earlier files too, for the next
complete run to tidy. Files written by another command into the same folder are not
touched; a file that a later command writes again becomes that command's.
"""

from __future__ import annotations

import json
import os
import re
import stat
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

from mechsolve.base.atomic import write_text

NAME = ".mechsolve-outputs.json"
FORMAT = 1

__all__ = ["FORMAT", "NAME", "Tidied", "record"]


@dataclass
class Tidied:
    """What :func:`record` did with an earlier run's files that this run did not write.

    Attributes
    ----------
    removed
        Removed: an earlier run of the command wrote them, and they were unchanged since.
    left
        Left in place: changed since an earlier run of the command wrote them.
    """

    removed: list[str] = field(default_factory=list)
    left: list[str] = field(default_factory=list)


def _stat(path: Path) -> list[int] | None:
    """``[size, mtime_ns]`` of a regular file (not through a link), else None."""
    try:
        st = os.lstat(path)
    except OSError:
        return None
    if not stat.S_ISREG(st.st_mode):
        return None
    return [st.st_size, st.st_mtime_ns]


def _plain(name: Any) -> bool:
    """Whether ``name`` (from the record) is a relative path inside the folder."""
    if not isinstance(name, str) or not name or "\\" in name or "\x00" in name:
        return False
    p = PurePosixPath(name)
    return not p.is_absolute() and ".." not in p.parts and p.name != NAME


def _read(folder: Path) -> dict[str, dict[str, list[int]]]:
    """The records of the folder's commands (an unreadable record is no record)."""
    try:
        data = json.loads((folder / NAME).read_text("utf-8"))
    except (OSError, ValueError):
        return {}
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        return {}
    out: dict[str, dict[str, list[int]]] = {}
    for command, rec in (data.get("commands") or {}).items():
        files = rec.get("files") if isinstance(rec, dict) else None
        if isinstance(files, dict):
            out[str(command)] = {
                n: list(s)
                for n, s in files.items()
                if _plain(n) and isinstance(s, list) and len(s) == 2
            }
    return out


def _names(folder: Path, written: Iterable[Path]) -> dict[str, list[int]]:
    """The files written inside ``folder``, by their names relative to it."""
    root = folder.resolve()
    out: dict[str, list[int]] = {}
    for p in written:
        p = Path(p)
        try:
            rel = (p.parent.resolve() / p.name).relative_to(root)
        except (OSError, ValueError):
            continue
        name = rel.as_posix()
        s = _stat(root / rel) if _plain(name) else None
        if s is not None:
            out[name] = s
    return out


def record(folder: Path, command: str, written: Iterable[Path], complete: bool) -> Tidied:
    """Record that ``command`` wrote ``written`` into ``folder``; when the run is
    ``complete``, remove the files its previous record names that it did not write
    again, if they are unchanged since (see the module's docstring). A run that wrote
    nothing into the folder changes nothing.

    Raises :class:`OSError` only from writing the record itself.
    """
    folder = Path(folder)
    root = folder.resolve()
    new = _names(folder, written)
    if not new:  # nothing written there: the earlier outputs were not replaced
        return Tidied()
    records = _read(folder)
    done = Tidied()
    files = dict(new)
    for name, was in sorted(records.get(command, {}).items()):
        if name in new:
            continue
        now = _stat(root / name)
        if now is None:  # gone already, or no longer a plain file: not ours to touch
            continue
        if now != was:
            done.left.append(name)  # changed since mechsolve wrote it: no longer ours
            continue
        if not complete:
            files[name] = was  # for the next complete run to tidy
            continue
        try:
            os.unlink(root / name)
        except OSError:
            files[name] = was
            done.left.append(name)
            continue
        done.removed.append(name)
    for other, rec in records.items():
        if other != command:
            for name in new:
                rec.pop(name, None)  # written again by this command: now its file
    records[command] = files
    body = {
        "format": FORMAT,
        "about": "the files each mechsolve command wrote into this folder; the next run "
        "of a command removes those of its files it does not write again",
        "commands": {c: {"files": dict(sorted(f.items()))} for c, f in sorted(records.items())},
    }
    text = re.sub(r"\[\s+(\d+),\s+(\d+)\s+\]", r"[\1, \2]", json.dumps(body, indent=1))
    write_text(folder / NAME, text + "\n")
    return done
