"""The Python API: load a mechanism, solve its sweep, check it. The CLI only calls these.

>>> import mechsolve as ms
>>> mech = ms.load("mechanisms/fourbar.yaml")
>>> res = ms.solve(mech)
>>> res.point("B").x            # array over the positions of the sweep
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.units import pretty_unit
from mechsolve.core.sweep import Analysis, StartAssembly
from mechsolve.joints.registry import KINDS
from mechsolve.model import Mechanism
from mechsolve.model.parse import load, loads
from mechsolve.results.results import Results
from mechsolve.results.run import (  # noqa: F401
    PLOT_STEP,
    checked_mechanism,
    checked_method,
    for_plots,
    parse_step,
    positions,
    solve,
)
from mechsolve.system.structure import grubler

if TYPE_CHECKING:
    from mechsolve.analyses.compare import Comparison

__all__ = [
    "load",
    "loads",
    "solve",
    "stream",
    "run",
    "check",
    "CheckReport",
    "compare",
    "parse_step",
    "positions",
    "shaking",
    "balanced",
]


def stream(mech: Mechanism, csv_path, **kwargs):
    """Solve a long sweep chunk by chunk and stream its CSV (see :mod:`mechsolve.analyses.chunked`).

    Returns a :class:`~mechsolve.analyses.chunked.StreamSummary` and the Results of a coarse sweep
    of the same range."""
    from mechsolve.analyses.chunked import stream as _stream

    return _stream(mech, csv_path, **kwargs)


def run(path: str | Path, variant: str | None = None, **kwargs) -> Results:
    """Load a mechanism file and solve it: ``run("crane.yaml").point("K").x``."""
    return solve(load(path, variant), **kwargs)


def compare(
    schemes: Sequence[str | Path | tuple[str | Path, str | None]],
    *,
    outputs: Sequence[str] | None = None,
    delta: float = 1 / 40,
    middle: float = 0.8,
    method: str | None = None,
    all_variants: bool = False,
) -> Comparison:
    """Several schemes side by side: ``compare(["A.yaml", "B.yaml@variant"])`` solves each
    over one turn of its crank and returns a
    :class:`~mechsolve.analyses.compare.Comparison` (its ``text()``, ``to_csv()`` and
    ``write_plots()``); see :func:`mechsolve.analyses.compare.compare` for the options."""
    from mechsolve.analyses.compare import compare as _compare

    return _compare(
        schemes,
        outputs=outputs,
        delta=delta,
        middle=middle,
        method=method,
        all_variants=all_variants,
    )


@dataclass
class CheckReport:
    """What ``mechsolve check`` reports about a mechanism."""

    mechanism: Mechanism
    grubler: int
    jacobian_dof: int
    n_coordinates: int
    jacobian_rank: int
    groups: list[str]
    branches: list[str]
    start_u: float
    start_points: dict[str, tuple[float, float]]
    analysis: Analysis
    assembly: StartAssembly
    notes: list[str] = field(default_factory=list)

    def pair_counts(self) -> tuple[int, int, int]:
        """Moving links n, lower pairs Pl and higher pairs Ph."""
        joints = self.mechanism.joints
        ph = sum(1 for j in joints if j.pair == "higher")
        return len(self.mechanism.links), len(joints) - ph, ph

    def grubler_terms(self) -> str:
        """``3*n - 2*Pl`` (and ``- Ph`` when there are higher pairs)."""
        n, pl, ph = self.pair_counts()
        return f"3*{n} - 2*{pl}" + (f" - {ph}" if ph else "")

    def text(self) -> str:
        mech = self.mechanism
        count = {kind: 0 for kind in KINDS}
        for j in mech.joints:
            count[j.kind] += 1
        lower = sum(1 for j in mech.joints if j.pair == "lower")
        higher = sum(1 for j in mech.joints if j.pair == "higher")
        kinds = ", ".join(f"{n} {k}" for k, n in count.items() if n or k in ("revolute", "slider"))
        lines = [
            f"{mech.name}: the file is valid",
            f"  {len(mech.links)} moving links, {len(mech.joints)} joints ({kinds})",
            f"  degrees of freedom: {self.grubler} by Grübler (3n - 2Pl - Ph = "
            f"3*{len(mech.links)} - 2*{lower} - {higher}), {self.jacobian_dof} by the rank of "
            f"the constraint Jacobian ({self.jacobian_rank} of {self.n_coordinates} "
            "coordinates)",
            f"  pairs: Pl = {lower} lower{_kinds_of(mech, 'lower')}, Ph = {higher} "
            f"higher{_kinds_of(mech, 'higher')}",
        ]
        local = sum(j.local_dof for j in mech.joints)
        if local:
            n, pl, ph = self.pair_counts()
            lines.append(
                f"  as textbooks count it, each roller a link on its own pin whose spin is a "
                f"local degree of freedom: 3*{n + local} - 2*{pl + local} - {ph} - {local} = "
                f"{3 * (n + local) - 2 * (pl + local) - ph - local} (here the roller centre "
                "is a point of the follower: no local freedom to solve)"
            )
        if self.grubler != self.jacobian_dof:
            lines.append(
                "  note: the two counts differ: some constraints are redundant (or the start "
                "position is singular)"
            )
        an = self.analysis
        lines.append(f"  driver: joint {mech.driver.joint}, start at {an.format_u(self.start_u)}")
        if an.redundant:
            lines.append("  groups of the start assembly (without the redundant equations):")
        else:
            lines.append("  groups, solved in this order:")
        for k, (g, b) in enumerate(zip(self.groups, self.branches), 1):
            lines.append(f"    {k}. {g}" + (f": {b}" if b else ""))
        # in the file's length unit, as its results are
        k, unit = mech.output_units().convert("m")
        unit = pretty_unit(unit)
        lines.append(
            f"  start position ({an.format_u(self.start_u)}), global coordinates [{unit}]:"
        )
        for p, (x, y) in self.start_points.items():
            lines.append(f"    {p:>8s}: ({x * k:.6g}, {y * k:.6g})")
        red = self.analysis.redundancy
        if red is not None:
            lines.append(
                f"  redundant constraints: {red.count} of the {self.analysis.system.nc} "
                f"equations repeat the others (rank {red.rank}); they involve "
                f"{', '.join(red.equations)}. Kinematics is solved by least squares on all "
                "equations; reactions there are not unique (minimum-norm values are reported)"
            )
            if red.removable:
                lines.append("  " + red.suggestion())
        for n in self.notes:
            lines.append("  " + n)
        return "\n".join(lines)


def _kinds_of(mech: Mechanism, pair: str) -> str:
    """The kinds of the joints that are ``pair`` pairs, as `` (revolute, slider)``."""
    kinds = dict.fromkeys(j.kind for j in mech.joints if j.pair == pair)
    return f" ({', '.join(kinds)})" if kinds else ""


def check(mech: Mechanism, method: str | None = None) -> CheckReport:
    """Validate, count degrees of freedom, and assemble the start position."""
    checked_mechanism(mech).ensure_valid()  # built in code, or edited since: check it
    an = Analysis(mech, checked_method(method))
    u0 = an.start_value()
    asm = an.assemble(u0)
    st = asm.state
    from mechsolve.system.constraints import ConstraintSystem

    free = ConstraintSystem(mech, with_driver=False)
    J = free.jacobian(st)[0]
    if J.size:
        sv = np.linalg.svd(J, compute_uv=False)
        rank = int(np.sum(sv > 1e-9 * sv[0]))
    else:
        rank = 0
    branches = []
    pn = an.joint_point
    modes = asm.group_modes if len(asm.group_modes) == len(an.groups) else asm.modes
    for g, mode, why in zip(an.groups, modes, asm.reasons):
        text = g.mode_text(st, mode, pn)
        branches.append(f"{text} ({why})" if text and why else text or why)
    pts = {}
    for p, ref in an.points.items():
        x, y = st.point(ref.body, ref.local)
        pts[p] = (float(x[0]), float(y[0]))
    notes = []
    if not math.isfinite(u0):
        notes.append("the start position could not be determined")
    return CheckReport(
        mech,
        grubler(mech),
        free.nq - rank,
        free.nq,
        rank,
        [g.label for g in an.groups],
        branches,
        u0,
        pts,
        an,
        asm,
        notes,
    )


def shaking(mech: Mechanism, **kwargs):
    """The shaking force and moment on the frame over the sweep (see
    :func:`mechsolve.analyses.shaking.shaking`)."""
    from mechsolve.analyses.shaking import shaking as _shaking

    return _shaking(mech, **kwargs)


def balanced(mech: Mechanism, **kwargs):
    """Counterweights for a four-bar or a slider-crank, the balanced file and the shaking
    before and after (see :func:`mechsolve.analyses.shaking.balanced`)."""
    from mechsolve.analyses.shaking import balanced as _balanced

    return _balanced(mech, **kwargs)
