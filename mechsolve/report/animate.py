"""The mechanism in motion: frames from a fine sweep, written as a GIF or MP4 (matplotlib)
or handed to the report's HTML player as plain numbers.

The frames come from their own sweep, 1 degree apart by default (a 360th of a linear
driver's travel, or of a sweep in time), whatever step the file tabulates, so that the
motion is smooth. Each frame draws the links to scale, the ground pivots and guides, the
paths of the output points traced so far (from that 1-degree sweep when fewer frames are
asked for, so that a path is not a polygon through the frames), the driver's value and
the time, and the file's point loads as labelled arrows (where they act); with
``forces`` also the reaction at each joint as a labelled arrow (the force on the joint's
second link by its first, the convention of the CSV). All arrows are on one scale, drawn
as a scale bar that reads two round numbers (1, 2 or 5 times a power of ten):
``5 m = 200 kN``.

The axes, the scale bar, the driver's value and the loads' sizes are in the units of the
file (an :class:`~mechsolve.base.units.OutputUnits`: a file in mm is drawn with its axes in
mm, ``50 mm = 20 N``); the coordinates stay metres inside, as the HTML player's numbers.
"""

from __future__ import annotations

import functools
import math
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mechsolve import api
from mechsolve.base.atomic import replacing
from mechsolve.base.errors import InputError
from mechsolve.base.units import SI_OUTPUT, OutputUnits
from mechsolve.writers.fonts import pyplot
from mechsolve.writers.plots import length_axes, length_text, round_125

if TYPE_CHECKING:
    from mechsolve.model import Mechanism
    from mechsolve.results.results import Results

PALETTE = [
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#17becf",
]
REACTION_COLOR = "#d62728"
LOAD_COLOR = "#1b3f8b"  # the applied loads: dark blue, apart from the red reactions
ARROW_SHARE = 0.25  # the longest arrow, as a share of the drawing's size
BAR_SHARE = 0.15  # the force scale bar, at most this share of the drawing's size
DEFAULT_FRAME_STEP = math.radians(1.0)
MAX_FRAMES = 20_000  # a longer animation is a mistake on the command line
FFMPEG_HINT = (
    "an MP4 needs ffmpeg on the PATH (Debian/Ubuntu: apt-get install ffmpeg; macOS: brew "
    "install ffmpeg; Windows: winget install ffmpeg); write a .gif instead, which needs "
    "nothing more"
)


@dataclass
class Outline:
    """What is drawn of one link in every frame: a closed polygon (its points' convex
    hull, or a small block for a slider), or a bar between two points."""

    name: str
    color: str
    x: np.ndarray  # (frames, corners)
    y: np.ndarray
    closed: bool


