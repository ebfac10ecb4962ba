"""Plots an engineer expects from a kinematic sweep (matplotlib, PNG by default).

* ``trajectories.png``: the mechanism drawn at the start position with the paths of the
  output points;
* ``point_<P>.png``: x and y position, velocity and acceleration of each output point
  against the driver coordinate;
* ``links.png``: angle, angular velocity and angular acceleration of the output links;
* ``sliders.png``: displacement, velocity and acceleration of the output sliders;
* with force analysis: ``torque.png`` (the driving torque with its mean and the work per
  cycle), ``reactions.png`` (magnitudes of all joint reactions) and ``hodographs.png``
  (vector-tip diagrams of the reactions at the fixed hinges).

Every axis names its quantity and unit, in the units asked for (an
:class:`~mechsolve.base.units.OutputUnits`: SI by default, the command line gives the
file's), written as a report prints them (``mm/s²``, ``kN·m``, ``°``). The results stay
SI; the values are converted here, where they are drawn. matplotlib is imported only here.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.atomic import replacing
from mechsolve.base.units import SI_OUTPUT, OutputUnits, pretty_text, pretty_unit

if TYPE_CHECKING:
    from mechsolve.results.results import Results


def pretty_figure(fig) -> None:
    """Write every text of ``fig`` as a report prints it (see
    :func:`~mechsolve.base.units.pretty_text`): ``[kg·m²]``, ``N·m``, ``ωₘₐₓ²``."""
    from matplotlib.text import Text

    if not hasattr(fig, "findobj"):  # not a matplotlib figure: nothing to write
        return
    for t in fig.findobj(Text):
        s = t.get_text()
        if s and isinstance(s, str):
            new = pretty_text(s)
            if new != s:
                t.set_text(new)


def save_figure(fig, path: Path, dpi: int) -> None:
    """Save ``fig`` so that an interrupted run never leaves a half-written image; the
    labels of drawn mechanisms are placed first (:func:`place_labels`), now that the
    figure's layout is final, and its texts take report units (:func:`pretty_figure`)."""
    path = Path(path)
    place_labels(fig)
    pretty_figure(fig)
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".").lower() or "png")


def round_125(x: float, up: bool = True) -> float:
    """The nearest number of the 1-2-5 series (1, 2 or 5 times a power of ten) at or
    above ``x`` (``up``) or at or below it: the values a scale bar reads (1 cm = 50 kN)."""
    if not (x > 0 and math.isfinite(x)):
        return 1.0
    k = math.floor(math.log10(x))
    series = [b * 10.0**e for e in (k - 1, k, k + 1) for b in (1.0, 2.0, 5.0)]
    if up:
        value = min(v for v in series if v >= x * (1 - 1e-12))
    else:
        value = max(v for v in series if v <= x * (1 + 1e-12))
    return float(f"{value:.12g}")


def length_text(metres: float) -> str:
    """``2 m``, ``50 mm``: a scale bar's length as a drawing reads it."""
    if metres >= 1:
        return f"{metres:g} m"
    return f"{metres * 1000:.6g} mm"


def _plt():
    from mechsolve.writers.fonts import pyplot

    return pyplot()


def names_of(mech) -> list[str]:
    """Every name a plot of ``mech`` may show (for the font check of :mod:`.fonts`)."""
    out = [mech.name, *(lk.name for lk in mech.links), *(j.name for j in mech.joints)]
    out += [ld.name for ld in mech.loads]
    for lk in mech.links:
        out += list(lk.points)
    return out


def shown(U: OutputUnits, values, unit: str) -> tuple[np.ndarray, str]:
    """``values`` (SI, in ``unit``) in the shown units, and that unit as a label prints it."""
    k, target = U.convert(unit)
    return np.asarray(values, float) * k, pretty_unit(target)


