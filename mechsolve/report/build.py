"""What the report shows, gathered from the stages as plain values for the template.

Every number is formatted here (with its unit); the template only lays them out. The
images are written by the same writers as ``run``, ``check --draw``, ``simulate`` and
``cam`` into a temporary folder and embedded as data URIs.
"""

from __future__ import annotations

import base64
import dataclasses
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mechsolve import api
from mechsolve.analyses.cam.analysis import analyse
from mechsolve.analyses.cam.model import load as load_cam
from mechsolve.analyses.cam.writers import write_plots as write_cam_plots
from mechsolve.analyses.dynamics import simulate as run_simulation
from mechsolve.analyses.dynamics.plots import write_simulation_plots
from mechsolve.analyses.polygons import draw_polygons
from mechsolve.base.errors import AssemblyError, InputError, SolverError
from mechsolve.base.units import SI_OUTPUT, OutputUnits, parse_quantity
from mechsolve.model import Damper, Limit, PointForce, Spring, Torque
from mechsolve.model.source import load_file
from mechsolve.report.animate import solve_frames
from mechsolve.results.requirements import check_requirements, located_extreme
from mechsolve.results.summary import places, unbounded_towards
from mechsolve.writers.plots import draw_start, write_plots

PLOT_TITLES = {
    "trajectories": "The mechanism at the start and the paths of its points",
    "links": "Links: angle, angular velocity, angular acceleration",
    "sliders": "Sliders: displacement, velocity, acceleration along their guides",
    "torque": "Driving torque over the cycle",
    "reactions": "Joint reactions",
    "hodographs": "Hodographs of the reactions on the ground",
    "motion": "Follower motion: displacement, velocity, acceleration, jerk",
    "pressure": "Pressure angle for both senses of rotation",
    "cam": "Cam profile",
}


@dataclass
class Image:
    """An embedded image: a title and a data URI."""

    title: str
    uri: str
    name: str = ""


# What a printed page holds, for splitting a wide table into parts that fit: the width of
# an A4 page (the narrower of A4 and Letter) less its margins, in CSS pixels, and the print
# stylesheet's character width and cell padding (report.css, @media print).
PRINT_WIDTH = (210 - 2 * 12) / 25.4 * 96 - 16  # px, a little to spare
PRINT_CHAR = 5.8  # px per character of a table at 8.5 px (a wide sans-serif: DejaVu Sans)
PRINT_PAD = 8.0  # px of padding and borders per cell
# and what a screen holds (report.css): the page's column (1100 px less its padding) at
# the tables' .86rem (a digit of DejaVu Sans is 8.75 px), 0.5rem padding each side; a
# table wider than this is shown in parts, so that no table scrolls sideways in a
# window 1280 px wide (or any window wider than the column)
SCREEN_WIDTH = 1100 - 2 * 19.2 - 24  # px, a little to spare
SCREEN_CHAR = 8.9
SCREEN_PAD = 18.0


@dataclass
class HeaderCell:
    """A cell of a printed part's two header rows."""

    text: str
    colspan: int = 1
    rowspan: int = 1


@dataclass
class PrintPart:
    """Some of a wide table's columns, with its leading columns repeated, as printed."""

    caption: str
    groups: list[HeaderCell]  # the first header row (a name over its columns)
    sub: list[str]  # the second header row (each column's quantity and unit)
    rows: list[list[str]]
    numeric: list[bool]


def _split_header(text: str) -> tuple[str, str]:
    """``O2(ground->crank).Fx [N]`` -> (``O2(ground->crank)``, ``Fx [N]``); a header without
    a name before its quantity -> ("", text)."""
    name, sp, unit = text.partition(" [")
    head, dot, q = name.rpartition(".")
    if not dot or not head:
        return "", text
    return head, q + sp + unit


def _width(texts: list[str], wrap: bool, char: float = PRINT_CHAR, pad: float = PRINT_PAD) -> float:
    """Estimated printed width (px) of a column holding ``texts``: its longest word when it
    may wrap, else its longest text (``char`` px a character, ``pad`` px a cell)."""
    if wrap:
        n = max((len(w) for t in texts for w in t.split()), default=1)
    else:
        n = max((len(t) for t in texts), default=1)
    return n * char + pad


