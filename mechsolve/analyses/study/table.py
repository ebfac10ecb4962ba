"""The study's table: one tidy row per design, units in the headers.

Columns: ``design [-]``, the parameters (in the unit they were given in), ``status``,
then the figures in the order the designs first show them (rows in design order, so the
order is the same whichever executor ran the study). CSV by default; Parquet (the same
columns) when pyarrow is installed.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path
from typing import Any

from mechsolve.analyses.study.designs import Study
from mechsolve.analyses.study.figures import Row
from mechsolve.base.atomic import replacing
from mechsolve.base.errors import InputError
from mechsolve.base.units import OutputUnits

UNIT_KEY = re.compile(r"^(?P<name>.*) \[(?P<unit>[^\]]+)\]$")


def rows_in_units(study: Study, rows: list[Row], units: OutputUnits | None) -> list[Row]:
    """The rows with their figures in ``units`` (see
    :class:`~mechsolve.base.units.OutputUnits`): each figure whose header names one of the
    SI units the results are computed in is scaled and renamed (``NAME.stroke [m]`` to
    ``NAME.stroke [mm]``). The parameters keep the unit they were given in, a
    requirement's value the unit of its limit; ``rows`` is not changed."""
    if units is None or units.is_si:
        return rows
    keep = {"design [-]", "status", *(p.header for p in study.params)}
    rename: dict[str, tuple[str, float]] = {}
    out = []
    for r in rows:
        new: Row = {}
        for key, value in r.items():
            if key not in rename:
                m = UNIT_KEY.match(key)
                if key in keep or key.startswith("req.") or not m:
                    rename[key] = (key, 1.0)
                else:
                    k, unit = units.convert(m["unit"])
                    rename[key] = (f"{m['name']} [{unit}]", k)
            name, k = rename[key]
            if k != 1.0 and isinstance(value, float):
                value = value * k
            new[name] = value
        out.append(new)
    return out


def columns(study: Study, rows: list[Row]) -> list[str]:
    """The table's columns, in a fixed order."""
    cols = ["design [-]", *[p.header for p in study.params], "status"]
    seen = set(cols)
    for r in sorted(rows, key=lambda r: r["design [-]"]):
        for key in r:
            if key not in seen:
                seen.add(key)
                cols.append(key)
    return cols


def cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "" if not math.isfinite(value) else f"{value:.10g}"
    return str(value)


def write_csv(study: Study, rows: list[Row], path: Path) -> Path:
    """Write the table (atomically: a file half written is never left)."""
    cols = columns(study, rows)
    with replacing(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in sorted(rows, key=lambda r: r["design [-]"]):
            w.writerow([cell(r.get(c)) for c in cols])
    return path


def write_parquet(study: Study, rows: list[Row], path: Path) -> Path:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise InputError("--format parquet needs pyarrow: pip install pyarrow") from None
    cols = columns(study, rows)
    rows = sorted(rows, key=lambda r: r["design [-]"])
    data = {}
    for c in cols:
        vals = [r.get(c) for r in rows]
        present = [v for v in vals if v is not None]
        if present and all(isinstance(v, bool) for v in present):
            data[c] = pa.array(vals, type=pa.bool_())
        elif present and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in present
        ):
            data[c] = pa.array([None if v is None else float(v) for v in vals], type=pa.float64())
        else:
            data[c] = pa.array([None if v is None else str(v) for v in vals], type=pa.string())
    with replacing(path) as tmp:
        pq.write_table(pa.table(data), tmp)
    return path


def write_table(study: Study, rows: list[Row], outdir: Path, fmt: str = "csv") -> Path:
    if fmt == "parquet":
        return write_parquet(study, rows, outdir / "study.parquet")
    return write_csv(study, rows, outdir / "study.csv")


def read_csv(path: Path) -> list[dict[str, str]]:
    """The table as written (for tests and for comparing two runs)."""
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


__all__ = ["cell", "columns", "read_csv", "write_csv", "write_parquet", "write_table"]
