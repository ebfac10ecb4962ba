"""CSV output: one row per driver position, one column per quantity, units in headers.

The file is written to a temporary name beside the target and moved into place at the
end, so that a failing run never leaves a half-written file that looks complete.
Unsolved positions keep their row: the quantities are empty and ``status`` says why.
"""

from __future__ import annotations

import csv
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..results import Results


def format_values(values: np.ndarray) -> list[str]:
    """Numbers with 12 significant digits; NaN as an empty cell."""
    out = []
    for v in values:
        out.append("" if not np.isfinite(v) else format(float(v), ".12g"))
    return out


def write_csv(results: Results, path: str | os.PathLike) -> Path:
    """Write ``results`` as CSV at ``path`` (atomically) and return the path."""
    path = Path(path)
    cols = results.columns()
    headers = ["step"] + [c.header for c in cols] + ["status", "solver.method"]
    body = [format_values(np.asarray(c.values, float)) for c in cols]
    status = results.status()
    methods = results.methods()
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(headers)
            for i in range(len(results)):
                w.writerow([i] + [col[i] for col in body] + [status[i], methods[i]])
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path
