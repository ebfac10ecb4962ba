"""The comparison as text (the figures side by side, each with its unit) and as a tidy
CSV (one row per scheme, one column per figure, its unit in the header)."""

from __future__ import annotations

import csv
import io
import math
import re
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from mechsolve.base.atomic import write_text
from mechsolve.base.units import SI_OUTPUT, OutputUnits, pretty_text

if TYPE_CHECKING:
    from mechsolve.analyses.compare import Comparison
    from mechsolve.analyses.compare.figures import SchemeFigures


def _g(x: float, digits: int = 6) -> str:
    return f"{x:.{digits}g}" if math.isfinite(x) else "–"


def _deg(x: float, digits: int = 5, u: OutputUnits | None = None) -> str:
    """An angle given in rad, in degrees (``u``'s angle unit when it is not deg)."""
    if not math.isfinite(x):
        return "–"
    if u is None or u.angle == "deg":
        return f"{math.degrees(x):.{digits}g}°"
    k, unit = u.convert("deg")
    return f"{math.degrees(x) * k:.{digits}g} {unit}"


def _force(x: float, u: OutputUnits | None = None) -> str:
    if x == math.inf:  # grows without bound towards a toggle (the notes say where)
        return "unbounded"
    if not math.isfinite(x):
        return "–"
    if u is None or u.force == "N":  # N, or kN from 10 kN on
        return f"{x / 1e3:.5g} kN" if abs(x) >= 1e4 else f"{x:.5g} N"
    k, unit = u.convert("N")
    return f"{x * k:.5g} {unit}"


def _amount(s: SchemeFigures, x: float, u: OutputUnits | None = None) -> str:
    """A value of the output's kind: a length in mm, an angle in degrees (SI); in ``u``'s
    length and angle units when given."""
    if not math.isfinite(x):
        return "–"
    if s.output.angular:
        return _deg(x, 6, u)
    if u is None:
        return f"{x * 1e3:.6g} mm"
    k, unit = u.convert("m")
    return f"{x * k:.6g} {unit}"


def _rate(s: SchemeFigures, x: float, u: OutputUnits | None = None) -> str:
    if not math.isfinite(x):
        return "–"
    k, unit = (u or SI_OUTPUT).convert("rad/s" if s.output.angular else "m/s")
    return f"{x * k:.4g} {unit}"


def _speed(x: float, u: OutputUnits | None = None) -> str:
    k, unit = (u or SI_OUTPUT).convert("rad/s")
    return f"{x * k:.6g} {unit}"


def _torque(x: float, u: OutputUnits | None = None) -> str:
    k, unit = (u or SI_OUTPUT).convert("N*m")
    return f"{_g(x * k, 5)} {unit}"


def _energy(x: float, u: OutputUnits | None = None) -> str:
    k, unit = (u or SI_OUTPUT).convert("J")
    return f"{_g(x * k, 5)} {unit}"


def _fraction(x: float) -> str:
    """``1/40`` for a coefficient that is the inverse of a whole number, else decimal."""
    n = 1 / x
    return f"1/{round(n)}" if abs(n - round(n)) < 1e-9 else f"{x:.4g}"


def _requirements(s: SchemeFigures) -> str:
    if not s.verdicts:
        return "none given"
    failed = s.failed
    if not failed:
        return f"{len(s.verdicts)} of {len(s.verdicts)} pass"
    return f"{len(failed)} FAIL: " + ", ".join(failed)