@dataclass
class Frames:
    """The mechanism at each frame of a fine sweep, in global coordinates (m)."""

    name: str
    driver: str
    u: np.ndarray  # driver value: deg (revolute) or m (linear)
    u_unit: str
    t: np.ndarray  # s
    timed: bool  # whether the times are meaningful (a driver at rest has none)
    outlines: list[Outline]
    points: dict[str, tuple[np.ndarray, np.ndarray]]  # every named point
    ground: list[str]  # fixed pivots (joints on the ground)
    joints: list[str]  # points that are joints between moving links
    paths: list[str]  # the output points whose paths are traced
    guides: list[tuple[float, float, float, float]]  # fixed slider guides: x0, y0, x1, y1
    ok: np.ndarray
    forces: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = field(
        default_factory=dict
    )  # joint -> (x, y, Fx, Fy) per frame
    force_scale: float = 0.0  # m of arrow per N: the bar's length over its force
    force_points: dict[str, str] = field(default_factory=dict)  # joint -> its point
    loads: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = field(
        default_factory=dict
    )  # point load -> (x, y, Fx, Fy) per frame, zero where it does not act
    load_points: dict[str, str] = field(default_factory=dict)  # load -> its point
    bar: float = 0.0  # the scale bar's length (m), 1, 2 or 5 times a power of ten (shown)
    units: OutputUnits = SI_OUTPUT  # what the axes and the texts are shown in
    # the paths drawn from a sweep finer than the frames (few frames): point -> (x, y),
    # and per frame how many of its samples the motion has passed by then
    traces: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    trace_upto: np.ndarray | None = None

    def path(self, p: str) -> tuple[np.ndarray, np.ndarray]:
        """The whole path of point ``p`` (m): from the fine sweep where the frames are
        fewer than its samples, else through the frames."""
        return self.traces.get(p, self.points[p])

    def trace(self, p: str, i: int) -> tuple[np.ndarray, np.ndarray]:
        """The path of ``p`` traced by frame ``i``: the fine sweep's samples passed by
        then, and the frame's own position at its end."""
        x, y = self.points[p]
        if p not in self.traces or self.trace_upto is None:
            return x[: i + 1], y[: i + 1]
        tx, ty = self.traces[p]
        k = int(self.trace_upto[i])
        return np.append(tx[:k], x[i]), np.append(ty[:k], y[i])

    @property
    def bar_text(self) -> str:
        """The scale bar's reading: ``1 m = 50 kN``, ``50 mm = 20 N``."""
        if not (self.force_scale > 0 and self.bar > 0):
            return ""
        return f"{self.length_text(self.bar)} = {self.force_text(self.bar / self.force_scale)}"

    def length_text(self, metres: float) -> str:
        """A length as the drawing reads it: in the shown length unit, or for metres as
        :func:`~mechsolve.writers.plots.length_text` (``2 m``, ``50 mm``)."""
        if self.units.length == "m":
            return length_text(metres)
        return self.units.text(metres, "m")

    def force_text(self, newtons: float) -> str:
        """A force in the shown force unit; in N, with the prefix engineers read
        (:func:`force_text`: ``69.09 kN``)."""
        if self.units.force == "N":
            return force_text(newtons)
        return self.units.text(newtons, "N", ".4g")

    def arrows(self) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """Every force arrow: the reactions, then the loads."""
        return {**self.forces, **self.loads}

    def __len__(self) -> int:
        return len(self.u)

    def names(self) -> list[str]:
        """Every name a frame shows (for the font check of :mod:`.writers.fonts`)."""
        return [
            self.name,
            *(o.name for o in self.outlines),
            *self.points,
            *self.forces,
            *self.loads,
        ]

    def bounds(self, margin: float = 0.08) -> tuple[float, float, float, float]:
        """xmin, xmax, ymin, ymax over every frame (and the force arrows), with a margin."""
        xs = [o.x for o in self.outlines] + [p[0] for p in self.points.values()]
        ys = [o.y for o in self.outlines] + [p[1] for p in self.points.values()]
        for x, y, fx, fy in self.arrows().values():
            xs.append(x + fx * self.force_scale)
            ys.append(y + fy * self.force_scale)
        for g in self.guides:
            xs.append(np.array(g[0::2]))
            ys.append(np.array(g[1::2]))
        x = np.concatenate([np.ravel(a) for a in xs])
        y = np.concatenate([np.ravel(a) for a in ys])
        x, y = x[np.isfinite(x)], y[np.isfinite(y)]
        if not x.size:
            return (-1.0, 1.0, -1.0, 1.0)
        x0, x1, y0, y1 = float(x.min()), float(x.max()), float(y.min()), float(y.max())
        pad = margin * max(x1 - x0, y1 - y0, 1e-9)
        return (x0 - pad, x1 + pad, y0 - pad, y1 + pad)

    def label(self, i: int) -> str:
        """``driver O1 = 120°, t = 18.87 s`` for frame ``i``."""
        u, U = float(self.u[i]), self.units
        fmt = (".1f" if U.angle == "deg" else ".4g") if self.u_unit == "deg" else ".4g"
        text = f"driver {self.driver} = {U.text(u, self.u_unit, fmt)}"
        if self.timed:
            text += f", t = {U.text(float(self.t[i]), 's', self.time_format)}"
        return text

    @functools.cached_property
    def time_format(self) -> str:
        """The format of the frames' times in the shown unit: three decimals, or as many
        as tell two frames apart (``.4f`` s at 1500 rpm, 0.11 ms a frame)."""
        k = self.units.convert("s")[0]
        dt = np.diff(np.asarray(self.t, float)) * k
        dt = dt[np.isfinite(dt) & (dt > 0)]
        if not dt.size:
            return ".3f"
        places = math.ceil(-math.log10(float(dt.min())) - 1e-9)  # its last place <= a step
        return f".{max(3, places)}f"

    def to_json(self, digits: int = 5) -> dict[str, Any]:
        """The frames as plain lists for the report's player (coordinates rounded to
        ``digits`` significant figures of the drawing's size; NaN as null)."""
        x0, x1, y0, y1 = self.bounds()
        q = 10.0 ** (digits - math.ceil(math.log10(max(x1 - x0, y1 - y0, 1e-12))))

        def arr(a: np.ndarray, scale: float = q) -> list:
            a = np.asarray(a, float)
            return [None if not math.isfinite(v) else round(v * scale) / scale for v in a.flat]

        out: dict[str, Any] = {
            "name": self.name,
            "labels": [self.label(i) for i in range(len(self))],
            "bounds": [x0, x1, y0, y1],
            "outlines": [
                {
                    "name": o.name,
                    "color": o.color,
                    "closed": o.closed,
                    "corners": o.x.shape[1],
                    "x": arr(o.x),
                    "y": arr(o.y),
                }
                for o in self.outlines
            ],
            "points": {p: [arr(x), arr(y)] for p, (x, y) in self.points.items()},
            "ground": self.ground,
            "joints": self.joints,
            "paths": self.paths,
            "guides": [list(g) for g in self.guides],
        }
        if self.traces and self.trace_upto is not None:  # the paths from a finer sweep
            out["traces"] = {p: [arr(x), arr(y)] for p, (x, y) in self.traces.items()}
            out["trace_upto"] = [int(k) for k in self.trace_upto]
        if self.forces:
            out["forces"] = {
                j: {
                    "at": self.force_points[j],
                    "fx": arr(fx * self.force_scale),
                    "fy": arr(fy * self.force_scale),
                }
                for j, (x, y, fx, fy) in self.forces.items()
            }
        if self.loads:
            out["loads"] = {
                name: {
                    "at": self.load_points[name],
                    "fx": arr(fx * self.force_scale),
                    "fy": arr(fy * self.force_scale),
                    "text": f"{name} {self.force_text(float(np.nanmax(np.hypot(fx, fy))))}",
                }
                for name, (x, y, fx, fy) in self.loads.items()
            }
        if self.forces or self.loads:
            out["bar"] = {"length": self.bar, "text": self.bar_text}
        return out


