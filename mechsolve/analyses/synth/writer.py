"""Ready mechanism files (the existing model format of ``mechanisms/*.yaml``) for the
designs of :mod:`mechsolve.analyses.synth`: ``mechsolve run`` solves them and its summary gives
the limit positions, time ratio and minimum transmission angle that confirm the design."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from mechsolve.analyses.synth.common import Design
from mechsolve.base.units import parse_unit

__all__ = ["Numbers", "mechanism_yaml", "num", "read_back"]


def num(x: float, round_to: float | None = None, unit: str = "m", digits: int | None = None) -> str:
    """A length (SI, written in ``unit``) or an angle in deg as YAML text: to ``digits``
    significant digits, or rounded to a multiple of ``round_to`` (m; the seed rounds its
    lengths to 1 mm); when neither is given, the shortest decimal that reads back as the
    same float (``repr``), so that the file reproduces the design to rounding."""
    scale = parse_unit(unit).factor
    if round_to:
        step = round_to / scale
        places = max(0, -math.floor(math.log10(step) + 1e-12))
        v = round(x / round_to) * step
        return f"{v:.{places}f}"
    v = x / scale
    if v == 0:
        return "0"
    if digits is None:
        return repr(float(v))
    return format(float(v), f".{digits}g")


def read_back(text: str, unit: str = "m") -> float:
    """The value (SI for a length in ``unit``) a number written by :func:`num` stands
    for: what ``mechsolve run`` of the file reads."""
    return float(text) * parse_unit(unit).factor


@dataclass(frozen=True)
class Numbers:
    """How a design's file writes its numbers: lengths in ``unit`` (the problem's), every
    digit (``digits`` None, the default), to ``digits`` significant digits or rounded to
    ``round_to`` (m); angles in deg."""

    unit: str = "m"
    round_to: float | None = None
    digits: int | None = None

    def len(self, x: float) -> str:
        return num(x, self.round_to, self.unit, self.digits)

    def ang(self, deg: float) -> str:
        return num(deg, None, "m", self.digits)

    def written(self, x: float) -> float:
        """The length (m) the file holds for the design's ``x`` (m): ``x`` itself to
        rounding unless the numbers are rounded."""
        return read_back(self.len(x), self.unit)

    def written_deg(self, deg: float) -> float:
        """The angle (deg) the file holds for the design's ``deg``."""
        return float(self.ang(deg))

    def xy(self, p) -> str:
        x, y = (num(c, None, self.unit, self.digits) for c in p[:2])
        return f"[{x}, {y}]"

    def text(self, x: float) -> str:
        """A length for a comment or the printed text, to the micrometre: ``47.245 mm``,
        ``1.387798 m``."""
        scale = parse_unit(self.unit).factor
        places = max(0, 6 + round(math.log10(scale)))
        text = f"{x / scale:.{places}f}"
        if text.startswith("-") and float(text) == 0.0:
            text = text[1:]  # no "-0.000 mm" for a coordinate rounded to zero
        return f"{text} {self.unit}"

    @property
    def factor(self) -> float:
        """Metres per ``unit``: a length in SI divided by it is the number shown."""
        return parse_unit(self.unit).factor

    @property
    def units_line(self) -> str:
        return f"units: {{length: {self.unit}, angle: deg}}"


def _header(d: Design, title: str, f: Numbers) -> list[str]:
    lines = [
        f"# {title}",
        f"# Written by mechsolve synth ({d.method}; {d.family}).",
        f"# Grashof: {d.grashof}; minimum transmission angle "
        + (
            f"{math.degrees(d.min_transmission):.4f} deg"
            if math.isfinite(d.min_transmission)
            else "not determined"
        )
        + (
            (
                f"; time ratio K = {d.time_ratio:.6f}"
                if math.isfinite(d.time_ratio)
                else "; time ratio not determined"
            )
            if d.time_ratio
            else ""
        )
        + ".",
    ]
    if f.round_to:
        lines.append(
            f"# Lengths rounded to {f.text(f.round_to)} (the figures above: mechsolve's run "
            "of the numbers as written)."
        )
    elif f.digits:
        lines.append(
            f"# Lengths and angles to {f.digits} significant digits (the figures above: "
            "mechsolve's run of the numbers as written)."
        )
    lines.append("# `mechsolve run` on this file reports the limit positions it was designed for.")
    return lines


