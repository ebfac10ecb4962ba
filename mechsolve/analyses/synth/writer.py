"""Ready mechanism files (the existing model format of ``mechanisms/*.yaml``) for the
designs of :mod:`mechsolve.analyses.synth`: ``mechsolve run`` solves them and its summary gives
the limit positions, time ratio and minimum transmission angle that confirm the design."""

from __future__ import annotations

import math
from dataclasses import dataclass

from mechsolve.analyses.synth.common import Design
from mechsolve.base.units import parse_unit

__all__ = ["SIGNIFICANT", "Numbers", "mechanism_yaml", "num"]


SIGNIFICANT = 6  # digits of a written length or angle that no rounding step fixes


def num(x: float, round_to: float | None = None, unit: str = "m", digits: int | None = None) -> str:
    """A length (SI, written in ``unit``) or an angle in deg as YAML text: to ``digits``
    significant digits (full precision when ``None``), or rounded to a multiple of
    ``round_to`` (m; the seed rounds its lengths to 1 mm)."""
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


@dataclass(frozen=True)
class Numbers:
    """How a design's file writes its numbers: lengths in ``unit`` (the problem's), to
    :data:`SIGNIFICANT` digits or rounded to ``round_to`` (m); angles in deg."""

    unit: str = "m"
    round_to: float | None = None
    digits: int | None = SIGNIFICANT

    def len(self, x: float) -> str:
        return num(x, self.round_to, self.unit, self.digits)

    def ang(self, deg: float) -> str:
        return num(deg, None, "m", self.digits)

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
        f"{math.degrees(d.min_transmission):.4f} deg"
        + (f"; time ratio K = {d.time_ratio:.6f}" if d.time_ratio else "")
        + ".",
    ]
    if f.round_to:
        lines.append(f"# Lengths rounded to {f.text(f.round_to)}.")
    elif f.digits:
        lines.append(f"# Lengths and angles to {f.digits} significant digits.")
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
    if "crank" in d.lengths and "rocker" in d.lengths:
        return _crank_rocker(d, name, f, **kw)
    if "rod" in d.lengths:
        return _slider_crank(d, name, f)
    if "input" in d.lengths:
        return _three_positions(d, name, f)
    return _guide_bar(d, name, f)


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
    out += [
        f"# The input {i0n}-{a_name} at {', '.join(f'{a:.6f}' for a in ang)} deg puts the "
        f"coupler line (P, Q) in positions {', '.join(str(i) for i in range(1, n + 1))}.",
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
    return "\n".join(out)