def driver_axis(res: Results, U: OutputUnits = SI_OUTPUT) -> tuple[np.ndarray, str]:
    """The x axis of the curves: it follows the motion. Time for a driver with a motion
    law; else the driver's travel from the start (so that a clockwise crank's curves run
    left to right, as time does), labelled with the start."""
    name = res.mechanism.driver.joint
    if res.mechanism.driver.motion is not None:
        t, unit = shown(U, res.t, "s")
        return t, f"time [{unit}]"
    start = float(res.u[0]) if len(res.u) else 0.0
    if res.linear:
        if res.mechanism.driver.direction > 0:
            x, unit = shown(U, res.u, "m")
            return x, f"driver position ({name}) [{unit}]"
        x, unit = shown(U, res.driver_travel, "m")
        return x, f"driver travel ({name}) from {U.text(start, 'm')} [{unit}]"
    if res.mechanism.driver.direction > 0 and 0 <= start < 2 * np.pi:
        x, unit = shown(U, np.degrees(res.u), "deg")
        return x, f"driver angle ({name}) [{unit}]"
    sense = "clockwise" if res.mechanism.driver.direction < 0 else "counter-clockwise"
    x, unit = shown(U, res.driver_travel, "deg")
    return (
        x,
        f"driver angle ({name}) travelled {sense} from "
        f"{U.text(np.degrees(start) % 360, 'deg')} [{unit}]",
    )


def length_axes(ax, U: OutputUnits) -> str:
    """Label an axes' ticks in the shown length unit while its artists stay in metres
    (round numbers in that unit); return the unit as a label prints it."""
    k, target = U.convert("m")
    if k != 1.0:
        from matplotlib.ticker import FuncFormatter, MaxNLocator

        class _Scaled(MaxNLocator):
            def tick_values(self, vmin, vmax):
                return super().tick_values(vmin * k, vmax * k) / k

        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_locator(_Scaled(nbins="auto", steps=[1, 2, 2.5, 5, 10]))
            axis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v * k:.6g}"))
    return pretty_unit(target)


def draw_mechanism(
    ax, res_or_analysis, state, i: int, color: str = "k", labels: bool = True
) -> None:
    """Draw links, joints, ground pivots and slider guides at position ``i``. The names
    (``labels``) are placed when the figure is saved through :func:`save_figure`, or by
    :func:`place_labels` (call it after the layout, before ``savefig``)."""
    an = getattr(res_or_analysis, "analysis", res_or_analysis)
    mech = an.mech
    sys_ = an.system
    joint_pts = set()
    for j in mech.joints:
        joint_pts.add(j.point)
    palette = [
        "#1f77b4",
        "#ff7f0e",
        "#2ca02c",
        "#d62728",
        "#9467bd",
        "#8c564b",
        "#e377c2",
        "#17becf",
    ]
    for k, lk in enumerate(mech.links):
        b = sys_.index[lk.name]
        xy = []
        for loc in lk.points.values():
            x, y = state.point(b, np.asarray(loc, float), [i])
            xy.append((float(x[0]), float(y[0])))
        pts = np.array(xy)
        if not np.all(np.isfinite(pts)):
            continue
        col = palette[k % len(palette)]
        if len(pts) == 1:
            # a slider block: a small square along its guide
            size = 0.03 * an.scale
            th = float(state.th[b, i])
            c, s = math.cos(th), math.sin(th)
            sq = np.array([[-1, -0.6], [1, -0.6], [1, 0.6], [-1, 0.6], [-1, -0.6]]) * size
            rot = sq @ np.array([[c, s], [-s, c]])
            ax.fill(rot[:, 0] + pts[0, 0], rot[:, 1] + pts[0, 1], color=col, alpha=0.5, lw=1)
            continue
        hull = _hull(pts)
        if len(hull) >= 3:
            ax.fill(hull[:, 0], hull[:, 1], color=col, alpha=0.18, lw=0)
            closed = np.vstack([hull, hull[:1]])
            ax.plot(closed[:, 0], closed[:, 1], color=col, lw=2)
        else:
            ax.plot(hull[:, 0], hull[:, 1], color=col, lw=2.5, solid_capstyle="round")
        if labels:
            cx, cy = pts.mean(axis=0)
            _label(ax, lk.name, cx, cy, fontsize=7, color=col, pin=False)
    _draw_joint_extras(ax, an, state, i)
    # joints and ground pivots
    for p, ref in an.points.items():
        x, y = state.point(ref.body, ref.local, [i])
        x, y = float(x[0]), float(y[0])
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        if ref.body == sys_.nb:
            if p in joint_pts:
                ax.plot([x], [y], marker="^", ms=11, color="0.3", zorder=3)
                ax.plot([x], [y], "o", ms=5, mfc="white", mec="k", zorder=4)
        elif p in joint_pts:
            ax.plot([x], [y], "o", ms=5, mfc="white", mec="k", zorder=4)
        else:
            ax.plot([x], [y], ".", ms=5, color=color, zorder=4)
        if labels:
            _label(ax, p, x, y, fontsize=8, color="k", pin=True)