def mechanism_yaml(
    d: Design,
    name: str,
    round_to: float | None = None,
    unit: str = "m",
    digits: int | None = None,
    **kw,
) -> str:
    """The mechanism file of a design, as text: lengths in ``unit`` (the problem's), to
    ``digits`` significant digits (full precision for ``None``) or rounded to
    ``round_to`` (m)."""
    f = Numbers(unit, round_to, digits)
    text = _family(d, name, f, **kw)
    if f.round_to or f.digits:
        # rounded numbers: the header's figures are those of the file as written
        text = _family(_as_written(d, text), name, f, **kw)
    return text


def _family(d: Design, name: str, f: Numbers, **kw) -> str:
    if "crank" in d.lengths and "rocker" in d.lengths:
        return _crank_rocker(d, name, f, **kw)
    if "rod" in d.lengths:
        return _slider_crank(d, name, f)
    if "input" in d.lengths:
        return _three_positions(d, name, f)
    return _guide_bar(d, name, f)


def _as_written(d: Design, text: str) -> Design:
    """``d`` with the minimum transmission angle and time ratio of the mechanism file
    ``text`` (its rounded numbers), by mechsolve's run of it."""
    from mechsolve.model.parse import loads
    from mechsolve.results.run import solve

    res = solve(loads(text))
    mu = [t.angle for t in res.transmission_angles()]
    k = [lp.time_ratio for lp in res.limit_positions() if lp.time_ratio is not None]
    return replace(
        d,
        min_transmission=min(mu) if mu else math.nan,
        time_ratio=(k[0] if k else math.nan) if d.time_ratio else d.time_ratio,
    )


def _crank_rocker(
    d: Design,
    name: str,
    f: Numbers,
    rocker_point: tuple[str, float, float] | None = None,
) -> str:
    """A crank-rocker O1-A-B-O3; ``rocker_point`` (name, length, angle from O3->B in rad)
    adds a point of the rocker (the crane's jib end C)."""
    L = d.lengths
    o1, o3 = d.ground["O1"], d.ground["O3"]
    side = "left" if d.extra["B_left_of_O3_A"] else "right"
    rocker_pts = f"{{O3: [0, 0], B: [{f.len(L['rocker'])}, 0]"
    if rocker_point:
        pname, plen, pang = rocker_point
        rocker_pts += f", {pname}: {{length: {f.len(plen)}, angle: {f.ang(math.degrees(pang))}}}"
    rocker_pts += "}"
    psi = [math.degrees(p) for p in d.extra["limits"]]
    out = _header(d, f"{name}: crank-rocker O1-A-B-O3", f) + [
        f"# Designed for the rocker O3->B at {psi[0]:.6f} and {psi[1]:.6f} deg.",
        f"name: {name}",
        f.units_line,
        "",
        "ground:",
        f"  O1: {f.xy(o1)}",
        f"  O3: {f.xy(o3)}",
        "",
        "links:",
        f"  crank: {{points: {{O1: [0, 0], A: [{f.len(L['crank'])}, 0]}}}}",
        f"  coupler: {{points: {{A: [0, 0], B: [{f.len(L['coupler'])}, 0]}}}}",
        f"  rocker: {{points: {rocker_pts}}}",
        "",
        "joints:",
        "  O1: [ground, crank]",
        "  A: [crank, coupler]",
        "  B: [coupler, rocker]",
        "  O3: [ground, rocker]",
        "",
        "assembly:",
        f"  - B {side} of O3 -> A",
        "",
        "driver: {joint: O1, speed: 1 rad/s, start: 0 deg}",
        "sweep: {range: 360 deg, step: 1 deg}",
        "",
    ]
    return "\n".join(out)


