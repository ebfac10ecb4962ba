"""A narrower program for a recognised plan: the sweep of a chain of closed-form groups
without the general sweep's machinery around it.

The general sweep (:meth:`~mechsolve.core.sweep.Analysis.solve`) serves every plan and
every call: Newton groups, chunks, single positions next to a sweep, branches chosen by
solving both at the start, points between samples for the branch analysis, bifurcations
followed, rates at singular positions replaced by their limits, unassemblable ranges
located. Each is a few NumPy calls on short arrays and some Python, some 270 us per call
in all: more than the closed form's own arithmetic over 3600 positions.

A plan made of the driver link on the ground followed by RRR and RRP dyads is the usual
four-bar, slider-crank, crane. For such a plan :class:`Program` (built once per kept
analysis, :mod:`mechsolve.core.kept`) solves a sweep from the driver's start at the
file's constant speed straight through:

* the branch of each dyad comes from its condition when that is the dyad's own branch
  statement ("B left of A -> O4"), read once per list of conditions; other conditions
  and sketches are decided by the general start's own code, group by group;
* each group's position, velocity and acceleration are written into the state with the
  same operations, in the same order, as the groups' own methods
  (:mod:`mechsolve.core.program_kernels` for the driver link and the usual RRR; the
  others by their methods), so the results are the same bit for bit;
* the checks read the dyad's discriminant ``H`` and its rate ``H'``, which its pass
  computes anyway: where the smallest ``H`` of the samples is at least ``sin^2(3 deg)``
  (so every sample closes, with its indicator above 1e-3: no rate is replaced by its
  limit) and every minimum between two samples that the branch analysis would refine
  is refined by the analysis's own bisection to one that is no event, there is no
  branch event, no unassemblable range and no warning. Samples further apart than the
  analysis's grid step are analysed by the analysis itself, on its grid;
* anything else (a position that does not close, a sample near a toggle, an event, a
  start that cannot close) returns None, and the caller solves the sweep by the general
  path, which then reports it as before.

So the program changes no result: it is the general path's outcome whenever it answers.
:data:`ENABLED` turns it off (tests compare the two paths).
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.base.errors import AssemblyError
from mechsolve.base.state import State
from mechsolve.core.branch_choice import _PendingConditions
from mechsolve.core.branches import (
    EVENT_CHECK,
    EVENT_STEP,
    NEAR_SINGULAR,
    TOUCH,
    _Context,
    _hermite_min,
)
from mechsolve.core.program_kernels import RRRPass, driver_fused, driver_pass, rrr_fused
from mechsolve.core.solution import Solution, StartAssembly
from mechsolve.core.sweep import _finish_lazy_start
from mechsolve.groups import Drive
from mechsolve.groups.closed import RRP, RRR, DriverLink
from mechsolve.model.expr import Side

__all__ = ["ENABLED", "Program", "program_for"]

ENABLED = True  # False: every sweep takes the general path (tests compare the two)

NEAR2 = NEAR_SINGULAR**2  # H below this at a sample: the branch analysis looks closer


def program_for(an) -> Program | None:
    """The program of ``an``'s plan, or None when the plan is not a chain of the driver
    link on the ground and RRR / RRP dyads (solved by the general path)."""
    if an.redundant or an.plan is not an.groups or not an.plan:
        return None
    plan = an.plan
    first = plan[0]
    if type(first) is not DriverLink or first.k != an.system.nb:
        return None
    drv = first.drv
    if an.system.nb not in (drv.a, drv.b) or np.ndim(drv.delta) != 0:
        return None
    for g in plan[1:]:
        if type(g) not in (RRR, RRP):
            return None
        if type(g) is RRR and (g.equal_arms or not isinstance(g.L1, float)):
            return None  # (its outer joints can coincide: the general path's limit pose)
    return Program(an)


class Program:
    """The sweep of a recognised plan (see the module docstring); kept with the analysis,
    it holds no group and no per-call state, only what it read from the plan."""

    def __init__(self, an) -> None:
        self.two = [gi for gi, g in enumerate(an.plan) if g.n_modes == 2]
        self.step = EVENT_STEP * (an.scale if an.linear else 1.0)
        nb = an.system.nb
        # how each group is solved: a fused pass, or its own methods
        self.kinds = [
            "driver"
            if type(g) is DriverLink and driver_fused(g, nb)
            else "rrr"
            if type(g) is RRR and rrr_fused(g, nb)
            else "methods"
            for g in an.plan
        ]
        self._modes: tuple | None = None  # (conditions, sketch, modes, reasons) last read

    def modes(self, an) -> tuple[list[float], list[str]] | None:
        """Each group's branch and its reason from the assembly conditions, as the general
        sweep's start decides them (:meth:`_decide_at_start`), when every condition is
        one dyad's own branch statement and no sketched point lies on a dyad; else None.
        Read once per list of conditions (kept with the objects it was read from)."""
        asm = an.mech.assembly
        conds = list(asm.conditions)
        sketch = tuple(asm.sketch)
        kept = self._modes
        if (
            kept is not None
            and kept[1] == sketch
            and len(kept[0]) == len(conds)
            and all(a is b for a, b in zip(kept[0], conds))
        ):
            return kept[2]
        out = self._read_modes(an, conds, sketch)
        self._modes = (conds, sketch, out)
        return out

    def _read_modes(self, an, conds, sketch) -> tuple[list[float], list[str]] | None:
        plan = an.plan
        ng = len(plan)
        modes, reasons = [1.0] * ng, [""] * ng
        nb = an.system.nb
        # when each condition is released: once every body it reads is solved
        release = {}
        order = {b: gi for gi, g in enumerate(plan) for b in g.bodies}
        for k, c in enumerate(conds):
            bodies = an.condition_bodies(c) - {nb}
            release[k] = max((order.get(b, ng) for b in bodies), default=-1)
        if any(r < 0 or r >= ng for r in release.values()):
            return None  # (read before any group, or never: the general path)
        for gi in self.two:
            g = plan[gi]
            if any(an.points[p].body in g.bodies for p in sketch if p in an.points):
                return None
            ready = [conds[k] for k in sorted(release) if release[k] == gi]
            if not ready:
                return None  # the default branch needs both branches solved at the start
            found = {
                g.mode_of_side(t.point, t.side, t.start, t.end, an.joint_point)
                if isinstance(t := c.tree, Side)
                else None
                for c in ready
            }
            if len(found) != 1 or None in found:
                return None
            modes[gi] = found.pop()
            reasons[gi] = "assembly condition " + ", ".join(repr(c.text) for c in ready)
        if any(release[k] not in self.two for k in release):
            return None  # a condition released at the driver link: checked, not used
        return modes, reasons

    def sweep(
        self, an, u: np.ndarray, u0: float, velocity: bool, acceleration: bool
    ) -> Solution | None:
        """The sweep at driver values ``u`` from the driver's start ``u0`` (rates per unit
        driver coordinate, as :meth:`Analysis.solve` with ``per_unit_driver``), or None
        where the general path must solve it (see the module docstring)."""
        n = len(u)
        if n < 2 or not ENABLED or u[0] != u0:
            return None
        d = an.mech.driver.direction
        du = np.subtract(u[1:], u[:-1])
        if d < 0:
            np.negative(du, out=du)
        if not du.min() > 0.0:
            return None  # not a sweep
        ng = len(an.plan)
        got = self.modes(an)
        if got is None:  # the general start's decisions, group by group
            conds = _PendingConditions(an, an.mech.assembly.conditions)
            modes, reasons = [1.0] * ng, [""] * ng
        else:
            conds = None
            modes, reasons = list(got[0]), list(got[1])
        start = StartAssembly(modes, {}, reasons, None, float(u[0]), [1.0] * ng)
        st = State(an.system.nb, n, 8 + 3 * acceleration)
        inds = np.empty((ng, n))
        ctx = None
        if not du.max() <= self.step:  # the general analysis, on its grid between samples
            ctx = an._context(st, u, start, {k: [] for k in range(ng)}, {}, True, True)
        with np.errstate(invalid="ignore", divide="ignore"):
            if not self._groups(an, st, u, start, conds, ctx, inds, acceleration):
                return None
        if conds is None:
            start.state = st.take(slice(0, 1))
            start.group_modes = list(modes)
        else:
            try:
                _finish_lazy_start(an, start, st, conds)
            except AssemblyError:
                return None
        t = None  # (the times: set by the caller, states(), as for the general sweep)
        ok, fl = np.ones(n, bool), {gi: [] for gi in range(ng)}
        vel, acc = velocity, velocity and acceleration
        it = np.zeros(n, int)
        return Solution(an, u, t, st, ok, [], inds, it, None, None, start, [], vel, acc, [], fl)

    def _groups(self, an, st, u, start, conds, ctx, inds, acceleration: bool) -> bool:
        """Solve the groups in order into ``st`` (their indicators into ``inds``); False
        where the general path must solve the sweep."""
        d = an.mech.driver.direction
        n = len(u)
        unit = None
        units: dict = {}  # driver links of driver_pass turning at +1 per unit driver angle
        for gi, g in enumerate(an.plan):
            kind = self.kinds[gi]
            if conds is not None:
                conds.solved(g.bodies)
            if kind == "driver":
                driver_pass(st, g, u, acceleration)
                inds[gi] = 1.0
                if g.drv.b == g.b:  # (its angle is +u)
                    units[g.b] = 1.0
                if ctx is not None:
                    ctx.extend_grid(gi)
                continue
            if kind != "rrr":  # (the fused pass needs no Drive)
                unit = unit or Drive(u, np.ones(n), np.zeros(n))
            if g.n_modes != 2:
                inds[gi] = g.position(st, unit)[1]
            else:
                # the branch at the start first (it solves the group on a state of its
                # own), then the discriminant on this one: its position reuses what
                # that computed (an RRP's guide line)
                if conds is not None:
                    try:
                        an._decide_at_start(gi, g, st, start, conds)
                    except AssemblyError:
                        return False  # (the general path says why, or starts later)
                fused = RRRPass(st, g, units) if kind == "rrr" else None
                H, dH = fused.ends() if fused is not None else g.disc(st)
                if ctx is not None:
                    # a sample near a singular position (the sweep's first and last too,
                    # which the events between samples do not look at): its rates are
                    # the limit along the motion, or undetermined, as the general path
                    # finds them
                    if not H.min() >= NEAR2:  # (a NaN fails too)
                        return False
                    if any(an._branch_events(gi, g, ctx, np.ones(n, bool))):
                        return False  # an event or a warning: the general path's
                elif not _quiet(an, gi, g, st, u, start, d, H, dH):
                    return False
                if fused is not None:
                    if not fused.closes():
                        return False
                    fused.pose(start.modes[gi], inds[gi])
                    fused.rates(acceleration)
                    if ctx is not None:
                        ctx.extend_grid(gi)
                    continue
                ok, inds[gi] = g.position(st, unit, start.modes[gi])
                if not ok.all():
                    return False
            g.velocity(st, unit)
            if acceleration:
                g.acceleration(st, unit)
            if ctx is not None:
                ctx.extend_grid(gi)
        return True


def _quiet(an, gi: int, g, st: State, u, start: StartAssembly, d: float, H, dH) -> bool:
    """Whether the branch analysis of dyad ``gi`` over the samples of ``st`` finds
    nothing, as :meth:`BranchEvents._branch_events` decides it where no point goes
    between the samples: every sample above ``sin^2(3 deg)`` (so it closes, with its
    indicator above 1e-3), and every minimum between two samples whose cubic Hermite
    estimate is below the analysis's threshold refined (by the analysis's own bisection)
    to one that is no event (not below zero, not touching it, not below 3 deg)."""
    if not H.min() >= NEAR2:  # (a NaN fails too)
        return False
    Hs = dH if d == 1 else dH * d  # H' along the sweep (dH * 1 is dH)
    turns = Hs[:-1] < 0
    turns &= Hs[1:] > 0
    if not turns.any():  # (one reduction; the indices only where there is a turn)
        return True
    inside = np.flatnonzero(turns)
    h = np.abs(u[inside + 1] - u[inside])
    est = _hermite_min(H[inside], H[inside + 1], Hs[inside] * h, Hs[inside + 1] * h)
    cand = inside[est < EVENT_CHECK]  # (a NaN estimate is not refined either)
    if not cand.size:
        return True
    flips = {k: [] for k in range(len(an.plan))}
    ctx = _Context(an, st, u, start, flips, {})
    _, hs = an._refine_minima(gi, g, ctx, cand, u, H, Hs, np.arange(len(u)))
    for h in hs.tolist():
        mu = float(np.arcsin(np.sqrt(max(min(h, 1.0), 0.0))))
        if h < -TOUCH or h <= TOUCH or mu < math.radians(3.0):
            return False  # an event: the general path reports it
    return True
