"""Reading a cam's follower, motion program and base values from a file's mapping: shared
by ``mechsolve cam`` (:mod:`mechsolve.analyses.cam.model`) and the cam contact inside a
linkage (:mod:`mechsolve.joints.cam_contact`). ``r`` is the model's file reader (its
``fail``, ``mapping``, ``positive``, ``quantity``); every mistake is an error naming the
file, the key and its line.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from mechsolve.base.cam.laws import NAMES_HELP, find_law
from mechsolve.base.cam.profile import Follower, base_radius_of, start_angle_of
from mechsolve.base.cam.program import Program, build_program

Reader = Any  # the model's file reader (mechsolve.model.reader.Reader)
FOLLOWER_KEYS = ("type", "arm", "roller_radius", "offset", "face_offset", "face_margin")
SENSES = {
    "cw": -1,
    "clockwise": -1,
    "ccw": 1,
    "counterclockwise": 1,
    "counter-clockwise": 1,
    "anticlockwise": 1,
}
TYPES = [
    f"{k} {c}"
    for k in ("translating", "oscillating")
    for c in ("knife-edge", "roller", "flat-faced")
    if not (k == "oscillating" and c == "knife-edge")
]
TOL_BASE = 0.005  # relative: a, phi0 and r0 as printed (rounded) must agree this well


@dataclass(frozen=True)
class LengthUnit:
    """The unit the results' lengths are given in: the file's (``factor`` metres each)."""

    name: str = "mm"
    factor: float = 1e-3

    def __call__(self, x):
        """``x`` (m) in this unit."""
        return x / self.factor

    @property
    def metric(self) -> bool:
        return self.name in METRIC

    @property
    def speed(self) -> str:
        """The unit of the follower's velocity (its acceleration adds ^2, jerk ^3): m/s
        for a metric file, as textbooks give it; in/s, ft/s for the others."""
        return "m" if self.metric else self.name


METRIC = ("m", "mm", "cm", "dm", "km", "um")
MM = LengthUnit()


def _norm(text: str) -> str:
    return " ".join(str(text).lower().replace("_", " ").replace("knife edge", "knife-edge")
                    .replace("flat faced", "flat-faced").replace("flat face", "flat-faced")
                    .split())  # fmt: skip


def read_follower(r: Reader, cam: Mapping, p: tuple) -> tuple:
    """The follower under ``cam["follower"]`` at key path ``p``: (kind, contact, roller
    radius, arm, offset, face margin or None), SI."""
    fm = r.mapping(cam["follower"], p + ("follower",), FOLLOWER_KEYS, "'follower'", ("type",))
    ftype = _norm(fm["type"]) if isinstance(fm["type"], str) else ""
    words = ftype.split()
    if len(words) == 1 and words[0] in ("knife-edge", "roller", "flat-faced"):
        words = ["translating", words[0]]
    if len(words) != 2 or " ".join(words) not in TYPES:
        raise r.fail(
            p + ("follower", "type"),
            f"unknown follower type {fm['type']!r}; known: {', '.join(TYPES)}",
        )
    kind, contact = words
    osc = kind == "oscillating"
    fp = p + ("follower",)
    roller = 0.0
    if contact == "roller":
        if "roller_radius" not in fm:
            raise r.fail(fp, "a roller follower needs 'roller_radius'")
        roller = r.positive(fm["roller_radius"], fp + ("roller_radius",), "length")
    elif "roller_radius" in fm:
        raise r.fail(fp + ("roller_radius",), f"a {contact} follower has no roller")
    arm = 0.0
    if osc:
        if "arm" not in fm:
            raise r.fail(fp, "an oscillating follower needs 'arm' (its length l)")
        arm = r.positive(fm["arm"], fp + ("arm",), "length")
        if "offset" in fm:
            raise r.fail(fp + ("offset",), "an oscillating follower has no offset; "
                         "a flat face's distance from the pivot is 'face_offset'")  # fmt: skip
    elif "arm" in fm:
        raise r.fail(fp + ("arm",), "a translating follower has no arm")
    offset = 0.0
    if "offset" in fm:
        offset = r.quantity(fm["offset"], fp + ("offset",), "length")
    if "face_offset" in fm:
        if not (osc and contact == "flat-faced"):
            raise r.fail(fp + ("face_offset",), "only an oscillating flat face has a face_offset")
        offset = r.quantity(fm["face_offset"], fp + ("face_offset",), "length")
    face_margin = None
    if "face_margin" in fm:
        if contact != "flat-faced":
            raise r.fail(fp + ("face_margin",), "only a flat face has a face_margin")
        face_margin = r.positive(fm["face_margin"], fp + ("face_margin",), "length",
                                 allow_zero=True)  # fmt: skip

    return kind, contact, roller, arm, offset, face_margin


def read_motion(
    r: Reader, cam: Mapping, osc: bool, limit: float | None = None, where: tuple = ("cam",)
) -> Program:
    """The motion program under ``cam["motion"]`` (``cam["law"]``: the default law) at
    key path ``where``; ``limit``: the largest swing of an oscillating follower."""
    p = where + ("motion",)
    seq = cam["motion"]
    if not isinstance(seq, list) or not seq:
        raise r.fail(
            p,
            "expected a list of segments such as {rise: 75 deg, "
            + ("swing: 15 deg" if osc else "lift: 20 mm")
            + ", law: cycloidal}",
        )
    default_law = None
    if "law" in cam:
        default_law = _law(r, cam["law"], where + ("law",))
    lift_key, lift_kind = ("swing", "angle") if osc else ("lift", "length")
    other = "lift" if osc else "swing"
    items = []
    total = 0.0
    level = 0.0
    for i, item in enumerate(seq):
        q = p + (i,)
        kinds = [k for k in ("rise", "return", "dwell") if isinstance(item, dict) and k in item]
        if len(kinds) != 1:
            raise r.fail(q, "each segment is one of {rise: ANGLE, ...}, {dwell: ANGLE} or "
                         "{return: ANGLE, ...}")  # fmt: skip
        kind = kinds[0]
        allowed = (kind,) if kind == "dwell" else (kind, lift_key, "law")
        if other in item:
            raise r.fail(q + (other,), f"a{'n oscillating' if osc else ' translating'} "
                         f"follower's stroke is its '{lift_key}'")  # fmt: skip
        r.mapping(item, q, allowed, f"the {kind} segment")
        angle = r.positive(item[kind], q + (kind,), "angle")
        total += angle
        lift = None
        law = None
        if kind != "dwell":
            if lift_key in item:
                lift = r.positive(item[lift_key], q + (lift_key,), lift_kind)
            elif kind == "rise":
                raise r.fail(q, f"a rise needs its '{lift_key}'")
            if "law" in item:
                law = _law(r, item["law"], q + ("law",))
            elif default_law is not None:
                law = default_law
            else:
                raise r.fail(q, "the segment needs a 'law' (or give 'law' for all under 'cam')")
            if kind == "rise":
                level += lift  # type: ignore[operator]
                if limit is not None and level >= limit:
                    what = "a flat face" if limit < math.pi else "a roller or knife edge"
                    raise r.fail(
                        q + (lift_key,),
                        f"the follower would swing {math.degrees(level):.6g} deg from its "
                        f"lowest position: impossible for an oscillating follower with {what}, "
                        "whose distance from the cam's centre grows only while the arm's "
                        "angle from the line of centres (phi0 + swing) stays below "
                        f"{math.degrees(limit):g} deg",
                    )
            else:
                if lift is not None and lift > level * (1 + 1e-9):
                    raise r.fail(
                        q + (lift_key,),
                        "the return goes below the lowest position "
                        f"(it returns {_show(lift, osc)} from {_show(level, osc)})",
                    )
                level -= level if lift is None else lift
        items.append((kind, angle, lift, law))
    if abs(total - 2 * math.pi) > 1e-9:
        raise r.fail(p, f"the segments cover {math.degrees(total):.6g} deg of cam angle; "
                     "they must cover one turn, 360 deg")  # fmt: skip
    if abs(level) > 1e-9 * max(1.0, max((x[2] or 0) for x in items)):
        raise r.fail(p, f"the follower ends {_show(level, osc)} above where it started: "
                     "the returns must bring it back")  # fmt: skip
    return build_program(items, osc)


def _show(x: float, osc: bool) -> str:
    return f"{math.degrees(x):.6g} deg" if osc else f"{x * 1e3:.6g} mm"


def _law(r: Reader, value: Any, path):
    law = find_law(value) if isinstance(value, str) else None
    if law is None:
        raise r.fail(path, f"unknown motion law {value!r}; known: {NAMES_HELP}")
    return law


def read_base(
    r: Reader,
    cam: Mapping,
    p: tuple,
    kind: str,
    contact: str,
    roller: float,
    offset: float,
    arm: float,
    program: Program,
    unit: LengthUnit = MM,
) -> tuple:
    """The base values under ``cam`` (key path ``p``): (the follower with them, designed:
    none given, notes, the values as given)."""
    osc = kind == "oscillating"
    limit = None if not osc else (math.pi / 2 if contact == "flat-faced" else math.pi)
    given: dict[str, float] = {}
    for key in ("base_radius", "pivot_distance", "start_angle"):
        if key in cam:
            kind_q = "angle" if key == "start_angle" else "length"
            given[key] = r.positive(cam[key], p + (key,), kind_q)
    if not osc:
        for key in ("pivot_distance", "start_angle"):
            if key in given:
                raise r.fail(p + (key,), "only an oscillating follower has a " + key)
    follower, designed, notes = _base(r, p, kind, contact, roller, offset, arm, given, unit)
    if limit is not None and not designed:
        top = follower.start_angle + program.stroke
        if top >= limit:
            raise r.fail(
                p + ("start_angle" if "start_angle" in given else "base_radius",),
                f"the arm starts {math.degrees(follower.start_angle):.6g} deg from the line "
                f"of centres (phi0) and swings {math.degrees(program.stroke):.6g} deg: at "
                f"{math.degrees(top):.6g} deg it passes {math.degrees(limit):g} deg, where "
                "its contact stops moving away from the cam's centre; the swing must stay "
                f"below {math.degrees(limit - follower.start_angle):.6g} deg with this phi0",
            )
    return follower, designed, notes, given


def _base(r: Reader, p, kind, contact, roller, offset, arm, given, unit: LengthUnit = MM):
    notes: list[str] = []
    zero = Follower(kind, contact, 0.0, roller=roller, offset=offset, arm=arm)
    if kind == "translating":
        if "base_radius" not in given:
            return zero, True, notes
        rb = given["base_radius"]
        if contact != "flat-faced" and rb <= abs(offset):
            raise r.fail(p + ("base_radius",), "the base radius must exceed the offset |e|")
        return zero.with_base(base_radius=rb), False, notes
    keys = set(given)
    if not keys:
        return zero, True, notes
    a = given.get("pivot_distance")
    phi0 = given.get("start_angle")
    r0 = given.get("base_radius")
    if a is None:
        raise r.fail(p, "an oscillating follower's base values: give 'pivot_distance' with "
                     "'start_angle' or 'base_radius' (or none, to have them designed)")  # fmt: skip
    if contact == "flat-faced":
        # the face touches the base circle at psi = 0: a sin(phi0) - face_offset = r0
        if r0 is None and phi0 is None:
            raise r.fail(p, "give 'base_radius' or 'start_angle' with 'pivot_distance'")
        if r0 is None:
            r0 = a * math.sin(phi0) - offset
        if not 0 < (r0 + offset) / a < 1:
            raise r.fail(p + ("base_radius",), "the face cannot touch a base circle that large")
        phi_calc = math.asin((r0 + offset) / a)
        rel = "r0 = a sin(phi0) - face_offset"
    else:
        if r0 is None and phi0 is None:
            raise r.fail(p, "give 'start_angle' (phi0) or 'base_radius' (r0) with "
                         "'pivot_distance'")  # fmt: skip
        if r0 is None:
            r0 = base_radius_of(a, arm, phi0)
        try:
            phi_calc = start_angle_of(a, arm, r0)
        except ValueError as exc:
            raise r.fail(p + ("base_radius",), str(exc)) from None
        rel = "r0^2 = a^2 + l^2 - 2 a l cos(phi0)"
    if phi0 is not None and "base_radius" in given:
        r_calc = (a * math.sin(phi0) - offset if contact == "flat-faced"
                  else base_radius_of(a, arm, phi0))  # fmt: skip
        if abs(r_calc - r0) > TOL_BASE * r0:
            raise r.fail(
                p + ("base_radius",),
                f"pivot_distance, start_angle and base_radius disagree: {rel} gives "
                f"r0 = {unit(r_calc):.4f} {unit.name} for the given a and phi0",
            )
        notes.append(
            f"{rel}: a = {unit(a):g} {unit.name}, phi0 = {math.degrees(phi0):g} deg give "
            f"r0 = {unit(r_calc):.4f} {unit.name} (given {unit(r0):g} {unit.name})"
        )
        # the drawing uses a and phi0 as given; r0 follows from them exactly
        r0 = r_calc
        phi_calc = phi0
    return zero.with_base(base_radius=r0, pivot=a, start_angle=phi_calc), False, notes
