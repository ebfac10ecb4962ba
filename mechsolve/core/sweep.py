"""The kinematic sweep: assemble at the start, then solve every driver position.

Pipeline (one model, one constraint system, arrays over positions):

1. :class:`Analysis` builds the :class:`~mechsolve.system.constraints.ConstraintSystem` and the
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

import numpy as np

from mechsolve.base.errors import AssemblyError, SolverError
from mechsolve.base.numerics import brent_root
from mechsolve.base.state import State
from mechsolve.core.assembly import Redundancy, StartAssembler
from mechsolve.core.branch_choice import _PendingConditions
from mechsolve.core.branches import EVENT_STEP, BranchEvents, _coincident_at, _Context
from mechsolve.core.failures import FailureReports
from mechsolve.core.newton_events import newton_events
from mechsolve.core.singular import SingularRates
from mechsolve.core.solution import (
    Event,
    Failure,
    PointRef,
    Solution,
    StartAssembly,
    StateView,
    angle_deg,
)
from mechsolve.groups import Drive, Group, NewtonGroup, build_plan
from mechsolve.model import MAX_POSITIONS, Limit, Mechanism
from mechsolve.model.expr import Ref
from mechsolve.model.expr.poles import first_pole
from mechsolve.model.motion import ExpressionMotion
from mechsolve.system.constraints import ConstraintSystem
from mechsolve.system.structure import RedundantStructure

__all__ = [
    "Analysis",
    "Event",
    "Failure",
    "Redundancy",
    "Solution",
    "StartAssembly",
    "StateView",
    "angle_deg",
    "check_solution",
]


class Analysis(StartAssembler, BranchEvents, SingularRates, FailureReports):
    """The constraint system and group plan of a mechanism, ready to solve positions.

    Parameters
    ----------
    mech
        A validated mechanism with a driver.
    method
        ``"auto"`` (default: the file's ``solver.method``) or ``"newton"``.
    """

    # the sweep of a recognised plan (mechsolve.core.program), set on a kept analysis
    program = None
    # Coulomb friction regularised through a standstill of the driver: ``tanh(|speed| /
    # friction_smoothing)`` times its value (set by the equation of motion on its own
    # analysis, which needs friction continuous in the speed); None: exact Coulomb
    friction_smoothing: float | None = None

    def __init__(self, mech: Mechanism, method: str | None = None) -> None:
        if mech.driver is None:
            raise mech.error(("driver",), "the mechanism has no driver: add a 'driver' section")
        self.mech = mech
        self.system = ConstraintSystem(mech)
        # sweep values by (start, step, travel, direction, speed): shared by the per-call
        # copies of a kept analysis (mechsolve.core.kept)
        self._values: dict = {}
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
            if mech.solver.compiled and hasattr(g, "compiled"):  # the file's key
                g.compiled = "solver.compiled"
        self.points: dict[str, PointRef] = {}
        nb = self.system.nb
        for p, xy in mech.ground.items():
            self.points[p] = PointRef(nb, np.asarray(xy, float))
        for lk in mech.links:  # a point on the ground and a link is a ground point
            b = self.system.index[lk.name]
            for p, xy in lk.points.items():
                self.points.setdefault(p, PointRef(b, np.asarray(xy, float)))
        d = mech.driver
        self.linear = mech.joint(d.joint).coordinate == "length"
        self.speed = d.speed
        # for messages: the name of the inner point of each joint
        self.joint_point = {self.system.by_joint[j.name]: j.label for j in mech.joints}
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
        sweep's driver steps, each at the time the law reaches it. ``time_step``
        overrides the file's step: in s, or in the driver's unit for a range."""
        d = self.mech.driver
        law = d.motion
        sw = self.mech.sweep
        if sw.duration is None:
            u, _ = self.sweep_values(float(d.start), step=time_step)
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
        pole = first_pole(law.expr, "t", t) if isinstance(law, ExpressionMotion) else None
        if pole is not None:  # finite samples on both sides of a pole: no motion
            raise self.mech.error(
                ("driver", "motion", "law"),
                f"the law grows without bound at t = {pole:.6g} s, between the samples (a "
                "division by zero)",
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
        # kept per analysis (an unchanged model solved again asks for the same values):
        # each call gets its own copies
        key = (u0, step, travel, self.mech.driver.direction, self.speed)
        got = self._values.get(key)
        if got is None:
            n = max(0, math.ceil(ratio - 1e-9))
            k = np.arange(n + 1, dtype=float)
            dist = np.minimum(k * step, travel)
            u = u0 + self.mech.driver.direction * dist
            t = dist / abs(self.speed) if self.speed else np.zeros_like(dist)
            if len(self._values) >= 8:
                self._values.clear()
            self._values[key] = got = (u, t)
        return got[0].copy(), got[1].copy()

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
        # solved once per analysis (a sweep's values and its states both ask for it; an
        # edited model gets an analysis of its own, see core.kept)
        key = (d.start.quantity.text, d.start.extreme)
        kept = self.__dict__.get("_limit_start")
        if kept is None or kept[0] != key:
            kept = (key, self.find_limit(d.start))
            self._limit_start = kept
        return kept[1]

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
        analyse = near is None and n > 1
        derivs = velocity or acceleration or analyse
        # closed-form groups write whole rows of their bodies: positions, and the rates
        # computed (see _solve_groups); a Newton group may leave rows to the zero start
        closed = not any(isinstance(g, NewtonGroup) for g in self.plan)
        written = (5 + 3 * derivs + 3 * (derivs and acceleration)) if closed else 0
        st = State(self.system.nb, n, written)
        unit = Drive(u, np.ones(n), np.zeros(n))  # derivatives per unit driver coordinate
        q_start, flips, history = self._continued_from(start, near, follow)
        ctx = self._context(st, u, start, flips, q_start, near is None and follow is None, analyse)
        ctx.history = history
        with np.errstate(invalid="ignore", divide="ignore"):
            ok_all, oks, inds, iters, methods, events, warnings = self._solve_groups(
                ctx, unit, conds if lazy else None, derivs, acceleration, analyse
            )
        if lazy:
            _finish_lazy_start(self, start, st, conds)
        ok = ok_all.copy()
        res = _check_residual(self, st, unit, ok, iters, methods)
        if not per_unit_driver:  # per unit driver coordinate -> time derivatives
            _scale_rates(st, self.speed)
        events.sort(key=lambda e: e.after)
        sol = Solution(
            self,
            u,
            (u - start.u0) / self.speed if n and self.speed else np.zeros_like(u),
            st,
            ok,
            self._failures(st, oks, ok, u),
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
        # where a Newton group's sweep stopped (its branch past there not known): a next
        # chunk cannot follow it
        sol.stopped = next(
            (g.stopped for g in self.plan if isinstance(g, NewtonGroup) and g.stopped), None
        )
        return sol

    def _solve_groups(
        self, ctx: _Context, unit: Drive, conds, derivs: bool, acceleration: bool, analyse: bool
    ):
        """Solve the groups one after another for all positions at once: positions on their
        branches (the branch events between samples when ``analyse``), then rates. Returns
        where every group closed, each group's success and conditioning, the iterations and
        methods of the Newton groups, the branch events and the warnings."""
        st, u, start, q_start = ctx.st, ctx.u, ctx.start, ctx.q_start
        n = len(u)
        ok_all = np.ones(n, bool)
        oks, inds = [], []
        iters = np.zeros(n, int)
        methods = _Methods(n)
        events: list[Event] = []
        warnings: list[str] = []
        for gi, g in enumerate(self.plan):
            if isinstance(g, NewtonGroup):
                ok, it, meth = g.sweep(
                    st,
                    unit,
                    q_start[gi],
                    ok_all,
                    prefix=lambda uu, k, gi=gi: ctx.prefix(gi, uu, k),
                    restart=lambda i, g=g: _restart_guess(self, g, float(u[i]), start),
                    history=ctx.history.get(gi) if hasattr(ctx, "history") else None,
                )
                iters = np.maximum(iters, it)
                methods.merge(meth)
                if analyse:
                    evs, warn = newton_events(self, gi, g, ctx, ok & ok_all)
                    events += evs
                    warnings += warn
                ind = np.ones(n)  # conditioning of Newton groups: see jacobian_rcond()
            else:
                if g.n_modes == 2 and analyse:
                    evs, warn = self._branch_events(gi, g, ctx, ok_all)
                    events += evs
                    warnings += warn
                ok, ind = self._closed_form_positions(gi, g, ctx, unit, ok_all, conds)
            if derivs:
                g.velocity(st, unit)
            if acceleration:
                g.acceleration(st, unit)
            ok = ok & ok_all
            oks.append(ok)
            inds.append(ind)
            ok_all = ok_all & ok
            ctx.extend_grid(gi)
        return ok_all, oks, inds, iters, methods, events, warnings

    def _continued_from(
        self, start: StartAssembly, near: tuple[Solution, int] | None, follow: Solution | None
    ) -> tuple[dict, dict, dict]:
        """The Newton groups' first guesses and the branches' flips: the start's, or those
        of a solved sweep at sample ``near[1]`` (single positions next to it) or at the last
        solved position of ``follow`` (the next chunk of a sweep, on its branches). With
        ``follow``, also each Newton group's history: the driver values and poses of the
        (up to two) solved samples just before that one, so that the chunk's continuation
        goes on in the same direction (next to a bifurcation one pose cannot tell)."""
        q_start = dict(start.q_start)
        if near is None and follow is None:
            return q_start, {gi: [] for gi in range(len(self.plan))}, {}
        sol0 = near[0] if near is not None else follow
        solved = np.flatnonzero(sol0.ok)
        i0 = near[1] if near is not None else (int(solved[-1]) if solved.size else -1)
        flips = {gi: list(v) for gi, v in sol0.flips.items()}
        back = [j for j in (i0 - 2, i0 - 1) if follow is not None and j >= 0]
        while back and not sol0.ok[back[0] : i0].all():
            back = back[1:]
        history = {}
        for gi, g in enumerate(self.plan):
            if isinstance(g, NewtonGroup) and i0 >= 0:
                q_start[gi] = g.get_q(sol0.state, i0)
                if back:
                    history[gi] = (
                        [float(sol0.u[j]) for j in back],
                        [g.get_q(sol0.state, j) for j in back],
                    )
        return q_start, flips, history

    def _context(self, st, u, start, flips, q_start, is_start: bool, analyse: bool) -> _Context:
        """The branch analysis's context, with its grid between samples when a group has
        two branches and the sweep is analysed."""
        ctx = _Context(self, st, u, start, flips, q_start)
        ctx.is_start = is_start
        two = [gi for gi, g in enumerate(self.plan) if g.n_modes == 2]
        if analyse and two:
            ctx.build_grid(EVENT_STEP * (self.scale if self.linear else 1.0))
            ctx.grid_upto = max(two)
        return ctx

    def _closed_form_positions(
        self,
        gi: int,
        g,
        ctx: _Context,
        unit: Drive,
        ok_all: np.ndarray,
        conds: _PendingConditions | None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Positions of closed-form group ``gi`` on its branch over the sweep (deciding the
        branch at the start as it goes when ``conds`` holds the pending conditions)."""
        st, u, start, flips = ctx.st, ctx.u, ctx.start, ctx.flips
        n = len(u)
        if conds is not None:
            conds.solved(g.bodies)
            if g.n_modes == 2:
                self._decide_at_start(gi, g, st, start, conds)
        if ctx.is_start and n and (_coincident_at(g, st, 0) or self._singular_just_ahead(g, st)):
            # the start's branch is the one taken from the start; the pose at the start
            # itself is the limit from that side (see RRR)
            flips[gi][:0] = [-math.inf * self.mech.driver.direction, float(u[0])]
        sigma = self.sigma_at(start.modes[gi], flips[gi], u)
        ok, ind = g.position(st, unit, sigma)
        if conds is not None and not ok[0]:
            closes = np.flatnonzero(ok & ok_all)
            raise self._cannot_close(g, st, start.u0, int(closes[0]) if closes.size else None)
        return ok, ind


_RATE = {"x": "vx", "y": "vy", "angle": "omega", "s": "v"}


class _Methods:
    """How each position was solved; an array of text only once some are not closed form."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.arr: np.ndarray | None = None
        self.same = "closed form"  # the text of every position while arr is None

    def _materialise(self) -> np.ndarray:
        if self.arr is None:
            self.arr = np.empty(self.n, dtype=object)  # np.full of text costs 14x more
            self.arr.fill(self.same)
        return self.arr

    def merge(self, meth: np.ndarray | str) -> None:
        """Add a group's texts: one per position, or one text for every position."""
        if isinstance(meth, str):
            if not meth:
                return
            if self.arr is None:
                self.same = meth if self.same == "closed form" else self.same + "+" + meth
            else:
                a = self.arr
                a[:] = np.where(a == "closed form", meth, a + "+" + meth)
            return
        if self.arr is None and meth.size:  # one text everywhere (a whole batched sweep)
            m0 = meth[0]
            if isinstance(m0, str) and m0 and bool(np.all(meth == m0)):
                self.same = m0 if self.same == "closed form" else self.same + "+" + m0
                return
        mask = meth != ""
        if not np.any(mask):
            return
        a = self._materialise()
        a[mask] = np.where(a[mask] == "closed form", meth[mask], a[mask] + "+" + meth[mask])

    def append(self, i: int, text: str) -> None:
        a = self._materialise()
        a[i] = a[i] + "+" + text

    def array(self) -> np.ndarray | None:
        if self.arr is None and self.same != "closed form":
            return self._materialise()
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


def _finish_lazy_start(
    an: Analysis, start: StartAssembly, st: State, conds: _PendingConditions
) -> None:
    """Keep the start's state, and check the assembly conditions no group decided."""
    start.state = st.take(slice(0, 1))  # (a copy of the first column: no fancy index)
    start.group_modes = list(start.modes)
    left = conds.remaining()
    if not left:  # every condition chose a branch (the usual case): nothing to check
        return
    view = StateView(an, start.state)
    view.has_velocity = view.has_acceleration = False
    for _, c in left:  # conditions no group decided: they must hold
        if not bool(np.all(c.evaluate(view))):
            raise AssemblyError(
                f"{an._file()}the start position does not satisfy the assembly "
                f"condition {c.text!r}, and no loop's branch can change that"
            )


def _check_residual(an: Analysis, st: State, unit: Drive, ok: np.ndarray, iters, methods):
    """With Newton groups, the full constraint residual at every position (nan where
    not solved), polished where it exceeds the tolerance; ``None`` without them."""
    if not any(isinstance(g, NewtonGroup) for g in an.plan):
        return None
    with np.errstate(invalid="ignore"):
        res = an.system.max_residual(st, unit.u)
    bad = ok & ~(res <= an.atol)
    for i in np.flatnonzero(bad):
        ok[i], res[i], it = an._polish(st, unit, i)
        iters[i] += it
        methods.append(i, "newton polish")
    return np.where(ok, res, np.nan)


def _scale_rates(st: State, w: float) -> None:
    """Rates per unit driver coordinate -> time derivatives at a constant speed ``w``."""
    if w != 1.0:
        for arr in (st.vx, st.vy, st.w):
            arr *= w
        for arr in (st.ax, st.ay, st.al):
            arr *= w * w
