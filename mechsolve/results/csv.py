"""CSV output: one row per driver position, one column per quantity, units in headers.

The file is written to a temporary name beside the target and moved into place at the
end, so that a failing run never leaves a half-written file that looks complete.
Unsolved positions keep their row: the quantities are empty and ``status`` says why.
Rows can be appended chunk by chunk (:class:`CsvStream`), so that a sweep of millions of
positions never holds more than one chunk in memory.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import os
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np

from mechsolve.base.atomic import WriteFailed, commit, new_temporary
from mechsolve.base.units import OutputUnits

if TYPE_CHECKING:  # what the writer reads of a table (mechsolve.results.results.Results has it)
    from collections.abc import Sequence

    class Results(Protocol):
        def columns(self) -> Sequence: ...
        def status(self) -> list[str]: ...
        def methods(self) -> list[str]: ...
        def __len__(self) -> int: ...


def format_values(values: np.ndarray) -> list[str]:
    """Numbers with 12 significant digits; NaN as an empty cell."""
    return ["" if not np.isfinite(v) else format(float(v) + 0.0, ".12g") for v in values]


BATCH = 4096


class InUnits:
    """A table's columns shown in other units (see
    :class:`~mechsolve.base.units.OutputUnits`): each column whose unit is one of the SI
    units the results are computed in is scaled and relabelled; the rest (``-``) is kept.
    The table itself stays SI; this view is what the writer reads."""

    def __init__(self, table: Results, units: OutputUnits) -> None:
        self.table = table
        self.units = units

    def columns(self) -> list:
        out = []
        for c in self.table.columns():
            k, unit = self.units.convert(c.unit)
            if k != 1.0 or unit != c.unit:
                c = dataclasses.replace(c, unit=unit, values=np.asarray(c.values, float) * k)
            out.append(c)
        return out

    def status(self) -> list[str]:
        return self.table.status()

    def methods(self) -> list[str]:
        return self.table.methods()

    def __len__(self) -> int:
        return len(self.table)


def in_units(table: Results, units: OutputUnits | None) -> Results:
    """``table`` as written in ``units`` (itself for ``None`` or the SI output)."""
    if units is None or units.is_si:
        return table
    return InUnits(table, units)  # type: ignore[return-value]


class CsvStream:
    """A CSV file written chunk by chunk, moved into place only when complete (flushed to
    the disk first). A write that fails (a full disk) removes the partial file and raises
    :class:`~mechsolve.base.atomic.WriteFailed`."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise WriteFailed(self.path, exc) from None
        fd, self.tmp = new_temporary(self.path)
        self.fh = os.fdopen(fd, "w", newline="", encoding="utf-8")
        self.header: list[str] | None = None
        self.rows = 0

    def write(self, results: Results, skip: int = 0) -> None:
        """Append the rows of ``results`` (leaving out the first ``skip``)."""
        try:
            self._write(results, skip)
        except OSError as exc:
            self.abort()
            raise WriteFailed(self.path, exc) from None

    def _write(self, results: Results, skip: int) -> None:
        cols = results.columns()
        headers = ["step"] + [c.header for c in cols] + ["status", "solver.method"]
        if self.header is None:
            self.header = headers
            csv.writer(self.fh).writerow(headers)
        elif headers != self.header:
            raise ValueError("the columns changed between chunks")
        n = len(results)
        if skip >= n:
            return
        status = results.status()
        methods = results.methods()
        fmt = ",".join(["%.12g"] * len(cols))
        for lo in range(skip, n, BATCH):  # a few thousand rows at a time: bounded memory
            hi = min(n, lo + BATCH)
            M = np.column_stack([np.asarray(c.values[lo:hi], float) for c in cols])
            M += 0.0  # -0.0 + 0.0 is +0.0: no "-0" cell
            finite = np.all(np.isfinite(M), axis=1)
            buf = io.StringIO()
            w = csv.writer(buf)
            for k, row in enumerate(M.tolist()):
                i = lo + k
                step = self.rows + i - skip
                st, me = status[i], methods[i]
                if finite[k] and "," not in st and '"' not in st:
                    buf.write(f"{step},{fmt % tuple(row)},{st},{me}\r\n")
                else:
                    w.writerow([step] + format_values(np.array(row)) + [st, me])
            self.fh.write(buf.getvalue())
        self.rows += n - skip

    def close(self) -> Path:
        """Finish the file, flush it to the disk and move it into place."""
        try:
            self.fh.close()
        except OSError as exc:  # the last buffer did not fit on the disk
            self.abort()
            raise WriteFailed(self.path, exc) from None
        commit(self.tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Forget the partial file (the target is left as it was)."""
        try:
            self.fh.close()
        except OSError:  # a full disk refuses the last buffer too: the file goes anyway
            pass
        finally:
            try:
                os.unlink(self.tmp)
            except OSError:
                pass


def write_csv(results: Results, path: str | os.PathLike, units: OutputUnits | None = None) -> Path:
    """Write ``results`` as CSV at ``path`` (atomically) in ``units`` (default SI) and
    return the path."""
    stream = CsvStream(path)
    try:
        stream.write(in_units(results, units))
    except BaseException:
        stream.abort()
        raise
    return stream.close()
