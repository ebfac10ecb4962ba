"""Plots of a study: each figure against each varied parameter, a pass/fail map over two
parameters, and for random studies a scatter matrix (figures against parameters).

Axes name what they show in words with the unit (``crank length O2-A [mm]``,
``min transmission angle B [deg]``), not the key paths of the table's columns; a figure
that a requirement checks is drawn once, with the requirement's limit as a dashed line
and the failing side shaded.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from mechsolve.analyses.study.designs import Study
from mechsolve.analyses.study.figures import Row
from mechsolve.analyses.study.table import columns
from mechsolve.base.units import UnitError, parse_unit
from mechsolve.writers.plots import save_figure

SKIP = {"design [-]", "positions [-]", "solved [-]"}
MAX_FIGURES = 12


def figure_columns(study: Study, rows: list[Row]) -> list[str]:
    """Numeric figure columns (not the parameters, not the verdicts)."""

    params = {p.header for p in study.params}
    out = []
    for c in columns(study, rows):
        if c in SKIP or c in params or c == "status":
            continue
        vals = [r.get(c) for r in rows if r.get(c) is not None]
        if vals and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
            if any(math.isfinite(v) for v in vals):
                out.append(c)
    # a requirement's value is the figure it reads: one panel, the figure's
    checked = {lim.figure for lim in limits(study).values()}
    have = {c.rsplit(" [", 1)[0] for c in out}
    # ... and a requirement without a limit (full turn: its value counts positions) none
    out = [c for c in out if not (_req_name(c) and _req_figure(study, c) in have | {None})]
    out = _distinct(out, rows)
    # the study's own figures first: they are what it was asked for; then what the
    # requirements check
    own = list(study.figures) + ([study.best[1]] if study.best is not None else [])
    first = [c for c in out if c.rsplit(" [", 1)[0] in own]
    first += [c for c in out if c not in first and c.rsplit(" [", 1)[0] in checked]
    return (first + [c for c in out if c not in first])[:MAX_FIGURES]


def _distinct(cols: list[str], rows: list[Row]) -> list[str]:
    """``cols`` without a column whose values repeat an earlier one's (to rounding):
    the same figure under two names is one panel."""
    out: list[str] = []
    seen: list[list[float]] = []
    for c in cols:
        vals = [_num(r.get(c)) for r in rows]
        if any(_same(vals, other) for other in seen):
            continue
        seen.append(vals)
        out.append(c)
    return out


def _same(a: list[float], b: list[float]) -> bool:
    for x, y in zip(a, b):
        if math.isnan(x) != math.isnan(y):
            return False
        if not math.isnan(x) and abs(x - y) > 1e-9 * max(abs(x), abs(y), 1e-300):
            return False
    return True


@dataclass
class Limit:
    """A requirement's limit on one figure, in SI: ``figure op value``."""

    name: str
    figure: str  # the figure as the requirement writes it: min(transmission_angle.B)
    op: str  # <=, <, >=, >
    value: float  # SI (radians for an angle)
    text: str  # as written: 30 deg


_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")
_FLIP = {"<=": ">=", ">=": "<=", "<": ">", ">": "<"}


def limits(study: Study) -> dict[str, Limit]:
    """The file's requirements that bound one figure by a number (``min(...) >= 30 deg``),
    by requirement name; ``full turn`` and comparisons of two figures have none."""
    data = study.source.data if isinstance(study.source.data, dict) else {}
    reqs = data.get("requirements")
    out: dict[str, Limit] = {}
    if not isinstance(reqs, dict):
        return out
    for name, text in reqs.items():
        if not isinstance(text, str):
            continue
        parts = re.split(r"(<=|>=|<|>)", text)
        if len(parts) != 3:
            continue
        left, op, right = parts
        for figure, bound, sense in ((left, right, op), (right, left, _FLIP[op])):
            m = _NUMBER.match(bound)
            if m is None or _NUMBER.match(figure):
                continue
            try:
                factor = parse_unit(m.group(2)).factor if m.group(2) else 1.0
            except UnitError:
                break
            fig_text = re.sub(
                r"\b(time_ratio|swing|stroke)\(\s*([^\W\d]\w*)\s*\)", r"\2.\1", figure
            )  # as the table names it: time_ratio(ram) is ram.time_ratio
            out[str(name)] = Limit(
                str(name),
                " ".join(fig_text.split()),
                sense,
                float(m.group(1)) * factor,
                bound.strip(),
            )
            break
    return out