@dataclass
class Table:
    """A table of text cells: a caption, header cells (each with its unit) and rows.

    ``lead``: how many leading columns identify a row (position number, time, driver
    value); a table too wide for a printed page is printed in parts (:meth:`print_parts`),
    each with these columns again."""

    caption: str
    header: list[str]
    rows: list[list[str]]
    numeric: list[bool] = field(default_factory=list)
    note: str = ""
    lead: int = 0

    def column_width(self, k: int, char: float = PRINT_CHAR, pad: float = PRINT_PAD) -> float:
        """The printed width (px) of column ``k``: its cells (a number does not wrap, a
        text does at its spaces) and its header, which wraps at spaces."""
        cells = [r[k] for r in self.rows if k < len(r)]
        num = bool(self.numeric) and k < len(self.numeric) and self.numeric[k]
        return max(_width(cells, not num, char, pad), _width([self.header[k]], True, char, pad))

    def screen_parts(self) -> list[PrintPart]:
        """The table as shown on screen when it is wider than the page's column: parts as
        :meth:`print_parts` makes them, at the screen's sizes. Empty when it fits."""
        return self.print_parts(SCREEN_WIDTH, SCREEN_CHAR, SCREEN_PAD)

    def print_parts(
        self, page: float = PRINT_WIDTH, char: float = PRINT_CHAR, pad: float = PRINT_PAD
    ) -> list[PrintPart]:
        """The table as printed when it is wider than a page (``page`` px at ``char`` px
        a character and ``pad`` px a cell): parts of whole groups of columns (a joint's
        Fx, Fy and F; a point's x and y) under a two-row header, each part led by the
        ``lead`` columns. Empty when the table fits as it is."""
        ncol = len(self.header)
        if ncol == 0 or sum(self.column_width(k, char, pad) for k in range(ncol)) <= page:
            return []
        lead = list(range(min(self.lead, ncol)))
        # the groups of the other columns: consecutive columns with one name
        groups: list[tuple[str, list[int]]] = []
        for k in range(len(lead), ncol):
            head, _ = _split_header(self.header[k])
            if groups and head and groups[-1][0] == head:
                groups[-1][1].append(k)
            else:
                groups.append((head, [k]))
        sub_of = {k: _split_header(self.header[k]) for k in range(ncol)}

        def sub_width(k: int) -> float:
            head, sub = sub_of[k]
            cells = [r[k] for r in self.rows if k < len(r)]
            num = bool(self.numeric) and k < len(self.numeric) and self.numeric[k]
            return max(
                _width(cells, not num, char, pad),
                _width([sub if head else self.header[k]], True, char, pad),
            )

        def group_width(head: str, cols: list[int]) -> float:
            inner = sum(sub_width(k) for k in cols)
            return max(inner, _width([head], False, char, pad)) if head else inner

        base = sum(sub_width(k) for k in lead)
        parts: list[list[tuple[str, list[int]]]] = [[]]
        used = base
        for head, cols in groups:
            w = group_width(head, cols)
            if parts[-1] and used + w > page:
                parts.append([])
                used = base
            parts[-1].append((head, cols))
            used += w
        out = []
        for i, part in enumerate(parts, start=1):
            cols = lead + [k for _, ks in part for k in ks]
            top = [HeaderCell(self.header[k], rowspan=2) for k in lead]
            sub = []
            for head, ks in part:
                if head:
                    top.append(HeaderCell(head, colspan=len(ks)))
                    sub += [sub_of[k][1] for k in ks]
                else:
                    top += [HeaderCell(self.header[k], rowspan=2) for k in ks]
            if not sub:  # one header row
                for cell in top:
                    cell.rowspan = 1
            out.append(
                PrintPart(
                    f"{self.caption} (part {i} of {len(parts)})",
                    top,
                    sub,
                    [[r[k] if k < len(r) else "" for k in cols] for r in self.rows],
                    [
                        bool(self.numeric) and k < len(self.numeric) and self.numeric[k]
                        for k in cols
                    ],  # fmt: skip
                )
            )
        return out


