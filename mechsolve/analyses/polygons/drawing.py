"""Drawing the polygons and the mechanism beside them (see :mod:`mechsolve.analyses.polygons`).

The polygons are drawn in mm of the drawing; their scales, the vector axes beside them
and the mechanism's axes are in the units of the printed text (an
:class:`~mechsolve.base.units.OutputUnits`, SI by default): ``μv = 10 (mm/s)/mm``."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from mechsolve.analyses.polygons.construction import Polygon, PolygonResult, build_polygons
from mechsolve.base.units import SI_OUTPUT, OutputUnits, pretty_unit
from mechsolve.model import Mechanism
from mechsolve.writers.fonts import pyplot
from mechsolve.writers.plots import draw_mechanism, length_axes, names_of, save_figure

COLOURS = {
    "absolute": "k",
    "relative": "tab:blue",
    "normal": "tab:green",
    "tangential": "tab:orange",
    "coriolis": "tab:purple",
    "sliding": "tab:red",
}


def _tex(name: str) -> str:
    """``a^n_A4`` as mathtext when its parts are plain letters and digits."""
    m = re.fullmatch(r"([va])(?:\^([ntkr]))?_([A-Za-z0-9]+)", name)
    if not m:
        return name
    sym, sup, sub = m.groups()
    return f"${sym}" + (f"^{{{sup}}}" if sup else "") + f"_{{\\mathrm{{{sub}}}}}$"


def _node_text(label: str) -> str:
    return label[:1].lower() + label[1:] if label[:1].isascii() else label


def _bounds(poly: Polygon) -> tuple[np.ndarray, np.ndarray, float]:
    """Lower and upper corners of the drawing (mm) with a margin, and the polygon's span."""
    pts = np.array(list(poly.nodes.values())) / poly.scale
    span = float(np.max(pts.max(axis=0) - pts.min(axis=0))) if len(pts) else 0.0
    span = span or 1.0
    pad = 0.12 * span + 3
    return pts.min(axis=0) - pad, pts.max(axis=0) + pad, span


def _free_spot(cands, taken: list[np.ndarray], gap: float) -> np.ndarray:
    """The first candidate position at least ``gap`` from every taken one, else the one
    farthest from them."""
    best, far = cands[0], -1.0
    for c in cands:
        near = min((float(np.hypot(*(c - t))) for t in taken), default=math.inf)
        if near >= gap:
            return c
        if near > far:
            best, far = c, near
    return best


def _draw_polygon(ax, poly: Polygon, U: OutputUnits = SI_OUTPUT) -> None:
    mu = poly.scale
    lo, hi, span = _bounds(poly)
    nodes = {k: v / mu for k, v in poly.nodes.items()}
    centre = np.mean(np.array(list(nodes.values())), axis=0)
    taken = list(nodes.values())
    gap = 0.045 * span
    groups: dict[tuple[float, float], list[str]] = {}
    for lab, p in nodes.items():
        groups.setdefault((round(float(p[0]), 3), round(float(p[1]), 3)), []).append(lab)
    for (x, y), labs in groups.items():
        at = np.array([x, y])
        ax.plot([x], [y], "o", ms=3, color="k", zorder=5)
        away = at - centre
        ang0 = math.atan2(away[1], away[0]) if np.hypot(*away) > 1e-9 * span else -math.pi / 2
        cands = [
            at + 0.05 * span * np.array([math.cos(ang0 + k), math.sin(ang0 + k)])
            for k in (0, 0.8, -0.8, 1.6, -1.6, 2.4, -2.4, math.pi)
        ]
        spot = _free_spot(cands, [t for t in taken if np.hypot(*(t - at)) > 1e-9], 1.4 * gap)
        taken.append(spot)
        pole = [lab for lab in labs if lab == poly.pole]
        rest = [_node_text(lab) for lab in labs if lab != poly.pole]
        text = (f"{pole[0]} ({', '.join(rest)})" if rest else pole[0]) if pole else ", ".join(rest)
        ax.text(*spot, text, fontsize=9, ha="center", va="center", zorder=6)
    for a in poly.arrows:
        t, h = nodes[a.tail], nodes[a.head]
        if np.hypot(*(h - t)) < 1e-9 * span:
            continue
        col = COLOURS[a.kind]
        ax.annotate(
            "",
            xy=h,
            xytext=t,
            arrowprops={
                "arrowstyle": "-|>",
                "color": col,
                "lw": 1.4,
                "shrinkA": 0,
                "shrinkB": 0,
                "mutation_scale": 11,
            },
        )
        dx, dy = h - t
        n = np.array([-dy, dx]) / np.hypot(dx, dy)
        off = 0.025 * span
        cands = [
            t + f * (h - t) + sg * off * n for f in (0.5, 0.35, 0.65, 0.25, 0.75) for sg in (1, -1)
        ]
        spot = _free_spot(cands, taken, gap)
        taken.append(spot)
        ax.text(*spot, _tex(a.name), color=col, fontsize=8, ha="center", va="center")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal", adjustable="box")
    ax.grid(True, alpha=0.25)
    sym = "μv" if poly.quantity == "velocity" else "μa"
    k, u = U.convert(poly.unit)  # the vectors in the printed text's unit
    u = pretty_unit(u)
    ax.set_title(f"{poly.quantity} polygon, {sym} = {mu * k:g} ({u})/mm", fontsize=10)
    ax.set_xlabel("x on the drawing [mm]")
    ax.set_ylabel("y on the drawing [mm]")
    q = "v" if poly.quantity == "velocity" else "a"
    mk = mu * k  # shown unit per mm of the drawing
    top = ax.secondary_xaxis("top", functions=(lambda x: x * mk, lambda x: x / mk))
    top.set_xlabel(f"{q}x [{u}]", fontsize=8)
    right = ax.secondary_yaxis("right", functions=(lambda x: x * mk, lambda x: x / mk))
    right.set_ylabel(f"{q}y [{u}]", fontsize=8)
    top.tick_params(labelsize=7)
    right.tick_params(labelsize=7)


