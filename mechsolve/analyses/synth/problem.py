"""The synthesis problem file of ``mechsolve synth`` and what it produces.

A problem file names its units (as a mechanism file does) and one section, the method::

    name: dock crane, crank-rocker O1ABO3 (seed 000, task 2)
    units: {length: m, angle: deg}
    crank-rocker:
      rocker_pivot: [0, 0]
      rocker: 4.0
      limits: [93, 134]          # of the rocker's line pivot -> pin, or of the line below
      line: {offset: 25, point: C, length: 28.525}   # optional: the jib O3C, 25 deg CCW of O3B
      crank_pivot: [2.86, 4.0]   # extreme distances; or time_ratio: K [frame: d]
    round: 1 mm                  # optional: lengths in the written file rounded (as printed)
    pick: transmission           # or shortest-crank, smallest

Other sections: ``slider-crank: {stroke, time_ratio, offset}``, ``guide-bar: {frame,
crank, time_ratio, bar, stroke}`` (two of frame, crank, time_ratio), ``three-positions:
{positions: [[x, y, angle] x 3], moving_pivots: {A: [x, y], B: [x, y]}}`` (pivots in the
line's frame: origin at its point, x along it) and ``window: {mechanism, variant, point,
width, measure, within, compare}``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mechsolve.analyses.synth.common import RULES, Design, pick
from mechsolve.analyses.synth.writer import Numbers
from mechsolve.base.errors import InputError
from mechsolve.base.units import UnitError, parse_quantity
from mechsolve.model.source import Source, load_file

METHODS = (
    "crank-rocker",
    "slider-crank",
    "guide-bar",
    "three-positions",
    "four-positions",
    "five-positions",
    "window",
    "function",
    "path",
)
OPTIMISED = ("function", "path")
TOP = ("name", "units", "round", "pick", *METHODS)


@dataclass
class Outcome:
    """What a problem gives: the designs (all found), the one picked and its file; or,
    for a window problem, the report."""

    name: str
    method: str
    designs: list[Design] = field(default_factory=list)
    chosen: Design | None = None
    yaml: str | None = None
    check: dict[str, Any] = field(default_factory=dict)
    text: str = ""
    unit: str = "m"  # the problem's length unit: the written file's and the printed text's


class _Reader:
    def __init__(self, src: Source, section: str) -> None:
        self.src = src
        self.section = section
        self.data = src.data[section]
        units = src.data.get("units") or {}
        if not isinstance(units, dict):
            raise src.error(("units",), "expected a mapping such as {length: m, angle: deg}")
        self.length = units.get("length", "m")
        self.angle = units.get("angle", "deg")
        if not isinstance(self.data, dict):
            raise src.error((section,), "expected a mapping of the problem's values")

    def err(self, key: str | tuple, msg: str) -> InputError:
        path = (self.section,) + (key if isinstance(key, tuple) else (key,))
        return self.src.error(path, msg)

    def allow(self, keys: tuple[str, ...]) -> None:
        for k in self.data:
            if k not in keys:
                raise self.err(k, f"unknown key (expected one of: {', '.join(keys)})")

    def has(self, key: str) -> bool:
        return self.data.get(key) is not None

    def q(self, key: str | tuple, kind: str, value: Any = None, optional: bool = False):
        v = value if value is not None else self.data.get(key)
        if v is None:
            if optional:
                return None
            raise self.err(key, f"missing: give {kind}")
        unit = self.length if kind == "length" else self.angle if kind == "angle" else None
        try:
            return parse_quantity(v, kind, unit)
        except UnitError as exc:
            raise self.err(key, str(exc)) from None

    def number(self, key: str, optional: bool = False) -> float | None:
        v = self.data.get(key)
        if v is None:
            if optional:
                return None
            raise self.err(key, "missing: give a number")
        if isinstance(v, str):  # a number given as text ("1e6")
            try:
                v = float(v.strip())
            except ValueError:
                raise self.err(key, f"expected a number, got {v!r}") from None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise self.err(key, f"expected a number, got {v!r}")
        return float(v)

    def point(self, key: str | tuple, value: Any = None) -> tuple[float, float]:
        v = value if value is not None else self.data.get(key)
        if not (isinstance(v, list) and len(v) == 2):
            raise self.err(key, f"expected a point [x, y], got {v!r}")
        k = key if isinstance(key, tuple) else (key,)
        return (self.q(k + (0,), "length", v[0]), self.q(k + (1,), "length", v[1]))

    def pair(self, key: str, kind: str) -> tuple[float, float]:
        v = self.data.get(key)
        if not (isinstance(v, list) and len(v) == 2):
            raise self.err(key, f"expected two values [first, second], got {v!r}")
        return (self.q((key, 0), kind, v[0]), self.q((key, 1), kind, v[1]))

    def wrap(self, key: str, fn, *args, **kw):
        """Call a synthesis function; its InputError names this section and key."""
        try:
            return fn(*args, **kw)
        except InputError as exc:
            if exc.file:
                raise
            raise self.err(getattr(exc, "problem_key", key), exc.message) from None


def read(path: str | Path) -> tuple[Source, str]:
    src = load_file(path)
    if not isinstance(src.data, dict):
        raise src.error((), "a synthesis problem is a mapping with one method section")
    for k in src.data:
        if k not in TOP:
            raise src.error((k,), f"unknown key (expected one of: {', '.join(TOP)})")
    found = [m for m in METHODS if m in src.data]
    if len(found) != 1:
        raise src.error(
            (), f"give exactly one method section: {', '.join(METHODS)} (found {len(found)})"
        )
    return src, found[0]


def solve_problem(
    path: str | Path,
    rule: str | None = None,
    solution: int | None = None,
    *,
    seed: int | None = 0,
    max_time: float | None = None,
    progress=None,
    digits: int | None = None,
) -> Outcome:
    """Read a problem file, solve it, pick a design (by ``rule``, or the ``solution``-th
    listed, from 1) and write its mechanism text: lengths in the problem's unit, every
    digit (``None``: the shortest decimal that reads back as the same float, so the file
    reproduces the design to rounding) or ``digits`` significant digits (the file's
    ``round`` rounds the lengths instead). ``seed``, ``max_time`` (s) and ``progress`` (called
    with the generation and the best objective) are for the optimising methods
    (function, path)."""
    from mechsolve.analyses.synth.writer import mechanism_yaml

    src, method = read(path)
    name = str(src.data.get("name") or Path(path).stem)
    if method in OPTIMISED:
        return _solve_optimised(src, method, name, rule, solution, seed, max_time, progress, digits)
    rule = rule or src.data.get("pick") or "transmission"
    if rule not in RULES:
        raise src.error(("pick",), f"unknown rule {rule!r}: choose one of {', '.join(RULES)}")
    round_to = None
    if src.data.get("round") is not None:
        try:
            round_to = parse_quantity(src.data["round"], "length", "m")
        except UnitError as exc:
            raise src.error(("round",), str(exc)) from None
        if not round_to > 0:
            raise src.error(("round",), "the rounding step must be positive")
    r = _Reader(src, method)
    if method == "window":
        return _window(r, Path(path), name)
    kw: dict[str, Any] = {}
    if method == "crank-rocker":
        designs, kw = _crank_rocker(r)
    elif method == "slider-crank":
        designs = _slider_crank(r)
    elif method == "guide-bar":
        designs = _guide_bar(r)
    elif method == "four-positions":
        designs = _four_positions(r)
    elif method == "five-positions":
        designs = _five_positions(r)
    else:
        designs = _three_positions(r)
    if solution is not None:
        if not 1 <= solution <= len(designs):
            raise InputError(
                f"--solution {solution}: the problem has {len(designs)} solution(s), "
                f"numbered 1 to {len(designs)}"
            )
        chosen = designs[solution - 1]
        if not chosen.valid:
            raise InputError(f"--solution {solution} is not valid: {'; '.join(chosen.notes)}")
        rule = "solution"
    else:
        try:
            chosen = pick(designs, rule)
        except InputError as exc:
            raise r.err((), exc.message) from None
    text = mechanism_yaml(chosen, name, round_to, unit=r.length, digits=digits, **kw)
    out = Outcome(name, method, designs, chosen, text, unit=r.length)
    out.text = describe(out, rule)
    return out


def _solve_optimised(
    src, method: str, name: str, rule, solution, seed, max_time, progress, digits=None
):
    """A problem solved by optimisation (function, path generation): its designs are
    listed by their error, at full precision (no ``pick`` rule, no rounding)."""
    from mechsolve.analyses.synth.optproblem import solve_optimised

    if rule is not None:
        raise InputError(
            f"--pick: a {method} problem lists its designs by their error; "
            "use --solution N to write another one"
        )
    for k in ("pick", "round"):
        if src.data.get(k) is not None:
            raise src.error(
                (k,),
                f"not for a {method} problem (its designs are listed "
                "by their error, at full precision)",
            )
    from mechsolve.analyses.synth.optproblem import describe_optimised

    r = _Reader(src, method)
    designs, chosen, text, check = solve_optimised(
        r, method, name, solution, digits, seed=seed, max_time=max_time, progress=progress
    )
    out = Outcome(name, method, designs, chosen, text, check, unit=r.length)
    out.text = describe_optimised(out)
    return out


def _crank_rocker(r: _Reader):
    from mechsolve.analyses.synth.fourbar import extreme_distance, from_time_ratio

    r.allow(("rocker_pivot", "rocker", "limits", "limit", "line", "crank_pivot", "time_ratio",
             "frame"))  # fmt: skip
    o3 = r.point("rocker_pivot")
    c = r.q("rocker", "length")
    if r.has("limit") and r.has("limits"):
        raise r.err("limit", "give both limits ('limits') or one and the time ratio ('limit')")
    if r.has("limit"):
        psi1 = psi2 = r.q("limit", "angle")
    else:
        psi1, psi2 = r.pair("limits", "angle")
    offset, kw = 0.0, {}
    line = r.data.get("line")
    if line is not None:
        if not isinstance(line, dict):
            raise r.err("line", "expected {offset: angle, point: name, length: length}")
        for k in line:
            if k not in ("offset", "point", "length"):
                raise r.err(("line", k), "unknown key (expected offset, point, length)")
        offset = r.q(("line", "offset"), "angle", line.get("offset"))
        if line.get("point") is not None:
            pname = line["point"]
            if not (isinstance(pname, str) and pname.isidentifier()) or pname in (
                "O1",
                "O3",
                "A",
                "B",
            ):
                raise r.err(("line", "point"), f"{pname!r}: a new point name, such as C")
            kw["rocker_point"] = (
                pname,
                r.q(("line", "length"), "length", line.get("length")),
                offset,
            )
    a, b = psi1 - offset, psi2 - offset
    if r.has("limit"):  # one limit, K and both pivots (or the frame along x)
        from mechsolve.analyses.synth.fourbar import from_one_limit

        if not r.has("time_ratio"):
            raise r.err((), "with one rocker limit ('limit') give the time ratio 'time_ratio'")
        if r.has("crank_pivot") == r.has("frame"):
            raise r.err(
                (),
                "with one rocker limit give the crank pivot: 'crank_pivot', or 'frame' "
                "(the crank pivot that far from the rocker pivot along -x)",
            )
        if r.has("crank_pivot"):
            o1 = r.point("crank_pivot")
        else:
            d = r.q("frame", "length")
            if not d > 0:
                raise r.err("frame", "the frame length must be positive")
            o1 = (o3[0] - d, o3[1])
        designs = r.wrap("time_ratio", from_one_limit, o1, o3, c, a, r.number("time_ratio"))
        for dsg in designs:
            dsg.extra["line_offset"] = offset
        return designs, kw
    if r.has("crank_pivot") == r.has("time_ratio"):
        raise r.err((), "give crank_pivot (extreme distances) or time_ratio, one of them")
    if r.has("crank_pivot"):
        if r.has("frame"):
            raise r.err("frame", "the frame follows from crank_pivot: leave it out")
        designs = r.wrap("limits", extreme_distance, r.point("crank_pivot"), o3, c, a, b)
    else:
        k = r.number("time_ratio")
        frame = r.q("frame", "length", optional=True)
        designs = r.wrap("time_ratio", from_time_ratio, o3, c, a, b, k, frame)
    for d in designs:
        d.extra["line_offset"] = offset
    return designs, kw


def _slider_crank(r: _Reader):
    from mechsolve.analyses.synth.slidercrank import slider_crank

    r.allow(("stroke", "time_ratio", "offset"))
    return r.wrap(
        "time_ratio",
        slider_crank,
        r.q("stroke", "length"),
        r.number("time_ratio"),
        r.q("offset", "length", optional=True),
    )


def _guide_bar(r: _Reader):
    from mechsolve.analyses.synth.guidebar import guide_bar

    r.allow(("frame", "crank", "time_ratio", "bar", "stroke"))
    return r.wrap(
        "frame",
        guide_bar,
        frame=r.q("frame", "length", optional=True),
        crank=r.q("crank", "length", optional=True),
        k=r.number("time_ratio", optional=True),
        bar=r.q("bar", "length", optional=True),
        stroke=r.q("stroke", "length", optional=True),
    )


def _three_positions(r: _Reader):
    from mechsolve.analyses.synth.motion_gen import three_positions

    r.allow(("positions", "moving_pivots"))
    pos = r.data.get("positions")
    if not (isinstance(pos, list) and len(pos) == 3):
        raise r.err("positions", "expected three positions [x, y, angle] of the coupler line")
    positions = []
    for i, p in enumerate(pos):
        if not (isinstance(p, list) and len(p) == 3):
            raise r.err(("positions", i), f"expected [x, y, angle], got {p!r}")
        positions.append(
            (
                (
                    r.q(("positions", i, 0), "length", p[0]),
                    r.q(("positions", i, 1), "length", p[1]),
                ),
                r.q(("positions", i, 2), "angle", p[2]),
            )
        )
    mp = r.data.get("moving_pivots")
    if not (isinstance(mp, dict) and set(mp) == {"A", "B"}):
        raise r.err("moving_pivots", "expected {A: [x, y], B: [x, y]} in the line's frame")
    pa, pb = r.point(("moving_pivots", "A"), mp["A"]), r.point(("moving_pivots", "B"), mp["B"])
    return r.wrap("positions", three_positions, positions, pa, pb)


def _poses(r: _Reader, n: int) -> list:
    pos = r.data.get("positions")
    if not (isinstance(pos, list) and len(pos) == n):
        got = len(pos) if isinstance(pos, list) else 0
        raise r.err(
            "positions", f"expected {n} positions [x, y, angle] of the coupler line, got {got}"
        )
    out = []
    for i, p in enumerate(pos):
        if not (isinstance(p, list) and len(p) == 3):
            raise r.err(("positions", i), f"expected [x, y, angle], got {p!r}")
        xy = (r.q(("positions", i, 0), "length", p[0]), r.q(("positions", i, 1), "length", p[1]))
        out.append((xy, r.q(("positions", i, 2), "angle", p[2])))
    return out


def _four_positions(r: _Reader):
    from mechsolve.analyses.synth.burmester import four_positions

    r.allow(("positions", "pivots"))
    poses = _poses(r, 4)
    pv = r.data.get("pivots")
    if not (isinstance(pv, dict) and set(pv) == {"A", "B"}):
        raise r.err(
            "pivots",
            "expected {A: [x, y], B: [x, y]}: near where the fixed pivots should be "
            "(each moves to the nearest point of the centre-point curve)",
        )
    near_a, near_b = r.point(("pivots", "A"), pv["A"]), r.point(("pivots", "B"), pv["B"])
    return r.wrap("positions", four_positions, poses, near_a, near_b)


def _five_positions(r: _Reader):
    from mechsolve.analyses.synth.burmester5 import five_positions

    r.allow(("positions",))
    return r.wrap("positions", five_positions, _poses(r, 5))


def _window(r: _Reader, path: Path, name: str) -> Outcome:
    from mechsolve.analyses.synth.window import MEASURES, choose_window, report
    from mechsolve.model.parse import load

    r.allow(("mechanism", "variant", "point", "width", "measure", "within", "compare"))
    file = r.data.get("mechanism")
    if not isinstance(file, str):
        raise r.err("mechanism", "expected the mechanism file's path (relative to this file)")
    mpath = (path.parent / file) if not Path(file).is_absolute() else Path(file)
    variant = r.data.get("variant")
    mech = load(mpath, variant)
    measure = r.data.get("measure", "y-range")
    if measure not in MEASURES:
        raise r.err("measure", f"unknown measure {measure!r}: choose one of {', '.join(MEASURES)}")
    point = r.data.get("point")
    if not isinstance(point, str):
        raise r.err("point", "expected the name of the point whose path is measured")
    within = r.pair("within", "angle") if r.has("within") else None
    compare = []
    for i, w in enumerate(r.data.get("compare") or []):
        if not (isinstance(w, list) and len(w) == 2):
            raise r.err(("compare", i), f"expected [start, end], got {w!r}")
        compare.append(
            (r.q(("compare", i, 0), "angle", w[0]), r.q(("compare", i, 1), "angle", w[1]))
        )
    ch = r.wrap(
        "point", choose_window, mech, point, r.q("width", "angle"), measure, within, compare=compare
    )
    out = Outcome(name, "window")
    out.check = {"choice": ch}
    out.text = report(ch)
    return out


def describe(out: Outcome, rule: str) -> str:
    """The designs as a table, the rule and the choice."""
    lines = [f"{out.name}: {out.method}, {len(out.designs)} solution(s)"]
    f = Numbers(out.unit)
    for i, d in enumerate(out.designs, 1):
        lens = ", ".join(f"{k} {f.text(v)}" for k, v in d.lengths.items())
        mark = "*" if d is out.chosen else " "
        status = "" if d.valid else " INVALID: " + "; ".join(d.notes)
        k = f", K = {d.time_ratio:.6f}" if d.time_ratio else ""
        g = ", ".join(f"{n} ({f.text(p[0])}, {f.text(p[1])})" for n, p in d.ground.items())
        lines.append(f" {mark}{i}. {d.family}: {lens}; pivots {g}")
        mu = (
            f"{math.degrees(d.min_transmission):.4f} deg"
            if math.isfinite(d.min_transmission)
            else "- (the loop does not close)"
        )
        lines.append(f"     {d.grashof}; minimum transmission angle {mu}{k}{status}")
    rules = {
        "transmission": "the largest minimum transmission angle",
        "shortest-crank": "the shortest input link",
        "smallest": "the smallest sum of link lengths",
        "solution": "its number, as asked (--solution)",
    }
    lines.append(f"  picked (*) by {rules[rule]}")
    return "\n".join(lines)


def confirm(out: Outcome) -> str:
    """Solve the written mechanism with mechsolve's own solver and say what its run
    reports: the limit positions (and time ratio) the design was made for."""
    from mechsolve.model.parse import loads
    from mechsolve.results.run import solve

    if out.method in OPTIMISED:
        from mechsolve.analyses.synth.optproblem import confirm_optimised

        return confirm_optimised(out)
    if out.method in ("four-positions", "five-positions"):
        from mechsolve.analyses.synth.burmester import confirm_poses

        return confirm_poses(out)
    d = out.chosen
    res = solve(loads(out.yaml))
    lims = res.limit_positions()
    parts = []
    for lp in lims:
        if lp.kind == "rocker":
            off = math.degrees(d.extra.get("line_offset", 0.0)) if lp.name == "rocker" else 0.0
            lo, hi = math.degrees(lp.low) + off, math.degrees(lp.high) + off
            what = "the line" if off else lp.name
            parts.append(f"{what} {lo:.6f} .. {hi:.6f} deg (swing {hi - lo:.6f} deg)")
        else:
            f = Numbers(out.unit)
            parts.append(
                f"{lp.name} {f.text(lp.low)} .. {f.text(lp.high)} (stroke {f.text(lp.swing)})"
            )
        if lp.time_ratio is not None:
            parts[-1] += f", K = {lp.time_ratio:.6f}"
    tr = res.transmission_angles()
    if tr:
        parts.append(
            "minimum transmission angle "
            + ", ".join(f"{math.degrees(t.angle):.4f} deg" for t in tr)
        )
    out.check = {"limits": lims, "transmission": tr}
    return "  mechsolve run of the written file: " + "; ".join(parts)
