"""The figures that decide a design, from one solved sweep: one table row.

Columns (SI but for angles, in degrees as everywhere in mechsolve):

* ``positions``, ``solved``, ``assembles`` (every position of the sweep solved); a design
  that does not assemble at every position has no other figures (blank cells) and its
  verdicts say ``not assembled``: figures read off part of a motion would mislead;
* per rocker ``NAME.swing [deg]``, per slider ``NAME.stroke [m]``, and over a full turn
  ``NAME.time_ratio [-]`` (see :mod:`mechsolve.results.limits`: extremes located exactly);
* per two-branch loop ``min(transmission_angle.LOOP) [deg]``: its smallest value;
* with a force analysis ``max(abs(input.torque)) (samples) [N*m]`` (``input.force``
  for a linear driver), the peak reactions ``max(JOINT.F) (samples) [N]``
  (``max(abs(JOINT.N))`` for a slider): the largest of the run's samples, which the
  column says (the same figure in ``requirements:``, ``figures:`` or ``--best`` is
  located between the samples, in its own column); one that grows without bound (next
  to a toggle or a change point) is blank, and ``notes`` says where to; and
  ``cycle.work [J]``: the driver's work over the sweep (per cycle for a full turn);

Each other column is named by the figure as the requirements' language writes it, so
that it can be copied into ``requirements:`` or ``--best``;
* each extra figure of the study (an expression such as ``range(K.y)``) and each
  requirement's value and verdict, when the mechanism file has requirements.
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from mechsolve.base.units import UnitError, parse_unit
from mechsolve.results.requirements import evaluate_figure
from mechsolve.results.summary import unbounded_towards

Row = dict[str, Any]


def loop_name(label: str) -> str:
    """``loop B (coupler A-B, rocker B-O4)`` -> ``B``."""
    m = re.match(r"\s*loop\s+([A-Za-z_][A-Za-z0-9_]*)", label)
    if m:
        return m.group(1)
    return re.sub(r"[^A-Za-z0-9_]+", "_", label).strip("_") or "loop"


def _finite(values: np.ndarray) -> np.ndarray:
    v = np.asarray(values, float)
    return v[np.isfinite(v)]


def kinematic_figures(res) -> Row:
    """Limit positions, time ratios and transmission angles of a solved sweep."""
    row: Row = {}
    n = len(res.u)
    solved = int(np.sum(res.ok))
    row["positions [-]"] = n
    row["solved [-]"] = solved
    zones = [e for e in res.solution.events if e.kind == "dead zone"]  # between samples
    row["assembles [-]"] = bool(solved == n and not res.failures and not zones)
    for lp in res.limit_positions():
        if lp.kind == "rocker":
            row[f"{lp.name}.swing [deg]"] = math.degrees(lp.swing)
        else:
            row[f"{lp.name}.stroke [m]"] = lp.swing
        if lp.time_ratio is not None:
            row[f"{lp.name}.time_ratio [-]"] = lp.time_ratio
    for t in res.transmission_angles():
        row[f"min(transmission_angle.{loop_name(t.group)}) [deg]"] = math.degrees(t.angle)
    return row


def force_figures(res) -> Row:
    """Peak driving effort, peak reactions and the driver's work. Each peak is the largest
    of the run's samples, and its column says so (``max(O2.F) (samples) [N]``): locating
    each between the samples, as ``requirements:`` does, costs a finer sweep and some
    five solves of 65 positions per figure and design: 1.3 to 5.6 times the time of a
    whole study, measured on the four-bar and crane examples. Where it grows without
    bound (towards a toggle or a change point, as the run's summary finds it) the cell
    is blank and ``notes`` says so."""
    row: Row = {}
    if res.forces is None:
        return row
    kind, unit = res.effort_name
    peaks = [(f"abs(input.{kind})", unit, np.abs(res.driving_effort))]
    f = res.forces
    for j in res.mechanism.joints:
        comp = j.magnitude  # the joint's magnitude: F, N, Fn...
        text = f"{j.name}.F" if comp == "F" else f"abs({j.name}.{comp})"
        peaks.append((text, "N", np.where(f.ok, np.abs(f.reactions[j.name][comp]), np.nan)))
    unbounded: dict[str, list[str]] = {}  # where -> the figures growing towards it
    for text, u, samples in peaks:
        value = math.nan
        if np.any(np.isfinite(samples)):
            i = int(np.nanargmax(samples))
            toward = unbounded_towards(res, samples, i)
            if toward is None:
                value = float(samples[i])
            else:  # the largest sample is only the one nearest the singular position
                unbounded.setdefault(toward, []).append(f"max({text})")
        row[f"max({text}) {SAMPLES} [{u}]"] = value
    row["cycle.work [J]"] = float(res.work())
    if unbounded:
        row["notes"] = "; ".join(
            f"{', '.join(keys)} {'grows' if len(keys) == 1 else 'grow'} without bound "
            f"towards {toward}"
            for toward, keys in unbounded.items()
        )
    return row


SAMPLES = "(samples)"  # a column's figure taken over the run's samples, not located


def expression_unit(text: str, res) -> str:
    """The unit of a figure such as ``range(K.y)``: its quantity's column unit when it
    names one quantity and the reductions keep the unit (min, max, mean, rms, range,
    abs, at); ``SI`` otherwise."""
    names = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)+", text))
    words = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*(?=\s*\()", text))
    if len(names) != 1 or words - {"min", "max", "mean", "rms", "range", "abs", "at"}:
        return "SI"
    if re.search(r"[*/^]", text):
        return "SI"
    name = names.pop()
    head, _, attr = name.rpartition(".")
    special = {"swing": "deg", "stroke": "m", "time_ratio": "-", "work": "J"}
    if head == "transmission_angle":
        return "deg"
    if attr in special and name not in {c.name for c in res.columns()}:
        return special[attr]
    units = getattr(res, "_study_units", None)
    if units is None:
        units = {c.name: c.unit for c in res.columns()}
        res._study_units = units
    if name not in units and "." in name:  # a reaction written JOINT.F
        for full, unit in units.items():
            if full.startswith(head + "(") and full.endswith("." + attr):
                return unit
    return units.get(name, "SI")


def extra_figures(res, mech, texts: list[str], have: Row | None = None) -> Row:
    """The study's own figures (``range(K.y)``), through the requirements' language; one
    of the columns in ``have`` already (``max(O2.F)``) is not evaluated again."""
    row: Row = {}
    if not texts:
        return row

    for text in texts:
        unit = expression_unit(text, res)
        key = f"{text} [{unit}]"
        if have is not None and key in have:
            continue
        try:
            value = float(evaluate_figure(text, mech, res))
        except (ArithmeticError, ValueError):
            value = math.nan
        if unit == "deg":  # angles are tabulated in degrees, evaluated in radians
            value = math.degrees(value)
        row[key] = value
    return row


def requirement_figures(res, mech) -> Row:
    """Each requirement's measured value and verdict, and whether all pass."""
    try:
        from mechsolve.results.requirements import check_requirements
    except ImportError:  # requirements not part of this mechsolve
        return {}
    verdicts = check_requirements(mech, res)
    row: Row = {}
    for v in verdicts:
        row[f"req.{v.name} [{v.unit or '-'}]"] = _shown(v.value, v.unit)
        row[f"req.{v.name}.pass [-]"] = bool(v.passed)
    if verdicts:
        row["requirements.pass [-]"] = all(v.passed for v in verdicts)
    return row


def _shown(value: float, unit: str) -> float:
    """A requirement's SI value in the unit it is shown in."""
    if not unit or unit == "-":
        return float(value)

    try:
        return float(value) / parse_unit(unit).factor
    except UnitError:
        return float(value)


NOT_ASSEMBLED = "not assembled"  # the verdict of a design that does not close everywhere
COUNTS = ("positions [-]", "solved [-]", "assembles [-]")


def design_row(res, mech, figures: list[str] = ()) -> Row:
    """Every figure of one solved design. A design that does not close at every position
    of its sweep has no figures: they are blank (NaN) and its verdicts say
    :data:`NOT_ASSEMBLED`, never a value or a pass read off the positions it does reach
    (see :func:`blank_unassembled`)."""
    row = kinematic_figures(res)
    row.update(force_figures(res))
    row.update(extra_figures(res, mech, list(figures), row))
    row.update(requirement_figures(res, mech))
    if not row["assembles [-]"]:
        row = blank_unassembled(row)
    return row


def blank_unassembled(row: Row) -> Row:
    """``row`` with every figure blank (NaN) and every verdict :data:`NOT_ASSEMBLED`: the
    counts of positions and whether it assembles stay; the notes on its figures go."""
    out: Row = {}
    for key, value in row.items():
        if key == "notes":
            continue
        if key in COUNTS:
            out[key] = value
        elif key.endswith(".pass [-]"):
            out[key] = NOT_ASSEMBLED
        else:
            out[key] = math.nan
    return out


__all__ = [
    "NOT_ASSEMBLED",
    "blank_unassembled",
    "design_row",
    "expression_unit",
    "extra_figures",
    "force_figures",
    "kinematic_figures",
    "loop_name",
    "requirement_figures",
]
