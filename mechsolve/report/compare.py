"""The HTML page of ``mechsolve compare ... --report out.html``: the schemes' figures side
by side (one column per scheme, each cell with its unit), the overlaid plots and each
scheme's requirements, in one self-contained file (images as data URIs), styled and
printed like ``mechsolve report``'s page."""

from __future__ import annotations

import datetime
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from mechsolve.base.atomic import write_text
from mechsolve.base.errors import InputError
from mechsolve.report import _environment, paper_size
from mechsolve.report.build import Image, Table, embed, verdict_rows

if TYPE_CHECKING:
    from mechsolve.analyses.compare import Comparison
    from mechsolve.base.units import OutputUnits

PLOT_TITLES = {
    "compare_velocity": "The outputs' velocity along their working stroke",
    "compare_velocity_rocker": "The rockers' angular velocity along their working stroke",
    "compare_displacement": "The outputs' displacement from the start of the working stroke",
    "compare_displacement_rocker": "The rockers' swing from the start of the working stroke",
    "compare_torque": "The driving torque along the crank's motion",
}


@dataclass
class CompareContent:
    """What the comparison page shows."""

    title: str
    speed: str
    table: Table
    plots: list[Image] = field(default_factory=list)
    requirements: list[Table] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def check_report_path(out: Path) -> None:
    """Before anything is solved: the page is NAME.html in a folder that exists."""
    out = Path(out)
    if out.suffix.lower() not in (".html", ".htm"):
        raise InputError(f"--report {out}: the report is an HTML file (NAME.html)")
    if not out.parent.is_dir():
        raise InputError(f"--report {out}: the folder {out.parent} does not exist")


def compare_content(c: Comparison, units: OutputUnits | None = None) -> CompareContent:
    """The comparison as the page shows it (the plots drawn into a temporary folder), its
    table in ``units`` (None: the SI text)."""
    from mechsolve.analyses.compare.table import NOTE, side_by_side

    names = [s.name for s in c.schemes]
    rows = [[label, *cells] for label, cells in side_by_side(c, units)]
    table = Table(
        f"{len(names)} scheme(s), one turn of the crank each",
        ["figure", *names],
        rows,
        note=NOTE.format(mid=f"{c.middle * 100:g}") + ".",
    )
    w = c.schemes[0].speed
    content = CompareContent(
        f"Comparison of {len(names)} scheme(s): " + ", ".join(names),
        f"All cranks at {w * 30 / 3.141592653589793:.6g} rpm; units: each cell says its own.",
        table,
    )
    content.notes = [f"{s.name}: {n}" for s in c.schemes for n in s.notes]
    with tempfile.TemporaryDirectory(prefix="mechsolve-compare-") as tmp:
        for p in c.write_plots(Path(tmp), units=units):
            content.plots.append(embed(p, PLOT_TITLES.get(p.stem)))
    for s in c.schemes:
        if s.verdicts:
            t = verdict_rows(s.verdicts)
            t.caption = f"{s.name}: {t.caption}"
            content.requirements.append(t)
    return content


def render_compare(content: CompareContent, paper: str = "a4") -> str:
    """The page's HTML, printed on ``paper`` (a4 or letter)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        ver = version("mechsolve")
    except PackageNotFoundError:  # run from a source tree
        ver = "dev"
    return (
        _environment()
        .get_template("compare.html.j2")
        .render(
            c=content,
            paper=paper_size(paper),
            version=ver,
            generated=datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
        )
    )


def write_compare_report(
    c: Comparison, out: str | Path, paper: str = "a4", units: OutputUnits | None = None
) -> Path:
    """Write the comparison's page to ``out`` (atomically), its table in ``units`` (None:
    the SI text); return the path."""
    out = Path(out)
    check_report_path(out)
    return write_text(out, render_compare(compare_content(c, units), paper))


__all__ = [
    "CompareContent",
    "check_report_path",
    "compare_content",
    "render_compare",
    "write_compare_report",
]
