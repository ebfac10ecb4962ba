"""What the sweep computes: poses of named points, and the containers of a solved sweep.

:class:`Solution` holds the state of every body at every position with the solve's
book-keeping (which positions closed, failures, branch events, singular positions);
:class:`StateView` reads named quantities out of a state for conditions and results.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mechsolve.base.errors import InputError
from mechsolve.base.state import State
from mechsolve.groups import Drive
from mechsolve.model import GROUND


@dataclass
class PointRef:
    body: int
    local: np.ndarray


class StateView:
    """Read quantities of named points, links and sliders from a :class:`State`.

    Implements the :class:`~mechsolve.model.expr.Context` protocol for conditions.
    """

    def __init__(self, analysis: Any, st: State, drive: Drive | None = None) -> None:
        self.an = analysis
        self.st = st
        self.drive = drive
        self.has_velocity = True
        self.has_acceleration = True

    def point_xy(self, name: str):
        p = self.an.points[name]
        return self.st.point(p.body, p.local)

    def quantity(self, name: str, attr: str):
        an, st = self.an, self.st
        if name in an.points:
            p = an.points[name]
            if attr in ("x", "y"):
                x, y = st.point(p.body, p.local)
                return x if attr == "x" else y
            self._need(attr)
            if attr in ("vx", "vy", "v"):
                vx, vy = st.point_velocity(p.body, p.local)
                return {"vx": vx, "vy": vy}.get(attr, np.hypot(vx, vy) if attr == "v" else None)
            ax, ay = st.point_acceleration(p.body, p.local)
            return {"ax": ax, "ay": ay}.get(attr, np.hypot(ax, ay) if attr == "a" else None)
        if name in an.system.index and name != GROUND:
            b = an.system.index[name]
            if attr == "angle":
                return st.th[b]
            self._need(attr)
            return st.w[b] if attr == "omega" else st.al[b]
        sl = an.system.by_joint[name]
        if attr == "s":
            return sl.displacement(st)
        self._need(attr)
        return sl.velocity(st) if attr == "v" else sl.acceleration(st)

    def _need(self, attr: str) -> None:
        if attr.startswith("v") or attr == "omega":
            if not self.has_velocity:
                raise InputError(f"'{attr}' is not known here: only positions are")
        elif not self.has_acceleration:
            raise InputError(f"'{attr}' is not known here: only positions and velocities are")


@dataclass
class StartAssembly:
    """The branch chosen for every group at the start, and how it was chosen."""

    modes: list[float]
    q_start: dict[int, np.ndarray]  # Newton groups: poses at the start
    reasons: list[str]
    state: State
    u0: float
    group_modes: list[float] = field(default_factory=list)  # of the assembly groups


@dataclass
class Failure:
    """A run of consecutive positions where the mechanism cannot close."""

    first: int
    last: int
    group: str
    reason: str
    u_first: float = math.nan  # the driver values at the first and last position
    u_last: float = math.nan
    # where the loop stops closing before the first position and closes again after the
    # last (the roots of its discriminant between the samples), NaN where not known
    edge_in: float = math.nan
    edge_out: float = math.nan


@dataclass
class Event:
    """Something the sweep met between or at its positions, in a group with two branches.

    ``kind`` is ``"bifurcation"`` (the group passed through a singular configuration where
    its two branches meet; the sweep followed the smooth motion onto the other branch),
    ``"dead zone"`` (the group cannot close somewhere between two solved positions: the
    motion between them is not continuous) or ``"near-singular"`` (a local minimum of the
    transmission angle below 3 degrees).
    """

    kind: str
    group: str
    u: float
    after: int  # the event lies after sample ``after`` (between it and the next one)
    transmission: float  # transmission angle at the event (rad)
    # a dead zone's edges: where the loop stops closing after sample ``after`` and closes
    # again before the next solved sample (roots of its discriminant), NaN where not known
    edge_in: float = math.nan
    edge_out: float = math.nan


@dataclass
class Solution:
    """Everything the sweep computed, before formatting."""

    analysis: Any
    u: np.ndarray
    t: np.ndarray
    state: State
    ok: np.ndarray
    failures: list[Failure]
    indicator: np.ndarray  # (n_groups, N)
    iterations: np.ndarray
    methods: np.ndarray | None  # None: every position solved in closed form
    residual_: np.ndarray | None  # None: not computed yet (see residual)
    start: StartAssembly
    warnings: list[str] = field(default_factory=list)
    has_velocity: bool = True
    has_acceleration: bool = True
    events: list[Event] = field(default_factory=list)
    flips: dict[int, list[float]] = field(default_factory=dict)  # group -> where its branch flips
    # singular positions whose rates are limits along the motion, or could not be found
    rates_by_limit: list[int] = field(default_factory=list)
    rates_undetermined: list[int] = field(default_factory=list)
    # the driver's rate and its rate of change at each position (None: the constant speed
    # of the file and no acceleration)
    ud: np.ndarray | None = None
    udd: np.ndarray | None = None

    def driver_rates(self) -> tuple[np.ndarray, np.ndarray]:
        """(u', u'') at each position: the driver's speed and acceleration."""
        n = len(self.u)
        ud = self.ud if self.ud is not None else np.full(n, float(self.analysis.speed))
        udd = self.udd if self.udd is not None else np.zeros(n)
        return ud, udd

    @property
    def residual(self) -> np.ndarray:
        """max |Phi| at each position (NaN where not solved).

        Sweeps with a Newton group check it while solving (and polish where needed).
        Closed-form groups close exactly by construction, so for them it is computed
        here, when first asked for (the CSV column, the summary); a value above the
        tolerance would be a bug, and the summary says so."""
        if self.residual_ is None:
            with np.errstate(invalid="ignore"):
                r = self.analysis.system.max_residual(self.state, self.u)
            self.residual_ = np.where(self.ok, r, np.nan)
            bad = int(np.sum(self.ok & ~(r <= self.analysis.atol)))
            if bad:
                self.warnings.append(
                    f"the constraint residual exceeds the tolerance at {bad} position(s) "
                    "solved in closed form: please report this"
                )
        return self.residual_


def angle_deg(u: float) -> float:
    """A driver angle in degrees in [0, 360), rounding noise (1e-13°) shown as 0."""
    d = round(math.degrees(u) % 360, 9)
    return 0.0 if d >= 360 else d + 0.0


def full_cycle(linear: bool, u) -> bool:
    """Does a sweep of driver values ``u`` cover exactly one turn of a crank?"""
    return (not linear) and len(u) > 0 and abs(abs(u[-1] - u[0]) - 2 * math.pi) < 1e-9
