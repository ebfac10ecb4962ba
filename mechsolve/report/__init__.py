"""``mechsolve report``: one self-contained HTML file with the model, the drawing, the
tables, the plots, the requirements, the dynamics, and the mechanism in motion.

The page is rendered from a jinja2 template shipped with the package (autoescaped: a
name or description in the file is shown as text, never read as HTML). Images are
embedded as data URIs and the animation is plain numbers drawn by a small inline script
on a canvas, so the file opens in any browser without a network. ``--pdf`` prints it with
a headless Chromium (:mod:`.browser`).

:func:`write_report` does the whole job and may be called again on the same file (the
watch mode calls it after each save): the HTML is replaced only when complete.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass
from pathlib import Path

from mechsolve import api
from mechsolve.base.atomic import replacing
from mechsolve.base.errors import InputError
from mechsolve.base.units import UnitError, parse_output_units
from mechsolve.model.source import load_file
from mechsolve.report.animate import check_frame_count
from mechsolve.report.build import Content, cam_content, mechanism_content

JINJA_HINT = (
    "mechsolve report renders its page with jinja2, which is not installed: "
    "pip install 'mechsolve[report]' (or pip install jinja2)"
)


@dataclass
class ReportOutcome:
    """What :func:`write_report` wrote and what the command's exit status depends on."""

    html: Path
    pdf: Path | None
    content: Content

    @property
    def incomplete(self) -> bool:
        return self.content.incomplete

    @property
    def failed_requirements(self) -> int:
        return self.content.failed_requirements

    @property
    def check_failed(self) -> bool:
        """A design check failed (exit 5): a requirement, or a cam's allowances."""
        return bool(self.content.failed_requirements or self.content.cam_problems)

    def text(self) -> str:
        c = self.content
        lines = [f"{c.title}: report of {c.file or 'the model'}"]
        if c.kind == "mechanism" and c.summary_text:
            lines.append(c.summary_text)
        elif c.cam_text:
            lines.append(c.cam_text)
        if c.polygons_problem:
            lines.append("  note: " + c.polygons_problem[:1].lower() + c.polygons_problem[1:])
        if c.verdicts:
            from mechsolve.results.requirements import verdict_table

            lines.append(verdict_table(c.verdicts))
        return "\n".join(lines)


def _environment():
    try:
        import jinja2
    except ImportError:
        raise InputError(JINJA_HINT) from None
    return jinja2.Environment(
        loader=jinja2.PackageLoader("mechsolve.report", "templates"),
        autoescape=True,
        trim_blocks=True,
        lstrip_blocks=True,
        undefined=jinja2.StrictUndefined,
    )


PAPERS = {"a4": "A4", "letter": "letter"}  # --paper: the CSS page size of each


def paper_size(paper: str) -> str:
    """The CSS page size of ``paper`` (``a4`` or ``letter``, any case)."""
    try:
        return PAPERS[str(paper).lower()]
    except KeyError:
        raise InputError(f"--paper {paper!r}: the paper is a4 or letter") from None


def render(content: Content, paper: str = "a4") -> str:
    """The report's HTML, printed (by ``--pdf`` or from a browser) on ``paper`` (``a4`` or
    ``letter``) with 12 mm margins."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        ver = version("mechsolve")
    except PackageNotFoundError:  # run from a source tree
        ver = "dev"
    size = paper_size(paper)
    env = _environment()
    return env.get_template("report.html.j2").render(
        c=content,
        paper=size,
        version=ver,
        generated=datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
    )


def is_cam_file(path: Path) -> bool:
    """Whether ``path`` is a cam design (a ``cam:`` section and no ``links:``)."""

    data = load_file(path).data
    return isinstance(data, dict) and "cam" in data and "links" not in data


def build(
    file: str | Path,
    variant: str | None = None,
    *,
    frames: int | None = None,
    method: str | None = None,
    polygons_at: str | int | None = None,
    units: str | None = None,
) -> Content:
    """Solve ``file`` every way the report shows it; ``units`` as ``--units`` reads it
    (``SI``, ``file`` or a map; None: the file's units)."""

    file = Path(file)
    _environment()  # say that jinja2 is missing before solving anything
    if is_cam_file(file):
        return cam_content(file, variant)
    mech = api.load(file, variant)
    shown = mech.output_units()
    if units is not None:
        try:
            shown = parse_output_units(units, shown)
        except UnitError as exc:
            raise InputError(f"--units {units!r}: {exc}") from None
    content = mechanism_content(
        mech, frames=frames, method=method, polygons_at=polygons_at, units=shown
    )
    content.variant = variant
    content.file = str(file)
    return content


def shown_name(file: str | Path, out: str | Path) -> str:
    """How the report names its input: relative to the report's folder when the input
    lies in it or below (``mechanisms/crane.yaml``), else by its name alone; never an
    absolute path, which would tell the reader of a shared report the writer's folders
    and mean nothing on another machine."""
    file, folder = Path(file).resolve(), Path(out).resolve().parent
    try:
        return file.relative_to(folder).as_posix()
    except ValueError:
        return file.name


def _write_atomic(path: Path, text: str) -> None:

    with replacing(path) as tmp, open(tmp, "w", encoding="utf-8") as fh:
        fh.write(text)


def write_report(
    file: str | Path,
    variant: str | None = None,
    out: str | Path | None = None,
    *,
    pdf: bool | str | Path = False,
    frames: int | None = None,
    method: str | None = None,
    polygons_at: str | int | None = None,
    paper: str = "a4",
    units: str | None = None,
) -> ReportOutcome:
    """Write the HTML report of ``file`` to ``out`` (default: ``<file stem>.html`` in the
    current folder) and, with ``pdf``, print it to PDF beside it (or to the path given), on
    ``paper`` (``a4`` or ``letter``; also the page size when the HTML is printed from a
    browser). ``units``: the units of its tables, summary and plots, as ``--units``
    reads them (``SI``, ``file`` or a map such as ``force=kN``; None: the file's).

    Raises :class:`~mechsolve.base.errors.InputError` for a wrong file or option, or for
    ``pdf`` without a headless browser (the HTML is written first, so it is there
    either way)."""

    check_frame_count(frames)  # a slip in the options costs nothing
    paper_size(paper)
    file = Path(file)
    if out is None:
        out = Path(file.stem + (f"-{variant}" if variant else "") + ".html")
    out = Path(out)
    if out.suffix.lower() not in (".html", ".htm"):
        raise InputError(f"-o {out}: the report is an HTML file (NAME.html)")
    if not out.parent.is_dir():
        raise InputError(f"-o {out}: the folder {out.parent} does not exist")
    pdf_path = None
    if pdf:
        pdf_path = Path(pdf) if not isinstance(pdf, bool) else out.with_suffix(".pdf")
    content = build(
        file, variant, frames=frames, method=method, polygons_at=polygons_at, units=units
    )
    content.file = shown_name(file, out)
    html = render(content, paper)
    try:
        _write_atomic(out, html)
    except OSError as exc:
        raise InputError(f"-o {out}: cannot write it: {exc.strerror or exc}") from None
    outcome = ReportOutcome(out, None, content)
    if pdf_path is not None:
        from mechsolve.report.browser import print_pdf

        try:
            outcome.pdf = print_pdf(out, pdf_path)
        except InputError as exc:
            raise InputError(f"{exc.message} (the HTML report {out} is written)") from None
    return outcome


__all__ = [
    "JINJA_HINT",
    "PAPERS",
    "ReportOutcome",
    "build",
    "is_cam_file",
    "paper_size",
    "render",
    "shown_name",
    "write_report",
]