def _hull(pts: np.ndarray) -> list[int]:
    """Indices of the convex hull of ``pts`` (counter-clockwise), or of the two farthest
    points when they are collinear."""
    n = len(pts)
    if n <= 2:
        return list(range(n))
    order = sorted(range(n), key=lambda k: (round(pts[k][0], 12), round(pts[k][1], 12)))

    def cross(o, a, b):
        return (pts[a][0] - pts[o][0]) * (pts[b][1] - pts[o][1]) - (pts[a][1] - pts[o][1]) * (
            pts[b][0] - pts[o][0]
        )

    lower: list[int] = []
    for k in order:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], k) <= 1e-15:
            lower.pop()
        lower.append(k)
    upper: list[int] = []
    for k in reversed(order):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], k) <= 1e-15:
            upper.pop()
        upper.append(k)
    hull = lower[:-1] + upper[:-1]
    if len(hull) < 3:  # collinear: the two ends
        return [order[0], order[-1]]
    return hull


def force_text(f: float) -> str:
    """``69.09 kN``, ``3.2 N``: a force with the prefix engineers read."""
    for scale, unit in ((1e6, "MN"), (1e3, "kN")):
        if abs(f) >= scale:
            return f"{f / scale:.4g} {unit}"
    return f"{f:.4g} N"