def _req_name(column: str) -> str | None:
    """``req.torque [N m]`` -> ``torque``; None for another column."""
    m = re.fullmatch(r"req\.(.+?) \[[^\]]*\]", column)
    return m.group(1) if m and not m.group(1).endswith(".pass") else None


def _req_figure(study: Study, column: str) -> str | None:
    lim = limits(study).get(_req_name(column) or "")
    return lim.figure if lim else None


def _column_limit(study: Study, column: str) -> Limit | None:
    """The limit to draw on ``column``'s panel: a requirement on its figure, or the
    requirement whose value it is."""
    name, _, _ = column.partition(" [")
    for lim in limits(study).values():
        if " ".join(name.split()) == lim.figure or _req_name(column) == lim.name:
            return lim
    return None


def _unit_of(column: str) -> str:
    m = re.search(r"\[([^\]]*)\]\s*$", column)
    return m.group(1) if m else ""


def _in_unit(value: float, unit: str) -> float | None:
    """An SI value in ``unit`` (None when the unit cannot be read)."""
    if unit in ("", "-", "SI"):
        return value
    try:
        return value / parse_unit(unit).factor
    except UnitError:
        return None


_WORDS = {
    "transmission_angle": "transmission angle",
    "time_ratio": "time ratio",
    "input": "input",
}


def figure_label(column: str) -> str:
    """A column's axis label in words: ``min(transmission_angle.B) [deg]`` ->
    ``min transmission angle B [deg]``, ``max(abs(input.torque)) [N*m]`` ->
    ``max |input torque| [N*m]``, ``req.swing [deg]`` -> ``swing (requirement) [deg]``."""
    name, sp, unit = column.partition(" [")
    req = _req_name(column)
    if req is not None:
        name = f"{req} (requirement)"
    text = name
    for _ in range(4):  # abs(x) -> |x|, f(x) -> f x
        text = re.sub(r"\babs\(([^()]*)\)", r"|\1|", text)
        text = re.sub(r"\b(min|max|mean|rms|range)\(([^()]*)\)", r"\1 \2", text)
    text = re.sub(r"\bcycle\.work\b", "work per cycle", text)
    text = re.sub(r"\b([A-Za-z_]\w*)\.(F|N)\b", r"\1 reaction \2", text)
    text = re.sub(r"\b([A-Za-z_]\w*)\.(?=[A-Za-z_])", r"\1 ", text)
    for key, word in _WORDS.items():
        text = text.replace(key, word)
    return text.replace("_", " ") + (sp + unit if sp else "")


def parameter_label(study: Study, i: int) -> str:
    """A parameter's axis label in words with its unit: ``links.crank.points.A[0]`` is
    ``crank length O2-A [mm]`` when A lies on the crank's base line from its first point
    at the origin, else ``crank: A x [mm]``; ``ground.O1[0]`` is ``ground O1 x [m]``;
    another key path its words (``coupler mass [kg]``)."""
    p = study.params[i]
    path = tuple(p.path)
    unit = f" [{p.unit or '-'}]"
    data = study.source.data if isinstance(study.source.data, dict) else {}
    axis = {0: "x", 1: "y"}
    if len(path) == 5 and path[0] == "links" and path[2] == "points" and path[4] in axis:
        link, point, k = path[1], path[3], path[4]
        pts = ((data.get("links") or {}).get(link) or {}).get("points") or {}
        first = next(iter(pts), None)
        here = pts.get(point)
        on_base = (
            k == 0
            and first is not None
            and first != point
            and pts.get(first) in ([0, 0], [0.0, 0.0])
            and isinstance(here, list)
            and len(here) == 2
            and here[1] in (0, 0.0)
        )
        if on_base:
            return f"{link} length {first}-{point}{unit}"
        return f"{link}: {point} {axis[k]}{unit}"
    if len(path) == 3 and path[0] == "ground" and path[2] in axis:
        return f"ground {path[1]} {axis[path[2]]}{unit}"
    words = [str(k) for k in path if not isinstance(k, int) and k not in ("links", "points")]
    idx = [axis.get(k, str(k)) for k in path if isinstance(k, int)]
    return " ".join(w.replace("_", " ") for w in words + idx) + unit


