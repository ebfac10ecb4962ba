"""Results of a sweep: named quantities as arrays, the CSV table, and a summary.

:class:`Results` is what the Python API returns and what the writers read. Arrays run
over the positions of the sweep; unsolved positions hold NaN and are listed in
:attr:`Results.failures`.

Conventions: SI units (m, m/s, m/s^2, rad/s, rad/s^2); the arrays give angles in radians
(:meth:`Results.link`, :meth:`Results.relative`, :meth:`Results.limit_positions`,
:meth:`Results.transmission_angles`, :attr:`Results.u`), counter-clockwise from +x, a
link's unwrapped along the sweep so that it changes continuously, with the first value in
[0, 2 pi). The CSV table (:meth:`Results.columns`, :meth:`Results.to_csv`),
:attr:`Results.driver_value` and :attr:`Results.driver_travel` give them in degrees.
"""

from __future__ import annotations

import copy
import functools
import math
import numbers
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mechsolve.base.errors import InputError
from mechsolve.base.numerics import brent_root
from mechsolve.base.units import OutputUnits, UnitError, parse_output_units
from mechsolve.core.solution import full_cycle
from mechsolve.core.sweep import Analysis, Failure, Solution, StateView
from mechsolve.core.work import driver_work_why
from mechsolve.model import GROUND, Mechanism, content_snapshot, model_from_snapshot
from mechsolve.results.csv import write_csv
from mechsolve.results.summary import Summary, unbounded_towards


class NotInResults(InputError, KeyError):
    """What was asked of the results is not in them: a point, link, slider or joint they
    do not have, or forces where no force analysis ran. An :class:`InputError`, and a
    :class:`KeyError` for the callers that catch that."""


NO_FORCES = (
    "no force analysis was run: the model has no masses or loads (solve(mech, "
    "forces=True) runs it; a massless, unloaded linkage then needs no force)"
)


@dataclass
class PointMotion:
    """Position, velocity and acceleration of a point (arrays over positions)."""

    name: str
    x: np.ndarray
    y: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    ax: np.ndarray
    ay: np.ndarray


@dataclass
class LinkMotion:
    """Angle (rad, unwrapped), angular velocity and angular acceleration of a link."""

    name: str
    angle: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray


@dataclass
class SliderMotion:
    """Displacement, velocity and acceleration of a slider along its guide."""

    name: str
    s: np.ndarray
    v: np.ndarray
    a: np.ndarray


@dataclass
class Column:
    """One CSV column: a quantity name, its unit, its values and an optional note."""

    name: str
    unit: str
    values: np.ndarray
    note: str = ""

    @property
    def header(self) -> str:
        head = f"{self.name} [{self.unit}]" if self.unit else self.name
        return f"{head} ({self.note})" if self.note else head


ANGLE_SNAP = 1e-9  # turns: a start this close below a whole turn counts as on it


def unwrap_angle(th: np.ndarray, near: float | None = None) -> np.ndarray:
    """Unwrap an angle along the sweep: the first finite value in [0, 2 pi) (a start
    within :data:`ANGLE_SNAP` turns below a whole turn is taken as on it), or within
    half a turn of ``near`` (to continue a previous chunk of the sweep)."""
    out = np.array(th, dtype=float)
    good = np.isfinite(out)
    if not np.any(good):
        return out
    out[good] = np.unwrap(out[good])
    first = out[good][0]
    if near is None or not math.isfinite(near):
        # a start rounded to just below a whole turn (-1e-16 for a link drawn at 0) is
        # that turn: 0, not 360 deg
        out[good] -= 2 * math.pi * math.floor(first / (2 * math.pi) + ANGLE_SNAP)
    else:
        out[good] -= 2 * math.pi * round((first - near) / (2 * math.pi))
    return out