def check_frame_count(count: int | None) -> None:
    """Refuse a number of frames outside 2 .. :data:`MAX_FRAMES` (None: the default).

    ``animate`` and ``report`` call it before loading or solving anything, so that a slip
    on the command line costs nothing; :func:`fine_step` calls it too."""
    if count is not None and count < 2:
        raise InputError(f"--frames {count}: an animation needs at least 2 frames")
    if count is not None and count > MAX_FRAMES:
        raise InputError(f"--frames {count}: at most {MAX_FRAMES} frames")


def fine_step(mech: Mechanism, count: int | None) -> tuple[float | None, int | None]:
    """The sweep step that gives ``count`` frames over the file's range (or 1 degree, a
    360th of a linear travel or of a sweep in time when ``count`` is None), and the count
    it gives. (None, None) when the file's own positions must be used (a motion law
    without a duration)."""

    check_frame_count(count)
    sw = mech.sweep
    if mech.driver.motion is not None:
        if sw.duration is None:
            return None, None
        n = count or 361
        return sw.duration / (n - 1), n
    linear = mech.joint(mech.driver.joint).coordinate == "length"
    travel = sw.travel if sw.travel is not None else 2 * math.pi
    if linear:
        n = count or 361
    else:
        n = count or max(2, round(travel / DEFAULT_FRAME_STEP) + 1)
    if n > MAX_FRAMES:
        n = MAX_FRAMES
    return travel / (n - 1), n


def frames_of(res: Results, forces: bool = False, units: OutputUnits | None = None) -> Frames:
    """The drawing of every position of ``res``, shown in ``units`` (default SI)."""
    an = res.analysis
    mech = res.mechanism
    st = res.solution.state
    sys_ = an.system
    n = len(res.u)
    outlines = []
    for k, lk in enumerate(mech.links):
        b = sys_.index[lk.name]
        locs = np.array([lk.points[p] for p in lk.points], float)
        col = PALETTE[k % len(PALETTE)]
        if len(locs) == 1:  # a slider block: a small square turning with the block
            size = 0.03 * an.scale
            sq = np.array([[-1, -0.6], [1, -0.6], [1, 0.6], [-1, 0.6]]) * size + locs[0]
            xs, ys = [], []
            for c in sq:
                x, y = st.point(b, c)
                xs.append(np.broadcast_to(x, (n,)))
                ys.append(np.broadcast_to(y, (n,)))
            outlines.append(Outline(lk.name, col, np.stack(xs, 1), np.stack(ys, 1), True))
            continue
        idx = _hull(locs)
        xs, ys = [], []
        for i in idx:
            x, y = st.point(b, locs[i])
            xs.append(np.broadcast_to(x, (n,)))
            ys.append(np.broadcast_to(y, (n,)))
        outlines.append(
            Outline(lk.name, col, np.stack(xs, 1), np.stack(ys, 1), closed=len(idx) >= 3)
        )
    points = {}
    for p, ref in an.points.items():
        x, y = st.point(ref.body, ref.local)
        points[p] = (np.array(np.broadcast_to(x, (n,)), float), np.array(np.broadcast_to(y, (n,))))
    joint_pts = {j.point for j in mech.joints}
    ground = [p for p in points if an.points[p].body == sys_.nb and p in joint_pts]
    joints = [p for p in points if an.points[p].body != sys_.nb and p in joint_pts]
    guides = []  # what the joints draw beyond the links: fixed guide lines
    for c in sys_.constraints:
        seg = c.guide(st, an.scale)
        if seg is not None:
            guides.append(tuple(float(v) for v in seg.ravel()))
    u = res.u if res.linear else np.degrees(res.u)
    timed = bool(np.any(np.asarray(res.t) != 0)) and bool(np.all(np.isfinite(res.t)))
    fr = Frames(
        name=mech.name,
        driver=mech.driver.joint,
        u=np.asarray(u, float),
        u_unit="m" if res.linear else "deg",
        t=np.asarray(res.t, float),
        timed=timed,
        outlines=outlines,
        points=points,
        ground=ground,
        joints=joints,
        paths=[p for p in res.point_names() if p in points],
        guides=guides,
        ok=np.asarray(res.ok, bool),
        units=units or SI_OUTPUT,
    )
    if forces and res.forces is None:
        raise InputError(
            f"--forces: {mech.name} has no masses or loads, so no joint forces to draw"
        )
    if res.forces is not None:
        _add_forces(fr, res, points, reactions=forces)
    return fr