def _aspect(poly: Polygon) -> float:
    lo, hi, _ = _bounds(poly)
    w, h = hi - lo
    return float(min(max(h / w, 0.35), 2.5))


def _legend(fig, *polys: Polygon) -> None:
    from matplotlib.lines import Line2D

    names = {
        "absolute": "absolute (from the pole)",
        "relative": "relative (rotation)",
        "normal": "normal component aⁿ",
        "tangential": "tangential component aᵗ",
        "coriolis": "Coriolis aᵏ",
        "sliding": "sliding along a guide",
    }
    used = {a.kind for p in polys for a in p.arrows}
    handles = [
        Line2D([], [], color=COLOURS[k], lw=2, label=v) for k, v in names.items() if k in used
    ]
    fig.legend(handles=handles, loc="lower center", ncol=3, fontsize=8, frameon=False)


def _draw_mechanism(ax, res: PolygonResult, U: OutputUnits = SI_OUTPUT) -> None:
    """The mechanism at the position (drawn in m, its ticks in the shown length unit)."""
    draw_mechanism(ax, res.analysis, res.state, 0)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.25)
    unit = length_axes(ax, U)
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    k = U.convert("m")[0]
    ax.set_title(f"mechanism, μl = {res.length_scale * k:g} {unit}/mm", fontsize=10)


def draw_polygons(
    mech: Mechanism,
    at: int | str,
    outdir: str | Path,
    *,
    scale_v: float | None = None,
    scale_a: float | None = None,
    per_turn: int = 12,
    svg: bool = False,
    sheet: str | Path | None = None,
    method: str | None = None,
    units: OutputUnits | None = None,
) -> PolygonResult:
    """Build the polygons (:func:`build_polygons`) and draw them into ``outdir``:
    ``velocity-polygon.png``, ``acceleration-polygon.png`` and ``polygons.png`` (the sheet:
    the mechanism to scale beside both polygons); with ``svg`` also the SVGs (text kept as
    text). ``sheet``: write the sheet to this file only (``.png`` or ``.svg``) instead.
    The scales and axes are in ``units`` (default SI), as the printed text of
    :meth:`PolygonResult.text`. The result's ``images`` lists the files written."""
    U = units or SI_OUTPUT

    res = build_polygons(
        mech, at, scale_v=scale_v, scale_a=scale_a, per_turn=per_turn, method=method
    )
    plt = pyplot([res.label, *names_of(mech)])
    outdir = Path(outdir)
    if sheet is None:
        outdir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    exts = ["png", "svg"] if svg else ["png"]
    title = f"{mech.name}: {res.label}"
    if sheet is None:
        for poly, stem in (
            (res.velocity, "velocity-polygon"),
            (res.acceleration, "acceleration-polygon"),
        ):
            fig, ax = plt.subplots(figsize=(7.5, 6.5 * _aspect(poly) + 2.2))
            _draw_polygon(ax, poly, U)
            fig.suptitle(title, fontsize=9)
            _legend(fig, poly)
            fig.tight_layout(rect=(0, 0.07, 1, 1))
            for ext in exts:
                path = outdir / f"{stem}.{ext}"
                save_figure(fig, path, 120)
                written.append(path)
            plt.close(fig)
    asp = [_aspect(res.velocity), _aspect(res.acceleration)]
    fig, axes = plt.subplots(
        1, 3, figsize=(18, 7), gridspec_kw={"width_ratios": [1.0, 1 / asp[0], 1 / asp[1]]}
    )
    _draw_mechanism(axes[0], res, U)
    _draw_polygon(axes[1], res.velocity, U)
    _draw_polygon(axes[2], res.acceleration, U)
    fig.suptitle(title, fontsize=11)
    _legend(fig, res.velocity, res.acceleration)
    fig.tight_layout(rect=(0, 0.07, 1, 0.96))  # the top: the title, clear of the axes
    if sheet is not None:
        path = Path(sheet)
        save_figure(fig, path, 120)
        written.append(path)
    else:
        for ext in exts:
            path = outdir / f"polygons.{ext}"
            save_figure(fig, path, 120)
            written.append(path)
    plt.close(fig)
    res.images = written
    return res