def distance_travelled(u: np.ndarray, u0: float, t: np.ndarray, ud: np.ndarray, law=None):
    """The distance the driver has travelled from ``u0`` at each position (rad or m):
    ``|u - u0|`` for a motion that goes one way; for one that turns back, the sum of the
    legs between its turning points. With a motion law ``law`` a turn between two rows
    (where ``u'`` changes sign) is located on the law (Brent's method on ``u'(t)``), so
    the distance is exact; without one (a simulated motion) the rows are joined
    straight."""
    u = np.asarray(u, float)
    du = np.diff(u)
    if not (np.any(du > 0) and np.any(du < 0)):  # one way: the distance from the start
        return np.abs(u - u0)
    ud = np.asarray(ud, float)
    legs = np.abs(du)
    for k in np.flatnonzero(ud[:-1] * ud[1:] < 0) if law is not None else ():
        a, b = float(t[k]), float(t[k + 1])
        try:
            tk = brent_root(lambda x: float(law.at(np.array([x]))[1][0]), a, b)
        except ValueError:  # not bracketed after all (a row's rate rounded): straight
            continue
        turn = float(law.at(np.array([tk]))[0][0])
        legs[k] = abs(turn - u[k]) + abs(u[k + 1] - turn)
    return abs(u[0] - u0) + np.r_[0.0, np.cumsum(legs)]


# a Results' analysis per call of one of its figures: what an edited model's results
# rebuild their own (the rest of the analysis is its constraint system and groups)
_PER_CALL = ("redundancy", "friction_smoothing", "_limit_start")
_UNKNOWN = object()
# inside a figure's computation: each model compared with its snapshot once (no user code
# runs meanwhile to edit it), not at each of the positions an edge or a peak is solved at
_CHECKED = threading.local()


def as_solved(method):
    """Compute ``method`` of a :class:`Results` for its model as solved (see
    :meth:`Results.model_as_solved`): a figure computed again (a position between two
    samples, the plots' finer sweep) is of the motion and loads the results hold, not of
    the model as edited since."""

    @functools.wraps(method)
    def run(self, *args, **kwargs):
        outer = getattr(_CHECKED, "memo", None) is None
        if outer:
            _CHECKED.memo = {}
        try:
            self.model_as_solved()
            return method(self, *args, **kwargs)
        finally:
            if outer:
                _CHECKED.memo = None

    return run