def _add_forces(fr: Frames, res: Results, points: dict, reactions: bool) -> None:
    """The point loads (where each acts) and, with ``reactions``, the joints' reactions as
    arrows of ``fr``, and one round scale for all of them (:func:`arrow_scale`)."""
    from mechsolve.model import PointForce

    ok = res.forces.ok
    if reactions:
        for j in res.mechanism.joints:
            r = res.reaction(j.name)
            x, y = points[j.point]
            fr.forces[j.name] = (x, y, np.where(ok, r["Fx"], np.nan), np.where(ok, r["Fy"], np.nan))
            fr.force_points[j.name] = j.point
    st, sys_ = res.solution.state, res.analysis.system
    for load in res.mechanism.loads:
        if not isinstance(load, PointForce) or load.point not in points:
            continue
        on = res.forces.active.get(load.name)
        f = np.ones(len(fr)) if on is None else np.asarray(on, float)
        fx, fy = (np.full(len(fr), float(v)) for v in load.force)
        if load.frame == "link":
            fx, fy = st.rotated(sys_.index[load.link], np.array(load.force, float))
        x, y = points[load.point]
        fr.loads[load.name] = (x, y, np.where(ok, fx * f, np.nan), np.where(ok, fy * f, np.nan))
        fr.load_points[load.name] = load.point
    big = 0.0
    for _, _, fx, fy in fr.arrows().values():
        mag = np.hypot(fx, fy)
        if np.any(np.isfinite(mag)):
            big = max(big, float(np.nanmax(mag)))
    x0, x1, y0, y1 = fr.bounds(0.0)
    # round numbers in the shown length and force units (1 in = 200 lbf, not 224.8)
    k = fr.units.convert("m")[0]
    kf = fr.units.convert("N")[0]
    per, bar = arrow_scale(big * kf, k * max(x1 - x0, y1 - y0))
    fr.force_scale, fr.bar = per * kf / k, bar / k


def arrow_scale(big: float, size: float) -> tuple[float, float]:
    """The scale of force arrows on a drawing ``size`` m across whose largest force is
    ``big`` N: (m of arrow per N, the scale bar's length in m). The bar is a 1-2-5 length
    between a twentieth of ``size`` and :data:`BAR_SHARE` of it, and the force it stands
    for a 1-2-5 force, so that the bar reads two round numbers (``5 m = 200 kN``); of
    these the pair that draws ``big`` longest, at most :data:`ARROW_SHARE` of ``size``.
    (0, 0) when there is no force to draw."""
    if not (big > 0 and size > 0 and math.isfinite(big) and math.isfinite(size)):
        return 0.0, 0.0
    best = (0.0, 0.0, 0.0)  # (longest arrow, m per N, bar)
    bar = round_125(BAR_SHARE * size, up=False)
    while bar >= size / 20 * (1 - 1e-9):
        force = round_125(big * bar / (ARROW_SHARE * size))
        if big * bar / force > best[0] * (1 + 1e-9):
            best = (big * bar / force, bar / force, bar)
        bar = round_125(bar * 0.99, up=False)
    return best[1], best[2]


def solve_frames(
    mech: Mechanism,
    count: int | None = None,
    forces: bool = False,
    method: str | None = None,
    units: OutputUnits | None = None,
) -> Frames:
    """Solve the fine sweep of ``mech`` for an animation of ``count`` frames (see
    :func:`fine_step`) and draw it, shown in ``units`` (default SI)."""

    if forces and not mech.needs_forces:
        raise InputError(
            f"--forces: {mech.name} has no masses or loads, so no joint forces to draw"
        )
    step, _ = fine_step(mech, count)
    fine, _ = fine_step(mech, None)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        res = api.solve(
            mech,
            step=step,
            method=method,
            velocity=False,
            acceleration=False,
            forces=forces or _has_point_loads(mech),
        )
        fr = frames_of(res, forces, units)
        if step is not None and fine is not None and step > fine * (1 + 1e-9):
            # fewer frames than the default's: the paths from the default's sweep
            path = api.solve(
                mech, step=fine, method=method, velocity=False, acceleration=False, forces=False
            )
            add_traces(fr, res, path)
        return fr


