"""The record of what a command wrote into its output folder, and the naming of what an
earlier run of the same command wrote there that this run did not write again.

A run into a folder that an earlier run used leaves the earlier run's other files there:
``point_G.png`` after the point G is removed from the file, ``torque.png`` and
``instants.csv`` after the loads and the instants are, the plots after a run with
``--no-plots``. So each command that ends in an output folder records the files it wrote
(their names relative to the folder, sizes and modification times) in :data:`NAME`
there, written atomically, one record per command (``run``, ``simulate``, ``sweep``...);
the next complete run of the same command names the files of its record that it did not
write again: they are from an earlier run, not from this one.

Nothing is ever removed: such a file may be a result the user still needs (the plots of
the last run with plots, a design ``sweep --keep-results`` kept, a balanced design that
is now another command's input). A file unchanged since mechsolve wrote it stays in the
record and is named by each complete run until it is gone or written again; one changed
since (edited, replaced, touched) is no longer mechsolve's: it is named once and dropped
from the record. Files written by another command into the same folder are not named;
a file that a later command writes again becomes that command's, and a file the command
reads (its input) is not named.
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
    """An earlier run's files in the folder that this run did not write (none is removed).

    Attributes
    ----------
    earlier
        Written by an earlier run of the command and unchanged since: not from this run.
    left
        Written by an earlier run of the command and changed since: no longer its.
    """

    earlier: list[str] = field(default_factory=list)
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


def record(
    folder: Path,
    command: str,
    written: Iterable[Path],
    complete: bool,
    inputs: Iterable[Path] = (),
) -> Tidied:
    """Record that ``command`` wrote ``written`` into ``folder`` and, when the run is
    ``complete``, name the files its previous record lists that it did not write again
    (see the module's docstring; nothing is removed). ``inputs`` are files the command
    read: never named. A run that wrote nothing into the folder changes nothing.

    Raises :class:`OSError` only from writing the record itself.
    """
    folder = Path(folder)
    root = folder.resolve()
    new = _names(folder, written)
    if not new:  # nothing written there: the earlier outputs were not replaced
        return Tidied()
    read = set(_names(folder, inputs))
    records = _read(folder)
    done = Tidied()
    files = dict(new)
    for name, was in sorted(records.get(command, {}).items()):
        if name in new or name in read:
            continue
        now = _stat(root / name)
        if now is None:  # gone already, or no longer a plain file: not ours
            continue
        if now != was:
            done.left.append(name)  # changed since mechsolve wrote it: no longer ours
            continue
        files[name] = was  # still from the earlier run: named again next time
        if complete:
            done.earlier.append(name)
    for other, rec in records.items():
        if other != command:
            for name in new:
                rec.pop(name, None)  # written again by this command: now its file
    records[command] = files
    body = {
        "format": FORMAT,
        "about": "the files each mechsolve command wrote into this folder; the next run "
        "of a command names those of its files it does not write again (from an earlier "
        "run); nothing is removed",
        "commands": {c: {"files": dict(sorted(f.items()))} for c, f in sorted(records.items())},
    }
    text = re.sub(r"\[\s+(\d+),\s+(\d+)\s+\]", r"[\1, \2]", json.dumps(body, indent=1))
    write_text(folder / NAME, text + "\n")
    return done