class Results(Summary):
    """The solved sweep of a mechanism.

    Attributes
    ----------
    mechanism
        The model that was solved: the model object itself, until it is edited; from the
        first figure the results compute after that (see :meth:`model_as_solved`), a copy
        of the model as it was solved.
    u
        Driver coordinate at each position (rad or m).
    t
        Time at each position (s), from the start of the sweep.
    ok
        True where the position was solved.
    failures
        Runs of positions where the mechanism cannot close, with the loop and reason.
    """

    def __init__(self, analysis: Analysis, solution: Solution, forces=None) -> None:
        self.analysis = analysis
        self.solution = solution
        self.forces = forces  # a ForceResult, or None when no force analysis was asked
        self.mechanism: Mechanism = analysis.mech
        self.u = solution.u
        self.t = solution.t
        self.ok = solution.ok
        self.failures: list[Failure] = solution.failures
        self.view = StateView(analysis, solution.state)
        self.view.has_velocity = solution.has_velocity
        self.view.has_acceleration = solution.has_acceleration
        self.warnings: list[str] = list(solution.warnings)
        self.angle_origin: dict[str, float] = {}  # a previous chunk's last link angles
        # the model's content as solved (mechsolve.model.content_snapshot): taken by solve
        # (core.kept), or here for an analysis built elsewhere, before anyone can edit it
        snap = analysis.__dict__.get("solved_snapshot", _UNKNOWN)
        if snap is _UNKNOWN:
            snap = analysis.solved_snapshot = content_snapshot(analysis.mech)
        self._snapshot = snap

    # -- the model as solved ------------------------------------------------------------
    def model_as_solved(self) -> Mechanism:
        """The model these results were solved for, as it was then.

        A model is a mutable object: edited after the solve (a mass, a load, gravity, a
        point, the driver), it is no longer what the results hold. Every figure the
        results compute again (:meth:`effort_at`, :meth:`reaction_at`,
        :meth:`solved_near`, the work, the limit positions, the summary's peaks between
        samples, the plots' finer sweep) calls this first: while the model's content is
        the one solved (:func:`~mechsolve.model.content_snapshot`, some 10 to 80 us) it is
        the model itself; once it differs, the results take a copy rebuilt from the
        snapshot (:func:`~mechsolve.model.model_from_snapshot`) and an analysis of their
        own, as :attr:`mechanism` and :attr:`analysis`, for good. (A model with a field
        that cannot be pickled, a motion law written as a Python function, has no
        snapshot: its results read it as it is.)"""
        snap, mech = self._snapshot, self.mechanism
        if snap is None:
            return mech
        memo = getattr(_CHECKED, "memo", None)
        key = (id(mech), id(snap))
        same = memo.get(key) if memo is not None else None
        if same is None:
            same = content_snapshot(mech) == snap
            if memo is not None:
                memo[key] = same
        if not same:
            self._as_solved(model_from_snapshot(snap, mech.source))
        return self.mechanism

    def _as_solved(self, mech: Mechanism) -> None:
        """Hold ``mech`` (the model as solved, rebuilt) and an analysis of it instead."""
        old = self.analysis
        an = Analysis(mech, old.method)
        for k in _PER_CALL:
            if k in old.__dict__:
                an.__dict__[k] = old.__dict__[k]
        an.solved_snapshot = self._snapshot = content_snapshot(mech)
        sol = copy.copy(self.solution)
        sol.analysis = an
        view = StateView(an, sol.state)
        view.has_velocity, view.has_acceleration = sol.has_velocity, sol.has_acceleration
        self.analysis, self.mechanism, self.solution, self.view = an, mech, sol, view

    @as_solved
    def summary(self, figures: Summary | None = None, units: OutputUnits | None = None) -> str:
        """The text summary (see :meth:`Summary.summary`) of the model as solved."""
        check = getattr(figures, "model_as_solved", None)  # (a finer sweep's results)
        if check is not None:
            check()
        return super().summary(figures, units)

    # -- sizes and names ----------------------------------------------------------------
    def __len__(self) -> int:
        return len(self.u)

    @property
    def linear(self) -> bool:
        return self.analysis.linear

    @property
    def driver_value(self) -> np.ndarray:
        """Driver coordinate in report units: degrees for a revolute driver, m for a slider."""
        return self.u if self.linear else np.degrees(self.u)

    @property
    @as_solved
    def driver_travel(self) -> np.ndarray:
        """Distance travelled by the driver from the start (deg or m), never decreasing:
        ``|u - u0|`` while it goes one way; a motion that turns back adds the way back
        (see :func:`distance_travelled`)."""
        sol = self.solution
        d = distance_travelled(
            self.u, sol.start.u0, self.t, sol.driver_rates()[0], self.mechanism.driver.motion
        )
        return d if self.linear else np.degrees(d)

    def point_names(self) -> list[str]:
        """Named points reported (the file's ``outputs.points``, default all moving ones)."""
        mech = self.mechanism
        if mech.outputs.points is not None:
            return list(mech.outputs.points)
        nb = self.analysis.system.nb
        return [p for p, ref in self.analysis.points.items() if ref.body != nb]

    def link_names(self) -> list[str]:
        mech = self.mechanism
        return list(mech.outputs.links) if mech.outputs.links is not None else mech.link_names

    def slider_names(self) -> list[str]:
        mech = self.mechanism
        if mech.outputs.sliders is not None:
            return list(mech.outputs.sliders)
        return [j.name for j in mech.sliders]

    # -- quantities ---------------------------------------------------------------------
    def _nan(self) -> np.ndarray:
        return np.full(len(self.u), np.nan)

    def point(self, name: str) -> PointMotion:
        """Kinematics of a named point."""
        if name not in self.analysis.points:
            raise NotInResults(f"no point named {name!r}")
        v = self.view
        x, y = v.quantity(name, "x"), v.quantity(name, "y")
        if v.has_velocity:
            vx, vy = v.quantity(name, "vx"), v.quantity(name, "vy")
        else:
            vx = vy = self._nan()
        if v.has_acceleration:
            ax, ay = v.quantity(name, "ax"), v.quantity(name, "ay")
        else:
            ax = ay = self._nan()
        b = np.broadcast_to
        n = len(self.u)
        return PointMotion(name, *(np.array(b(a, (n,)), float) for a in (x, y, vx, vy, ax, ay)))

    def link(self, name: str) -> LinkMotion:
        """Kinematics of a link (its frame's x axis)."""
        if name == GROUND or name not in self.analysis.system.index:
            raise NotInResults(f"no link named {name!r}")
        b = self.analysis.system.index[name]
        st = self.solution.state
        om = st.w[b] if self.view.has_velocity else self._nan()
        al = st.al[b] if self.view.has_acceleration else self._nan()
        return LinkMotion(
            name, unwrap_angle(st.th[b], self.angle_origin.get(name)), om.copy(), al.copy()
        )

    def slider(self, name: str) -> SliderMotion:
        """Relative motion of a slider along its guide."""
        if name not in [j.name for j in self.mechanism.sliders]:
            raise NotInResults(f"no slider named {name!r}")
        v = self.view
        s = v.quantity(name, "s")
        sv = v.quantity(name, "v") if v.has_velocity else self._nan()
        sa = v.quantity(name, "a") if v.has_acceleration else self._nan()
        return SliderMotion(name, s, sv, sa)

    # -- the table ----------------------------------------------------------------------
    @as_solved
    def columns(self) -> list[Column]:
        """All reported quantities as CSV columns, in a stable order."""
        cols: list[Column] = [Column("t", "s", self.t)]
        if self.linear:
            cols += [
                Column("input.s", "m", self.u),
                Column("input.travel", "m", self.driver_travel),
            ]
        else:
            cols += [
                Column("input.angle", "deg", self.driver_value),
                Column("input.travel", "deg", self.driver_travel),
            ]
        vel, acc = self.view.has_velocity, self.view.has_acceleration
        for p in self.point_names():
            m = self.point(p)
            cols += [Column(f"{p}.x", "m", m.x), Column(f"{p}.y", "m", m.y)]
            if vel:
                cols += [Column(f"{p}.vx", "m/s", m.vx), Column(f"{p}.vy", "m/s", m.vy)]
            if acc:
                cols += [Column(f"{p}.ax", "m/s^2", m.ax), Column(f"{p}.ay", "m/s^2", m.ay)]
        for ln in self.link_names():
            m = self.link(ln)
            cols.append(Column(f"{ln}.angle", "deg", np.degrees(m.angle)))
            if vel:
                cols.append(Column(f"{ln}.omega", "rad/s", m.omega))
            if acc:
                cols.append(Column(f"{ln}.alpha", "rad/s^2", m.alpha))
        for a, b in self.mechanism.outputs.relative:
            m = self.relative(a, b)
            cols.append(Column(f"{m.name}.angle", "deg", np.degrees(m.angle)))
            if vel:
                cols.append(Column(f"{m.name}.omega", "rad/s", m.omega))
            if acc:
                cols.append(Column(f"{m.name}.alpha", "rad/s^2", m.alpha))
        for sn in self.slider_names():
            m = self.slider(sn)
            cols.append(Column(f"{sn}.s", "m", m.s))
            if vel:
                cols.append(Column(f"{sn}.v", "m/s", m.v))
            if acc:
                cols.append(Column(f"{sn}.a", "m/s^2", m.a))
        if self.forces is not None:
            cols += self.force_columns()
        sol = self.solution
        cols += [
            Column("jacobian.rcond", "-", np.where(self.ok, self.jacobian_rcond(), np.nan)),
            Column("solver.iterations", "-", sol.iterations.astype(float)),
            Column("solver.residual", "m", sol.residual),
        ]
        return cols

    def relative(self, a: str, b: str) -> LinkMotion:
        """Motion of link ``a`` relative to link ``b`` (either may be ``ground``), named
        ``a/b``: the angle of a's frame minus b's (rad, unwrapped like a link's angle, the
        first value in [0, 2 pi)), and the differences of their angular velocities and
        accelerations."""
        name = f"{a}/{b}"
        zero = np.zeros(len(self.u))
        rows = []
        for ln in (a, b):
            if ln == GROUND:
                rows.append((zero, zero, zero))
                continue
            if ln not in self.analysis.system.index:
                raise NotInResults(f"no link named {ln!r}")
            k = self.analysis.system.index[ln]
            st = self.solution.state
            om = st.w[k] if self.view.has_velocity else self._nan()
            al = st.al[k] if self.view.has_acceleration else self._nan()
            rows.append((st.th[k], om, al))
        (tha, wa, ala), (thb, wb, alb) = rows
        th = unwrap_angle(np.asarray(tha, float) - thb, self.angle_origin.get(name))
        return LinkMotion(name, th, np.asarray(wa - wb, float), np.asarray(ala - alb, float))

    # -- conditioning and design figures --------------------------------------------------
    def jacobian_rcond(self) -> np.ndarray:
        """Reciprocal condition number of the constraint equations at each position (the
        smallest over the groups, see :func:`mechsolve.core.conditioning.jacobian_rcond`):
        1 well conditioned, 0 singular."""
        if not hasattr(self, "_rcond"):
            from mechsolve.core.conditioning import jacobian_rcond

            with np.errstate(invalid="ignore", divide="ignore"):
                sol = self.solution
                self._rcond = jacobian_rcond(self.analysis.plan, sol.state, sol.indicator)
        return self._rcond

    @as_solved
    def limit_positions(self):
        """Limit positions of the rockers and sliders (see :mod:`mechsolve.results.limits`)."""
        if not hasattr(self, "_limits"):
            from mechsolve.results.limits import limit_positions

            self._limits = limit_positions(self.solution)
        return self._limits

    @as_solved
    def transmission_angles(self):
        """The smallest transmission angle of each loop (see :mod:`mechsolve.results.limits`)."""
        if not hasattr(self, "_transmission"):
            from mechsolve.results.limits import transmission_angles

            self._transmission = transmission_angles(self.solution)
        return self._transmission

    @property
    def events(self):
        """Bifurcations, dead zones stepped over, near-singular minima met by the sweep."""
        return self.solution.events

    # -- forces -------------------------------------------------------------------------
    @property
    def effort_name(self) -> tuple[str, str]:
        """("torque", "N*m") for a revolute driver, ("force", "N") for a linear one."""
        return ("force", "N") if self.linear else ("torque", "N*m")

    def joint_label(self, name: str) -> str:
        """``O1(ground->crank)``: the reaction is the force on the second link by the first."""
        j = self.mechanism.joint(name)
        return f"{name}({j.links[0]}->{j.links[1]})"

    def _with_forces(self):
        """The force analysis, or the :class:`NotInResults` that says none ran."""
        if self.forces is None:
            raise NotInResults(NO_FORCES)
        return self.forces

    def reaction(self, name: str) -> dict[str, np.ndarray]:
        """Reaction components of a joint: Fx, Fy, F (revolute) or N, M, Fx, Fy (slider);
        the caller's own copies."""
        return {k: np.array(v, float) for k, v in self._reactions_of(name).items()}

    def _reactions_of(self, name: str) -> dict:
        r = self._with_forces().reactions
        if name not in r:
            raise NotInResults(f"no joint named {name!r} (joints: {', '.join(r)})")
        return r[name]

    @as_solved
    def solved_near(self, x: np.ndarray, near: int):
        """The positions at driver values ``x`` solved next to sample ``near`` of this
        sweep (on its branches), their rates scaled to the driver's speed there: where a
        figure is located between the samples. Not for a motion law of time (its samples
        are in time)."""
        from mechsolve.core import evaluate as core

        an, sol = self.analysis, self.solution
        x = np.asarray(x, float)
        one = an.solve(x, start=sol.start, near=(sol, near), per_unit_driver=True)
        ud, udd = sol.driver_rates()
        m = len(x)
        rates = np.full(m, ud[near]), np.full(m, udd[near])
        core.scale_rates(one.state, *rates, sol.has_acceleration)
        one.ud, one.udd = rates
        one.has_velocity, one.has_acceleration = sol.has_velocity, sol.has_acceleration
        one.t = np.zeros(m)
        return one

    @as_solved
    def reaction_at(self, name: str, x: np.ndarray, near: int) -> dict[str, np.ndarray]:
        """Joint ``name``'s reaction components solved at driver values ``x`` (one value or
        a 1-D array) next to sample ``near`` of this sweep (its index; see
        :meth:`solved_near`); arrays as long as ``x``, NaN where a position does not
        solve."""
        from mechsolve.core import evaluate as core

        self._reactions_of(name)  # forces, and a joint of that name
        n = len(self.u)
        if isinstance(near, bool) or not isinstance(near, numbers.Integral) or not -n <= near < n:
            raise InputError(f"near={near!r}: the index of a sample of this sweep, 0 .. {n - 1}")
        try:
            x = np.atleast_1d(np.asarray(x, float))
        except (TypeError, ValueError):
            raise InputError(f"x={x!r}: expected driver values (numbers)") from None
        if x.ndim != 1:
            raise InputError(f"x: expected one driver value or a 1-D array, got shape {x.shape}")
        one = self.solved_near(x, int(near) % n)
        extremes = self.forces.stroke_extremes
        with np.errstate(all="ignore"):
            r = core.forces(self.analysis, one, extremes).reactions[name]
        bad = ~np.asarray(one.ok, bool)
        return {k: np.where(bad, np.nan, np.asarray(v, float)) for k, v in r.items()}

    @as_solved
    def effort_at(self, x: np.ndarray, near: int) -> np.ndarray:
        """The driving effort at driver values ``x`` solved next to sample ``near`` (see
        :meth:`solved_near`); NaN where a position does not solve."""
        from mechsolve.core import evaluate as core

        one = self.solved_near(x, near)
        extremes = self.forces.stroke_extremes if self.forces is not None else None
        with np.errstate(all="ignore"):
            e = np.asarray(core.forces(self.analysis, one, extremes).effort, float)
        return np.where(np.asarray(one.ok, bool), e, np.nan)

    @property
    def driving_effort(self) -> np.ndarray:
        """The driving torque (N m) or force (N) the driver applies to the driven link."""
        f = self._with_forces()
        ok = f.ok.copy()
        ok[f.effort_by_limit] = True  # its limit along the motion at a singular position
        return np.where(ok, f.effort, np.nan)

    def force_columns(self) -> list[Column]:
        f = self.forces
        ok = f.ok

        def m(a):
            return np.where(ok, a, np.nan)

        kind, unit = self.effort_name
        cols = [Column(f"input.{kind}", unit, self.driving_effort, self._note("driver", "effort"))]
        for j in self.mechanism.joints:
            lab = self.joint_label(j.name)
            r = f.reactions[j.name]
            # the joint's own columns, or its reaction's components in their order (a
            # moment is named M)
            comps = j.components or [(c, "N*m" if c == "M" else "N") for c in r]
            cols += [Column(f"{lab}.{c}", un, m(r[c]), self._note(j.name, c)) for c, un in comps]
        cols += self._friction_columns()
        for name, on in f.active.items():
            cols.append(Column(f"load.{name}.active", "-", on.astype(float)))
        solved = self.solution.ok  # the energies need the motion only, not the forces
        cols += [
            Column("energy.kinetic", "J", np.where(solved, f.kinetic, np.nan)),
            Column("energy.potential", "J", np.where(solved, f.potential, np.nan)),
            Column("power.input", "W", m(f.power_input)),
            Column("power.kinetic_rate", "W", m(f.kinetic_rate)),
            Column("power.potential_rate", "W", m(f.potential_rate)),
            Column("power.loads", "W", m(f.power_loads)),
            Column("power.residual", "W", m(f.residual)),
        ]
        if f.friction is not None:
            cols.insert(-1, Column("power.friction", "W", m(f.power_friction)))
        return cols

    def _friction_columns(self) -> list[Column]:
        """With friction in the joints: the driving effort without it, each joint's
        friction (a slider's force, a pin's moment) and the power it loses, and the
        instantaneous efficiency (see :meth:`efficiency`)."""
        f = self.forces
        fr = f.friction
        if fr is None:
            return []
        kind, unit = self.effort_name
        ideal = np.where(f.ok, fr.ideal_effort, np.nan)
        cols = [Column(f"input.{kind}_without_friction", unit, ideal)]
        for j in self.mechanism.joints:
            if j.name in fr.friction:
                lab = self.joint_label(j.name)
                un = "N*m" if j.coordinate == "angle" else "N"
                cols.append(Column(f"{lab}.friction", un, fr.friction[j.name]))
                cols.append(Column(f"{lab}.friction_power", "W", fr.loss[j.name]))
        cols.append(Column("efficiency.instant", "-", self.efficiency))
        return cols

    @property
    def efficiency(self) -> np.ndarray:
        """The instantaneous mechanical efficiency ``T_ideal / T = 1 - P_friction /
        P_input``: the driving effort without friction over the effort with it, for the
        same motion and loads. Given where the driver delivers power both with and without
        friction (elsewhere the loads or the stored energy drive the mechanism and the
        ratio is not an efficiency): empty there."""
        f = self._with_forces()
        if f.friction is None:
            return np.full(len(self.u), np.nan)
        p_in = np.where(f.ok, f.power_input, np.nan)
        p_ideal = f.friction.ideal_effort * f.speed
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where((p_in > 0) & (p_ideal > 0), p_ideal / p_in, np.nan)

    def _note(self, joint: str, component: str) -> str:
        """``minimum-norm`` for a reaction component that redundant constraints leave
        indeterminate."""
        return "minimum-norm" if component in self.forces.nonunique.get(joint, ()) else ""

    def power_scale(self) -> float:
        """The largest power term over the sweep: the scale of the power-balance check."""
        f = self.forces
        terms = [f.power_input, f.kinetic_rate, f.potential_rate, f.power_loads]
        vals = [np.nanmax(np.abs(np.where(f.ok, t, np.nan))) for t in terms if np.any(f.ok)]
        return float(max(vals)) if vals else 0.0

    def work(self) -> float:
        """Work done by the driver over the sweep (J); for a full turn, the work per cycle.
        See :func:`mechsolve.core.work.driver_work`."""
        return self._work_why()[0]

    @as_solved
    def _work_why(self) -> tuple[float, str]:
        """The driver's work and why it is not defined (see
        :func:`mechsolve.core.work.driver_work_why`), computed once."""

        if not hasattr(self, "_work"):
            self._with_forces()
            self._work = driver_work_why(self.analysis, self.solution, self.forces)
        return self._work

    def incomplete(self) -> bool:
        """Whether anything asked for was left out or is doubtful: positions not solved,
        rates or forces not determined at singular positions, or a warning (call after
        :meth:`summary`, which runs the checks). The command line warns then (exit 0)."""
        sol = self.solution
        return bool(
            self.failures
            or sol.rates_undetermined
            or (self.forces is not None and self.forces.singular)
            or self.warnings
        )

    @as_solved
    def mean_effort(self) -> tuple[float, str]:
        """The driver's mean effort and what it is: the work over the travel when the
        motion has no gaps (no unsolved positions, no dead zone stepped over between two
        samples) and goes one way (the exact mean over the sweep, between samples too),
        else the average of the solved samples, said so.

        A motion law that turns back (an oscillation, one that returns to its start) has
        no mean over the travel: the travel may be zero to rounding (``sin(t)`` over
        ``2 pi``: ``W / 2.4e-16``) and the angle is passed more than once. There the mean
        is over time, ``integral of T dt / duration`` (trapezoidal rule on the solved
        samples, as the RMS), said ``time mean``."""
        self._with_forces()
        u = np.asarray(self.u, float)
        du = np.diff(u)
        tol = 1e-12 * float(np.sum(np.abs(du)))  # rounding, against the path
        turns_back = bool(np.any(du > tol) and np.any(du < -tol))
        if self.mechanism.driver.motion is not None and (turns_back or abs(u[-1] - u[0]) <= tol):
            return self._time_mean_effort()
        work = self.work()
        travel = u[-1] - u[0]
        if math.isfinite(work) and travel != 0:
            return work / travel, "mean"
        e = np.where(self.forces.ok, self.forces.effort, np.nan)
        if not np.any(np.isfinite(e)):
            return float("nan"), "mean"
        return float(np.nanmean(e)), "mean of the solved positions"

    def _time_mean_effort(self) -> tuple[float, str]:
        """The driving effort's mean over time along a motion law (see
        :meth:`mean_effort`): over the intervals whose two samples are solved."""
        e = self.driving_effort
        ok = np.isfinite(e)
        for i, sign in ((int(np.nanargmax(e)), 1.0), (int(np.nanargmin(e)), -1.0)):
            if ok.any() and unbounded_towards(self, sign * e, i) is not None:
                return float("nan"), "time mean"  # infinite: it grows without bound
        both = ok[1:] & ok[:-1]
        for e in self.events:  # not across a dead zone stepped over between two samples
            if e.kind == "dead zone" and 0 <= e.after < len(both):
                both[e.after] = False
        dt = np.diff(np.asarray(self.t, float))[both]
        span = float(np.sum(dt))
        what = "time mean" if both.all() else "time mean of the solved positions"
        if not span > 0:
            return float("nan"), what
        return float(np.sum(0.5 * (e[1:][both] + e[:-1][both]) * dt) / span), what

    def is_full_cycle(self) -> bool:

        return full_cycle(self.linear, self.u)

    def status(self) -> list[str]:
        """Per position: ``ok`` or why it was not solved."""
        out = ["ok"] * len(self.u)
        for f in self.failures:
            for i in range(f.first, f.last + 1):
                # (a sweep that stopped following a branch: not known to be unassemblable)
                what = "not solved" if "cannot be followed" in f.reason else "unassemblable"
                out[i] = f"{what}: " + f.group
        for i in self.solution.rates_undetermined:  # blank velocities or accelerations
            if out[i] == "ok":
                out[i] = "singular: rates not determined (rounding near a singular position)"
        if self.forces is not None:
            for i, label in self.forces.singular:
                if out[i] == "ok":
                    out[i] = f"singular: forces indeterminate in {label}"
            fr = self.forces.friction
            for i in np.flatnonzero(fr.locked) if fr is not None else ():
                if out[i] == "ok":
                    out[i] = "self-locking: no finite driving effort moves it"
        return out

    def methods(self) -> list[str]:
        """How each position was solved (``closed form``, ``newton``, ``scipy-hybr``...)."""
        m = self.solution.methods
        if m is None:
            return ["closed form" if ok else "" for ok in self.ok]
        return [str(x) if ok else "" for x, ok in zip(m, self.ok)]

    def to_csv(self, path, units: OutputUnits | None = None) -> Path:
        """Write the table as CSV (see :mod:`mechsolve.results.csv`) in ``units`` (SI
        when not given; ``self.mechanism.output_units()`` for the file's, or a text as
        ``--units`` takes it: ``"SI"``, ``"file"``, ``"length=mm,force=kN"``); return the
        path."""
        if isinstance(units, str):
            try:
                units = parse_output_units(units, self.mechanism.output_units())
            except UnitError as exc:
                raise InputError(f"units={units!r}: {exc}") from None
        elif units is not None and not isinstance(units, OutputUnits):
            raise InputError(
                f"units={units!r}: expected res.mechanism.output_units(), an OutputUnits, or "
                "a text as --units takes it ('SI', 'file', 'length=mm,force=kN')"
            )
        return write_csv(self, path, units)