def embed(path: Path, title: str | None = None) -> Image:
    """``path`` (PNG, SVG, JPEG) as a data URI."""
    path = Path(path)
    mime = {".png": "image/png", ".svg": "image/svg+xml", ".jpg": "image/jpeg"}.get(
        path.suffix.lower(), "application/octet-stream"
    )
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return Image(title or plot_title(path), f"data:{mime};base64,{data}", path.name)


def plot_title(path: Path) -> str:
    stem = Path(path).stem
    if stem in PLOT_TITLES:
        return PLOT_TITLES[stem]
    if stem.startswith("point_"):
        return f"Point {stem[6:]}: position, velocity and acceleration"
    return stem.replace("_", " ").capitalize()


def num(x: float | None, digits: int = 5) -> str:
    """A number as an engineer writes it: ``digits`` significant figures, no exponent for
    ordinary sizes; a dash for a missing value."""
    if x is None or not math.isfinite(x):
        return "–"
    if x == 0:
        return "0"
    if 1e-4 <= abs(x) < 1e7:
        dec = max(0, digits - 1 - math.floor(math.log10(abs(x))))
        text = f"{x:.{dec}f}"
        if "." in text:
            text = text.rstrip("0").rstrip(".")
        return text
    return f"{x:.{digits - 1}e}"


def column_format(values: np.ndarray, digits: int = 5, zero: float = 1e-9) -> list[str]:
    """One column of a table with a common number of decimals (``digits`` significant
    figures of its largest value), as printed tables align them; a column whose largest
    value is below ``zero`` is zero but for rounding."""
    v = np.asarray(values, float)
    good = v[np.isfinite(v)]
    big = float(np.max(np.abs(good))) if good.size else 0.0
    if big < zero:  # zero but for rounding (SI values: nm, nm/s)
        return ["–" if not math.isfinite(x) else "0" for x in v]
    if big == 0:
        dec = 3
    elif 1e-4 <= big < 1e7:
        dec = max(0, digits - 1 - math.floor(math.log10(big)))
    else:
        return [num(float(x), digits) for x in v]
    return ["–" if not math.isfinite(x) else f"{x:.{dec}f}" for x in v]


# -- the model ------------------------------------------------------------------------
def _unit_factor(unit: str) -> float:
    return parse_quantity(f"1 {unit}", "length")


def model_tables(mech, check_report) -> list[Table]:
    """Ground points, links (points, lengths, angles, masses, inertias), joints, loads."""
    lu = mech.length_unit
    f = _unit_factor(lu)
    tables = [_ground_table(mech, lu, f), _links_table(mech, lu, f), _joints_table(mech, lu, f)]
    loads = _loads_table(mech, lu, f)
    if loads is not None:
        tables.append(loads)
    tables.append(_driver_table(mech, check_report, lu, f))
    return tables


def _ground_table(mech, lu: str, f: float) -> Table:
    """The fixed points."""
    return Table(
        "Fixed points (ground)",
        ["point", f"x [{lu}]", f"y [{lu}]"],
        [[p, num(x / f), num(y / f)] for p, (x, y) in mech.ground.items()],
        [False, True, True],
    )


def _links_table(mech, lu: str, f: float) -> Table:
    """Each link's points in its frame, with its mass properties."""
    rows = []
    for lk in mech.links:
        names = list(lk.points)
        first = True
        for p in names:
            x, y = lk.points[p]
            r = math.hypot(x, y)
            ang = math.degrees(math.atan2(y, x)) if r > 0 else float("nan")
            mass = inertia = com = ""
            if first:
                mass = num(lk.mass) if lk.mass else "–"
                inertia = num(lk.inertia) if lk.inertia is not None else "–"
                if lk.mass:
                    cx, cy = lk.com if lk.com is not None else (0.0, 0.0)
                    com = f"({num(cx / f)}, {num(cy / f)})"
            rows.append(
                [
                    lk.name if first else "",
                    p,
                    num(x / f),
                    num(y / f),
                    num(r / f) if r > 0 else "0",
                    num(ang, 4) if r > 0 else "–",
                    mass,
                    com,
                    inertia,
                ]
            )
            first = False
    return Table(
        "Links: points in each link's frame (its x axis is the angle 0)",
        [
            "link",
            "point",
            f"x [{lu}]",
            f"y [{lu}]",
            f"distance from the frame origin [{lu}]",
            "angle from the x axis [deg]",
            "mass [kg]",
            f"centre of mass [{lu}]",
            "inertia about the centre of mass [kg m²]",
        ],
        rows,
        [False, False, True, True, True, True, True, False, True],
        "A link with a mass and no inertia is a point mass at its centre of mass.",
    )