def add_traces(fr: Frames, res: Results, path: Results) -> None:
    """Draw ``fr``'s paths (the frames of ``res``) from the finer sweep ``path`` of the
    same motion: each point's positions there, and per frame the samples passed before
    it (in time for a motion law, else along the driver's travel)."""
    timed = res.mechanism.driver.motion is not None

    def along(r: Results) -> np.ndarray:
        return np.asarray(r.t if timed else np.abs(r.u - r.u[0]), float)

    a, b = along(path), along(res)
    tol = 1e-9 * max(float(np.max(np.abs(a))), 1e-30)
    fr.trace_upto = np.searchsorted(a, b - tol, side="right")  # before the frame's own
    st = path.solution.state
    ok = np.asarray(path.ok, bool)
    n = len(path.u)
    for p in fr.paths:
        ref = path.analysis.points[p]
        x, y = st.point(ref.body, ref.local)
        fr.traces[p] = (
            np.where(ok, np.broadcast_to(x, (n,)), np.nan),
            np.where(ok, np.broadcast_to(y, (n,)), np.nan),
        )


def _has_point_loads(mech: Mechanism) -> bool:
    from mechsolve.model import PointForce

    return any(isinstance(ld, PointForce) for ld in mech.loads)


def ffmpeg_available() -> bool:
    """Whether matplotlib can write MP4 (ffmpeg on the PATH, or where matplotlib's
    ``animation.ffmpeg_path`` points)."""
    import matplotlib

    path = matplotlib.rcParams["animation.ffmpeg_path"]
    return shutil.which(path) is not None


def render(fr: Frames, size: tuple[int, int] = (800, 600), dpi: int = 100):
    """Yield each frame as an RGB image (an array of shape (height, width, 3), uint8).

    The axes, grid, guides, pivots and faint full paths are drawn once; each frame
    redraws only what moves (blitting), which keeps a 361-frame animation to seconds."""

    plt = pyplot(fr.names())
    fig = plt.figure(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi)
    try:
        yield from _render(fr, fig)
    finally:
        plt.close(fig)


