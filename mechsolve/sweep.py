"""The kinematic sweep: assemble at the start, then solve every driver position.

Pipeline (one model, one constraint system, arrays over positions):

1. :class:`Analysis` builds the :class:`~mechsolve.constraints.ConstraintSystem` and the
   plan of group solvers (:func:`~mechsolve.groups.build_plan`).
2. :meth:`Analysis.assemble` closes the mechanism at the start position and fixes the
   assembly branch of every group: from the user's conditions, then the sketch, else
   the documented default (branch +1 of each group).
3. :meth:`Analysis.solve` solves positions group by group for all positions at once
   (closed-form groups) or by continuation (Newton groups), marks positions where a group
   cannot close, checks the full constraint residual at every position, then computes
   velocities and accelerations from the differentiated constraints.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .conditioning import SINGULAR_INDICATOR, group_block, rcond
from .constraints import ConstraintSystem
from .errors import AssemblyError, CannotCloseAtStart, InputError, SolverError
from .expr import Ref, Side
from .groups import Drive, Group, NewtonGroup, build_plan
from .model import GROUND, MAX_POSITIONS, Limit, Mechanism, PinJoint, SliderJoint
from .numerics import brent_root
from .solvers.newton import solve as newton_solve
from .state import State
from .structure import RedundantStructure


@dataclass
class PointRef:
    body: int
    local: np.ndarray


class StateView:
    """Read quantities of named points, links and sliders from a :class:`State`.

    Implements the :class:`~mechsolve.expr.Context` protocol for conditions.
    """

    def __init__(self, analysis: Analysis, st: State, drive: Drive | None = None) -> None:
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
class Redundancy:
    """Redundant constraints found at the start position.

    ``count`` equations repeat the others: the constraint Jacobian has rank ``rank``, less
    than its number of equations. ``equations`` names the equations that take part in the
    dependencies (any ``count`` of them could be left out).
    """

    count: int
    rank: int
    equations: list[str]
    removable: list[str] = field(default_factory=list)

    def suggestion(self) -> str:
        """Which constraints a user could remove to make the mechanism determinate."""
        if not self.removable:
            return ""
        return (
            f"without {' and '.join(self.removable)} the constraints are independent and "
            "still determine the motion (a revolute joint's single component: let that "
            "joint slide along it, a pin in a slot)"
        )


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


@dataclass
class Solution:
    """Everything the sweep computed, before formatting."""

    analysis: Analysis
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


class Analysis:
    """The constraint system and group plan of a mechanism, ready to solve positions.

    Parameters
    ----------
    mech
        A validated mechanism with a driver.
    method
        ``"auto"`` (default: the file's ``solver.method``) or ``"newton"``.
    """

    def __init__(self, mech: Mechanism, method: str | None = None) -> None:
        if mech.driver is None:
            raise mech.error(("driver",), "the mechanism has no driver: add a 'driver' section")
        self.mech = mech
        self.system = ConstraintSystem(mech)
        self.scale = _scale(mech)
        self.atol = mech.solver.tolerance * self.scale
        self.method = method or mech.solver.method
        # the assembly at the start always uses the split into groups, so that branch
        # conditions apply loop by loop; the sweep uses the chosen method
        its = mech.solver.max_iterations
        self.redundant: list = []  # surplus equations (constraint, index), if any
        self.redundancy: Redundancy | None = None
        try:
            self.groups: list[Group] = build_plan(self.system, "auto", self.atol, its)
        except RedundantStructure as exc:
            # redundant constraints: assemble on the others, sweep by least squares on all
            self.redundant = exc.extra
            self.groups = build_plan(self.system.without(exc.extra), "auto", self.atol, its)
            self.method = "newton"
        if self.redundant:
            self.plan = [
                NewtonGroup(
                    list(range(self.system.nb)),
                    list(self.system.constraints),
                    self.system.body_names,
                    self.atol,
                    its,
                )
            ]
        elif self.method == "auto":
            self.plan = self.groups
        else:
            self.plan = build_plan(self.system, self.method, self.atol, its)
        for g in self.groups + self.plan:
            if hasattr(g, "scale"):
                g.scale = self.scale
            if hasattr(g, "lref"):
                g.lref = self.scale
            if hasattr(g, "direction"):
                g.direction = float(mech.driver.direction)
        self.points: dict[str, PointRef] = {}
        nb = self.system.nb
        for p, xy in mech.ground.items():
            self.points[p] = PointRef(nb, np.asarray(xy, float))
        for lk in mech.links:  # a point on the ground and a link is a ground point
            b = self.system.index[lk.name]
            for p, xy in lk.points.items():
                self.points.setdefault(p, PointRef(b, np.asarray(xy, float)))
        d = mech.driver
        self.linear = isinstance(mech.joint(d.joint), SliderJoint)
        self.speed = d.speed
        # for messages: the name of the inner point of each joint
        self.joint_point = {
            self.system.by_joint[j.name]: (j.point if isinstance(j, PinJoint) else j.name)
            for j in mech.joints
        }
        self.joint_point[self.system.driver] = d.joint

    def reversed(self) -> Analysis:
        """The same analysis with the driver moving the other way from its start (for
        positions behind the start)."""
        import copy

        mech = copy.copy(self.mech)
        d = self.mech.driver
        mech.driver = dataclasses.replace(d, speed=-d.speed, sense=-d.direction)
        return Analysis(mech, self.method)

    def motion_values(self, time_step: float | None = None):
        """``(u, t, u', u'')`` of the sweep of a driver with a motion law: at time steps
        over the sweep's duration, or (constant acceleration over an angle range) at the
        sweep's driver steps, each at the time the law reaches it."""
        d = self.mech.driver
        law = d.motion
        sw = self.mech.sweep
        if sw.duration is None:
            u, _ = self.sweep_values(float(d.start))
            t = law.time_at(d.direction * (u - float(d.start)))
            reach = np.isfinite(t)
            if not reach.all():
                k = int(np.argmin(reach))
                raise self.mech.error(
                    ("sweep",),
                    f"the motion never reaches {self.format_u(float(u[k]))}: it stops and "
                    "turns back before; sweep it in time (duration, time_step) instead",
                )
        else:
            dt = time_step or sw.time_step
            n = max(0, math.ceil(sw.duration / dt - 1e-9))
            if n >= MAX_POSITIONS:
                raise self.mech.error(("sweep",), "too many positions for one run")
            t = np.minimum(np.arange(n + 1) * dt, sw.duration)
        u, ud, udd = law.at(t)
        bad = ~(np.isfinite(u) & np.isfinite(ud) & np.isfinite(udd))
        if bad.any():
            k = int(np.argmax(bad))
            raise self.mech.error(
                ("driver", "motion"), f"the motion law is not finite at t = {t[k]:.6g} s"
            )
        return u, t, ud, udd

    # -- driver ---------------------------------------------------------------------
    def drive(self, u: np.ndarray) -> Drive:
        u = np.asarray(u, float)
        return Drive(u, np.full(u.shape, self.speed), np.zeros(u.shape))

    def format_u(self, u: float) -> str:
        if self.linear:
            return f"driver position {u:.6g} m"
        return f"driver angle {angle_deg(u):.6g}°"

    def sweep_values(self, u0: float, step: float | None = None, travel: float | None = None):
        """Driver values and times of the positions of the sweep."""
        sw = self.mech.sweep
        travel = sw.travel if travel is None else travel
        step = sw.step if step is None else step
        if travel is None:
            if self.linear:
                raise self.mech.error(
                    ("sweep",), "a linear driver needs 'range' or 'to' in the 'sweep' section"
                )
            travel = 2 * math.pi
        if step is None:
            step = math.radians(1.0) if not self.linear else travel / 100 if travel else 1.0
        ratio = travel / step
        if not ratio < MAX_POSITIONS:
            raise self.mech.error(
                ("sweep",),
                f"the sweep has {ratio:.3g} positions, more than the {MAX_POSITIONS:,} "
                "mechsolve solves in one run: use a larger step or a smaller range",
            )
        n = max(0, math.ceil(ratio - 1e-9))
        k = np.arange(n + 1, dtype=float)
        dist = np.minimum(k * step, travel)
        u = u0 + self.mech.driver.direction * dist
        t = dist / abs(self.speed) if self.speed else np.zeros_like(dist)
        return u, t

    # -- positions ------------------------------------------------------------------
    def assemble(self, u0: float) -> StartAssembly:
        """Close the mechanism at driver value ``u0`` and choose every group's branch."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self._assemble(u0)

    def _assemble(self, u0: float) -> StartAssembly:
        mech = self.mech
        # two columns: the "+" and "-" branches of the group being decided; equal otherwise
        st2 = State(self.system.nb, 2)
        drive2 = self.drive(np.array([u0, u0]))
        unit2 = Drive(drive2.u, np.ones(2), np.zeros(2))  # rates per unit driver coordinate
        drive = self.drive(np.array([u0]))
        asm = mech.assembly
        conds = _PendingConditions(self, asm.conditions)
        modes: list[float] = []
        reasons: list[str] = []
        q_start: dict[int, np.ndarray] = {}
        view = StateView(self, st2)
        view.has_velocity = view.has_acceleration = False
        for gi, g in enumerate(self.groups):
            conds.solved(g.bodies)
            ready = conds.ready()
            if isinstance(g, NewtonGroup):
                q = self._assemble_newton_group(g, st2, drive, ready, u0)
                q_start[gi] = q
                g.set_q(st2, 0, q)
                g.set_q(st2, 1, q)
                g.velocity(st2, unit2)
                modes.append(1.0)
                reasons.append("from the sketch" if asm.sketch else "from the links' frames")
                conds.use(ready)
                continue
            if g.n_modes < 2:
                ok, _ = g.position(st2, drive2, 1.0)
                if not ok[0]:
                    raise self._cannot_close(g, st2, u0)
                g.velocity(st2, unit2)
                modes.append(1.0)
                reasons.append("")
                continue
            # both branches at once, one in each column
            ok2, _ = g.position(st2, drive2, np.array([1.0, -1.0]))
            if not ok2.any():
                raise self._cannot_close(g, st2, u0)
            g.velocity(st2, unit2)
            j, reason = self._choose(
                g, *self._where_to_choose(gi, g, st2, ok2, modes, q_start, u0), ready
            )
            mode = 1.0 if j == 0 else -1.0
            if _coincident_at(g, st2, 0):  # the limit from the side the motion goes to
                g.position(st2, drive2, np.array([-mode, -mode]))
                g.velocity(st2, unit2)
            bodies = list(g.bodies)  # keep the chosen branch in both columns
            st2.block[:, bodies, 1 - j] = st2.block[:, bodies, j]
            st2.token = State.new_token()
            modes.append(mode)
            reasons.append(reason)
            conds.use(ready)
        st = st2  # both columns hold the chosen assembly; index 0 is the start
        view = StateView(self, st)
        view.has_velocity = view.has_acceleration = False
        for _, c in conds.remaining():  # conditions that no group decided: they must hold
            if not bool(np.all(c.evaluate(view))):
                raise AssemblyError(
                    f"{self._file()}the start position does not satisfy the assembly condition "
                    f"{c.text!r}, and no loop's branch can change that"
                )
        if self.redundant:
            self.redundancy = self._check_redundancy(st, drive)
        group_modes = list(modes)
        if self.plan is not self.groups:  # monolithic Newton starts from the assembled pose
            q_start = {
                gi: g.get_q(st, 0) for gi, g in enumerate(self.plan) if isinstance(g, NewtonGroup)
            }
            modes = [1.0] * len(self.plan)
        return StartAssembly(modes, q_start, reasons, st, u0, group_modes)

    def _assemble_newton_group(self, g: NewtonGroup, st2: State, drive: Drive, ready, u0):
        """Close a Newton group at the start, on a configuration that satisfies the
        assembly conditions that apply to it.

        The first guess places the links as their frames (or the sketch) say. Where that
        guess is itself a singular configuration (links drawn collinear, as a file often
        draws them), the direction of Newton's first step is decided by rounding, and so
        by the linear algebra library: such a guess is not used. Further guesses turn
        each link by fixed pseudo-random angles (the same on every machine); the first
        closed configuration that satisfies the conditions is taken.
        """
        st = st2.take([0])
        solver = g
        if any(getattr(c, "base", None) is not None for c in g.constraints):
            # a group that lost redundant equations: close it on all of them, by
            # least squares, so that it lands on the configuration they agree on
            full = [getattr(c, "base", c) for c in g.constraints]
            solver = NewtonGroup(g.bodies, full, self.system.body_names, self.atol, 50)
        view = StateView(self, st2)
        view.has_velocity = view.has_acceleration = False
        rng = np.random.default_rng(20261123)
        first = None  # the first closed configuration, and its residual
        worst = math.inf
        tries = 1 + NEWTON_START_TRIES
        for k in range(tries):
            turn = None if k == 0 else rng.uniform(-math.pi, math.pi, len(g.bodies))
            q0 = self._initial_guess(g, st, turn)
            if k == 0:
                g.set_q(st, 0, q0)
                if rcond(group_block(g, st)[0])[0] < START_GUESS_RCOND:
                    continue  # a singular guess: which branch Newton takes is rounding
            q, stats = solver.solve_at(st, drive.u, q0)
            if not stats.converged:
                worst = min(worst, stats.residual)
                continue
            if first is None:
                first = q
            if not ready:
                return q
            g.set_q(st2, 0, q)
            g.set_q(st2, 1, q)
            if all(bool(np.all(c.evaluate(view))) for _, c in ready):
                return q
        if first is None and solver is not g:
            raise AssemblyError(
                f"{self._file()}the mechanism is over-constrained and cannot close at "
                f"{self.format_u(u0)}: the redundant constraints of the {g.label} "
                f"disagree by {worst:.3g} m (check the dimensions of the redundant links)"
            )
        if first is None:
            raise CannotCloseAtStart(
                f"{self._file()}cannot assemble at {self.format_u(u0)}: Newton-Raphson "
                f"and scipy found no closed position of the {g.label} (residual "
                f"{worst:.3g} m); give approximate positions under 'assembly: sketch:'",
                g.label,
                f"{g.label}: Newton-Raphson and scipy found no closed position",
            )
        texts = ", ".join(repr(c.text) for _, c in ready)
        raise AssemblyError(
            f"{self._file()}no closed position of the {g.label} found from "
            f"{tries} start guesses satisfies {texts}; give approximate positions under "
            "'assembly: sketch:'"
        )

    def assembly_guess(self, u: float, start: StartAssembly) -> State | None:
        """The mechanism closed at driver value ``u`` by the assembly groups on the start's
        branches (None if some group has no closed form or cannot close there): where a
        Newton sweep restarts after a dead zone, so that it resumes on the user's branch."""
        st = State(self.system.nb, 1)
        drive = self.drive(np.array([u]))
        with np.errstate(invalid="ignore", divide="ignore"):
            for g, mode in zip(self.groups, start.group_modes):
                ok, _ = g.position(st, drive, mode)
                if not ok[0]:
                    return None
        return st

    def _decide_at_start(self, gi, g, st, start, conds: _PendingConditions) -> None:
        """Choose a group's branch at the sweep's first position, as :meth:`assemble`
        does, before the group is solved over the sweep (the groups before it are)."""
        ready = conds.ready()
        conds.use(ready)
        has_sketch = any(self.points[p].body in g.bodies for p in self.mech.assembly.sketch)
        if ready and not has_sketch:
            # a condition that is the group's own branch statement ("B left of A -> O4"
            # for the loop A-B-O4) decides it without solving anything
            modes = {
                g.mode_of_side(t.point, t.side, t.start, t.end, self.joint_point)
                if isinstance(t := c.tree, Side)
                else None
                for _, c in ready
            }
            if len(modes) == 1 and None not in modes:
                texts = ", ".join(repr(c.text) for _, c in ready)
                start.reasons[gi] = f"assembly condition {texts}"
                start.modes[gi] = modes.pop()
                return
        # both branches at the first position, one in each column
        two = st.take([0, 0])
        u0 = start.u0
        ok2, _ = g.position(two, self.drive(np.array([u0, u0])), np.array([1.0, -1.0]))
        if not ok2.any():
            raise self._cannot_close(g, two, u0)
        if not ready and not has_sketch and ok2[0]:
            start.reasons[gi] = "default branch (+)"
            return
        j, reason = self._choose(
            g, *self._where_to_choose(gi, g, two, ok2, start.modes, start.q_start, u0), ready
        )
        start.reasons[gi] = reason
        start.modes[gi] = 1.0 if j == 0 else -1.0

    def _cannot_close(self, g: Group, st: State, u0: float, first_ok=None) -> CannotCloseAtStart:
        reason = g.fail_reason(st, 0)
        return CannotCloseAtStart(
            f"{self._file()}cannot assemble at {self.format_u(u0)}: {reason}",
            g.label,
            reason,
            first_ok,
        )

    def solve_sweep(
        self,
        u: np.ndarray,
        velocity: bool = True,
        acceleration: bool = True,
        per_unit_driver: bool = False,
    ):
        """Solve a sweep from its start, as :meth:`solve`; where the mechanism cannot close
        at the start (a dead zone there), skip ahead to the first position where it
        closes, assemble there (on the branches the conditions and sketch ask for), and
        keep the positions skipped as unassemblable rows."""
        u = np.asarray(u, float)
        k = 0
        first: CannotCloseAtStart | None = None
        while True:
            try:
                sol = self.solve(
                    u[k:],
                    velocity=velocity,
                    acceleration=acceleration,
                    per_unit_driver=per_unit_driver,
                )
                break
            except CannotCloseAtStart as exc:
                if first is None:
                    first = exc
                nxt = k + (exc.first_ok if exc.first_ok else 1)
                if nxt >= len(u) or nxt <= k:
                    raise first from None
                k = nxt
        if k:
            sol = _prepend_gap(self, sol, u, k, first)
        self.locate_edges(sol)
        return sol

    def locate_edges(self, sol: Solution) -> None:
        """Where each unassemblable range truly begins and ends: the root of the failing
        loop's discriminant between the last position that closes and the first that does
        not (bisection to rounding, the end kept on the side that closes)."""
        if not sol.failures:
            return
        ctx = _Context(self, sol.state, sol.u, sol.start, sol.flips, {})
        ctx.is_start = False
        labels = {g.label: gi for gi, g in enumerate(self.plan)}
        n = len(sol.u)
        with np.errstate(invalid="ignore", divide="ignore"):
            for f in sol.failures:
                gi = labels.get(f.group)
                if gi is None or self.plan[gi].n_modes != 2:
                    continue
                if f.first > 0 and sol.ok[f.first - 1]:
                    f.edge_in = self._edge(ctx, gi, f.first - 1, f.first)
                if f.last < n - 1 and sol.ok[f.last + 1]:
                    f.edge_out = self._edge(ctx, gi, f.last + 1, f.last)

    def _edge(self, ctx: _Context, gi: int, good: int, bad: int) -> float:
        g = self.plan[gi]
        near = min(good, bad)

        def H(x: float) -> float:
            return float(g.disc(ctx.prefix(gi, np.array([x]), near))[0][0])

        a, b = float(ctx.u[good]), float(ctx.u[bad])
        if not (H(a) >= -TOUCH and H(b) < -TOUCH):
            return math.nan
        for _ in range(200):
            m = 0.5 * (a + b)
            if m in (a, b):
                break
            if H(m) >= 0.0:
                a = m
            else:
                b = m
        return a

    def _where_to_choose(self, gi: int, g: Group, st2: State, ok2, modes, q_start, u0: float):
        """Where a group's branch is read at the start: at the start itself, or, where
        the group is singular there (its two branches meet: a toggle, a bifurcation,
        coincident joints), just past it, where the branches differ. Returns the state
        with both branches (one in each column) and where each closes."""
        H = g.disc(st2)[0]
        if not (np.isfinite(H[0]) and H[0] <= TOUCH):
            return st2, ok2
        d = self.mech.driver.direction
        delta = START_PROBE * (self.scale if self.linear else 1.0)
        for side in (1.0, -1.0):  # the side the motion goes to, else where it comes from
            u = u0 + side * d * delta
            st = self._groups_at(u, gi, modes, q_start)
            if st is None:
                continue
            unit = Drive(np.array([u, u]), np.ones(2), np.zeros(2))
            ok, _ = g.position(st, unit, np.array([side, -side]))
            if ok.any():
                return st, ok
        return st2, ok2

    def _groups_at(self, u: float, upto: int, modes, q_start) -> State | None:
        """The assembly groups before ``upto`` solved at driver value ``u`` (two equal
        columns) on the given branches, with their rates; None if one cannot close."""
        st = State(self.system.nb, 2)
        unit = Drive(np.array([u, u]), np.ones(2), np.zeros(2))
        with np.errstate(invalid="ignore", divide="ignore"):
            for gj in range(upto):
                h = self.groups[gj]
                if isinstance(h, NewtonGroup):
                    st1 = st.take([0])
                    q, stats = h.solve_at(st1, unit.u[:1], q_start[gj])
                    if not stats.converged:
                        return None
                    h.set_q(st, 0, q)
                    h.set_q(st, 1, q)
                    st.token = State.new_token()
                else:
                    ok, _ = h.position(st, unit, modes[gj])
                    if not ok.all():
                        return None
                h.velocity(st, unit)
        return st

    def condition_bodies(self, c) -> set[int]:
        """The bodies whose poses a condition reads."""
        bodies = set()
        for p in c.points():
            if p in self.points:
                bodies.add(self.points[p].body)
            elif p in self.system.index:
                bodies.add(self.system.index[p])
        return bodies

    def _lazy_start(self) -> bool:
        """Can the branches be chosen inside the sweep (no separate assembly pass)?"""
        return self.plan is self.groups and not any(isinstance(g, NewtonGroup) for g in self.plan)

    def _check_redundancy(self, st: State, drive: Drive) -> Redundancy:
        """At the assembled start: are the surplus equations consistent, and which ones
        take part in a dependency (the left null space of Phi_q)?"""
        sys_ = self.system
        res = np.abs(sys_.residual(st, drive.u)[:, 0])
        names = sys_.equation_names()
        if np.max(res) > self.atol:
            k = int(np.argmax(res))
            raise AssemblyError(
                f"{self._file()}the mechanism is over-constrained and cannot close at "
                f"{self.format_u(float(drive.u[0]))}: the equation {names[k]!r} is off by "
                f"{res[k]:.3g} m once the others are met (check the dimensions of the "
                "redundant links)"
            )
        J = sys_.jacobian(st)[0]
        U, sv, _ = np.linalg.svd(J)
        rank = int(np.sum(sv > 1e-9 * sv[0]))
        if rank < sys_.nq:
            raise AssemblyError(
                f"{self._file()}the constraints leave {sys_.nq - rank} coordinate(s) free at "
                f"{self.format_u(float(drive.u[0]))}: the mechanism is not determined"
            )
        # the equations that take part in a dependency: nonzero in the left null space
        null = U[:, rank:]
        involved = np.flatnonzero(np.max(np.abs(null), axis=1) > 1e-8)
        # single equations that can go, the last in the file first (the added link):
        # leaving one out keeps the rank, so the others still determine every coordinate
        keep = list(range(sys_.nc))
        tol = 1e-9 * sv[0]
        gone: list[int] = []
        for k in reversed(involved.tolist()):
            if len(gone) == sys_.nc - rank:
                break
            trial = [r for r in keep if r != k]
            if np.sum(np.linalg.svd(J[trial], compute_uv=False) > tol) == rank:
                keep = trial
                gone.append(k)
        removable = []
        row = 0
        for c in sys_.constraints:
            rows = set(range(row, row + c.m))
            row += c.m
            if rows <= set(gone):
                removable.append(f"joint {c.name}")
            else:
                removable += [names[k] for k in sorted(rows & set(gone))]
        return Redundancy(sys_.nc - rank, rank, [names[k] for k in involved], removable)

    def _choose(self, g: Group, st2: State, ok2: np.ndarray, ready) -> tuple[int, str]:
        """The column (0: branch +, 1: branch -) to keep: the conditions that apply, then
        the sketch, then branch +."""
        if ok2.sum() == 1:
            return int(np.flatnonzero(ok2)[0]), "the only branch that closes"
        if ready:
            view = StateView(self, st2)
            view.has_velocity = view.has_acceleration = False
            sat = np.ones(2, bool)
            for _, c in ready:
                sat &= np.broadcast_to(np.asarray(c.evaluate(view), bool), (2,))
            texts = ", ".join(repr(c.text) for _, c in ready)
            if not sat.any():
                raise AssemblyError(f"{self._file()}no branch of the {g.label} satisfies {texts}")
            if sat.sum() == 1:
                return int(np.flatnonzero(sat)[0]), f"assembly condition {texts}"
        sketch = {
            p: xy for p, xy in self.mech.assembly.sketch.items() if self.points[p].body in g.bodies
        }
        if sketch:
            dist = np.zeros(2)
            for p, (sx, sy) in sketch.items():
                ref = self.points[p]
                x, y = st2.point(ref.body, ref.local)
                dist += (x - sx) ** 2 + (y - sy) ** 2
            return int(np.argmin(dist)), "nearest to the sketch"
        return 0, "default branch (+)"

    def _initial_guess(
        self, g: NewtonGroup, st: State, turn: np.ndarray | None = None
    ) -> np.ndarray:
        """A start guess for a Newton group: from the sketch, else the links' frames.

        Each body is placed so that one of its joint points (to a body already placed)
        coincides, with the orientation that best fits any sketched points, turned by
        ``turn[k]`` (rad) for the group's k-th body when given.
        """
        placed = {b for b in range(self.system.nb + 1) if b not in g.bodies}
        q = np.zeros(g.n)
        sketch = self.mech.assembly.sketch
        todo = list(g.bodies)
        guard = 0
        while todo and guard < 10 * len(g.bodies):
            guard += 1
            b = todo.pop(0)
            anchor = None
            for c in g.constraints:
                if c.kind != "revolute" or b not in (c.a, c.b):
                    continue
                other = c.b if c.a == b else c.a
                if other in placed:
                    s_b = c.sa if c.a == b else c.sb
                    s_o = c.sb if c.a == b else c.sa
                    anchor = (s_b, st.point(other, s_o))
                    break
            if anchor is None and todo and guard < 5 * len(g.bodies):
                todo.append(b)
                continue
            name = self.system.body_names[b]
            # Known points of the body: its anchor (where it joins a placed body) and
            # its sketched points; the orientation is the rotation that best maps the
            # local coordinates onto them (2-D Procrustes), the anchor kept exact.
            pairs = [
                (np.asarray(xy, float), np.asarray(sketch[p], float))
                for p, xy in self.mech.link(name).points.items()
                if p in sketch
            ]
            if anchor is not None:
                s_b, (ax, ay) = anchor
                pairs.insert(0, (np.asarray(s_b, float), np.array([ax[0], ay[0]], float)))
            th = 0.0
            if len(pairs) >= 2:
                loc = np.array([p[0] for p in pairs])
                glo = np.array([p[1] for p in pairs])
                loc, glo = loc - loc.mean(0), glo - glo.mean(0)
                cross = float(np.sum(loc[:, 0] * glo[:, 1] - loc[:, 1] * glo[:, 0]))
                dot = float(np.sum(loc * glo))
                if cross or dot:
                    th = math.atan2(cross, dot)
            if turn is not None:
                th += float(turn[g.col[b]])
            c, s = math.cos(th), math.sin(th)
            if pairs:
                (lx, ly), (gx, gy) = pairs[0]
                x = gx - (c * lx - s * ly)
                y = gy - (s * lx + c * ly)
            else:
                x = y = 0.0
            k = g.col[b]
            q[3 * k : 3 * k + 3] = (x, y, th)
            st.x[b, 0], st.y[b, 0] = x, y
            st.set_angle(b, th, 0)
            placed.add(b)
        return q

    def _file(self) -> str:
        src = self.mech.source
        return f"{src.file}: " if src is not None and src.file else ""

    # -- the start ------------------------------------------------------------------
    def start_value(self) -> float:
        """The driver value at the start of the sweep (solving for a limit if asked)."""
        d = self.mech.driver
        if not isinstance(d.start, Limit):
            return float(d.start)
        if self.linear:
            raise self.mech.error(
                d.where + ("start",), "a limit start needs a revolute driver; give a number"
            )
        return self.find_limit(d.start)

    def find_limit(self, lim: Limit, u_from: float = 0.0) -> float:
        """Driver angle at which ``lim.quantity`` is extreme over one turn."""
        u, _ = self.sweep_values(u_from, step=math.radians(1.0), travel=2 * math.pi)
        sol = self.solve(u, start=self.assemble(u_from))
        view = StateView(self, sol.state)
        vals = np.asarray(lim.quantity.evaluate(view), float) * np.ones(len(u))
        vals = np.where(sol.ok, vals, np.nan)
        if not np.any(np.isfinite(vals)):
            raise AssemblyError(f"{self._file()}cannot find the limit of {lim.quantity.text!r}")
        sign = 1.0 if lim.extreme == "min" else -1.0
        i = int(np.nanargmin(sign * vals))
        asm = sol.start
        h = math.radians(1.0)

        def at(x: float, attr: str | None = None) -> float:
            s = self.solve(np.array([x]), start=asm, near=(sol, i))
            view = StateView(self, s.state)
            if attr is None:
                v = lim.quantity.evaluate(view)
            else:
                tree = lim.quantity.tree
                v = view.quantity(tree.name, attr)
            return float(np.asarray(v, float).ravel()[0])

        # an extreme of a coordinate is where its rate vanishes: find that root exactly
        tree = lim.quantity.tree
        rate = _RATE.get(getattr(tree, "attr", None)) if isinstance(tree, Ref) else None
        if rate is not None:
            lo, hi = u[i] - h, u[i] + h
            flo, fhi = at(lo, rate), at(hi, rate)
            if np.isfinite(flo) and np.isfinite(fhi) and flo * fhi < 0:
                try:
                    return brent_root(
                        lambda x: at(x, rate), lo, hi, xtol=1e-15, rtol=1e-15, fa=flo, fb=fhi
                    )
                except (ValueError, RuntimeError):
                    pass  # find the extreme by minimisation instead
        from scipy.optimize import minimize_scalar

        res = minimize_scalar(
            lambda x: sign * at(x),
            bounds=(u[i] - h, u[i] + h),
            method="bounded",
            options={"xatol": 1e-11},
        )
        return float(res.x)

    # -- the sweep ------------------------------------------------------------------
    def sigma_at(self, sigma0: float, flips: list[float], u: np.ndarray) -> np.ndarray:
        """A two-branch group's branch at driver values ``u``, given its start branch and the
        driver values where the sweep followed it through a bifurcation."""
        u = np.asarray(u, float)
        out = np.full(u.shape, float(sigma0))
        d = self.mech.driver.direction
        for uf in flips:
            out = np.where(d * (u - uf) > 0, -out, out)
        return out

    def solve(
        self,
        u: np.ndarray,
        start: StartAssembly | None = None,
        velocity: bool = True,
        acceleration: bool = True,
        near: tuple[Solution, int] | None = None,
        per_unit_driver: bool = False,
        follow: Solution | None = None,
        limits: bool = True,
    ) -> Solution:
        """Solve positions (and velocities and accelerations) at driver values ``u``.

        ``u[0]`` is the start of the sweep unless ``start`` is given; with ``near``, the
        positions are solved close to sample ``i`` of a solved sweep, on its branches;
        with ``follow``, ``u`` continues a solved sweep from its last position (chunks).
        Groups are solved one after another for all positions at once. Derivatives are
        computed per unit of the driver coordinate and scaled by the driver's speed at the
        end, so that the branch analysis has tangents even for a sweep at rest
        (``per_unit_driver`` keeps them per unit driver coordinate). At a position where a
        group is singular the rates are the limits along the followed motion (see
        :meth:`_rates_at_singular`; ``limits=False`` leaves them as computed).
        """
        u = np.asarray(u, float)
        n = len(u)
        lazy = start is None and near is None and follow is None and self._lazy_start()
        if lazy:  # the branches are chosen as the groups are solved, at the first position
            ng = len(self.plan)
            start = StartAssembly([1.0] * ng, {}, [""] * ng, None, float(u[0]), [1.0] * ng)
            conds = _PendingConditions(self, self.mech.assembly.conditions)
        elif start is None:
            start = self.assemble(float(u[0]))
        st = State(self.system.nb, n)
        unit = Drive(u, np.ones(n), np.zeros(n))  # derivatives per unit driver coordinate
        analyse = near is None and n > 1
        derivs = velocity or acceleration or analyse
        q_start = dict(start.q_start)
        flips = {gi: [] for gi in range(len(self.plan))}
        if near is not None or follow is not None:
            # near: single positions next to a solved sweep; follow: the next chunk of a
            # sweep, starting at the previous chunk's last position, on its branches
            sol0 = near[0] if near is not None else follow
            solved = np.flatnonzero(sol0.ok)
            i0 = near[1] if near is not None else (int(solved[-1]) if solved.size else -1)
            flips = {gi: list(v) for gi, v in sol0.flips.items()}
            for gi, g in enumerate(self.plan):
                if isinstance(g, NewtonGroup) and i0 >= 0:
                    q_start[gi] = g.get_q(sol0.state, i0)
        ok_all = np.ones(n, bool)
        oks, inds = [], []
        iters = np.zeros(n, int)
        methods = _Methods(n)
        events: list[Event] = []
        warnings: list[str] = []
        ctx = _Context(self, st, u, start, flips, q_start)
        ctx.is_start = near is None and follow is None
        two = [gi for gi, g in enumerate(self.plan) if g.n_modes == 2]
        if analyse and two:
            ctx.build_grid(EVENT_STEP * (self.scale if self.linear else 1.0))
            ctx.grid_upto = max(two)
        with np.errstate(invalid="ignore", divide="ignore"):
            for gi, g in enumerate(self.plan):
                if isinstance(g, NewtonGroup):
                    ok, it, meth = g.sweep(
                        st,
                        unit,
                        q_start[gi],
                        ok_all,
                        prefix=lambda uu, k, gi=gi: ctx.prefix(gi, uu, k),
                        restart=lambda i, g=g: _restart_guess(self, g, float(u[i]), start),
                    )
                    iters = np.maximum(iters, it)
                    methods.merge(meth)
                    if derivs:
                        g.velocity(st, unit)
                    if acceleration:
                        g.acceleration(st, unit)
                    ind = np.ones(n)  # conditioning of Newton groups: see jacobian_rcond()
                else:
                    if g.n_modes == 2 and analyse:
                        evs, warn = self._branch_events(gi, g, ctx, ok_all)
                        events += evs
                        warnings += warn
                    if lazy:
                        conds.solved(g.bodies)
                        if g.n_modes == 2:
                            self._decide_at_start(gi, g, st, start, conds)
                    if ctx.is_start and n and _coincident_at(g, st, 0):
                        # the start's branch is the one taken from the start; the pose at
                        # the start itself is the limit from that side (see RRR)
                        flips[gi][:0] = [-math.inf * self.mech.driver.direction, float(u[0])]
                    sigma = self.sigma_at(start.modes[gi], flips[gi], u)
                    ok, ind = g.position(st, unit, sigma)
                    if lazy and not ok[0]:
                        closes = np.flatnonzero(ok & ok_all)
                        raise self._cannot_close(
                            g, st, start.u0, int(closes[0]) if closes.size else None
                        )
                    if derivs:
                        g.velocity(st, unit)
                    if acceleration:
                        g.acceleration(st, unit)
                ok = ok & ok_all
                oks.append(ok)
                inds.append(ind)
                ok_all = ok_all & ok
                ctx.extend_grid(gi)
        if lazy:
            start.state = st.take([0])
            start.group_modes = list(start.modes)
            view = StateView(self, start.state)
            view.has_velocity = view.has_acceleration = False
            for _, c in conds.remaining():  # conditions no group decided: they must hold
                if not bool(np.all(c.evaluate(view))):
                    raise AssemblyError(
                        f"{self._file()}the start position does not satisfy the assembly "
                        f"condition {c.text!r}, and no loop's branch can change that"
                    )
        ok = ok_all.copy()
        res = None
        if any(isinstance(g, NewtonGroup) for g in self.plan):
            # check the full constraint residual everywhere; polish where needed
            with np.errstate(invalid="ignore"):
                res = self.system.max_residual(st, u)
            bad = ok & ~(res <= self.atol)
            for i in np.flatnonzero(bad):
                ok[i], res[i], it = self._polish(st, unit, i)
                iters[i] += it
                methods.append(i, "newton polish")
            res = np.where(ok, res, np.nan)
        # derivatives per unit driver coordinate -> time derivatives at constant speed
        w = 1.0 if per_unit_driver else self.speed
        if w != 1.0:
            for arr in (st.vx, st.vy, st.w):
                arr *= w
            for arr in (st.ax, st.ay, st.al):
                arr *= w * w
        failures = self._failures(st, oks, ok, u)
        events.sort(key=lambda e: e.after)
        sol = Solution(
            self,
            u,
            (u - start.u0) / self.speed if n and self.speed else np.zeros_like(u),
            st,
            ok,
            failures,
            np.array(inds) if inds else np.zeros((0, n)),
            iters,
            methods.array(),
            res,
            start,
            warnings,
            velocity,
            velocity and acceleration,
            events,
            flips,
        )
        if limits and derivs and inds:
            self._rates_at_singular(sol, velocity, acceleration, per_unit_driver)
        return sol

    def _downstream(self) -> list[set[int]]:
        """For each group of the plan, its bodies and those of every later group that
        depends on them (through a joint, directly or through other groups)."""
        if getattr(self, "_down", None) is None:
            down = []
            for gi, g in enumerate(self.plan):
                bodies = set(g.bodies)
                for h in self.plan[gi + 1 :]:
                    touches = {b for c in h.constraints for b in (c.a, c.b)}
                    if touches & bodies:
                        bodies |= set(h.bodies)
                down.append(bodies)
            self._down = down
        return self._down

    def _rates_at_singular(
        self, sol: Solution, velocity: bool, acceleration: bool, per_unit_driver: bool
    ) -> None:
        """Rates at the positions where a group is singular (a toggle or a bifurcation
        point: the sine of a loop's transmission angle below ``SINGULAR_INDICATOR``, or a
        Newton group's reciprocal condition number below ``NEWTON_SINGULAR_RCOND``).

        There the differentiated constraints do not determine the rates (0 / 0 in the
        group's formulas, rounding noise in practice). The motion the sweep follows is
        smooth through such a point, so its rates are their limits: the analytic rates
        are evaluated at ``u -+ d`` and ``u -+ 2d`` on the followed branches and
        extrapolated to ``u`` (Richardson, error O(d^4)); at the first or last sample of
        a sweep, from the side the sweep follows (``u + d ... u + 4d``, cubic). ``d`` is
        5e-3 rad, or 5e-3 of the mechanism's size for a linear driver: rounding grows
        near the singular point as d shrinks (about eps / d^3 in accelerations), the
        extrapolation error as d^4; the limits are good to about 1e-9 of the rates'
        natural sizes. A Newton group's points on each side are reached by continuation
        from the neighbouring sample on that side, which lies on the followed motion.
        Where the motion does not exist on both sides (a limit position of a driven
        rocker: the rates are infinite) or the two sides disagree, the rates of the
        singular group and of the groups that depend on it stay NaN; the other rates
        (the driver's, groups before it or beside it) keep their values.
        """
        ind = sol.indicator
        st = sol.state
        n = len(sol.u)
        sing_by: dict[int, list[int]] = {}  # position -> its singular groups
        newton = np.zeros(n, bool)
        for gi, g in enumerate(self.plan):
            if g.n_modes == 2 and gi < len(ind):
                where = ind[gi] <= SINGULAR_INDICATOR
            elif isinstance(g, NewtonGroup):
                # a Newton solve stops within the square root of the rounding error of
                # a singular point, so its block is only nearly singular there
                where = rcond(group_block(g, st)[0]) <= NEWTON_SINGULAR_RCOND
                newton |= where & sol.ok
            else:
                continue
            for i in np.flatnonzero(where & sol.ok):
                sing_by.setdefault(int(i), []).append(gi)
        sol.rates_undetermined = []
        if not sing_by:
            return
        rows = slice(5, 8) if not acceleration else slice(5, 11)
        d = 5e-3 * (self.scale if self.linear else 1.0)
        # natural sizes of the rates, for telling a jump from rounding
        ws = (1.0 if per_unit_driver else abs(self.speed)) / (self.scale if self.linear else 1.0)
        kind = np.array([self.scale * ws, self.scale * ws, ws] + [self.scale * ws * ws] * 2)
        kind = np.append(kind, ws * ws)[rows, None]
        down = self._downstream()
        kw = dict(
            start=sol.start,
            velocity=velocity,
            acceleration=acceleration,
            per_unit_driver=per_unit_driver,
            limits=False,
        )
        for i, groups in sorted(sing_by.items()):
            ui = float(sol.u[i])
            one_sided = n > 1 and i in (0, n - 1)
            if one_sided:
                # the first or last sample: the followed motion lies on one side only
                into = math.copysign(1.0, sol.u[1] - sol.u[0]) * (1 if i == 0 else -1)
                x = ui + into * d * np.arange(1.0, 5.0)
                if newton[i]:
                    k = i + 1 if i == 0 else i - 1  # continue from the neighbour inward
                    side = self._side_solve(sol, k, x[::-1], kw)
                    r = None if side is None else side.block[rows, :, ::-1]
                else:
                    near = self.solve(x, near=(sol, int(i)), **kw)
                    r = near.state.block[rows, :, :] if near.ok.all() else None
            elif newton[i]:
                lo = self._side_solve(sol, i - 1, ui - d * np.array([2.0, 1.0]), kw)
                hi = self._side_solve(sol, i + 1, ui + d * np.array([2.0, 1.0]), kw)
                r = None
                if lo is not None and hi is not None:
                    a, b = lo.block[rows], hi.block[rows]
                    r = np.stack([a[:, :, 1], b[:, :, 1], a[:, :, 0], b[:, :, 0]], axis=2)
            else:
                near = self.solve(ui + d * np.array([-1.0, 1.0, -2.0, 2.0]), near=(sol, i), **kw)
                r = near.state.block[rows, :, :] if near.ok.all() else None
            bodies = sorted(set().union(*(down[gi] for gi in groups)))
            if r is None:
                st.block[rows, bodies, i] = np.nan
                sol.rates_undetermined.append(int(i))
                continue
            if one_sided:  # cubic extrapolation, checked against the quadratic one
                est = r @ np.array([4.0, -6.0, 4.0, -1.0])
                quad = r[:, :, :3] @ np.array([3.0, -3.0, 1.0])
                if np.all(np.abs(est - quad) <= 1e-3 * np.abs(est) + 1e-6 * kind):
                    st.block[rows, :, i] = est
                    sol.rates_by_limit.append(int(i))
                else:  # not smooth there: the rates grow without bound (a limit position)
                    st.block[rows, bodies, i] = np.nan
                    sol.rates_undetermined.append(int(i))
                continue
            lo1, hi1, lo2, hi2 = (r[:, :, k] for k in range(4))
            # a smooth motion changes twice as much over 4d as over 2d; a jump does not
            smooth = np.abs((hi2 - lo2) - 2.0 * (hi1 - lo1)) <= (
                0.1 * np.abs(hi2 - lo2) + 1e-6 * kind + 1e-300
            )
            est = (4.0 * (lo1 + hi1) - (lo2 + hi2)) / 6.0
            if smooth.all():
                st.block[rows, :, i] = est
                sol.rates_by_limit.append(int(i))
            else:
                st.block[rows, bodies, i] = np.nan
                sol.rates_undetermined.append(int(i))
        st.token = State.new_token()

    def _side_solve(self, sol: Solution, k: int, x: np.ndarray, kw) -> State | None:
        """Positions ``x`` reached by continuation from solved sample ``k`` (which is
        solved again first, so that the march starts on its pose); None if sample ``k``
        was not solved or a position does not close."""
        if not (0 <= k < len(sol.u)) or not sol.ok[k]:
            return None
        near = self.solve(np.r_[sol.u[k], x], near=(sol, k), **kw)
        if not near.ok.all():
            return None
        return near.state.take(np.arange(1, len(x) + 1))

    def _refine_minima(self, gi: int, g: Group, ctx: _Context, cand, u, H, Hs, near):
        """Locate the minima of the discriminant between points ``cand`` and ``cand + 1``
        of the analysis grid ``u`` (with values ``H``, rates along the sweep ``Hs``, and
        the sweep sample ``near`` each grid point lies next to).

        Bisection on its rate H' = 0, evaluating the groups before this one at the
        midpoints (all candidates at once), until the bracket closes in on the minimum
        (to rounding), where H is evaluated. A candidate is settled early only when the
        minimum is proven above zero: once the bracket is short (:data:`SETTLE_WIDTH`),
        H is convex on it, so H lies above both end tangents, and their intersection is a
        lower bound of the minimum; if that bound is above :data:`NO_TOUCH`, the motion
        does not pass through a singular configuration there.
        """
        d = self.mech.driver.direction
        lo, hi = u[cand].copy(), u[cand + 1].copy()
        hlo, hhi = H[cand].copy(), H[cand + 1].copy()
        slo, shi = Hs[cand].copy(), Hs[cand + 1].copy()  # rates along the sweep
        nk = near[cand]
        est = np.full(len(cand), np.nan)
        open_ = np.ones(len(cand), bool)
        settle_w = SETTLE_WIDTH * (self.scale if self.linear else 1.0)
        for _ in range(80):
            w = np.abs(hi - lo)
            with np.errstate(invalid="ignore", divide="ignore"):
                x = (hhi - hlo - shi * w) / (slo - shi)  # where the end tangents meet
                bound = hlo + slo * np.clip(x, 0.0, w)
            settled = (w <= settle_w) & (bound > NO_TOUCH)
            tiny = w <= 4e-16 * (1 + np.abs(lo))
            est = np.where(
                open_ & settled, np.maximum(bound, _hermite_min(hlo, hhi, slo * w, shi * w)), est
            )
            open_ &= ~(settled | tiny)
            if not open_.any():
                break
            k = np.flatnonzero(open_)
            mid = 0.5 * (lo[k] + hi[k])
            hm, dm = g.disc(ctx.prefix(gi, mid, nk[k]))
            sm = dm * d
            down = sm < 0
            lo[k] = np.where(down, mid, lo[k])
            hlo[k] = np.where(down, hm, hlo[k])
            slo[k] = np.where(down, sm, slo[k])
            hi[k] = np.where(down, hi[k], mid)
            hhi[k] = np.where(down, hhi[k], hm)
            shi[k] = np.where(down, shi[k], sm)
        ustar = 0.5 * (lo + hi)
        # where the bracket closed in on the minimum, the discriminant there
        exact = np.isnan(est)
        if exact.any():
            k = np.flatnonzero(exact)
            est[k] = np.asarray(g.disc(ctx.prefix(gi, ustar[k], nk[k]))[0])
        return ustar, est

    def _analysis_grid(self, gi: int, g: Group, ctx: _Context, ok_prev: np.ndarray):
        """The discriminant on the sweep's samples and, where the samples are further
        apart than :data:`EVENT_STEP`, on points in between (evaluating the groups before
        this one there), so that no minimum hides between two samples.

        Returns ``u, H, Hs, good, near, at_sample``: the grid's driver values, H and its
        rate along the sweep, where both are known, the sweep sample each point lies
        next to (the interval it is in), and which grid points are samples.
        """
        H, dH = g.disc(ctx.st)
        d = self.mech.driver.direction
        u = ctx.u
        n = len(u)
        good = ok_prev & np.isfinite(H) & np.isfinite(dH)
        if ctx.grid is None:
            return u, H, dH * d, good, np.arange(n), np.ones(n, bool)
        ug, at_sample, near, gst = ctx.grid
        Hg = np.empty(len(ug))
        dHg = np.empty(len(ug))
        idx = np.flatnonzero(at_sample)
        Hg[idx], dHg[idx] = H, dH
        mid = np.flatnonzero(~at_sample)
        hm, dm = g.disc(gst)  # the groups before this one are solved there
        Hg[mid], dHg[mid] = hm, dm
        goodg = np.empty(len(ug), bool)
        goodg[idx] = good
        k = near[mid]
        goodg[mid] = np.isfinite(hm) & np.isfinite(dm) & good[k] & good[k + 1]
        return ug, Hg, dHg * d, goodg, near, at_sample

    def _branch_events(self, gi: int, g: Group, ctx: _Context, ok_prev: np.ndarray):
        """Find where a two-branch group meets a singular configuration along the sweep.

        The group's discriminant H (zero where its branches meet) depends only on earlier
        groups; with its exact rate H' it locates each local minimum of H on a grid no
        coarser than :data:`EVENT_STEP`: between two grid points where H' changes sign,
        refined by bisection on H' = 0 (see :meth:`_refine_minima`). At a minimum where H
        touches zero (to rounding) the motion passes through a bifurcation point: the
        smooth continuation is on the other branch, so the branch flips there. A minimum
        below zero means the sweep stepped over a dead zone. A minimum at the sweep's
        first position does not flip anything: the start's branch is the one the motion
        takes from there (see :meth:`assemble`).
        """
        d = self.mech.driver.direction
        u_s = ctx.u
        u, H, Hs, good, near, at_sample = self._analysis_grid(gi, g, ctx, ok_prev)
        # intervals between two samples where the group closes (a minimum elsewhere is
        # part of a range where it cannot close, reported as such)
        hs_ = H[at_sample]
        closes = good[at_sample] & (hs_ >= -TOUCH)
        both = closes[:-1] & closes[1:]
        owner = np.minimum(near[:-1], len(closes) - 2) if len(closes) > 1 else near[:-1]
        pair = good[:-1] & good[1:] & (both[owner] if len(closes) > 1 else False)
        inside = np.flatnonzero(pair & (Hs[:-1] < 0) & (Hs[1:] > 0))
        h = np.abs(u[inside + 1] - u[inside])
        est = _hermite_min(H[inside], H[inside + 1], Hs[inside] * h, Hs[inside + 1] * h)
        cand = inside[est < EVENT_CHECK]
        events: list[Event] = []
        warnings: list[str] = []
        found: list[tuple[int, float, float]] = []  # (sample before, u*, H*)
        if cand.size:
            us, hs = self._refine_minima(gi, g, ctx, cand, u, H, Hs, near)
            found += list(zip(near[cand].tolist(), us.tolist(), hs.tolist()))
        # minima exactly at a grid point
        for k in np.flatnonzero(good[1:-1] & (np.abs(H[1:-1]) <= TOUCH)) + 1:
            if good[k - 1] and good[k + 1] and H[k - 1] > H[k] < H[k + 1]:
                found.append((int(near[k - 1]), float(u[k]), float(H[k])))
        # near-singular minima seen at the grid points themselves (where the group closes)
        closable = good & (H >= -TOUCH)
        for k in np.flatnonzero(closable[1:-1] & (H[1:-1] < NEAR_SINGULAR**2)) + 1:
            if not (closable[k - 1] and closable[k + 1]):
                continue
            if H[k - 1] >= H[k] <= H[k + 1] and not any(
                abs(f[1] - u[k]) <= abs(u[k + 1] - u[k - 1]) for f in found
            ):
                found.append((int(near[k - 1]), float(u[k]), float(H[k])))
        found.sort(key=lambda f: d * f[1])
        merged: list[tuple[int, float, float]] = []
        for f in found:  # one minimum seen from both sides of a point is one event
            if merged and abs(f[1] - merged[-1][1]) <= 1e-9 * (1.0 + abs(f[1])):
                if f[2] < merged[-1][2]:
                    merged[-1] = (merged[-1][0], merged[-1][1], f[2])
                continue
            merged.append(f)
        for k, us, hs in merged:
            # a minimum on a sample (to rounding) is that sample: the sample keeps the
            # branch it comes in on, and the flip applies after it
            j = int(np.argmin(np.abs(u_s - us)))
            if abs(u_s[j] - us) <= 1e-12 * (1.0 + abs(us)):
                us = float(u_s[j])
                if j == 0 and ctx.is_start:
                    continue  # the start's branch is the one taken from the start
            mu = float(np.arcsin(np.sqrt(max(min(hs, 1.0), 0.0))))
            if hs < -TOUCH:
                events.append(Event("dead zone", g.label, us, k, 0.0))
                warnings.append(
                    f"between {self.format_u(u_s[k])} and {self.format_u(u_s[k + 1])} the "
                    f"{g.label} cannot close (near {self.format_u(us)}): the sweep steps over "
                    "this dead zone; the motion between these positions is not continuous "
                    "(use a smaller step to see it)"
                )
            elif hs <= TOUCH:
                events.append(Event("bifurcation", g.label, us, k, mu))
                ctx.flips[gi].append(us)
            elif mu < math.radians(3.0):
                events.append(Event("near-singular", g.label, us, k, mu))
        return events, warnings

    def _polish(self, st: State, drive: Drive, i: int):
        """Newton on the whole system at position ``i`` from the closed-form answer."""
        st1 = st.take([i])
        sys_ = self.system
        u1 = drive.u[i : i + 1]

        def setq(q):
            for b in range(sys_.nb):
                st1.x[b, 0], st1.y[b, 0] = q[3 * b], q[3 * b + 1]
                st1.set_angle(b, q[3 * b + 2], 0)

        def fun(q):
            setq(q)
            return sys_.residual(st1, u1)[:, 0]

        def jac(q):
            setq(q)
            return sys_.jacobian(st1)[0]

        q0 = st1.q()[0]
        if not np.all(np.isfinite(q0)):
            return False, np.nan, 0
        q, stats = newton_solve(fun, jac, q0, self.atol, self.mech.solver.max_iterations)
        if stats.converged:
            setq(q)
            st.put([i], st1)
        return stats.converged, stats.residual, stats.iterations

    def _failures(self, st: State, oks, ok, st_u) -> list[Failure]:
        out: list[Failure] = []
        if ok.all():
            return out
        bad = np.concatenate(([False], ~ok, [False]))
        edges = np.flatnonzero(bad[1:] != bad[:-1])  # starts and ends of runs of failures
        for i, j in zip(edges[0::2], edges[1::2] - 1):
            i, j = int(i), int(j)
            gi = next((k for k, o in enumerate(oks) if not o[i]), None)
            if gi is None:
                group, reason = "the whole system", "the constraint residual stays above tolerance"
            else:
                g = self.plan[gi]
                group = g.label
                reason = (
                    g.fail_reason(st, i)
                    if not isinstance(g, NewtonGroup)
                    else (f"{g.label}: Newton-Raphson and scipy found no closed position")
                )
            out.append(Failure(i, j, group, reason, float(st_u[i]), float(st_u[j])))
        return out


_RATE = {"x": "vx", "y": "vy", "angle": "omega", "s": "v"}

NEWTON_START_TRIES = 24  # further start guesses for a Newton group at the assembly
START_GUESS_RCOND = 1e-8  # a start guess this near singular leaves the branch to rounding
NEWTON_SINGULAR_RCOND = 1e-7  # a Newton group's block this near singular: rates by limits
TOUCH = 1e-10  # |discriminant| below this at a minimum: the branches meet (bifurcation)
NO_TOUCH = 1e-6  # a minimum proven above this needs no further refinement
SETTLE_WIDTH = 0.02  # brackets this short (rad, or of the size) are convex about a minimum
EVENT_STEP = math.radians(2.0)  # the branch analysis's coarsest grid (x size: linear driver)
START_PROBE = 1e-4  # how far past a singular start its branch is read (rad, x size)
EVENT_CHECK = 0.25  # examine minima whose interpolated discriminant is below this
NEAR_SINGULAR = math.sin(math.radians(3.0))


class _PendingConditions:
    """The assembly conditions not used yet, each released once the groups solved so far
    have placed every body it reads (linear in the number of conditions and groups)."""

    def __init__(self, an: Analysis, conditions) -> None:
        self.items = dict(enumerate(conditions))
        self.waiting: dict[int, int] = {}  # condition -> number of bodies still unsolved
        self.by_body: dict[int, list[int]] = {}
        self.released: dict[int, object] = {}
        for k, c in self.items.items():
            bodies = an.condition_bodies(c) - {an.system.nb}
            if not bodies:
                self.released[k] = c
                continue
            self.waiting[k] = len(bodies)
            for b in bodies:
                self.by_body.setdefault(b, []).append(k)

    def solved(self, bodies) -> None:
        """These bodies are placed now."""
        for b in bodies:
            for k in self.by_body.pop(b, ()):
                self.waiting[k] -= 1
                if self.waiting[k] == 0:
                    del self.waiting[k]
                    self.released[k] = self.items[k]

    def ready(self) -> list:
        """(index, condition) of the conditions that can be evaluated and are not used."""
        return sorted(self.released.items(), key=lambda kc: kc[0])

    def use(self, ready) -> None:
        for k, _ in ready:
            self.released.pop(k, None)

    def remaining(self) -> list:
        """Every condition not used yet, in the file's order."""
        left = set(self.released) | set(self.waiting)
        return [(k, self.items[k]) for k in sorted(left)]


class _Methods:
    """How each position was solved; an array of text only once some are not closed form."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.arr: np.ndarray | None = None

    def _materialise(self) -> np.ndarray:
        if self.arr is None:
            self.arr = np.full(self.n, "closed form", dtype=object)
        return self.arr

    def merge(self, meth: np.ndarray) -> None:
        mask = meth != ""
        if not np.any(mask):
            return
        a = self._materialise()
        a[mask] = np.where(a[mask] == "closed form", meth[mask], a[mask] + "+" + meth[mask])

    def append(self, i: int, text: str) -> None:
        a = self._materialise()
        a[i] = a[i] + "+" + text

    def array(self) -> np.ndarray | None:
        return self.arr


def _restart_guess(an: Analysis, g: NewtonGroup, u: float, start: StartAssembly):
    """Where a Newton sweep resumes after a gap: the closed-form groups on the user's
    branches; ``False`` when they cannot close there (the position is unassemblable on
    the user's branch, whatever another branch would allow); None if there is no closed
    form to ask."""
    if an.plan is an.groups or any(isinstance(h, NewtonGroup) for h in an.groups):
        return None
    st = an.assembly_guess(u, start)
    return False if st is None else g.get_q(st, 0)


def _prepend_gap(an: Analysis, sol: Solution, u: np.ndarray, k: int, exc) -> Solution:
    """The sweep's solution with its first ``k`` positions, where the mechanism could not
    close, put back in front of ``sol`` (solved from position ``k``) as failures."""
    n = len(u)
    nb = an.system.nb
    st = State(nb, n)
    st.block[:, :, k:] = sol.state.block
    st.block[:, :nb, :k] = np.nan
    st.block[:, nb, :k] = sol.state.block[:, nb, :1]  # the ground stays where it is
    ok = np.zeros(n, bool)
    ok[k:] = sol.ok
    fails = [Failure(0, k - 1, exc.group, exc.reason, float(u[0]), float(u[k - 1]))]
    for f in sol.failures:
        fails.append(Failure(f.first + k, f.last + k, f.group, f.reason, f.u_first, f.u_last))
    ind = np.zeros((sol.indicator.shape[0], n))
    ind[:, k:] = sol.indicator
    iters = np.zeros(n, int)
    iters[k:] = sol.iterations
    methods = None
    if sol.methods is not None:
        methods = np.full(n, "failed", dtype=object)
        methods[k:] = sol.methods
    res = None
    if sol.residual_ is not None:
        res = np.full(n, np.nan)
        res[k:] = sol.residual_
    for e in sol.events:
        e.after += k
    warnings = [
        f"the mechanism cannot close at the start of the sweep: from {an.format_u(u[0])} to "
        f"{an.format_u(u[k - 1])} the {exc.reason}; the sweep starts at "
        f"{an.format_u(u[k])}, the first position that closes, on the branches chosen there"
    ] + sol.warnings
    speed = an.speed
    out = Solution(
        an,
        u,
        (u - u[0]) / speed if speed else np.zeros(n),
        st,
        ok,
        fails,
        ind,
        iters,
        methods,
        res,
        dataclasses.replace(sol.start, u0=float(u[0])),  # the sweep still starts at u[0]
        warnings,
        sol.has_velocity,
        sol.has_acceleration,
        sol.events,
        sol.flips,
        [i + k for i in sol.rates_by_limit],
        [i + k for i in sol.rates_undetermined],
    )
    out.skipped_start = k
    return out


def _coincident_at(g: Group, st: State, i: int) -> bool:
    """Do the outer joints of the group coincide at position ``i`` (see RRR)?"""
    f = getattr(g, "coincident", None)
    c = f(st) if f is not None else None
    return c is not None and bool(c[i])


def _hermite_min(h0, h1, d0, d1):
    """Smallest value of the cubic Hermite interpolant on [0, 1] (values h, slopes d)."""
    if len(h0) == 0:
        return np.zeros(0)
    b00, b10, b01, b11 = _HERMITE_BASIS
    vals = b00 * h0 + b10 * d0 + b01 * h1 + b11 * d1
    return vals.min(axis=0)


def _hermite_basis(k: int = 17):
    t = np.linspace(0.0, 1.0, k)[:, None]
    t2, t3 = t * t, t * t * t
    return (2 * t3 - 3 * t2 + 1, t3 - 2 * t2 + t, -2 * t3 + 3 * t2, t3 - t2)


_HERMITE_BASIS = _hermite_basis()


class _Context:
    """What the groups of one sweep share: the state so far, the branches and the driver
    values; evaluates the groups before a given one at new driver values."""

    def __init__(self, an: Analysis, st: State, u, start: StartAssembly, flips, q_start):
        self.an = an
        self.st = st
        self.u = u
        self.start = start
        self.flips = flips
        self.q_start = q_start
        self.is_start = True  # u[0] is the sweep's start (not a chunk, nor a single position)
        # the branch analysis's points between samples further apart than its grid step:
        # (driver values of samples and points, which are samples, the sample before each
        # point, the state at the points with the groups solved so far)
        self.grid: tuple | None = None
        self.grid_upto = 0  # the groups before this one are solved on the grid

    def build_grid(self, step: float) -> None:
        """Points between the samples so that the grid is no coarser than ``step``; the
        groups are solved there as the sweep solves them (:meth:`extend_grid`)."""
        u = self.u
        n = len(u)
        if n < 2:
            return
        extra = np.maximum(np.ceil(np.abs(np.diff(u)) / step).astype(int) - 1, 0)
        if not extra.any():
            return
        counts = extra + 1
        owner = np.repeat(np.arange(n - 1), counts)
        first = np.cumsum(counts) - counts
        j = np.arange(len(owner)) - np.repeat(first, counts)  # 0: the sample itself
        frac = j / np.repeat(counts, counts)
        ug = np.append(u[owner] + frac * (u[owner + 1] - u[owner]), u[-1])
        at_sample = np.append(j == 0, True)
        near = np.append(owner, n - 1)
        gst = State(self.an.system.nb, int(np.sum(~at_sample)))
        self.grid = (ug, at_sample, near, gst)

    def extend_grid(self, gi: int) -> None:
        """Solve group ``gi`` (positions and rates) at the grid's points between samples."""
        if self.grid is None or gi >= self.grid_upto:
            return  # no group after this one needs it
        ug, at_sample, near, gst = self.grid
        mid = ~at_sample
        with np.errstate(invalid="ignore", divide="ignore"):
            self._solve_group(gi, gst, ug[mid], near[mid])

    def _solve_group(self, gj: int, st: State, u_new: np.ndarray, near_k) -> None:
        """Group ``gj`` at driver values ``u_new`` (the groups before it solved in ``st``),
        each near sample ``near_k`` of the sweep, with its rates per unit driver."""
        an = self.an
        g = an.plan[gj]
        m = len(u_new)
        unit = Drive(u_new, np.ones(m), np.zeros(m))
        if isinstance(g, NewtonGroup):
            for j in range(m):
                k = int(near_k[j])
                q = g.get_q(self.st, k)
                du = u_new[j] - self.u[k]
                qd = g.get_qdot(self.st, k)
                q0 = q + qd * du if np.all(np.isfinite(qd)) else q
                st1 = st.take([j])
                qj, stats = g.solve_at(st1, u_new[j : j + 1], q0)
                g.set_q(st, j, qj if stats.converged else np.full_like(qj, np.nan))
            st.token = State.new_token()
            g.velocity(st, unit)
        else:
            sigma = an.sigma_at(self.start.modes[gj], self.flips[gj], u_new)
            g.position(st, unit, sigma)
            g.velocity(st, unit)

    def prefix(self, gi: int, u_new, near_k) -> State:
        """Solve the groups before ``gi`` (positions and derivatives per unit driver
        coordinate) at driver values ``u_new``, each near sample ``near_k`` of the sweep."""
        an = self.an
        u_new = np.atleast_1d(np.asarray(u_new, float))
        near_k = np.broadcast_to(np.asarray(near_k, int), u_new.shape)
        st = State(an.system.nb, len(u_new))
        with np.errstate(invalid="ignore", divide="ignore"):
            for gj in range(gi):
                self._solve_group(gj, st, u_new, near_k)
        return st


def angle_deg(u: float) -> float:
    """A driver angle in degrees in [0, 360), rounding noise (1e-13°) shown as 0."""
    d = round(math.degrees(u) % 360, 9)
    return 0.0 if d >= 360 else d + 0.0


def _scale(mech: Mechanism) -> float:
    """A characteristic length of the mechanism (m), for tolerances."""
    r = 0.0
    for xy in mech.ground.values():
        r = max(r, math.hypot(*xy))
    for lk in mech.links:
        pts = list(lk.points.values())
        for i, a in enumerate(pts):
            for b in pts[i + 1 :]:
                r = max(r, math.dist(a, b))
    return r if r > 0 else 1.0


def check_solution(sol: Solution) -> None:
    """Raise :class:`SolverError` if nothing could be solved."""
    if not np.any(sol.ok):
        f = sol.failures[0] if sol.failures else None
        raise SolverError(
            "no position of the sweep could be solved" + (f": {f.reason}" if f else "")
        )