def _slider_crank(d: Design, name: str, f: Numbers) -> str:
    L = d.lengths
    x1, x2 = d.extra["limits_x"]
    out = _header(d, f"{name}: offset slider-crank O-A-C", f) + [
        f"# Designed for the slider's limits x = {f.text(x1)} and {f.text(x2)} "
        f"(stroke {f.text(x2 - x1)}) on the line y = {f.text(L['offset'])}.",
        f"name: {name}",
        f.units_line,
        "",
        "ground:",
        "  O: [0, 0]",
        "",
        "links:",
        f"  crank: {{points: {{O: [0, 0], A: [{f.len(L['crank'])}, 0]}}}}",
        f"  rod: {{points: {{A: [0, 0], C: [{f.len(L['rod'])}, 0]}}}}",
        "  slider: {points: {C: [0, 0]}}",
        "",
        "joints:",
        "  O: [ground, crank]",
        "  A: [crank, rod]",
        "  C: [rod, slider]",
        f"  guide: {{slider: [ground, slider], point: C, line: {{through: "
        f"[0, {f.len(L['offset'])}], angle: 0}}}}",
        "",
        "assembly:",
        "  - C.x > A.x",
        "",
        "driver: {joint: O, speed: 1 rad/s, start: 0 deg}",
        "sweep: {range: 360 deg, step: 1 deg}",
        "",
    ]
    return "\n".join(out)


def _guide_bar(d: Design, name: str, f: Numbers) -> str:
    L = d.lengths
    bar = L.get("bar", L["frame"] + L["crank"])
    out = _header(d, f"{name}: oscillating guide bar (slotted lever)", f) + [
        f"# The bar swings {math.degrees(d.extra['swing']):.6f} deg"
        + (
            f"; its end B sweeps a chord of {f.text(d.extra['stroke'])}."
            if d.extra["stroke"]
            else "."
        ),
        f"name: {name}",
        f.units_line,
        "",
        "ground:",
        "  O4: [0, 0]",
        f"  O2: [0, {f.len(L['frame'])}]",
        "",
        "links:",
        f"  crank: {{points: {{O2: [0, 0], A: [{f.len(L['crank'])}, 0]}}}}",
        "  block: {points: {A: [0, 0]}}",
        f"  guide_bar: {{points: {{O4: [0, 0], B: [{f.len(bar)}, 0]}}}}",
        "",
        "joints:",
        "  O2: [ground, crank]",
        "  A: [crank, block]",
        "  slot: {slider: [guide_bar, block], point: A, line: [O4, B]}",
        "  O4: [ground, guide_bar]",
        "",
        "driver: {joint: O2, speed: 1 rad/s, start: 0 deg}",
        "sweep: {range: 360 deg, step: 1 deg}",
        "",
    ]
    return "\n".join(out)


