"""Which branch each two-branch group takes at the start: the conditions, the sketch,
the drawn pose, and, where the start is singular (the branches meet there), read just
past it (a part of :class:`mechsolve.core.assembly.StartAssembler`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mechsolve.base.errors import AssemblyError
from mechsolve.base.state import State
from mechsolve.core.branches import START_SNAP, TOUCH, _coincident_at
from mechsolve.core.solution import StateView
from mechsolve.groups import Drive, Group
from mechsolve.model.expr import Side


class _PendingConditions:
    """The assembly conditions not used yet, each released once the groups solved so far
    have placed every body it reads (linear in the number of conditions and groups)."""

    def __init__(self, an: Any, conditions) -> None:
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


START_PROBE = 1e-4  # how far past a singular start its branch is read (rad, x size)


class BranchChoice:
    """Methods of :class:`~mechsolve.core.assembly.StartAssembler`: see the module docstring."""

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
        singular = self._branches_meet(g, two, ok2)
        if not ready and not has_sketch and ok2[0] and not singular:
            start.reasons[gi] = "default branch (+)"
            return
        j, reason = self._choose(
            g,
            *self._where_to_choose(gi, g, two, ok2, start.modes, start.q_start, u0),
            ready,
            singular,
        )
        start.reasons[gi] = reason
        start.modes[gi] = 1.0 if j == 0 else -1.0

    def _where_to_choose(self, gi: int, g: Group, st2: State, ok2, modes, q_start, u0: float):
        """Where a group's branch is read at the start: at the start itself, or, where
        the group is singular there (its two branches meet: a toggle, a bifurcation,
        coincident joints), just past it, where the branches differ. Returns the state
        with both branches (one in each column) and where each closes."""
        if not self._branches_meet(g, st2, ok2):
            return st2, ok2
        d = self.mech.driver.direction
        delta = START_PROBE * (self.scale if self.linear else 1.0)
        # a singular point just off the start (a start 1e-5 rad before a bifurcation)
        # must not lie between the start and the probe: the branches swap across it;
        # one nearer than START_SNAP is the start's (the sweep does not flip there), and
        # so is one where the outer joints coincide at the start to within the tolerance
        # of its pose: the probe goes past it
        off = self._singular_offset(g, st2)
        snap = START_SNAP * (self.scale if self.linear else 1.0)
        for side in (1.0, -1.0):  # the side the motion goes to, else where it comes from
            step = delta
            if snap < side * d * off < delta:  # (nearer, the sweep takes it as the start)
                step = 0.5 * abs(off)
            u = u0 + side * d * step
            st = self._groups_at(u, gi, modes, q_start)
            if st is None:
                continue
            unit = Drive(np.array([u, u]), np.ones(2), np.zeros(2))
            ok, _ = g.position(st, unit, np.array([side, -side]))
            if ok.any():
                return st, ok
        return st2, ok2

    def _branches_meet(self, g: Group, st2: State, ok2) -> bool:
        """Do the group's two branches (the two columns of ``st2``) meet here, so that
        which one the motion takes is read just past this position? Its discriminant
        vanishes there, and its links' poses are the same on both (near a loop whose
        outer joints nearly coincide the discriminant is tiny but the branches are far
        apart: a probe past the start could then cross the singular point and swap
        them)."""
        H = g.disc(st2)[0]
        if not (np.isfinite(H[0]) and H[0] <= TOUCH):
            return False
        if not np.all(ok2) or _coincident_at(g, st2, 0):
            return True
        if abs(self._singular_offset(g, st2)) <= START_SNAP * (self.scale if self.linear else 1):
            return True  # the singular point is the start's (see branches.START_SNAP)
        b = list(g.bodies)
        pos = st2.block[:2, b, :]
        ang = st2.block[2, b, :]
        dpos = float(np.max(np.abs(pos[..., 0] - pos[..., 1]))) / self.scale
        dang = float(np.max(np.abs((ang[:, 0] - ang[:, 1] + np.pi) % (2 * np.pi) - np.pi)))
        return max(dpos, dang) <= 1e-6

    def _singular_just_ahead(self, g: Group, st: State) -> bool:
        """Is the group's singular point just ahead of the sweep's start (within
        START_SNAP, in the direction of motion)? It is then the start's: the branch is
        read past it and the start's own pose is the other label's (as where the outer
        joints coincide at the start)."""
        if g.n_modes != 2:
            return False
        disc = g.disc(st)
        if disc is None:
            return False
        H = float(np.asarray(disc[0])[0])
        if not (np.isfinite(H) and H <= TOUCH):
            return False
        ahead = self.mech.driver.direction * self._singular_offset(g, st)
        return 0.0 < ahead <= START_SNAP * (self.scale if self.linear else 1.0)

    @staticmethod
    def _singular_offset(g: Group, st2: State) -> float:
        """How far (driver coordinate) the group's singular point lies from the first
        column's position, from its discriminant and rate: a minimum that touches zero,
        H = c (u - u*)^2, gives u* - u = -2 H / H'; inf where not known, and where the
        outer joints coincide there already."""
        disc = g.disc(st2)
        if disc is None:
            return math.inf
        H, dH = (float(np.asarray(x)[0]) for x in disc)
        if _coincident_at(g, st2, 0) or not (np.isfinite(H) and np.isfinite(dH)) or dH == 0:
            return math.inf
        return -2.0 * H / dH

    def _choose(
        self, g: Group, st2: State, ok2: np.ndarray, ready, singular: bool = False
    ) -> tuple[int, str]:
        """The column (0: branch +, 1: branch -) to keep: the conditions that apply, then
        the sketch, then branch +; at a start where the group is singular (its branches
        meet there, so that branch + means nothing), the branch nearest to the drawn pose
        just past the start, or an error asking for a sketch where the two are equally
        near."""
        take_m, why, conflict, texts = self._choose_branches(g, st2, ok2, ready)
        if conflict[0]:
            raise AssemblyError(f"{self._file()}no branch of the {g.label} satisfies {texts}")
        if singular and why[0] != "default branch (+)":
            return int(take_m[0]), (
                f"{why[0]}, read just past the start (the start is singular: the "
                "branches meet there)"
            )
        if singular and why[0] == "default branch (+)" and ok2.all():
            # the drawn pose: every link along its own x axis (its angle 0)
            ang = np.stack([st2.block[2, b, :] for b in g.bodies])
            ang = (ang + np.pi) % (2 * np.pi) - np.pi
            dist = np.sum(ang * ang, axis=0)
            if abs(dist[0] - dist[1]) <= 1e-6 * max(dist.max(), 1e-300):
                raise AssemblyError(
                    f"{self._file()}the start is a singular position of the {g.label} (its "
                    "two branches meet there) and neither the assembly conditions nor the "
                    "drawn pose tell which branch the motion takes from it: give "
                    "'assembly: {sketch: ...}' with a point of the loop a little past the "
                    "start, or start the driver elsewhere"
                )
            j = int(dist[1] < dist[0])
            return j, (
                "nearest to the drawn pose just past the start (the start is singular: "
                "the branches meet there)"
            )
        return int(take_m[0]), str(why[0])

    def _choose_branches(self, g: Group, st2: State, ok2: np.ndarray, ready):
        """The branch of a two-branch group for each of n designs (one, or many solved as
        a batch, :mod:`mechsolve.analyses.batch`), from a state of 2 n columns: branch + of each
        design, then branch - of each. The only branch that closes, else the conditions
        that apply, else the sketch, else branch +.

        Returns where branch - is taken and why (arrays over the designs), the designs
        whose two branches close but neither satisfies the conditions, and the
        conditions' text."""
        n = len(ok2) // 2
        okp, okm = ok2[:n], ok2[n:]
        take_m = np.zeros(n, bool)
        why = np.full(n, "default branch (+)", dtype=object)
        only = okp ^ okm
        take_m[only] = okm[only]
        why[only] = "the only branch that closes"
        both = okp & okm
        conflict = np.zeros(n, bool)
        texts = ""
        if ready and both.any():
            view = StateView(self, st2)
            view.has_velocity = view.has_acceleration = False
            sat = np.ones(2 * n, bool)
            for _, c in ready:
                sat &= np.broadcast_to(np.asarray(c.evaluate(view), bool), (2 * n,))
            sp, sm = sat[:n], sat[n:]
            texts = ", ".join(repr(c.text) for _, c in ready)
            conflict = both & ~sp & ~sm
            one = both & (sp ^ sm)
            take_m[one] = sm[one]
            why[one] = f"assembly condition {texts}"
            both &= sp & sm
        sketch = {
            p: xy for p, xy in self.mech.assembly.sketch.items() if self.points[p].body in g.bodies
        }
        if sketch and both.any():
            dist = np.zeros(2 * n)
            for p, (sx, sy) in sketch.items():
                ref = self.points[p]
                x, y = st2.point(ref.body, ref.local)
                dist += (x - sx) ** 2 + (y - sy) ** 2
            near_m = dist[n:] < dist[:n]  # a tie keeps branch +
            take_m[both] = near_m[both]
            why[both] = "nearest to the sketch"
        return take_m, why, conflict, texts
