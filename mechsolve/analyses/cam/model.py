"""Read a cam file: a top-level ``cam:`` section (alone, or in a mechanism file).

    name: shaper feed cam
    units: {length: mm, angle: deg}
    cam:
      follower: {type: oscillating roller, arm: 125 mm, roller_radius: 15 mm}
      pivot_distance: 135 mm        # a (oscillating)
      start_angle: 12.5 deg         # phi0 (oscillating)
      base_radius: 30 mm            # r0; leave the base values out to have them designed
      rotation: cw                  # the cam's sense: cw or ccw
      speed: 60 rpm
      motion:
        - {rise: 75 deg, swing: 15 deg, law: equal acceleration}
        - {dwell: 10 deg}
        - {return: 75 deg, law: equal acceleration}
        - {dwell: 200 deg}
      allowable_pressure_angle: {rise: 40 deg, return: 70 deg}
      min_curvature_radius: 3 mm
      table_step: 5 deg

Every mistake is an :class:`~mechsolve.base.errors.InputError` naming the file, the key and
its line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mechsolve.analyses.cam.design import Allowance
from mechsolve.base.cam.profile import Follower
from mechsolve.base.cam.program import Program
from mechsolve.base.cam.read import (
    FOLLOWER_KEYS as FOLLOWER_KEYS,
)
from mechsolve.base.cam.read import (
    MM,
    SENSES,
    LengthUnit,
    read_base,
    read_follower,
    read_motion,
)
from mechsolve.model.parse import Reader, read_units
from mechsolve.model.source import Source, load_file

CAM_KEYS = (
    "follower",
    "base_radius",
    "pivot_distance",
    "start_angle",
    "rotation",
    "speed",
    "motion",
    "law",
    "allowable_pressure_angle",
    "min_curvature_radius",
    "table_step",
)


def file_length_unit(src: Source, r: Reader) -> LengthUnit:
    """The length unit the cam's file uses: its ``units: {length: ...}``; else the one
    unit its cam's lengths are written in (``2 in`` ...), plain numbers counting as
    metres; mm when they mix units."""
    from mechsolve.base.units import _QUANTITY_RE, _UNITS, parse_unit

    data = src.data
    units = data.get("units") if isinstance(data, dict) else None
    if isinstance(units, dict) and "length" in units:
        name = str(units["length"]).strip()
        name = "in" if name == "inch" else name
        return LengthUnit(name, parse_unit(name).factor)
    found: set[str] = set()

    def scan(v: Any) -> None:
        if isinstance(v, dict):
            for x in v.values():
                scan(x)
        elif isinstance(v, list):
            for x in v:
                scan(x)
        elif isinstance(v, str):
            m = _QUANTITY_RE.match(v)
            if m and m.group(2) in _UNITS and _UNITS[m.group(2)][1] == (1, 0, 0, 0):
                found.add("in" if m.group(2) == "inch" else m.group(2))
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            pass  # plain numbers: the default unit, m (counted below where lengths are)

    scan(data.get("cam") if isinstance(data, dict) else None)
    if len(found) == 1:
        name = found.pop()
        return LengthUnit(name, _UNITS[name][0])
    return MM


@dataclass
class CamModel:
    """A cam as the file gives it (SI units)."""

    name: str
    file: str | None
    program: Program
    follower: Follower  # base values may be missing (0) when ``designed`` is True
    sense: int
    speed: float  # rad/s
    allowance: Allowance
    table_step: float
    designed: bool  # True: no base values given, the command designs them
    given: dict[str, float] = field(default_factory=dict)  # base values as written
    notes: list[str] = field(default_factory=list)
    unit: LengthUnit = MM  # the results' lengths: in the file's unit
    face_margin: float | None = None  # a flat face's clearance at each end (m), if given


def load(path: str | Path, variant: str | None = None) -> CamModel:
    """Read the ``cam:`` section of ``path`` (``variant``: a ``variants:`` entry)."""
    src = load_file(path)
    if variant is not None:
        src = src.with_variant(variant)
    return from_source(src)


def from_source(src: Source) -> CamModel:
    r = Reader(src)
    data = src.data
    if "units" in data:
        read_units(r, data["units"])
    if "cam" not in data:
        raise r.fail((), "no 'cam:' section: a cam file describes its cam under the key 'cam'")
    cam = r.mapping(data["cam"], ("cam",), CAM_KEYS, "'cam'", ("follower", "motion"))
    p = ("cam",)

    kind, contact, roller, arm, offset, face_margin = read_follower(r, cam, p)
    osc = kind == "oscillating"
    unit = file_length_unit(src, r)

    # rotation and speed
    sense = -1
    if "rotation" in cam:
        t = str(cam["rotation"]).strip().lower()
        if t not in SENSES:
            raise r.fail(p + ("rotation",), f"expected cw or ccw, got {cam['rotation']!r}")
        sense = SENSES[t]
    else:
        raise r.fail(p, "'cam' needs the key 'rotation' (cw or ccw): the sense changes the "
                     "pressure angle")  # fmt: skip
    if "speed" not in cam:
        raise r.fail(p, "'cam' needs the key 'speed' (e.g. '60 rpm')")
    speed = r.positive(cam["speed"], p + ("speed",), "angular speed")

    # the geometry first: an arm's contact moves away from the cam's centre only while the
    # arm's angle from the line of centres stays below 180 deg (a roller or knife edge;
    # the distance is sqrt(a^2 + l^2 - 2 a l cos(phi))), below 90 deg for a flat face (the
    # face's distance a sin(phi) - face_offset)
    limit = None if not osc else (math.pi / 2 if contact == "flat-faced" else math.pi)
    program = read_motion(r, cam, osc, limit)

    follower, designed, notes, given = read_base(
        r, cam, p, kind, contact, roller, offset, arm, program, unit
    )

    allow = _allowance(r, cam, p, program)
    step = math.radians(1.0)
    if "table_step" in cam:
        step = r.positive(cam["table_step"], p + ("table_step",), "angle")
        if step > math.pi / 2 or abs(2 * math.pi / step - round(2 * math.pi / step)) > 1e-6:
            raise r.fail(p + ("table_step",), "must divide 360 deg (e.g. 1, 2, 5 or 10 deg)")
    name = data.get("name") if isinstance(data.get("name"), str) else None
    return CamModel(
        name=name or (Path(src.file).stem if src.file else "cam"),
        file=src.file,
        program=program,
        follower=follower,
        sense=sense,
        speed=speed,
        allowance=allow,
        table_step=step,
        designed=designed,
        given=given,
        notes=notes,
        unit=unit,
        face_margin=face_margin,
    )


def _allowance(r: Reader, cam: dict, p, program: Program) -> Allowance:
    rise = ret = None
    if "allowable_pressure_angle" in cam:
        v = cam["allowable_pressure_angle"]
        q = p + ("allowable_pressure_angle",)
        if isinstance(v, dict):
            r.mapping(v, q, ("rise", "return"), "'allowable_pressure_angle'")
            if "rise" in v:
                rise = r.positive(v["rise"], q + ("rise",), "angle")
            if "return" in v:
                ret = r.positive(v["return"], q + ("return",), "angle")
        else:
            rise = ret = r.positive(v, q, "angle")
        for lim, key in ((rise, "rise"), (ret, "return")):
            if lim is not None and lim >= math.pi / 2:
                raise r.fail(q, f"the allowable pressure angle on the {key} must be below 90 deg")
    rho = 0.0
    if "min_curvature_radius" in cam:
        rho = r.positive(cam["min_curvature_radius"], p + ("min_curvature_radius",), "length",
                         allow_zero=True)  # fmt: skip
    return Allowance(rise, ret, rho)