def _three_positions(d: Design, name: str, f: Numbers) -> str:
    """The four-bar A0-A-B-B0; the coupler carries the line's point P and a point Q one
    metre along the line, so that the run gives the line's positions."""
    L = d.lengths
    inp = d.extra["input"]
    ip, op = d.extra["moving"]
    a_name, b_name = ("A", "B") if inp == "A0" else ("B", "A")
    i0, o0 = (d.ground["A0"], d.ground["B0"]) if inp == "A0" else (d.ground["B0"], d.ground["A0"])
    i0n, o0n = inp, ("B0" if inp == "A0" else "A0")
    (p1, phi1) = d.extra["positions"][0]
    # P and Q in the coupler's frame (origin at the input's pin, x towards the other pin)
    ax, ay = ip[0]
    bx, by = op[0]
    base = math.atan2(by - ay, bx - ax)
    c, s = math.cos(base), math.sin(base)

    def local(p):
        dx, dy = p[0] - ax, p[1] - ay
        return (c * dx + s * dy, -s * dx + c * dy)

    P = local(p1)
    Q = local((p1[0] + math.cos(phi1), p1[1] + math.sin(phi1)))
    ang = [math.degrees(a) for a in d.extra["input_angles"]]
    direction = "ccw" if d.extra["direction"] > 0 else "cw"
    side = "left" if d.extra["output_left"] else "right"
    n = len(d.extra["positions"])
    words = {3: "three", 4: "four", 5: "five"}
    out = _header(d, f"{name}: four-bar through {words.get(n, n)} positions of a coupler line",
                  f)  # fmt: skip
    shown = [f.ang(a) for a in ang]  # as written, and solved so below
    out += [
        f"# The input {i0n}-{a_name} at {', '.join(shown)} deg puts the "
        f"coupler line (P, Q) in positions {', '.join(str(i) for i in range(1, n + 1))}.",
    ]
    body = [
        f"name: {name}",
        f.units_line,
        "",
        "ground:",
        f"  {i0n}: {f.xy(i0)}",
        f"  {o0n}: {f.xy(o0)}",
        "",
        "links:",
        f"  input: {{points: {{{i0n}: [0, 0], {a_name}: [{f.len(L['input'])}, 0]}}}}",
        f"  coupler: {{points: {{{a_name}: [0, 0], {b_name}: [{f.len(L['coupler'])}, 0],"
        f" P: {f.xy(P)}, Q: {f.xy(Q)}}}}}",
        f"  output: {{points: {{{o0n}: [0, 0], {b_name}: [{f.len(L['output'])}, 0]}}}}",
        "",
        "joints:",
        f"  {i0n}: [ground, input]",
        f"  {a_name}: [input, coupler]",
        f"  {b_name}: [coupler, output]",
        f"  {o0n}: [ground, output]",
        "",
        "assembly:",
        f"  - {b_name} {side} of {o0n} -> {a_name}",
        "",
        f"driver: {{joint: {i0n}, speed: 1 rad/s, direction: {direction}, "
        f"start: {f.ang(ang[0])} deg}}",
        f"sweep: {{range: {f.ang(math.degrees(d.extra['travel']))} deg, step: 1 deg}}",
        "",
        "outputs:",
        "  points: [P, Q]",
        "",
    ]
    err = _pose_errors("\n".join(body), d, [math.radians(float(a)) for a in shown], f)
    return "\n".join([*out, err, *body])


def _pose_errors(text: str, d: Design, angles: list[float], f: Numbers) -> str:
    """The header's line of the largest errors of the positions reached by the mechanism
    ``text`` (the file's numbers as written) at the input ``angles`` (rad): P's distance
    from the target and the line's angle (P -> Q) from the target's."""
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.model.parse import loads

    res = solve_instants(loads(text), [Instant(a, 1.0, 0.0) for a in angles], forces=False)
    p, q = res.point("P"), res.point("Q")
    dist, turn = [], []
    for i, (pt, phi) in enumerate(d.extra["positions"]):
        dist.append(math.hypot(p.x[i] - pt[0], p.y[i] - pt[1]))
        line = math.atan2(q.y[i] - p.y[i], q.x[i] - p.x[i])
        turn.append(abs((line - phi + math.pi) % (2 * math.pi) - math.pi))
    if not all(map(math.isfinite, dist + turn)):
        return "# The file as written does not reach every position (it does not close there)."
    what = "every digit written" if not (f.digits or f.round_to) else "rounded numbers"
    return (
        f"# Largest error of the positions: P {max(dist) / f.factor:.3e} {f.unit}, the line "
        f"{math.degrees(max(turn)):.3e} deg (mechsolve's solution of the numbers as written: "
        f"{what})."
    )