def _joints_table(mech, lu: str, f: float) -> Table:
    """Each joint as its kind describes it."""
    rows = []
    for j in mech.joints:
        links, point, own = j.describe(lambda x: num(x / f), lambda a: num(math.degrees(a), 4), lu)
        rows.append([j.name, j.kind, links, point, own])
    return Table(
        "Joints (a reaction is the force on the second link by the first)",
        ["joint", "kind", "links", "point", "guide"],
        rows,
    )


def _loads_table(mech, lu: str, f: float) -> Table | None:
    """The loads and gravity (``None`` without any)."""

    rows = []
    for ld in mech.loads:
        if isinstance(ld, PointForce):
            what = (
                f"force ({num(ld.force[0])}, {num(ld.force[1])}) N at {ld.point} on {ld.link}"
                + (" (in the link's frame)" if ld.frame == "link" else "")
            )
            kind = "force"
        elif isinstance(ld, Torque):
            kind, what = "torque", f"{num(ld.torque)} N m on {ld.link} (counter-clockwise +)"
        elif isinstance(ld, Spring):
            (la, pa), (lb, pb) = ld.ends
            kind = "spring"
            what = (
                f"k = {num(ld.stiffness)} N/m, free length {num(ld.free_length / f)} {lu}, "
                f"between {pa} of {la} and {pb} of {lb}"
            )
        elif isinstance(ld, Damper):
            kind = "damper"
            if ld.slider is not None:
                where = f"along slider {ld.slider}"
            elif ld.drag is not None:
                where = f"against the velocity of {ld.drag[1]} on {ld.drag[0]}"
            else:
                (la, pa), (lb, pb) = ld.ends
                where = f"between {pa} of {la} and {pb} of {lb}"
            what = f"c = {num(ld.coefficient)} N s/m {where}"
        else:
            kind, what = type(ld).__name__.lower(), ""
        rows.append([ld.name, kind, what, ld.when.text if ld.when is not None else "always"])
    g = tuple(0.0 if abs(v) < 1e-12 * math.hypot(*mech.gravity_vector()) else v
              for v in mech.gravity_vector())  # fmt: skip
    if g != (0.0, 0.0):
        rows.append(["gravity", "field", f"({num(g[0])}, {num(g[1])}) m/s²", "always"])
    return Table("Loads", ["load", "kind", "value", "acts when"], rows) if rows else None


def _driver_table(mech, check_report, lu: str, f: float) -> Table:
    """The driver and the sweep."""

    d = mech.driver
    an = check_report.analysis
    rows = [["joint", d.joint + (f" (line {d.line[0]} → {d.line[1]})" if d.line else "")]]
    if d.motion is not None:
        from mechsolve.model.motion import describe

        rows.append(["motion", describe(d.motion)])
    elif an.linear:
        rows.append(["speed", f"{num(d.speed)} m/s"])
    else:
        rows.append(["speed", f"{num(d.speed)} rad/s = {num(d.speed * 30 / math.pi)} rpm"])
    rows.append(["direction of the sweep", "+" if d.direction > 0 else "−"])
    if isinstance(d.start, Limit):
        start = f"the {d.start.extreme} of {d.start.quantity.text}: "
    else:
        start = ""
    rows.append(["start", start + an.format_u(check_report.start_u)])
    sw = mech.sweep
    if sw.duration is not None:
        rows.append(["sweep", f"{num(sw.duration)} s in steps of {num(sw.time_step)} s"])
    else:
        travel = sw.travel if sw.travel is not None else 2 * math.pi
        if an.linear:
            text = f"{num(travel / f)} {lu}"
            if sw.step:
                text += f" in steps of {num(sw.step / f)} {lu}"
        else:
            text = f"{num(math.degrees(travel))}°"
            if sw.step:
                text += f" in steps of {num(math.degrees(sw.step))}°"
        rows.append(["sweep", text])
    return Table("Driver", ["", ""], rows)