def _render(fr: Frames, fig):
    ax = fig.add_axes((0.1, 0.09, 0.86, 0.83))
    x0, x1, y0, y1 = fr.bounds()
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal", adjustable="box")
    unit = length_axes(ax, fr.units)  # the ticks in the shown unit, the artists in m
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    ax.grid(True, alpha=0.3)
    ax.set_title(fr.name)
    for g in fr.guides:
        ax.plot(g[0::2], g[1::2], "--", color="0.4", lw=1)
    for p in fr.ground:
        x, y = fr.points[p]
        ax.plot(x[:1], y[:1], marker="^", ms=11, color="0.3", zorder=3)
    for k, p in enumerate(fr.paths):
        x, y = fr.path(p)
        ax.plot(x, y, "-", lw=0.6, color=f"C{k % 10}", alpha=0.3)  # the whole path, faint
    if fr.force_scale > 0:
        _scale_bar(ax, fr)
    moving = []

    def add(artist):
        artist.set_animated(True)
        moving.append(artist)
        return artist

    polys = []
    for o in fr.outlines:
        fill = (
            add(ax.fill(o.x[0], o.y[0], color=o.color, alpha=0.25, lw=0)[0]) if o.closed else None
        )
        line = add(ax.plot(o.x[0], o.y[0], color=o.color, lw=2.5, solid_capstyle="round")[0])
        lab = add(ax.text(0, 0, o.name, fontsize=7, color=o.color, ha="center", va="center"))
        polys.append((o, fill, line, lab))
    traces = {}
    for k, p in enumerate(fr.paths):
        traces[p] = add(ax.plot([], [], "-", lw=1.5, color=f"C{k % 10}", label=f"path of {p}")[0])
    if traces:
        ax.legend(handles=list(traces.values()), fontsize=7, loc="upper right")
    shown = [p for p in fr.points if p in set(fr.ground) | set(fr.joints) | set(fr.paths)]
    pins = add(ax.plot([], [], "o", ms=5, mfc="white", mec="k", zorder=4)[0])
    names = {p: add(ax.text(0, 0, p, fontsize=8, zorder=5)) for p in shown}
    arrows = {}
    for j, text in arrow_labels(fr).items():
        col = LOAD_COLOR if j in fr.loads else REACTION_COLOR
        arrow = ax.annotate(
            "",
            xy=(0, 0),
            xytext=(0, 0),
            arrowprops={"arrowstyle": "->", "color": col, "lw": 1.5},
            zorder=6,
        )
        tag = ax.text(0, 0, text, fontsize=7, color=col, ha="center", va="center", zorder=7)
        arrows[j] = (add(arrow), add(tag))
    info = add(ax.text(0.01, 0.99, "", transform=ax.transAxes, va="top", fontsize=9))
    canvas = fig.canvas
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    span = x1 - x0
    for i in range(len(fr)):
        for o, fill, line, lab in polys:
            xs, ys = o.x[i], o.y[i]
            good = bool(np.all(np.isfinite(xs)) and np.all(np.isfinite(ys)))
            if o.closed:
                xs, ys = np.append(xs, xs[0]), np.append(ys, ys[0])
                if good:
                    fill.set_xy(np.column_stack([xs, ys]))
                fill.set_visible(good)
            line.set_data(xs, ys)
            line.set_visible(good)
            lab.set_visible(good)
            if good:
                lab.set_position((float(np.mean(o.x[i])), float(np.mean(o.y[i]))))
        for p, tr in traces.items():
            tr.set_data(*fr.trace(p, i))
        pins.set_data(
            [fr.points[p][0][i] for p in fr.joints + fr.ground],
            [fr.points[p][1][i] for p in fr.joints + fr.ground],
        )
        for p, t in names.items():
            x, y = fr.points[p][0][i], fr.points[p][1][i]
            good = math.isfinite(x) and math.isfinite(y)
            t.set_visible(good)
            if good:
                t.set_position((x + 0.008 * span, y + 0.008 * span))
        all_arrows = fr.arrows()
        for j, (a, tag) in arrows.items():
            x, y, fx, fy = (float(v[i]) for v in all_arrows[j])
            good = all(math.isfinite(v) for v in (x, y, fx, fy)) and (fx, fy) != (0.0, 0.0)
            a.set_visible(good)
            tag.set_visible(good)
            if good:
                hx, hy = x + fx * fr.force_scale, y + fy * fr.force_scale
                a.xy = (hx, hy)
                a.set_position((x, y))
                k = 0.025 * span / max(math.hypot(hx - x, hy - y), 1e-12)
                tag.set_position((hx + k * (hx - x), hy + k * (hy - y)))  # beyond the head
        info.set_text(fr.label(i) + ("" if fr.ok[i] else "  (cannot close here)"))
        canvas.restore_region(background)
        for a in moving:
            ax.draw_artist(a)
        canvas.blit(fig.bbox)
        yield np.array(canvas.buffer_rgba())[:, :, :3]


def arrow_labels(fr: Frames) -> dict[str, str]:
    """The text beside each arrow's head: ``R O3`` for the reaction at joint O3, the
    load's name and size (``Q 50 kN``) for a load."""
    out = {j: f"R {j}" for j in fr.forces}
    for name, (_, _, fx, fy) in fr.loads.items():
        mag = np.hypot(fx, fy)
        size = float(np.nanmax(mag)) if np.any(np.isfinite(mag)) else 0.0
        out[name] = f"{name} {fr.force_text(size)}"
    return out