def _draw_joint_extras(ax, an, state, i: int) -> None:
    """What the joints draw beyond the links at position ``i``: the guides of sliders on
    the ground, what moves with the links (pitch circles...), the curves fixed in a body
    (a cam's profile, its roller)."""
    for c in an.system.constraints:
        seg = c.guide(state, an.scale)
        if seg is not None:
            ax.plot(seg[:, 0], seg[:, 1], "--", color="0.4", lw=1)
        for line in c.drawing(state, i):
            ax.plot(line[:, 0], line[:, 1], "-.", color="0.35", lw=0.9)
        for b, loc in c.outlines():
            if not math.isfinite(float(state.th[b, i])):
                continue
            ct, st_ = math.cos(float(state.th[b, i])), math.sin(float(state.th[b, i]))
            ox, oy = float(state.x[b, i]), float(state.y[b, i])
            ax.plot(ox + ct * loc[:, 0] - st_ * loc[:, 1], oy + st_ * loc[:, 0] + ct * loc[:, 1],
                    "-", color="0.2", lw=1.2)  # fmt: skip


def _label(ax, text: str, x: float, y: float, *, fontsize: float, color: str, pin: bool) -> None:
    """Ask for ``text`` beside (x, y): placed when the figure is saved (:func:`place_labels`),
    when the axes' scale is known. ``pin``: a point's name (placed first; its marker is
    kept clear of every label)."""
    pending = ax.__dict__.setdefault("_mechsolve_labels", [])
    pending.append((text, float(x), float(y), fontsize, color, pin))


# where a label may go around its point: directions (unit steps) tried in this order, at
# growing distances (pixels at the figure's dpi); beyond the first ring a leader line
# joins the label to its point
_DIRECTIONS = [(1, 1), (-1, 1), (1, -1), (-1, -1), (1, 0), (-1, 0), (0, 1), (0, -1)]
_RINGS = (4.0, 10.0, 18.0, 28.0, 42.0)
_PIN = 5.0  # half the size (pixels) of the box kept clear around a pin's marker