def _draw_limit(ax, lim: Limit, column: str) -> None:
    """The limit as a dashed line, the side that fails shaded."""
    value = _in_unit(lim.value, _unit_of(column))
    if value is None or not math.isfinite(value):
        return
    ax.axhline(value, color="tab:red", ls="--", lw=1.1)
    lo, hi = ax.get_ylim()
    lo, hi = min(lo, value), max(hi, value)
    pad = 0.05 * (hi - lo or abs(value) or 1.0)
    lo, hi = lo - pad, hi + pad
    if lim.op in (">=", ">"):
        ax.axhspan(lo, value, color="tab:red", alpha=0.08, lw=0)
    else:
        ax.axhspan(value, hi, color="tab:red", alpha=0.08, lw=0)
    ax.set_ylim(lo, hi)
    ax.text(
        0.99, 0.02 if lim.op in (">=", ">") else 0.98, f"{lim.name}: {lim.op} {lim.text}",
        transform=ax.transAxes, ha="right", va="bottom" if lim.op in (">=", ">") else "top",
        fontsize=7, color="tab:red",
    )  # fmt: skip


def _num(v) -> float:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_")


def _grid(n: int):
    ncol = min(3, n)
    nrow = math.ceil(n / ncol)
    return nrow, ncol


def passed(row: Row) -> bool | None:
    """Whether a design passes: its requirements when the file has any, else whether it
    assembles at every position; None for an invalid design."""
    if str(row.get("status", "")).startswith("invalid"):
        return None
    if "requirements.pass [-]" in row:
        return row["requirements.pass [-]"] is True  # "not assembled" is no pass
    return row.get("status") == "ok"


def write_plots(study: Study, rows: list[Row], outdir: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = sorted(rows, key=lambda r: r["design [-]"])
    figs = figure_columns(study, rows)
    out: list[Path] = []
    if not rows:
        return out
    if figs:
        if study.design in ("random", "latin-hypercube"):
            out.append(_scatter_matrix(plt, study, rows, figs, outdir))
        else:
            for i in range(len(study.params)):
                out.append(_against(plt, study, rows, figs, i, outdir))
    if len(study.params) >= 2:
        out.append(_pass_fail(plt, study, rows, outdir))
    return out


def _against(plt, study: Study, rows: list[Row], figs: list[str], i: int, outdir: Path) -> Path:
    p = study.params[i]
    if study.design == "one-at-a-time":
        sel = [r for r in rows if set(study.designs[r["design [-]"]]) == {i}]
        groups = {"": sel}
    else:  # a grid: one line per combination of the other parameters
        groups: dict[str, list[Row]] = {}
        others = [q for j, q in enumerate(study.params) if j != i and len(q.values) > 1]
        for r in rows:
            label = ", ".join(
                f"{parameter_label(study, study.params.index(q)).rsplit(' [', 1)[0]} = "
                f"{r[q.header]:.4g} {q.unit}".strip()
                for q in others
            )
            groups.setdefault(label, []).append(r)
    nrow, ncol = _grid(len(figs))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.2 * nrow), squeeze=False)
    many = len(groups) > 8
    for ax, c in zip(axes.flat, figs):
        for label, sel in groups.items():
            xs = [_num(r[p.header]) for r in sel]
            ys = [_num(r.get(c)) for r in sel]
            if many:
                ax.plot(xs, ys, ".", color="C0", alpha=0.6)
            else:
                ax.plot(xs, ys, "o-", ms=3, label=label or None)
        ax.set_xlabel(parameter_label(study, i))
        ax.set_ylabel(figure_label(c))
        ax.grid(True, alpha=0.3)
        lim = _column_limit(study, c)
        if lim is not None:
            _draw_limit(ax, lim, c)
    for ax in list(axes.flat)[len(figs) :]:
        ax.axis("off")
    if not many and len(groups) > 1:
        handles, labels = axes.flat[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="lower center", ncol=min(3, len(labels)), fontsize=7)
    kind = "one at a time" if study.design == "one-at-a-time" else "grid"
    what = parameter_label(study, i).rsplit(" [", 1)[0]
    fig.suptitle(f"{_file_name(study)}: figures against {what} ({kind})")
    fig.tight_layout(rect=(0, 0.06 if not many and len(groups) > 1 else 0, 1, 0.96))
    path = outdir / f"study-{_slug(p.name)}.png"
    save_figure(fig, path, 100)
    plt.close(fig)
    return path