# -- results ----------------------------------------------------------------------------
def figures_table(res, units: OutputUnits | None = None) -> Table:
    """Limit positions, stroke, time ratio, transmission angles, peak torque, work per
    cycle and the power balance, in ``units`` (default SI, with kN and kN m from 1e4)."""
    U = units or SI_OUTPUT
    k_len, L = U.convert("m")
    k_ang, A = U.convert("deg")
    deg = "°" if A == "deg" else f" {A}"
    res._shown = U  # res words driver values (and their turns) in the shown units
    rows: list[list[str]] = []
    for lp in res.limit_positions():
        a, b = places(res, lp.u_lows), places(res, lp.u_highs)
        where = f"the lower at {a}; the higher at {b}"
        if lp.kind == "rocker":
            rows.append(
                [
                    f"limit positions of rocker {lp.name}",
                    f"{num(math.degrees(lp.low) * k_ang, 6)}{deg} to "
                    f"{num(math.degrees(lp.high) * k_ang, 6)}{deg}",
                    where,
                ]
            )
            rows.append(
                [f"swing of {lp.name}", f"{num(math.degrees(lp.swing) * k_ang, 6)}{deg}", ""]
            )
        else:
            rows.append(
                [
                    f"limit positions of slider {lp.name}",
                    f"{num(lp.low * k_len, 6)} {L} to {num(lp.high * k_len, 6)} {L}",
                    where,
                ]
            )
            rows.append([f"stroke of {lp.name}", f"{num(lp.swing * k_len, 6)} {L}", ""])
        if lp.time_ratio is not None:
            rows.append(
                [
                    f"time ratio of {lp.name}",
                    f"K = {num(lp.time_ratio, 4)}",
                    f"{num(math.degrees(max(lp.forward, lp.back)) * k_ang)}{deg} / "
                    f"{num(math.degrees(min(lp.forward, lp.back)) * k_ang)}{deg} of the driver",
                ]
            )
    for t in res.transmission_angles():
        rows.append(
            [
                f"minimum transmission angle, {t.group}",
                f"{num(math.degrees(t.angle) * k_ang, 4)}{deg}",
                f"at {res.format_u(t.u)}",
            ]
        )
    rows += _force_figure_rows(res, U)
    return Table("Figures of the motion", ["figure", "value", "where / note"], rows)


def _force_figure_rows(res, U: OutputUnits) -> list[list[str]]:
    """The figures table's rows of the forces: the driving effort's extremes and mean, the
    driver's work, the power balance (in ``U``; kN and kN m from 1e4 in SI)."""
    rows: list[list[str]] = []
    f = res.forces
    if f is not None and np.any(f.ok):
        kind, unit = res.effort_name
        e = res.driving_effort
        if np.any(np.isfinite(e)):
            k, unit = U.convert(unit)
            sc = 1.0 / k
            if unit in ("N", "N*m") and np.nanmax(np.abs(e)) * k >= 1e4:
                sc, unit = sc * 1e3, "k" + unit
            unit = unit.replace("*", " ")
            imax, imin = int(np.nanargmax(e)), int(np.nanargmin(e))
            unbounded = False
            for what, i, sign in (("largest", imax, 1.0), ("smallest", imin, -1.0)):
                toward = unbounded_towards(res, sign * e, i)  # no peak at a dead centre
                if toward is not None:
                    unbounded = True
                    rows.append([f"{what} driving {kind}", "unbounded", f"grows towards {toward}"])
                    continue
                value, where = _effort_extreme(res, sign > 0)
                rows.append([f"{what} driving {kind}", f"{num(value / sc, 6)} {unit}", where])
            mean, what = res.mean_effort()
            if unbounded and what != "mean":  # a mean over time of an unbounded effort
                mean = math.nan
            text = f"{num(mean / sc, 6)} {unit}" if math.isfinite(mean) else "not determined"
            rows.append([f"{what} driving {kind}", text, ""])
        rows.append(["work of the driver", res.work_text().split(": ", 1)[-1],
                     "per cycle" if res.is_full_cycle() else "over the sweep"])  # fmt: skip
        resid = np.where(f.ok, f.residual, np.nan)
        if np.any(np.isfinite(resid)):
            big = float(np.nanmax(np.abs(resid)))
            ps = res.power_scale()
            k_w, W = U.convert("W")
            rows.append(
                [
                    "power balance",
                    f"max residual {num(big * k_w, 3)} {W}",
                    f"{num(big / ps, 2) if ps > 0 else '0'} of the largest power term",
                ]
            )
    return rows