def place_labels(fig) -> None:
    """Place the names asked for by :func:`draw_mechanism` so that no two overlap and none
    covers a pin: each in turn (the points' names first, then the links') takes the first
    free spot around its point (greedy, against the boxes of the labels already placed),
    nearest first; a label pushed beyond the first ring gets a thin leader line to its
    point. A label with no free spot takes the one it overlaps least."""
    from matplotlib.transforms import Bbox

    pending = [(ax, ax.__dict__.pop("_mechsolve_labels", [])) for ax in getattr(fig, "axes", ())]
    if not any(items for _, items in pending):
        return
    renderer = fig.canvas.get_renderer()
    scale = fig.dpi / 72.0  # pixels per point
    for ax, items in pending:
        items = sorted(items, key=lambda it: not it[5])  # points' names first
        at = [ax.transData.transform((x, y)) for _, x, y, *_ in items]
        taken = [
            Bbox.from_bounds(px - _PIN, py - _PIN, 2 * _PIN, 2 * _PIN)
            for (px, py), it in zip(at, items)
            if it[5] and np.all(np.isfinite((px, py)))
        ]
        frame = ax.get_window_extent(renderer)
        for (text, x, y, size, color, pin), (px, py) in zip(items, at):
            if not np.all(np.isfinite((px, py))):
                continue
            probe = ax.text(0, 0, text, fontsize=size)
            w, h = probe.get_window_extent(renderer).size
            probe.remove()
            best, least = None, math.inf
            rings = _RINGS if pin else (0.0, *_RINGS)
            for r in rings:
                for dx, dy in _DIRECTIONS if r else [(0, 0)]:
                    # the box's corner nearest the point sits r pixels out along (dx, dy)
                    n = math.hypot(dx, dy) or 1.0
                    cx = px + r * dx / n + (dx * w / 2 if dx else 0)
                    cy = py + r * dy / n + (dy * h / 2 if dy else 0)
                    if pin and not dx:
                        cy += dy * _PIN
                    if pin and not dy:
                        cx += dx * _PIN
                    box = Bbox.from_bounds(cx - w / 2, cy - h / 2, w, h)
                    cost = sum(_overlap(box, t) for t in taken)
                    cost += w * h - _overlap(box, frame)  # outside the axes
                    if cost < least:
                        best, least = (cx, cy, r), cost
                    if cost == 0:
                        break
                if least == 0:
                    break
            cx, cy, r = best
            leader = r > _RINGS[0] + 1e-9
            ax.annotate(
                text,
                (x, y),
                xytext=((cx - px) / scale, (cy - py) / scale),
                textcoords="offset points",
                fontsize=size,
                color=color,
                ha="center",
                va="center",
                zorder=6,
                arrowprops=(
                    {"arrowstyle": "-", "color": "0.45", "lw": 0.6, "shrinkA": 0, "shrinkB": 2}
                    if leader
                    else None
                ),
            )
            taken.append(Bbox.from_bounds(cx - w / 2, cy - h / 2, w, h))


def _overlap(a, b) -> float:
    """The area two boxes share (pixels²)."""
    dx = min(a.x1, b.x1) - max(a.x0, b.x0)
    dy = min(a.y1, b.y1) - max(a.y0, b.y0)
    return dx * dy if dx > 0 and dy > 0 else 0.0


def _hull(pts: np.ndarray) -> np.ndarray:
    """Convex hull (monotone chain), or the two farthest points of collinear ones."""
    uniq = np.unique(np.round(pts, 12), axis=0)
    if len(uniq) <= 2:
        return uniq
    p = sorted(map(tuple, uniq))

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for q in p:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], q) <= 0:
            lower.pop()
        lower.append(q)
    upper: list = []
    for q in reversed(p):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], q) <= 0:
            upper.pop()
        upper.append(q)
    hull = lower[:-1] + upper[:-1]
    return np.array(hull)


def plot_trajectories(res: Results, path: Path, U: OutputUnits = SI_OUTPUT) -> Path:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 6.5))
    i0 = int(np.flatnonzero(res.ok)[0]) if np.any(res.ok) else 0
    draw_mechanism(ax, res, res.solution.state, i0)
    for p in res.point_names():
        m = res.point(p)
        ax.plot(m.x, m.y, "-", lw=1.2, label=f"path of {p}")
    ax.set_aspect("equal", adjustable="datalim")
    lu = length_axes(ax, U)
    ax.set_xlabel(f"x [{lu}]")
    ax.set_ylabel(f"y [{lu}]")
    ax.set_title(f"{res.mechanism.name}: mechanism at the start and point paths")
    ax.grid(True, alpha=0.3)
    if res.point_names():
        ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    save_figure(fig, path, 120)
    plt.close(fig)
    return path