def _rows(
    c: Comparison, u: OutputUnits | None = None
) -> list[tuple[str, Callable[[SchemeFigures], str]]]:
    """The rows of the text: (what, its cell of a scheme); ``u`` None: the SI text (a
    stroke in mm, forces from 10 kN on in kN)."""
    k_band = (u or SI_OUTPUT).convert
    mid = f"{c.middle * 100:g} %"
    return [
        ("file", lambda s: s.file + (f"@{s.variant}" if s.variant else "")),
        ("output", lambda s: s.output.spec),
        (
            "working stroke (the slower)",
            lambda s: ("increasing " if s.work_sign > 0 else "decreasing ") + s.output.spec,
        ),
        ("stroke (swing for a rocker)", lambda s: _amount(s, s.stroke, u)),
        ("time ratio K", lambda s: _g(s.time_ratio)),
        (
            "crank angle: working / return",
            lambda s: f"{_deg(s.work_travel, 5, u)} / {_deg(s.return_travel, 5, u)}",
        ),
        ("mean velocity, working stroke", lambda s: _rate(s, s.v_mean, u)),
        (
            "peak velocity: working / return",
            lambda s: f"{_rate(s, s.v_peak_work, u).split()[0]} / {_rate(s, s.v_peak_return, u)}",
        ),
        (f"velocity CV, middle {mid} of it", lambda s: _g(s.uniformity, 3)),
        (
            "velocity range there",
            lambda s: (
                f"{_g(s.v_band[0] * k_band('rad/s' if s.output.angular else 'm/s')[0], 4)}"
                f" .. {_rate(s, s.v_band[1], u)}"
            ),
        ),
        ("min transmission angle", lambda s: _deg(s.transmission, 4, u)),
        ("  in loop", lambda s: s.transmission_loop.split(" (")[0] or "–"),
        ("max pressure angle", lambda s: _deg(s.pressure, 4, u)),
        ("max pressure angle at a cam", lambda s: _deg(s.contact_pressure, 4, u)),
        (
            "  at joint, crank angle",
            lambda s: (
                f"{s.contact_pressure_joint}, {_deg(s.contact_pressure_at, 4, u)}"
                if s.contact_pressure_joint
                else "–"
            ),
        ),
        (
            "peak driving torque",
            lambda s: _torque(s.torque_peak_value, u) if math.isfinite(s.torque_peak) else "–",
        ),
        ("  at crank angle", lambda s: _deg(s.torque_peak_at, 4, u)),
        ("RMS driving torque", lambda s: _torque(s.torque_rms, u)),
        ("mean driving torque", lambda s: _torque(s.torque_mean, u)),
        ("peak joint reaction", lambda s: _force(s.reaction_peak, u)),
        (
            "  at joint, crank angle",
            lambda s: f"{s.reaction_joint or '–'}, {_deg(s.reaction_at, 4, u)}",
        ),
        ("flywheel: energy excursion", lambda s: _energy(s.energy_max, u)),
        (
            f"  inertia needed, delta {_fraction(c.delta)}",
            lambda s: f"{_g(s.inertia_needed, 5)} kg*m^2",
        ),
        ("  beyond the machine's own", lambda s: f"{_g(s.flywheel, 5)} kg*m^2"),
        ("requirements", _requirements),
    ]


def side_by_side(c: Comparison, units: OutputUnits | None = None) -> list[tuple[str, list[str]]]:
    """The figures as text: (what, one cell per scheme), each cell with its unit (in
    ``units``; None: the SI text); a figure a scheme lacks is a dash."""
    out = []
    for label, fn in _rows(c, units):
        cells = [fn(s) for s in c.schemes]
        out.append((label, ["–" if v.startswith("– ") else v for v in cells]))
    return out


NOTE = (
    "crank angles from the start of each working stroke; velocity CV: standard deviation "
    "over mean of the speed over the middle {mid} % of the working stroke, weighted by the "
    "displacement; torque along the crank's motion (positive: the motor drives); flywheel "
    "by the energy method at the crank's speed"
)


def comparison_text(c: Comparison, units: OutputUnits | None = None) -> str:
    """The figures side by side (in ``units``; None: the SI text); the crank angles are
    counted from the start of each scheme's working stroke."""
    schemes = c.schemes
    # the cells as they are printed (kg*m^2 as kg·m², one character shorter), so that
    # the columns are padded to the width they show
    table = [
        (pretty_text(label), [pretty_text(v) for v in r]) for label, r in side_by_side(c, units)
    ]
    label_w = max(len(label) for label, _ in table) + 2
    widths = [max(len(s.name), *(len(r[k]) for _, r in table)) + 2 for k, s in enumerate(schemes)]
    widths[-1] -= 2  # no margin after the last column: every row is as wide
    speed = schemes[0].speed
    head = (
        f"compare {len(schemes)} scheme(s) over one turn of the crank at "
        f"{speed * 30 / math.pi:.6g} rpm ({_speed(speed, units)}), 0.1° samples"
    )
    lines = [head, " " * label_w + "".join(f"{s.name:<{w}}" for s, w in zip(schemes, widths))]
    for label, r in table:
        lines.append(f"{label:<{label_w}}" + "".join(f"{v:<{w}}" for v, w in zip(r, widths)))
    note = NOTE.format(mid=f"{c.middle * 100:g}")
    lines += textwrap.wrap(note, 90, initial_indent="  ", subsequent_indent="  ")
    for s in schemes:
        for n in s.notes:
            lines += textwrap.wrap(
                f"{s.name}: {n}", 90, initial_indent="  ", subsequent_indent="    "
            )
    for s in schemes:
        if s.verdicts:
            from mechsolve.results.requirements import verdict_table

            lines.append(f"{s.name}: " + verdict_table(s.verdicts))
    return "\n".join(lines)


def _num(x: float) -> str:
    return format(float(x), ".12g") if math.isfinite(x) else ""