def _file_name(study: Study) -> str:
    """The study's file by its name alone: a figure never shows a folder of the machine
    it was made on."""
    return Path(study.file).name


def _pass_fail(plt, study: Study, rows: list[Row], outdir: Path) -> Path:
    p, q = study.params[0], study.params[1]
    by_req = any("requirements.pass [-]" in r for r in rows)
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    marks = [
        (True, "o", "tab:green", "meets every requirement" if by_req else "assembles"),
        (False, "x", "tab:red", "fails a requirement" if by_req else "does not assemble"),
        (None, "s", "0.6", "invalid design"),
    ]
    for verdict, m, color, label in marks:
        sel = [r for r in rows if passed(r) is verdict]
        if by_req and verdict is False:  # a design that cannot be solved fails too
            sel = [r for r in rows if passed(r) is False]
        if sel:
            ax.scatter(
                [_num(r[p.header]) for r in sel],
                [_num(r[q.header]) for r in sel],
                marker=m,
                c=color,
                label=f"{label} ({len(sel)})",
            )
    ax.set_xlabel(parameter_label(study, 0))
    ax.set_ylabel(parameter_label(study, 1))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    px, qy = (parameter_label(study, k).rsplit(" [", 1)[0] for k in (0, 1))
    ax.set_title(f"{_file_name(study)}:\npass/fail over {px} and {qy}", fontsize=9)
    fig.tight_layout()
    path = outdir / "study-pass-fail.png"
    save_figure(fig, path, 100)
    plt.close(fig)
    return path


def _scatter_matrix(plt, study: Study, rows: list[Row], figs: list[str], outdir: Path) -> Path:
    figs = figs[:6]
    params = study.params
    fig, axes = plt.subplots(
        len(figs), len(params), figsize=(3.2 * len(params), 2.6 * len(figs)), squeeze=False
    )
    colors = ["tab:green" if passed(r) else "tab:red" for r in rows]
    for a, c in enumerate(figs):
        ys = [_num(r.get(c)) for r in rows]
        for b, p in enumerate(params):
            ax = axes[a][b]
            ax.scatter([_num(r[p.header]) for r in rows], ys, s=8, c=colors, alpha=0.7)
            ax.grid(True, alpha=0.3)
            if a == len(figs) - 1:
                ax.set_xlabel(parameter_label(study, b), fontsize=8)
            if b == 0:
                ax.set_ylabel(figure_label(c), fontsize=8)
            lim = _column_limit(study, c)
            if lim is not None:
                _draw_limit(ax, lim, c)
            ax.tick_params(labelsize=7)
    by_req = any("requirements.pass [-]" in r for r in rows)
    what = "meets every requirement" if by_req else "assembles"
    fig.suptitle(
        f"{_file_name(study)}: {len(rows)} {study.design} designs (green: {what}, red: not)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    path = outdir / "study-scatter.png"
    save_figure(fig, path, 100)
    plt.close(fig)
    return path


__all__ = [
    "Limit",
    "figure_columns",
    "figure_label",
    "limits",
    "parameter_label",
    "passed",
    "write_plots",
]