def plot_point(res: Results, name: str, path: Path, U: OutputUnits = SI_OUTPUT) -> Path:
    plt = _plt()
    m = res.point(name)
    xs, xlabel = driver_axis(res, U)
    rows = [("position", "m", m.x, m.y)]
    if res.view.has_velocity:
        rows.append(("velocity", "m/s", m.vx, m.vy))
    if res.view.has_acceleration:
        rows.append(("acceleration", "m/s^2", m.ax, m.ay))
    rows = [(w, *_pair(U, a, b, unit)) for w, unit, a, b in rows]
    fig, axes = plt.subplots(
        len(rows), 2, figsize=(10, 2.8 * len(rows)), sharex=True, squeeze=False
    )
    syms = {"position": ("x", "y"), "velocity": ("vx", "vy"), "acceleration": ("ax", "ay")}
    for r, (what, unit, a, b) in enumerate(rows):
        for c, (vals, sym) in enumerate(zip((a, b), syms[what])):
            ax = axes[r][c]
            ax.plot(xs, vals, lw=1.4)
            ax.set_ylabel(f"{name}.{sym} [{unit}]")
            ax.grid(True, alpha=0.3)
    for c in range(2):
        axes[-1][c].set_xlabel(xlabel)
    fig.suptitle(f"{res.mechanism.name}: point {name}")
    fig.tight_layout()
    save_figure(fig, path, 110)
    plt.close(fig)
    return path


def _pair(U: OutputUnits, a, b, unit: str) -> tuple[str, np.ndarray, np.ndarray]:
    """(shown unit, a, b): two arrays in ``unit`` in the shown units."""
    a, shown_unit = shown(U, a, unit)
    return shown_unit, a, shown(U, b, unit)[0]


def plot_links(res: Results, path: Path, U: OutputUnits = SI_OUTPUT) -> Path | None:
    names = res.link_names()
    if not names:
        return None
    plt = _plt()
    xs, xlabel = driver_axis(res, U)
    rows = [("angle", "deg")]
    if res.view.has_velocity:
        rows.append(("omega", "rad/s"))
    if res.view.has_acceleration:
        rows.append(("alpha", "rad/s^2"))
    fig, axes = plt.subplots(len(rows), 1, figsize=(9, 2.8 * len(rows)), sharex=True, squeeze=False)
    for ln in names:
        m = res.link(ln)
        vals = {"angle": np.degrees(m.angle), "omega": m.omega, "alpha": m.alpha}
        for r, (q, unit) in enumerate(rows):
            axes[r][0].plot(xs, shown(U, vals[q], unit)[0], lw=1.3, label=ln)
    labels = {"angle": "link angle", "omega": "angular velocity", "alpha": "angular acceleration"}
    for r, (q, unit) in enumerate(rows):
        axes[r][0].set_ylabel(f"{labels[q]} [{pretty_unit(U.convert(unit)[1])}]")
        axes[r][0].grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=7, ncol=3)
    axes[-1][0].set_xlabel(xlabel)
    fig.suptitle(f"{res.mechanism.name}: links")
    fig.tight_layout()
    save_figure(fig, path, 110)
    plt.close(fig)
    return path


def plot_sliders(res: Results, path: Path, U: OutputUnits = SI_OUTPUT) -> Path | None:
    names = res.slider_names()
    if not names:
        return None
    plt = _plt()
    xs, xlabel = driver_axis(res, U)
    rows = [("s", "displacement", "m")]
    if res.view.has_velocity:
        rows.append(("v", "velocity", "m/s"))
    if res.view.has_acceleration:
        rows.append(("a", "acceleration", "m/s^2"))
    fig, axes = plt.subplots(len(rows), 1, figsize=(9, 2.8 * len(rows)), sharex=True, squeeze=False)
    for sn in names:
        m = res.slider(sn)
        for r, (q, _, unit) in enumerate(rows):
            axes[r][0].plot(xs, shown(U, getattr(m, q), unit)[0], lw=1.3, label=sn)
    for r, (_, label, unit) in enumerate(rows):
        axes[r][0].set_ylabel(f"slider {label} [{pretty_unit(U.convert(unit)[1])}]")
        axes[r][0].grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=7)
    axes[-1][0].set_xlabel(xlabel)
    fig.suptitle(f"{res.mechanism.name}: sliders (along their guides)")
    fig.tight_layout()
    save_figure(fig, path, 110)
    plt.close(fig)
    return path


