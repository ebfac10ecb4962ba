"""The comparison as text (the figures side by side, each with its unit) and as a tidy
CSV (one row per scheme, one column per figure, its unit in the header)."""

from __future__ import annotations

import csv
import io
import math
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from mechsolve.base.atomic import write_text

if TYPE_CHECKING:
    from mechsolve.analyses.compare import Comparison
    from mechsolve.analyses.compare.figures import SchemeFigures


def _g(x: float, digits: int = 6) -> str:
    return f"{x:.{digits}g}" if math.isfinite(x) else "–"


def _deg(x: float, digits: int = 5) -> str:
    return f"{math.degrees(x):.{digits}g}°" if math.isfinite(x) else "–"


def _force(x: float) -> str:
    if not math.isfinite(x):
        return "–"
    return f"{x / 1e3:.5g} kN" if abs(x) >= 1e4 else f"{x:.5g} N"


def _amount(s: SchemeFigures, x: float) -> str:
    """A value of the output's kind: a length in mm, an angle in degrees."""
    if not math.isfinite(x):
        return "–"
    return _deg(x, 6) if s.output.angular else f"{x * 1e3:.6g} mm"


def _rate(s: SchemeFigures, x: float) -> str:
    if not math.isfinite(x):
        return "–"
    return f"{x:.4g} rad/s" if s.output.angular else f"{x:.4g} m/s"


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


def _rows(c: Comparison) -> list[tuple[str, Callable[[SchemeFigures], str]]]:
    mid = f"{c.middle * 100:g} %"
    return [
        ("file", lambda s: s.file + (f"@{s.variant}" if s.variant else "")),
        ("output", lambda s: s.output.spec),
        (
            "working stroke (the slower)",
            lambda s: ("increasing " if s.work_sign > 0 else "decreasing ") + s.output.spec,
        ),
        ("stroke (swing for a rocker)", lambda s: _amount(s, s.stroke)),
        ("time ratio K", lambda s: _g(s.time_ratio)),
        (
            "crank angle: working / return",
            lambda s: f"{_deg(s.work_travel)} / {_deg(s.return_travel)}",
        ),
        ("mean velocity, working stroke", lambda s: _rate(s, s.v_mean)),
        (
            "peak velocity: working / return",
            lambda s: f"{_rate(s, s.v_peak_work).split()[0]} / {_rate(s, s.v_peak_return)}",
        ),
        (f"velocity CV, middle {mid} of it", lambda s: _g(s.uniformity, 3)),
        (
            "velocity range there",
            lambda s: f"{_g(s.v_band[0], 4)} .. {_rate(s, s.v_band[1])}",
        ),
        ("min transmission angle", lambda s: _deg(s.transmission, 4)),
        ("  in loop", lambda s: s.transmission_loop.split(" (")[0] or "–"),
        ("max pressure angle", lambda s: _deg(s.pressure, 4)),
        ("max pressure angle at a cam", lambda s: _deg(s.contact_pressure, 4)),
        (
            "  at joint, crank angle",
            lambda s: (
                f"{s.contact_pressure_joint}, {_deg(s.contact_pressure_at, 4)}"
                if s.contact_pressure_joint
                else "–"
            ),
        ),
        (
            "peak driving torque",
            lambda s: f"{_g(s.torque_peak_value, 5)} N*m" if math.isfinite(s.torque_peak) else "–",
        ),
        ("  at crank angle", lambda s: _deg(s.torque_peak_at, 4)),
        ("RMS driving torque", lambda s: f"{_g(s.torque_rms, 5)} N*m"),
        ("mean driving torque", lambda s: f"{_g(s.torque_mean, 5)} N*m"),
        ("peak joint reaction", lambda s: _force(s.reaction_peak)),
        (
            "  at joint, crank angle",
            lambda s: f"{s.reaction_joint or '–'}, {_deg(s.reaction_at, 4)}",
        ),
        ("flywheel: energy excursion", lambda s: f"{_g(s.energy_max, 5)} J"),
        (
            f"  inertia needed, delta {_fraction(c.delta)}",
            lambda s: f"{_g(s.inertia_needed, 5)} kg*m^2",
        ),
        ("  beyond the machine's own", lambda s: f"{_g(s.flywheel, 5)} kg*m^2"),
        ("requirements", _requirements),
    ]


def side_by_side(c: Comparison) -> list[tuple[str, list[str]]]:
    """The figures as text: (what, one cell per scheme), each cell with its unit; a
    figure a scheme lacks is a dash."""
    out = []
    for label, fn in _rows(c):
        cells = [fn(s) for s in c.schemes]
        out.append((label, ["–" if v.startswith("– ") else v for v in cells]))
    return out


NOTE = (
    "crank angles from the start of each working stroke; velocity CV: standard deviation "
    "over mean of the speed over the middle {mid} % of the working stroke, weighted by the "
    "displacement; torque along the crank's motion (positive: the motor drives); flywheel "
    "by the energy method at the crank's speed"
)


def comparison_text(c: Comparison) -> str:
    """The figures side by side; the crank angles are counted from the start of each
    scheme's working stroke."""
    schemes = c.schemes
    table = side_by_side(c)
    rows = [(label, None) for label, _ in table]
    cells = [r for _, r in table]
    label_w = max(len(label) for label, _ in rows) + 2
    widths = [max(len(s.name), *(len(r[k]) for r in cells)) + 2 for k, s in enumerate(schemes)]
    speed = schemes[0].speed
    head = (
        f"compare {len(schemes)} scheme(s) over one turn of the crank at "
        f"{speed * 30 / math.pi:.6g} rpm ({speed:.6g} rad/s), 0.1° samples"
    )
    lines = [head, " " * label_w + "".join(f"{s.name:<{w}}" for s, w in zip(schemes, widths))]
    for (label, _), r in zip(rows, cells):
        lines.append(f"{label:<{label_w}}" + "".join(f"{v:<{w}}" for v, w in zip(r, widths)))
    lines = [line.rstrip() for line in lines]
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


def write_csv(c: Comparison, path: Path) -> Path:
    """Write the tidy table at ``path`` atomically; return the path."""
    cols = columns(c)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([h for h, _ in cols])
    for k in range(len(c.schemes)):
        w.writerow([cells[k] for _, cells in cols])
    write_text(path, buf.getvalue())
    return path