# a joint's reaction columns in the report's table: a pin's Fx, Fy, F; a slider's N, M;
# a gear mesh's or rack's tooth forces Ft (tangential, the one that sizes the teeth), Fr
# (radial) and Fn (along the line of action, the whole tooth force)
REACTIONS = ("Fx", "Fy", "F", "N", "M", "Ft", "Fr", "Fn")


def _effort_extreme(res, largest: bool) -> tuple[float, str]:
    """The driving effort's largest (or smallest) value over ``res`` (the figures'
    sweep) and where, in words: located between its neighbouring samples as the
    requirements locate ``max()`` and ``min()`` (solved there, :func:`located_extreme`).
    A motion law of time, or a sweep whose ends do not close, has no such sweep: its
    largest sample, said so."""
    e = res.driving_effort
    i = int(np.nanargmax(e) if largest else np.nanargmin(e))
    # as the requirements' reducer decides (a sweep to locate in: _Reducer._fine_sweep)
    if res.mechanism.driver.motion is None and len(res.u) > 1 and np.all(res.ok[[0, -1]]):
        if getattr(res, "_plots_sweep", None) is None:
            res._plots_sweep = (res.mechanism, res)  # the figures' sweep is its own
        value, u = located_extreme(f"input.{res.effort_name[0]}", res, largest)
        if math.isfinite(value) and math.isfinite(u):
            return value, res.format_u(u)
    word = "largest" if largest else "smallest"
    return float(e[i]), f"{res.describe_u(i)} ({word} of the {res.sample_spacing()} samples)"


def _groups(res) -> dict[str, list]:
    """The columns of ``res`` sorted into the tables a printed report has."""
    pts = set(res.point_names())
    links = set(res.link_names()) | {f"{a}/{b}" for a, b in res.mechanism.outputs.relative}
    sliders = set(res.slider_names())
    out: dict[str, list] = {
        "driver": [],
        "positions": [],
        "velocities": [],
        "accelerations": [],
        "links": [],
        "sliders": [],
        "forces": [],
    }
    for c in res.columns():
        head, _, q = c.name.rpartition(".")
        if c.name in ("t", "input.angle", "input.s"):
            out["driver"].append(c)
        elif head in pts and q in ("x", "y"):
            out["positions"].append(c)
        elif head in pts and q in ("vx", "vy"):
            out["velocities"].append(c)
        elif head in pts and q in ("ax", "ay"):
            out["accelerations"].append(c)
        elif head in links:
            out["links"].append(c)
        elif head in sliders:
            out["sliders"].append(c)
        elif c.name.startswith("input.torque") or c.name.startswith("input.force"):
            out["forces"].insert(0, c)
        elif q in REACTIONS and "(" in head:
            out["forces"].append(c)
    return out


CAPTIONS = {
    "positions": "Positions of the points",
    "velocities": "Velocities of the points",
    "accelerations": "Accelerations of the points",
    "links": "Angles, angular velocities and angular accelerations of the links",
    "sliders": "Sliders along their guides",
    "forces": "Driving effort and joint reactions",
}


