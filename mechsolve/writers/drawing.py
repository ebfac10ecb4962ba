"""The linkage as a drawing for CAD (``mechsolve draw``): DXF through ezdxf, SVG and PDF
through matplotlib.

:func:`sheet` computes everything drawn, in the file's length unit, once: the links as
bars (their outline around their points, with a centre line between each pair of joint
points), the pins, the slider blocks, the ground pivots with their hatching, the fixed
guides, what the joints draw through their hooks (a gear's pitch circle, a cam's
profile), the point paths over the sweep and the dimensions of the link lengths.
:func:`write_dxf` and :func:`write_figure` only trace that sheet, so the DXF and the
SVG/PDF cannot differ. A joint is asked how it is drawn (``guide``, ``drawing``,
``outlines``), never tested for its kind.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mechsolve.base.atomic import replacing
from mechsolve.base.units import parse_unit

DXF_HINT = 'the DXF needs ezdxf: pip install "mechsolve[cad]" (or pip install ezdxf)'
DIMSTYLE = "MECHSOLVE"  # the drawing's dimension style: it measures in the drawing's unit
LAYERS = {  # name: AutoCAD colour index
    "LINKS": 7,
    "PINS": 1,
    "GROUND": 8,
    "GUIDES": 8,
    "PATHS": 3,
    "DIMENSIONS": 5,
    "JOINTS": 6,
    "ENVELOPE": 9,
}
# sizes as fractions of the mechanism's characteristic length
PIN = 0.018
BAR = 0.035
BLOCK = 0.045
PIVOT = 0.06
DIM_OFFSET = 0.09
TEXT = 0.022


@dataclass
class Bar:
    """A link drawn as a bar: its closed outline and its centre lines (one per pair of
    joint points, ``(p, q)`` named by the points)."""

    link: str
    outline: np.ndarray
    centres: list[tuple[str, str, np.ndarray, np.ndarray]]


@dataclass
class Dimension:
    """An aligned dimension of ``length`` between ``p`` and ``q``, its line ``offset``
    to the left of ``p -> q``."""

    p: np.ndarray
    q: np.ndarray
    offset: float
    length: float
    text: str


@dataclass
class Sheet:
    """Everything a drawing of a linkage shows, in the file's length unit ``unit``."""

    title: str
    unit: str
    size: float  # the mechanism's characteristic length, in ``unit``
    bars: list[Bar] = field(default_factory=list)
    blocks: list[tuple[str, np.ndarray]] = field(default_factory=list)
    pins: list[tuple[float, float, float]] = field(default_factory=list)
    ground: list[np.ndarray] = field(default_factory=list)  # polylines
    guides: list[np.ndarray] = field(default_factory=list)
    joints: list[np.ndarray] = field(default_factory=list)  # the joints' own curves
    paths: list[tuple[str, np.ndarray]] = field(default_factory=list)
    dimensions: list[Dimension] = field(default_factory=list)
    envelope: list[np.ndarray] = field(default_factory=list)

    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        """The lower-left and upper-right corners of everything drawn."""
        pts = [b.outline for b in self.bars] + [b for _, b in self.blocks]
        pts += self.ground + self.guides + self.joints + self.envelope
        pts += [p for _, p in self.paths]
        pts += [np.array([[x - r, y - r], [x + r, y + r]]) for x, y, r in self.pins]
        for d in self.dimensions:
            pts.append(np.array([d.p, d.q]) + _normal(d.p, d.q) * d.offset)
        allp = np.vstack([p[np.all(np.isfinite(p), axis=1)] for p in pts if len(p)])
        return allp.min(axis=0), allp.max(axis=0)


