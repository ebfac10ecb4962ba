"""The generic group: any block of the constraint system, solved by Newton-Raphson.

Used for groups with no closed form (class III groups, triads, cylinders between two
moving links, ...) and, with ``solver.method: newton``, for the whole mechanism at once.
Positions are solved one after another; each starts from a prediction extrapolated from
the previous solutions (continuation), so that the solution stays on the branch it
started on. Velocities and accelerations solve the group's block of
``Phi_q qdot = nu`` and ``Phi_q qddot = gamma`` for all positions in one batched solve.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.base.newton import SolveStats, newton_lean, solve
from mechsolve.base.state import State
from mechsolve.groups.base import Drive, Group
from mechsolve.groups.compiled import ENV, requested
from mechsolve.groups.newton_batched import BatchedSweep
from mechsolve.groups.newton_common import BATCH_MIN, MAX_DEPTH, MAX_JUMP, _extrapolate
from mechsolve.groups.newton_rates import NewtonRates
from mechsolve.groups.reduced import FLOATS_UP_TO, _Angles, _det_small, _rowmax_abs

MAX_GAPS = 8  # a sweep starts again past at most this many breaks, then stops
# a Hadamard ratio of the group's determinant below this: a singular position, whose sign
# is not to be trusted (Newton converges to about sqrt(atol) at a limit position)
DET_SIGN = 1e-6
# the poses either side of a bisected sign change farther apart than this (radians, or
# lengths over the size): two branches that pass close, not a bifurcation they share
JUMP_APART = 1e-6


class NewtonGroup(BatchedSweep, NewtonRates, Group):
    """A group solved numerically. Keeps per-position solver statistics."""

    kind = "Newton"
    n_modes = 0  # the branch follows from the start guess and continuity

    def __init__(self, bodies, constraints, names, atol: float, max_iterations: int = 30):
        self.col = {b: k for k, b in enumerate(bodies)}
        self.n = 3 * len(bodies)
        self.m = sum(c.m for c in constraints)
        self.atol = atol
        self.scale = 1.0  # the mechanism's size; the analysis sets it
        self.batched = True
        self.predictor = "hermite"  # batched prediction between coarse positions: or "linear"
        # what asks for the compiled sweep (mechsolve.groups.compiled), None: NumPy only
        self.compiled: str | None = ENV if requested() else None
        self.max_iterations = max_iterations
        try:  # revolute groups: the links' angles are the only unknowns of the sweep
            self.red: _Angles | None = _Angles(bodies, constraints) if self.m == self.n else None
        except ValueError:
            self.red = None
        self._inv_cache: tuple | None = None
        self._elim_cache: tuple | None = None  # see _angle_elim, _angle_entries2
        self._entries2_cache: tuple | None = None
        self._det_cache: tuple | None = None  # see dets()
        self._bound: tuple[float, float, float] | None = None
        self._jump_w: tuple[float, np.ndarray] | None = None
        # where the last sweep was not continuous: (the position before, a driver value
        # in between where the group could not be solved next to its neighbours)
        self.gaps: list[tuple[int, float]] = []
        # where it stopped: (the first position not followed, where it broke, how many
        # times it had started again before)
        self.stopped: tuple[int, float, int] | None = None
        self._gap_u, self._gap_open = float("nan"), False
        super().__init__(bodies, constraints, names)

    def describe(self) -> str:
        joints = ", ".join(c.name for c in self.constraints)
        return f"group of {', '.join(self.body_names)} (joints {joints})"

    # -- one position ------------------------------------------------------------------
    def get_q(self, st: State, i: int) -> np.ndarray:
        q = np.empty(self.n)
        for b, k in self.col.items():
            q[3 * k] = st.x[b, i]
            q[3 * k + 1] = st.y[b, i]
            q[3 * k + 2] = st.th[b, i]
        return q

    def set_q(self, st: State, i, q: np.ndarray) -> None:
        for b, k in self.col.items():
            st.x[b, i] = q[3 * k]
            st.y[b, i] = q[3 * k + 1]
            st.set_angle(b, q[3 * k + 2], i)

    def residual(self, st: State, u) -> np.ndarray:
        return np.concatenate([c.residual(st, u) for c in self.constraints], axis=0)

    def jacobian(self, st: State) -> np.ndarray:
        """The group's own block of Phi_q, shape (N, m, n)."""
        J = np.zeros((st.n, self.m, self.n))
        r = 0
        for c in self.constraints:
            for body, blk in c.jacobian(st).items():
                k = self.col.get(body)
                if k is not None:
                    J[:, r : r + c.m, 3 * k : 3 * k + 3] = blk.transpose(2, 0, 1)
            r += c.m
        return J

    def solve_at(self, st1: State, u1: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, SolveStats]:
        """Solve the group at the single position held by ``st1`` (N == 1) from ``q0``."""

        def fun(q):
            self.set_q(st1, 0, q)
            return self.residual(st1, u1)[:, 0]

        def jac(q):
            self.set_q(st1, 0, q)
            return self.jacobian(st1)[0]

        q, stats = solve(fun, jac, q0, self.atol, self.max_iterations)
        self.set_q(st1, 0, q)
        return q, stats

    def _solve_one(self, st1: State | None, u1: np.ndarray, q0: np.ndarray, K=None):
        """One position of a sweep from the guess ``q0`` (body coordinates, as
        :meth:`solve_at`): a revolute group by Newton in its links' angles alone (the
        guess's angles; its frames' positions follow from them), else :meth:`solve_at`.
        The scipy fallback of :func:`~mechsolve.base.newton.solve` applies to both.
        ``K``: the solved bodies' terms at this position (:meth:`_Angles.known`), when
        known already; ``st1`` (a one-position state, updated) may then be None."""
        red = self.red
        if red is None:
            return self.solve_at(st1, u1, q0)
        if K is None:
            K = red.known(st1)
        if isinstance(K[0], list):  # known_one's floats: a lone position, in floats
            return self._solve_one_floats(st1, u1, q0, K)
        Kr0, thp, fun_jac = self._reduced(K, u1)
        sub = red.sub
        th0 = np.asarray(q0, float)[2::3][red.free]
        if sub.nb == 0:  # every angle fixed by a driver: nothing to iterate
            thf, stats = th0, SolveStats(True, "newton", 0, 0, 0, 0.0)
        else:
            if sub.nb <= FLOATS_UP_TO:  # (newton_floats, its angles kept as a list)
                thf, ok, it, r, nfev = sub.newton_list(
                    Kr0.tolist(), th0.tolist(), self.atol, self.max_iterations
                )
                stats = SolveStats(ok, "newton", it, nfev, nfev, r)
            else:
                thf, stats = newton_lean(fun_jac, th0, self.atol, self.max_iterations)
            if not stats.converged:  # the full Newton with its scipy fallback

                def fun(th):
                    return fun_jac(th)[0]

                def jac(th):
                    return fun_jac(th)[1]

                thf, stats = solve(fun, jac, th0, self.atol, self.max_iterations)
        th = red.join_one(thf, thp[0])
        q = np.empty(self.n)
        q[2::3] = th
        q[0::3], q[1::3] = red.poses_one(th, K[1][0].tolist(), K[2][0].tolist())
        if st1 is not None:
            self.set_q(st1, 0, q)
        return q, stats

    def _solve_one_floats(self, st1: State | None, u1: np.ndarray, q0: np.ndarray, K):
        """:meth:`_solve_one` with the solved bodies' terms ``K`` as
        :meth:`_Angles.known_one` gives them (lists of floats): the constant part and the
        fixed angles (:meth:`_Angles.reduce`) in floats; a Newton solve that does not
        converge in floats goes through :meth:`_solve_one` with arrays."""
        red = self.red
        sub = red.sub
        if sub.nb == 0 or sub.nb > FLOATS_UP_TO:
            return self._solve_one(st1, u1, q0, [np.array([k]) for k in K])
        K0, Px, Py = K
        u = float(u1[0])
        Ku = list(K0)
        for e in range(2 * red.ne, red.nb):  # with_driver
            Ku[e] -= u
        th = np.asarray(q0, float)[2::3].tolist()
        free, fixed = red.free.tolist(), red.fixed.tolist()
        if fixed:  # reduce(): theta_k = sign (u - K_d), their terms into the constant part
            thp = [-Ku[r] * sg for r, sg in zip(red.frows.tolist(), red.fsign.tolist())]
            v = [math.cos(t) for t in thp] + [math.sin(t) for t in thp] + thp
            MTf = red.mtf_list()
            Kr0 = [
                Ku[r] + sum(vj * MTf[j][col] for j, vj in enumerate(v))
                for col, r in enumerate(red.rows.tolist())
            ]
        else:
            thp, Kr0 = [], Ku
        thf, ok, it, r, nfev = sub.newton_list(
            Kr0, [th[k] for k in free], self.atol, self.max_iterations
        )
        if not ok:  # the full Newton with its scipy fallback, as _solve_one takes it
            return self._solve_one(st1, u1, q0, [np.array([k]) for k in K])
        for j, k in enumerate(free):
            th[k] = thf[j]
        for j, k in enumerate(fixed):
            th[k] = thp[j]
        q = np.empty(self.n)
        q[2::3] = th
        q[0::3], q[1::3] = red.poses_one(th, Px, Py)
        if st1 is not None:
            self.set_q(st1, 0, q)
        return q, SolveStats(True, "newton", it, nfev, nfev, r)

    def _reduced(self, K, u1: np.ndarray):
        """A revolute group's equations in its free angles at one position: the known
        terms, the angles the drivers fix, and ``fun_jac(th) -> (residual, Jacobian)``."""
        red = self.red
        Kr, thp = red.reduce(red.with_driver(K[0], u1))
        sub = red.sub
        Kr0 = Kr[0]
        M1, M2, M3, MT = sub.M1, sub.M2, sub.M3 if sub.nd else 0.0, sub.MT

        def fun_jac(th):
            C, S = np.cos(th), np.sin(th)
            return Kr0 + np.concatenate([C, S, th]) @ MT, M2 * C - M1 * S + M3

        return Kr0, thp, fun_jac

    def _det(self, st1: State | None, u1: np.ndarray, q: np.ndarray, K=None) -> float:
        """The determinant of the group's equations at the solved pose ``q`` (of its
        reduced equations in the angles for a revolute group: the same sign changes),
        over the product of its rows' lengths: between -1 and 1 whatever the units
        (Hadamard's ratio), 0 where the group is singular."""
        if self.m != self.n:
            return 1.0  # a redundant block: no sign to follow
        if self.red is None:
            self.set_q(st1, 0, q)
            J = self.jacobian(st1)[0]
        elif self.red.sub.nb == 0:
            return 1.0
        elif self.red.sub.nb <= 4:  # in floats: the constant part does not enter
            th = np.asarray(q, float)[2::3].tolist()
            return self.red.sub.det_ratio([th[k] for k in self.red.free_list])
        else:
            _, _, fun_jac = self._reduced(self.red.known(st1) if K is None else K, u1)
            J = fun_jac(np.asarray(q, float)[2::3][self.red.free])[1]
        with np.errstate(all="ignore"):
            det = _det_small(J) if self.red is not None else np.linalg.det(J)
            d = float(det / np.prod(np.linalg.norm(J, axis=1)))
        return d if np.isfinite(d) else 0.0

    def red_dets(self, st: State, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A revolute group's :meth:`_det` at every position of ``st`` (NaN where not
        ``ok`` or not finite), and where it is finite: the determinant of its free angles'
        Jacobian, which differs from that of its block of Phi_q by a constant factor (the
        Schur complement of a constant unimodular block, bordered by the drivers' rows
        of +-1: see :class:`~mechsolve.groups.reduced._Angles`), so that it changes sign
        where that one does, at a fraction of its cost."""
        red = self.red
        sub = red.sub
        if sub is red and red.nb == 2 and ok.all():  # the entries kept for the rates
            det = self._angle_entries2(st)[4]  # (and the bound): the same products
            good = np.isfinite(det)  # (NaN where a cosine or sine is not finite)
            return (det, good) if good.all() else (np.where(good, det, np.nan), good)
        bodies = [self.bodies[k] for k in red.free.tolist()]
        C, S = st.c[bodies].T, st.s[bodies].T
        det = np.full(st.n, np.nan)
        good = ok & np.isfinite(_rowmax_abs(C)) & np.isfinite(_rowmax_abs(S))
        if good.all() and sub is red and red.elim is not None:  # kept for the rates
            det = self._angle_elim(st)[0].dets()
        elif good.all():
            det = sub.dets(C, S)
        elif good.any():
            det[good] = sub.dets(C[good], S[good])
        good &= np.isfinite(det)
        return det, good

    def dets(self, st: State, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The group's determinant at every position of ``st`` (of its free angles'
        equations for a revolute group: :meth:`red_dets`) and where it is known (``ok``
        and finite); a redundant group, or one whose angles the drivers fix, has none
        (``known`` all False)."""
        if self.m != self.n or (self.red is not None and self.red.sub.nb == 0):
            return np.full(st.n, np.nan), np.zeros(st.n, bool)
        if self.red is not None:
            # kept for the same poses (the state's token and the angles) and the same
            # ``ok``: the batched sweep's check for a sign change and the bifurcation
            # search ask for the same determinants one after the other
            th = st.th[self.bodies]
            c = self._det_cache
            if (
                c is not None
                and c[0] == st.token
                and c[1].shape == th.shape
                and np.array_equal(c[1], th)
                and np.array_equal(c[2], ok)
            ):
                return c[3], c[4]
            det, good = self.red_dets(st, ok)
            self._det_cache = (st.token, th, ok.copy(), det, good)
            return det, good
        J = self.jacobian(st)
        good = ok & np.all(np.isfinite(J), axis=(1, 2))
        det = np.full(st.n, np.nan)
        if good.any():
            det[good] = np.linalg.det(J[good])
        return det, good

    def _sign_changes(self, st: State, ok: np.ndarray) -> bool:
        """Does the determinant change sign between two solved positions?"""
        det, good = self.dets(st, ok)
        s = np.sign(det)
        return bool(np.any(good[:-1] & good[1:] & (s[:-1] * s[1:] < 0)))

    def _put_angles(self, st: State, th: np.ndarray, Px: np.ndarray, Py: np.ndarray, cs=None):
        """Place the group's links at all positions of ``st`` from their angles (N, n):
        each link's angle, cosine and sine written in place into its rows, its frame
        ``P_b + sum_k A(theta_k) W[b, k]`` from the tree's nonzero local vectors only
        (none for a link whose frame sits at a solved body's point). ``cs``: the free
        angles' cosines and sines when known (a refinement turns them with its steps:
        ``cos`` and ``sin`` of thousands of angles cost some 15 ns each, 50 times a
        product), as lists of 1-D arrays in the order of ``red.free``."""
        red = self.red
        given = {} if cs is None else {k: j for j, k in enumerate(red.free.tolist())}
        for b, k in self.col.items():
            j = given.get(k)
            if j is None:
                st.set_angle(b, th[:, k])
            else:
                st.th[b], st.c[b], st.s[b] = th[:, k], cs[0][j], cs[1][j]
        C = [st.c[b] for b in self.bodies]
        S = [st.s[b] for b in self.bodies]
        for b, k in self.col.items():
            x, y = st.x[b], st.y[b]
            x[:] = Px[:, k]
            y[:] = Py[:, k]
            for j, a, c in red._wterms[k]:  # as poses_one: + c_j a - s_j c, + s_j a + c_j c
                t = C[j] * a
                t -= S[j] * c
                x += t
                t = S[j] * a
                t += C[j] * c
                y += t

    def _q_rows(self, st: State, rates: bool = False) -> np.ndarray:
        """The group's body coordinates at every position (N, 3 links), or their rates."""
        x, y, th = (st.vx, st.vy, st.w) if rates else (st.x, st.y, st.th)
        q = np.empty((st.n, self.n))
        for b, k in self.col.items():
            q[:, 3 * k], q[:, 3 * k + 1], q[:, 3 * k + 2] = x[b], y[b], th[b]
        return q

    # -- the sweep ----------------------------------------------------------------------
    def get_qdot(self, st: State, i: int) -> np.ndarray:
        q = np.empty(self.n)
        for b, k in self.col.items():
            q[3 * k], q[3 * k + 1], q[3 * k + 2] = st.vx[b, i], st.vy[b, i], st.w[b, i]
        return q

    def _jump(self, q: np.ndarray, q_pred: np.ndarray) -> float:
        """Size of the Newton correction from the prediction: lengths over the mechanism's
        size, angles in radians."""
        if not q.size:
            return 0.0
        w = self._jump_w
        if w is None or w[0] != self.scale:
            v = np.ones(self.n)
            v[0::3] = v[1::3] = 1.0 / self.scale
            w = self._jump_w = (self.scale, v)
        return float(np.max(np.abs(q - q_pred) * w[1]))

    def _near_jump(self, q: np.ndarray, q_pred: np.ndarray) -> tuple[np.ndarray, float]:
        """``_near_angles(q, q_pred)`` and its :meth:`_jump` from ``q_pred``, from one
        difference where no angle is moved (the same values: a continuation step asks
        for both, and each NumPy call costs about a microsecond)."""
        if not q.size:
            return q, 0.0
        a = np.abs(q - q_pred)
        if (a[2::3] > np.pi).any():  # an angle whole turns away: moved, measured again
            q = _near_angles(q, q_pred)
            return q, self._jump(q, q_pred)
        w = self._jump_w
        if w is None or w[0] != self.scale:
            return q, self._jump(q, q_pred)
        return q, float((a * w[1]).max())

    def sweep(
        self,
        st: State,
        drive: Drive,
        q_start: np.ndarray,
        ok_in: np.ndarray,
        prefix=None,
        restart=None,
        history=None,
    ):
        """Solve positions 0..N-1: batched when possible (:meth:`sweep_batched`), else by
        continuation (:meth:`sweep_sequential`). Returns ``ok``, ``iterations``, ``methods``
        (the text of each position, or one text when every position has it: an array of
        text costs ~0.1 ms to build and to compare on a sweep of thousands).
        ``history``: the driver values and poses solved before position 0 (a chunk that
        continues a sweep), so that its first steps continue the same motion."""
        self.gaps, self.stopped = [], None
        if self.red is not None and self.red.sub.nb == 0:
            return self._sweep_fixed(st, drive, ok_in)
        if self.batched and st.n >= BATCH_MIN and self.m == self.n and ok_in.all():
            out = self.sweep_batched(st, drive, q_start, prefix)
            # (a singular position passed: whether a bifurcation or a range where the
            # group cannot close stepped over, the sequential sweep tells them apart)
            if (
                out is not None
                and not self._sign_changes(st, out[0])
                and self._continues(st, drive, q_start, prefix, history)
            ):
                return out
        return self.sweep_sequential(st, drive, q_start, ok_in, prefix, restart, history)

    def _continues(self, st: State, drive: Drive, q_start, prefix, history) -> bool:
        """Whether the batched sweep's first positions (started from one pose) are those
        that continuation from ``history`` reaches: next to a bifurcation a start from
        one pose cannot tell the direction of the motion."""
        if not history:
            return True
        k = min(st.n, 4)
        sub = st.take(np.arange(k))
        ok, _, _ = self.sweep_sequential(
            sub, drive.take(np.arange(k)), q_start, np.ones(k, bool), prefix, None, history
        )
        self.gaps, self.stopped = [], None
        return bool(ok.all()) and all(
            self._jump(self.get_q(sub, i), self.get_q(st, i)) < 1e-6 for i in range(k)
        )

    def _sweep_fixed(self, st: State, drive: Drive, ok_in: np.ndarray):
        """A group whose every angle a driver fixes alone (a driven crank): its poses
        follow from the driver values directly, at every position."""
        red = self.red
        if st.n == 1 and ok_in[0] and self._fixed_one(st, float(drive.u[0])):
            return ok_in.copy(), np.zeros(1, int), "newton"
        thp = self._crank_alone(st, drive)
        if thp is not None:  # (one angle: its own largest value)
            ok = ok_in & np.isfinite(thp)
        else:
            K, Px, Py = red.known(st)
            thp = red.fixed_angles(red.with_driver(K, drive.u))
            self._put_angles(st, red.join(thp[:, :0], thp), Px, Py)
            ok = ok_in & np.isfinite(_rowmax_abs(thp))
        if ok.all():
            return ok, np.zeros(st.n, int), "newton"
        for i in np.flatnonzero(~ok):
            self._nan(st, i)
        methods = np.where(ok, "newton", np.where(ok_in, "failed", "")).astype(object)
        return ok, np.zeros(st.n, int), methods

    def _crank_alone(self, st: State, drive: Drive):
        """:meth:`_sweep_fixed`'s poses for a lone link whose angle its driver fixes and
        whose terms are all the ground's (a crank at a ground pivot): the angle
        ``-(K_d - u) sign`` on the driver values' row, placed with its cosine and sine,
        the frame at its constant point. The same operations on the same values as
        :meth:`_Angles.known`, :meth:`~_Angles.fixed_angles` and :meth:`_put_angles`,
        without their (N, 1) arrays. Returns the angles (N,), or None for other groups
        (nothing written)."""
        red = self.red
        if red.nb != 1 or red.ne or not red.nd or red.free.size or red._wterms[0]:
            return None
        kc, pxc, pyc, _, kmov, dmov, pmov = red._known_plan(st.nb)
        if kmov or dmov or pmov:
            return None
        th = kc[int(red.frows[0])] - drive.u  # with_driver: K_d - u
        np.negative(th, out=th)  # fixed_angles: -(K_d - u) * sign
        th *= red.fsign[0]
        b = self.bodies[0]
        st.set_angle(b, th)
        st.x[b] = pxc[0]
        st.y[b] = pyc[0]
        return th

    def _fixed_one(self, st: State, u: float) -> bool:
        """:meth:`_sweep_fixed` at the one position of ``st`` in floats, the same
        operations in the same order (a NumPy call on one-element arrays costs more than
        its arithmetic): False (nothing written) where an angle is not finite."""
        red = self.red
        K, Px, Py = red.known_one(st)
        for e in range(2 * red.ne, red.nb):  # with_driver
            K[e] -= u
        th = [0.0] * red.nb
        for k, row, sign in zip(red.fixed.tolist(), red.frows.tolist(), red.fsign.tolist()):
            th[k] = -K[row] * sign
        if not all(math.isfinite(v) for v in th):
            return False
        C = np.cos(th).tolist()  # as _put_angles
        S = np.sin(th).tolist()
        wx, wy = red._wx, red._wy
        for b, k in self.col.items():  # red.poses: Px + C Wx^T - S Wy^T
            x, y = Px[k], Py[k]
            cx = sy = sx = cy = 0.0
            for j in range(red.nb):
                cx += C[j] * wx[k][j]
                sy += S[j] * wy[k][j]
                sx += S[j] * wx[k][j]
                cy += C[j] * wy[k][j]
            st.x[b, 0], st.y[b, 0], st.th[b, 0] = (x + cx) - sy, (y + sx) + cy, th[k]
            st.c[b, 0], st.s[b, 0] = C[k], S[k]
        return True

    def sweep_sequential(
        self,
        st: State,
        drive: Drive,
        q_start: np.ndarray,
        ok_in: np.ndarray,
        prefix=None,
        restart=None,
        history=None,
    ):
        """Solve positions 0..N-1 in order by continuation from ``q_start`` at position 0
        (after the driver values and poses ``history``, lists, when given).

        Each step predicts from the previous solutions (Lagrange extrapolation) and corrects
        by Newton-Raphson (scipy when Newton fails). A step is accepted when the correction
        is small (:data:`MAX_JUMP`); otherwise the interval is marched in 2, 4, 8, ...
        substeps (``prefix(u, k)`` solves the groups before this one at substep values), so
        that a coarse step cannot jump to another branch. After a gap (a dead zone) the
        sweep resumes from ``restart(i)`` when it gives a guess (the closed-form groups on
        the user's branches; ``False`` when those cannot close there: the position is then
        unassemblable), else from the last solution; likewise where position i is not
        reached continuously from i - 1 (see :meth:`_start_again`). Returns ``ok``,
        ``iterations`` and ``methods`` over the positions."""
        n = st.n
        self.gaps, self.stopped, crossed = [], None, False
        ok = np.zeros(n, bool)
        iters = np.zeros(n, int)
        methods = np.array(["" for _ in range(n)], dtype=object)
        hu, hq = [], []  # the last driver values and poses: the continuation's history
        last_good = np.asarray(q_start, float)
        last_det = 0.0
        Kall, Kone = self._known_terms(st)
        for i in range(n):
            if not ok_in[i]:
                self._nan(st, i)
                hu, hq = [], []
                continue
            Ki = Kone if Kall is None else [k[i : i + 1] for k in Kall]
            st1 = st.take([i]) if Ki is None else None
            ui = float(drive.u[i])
            if not hq:  # the start, or the first position after a gap
                guess = restart(i) if (restart is not None and i > 0) else None
                if guess is False:  # it cannot close on the user's branch here
                    self._nan(st, i)
                    methods[i] = "failed"
                    continue
                q0 = guess if guess is not None else last_good
                q, stats = self._solve_one(st1, drive.u[i : i + 1], q0, Ki)
                good = stats.converged
            else:
                q, stats, good, det, passed = self._step(
                    st1, drive, i, Ki, hu, hq, last_det, prefix
                )
                crossed = crossed or passed is True
                if not good:  # not reached continuously from i - 1: start again at i
                    q, stats, good = self._start_again(st1, drive, i, Ki, good, restart, crossed)
                    if good is None:  # the branch past here is not known: stop
                        for j in range(i, n):
                            self._nan(st, j)
                        methods[i:] = "failed"
                        break
                    hu, hq = [], []
            iters[i] = stats.iterations
            methods[i] = stats.method
            if good:
                ok[i], fresh = True, not hq
                if fresh:  # (the next position compares its sign: none after the last)
                    det = self._det(st1, drive.u[i : i + 1], q, Ki) if i + 1 < n else 0.0
                self.set_q(st, i, q)
                last_good, last_det = q, det
                # started again on a limit position (the edge of a range where it cannot
                # close), where both branches meet: the next position starts again too
                edge = fresh and i > 0 and restart is not None and abs(det) < DET_SIGN
                if i == 0 and history:  # a chunk continuing a sweep: the motion so far
                    hu, hq = history
                hu, hq = ([], []) if edge else ((hu + [ui])[-3:], (hq + [q])[-3:])
            else:
                self._nan(st, i)
                hu, hq = [], []
        return ok, iters, methods

    def _known_terms(self, st: State):
        """A revolute group needs only the solved bodies' terms at each position:
        ``(per position, None)``; a lone position ``(None, as floats)`` (``_solve_one``
        solves it in floats); ``(None, None)`` for other groups."""
        if self.red is None:
            return None, None
        return (self.red.known(st), None) if st.n > 1 else (None, self.red.known_one(st))

    def _step(self, st1, drive: Drive, i: int, Ki, hu, hq, last_det: float, prefix):
        """Position ``i`` by continuation from the history: ``(q, stats, good, det,
        passed)`` (see :meth:`_advance`, :meth:`_passed`; ``good`` None past a range
        where the group cannot close). A step onto the other branch next to a
        near-singular position is taken again in substeps that keep the sign."""
        ui = float(drive.u[i])
        q, stats, good = self._advance(st1, ui, hu, hq, i - 1, prefix, Ki)
        det, passed = last_det, False
        if good:
            det, passed = self._passed(st1, drive, i, Ki, q, hu, hq, last_det, prefix)
            if passed == "jump":  # unless no substeps keep the sign: a bifurcation
                got = self._advance(st1, ui, hu, hq, i - 1, prefix, Ki, keep=last_det)
                if got[2]:
                    q, stats, good = got
                    det, passed = self._det(st1, drive.u[i : i + 1], q, Ki), False
                else:
                    passed = True
            good = None if passed == "gap" else good
        return q, stats, good, det, passed

    def _passed(self, st1, drive: Drive, i: int, Ki, q, hu, hq, last_det: float, prefix):
        """The group's determinant at position ``i`` (solved as ``q``, continuously from
        the history ``hu``, ``hq``) and what the step passed where it changed sign: a
        range where the group cannot close (``"gap"``), a bifurcation (True), or nothing
        (False; nor where either end is singular, its sign then being rounding's)."""
        det = self._det(st1, drive.u[i : i + 1], q, Ki)
        if not (det * last_det < 0 and min(abs(det), abs(last_det)) > DET_SIGN):
            return det, False
        ends = (hu[-1], hq[-1], last_det), (float(drive.u[i]), q, det)
        found = self._hidden_gap(st1, Ki, *ends, i - 1, prefix)
        return det, {"gap": "gap", "jump": "jump"}.get(found, True)

    def _start_again(self, st1, drive: Drive, i: int, Ki, good, restart, crossed: bool):
        """Position ``i``, which the sweep did not reach continuously from ``i - 1``
        (``good``: None if the group closes there, False if not from the prediction):
        solved on the user's branches, which are the motion's past a range where it
        cannot close while no bifurcation has been passed. Else (a jump at a singular
        position, or after a bifurcation) the branch past here is not known: ``good`` is
        None and ``self.stopped`` says where."""
        across = good is False or self._gap_open  # a range it cannot close
        trust = restart is not None and across and not crossed
        guess = restart(i) if trust else None
        q, stats = None, SolveStats(False, "failed", 0, 0, 0, float("nan"))
        if (guess is None and good is None) or len(self.gaps) >= MAX_GAPS:
            # (nor does it start again more than MAX_GAPS times: a sweep whose every
            # step breaks off would march 2**MAX_DEPTH substeps at every position)
            self.stopped = (i, self._gap_u, len(self.gaps))
            return q, stats, None
        solved = False
        if guess is not None and guess is not False:
            q, stats = self._solve_one(st1, drive.u[i : i + 1], guess, Ki)
            solved = stats.converged
        if solved:
            self.gaps.append((i - 1, self._gap_u))
        return q, stats, solved

    def _hidden_gap(self, st1, K1, before, after, k: int, prefix) -> str:
        """Between two positions reached continuously, ``before = (u0, q0, det0)`` and
        ``after = (u1, q1, det1)``, where the group's determinant changes sign: is there a
        point where it cannot close (a range narrower than the substeps, stepped over onto
        the other branch: ``"gap"``), a bifurcation passed smoothly (``"crossing"``), or a
        step onto the other branch next to a near-singular position (``"jump"``: the two
        branches pass closer than a Newton step, but never meet)?
        Bisection on the sign of the determinant, each probe reached by continuation
        (:meth:`_advance`) from one end of the bracket or the other: a probe that neither
        reaches continuously is in such a range (``self._gap_u`` there;
        ``self._gap_open`` when it cannot close there at all); where the bracket closes
        on poses still apart (by more than :data:`JUMP_APART`), the sign changed by a
        jump between two branches, not at a point they share."""
        a, qa, da = before
        b, qb, _ = after
        # (to rounding of the driver value: a sign that rounding flips next to a singular
        # position must not bisect for ever)
        width = max(1e-9 * abs(b - a), 8 * np.finfo(float).eps * max(abs(a), abs(b), 1.0))
        for _ in range(64):
            if abs(b - a) <= width:
                break
            m = 0.5 * (a + b)
            if prefix is not None and self.red is None:
                stm, Km = prefix(np.array([m]), k), None
            elif prefix is not None:
                stm, Km = None, self.red.known(prefix(np.array([m]), k))
            else:
                stm, Km = st1, K1
            for u0, q0 in ((a, qa), (b, qb)):
                qm, _, good = self._advance(stm, m, [u0], [q0], k, prefix, Km)
                if good:
                    break
            else:
                self._gap_u = m
                return "gap"
            dm = self._det(stm, np.array([m]), qm, Km)
            if dm * da > 0:
                a, qa, da = m, qm, dm
            else:
                b, qb = m, qm
        # both branches pass through a bifurcation, so the poses either side of it meet
        # as the bracket closes; next to a near-singular position they stay apart (the
        # determinant's ratio is no measure: it stays finite where a row vanishes)
        return "jump" if self._jump(qa, qb) > JUMP_APART else "crossing"

    def _advance(self, st1: State | None, ui: float, hu, hq, k: int, prefix, K1=None, keep=None):
        """One continuation step to ``ui``; substeps when the full step jumps. ``K1``:
        the solved bodies' terms at ``ui`` for a revolute group (``st1`` is then None).
        ``keep``: the determinant's value at the last position, whose sign the substeps
        must keep (the full step went onto the other branch past a near-singular
        position; a sign change of trusted size counts as a jump)."""
        q_pred = _extrapolate(hu, hq, ui)
        q, stats = self._solve_one(st1, np.array([ui]), q_pred, K1)
        q, jump = self._near_jump(q, q_pred)
        if keep is None and stats.converged and jump <= MAX_JUMP:
            return q, stats, True
        u0 = hu[-1]
        uj = 0.5 * (u0 + ui)  # where the substeps last broke
        self._gap_open = False  # ... and whether the group could not close there
        for depth in range(1, MAX_DEPTH + 1):
            m = 2**depth
            us = u0 + (ui - u0) * np.arange(1, m + 1) / m
            sub = prefix(us[:-1], k) if (prefix is not None and m > 1) else None
            Ks = None if (K1 is None or sub is None) else self.red.known(sub)
            lu, lq = list(hu), list(hq)
            total = 0
            ok_all = True
            for j, uj in enumerate(us):
                if K1 is not None:  # a revolute group: the solved bodies' terms
                    stj = None
                    Kj = K1 if (j == m - 1 or Ks is None) else [a[j : j + 1] for a in Ks]
                else:
                    stj = st1 if j == m - 1 else (sub.take([j]) if sub is not None else st1)
                    Kj = None
                qp = _extrapolate(lu, lq, uj)
                qj, sj = self._solve_one(stj, np.array([uj]), qp, Kj)
                qj, jump = self._near_jump(qj, qp)
                total += sj.iterations
                if not (sj.converged and jump <= MAX_JUMP) or (
                    keep is not None and self._flips(stj, uj, qj, Kj, keep)
                ):
                    ok_all = False
                    self._gap_open = not sj.converged
                    break
                if keep is not None:
                    keep = self._last_det
                lu, lq = (lu + [uj])[-3:], (lq + [qj])[-3:]
            if ok_all:
                sj.iterations = total
                return qj, sj, True
            if not sj.converged and j == 0 and depth >= 4:
                break  # no solution even right next to the last one: a dead zone starts here
        self._gap_u = uj
        if stats.converged:
            # the group closes at ui, but not continuously from the last position: a range
            # where it cannot close, or a singular position, lies inside the interval,
            # narrower than the finest substep; the caller starts again at ui
            return q, stats, None
        return q, stats, False

    def _flips(self, st1, u: float, q, K, keep: float) -> bool:
        """Whether the determinant at ``q`` (position ``u``) has the other sign than
        ``keep``, both of trusted size; keeps the value in ``self._last_det``."""
        d = self._det(st1, np.array([u]), q, K)
        self._last_det = d
        return d * keep < 0 and min(abs(d), abs(keep)) > DET_SIGN

    def _nan(self, st: State, i: int) -> None:
        for b in self.bodies:
            for arr in (st.x, st.y, st.th, st.c, st.s):
                arr[b, i] = np.nan

    def position(self, st: State, drive: Drive, mode=1.0):
        """Solve all positions by continuation from the poses already in ``st`` at 0."""
        q0 = self.get_q(st, 0)
        ok, _, _ = self.sweep(st, drive, q0, np.ones(st.n, bool))
        return ok, self.indicator(st)

    def indicator(self, st: State) -> np.ndarray:
        """Reciprocal condition number of the group's Jacobian block at each position."""
        J = self.jacobian(st)
        good = np.all(np.isfinite(J), axis=(1, 2))
        out = np.zeros(st.n)
        if np.any(good):
            sv = np.linalg.svd(J[good], compute_uv=False)
            with np.errstate(divide="ignore", invalid="ignore"):
                out[good] = np.where(sv[:, 0] > 0, sv[:, -1] / sv[:, 0], 0.0)
        return out


# -- revolute-only groups: the angles as the only unknowns ------------------------------


def _near_angles(q: np.ndarray, q_pred: np.ndarray) -> np.ndarray:
    """``q`` with each link's angle moved by whole turns to the one nearest its predicted
    value: the equations are periodic in the angles, and a Newton step from a singular
    guess (a limit position a sweep starts from) can land whole turns away from a pose
    next to the prediction; the pose is the same, the continuation is not broken."""
    th, th_p = q[2::3], q_pred[2::3]
    d = th - th_p
    if not (np.abs(d) > np.pi).any():  # (the method: np.any's dispatch costs ~2 us a step)
        return q
    q = q.copy()
    q[2::3] = th_p + (d + np.pi) % (2 * np.pi) - np.pi
    return q