def position_tables(res, units: OutputUnits | None = None) -> list[Table]:
    """The tables at the file's step, the driver's columns first in each, in ``units``
    (default SI)."""
    U = units or SI_OUTPUT
    groups = _groups(res)
    lead = groups.pop("driver")
    status = res.status()
    tables = []
    for key, cols in groups.items():
        cols = [c for c in cols if np.any(np.isfinite(c.values))]
        if not cols:
            continue
        allc = []
        formatted = []
        for c in lead + cols:  # in the shown units; zero but for rounding judged in SI
            k, unit = U.convert(c.unit)
            if k != 1.0 or unit != c.unit:
                c = dataclasses.replace(c, unit=unit, values=np.asarray(c.values, float) * k)
            allc.append(c)
            formatted.append(column_format(c.values, zero=1e-9 * k))
        rows = []
        for i in range(len(res.u)):
            row = [str(i + 1)] + [f[i] for f in formatted]
            rows.append(row)
        notes = sorted({s for s in status if s != "ok"})
        tables.append(
            Table(
                CAPTIONS[key],
                ["#"] + [c.header.replace("*", " ").replace("^2", "²") for c in allc],
                rows,
                [True] * (len(allc) + 1),
                "Not solved or not determined: " + "; ".join(notes) if notes else "",
                lead=1 + len(lead),
            )
        )
    return tables


def verdict_rows(verdicts) -> Table:
    rows = []
    for v in verdicts:
        rows.append([v.name, v.text, v.message.rsplit(": ", 1)[0], "pass" if v.passed else "FAIL"])
    failed = sum(not v.passed for v in verdicts)
    return Table(
        f"Requirements: {len(verdicts) - failed} of {len(verdicts)} pass",
        ["requirement", "as written", "measured", "verdict"],
        rows,
    )


@dataclass
class Content:
    """Everything the template shows."""

    title: str
    description: str
    file: str
    variant: str | None
    kind: str  # "mechanism" or "cam"
    sections: list[str] = field(default_factory=list)
    model_tables: list[Table] = field(default_factory=list)
    structure: dict[str, Any] = field(default_factory=dict)
    drawing: Image | None = None
    figures: Table | None = None
    summary_text: str = ""
    tables: list[Table] = field(default_factory=list)
    table_step: str = ""
    plots: list[Image] = field(default_factory=list)
    requirements: Table | None = None
    dynamics_text: str = ""
    dynamics_plots: list[Image] = field(default_factory=list)
    cam_text: str = ""
    cam_plots: list[Image] = field(default_factory=list)
    polygons_text: str = ""
    polygons_problem: str = ""  # why the polygons are not drawn
    polygons_images: list[Image] = field(default_factory=list)
    animation: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)
    # for the command's exit status
    incomplete: bool = False
    failed_requirements: int = 0
    cam_problems: list[str] = field(default_factory=list)  # allowances exceeded, undercut
    verdicts: list = field(default_factory=list)


def _plain(exc: Exception) -> str:
    """An error's message without the command's prefix (``polygons: ...``)."""
    return str(exc).removeprefix("polygons: ")


def _description(source) -> str:
    data = getattr(source, "data", None) or {}
    text = data.get("description") if isinstance(data, dict) else None
    return " ".join(str(text).split()) if text else ""


def mechanism_content(
    mech,
    *,
    frames: int | None = None,
    method: str | None = None,
    simulate: bool = True,
    polygons_at: str | int | None = None,
    units: OutputUnits | None = None,
) -> Content:
    """Solve ``mech`` every way the report shows it and gather the results; its tables,
    summary and plots in ``units`` (default SI)."""
    U = units or SI_OUTPUT

    file = str(mech.source.file) if mech.source is not None and mech.source.file else ""
    c = Content(mech.name, _description(mech.source), file, None, "mechanism")
    rep = api.check(mech, method)
    c.model_tables = model_tables(mech, rep)
    c.structure = {
        "grubler": rep.grubler,
        "jacobian": rep.jacobian_dof,
        "links": len(mech.links),
        "joints": len(mech.joints),
        "groups": list(zip(rep.groups, rep.branches)),
        "redundant": rep.analysis.redundant,
        "notes": rep.notes,
    }
    res = api.solve(mech, method=method)
    fine = api.for_plots(mech, res, method)
    # one computation of each figure for the whole report: the summary takes its limit
    # positions, transmission angles and torque figures from the sweep the figures
    # table and the plots are drawn from
    c.summary_text = res.summary(figures=fine, units=U)  # also runs the checks that warn
    c.incomplete = res.incomplete()
    c.figures = figures_table(fine, U)
    c.tables = position_tables(res, U)
    c.table_step = _table_step(mech, res, U) or c.table_step
    with tempfile.TemporaryDirectory(prefix="mechsolve-report-") as tmp:
        d = Path(tmp)
        draw_start(
            rep.analysis, rep.assembly.state, d / "start.png", f"{mech.name}: start position"
        )
        c.drawing = embed(d / "start.png", "The mechanism at the start position, to scale")
        pdir = d / "plots"
        pdir.mkdir()
        c.plots = [embed(p) for p in write_plots(fine, pdir, units=U)]
        if mech.motor is not None and mech.simulation is not None and simulate:
            _simulation_section(c, mech, d, U)
        if mech.driver is not None and not res.linear:
            _polygons_section(c, mech, d, polygons_at, U)
        if mech.requirements:
            c.verdicts = check_requirements(mech, res)
            c.requirements = verdict_rows(c.verdicts)
            c.failed_requirements = sum(not v.passed for v in c.verdicts)
    fr = solve_frames(mech, frames, forces=mech.needs_forces, method=method, units=U)
    c.animation = fr.to_json()
    return c