def _switches(res: Results) -> np.ndarray:
    """Indices k where a conditional load switches between samples k and k+1."""
    ks: set[int] = set()
    for on in res.forces.active.values():
        ks.update(np.flatnonzero(on[1:] != on[:-1]).tolist())
    return np.array(sorted(ks), dtype=int)


def _broken(res: Results, *arrays: np.ndarray, at_switch: bool = False) -> list[np.ndarray]:
    """Copies of ``arrays`` with NaN inserted where a load switches between two samples,
    so that a plotted line does not join the two sides with a slope. Where the sweep has
    samples on both sides of the exact switch (:func:`mechsolve.api.for_plots`), the line
    joins them: a vertical jump at its angle. ``at_switch``: break there too (a curve
    not drawn against the driver, such as a hodograph, would draw that jump as a chord)."""
    k = _switches(res)
    u = np.asarray(res.u, float)
    if k.size and not at_switch:
        gap = np.abs(u[k + 1] - u[k])
        k = k[gap > 1e-6 * (res.analysis.scale if res.linear else 1.0)]
    if k.size == 0:
        return [np.asarray(a, float) for a in arrays]
    return [np.insert(np.asarray(a, float), k + 1, np.nan) for a in arrays]


def break_at_switches(active: dict[str, np.ndarray], *arrays: np.ndarray) -> list[np.ndarray]:
    """Copies of ``arrays`` (samples along a motion) with NaN inserted wherever one of
    the conditional loads (``active``: where each acts) switches between two samples:
    a curve drawn through them jumps there as a gap, never a sloped chord."""
    ks: set[int] = set()
    for on in active.values():
        on = np.asarray(on, bool)
        ks.update(np.flatnonzero(on[1:] != on[:-1]).tolist())
    k = np.array(sorted(ks), dtype=int)
    if k.size == 0:
        return [np.asarray(a, float) for a in arrays]
    return [np.insert(np.asarray(a, float), k + 1, np.nan) for a in arrays]


JUMP_FACTOR = 12.0  # a step this many times the curve's typical step ...
JUMP_SHARE = 0.08  # ... and this share of the curve's size is a jump, not motion


def jumps(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Indices k where the vector tip (x, y) jumps between samples k and k+1: a step
    longer than :data:`JUMP_FACTOR` times the median step and :data:`JUMP_SHARE` of the
    curve's extent. A force that switches between samples (a load acting only part of
    the cycle, a reaction crossing a dead point) jumps; a smooth curve sampled at 1°
    never steps so far beyond its neighbours."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    step = np.hypot(np.diff(x), np.diff(y))
    good = np.isfinite(step)
    if np.count_nonzero(good) < 3:
        return np.array([], dtype=int)
    size = max(float(np.nanmax(x) - np.nanmin(x)), float(np.nanmax(y) - np.nanmin(y)))
    typical = float(np.median(step[good]))
    big = good & (step > JUMP_FACTOR * typical) & (step > JUMP_SHARE * size)
    return np.flatnonzero(big)


