"""Plots of a study: each figure against each varied parameter, a pass/fail map over two
parameters, and for random studies a scatter matrix (figures against parameters)."""

from __future__ import annotations

import math
import re
from pathlib import Path

from mechsolve.analyses.study.designs import Study
from mechsolve.analyses.study.figures import Row
from mechsolve.analyses.study.table import columns
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
    # the study's own figures first: they are what it was asked for
    own = list(study.figures) + ([study.best[1]] if study.best is not None else [])
    first = [c for c in out if c.rsplit(" [", 1)[0] in own]
    return (first + [c for c in out if c not in first])[:MAX_FIGURES]


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
            label = ", ".join(f"{q.name} = {r[q.header]:.4g} {q.unit}".strip() for q in others)
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
        ax.set_xlabel(p.header)
        ax.set_ylabel(c)
        ax.grid(True, alpha=0.3)
    for ax in list(axes.flat)[len(figs) :]:
        ax.axis("off")
    if not many and len(groups) > 1:
        handles, labels = axes.flat[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="lower center", ncol=min(3, len(labels)), fontsize=7)
    kind = "one at a time" if study.design == "one-at-a-time" else "grid"
    fig.suptitle(f"{study.file}: figures against {p.name} ({kind})")
    fig.tight_layout(rect=(0, 0.06 if not many and len(groups) > 1 else 0, 1, 0.96))
    path = outdir / f"study-{_slug(p.name)}.png"
    save_figure(fig, path, 100)
    plt.close(fig)
    return path


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
    ax.set_xlabel(p.header)
    ax.set_ylabel(q.header)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    ax.set_title(f"{study.file}:\npass/fail over {p.name} and {q.name}", fontsize=9)
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
                ax.set_xlabel(p.header, fontsize=8)
            if b == 0:
                ax.set_ylabel(c, fontsize=8)
            ax.tick_params(labelsize=7)
    by_req = any("requirements.pass [-]" in r for r in rows)
    what = "meets every requirement" if by_req else "assembles"
    fig.suptitle(
        f"{study.file}: {len(rows)} {study.design} designs (green: {what}, red: not)", fontsize=10
    )
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    path = outdir / "study-scatter.png"
    save_figure(fig, path, 100)
    plt.close(fig)
    return path


__all__ = ["figure_columns", "passed", "write_plots"]