def _scale_bar(ax, fr: Frames) -> None:
    """The force scale in the drawing's lower left corner: a bar ``fr.bar`` m long with
    end ticks, reading ``1 m = 50 kN`` (in the shown units), and what the colours are."""
    x0, x1, y0, y1 = ax.get_xlim() + ax.get_ylim()
    span = max(x1 - x0, y1 - y0)
    bx, by = x0 + 0.03 * (x1 - x0), y0 + 0.05 * (y1 - y0)
    tick = 0.008 * span
    ax.plot([bx, bx + fr.bar], [by, by], "-", color="k", lw=2)
    for x in (bx, bx + fr.bar):
        ax.plot([x, x], [by - tick, by + tick], "-", color="k", lw=1.2)
    ax.text(bx, by + 2 * tick, fr.bar_text, fontsize=8, va="bottom")
    what = []
    if fr.forces:
        what.append("red: joint reactions (on the second link by the first)")
    if fr.loads:
        what.append("blue: loads")
    ax.text(0.01, 0.005, "; ".join(what), transform=ax.transAxes, fontsize=7, va="bottom")


def write_animation(
    fr: Frames,
    path: Path,
    fps: float = 30.0,
    size: tuple[int, int] = (800, 600),
    dpi: int = 100,
) -> Path:
    """Write the frames as an animated GIF (Pillow) or an MP4 (H.264 through ffmpeg),
    chosen by the suffix of ``path``, looping once per sweep; the file appears only when
    complete."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise InputError(f"-o {path}: the animation is written as .gif or .mp4")
    if not (fps > 0 and math.isfinite(fps)):
        raise InputError(f"--fps {fps}: the frame rate must be a positive number")
    if suffix == ".mp4" and not ffmpeg_available():
        raise InputError(f"-o {path}: {FFMPEG_HINT}")
    with replacing(path, suffix) as tmp:  # Pillow and ffmpeg go by the suffix
        if suffix == ".gif":
            _write_gif(render(fr, size, dpi), tmp, fps)
        else:
            _write_mp4(render(fr, size, dpi), tmp, fps, size)
    return path


def _write_gif(images, path: str, fps: float) -> None:
    from PIL import Image

    # one palette for all frames (from the first and the last, where every traced path
    # is complete): quantizing to a given palette is several times faster than choosing
    # one per frame, and the colours do not flicker
    rgb = list(images)
    both = np.concatenate([rgb[0], rgb[-1]], axis=0)
    pal = Image.fromarray(both).quantize(colors=255, method=Image.Quantize.MEDIANCUT)
    frames = [Image.fromarray(a).quantize(palette=pal, dither=Image.Dither.NONE) for a in rgb]
    frames[0].save(
        path,
        format="GIF",
        save_all=True,
        append_images=frames[1:],
        duration=max(20, round(1000 / fps)),  # ms; browsers treat less than 20 as 100
        loop=0,
        disposal=1,
    )


def _write_mp4(images, path: str, fps: float, size: tuple[int, int]) -> None:
    import subprocess

    import matplotlib

    exe = shutil.which(matplotlib.rcParams["animation.ffmpeg_path"])
    proc = None
    try:
        for a in images:
            if proc is None:
                h, w = a.shape[:2]
                proc = subprocess.Popen(
                    [exe, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24",
                     "-s", f"{w}x{h}", "-r", f"{fps:g}", "-i", "-", "-an", "-c:v", "libx264",
                     "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2",
                     "-f", "mp4", path],
                    stdin=subprocess.PIPE,
                    stderr=subprocess.PIPE,
                )  # fmt: skip
            proc.stdin.write(np.ascontiguousarray(a).tobytes())
    finally:
        if proc is not None:
            proc.stdin.close()
            err = proc.stderr.read().decode(errors="replace")
            if proc.wait() != 0:
                raise InputError(f"ffmpeg could not write {path}: {err.strip()}")


__all__ = [
    "FFMPEG_HINT",
    "Frames",
    "ffmpeg_available",
    "fine_step",
    "check_frame_count",
    "frames_of",
    "render",
    "solve_frames",
    "write_animation",
]
