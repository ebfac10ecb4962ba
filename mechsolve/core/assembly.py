"""Assembly at the start: close the mechanism at the driver's start and choose every
group's branch (the user's conditions, then the sketch, else branch +), also where the
start is singular (the branch is read just past it) and for Newton groups (start guesses
that do not leave the branch to rounding); redundant constraints are named here.

:class:`StartAssembler` is a part of :class:`~mechsolve.core.sweep.Analysis`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from mechsolve.base.errors import AssemblyError, CannotCloseAtStart
from mechsolve.base.state import State
from mechsolve.core.branch_choice import START_PROBE, BranchChoice, _PendingConditions
from mechsolve.core.branches import _coincident_at
from mechsolve.core.conditioning import group_block, rcond
from mechsolve.core.solution import StartAssembly, StateView
from mechsolve.groups import Drive, Group, NewtonGroup


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


NEWTON_START_TRIES = 24  # further start guesses for a Newton group at the assembly

START_GUESS_RCOND = 1e-8  # a start guess this near singular leaves the branch to rounding


class StartAssembler(BranchChoice):
    """Methods of :class:`~mechsolve.core.sweep.Analysis`: see the module docstring."""

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
            meet = self._branches_meet(g, st2, ok2)
            j, reason = self._choose(
                g, *self._where_to_choose(gi, g, st2, ok2, modes, q_start, u0), ready, meet
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
        self._check_start(st, conds)
        if self.redundant:
            # the dependencies are those of the motion: at a singular start (a redundant
            # parallelogram started collinear) the Jacobian loses rank there only, so
            # they are read just past it, on the side the motion goes to
            d = self.mech.driver.direction * START_PROBE * 10 * (self.scale if self.linear else 1.0)
            past = self._groups_at(u0 + d, len(self.groups), modes, q_start)
            self.redundancy = self._check_redundancy(
                st, drive, None if past is None else (past.take([0]), u0 + d)
            )
        group_modes = list(modes)
        if self.plan is not self.groups:  # monolithic Newton starts from the assembled pose
            q_start = {
                gi: g.get_q(st, 0) for gi, g in enumerate(self.plan) if isinstance(g, NewtonGroup)
            }
            modes = [1.0] * len(self.plan)
        return StartAssembly(modes, q_start, reasons, st, u0, group_modes)

    def _check_start(self, st: State, conds: _PendingConditions) -> None:
        """The assembly conditions no group decided must hold at the start, and each joint
        kind checks its own (a rack's mesh)."""
        mech = self.mech
        view = StateView(self, st)
        view.has_velocity = view.has_acceleration = False
        for _, c in conds.remaining():  # conditions that no group decided: they must hold
            if not bool(np.all(c.evaluate(view))):
                raise AssemblyError(
                    f"{self._file()}the start position does not satisfy the assembly condition "
                    f"{c.text!r}, and no loop's branch can change that"
                )
        first = st.take([0])
        for j in mech.joints:  # the kinds' own checks of the start (a rack's mesh)
            j.check_start(mech, self.system.by_joint[j.name], first)

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
            for c in g.constraints:  # a joint that can tell why (a follower off its cam)
                c.cannot_close(st)
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

    def _check_redundancy(
        self, st: State, drive: Drive, past: tuple[State, float] | None = None
    ) -> Redundancy:
        """At the assembled start: are the surplus equations consistent, and which ones
        take part in a dependency (the left null space of Phi_q)? Where the start is
        singular (the rank is short there), the dependencies are read at ``past``, a
        position just past it along the motion."""
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
        if rank < sys_.nq and past is not None:
            J = sys_.jacobian(past[0])[0]
            U, sv, _ = np.linalg.svd(J)
            rank = int(np.sum(sv > 1e-9 * sv[0]))
            drive = self.drive(np.array([past[1]]))
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
                if c.letter != "R" or b not in (c.a, c.b):
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

    def _cannot_close(self, g: Group, st: State, u0: float, first_ok=None) -> CannotCloseAtStart:
        words = partial(self.mech.output_units().text, unit="m")  # the file's unit
        reason = g.fail_reason(st, 0, words)
        return CannotCloseAtStart(
            f"{self._file()}cannot assemble at {self.format_u(u0)}: {reason}",
            g.label,
            reason,
            first_ok,
        )
