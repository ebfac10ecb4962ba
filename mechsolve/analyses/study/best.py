"""The best design of a study (``--best "min range(K.y)"``), written as a runnable file.

Candidates are the designs solved at every position; when the file has requirements,
only those that meet all of them (if none does, the best of all is reported, said so).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import yaml

from mechsolve.analyses.study.designs import Study
from mechsolve.analyses.study.figures import Row
from mechsolve.base.atomic import write_text


@dataclass
class Best:
    row: Row
    design: int
    column: str
    value: float
    note: str = ""


def best_column(study: Study, rows: list[Row]) -> str | None:
    if study.best is None:
        return None
    expr = study.best[1]
    for r in rows:
        for key in r:
            if key.startswith(expr + " ["):
                return key
    return None


def pick_best(study: Study, rows: list[Row]) -> Best | None:
    """The design with the smallest (largest) figure, or None when no design has it."""
    col = best_column(study, rows)
    if col is None:
        return None
    sense = study.best[0]

    def value(r: Row) -> float:
        v = r.get(col)
        return float(v) if isinstance(v, (int, float)) and math.isfinite(v) else math.nan

    cands = [r for r in rows if r.get("status") == "ok" and math.isfinite(value(r))]
    note = ""
    has_req = any("requirements.pass [-]" in r for r in cands)
    if has_req:
        passing = [r for r in cands if r.get("requirements.pass [-]") is True]
        if passing:
            cands = passing
        else:
            note = "no design meets every requirement: the best of all designs"
    if not cands:
        return None
    key = (lambda r: value(r)) if sense == "min" else (lambda r: -value(r))
    # ties go to the first design in the table's order, whichever executor ran it
    best = min(sorted(cands, key=lambda r: r["design [-]"]), key=key)
    return Best(best, int(best["design [-]"]), col, value(best), note)


def design_yaml(study: Study, k: int, header: str = "") -> str:
    """Design ``k`` as a mechanism file: the study's file with the values written in
    (comments of the original are not kept; its ``study`` section is left out)."""
    data = study.source_of(k).data
    text = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, allow_unicode=True)
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    return "\n".join(lines) + ("\n" if lines else "") + text


def write_best(study: Study, best: Best, path: Path) -> Path:
    sense, expr = study.best
    header = (
        f"Best design of the study of {study.file} ({sense} {expr}):\n"
        f"design {best.design}: {study.describe(best.design)}\n"
        f"{best.column} = {best.value:.6g}"
        + (f"\n{best.note}" if best.note else "")
        + "\nwritten by mechsolve sweep; run it with: mechsolve run "
        + path.name
    )

    return write_text(path, design_yaml(study, best.design, header))


__all__ = ["Best", "best_column", "design_yaml", "pick_best", "write_best"]