def columns(c: Comparison) -> list[tuple[str, list[str]]]:
    """The CSV's columns: (header with its unit, one cell per scheme)."""
    S = c.schemes

    def lin(f):  # a figure of a length output (m, m/s), empty for a rocker
        return [_num(f(s)) if not s.output.angular else "" for s in S]

    def ang(f, scale=1.0):  # of a rocker (deg, rad/s), empty for a length output
        return [_num(f(s) * scale) if s.output.angular else "" for s in S]

    deg = math.degrees(1.0)
    return [
        ("scheme", [s.name for s in S]),
        ("file", [s.file for s in S]),
        ("variant", [s.variant or "" for s in S]),
        ("output", [s.output.spec for s in S]),
        ("output.kind", [s.output.kind for s in S]),
        ("working.direction [-]", [str(s.work_sign) for s in S]),
        ("crank.speed [rad/s]", [_num(s.speed) for s in S]),
        ("stroke [m]", lin(lambda s: s.stroke)),
        ("swing [deg]", ang(lambda s: s.stroke, deg)),
        ("time_ratio [-]", [_num(s.time_ratio) for s in S]),
        ("working.crank_angle [deg]", [_num(math.degrees(s.work_travel)) for s in S]),
        ("return.crank_angle [deg]", [_num(math.degrees(s.return_travel)) for s in S]),
        ("working.velocity_mean [m/s]", lin(lambda s: s.v_mean)),
        ("working.velocity_peak [m/s]", lin(lambda s: s.v_peak_work)),
        ("return.velocity_peak [m/s]", lin(lambda s: s.v_peak_return)),
        ("working.omega_mean [rad/s]", ang(lambda s: s.v_mean)),
        ("working.omega_peak [rad/s]", ang(lambda s: s.v_peak_work)),
        ("return.omega_peak [rad/s]", ang(lambda s: s.v_peak_return)),
        ("uniformity.middle [-]", [_num(s.middle) for s in S]),
        ("uniformity.cv [-]", [_num(s.uniformity) for s in S]),
        ("uniformity.velocity_min [m/s]", lin(lambda s: s.v_band[0])),
        ("uniformity.velocity_max [m/s]", lin(lambda s: s.v_band[1])),
        ("uniformity.omega_min [rad/s]", ang(lambda s: s.v_band[0])),
        ("uniformity.omega_max [rad/s]", ang(lambda s: s.v_band[1])),
        ("transmission.min [deg]", [_num(math.degrees(s.transmission)) for s in S]),
        ("transmission.loop", [s.transmission_loop for s in S]),
        ("transmission.at [deg]", [_num(math.degrees(s.transmission_at)) for s in S]),
        ("pressure_angle.max [deg]", [_num(math.degrees(s.pressure)) for s in S]),
        ("contact.pressure_angle.max [deg]", [_num(math.degrees(s.contact_pressure)) for s in S]),
        ("contact.joint", [s.contact_pressure_joint for s in S]),
        ("contact.at [deg]", [_num(math.degrees(s.contact_pressure_at)) for s in S]),
        ("torque.peak [N*m]", [_num(s.torque_peak_value) for s in S]),
        ("torque.peak_at [deg]", [_num(math.degrees(s.torque_peak_at)) for s in S]),
        ("torque.rms [N*m]", [_num(s.torque_rms) for s in S]),
        ("torque.mean [N*m]", [_num(s.torque_mean) for s in S]),
        ("reaction.peak [N]", [_num(s.reaction_peak) for s in S]),
        ("reaction.joint", [s.reaction_joint for s in S]),
        ("reaction.at [deg]", [_num(math.degrees(s.reaction_at)) for s in S]),
        ("flywheel.delta [-]", [_num(s.delta) for s in S]),
        ("flywheel.energy_max [J]", [_num(s.energy_max) for s in S]),
        ("flywheel.inertia_needed [kg*m^2]", [_num(s.inertia_needed) for s in S]),
        ("flywheel.inertia_own [kg*m^2]", [_num(s.inertia_own) for s in S]),
        ("flywheel.inertia_added [kg*m^2]", [_num(s.flywheel) for s in S]),
        ("requirements.passed [-]", [str(len(s.verdicts) - len(s.failed)) for s in S]),
        ("requirements.failed [-]", [str(len(s.failed)) for s in S]),
        ("requirements.failing", ["; ".join(s.failed) for s in S]),
    ]


_HEADER = re.compile(r"^(?P<name>.+) \[(?P<unit>[^\]]+)\]$")


def in_units(cols: list[tuple[str, list[str]]], units: OutputUnits | None):
    """The CSV's columns with every figure in ``units`` (its header relabelled); columns
    in kg*m^2 or without a unit are kept."""
    if units is None or units.is_si:
        return cols
    out = []
    for head, cells in cols:
        m = _HEADER.match(head)
        if m is not None:
            k, unit = units.convert(m["unit"])
            if k != 1.0 or unit != m["unit"]:
                head = f"{m['name']} [{unit}]"
                cells = [_num(float(v) * k) if v else "" for v in cells]
        out.append((head, cells))
    return out


def write_csv(c: Comparison, path: Path, units: OutputUnits | None = None) -> Path:
    """Write the tidy table at ``path`` atomically, in ``units`` (default SI); return
    the path."""
    cols = in_units(columns(c), units)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([h for h, _ in cols])
    for k in range(len(c.schemes)):
        w.writerow([cells[k] for _, cells in cols])
    write_text(path, buf.getvalue())
    return path