def _table_step(mech, res, units: OutputUnits | None = None) -> str | None:
    """How the position tables sample the motion (a linear driver's step in ``units``)."""
    n = len(res.u)
    if mech.driver.motion is not None or mech.sweep.duration is not None:
        return f"{n} positions in time"
    if n > 1:
        step = abs(float(res.u[1] - res.u[0]))
        if res.linear:
            k, L = (units or SI_OUTPUT).convert("m")
            return f"{n} positions, every {num(step * k)} {L}"
        return f"{n} positions, every {num(math.degrees(step))}° of the driver"
    return None


def _simulation_section(c: Content, mech, d: Path, units: OutputUnits | None = None) -> None:
    """The motor-driven start-up: its summary (in ``units``, default SI) and plots."""

    sim = run_simulation(mech)
    c.dynamics_text = sim.summary(units=units)
    sdir = d / "simulation"
    sdir.mkdir()
    plots = write_simulation_plots(sim, sim.model, sdir, units or SI_OUTPUT)
    c.dynamics_plots = [embed(p) for p in plots]
    c.incomplete = c.incomplete or sim.incomplete()


def _polygons_section(
    c: Content, mech, d: Path, polygons_at: str | int | None, units: OutputUnits | None = None
) -> None:
    """The velocity and acceleration polygons at one position, or why there are none."""
    # the graphical check at one position (default: position 2 of 12, 30 deg
    # after the start, where a mechanism that starts at a limit already moves)

    try:
        pol = draw_polygons(mech, 2 if polygons_at is None else polygons_at, d / "pol", units=units)
    except InputError as exc:  # a group the graphical method here does not draw
        if polygons_at is not None:
            raise
        c.polygons_problem = f"No polygons: {_plain(exc)}"
    except (
        SolverError,
        AssemblyError,
    ) as exc:  # the position lies where the mechanism cannot close
        c.polygons_problem = (
            f"No polygons: {_plain(exc)}. "
            + (
                "Position 2 (30° after the start) is only the default: "
                if polygons_at is None
                else ""
            )
            + "give a position the mechanism reaches with --polygons-at (a position "
            "number, 1 at the start, or a driver angle such as '100 deg')."
        )
        # asked for and not drawn: the report lacks it (warned); the default is not
        c.incomplete = c.incomplete or polygons_at is not None
    else:
        c.polygons_text = pol.text(units)
        c.polygons_images = [embed(p) for p in pol.images if p.suffix == ".png"]


def cam_content(path: Path, variant: str | None) -> Content:
    """A cam file (a ``cam:`` section, no links): the cam's summary and plots."""

    model = load_cam(path, variant)
    try:
        res = analyse(model)
    except ValueError as exc:
        raise InputError(str(exc), file=str(path), keypath="cam") from None
    c = Content(model.name, _description(load_file(path)), str(path), variant, "cam")
    c.cam_text = res.summary()
    c.cam_problems = list(res.problems)
    with tempfile.TemporaryDirectory(prefix="mechsolve-report-") as tmp:
        d = Path(tmp)
        c.cam_plots = [embed(p) for p in write_cam_plots(res, d)]
    return c