def break_jumps(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``x`` and ``y`` with NaN inserted at each jump (:func:`jumps`): a line drawn
    through them stops at one side of the jump and starts again at the other."""
    k = jumps(x, y)
    if k.size == 0:
        return np.asarray(x, float), np.asarray(y, float)
    return np.insert(np.asarray(x, float), k + 1, np.nan), np.insert(
        np.asarray(y, float), k + 1, np.nan
    )


def _scaled(values: np.ndarray, unit: str, U: OutputUnits = SI_OUTPUT) -> tuple[float, str]:
    """``(divisor, label unit)`` to draw ``values`` (SI, in ``unit``) with: the shown
    unit, in kN or kN·m for SI forces and torques of 1e4 and more."""
    k, target = U.convert(unit)
    big = np.nanmax(np.abs(values)) * k if np.any(np.isfinite(values)) else 0.0
    if target in ("N", "N*m") and big >= 1e4:
        return 1e3 / k, pretty_unit("k" + target)
    return 1.0 / k, pretty_unit(target)


def plot_effort(res: Results, path: Path, U: OutputUnits = SI_OUTPUT) -> Path:
    """The driving torque (force) against the driver, with its mean and the work."""
    plt = _plt()
    xs, xlabel = driver_axis(res, U)
    e = res.driving_effort
    kind, unit = res.effort_name
    mean, what = res.mean_effort()
    sc, su = _scaled(e, unit, U)
    fig, ax = plt.subplots(figsize=(9, 4.5))
    bx, be = _broken(res, xs, e / sc)
    ax.plot(bx, be, lw=1.6, label=f"driving {kind}")
    work = res.work_text(U).replace("of the driver ", "")
    if math.isfinite(mean):  # (not determined where the effort grows without bound)
        ax.axhline(
            mean / sc, ls="--", color="C3", lw=1.2, label=f"{what} {mean / sc:.6g} {su}; {work}"
        )
    else:
        ax.plot([], [], ls="--", color="C3", label=f"{what} not determined; {work}")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.set_xlabel(xlabel)
    driven = res.mechanism.joint(res.mechanism.driver.joint).b
    ax.set_ylabel(f"driving {kind} on {driven} [{su}]")
    ax.set_title(f"{res.mechanism.name}: driving {kind} (counter-clockwise positive)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, 110)
    plt.close(fig)
    return path


def ground_joints(res: Results) -> list[str]:
    """Joints with the ground, fixed hinges first, then sliders on fixed guides: the
    reactions the frame (foundation) must carry."""
    from mechsolve.model import GROUND

    on_ground = [j for j in res.mechanism.joints if GROUND in j.links]
    hinges = [j.name for j in on_ground if j.coordinate == "angle"]
    return hinges + [j.name for j in on_ground if j.coordinate != "angle"]


def plot_hodographs(res: Results, path: Path, U: OutputUnits = SI_OUTPUT) -> Path | None:
    """Vector-tip diagrams (hodographs) of the reactions on the ground: at the fixed
    hinges, and at the sliders on fixed guides (the guide's normal force with its
    components; its tip moves along the guide's normal)."""
    names = ground_joints(res)
    if not names:
        return None
    plt = _plt()
    k = len(names)
    cols = min(k, 3)
    rows = math.ceil(k / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.6 * cols, 4.4 * rows), squeeze=False)
    for ax, name in zip(axes.flat, names):
        r = res.reaction(name)
        fx, fy = np.where(res.forces.ok, r["Fx"], np.nan), np.where(res.forces.ok, r["Fy"], np.nan)
        scale, fu = _scaled(np.hypot(fx, fy), "N", U)
        # a force that jumps (a load switching on or off) is drawn as two ends, no chord
        bx, by = break_jumps(*_broken(res, fx / scale, fy / scale, at_switch=True))
        ax.plot(bx, by, "-o", ms=2.5, lw=1.2)
        i0 = int(np.flatnonzero(np.isfinite(fx))[0])
        ax.annotate(
            "",
            xy=(fx[i0] / scale, fy[i0] / scale),
            xytext=(0, 0),
            arrowprops={"arrowstyle": "->", "color": "C3"},
        )
        ax.annotate("start", (fx[i0] / scale, fy[i0] / scale), fontsize=7, color="C3")
        ax.plot([0], [0], "k+", ms=10)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(f"{name}.Fx [{fu}]")
        ax.set_ylabel(f"{name}.Fy [{fu}]")
        slider = res.mechanism.joint(name).magnitude == "N"  # a guide's normal force
        ax.set_title(
            f"{res.joint_label(name)}" + (" (guide normal force)" if slider else ""), fontsize=9
        )
        ax.grid(True, alpha=0.3)
    for ax in list(axes.flat)[k:]:
        ax.axis("off")
    fig.suptitle(f"{res.mechanism.name}: hodographs of the reactions on the ground")
    fig.tight_layout()
    save_figure(fig, path, 110)
    plt.close(fig)
    return path


def plot_reactions(res: Results, path: Path, U: OutputUnits = SI_OUTPUT) -> Path:
    """Magnitudes of all joint reactions against the driver."""
    plt = _plt()
    xs, xlabel = driver_axis(res, U)
    fig, ax = plt.subplots(figsize=(9, 4.8))
    mags = {}
    for j in res.mechanism.joints:
        r = res.reaction(j.name)
        mag = np.abs(r[j.magnitude])
        mags[j.name] = np.where(res.forces.ok, mag, np.nan)
    sc, su = _scaled(np.concatenate(list(mags.values())), "N", U)
    for j in res.mechanism.joints:
        label = res.joint_label(j.name) + j.magnitude_note
        bx, bm = _broken(res, xs, mags[j.name] / sc)
        ax.plot(bx, bm, lw=1.3, label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(f"reaction magnitude [{su}]")
    ax.set_title(f"{res.mechanism.name}: joint reactions")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_figure(fig, path, 110)
    plt.close(fig)
    return path


PLOT_FORMATS = ("png", "svg")


def write_plots(
    res: Results, outdir: Path, fmt: str = "png", units: OutputUnits | None = None
) -> list[Path]:
    """Write all plots into ``outdir`` as ``fmt`` (png, or svg with its text kept as text)
    in ``units`` (SI when not given); return the files written."""
    U = units or SI_OUTPUT
    from mechsolve.writers.fonts import pyplot

    if fmt not in PLOT_FORMATS:
        raise ValueError(f"plot format {fmt!r}: one of {', '.join(PLOT_FORMATS)}")
    pyplot(names_of(res.mechanism))  # fonts for the names; one note if some cannot be drawn
    outdir.mkdir(parents=True, exist_ok=True)
    written = [plot_trajectories(res, outdir / f"trajectories.{fmt}", U)]
    for p in res.point_names():
        written.append(plot_point(res, p, outdir / f"point_{p}.{fmt}", U))
    for f in (
        plot_links(res, outdir / f"links.{fmt}", U),
        plot_sliders(res, outdir / f"sliders.{fmt}", U),
    ):
        if f is not None:
            written.append(f)
    if res.forces is not None and np.any(res.forces.ok):
        written.append(plot_effort(res, outdir / f"torque.{fmt}", U))
        written.append(plot_reactions(res, outdir / f"reactions.{fmt}", U))
        h = plot_hodographs(res, outdir / f"hodographs.{fmt}", U)
        if h is not None:
            written.append(h)
    return written


def draw_start(analysis, state, path: Path, title: str) -> Path:
    """Draw the assembled start position alone (``mechsolve check --draw``)."""
    from mechsolve.writers.fonts import pyplot

    plt = pyplot([title, *names_of(analysis.mech)])
    fig, ax = plt.subplots(figsize=(7, 6))
    draw_mechanism(ax, analysis, state, 0)
    ax.set_aspect("equal", adjustable="datalim")
    lu = length_axes(ax, analysis.mech.output_units())
    ax.set_xlabel(f"x [{lu}]")
    ax.set_ylabel(f"y [{lu}]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path, 120)
    plt.close(fig)
    return path