def _normal(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    d = q - p
    n = math.hypot(*d)
    return np.array([-d[1], d[0]]) / n if n else np.array([0.0, 1.0])


def rounded_hull(pts: np.ndarray, r: float, arc: int = 12) -> np.ndarray:
    """The closed outline at distance ``r`` around the convex hull of ``pts`` (k, 2):
    straight sides parallel to the hull's, joined by arcs of radius ``r`` around its
    corners (two points give a slot, one a circle). The last point repeats the first."""
    from mechsolve.writers.plots import _hull

    hull = _hull(np.asarray(pts, float))
    if len(hull) >= 3:  # counter-clockwise, as _hull gives it
        area = np.sum(hull[:, 0] * np.roll(hull[:, 1], -1) - np.roll(hull[:, 0], -1) * hull[:, 1])
        if area < 0:
            hull = hull[::-1]
    out = []
    n = len(hull)
    if n == 1:
        t = np.linspace(0, 2 * np.pi, 4 * arc + 1)
        return hull[0] + r * np.column_stack([np.cos(t), np.sin(t)])
    for k in range(n):
        prev, cur, nxt = hull[k - 1], hull[k], hull[(k + 1) % n]
        a0 = math.atan2(*(cur - prev)[::-1]) - math.pi / 2  # outward normal of the side in
        a1 = math.atan2(*(nxt - cur)[::-1]) - math.pi / 2  # ... and of the side out
        if n == 2:  # a slot: each end a half circle
            a1 = a0 + math.pi
        sweep = (a1 - a0) % (2 * math.pi)
        steps = max(2, int(math.ceil(sweep / (math.pi / 2) * arc / 2)))
        t = a0 + np.linspace(0.0, sweep, steps + 1)
        out.append(cur + r * np.column_stack([np.cos(t), np.sin(t)]))
    o = np.vstack(out)
    return np.vstack([o, o[:1]])


def _place(state: Any, b: int, i: int, loc: np.ndarray) -> np.ndarray:
    """Points ``loc`` (k, 2) fixed in body ``b``, placed at position ``i``."""
    th = float(state.th[b, i])
    c, s = math.cos(th), math.sin(th)
    x0, y0 = float(state.x[b, i]), float(state.y[b, i])
    return np.column_stack([x0 + c * loc[:, 0] - s * loc[:, 1], y0 + s * loc[:, 0] + c * loc[:, 1]])


def _link_shapes(an: Any, state: Any, i: int, k: float) -> list[tuple[str, np.ndarray, bool]]:
    """Each link at position ``i``: its name, its points placed (in the drawing's unit,
    ``k`` per metre), and whether it is a block (a single point)."""
    out = []
    for lk in an.mech.links:
        b = an.system.index[lk.name]
        loc = np.array(list(lk.points.values()), float)
        pts = _place(state, b, i, loc) * k
        if np.all(np.isfinite(pts)):
            out.append((lk.name, pts, len(pts) == 1))
    return out


def _block(centre: np.ndarray, th: float, h: float) -> np.ndarray:
    c, s = math.cos(th), math.sin(th)
    sq = np.array([[-1, -0.6], [1, -0.6], [1, 0.6], [-1, 0.6], [-1, -0.6]]) * h
    return centre + sq @ np.array([[c, s], [-s, c]])


def _pivot(x: float, y: float, h: float, pin: float) -> list[np.ndarray]:
    """A ground pivot under ``(x, y)``: a triangle from the pin down to a base line, and
    the base's hatching (short lines at 45 degrees below it)."""
    w = 0.7 * h
    tri = np.array([[x - w, y - h], [x, y - pin], [x + w, y - h]])
    base = np.array([[x - 1.5 * w, y - h], [x + 1.5 * w, y - h]])
    out = [tri, base]
    step = 3 * w / 6
    for j in range(7):
        x0 = x - 1.5 * w + j * step
        out.append(np.array([[x0, y - h], [x0 - 0.45 * h, y - 1.45 * h]]))
    return out


def _guide(seg: np.ndarray, h: float) -> list[np.ndarray]:
    """A fixed guide: its line, and hatching on its right-hand side."""
    p, q = seg[0], seg[1]
    n = _normal(p, q)
    d = q - p
    length = math.hypot(*d)
    out = [seg]
    if length > 0:
        u = d / length
        count = max(2, int(length / (0.8 * h)))
        for j in range(count + 1):
            a = p + d * j / count - n * 0.6 * h  # below the block's face
            out.append(np.array([a, a - 0.5 * h * (u + n)]))
    return out


def _segments(xy: np.ndarray) -> list[np.ndarray]:
    """A path split where it is not defined (NaN: positions that did not solve)."""
    ok = np.all(np.isfinite(xy), axis=1)
    out, cur = [], []
    for p, good in zip(xy, ok):
        if good:
            cur.append(p)
        elif cur:
            out.append(np.array(cur))
            cur = []
    if cur:
        out.append(np.array(cur))
    return [s for s in out if len(s) >= 2]


def _fmt(value: float) -> str:
    return f"{value:.6g}"


def _link(
    out: Sheet, lk: Any, an: Any, state: Any, i: int, k: float, joints: set[str], block: bool
) -> None:
    """Link ``lk`` at position ``i`` onto ``out``: a block (a one-point link that slides),
    or a bar with a centre line and an aligned dimension between each pair of its joint
    points ``joints``."""
    size = out.size
    b = an.system.index[lk.name]
    names = list(lk.points)
    loc = np.array([lk.points[n] for n in names], float)
    pts = _place(state, b, i, loc) * k
    if not np.all(np.isfinite(pts)):
        return
    if len(pts) == 1 and block:
        out.blocks.append((lk.name, _block(pts[0], float(state.th[b, i]), BLOCK * size)))
        return
    jp = [n for n in names if n in joints]
    centres = []
    for a_ in range(len(jp)):
        for b_ in range(a_ + 1, len(jp)):
            p, q = pts[names.index(jp[a_])], pts[names.index(jp[b_])]
            centres.append((jp[a_], jp[b_], p, q))
            if (q[0] - p[0], q[1] - p[1]) < (0.0, 0.0):  # its text reads left to right
                p, q = q, p
            # the length in the file's unit from the link's own points, not the drawing
            la = np.asarray(lk.points[jp[a_]], float)
            lb = np.asarray(lk.points[jp[b_]], float)
            length = math.dist(la, lb) * k
            out.dimensions.append(
                Dimension(p, q, DIM_OFFSET * size, length, f"{_fmt(length)} {out.unit}")
            )
    out.bars.append(Bar(lk.name, rounded_hull(pts, BAR * size), centres))


def sheet(
    an: Any,
    state: Any,
    i: int,
    *,
    sweep: Any = None,
    paths: dict[str, np.ndarray] | None = None,
    envelope: int = 0,
    title: str = "",
    unit: str = "m",
) -> Sheet:
    """What a drawing of the linkage at position ``i`` of ``state`` shows.

    Parameters
    ----------
    an
        The mechanism's :class:`~mechsolve.core.sweep.Analysis`.
    state
        The solved state (:class:`~mechsolve.base.state.State`) holding position ``i``.
    sweep
        The state over the sweep: fixed guides span the travel seen in it; with
        ``envelope``, that many positions of it, evenly spread, are outlined.
    paths
        Point paths over the sweep, ``(k, 2)`` arrays in metres (NaN where unsolved).
    unit
        The drawing's length unit (the file's); lengths are written in it.
    """
    k = 1.0 / parse_unit(unit).factor
    size = an.scale * k
    out = Sheet(title, unit, size)
    sys_ = an.system
    mech = an.mech
    pin = PIN * size
    joint_of_link: dict[str, set[str]] = {lk.name: set() for lk in mech.links}
    pinned: set[str] = set()
    sliding: set[str] = set()  # links that a sliding pair joins: a one-point one is a block
    for j in mech.joints:
        for ln in j.links:
            if ln in joint_of_link:
                joint_of_link[ln].add(j.point)
                if j.coordinate == "length":
                    sliding.add(ln)
        if j.joins(j.point):
            pinned.add(j.point)
    for lk in mech.links:
        _link(out, lk, an, state, i, k, joint_of_link[lk.name], lk.name in sliding)
    for p, ref in an.points.items():
        if p not in pinned:
            continue
        x, y = (float(v[0]) * k for v in state.point(ref.body, ref.local, [i]))
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        if (x, y, pin) not in out.pins:
            out.pins.append((x, y, pin))
        if ref.body == sys_.nb:
            out.ground += _pivot(x, y, PIVOT * size, pin)
    for c in sys_.constraints:
        seg = c.guide(sweep if sweep is not None else state, an.scale)
        if seg is not None:
            out.guides += _guide(np.asarray(seg, float) * k, BLOCK * size)
        out.joints += [np.asarray(line, float) * k for line in c.drawing(state, i)]
        for b, loc in c.outlines():
            if math.isfinite(float(state.th[b, i])):
                out.joints.append(_place(state, b, i, np.asarray(loc, float)) * k)
    for name, xy in (paths or {}).items():
        for seg in _segments(np.asarray(xy, float) * k):
            out.paths.append((name, seg))
    if envelope and sweep is not None:
        _envelope(out, an, sweep, envelope, k, sliding)
    return out


def _envelope(out: Sheet, an: Any, sweep: Any, count: int, k: float, sliding: set[str]) -> None:
    """Outlines of the links at ``count`` positions spread evenly over the sweep, and the
    overall extent of the linkage in motion with its two dimensions: the box around the
    moving links' outlines at every position of the sweep (not the dimension lines,
    hatching and guides on the sheet, so not the position drawn)."""
    n = sweep.th.shape[1]
    idx = set(np.unique(np.linspace(0, n - 1, min(count, n)).round().astype(int)).tolist())
    size = out.size
    lo = np.full(2, np.inf)
    hi = np.full(2, -np.inf)
    for j in range(n):
        for _name, pts, block in _link_shapes(an, sweep, j, k):
            if block and _name in sliding:
                b = an.system.index[_name]
                shape = _block(pts[0], float(sweep.th[b, j]), BLOCK * size)
                lo, hi = np.minimum(lo, shape.min(axis=0)), np.maximum(hi, shape.max(axis=0))
            else:  # the rounded outline's box: its points' box grown by the bar's radius
                r = BAR * size
                lo, hi = np.minimum(lo, pts.min(axis=0) - r), np.maximum(hi, pts.max(axis=0) + r)
                shape = rounded_hull(pts, r, arc=4) if j in idx else None
            if j in idx and shape is not None:
                out.envelope.append(shape)
    if not np.all(np.isfinite([lo, hi])):
        return
    box = np.array([lo, [hi[0], lo[1]], hi, [lo[0], hi[1]], lo])
    out.envelope.append(box)
    for p, q in ((box[0], box[1]), (box[1], box[2])):
        length = math.dist(p, q)
        out.dimensions.append(
            Dimension(p, q, -DIM_OFFSET * size, length, f"{_fmt(length)} {out.unit}")
        )


# -- DXF ------------------------------------------------------------------------------
def write_dxf(sh: Sheet, path: Path) -> Path:
    """The sheet as DXF R2010 in the file's length unit (``$INSUNITS``), one layer per
    kind of line (:data:`LAYERS`); the dimensions are true aligned DIMENSION entities.
    Raises ImportError when ezdxf is not installed."""
    import ezdxf

    # the line types and text styles only: ezdxf's own dimension styles measure a drawing
    # in metres as centimetres (a length factor of 100)
    doc = ezdxf.new("R2010", setup=["linetypes", "styles"])
    code = dxf_unit_code(sh.unit)
    doc.units = code if code is not None else 0  # 0: unitless (a unit DXF does not name)
    doc.header["$MEASUREMENT"] = 0 if code in imperial_codes() else 1
    h = TEXT * sh.size
    _dimstyle(doc, sh.unit, h)
    for name, color in LAYERS.items():
        doc.layers.add(name, color=color)
    msp = doc.modelspace()

    def poly(pts: np.ndarray, layer: str, closed: bool = False) -> None:
        msp.add_lwpolyline(np.asarray(pts, float).tolist(), close=closed,
                           dxfattribs={"layer": layer})  # fmt: skip

    for bar in sh.bars:
        poly(bar.outline[:-1], "LINKS", closed=True)
        for _p, _q, a, b in bar.centres:
            msp.add_line(tuple(a), tuple(b), dxfattribs={"layer": "LINKS", "linetype": "CENTER"})
    for _name, blk in sh.blocks:
        poly(blk[:-1], "LINKS", closed=True)
    for x, y, r in sh.pins:
        msp.add_circle((x, y), r, dxfattribs={"layer": "PINS"})
    for line in sh.ground:
        poly(line, "GROUND")
    for line in sh.guides:
        poly(line, "GUIDES")
    for line in sh.joints:
        poly(line, "JOINTS")
    for name, line in sh.paths:
        poly(line, "PATHS")
        msp.add_text(name, height=h, dxfattribs={"layer": "PATHS", "insert": tuple(line[0])})
    for line in sh.envelope:
        poly(line, "ENVELOPE")
    for d in sh.dimensions:
        # the text is the measurement ("<>", kept live by CAD) and the unit (the
        # style's suffix), to six significant digits
        dim = msp.add_aligned_dim(
            p1=tuple(d.p),
            p2=tuple(d.q),
            distance=d.offset,
            dimstyle=DIMSTYLE,
            dxfattribs={"layer": "DIMENSIONS"},
            # the suffix also on each dimension: ezdxf leaves it out of an R2007+ style
            override={"dimdec": _decimals(d.length), "dimpost": f"<> {sh.unit}"},
        )
        dim.render()
    with replacing(path) as tmp:
        doc.saveas(tmp)
    return path


def dxf_unit_code(unit: str) -> int | None:
    """The DXF ``$INSUNITS`` code of the length unit ``unit`` (as a file writes it:
    ``mm``, ``inch``, ``µm``, ``in*in/mm``), found by its size against ezdxf's table of
    the codes' units; None where DXF has no code for it."""
    from ezdxf.units import METER_FACTOR

    per_metre = 1.0 / parse_unit(unit).factor
    for code, factor in enumerate(METER_FACTOR):
        if factor and math.isclose(factor, per_metre, rel_tol=1e-8):
            return code
    return None


def imperial_codes() -> set[int]:
    """The DXF ``$INSUNITS`` codes of imperial units (``$MEASUREMENT`` 0 for them)."""
    from ezdxf.units import IMPERIAL_UNITS

    return {int(u) for u in IMPERIAL_UNITS}


def _decimals(length: float) -> int:
    """The decimals that show ``length`` to six significant digits (as the SVG does)."""
    if not (math.isfinite(length) and length):
        return 0
    return int(min(8, max(0, 5 - math.floor(math.log10(abs(length))))))


def _dimstyle(doc: Any, unit: str, h: float) -> None:
    """The drawing's dimension style :data:`DIMSTYLE`, also its current one (the header's
    ``$DIM...`` variables): a length factor of 1 (a dimension reads the drawing's own
    unit), text and arrows of height ``h``, trailing zeros dropped, the unit after the
    measurement."""
    attrs = {
        "dimlfac": 1.0,
        "dimscale": 1.0,
        "dimtxt": h,
        "dimasz": h,
        "dimexo": 0.3 * h,
        "dimexe": 0.5 * h,
        "dimgap": 0.3 * h,
        "dimtad": 1,
        "dimdec": 4,
        "dimzin": 8,
        "dimlunit": 2,
        "dimdsep": ord("."),
        "dimpost": f"<> {unit}",
    }
    doc.dimstyles.new(DIMSTYLE, dxfattribs=dict(attrs))
    doc.header["$DIMSTYLE"] = DIMSTYLE
    for key, value in attrs.items():
        doc.header["$" + key.upper()] = value


# -- SVG and PDF ------------------------------------------------------------------------
PAPER = (277.0, 190.0)  # A4 landscape less its margins [mm]
SERIES = (1.0, 2.0, 2.5, 5.0)


def paper_scale(extent: float, unit: str, room: float) -> float:
    """The drawing's scale as paper mm per drawing unit: the largest standard ratio
    (1:1, 1:2, 1:2.5, 1:5, 1:10 ..., or 2:1, 5:1 ...) at which ``extent`` fits ``room``
    millimetres."""
    mm = parse_unit(unit).factor * 1e3  # mm per drawing unit
    need = extent * mm / room  # reduce at least this much
    best = None
    for e in range(-4, 7):
        for s in SERIES:
            ratio = s * 10.0**e
            if ratio >= need * (1 - 1e-12) and (best is None or ratio < best):
                best = ratio
    return mm / (best or need)


def ratio_text(mm_per_unit: float, unit: str) -> str:
    r = parse_unit(unit).factor * 1e3 / mm_per_unit
    return f"1:{r:.6g}" if r >= 1 else f"{1 / r:.6g}:1"


def write_figure(sh: Sheet, path: Path) -> Path:
    """The sheet as SVG or PDF (from the suffix) at a standard scale that fits A4, the scale
    and the unit in its title. Each bar is one group with id ``bar-<link>``."""
    from mechsolve.writers.fonts import pyplot
    from mechsolve.writers.plots import save_figure

    plt = pyplot([sh.title, *(b.link for b in sh.bars), *(n for n, _ in sh.paths)])
    lo, hi = sh.extent()
    pad = 0.04 * sh.size
    lo, hi = lo - pad, hi + pad
    span = hi - lo
    s = min(paper_scale(span[0], sh.unit, PAPER[0]), paper_scale(span[1], sh.unit, PAPER[1]))
    w_mm, h_mm = span * s
    margin = 12.0
    fig = plt.figure(figsize=((w_mm + 2 * margin) / 25.4, (h_mm + 2 * margin + 12) / 25.4))
    W, H = fig.get_size_inches() * 25.4
    ax = fig.add_axes((margin / W, margin / H, w_mm / W, h_mm / H))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_axis_off()
    pt = 72 / 25.4  # points per paper mm
    text_pt = max(5.0, min(9.0, TEXT * sh.size * s * pt))
    for line in sh.envelope:
        ax.plot(line[:, 0], line[:, 1], color="0.75", lw=0.3)
    for bar in sh.bars:
        (art,) = ax.plot(bar.outline[:, 0], bar.outline[:, 1], color="k", lw=0.7)
        art.set_gid(f"bar-{bar.link}")
        for _p, _q, a, b in bar.centres:
            ax.plot([a[0], b[0]], [a[1], b[1]], color="0.3", lw=0.35, dashes=(8, 2, 1.5, 2))
    for name, blk in sh.blocks:
        (art,) = ax.plot(blk[:, 0], blk[:, 1], color="k", lw=0.7)
        art.set_gid(f"block-{name}")
    for x, y, r in sh.pins:
        t = np.linspace(0, 2 * np.pi, 49)
        ax.plot(x + r * np.cos(t), y + r * np.sin(t), color="#c00000", lw=0.5)
    for line in sh.ground + sh.guides:
        ax.plot(line[:, 0], line[:, 1], color="0.35", lw=0.5)
    for line in sh.joints:
        ax.plot(line[:, 0], line[:, 1], color="#8000a0", lw=0.5, dashes=(6, 2, 1.5, 2))
    for name, line in sh.paths:
        ax.plot(line[:, 0], line[:, 1], color="#008000", lw=0.5)
        ax.annotate(name, tuple(line[0]), fontsize=text_pt, color="#008000")
    for d in sh.dimensions:
        _dimension(ax, d, text_pt)
    import textwrap

    chars = max(30, int((W - 2 * margin) / 1.9))  # about 1.9 mm a character at 8 pt
    head = textwrap.fill(
        f"{sh.title} · lengths in {sh.unit} · scale {ratio_text(s, sh.unit)} printed at 100 %",
        chars,
    )
    fig.text(margin / W, 1 - 3 / H, head, ha="left", va="top", fontsize=8)
    save_figure(fig, path, 150)
    plt.close(fig)
    return path


def _dimension(ax: Any, d: Dimension, text_pt: float) -> None:
    """An aligned dimension drawn as a draughtsman does: extension lines, the dimension
    line with arrows at both ends, the measurement above its middle."""
    n = _normal(d.p, d.q)
    a, b = d.p + n * d.offset, d.q + n * d.offset
    col = "#0030c0"
    for base, end in ((d.p, a), (d.q, b)):
        e = end + n * np.sign(d.offset) * 0.2 * abs(d.offset)
        ax.plot([base[0] + n[0] * 0.15 * d.offset, e[0]],
                [base[1] + n[1] * 0.15 * d.offset, e[1]], color=col, lw=0.3)  # fmt: skip
    ax.annotate("", xy=tuple(a), xytext=tuple(b),
                arrowprops={"arrowstyle": "<|-|>", "color": col, "lw": 0.4,
                            "shrinkA": 0, "shrinkB": 0, "mutation_scale": 5})  # fmt: skip
    ang = math.degrees(math.atan2(b[1] - a[1], b[0] - a[0]))
    if ang > 90 or ang <= -90:
        ang -= 180 * np.sign(ang)
    mid = (a + b) / 2
    ax.annotate(d.text, tuple(mid), rotation=ang, rotation_mode="anchor", ha="center",
                va="bottom", fontsize=text_pt, color=col)  # fmt: skip
