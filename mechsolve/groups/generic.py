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

from ..constraints import AngleDriverConstraint, RevoluteConstraint
from ..errors import SolverError
from ..solvers.newton import SolveStats, newton_lean, solve
from ..state import State
from .base import Drive, Group

MAX_JUMP = 0.05  # largest accepted Newton correction: 5 % of the size, or 0.05 rad
MAX_DEPTH = 10  # at most 2**10 substeps per interval
BATCH_MIN = 64  # sweeps of at least this many positions are refined in one batch
COARSE = 32  # positions of the coarse continuation that predicts a batched sweep


class NewtonGroup(Group):
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
        self.max_iterations = max_iterations
        try:  # revolute groups: the links' angles are the only unknowns of the sweep
            self.red: _Angles | None = _Angles(bodies, constraints) if self.m == self.n else None
        except ValueError:
            self.red = None
        self._inv_cache: tuple | None = None
        self._bound: tuple[float, float, float] | None = None
        self._jump_w: tuple[float, np.ndarray] | None = None
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
        The scipy fallback of :func:`~mechsolve.solvers.newton.solve` applies to both.
        ``K``: the solved bodies' terms at this position (:meth:`_Angles.known`), when
        known already; ``st1`` (a one-position state, updated) may then be None."""
        red = self.red
        if red is None:
            return self.solve_at(st1, u1, q0)
        if K is None:
            K = red.known(st1)
        Kr, thp = red.reduce(red.with_driver(K[0], u1))
        sub = red.sub
        th0 = np.asarray(q0, float)[2::3][red.free]
        if sub.nb == 0:  # every angle fixed by a driver: nothing to iterate
            thf, stats = th0, SolveStats(True, "newton", 0, 0, 0, 0.0)
        else:
            Kr0 = Kr[0]
            M1, M2, M3, MT = sub.M1, sub.M2, sub.M3 if sub.nd else 0.0, sub.MT

            def fun_jac(th):
                C, S = np.cos(th), np.sin(th)
                return Kr0 + np.concatenate([C, S, th]) @ MT, M2 * C - M1 * S + M3

            if sub.nb <= 3:
                thf, stats = sub.newton_floats(Kr0, th0, self.atol, self.max_iterations)
            else:
                thf, stats = newton_lean(fun_jac, th0, self.atol, self.max_iterations)
            if not stats.converged:  # the full Newton with its scipy fallback

                def fun(th):
                    return fun_jac(th)[0]

                def jac(th):
                    return fun_jac(th)[1]

                thf, stats = solve(fun, jac, th0, self.atol, self.max_iterations)
        th = red.join(thf[None], thp)
        q = np.empty(self.n)
        q[2::3] = th[0]
        q[0::3], q[1::3] = red.poses_one(th[0], K[1][0], K[2][0])
        if st1 is not None:
            self.set_q(st1, 0, q)
        return q, stats

    def _put_angles(self, st: State, th: np.ndarray, Px: np.ndarray, Py: np.ndarray) -> None:
        """Place the group's links at all positions of ``st`` from their angles (N, n)."""
        C, S = np.cos(th), np.sin(th)
        x, y = self.red.poses(C, S, Px, Py)
        for b, k in self.col.items():
            st.x[b], st.y[b], st.th[b] = x[:, k], y[:, k], th[:, k]
            st.c[b], st.s[b] = C[:, k], S[:, k]

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

    def sweep(
        self,
        st: State,
        drive: Drive,
        q_start: np.ndarray,
        ok_in: np.ndarray,
        prefix=None,
        restart=None,
    ):
        """Solve positions 0..N-1: batched when possible (:meth:`sweep_batched`), else by
        continuation (:meth:`sweep_sequential`). Returns ``ok``, ``iterations``, ``methods``
        (the text of each position, or one text when every position has it: an array of
        text costs ~0.1 ms to build and to compare on a sweep of thousands)."""
        if self.red is not None and self.red.sub.nb == 0:
            return self._sweep_fixed(st, drive, ok_in)
        if self.batched and st.n >= BATCH_MIN and self.m == self.n and ok_in.all():
            out = self.sweep_batched(st, drive, q_start, prefix)
            if out is not None:
                return out
        return self.sweep_sequential(st, drive, q_start, ok_in, prefix, restart)

    def _sweep_fixed(self, st: State, drive: Drive, ok_in: np.ndarray):
        """A group whose every angle a driver fixes alone (a driven crank): its poses
        follow from the driver values directly, at every position."""
        red = self.red
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

    def sweep_batched(self, st: State, drive: Drive, q_start: np.ndarray, prefix=None):
        """Predict every position from a coarse continuation, then refine all positions
        at once by batched Newton-Raphson.

        1. every k-th position (about :data:`COARSE` of them) is solved by continuation
           (:meth:`sweep_sequential`, with its jump checks and substeps);
        2. the group's rates dq/du there (a linear solve) give a cubic Hermite
           prediction of every position in between;
        3. Newton-Raphson iterates on all positions together (one batched linear solve per
           iteration); each position must converge and stay within :data:`MAX_JUMP` of
           its prediction.

        Returns None when any of this fails, so that the caller marches sequentially.
        """
        n = st.n
        k = max(1, n // COARSE)
        coarse = np.unique(np.r_[np.arange(0, n, k), n - 1])
        sub = st.take(coarse)
        dsub = drive.take(coarse)
        # the coarse pass counts its own positions; prefix() wants the sweep's sample
        sub_prefix = None if prefix is None else (lambda us, j: prefix(us, int(coarse[j])))
        if self.red is not None and self.red.sub.nb <= 3:
            itc = self._coarse_floats(sub, dsub, q_start, sub_prefix)
            if itc is None:
                return None
        else:
            okc, itc, _ = self.sweep_sequential(
                sub, dsub, q_start, np.ones(len(coarse), bool), prefix=sub_prefix
            )
            if not okc.all():
                return None
        self.velocity(sub, Drive(dsub.u, np.ones(len(coarse)), np.zeros(len(coarse))))
        qc = self._q_rows(sub)
        dqc = self._q_rows(sub, rates=True)
        if not np.all(np.isfinite(dqc)):
            return None
        # cubic Hermite between coarse positions, in the driver coordinate: each
        # segment's polynomial in t = (u - u0) / (u1 - u0), by Horner; the positions of a
        # segment are consecutive (the last position belongs to the last segment), so its
        # coefficients are repeated rather than gathered (a fancy index costs 6x more)
        u = drive.u
        counts = np.diff(coarse)
        counts[-1] += 1
        uc = u[coarse]
        hc = (uc[1:] - uc[:-1])[:, None]
        q0, q1 = qc[:-1], qc[1:]
        t = ((u - np.repeat(uc[:-1], counts)) / np.repeat(hc[:, 0], counts))[:, None]
        if self.predictor == "linear":  # first order: the chord between coarse positions
            pred = np.repeat(q1 - q0, counts, axis=0)
            pred *= t
            pred += np.repeat(q0, counts, axis=0)
        else:  # q0 + t (m0 + t (3 (q1 - q0) - 2 m0 - m1 + t (2 (q0 - q1) + m0 + m1)))
            m0, m1 = hc * dqc[:-1], hc * dqc[1:]
            dq = q1 - q0
            c2 = 3 * dq - 2 * m0 - m1
            c3 = m0 + m1 - 2 * dq
            pred = np.repeat(c3, counts, axis=0)
            for c in (c2, m0, q0):
                pred *= t
                pred += np.repeat(c, counts, axis=0)
        if self.red is not None:
            iters = self._refine_angles(st, u, pred, coarse, qc)
            if iters is None:
                return None
            q = self._q_rows(st)
        else:
            q, iters = self._refine_bodies(st, u, pred, coarse, qc)
            if q is None:
                return None
        d = np.abs(q - pred)
        d[:, 0::3] /= self.scale
        d[:, 1::3] /= self.scale
        if np.max(d) > MAX_JUMP or not np.all(np.isfinite(q)):
            return None
        if self.red is None:
            self._set_q_rows_into(st, q)
        iters[coarse] = itc
        return np.ones(n, bool), iters, "newton (batched)"

    def _coarse_floats(self, st: State, drive: Drive, q_start: np.ndarray, prefix=None):
        """:meth:`sweep_sequential` over all positions of ``st`` for a small revolute
        group, its plain steps in floats: a step that converges by Newton from the
        extrapolated prediction and moves less than :data:`MAX_JUMP` from it is taken as
        the general code would take it; any other goes through :meth:`_advance` (its
        substeps, scipy, its error) with the same history. Returns the iterations per
        position (the poses written into ``st``), or None when a position fails."""
        red = self.red
        sub = red.sub
        Kall = red.known(st)
        u = drive.u
        Kr, thp = red.reduce(red.with_driver(Kall[0], u))
        Kr, thp = Kr.tolist(), thp.tolist()
        Px, Py = Kall[1].tolist(), Kall[2].tolist()
        free, fixed, nb = red.free.tolist(), red.fixed.tolist(), red.nb
        inv_scale = 1.0 / self.scale
        hu: list[float] = []
        hq: list[list[float]] = []
        q_pred = [float(v) for v in q_start]
        iters = np.zeros(st.n, int)
        th = [0.0] * nb
        jw = [1.0 if j % 3 == 2 else inv_scale for j in range(self.n)]  # the jump's weights
        out: list[list[float]] = []
        atol, its = self.atol, self.max_iterations
        for i, ui in enumerate(u.tolist()):
            if len(hq) == 1:  # the first step: along the tangent, not from the start's pose
                q_pred = self._tangent_floats(hq[0], Kr[i], thp[i], Px[i], Py[i])
            elif hq:
                q_pred = _extrapolate_floats(hu, hq, ui)
            thf, plain, it, _, _ = sub.newton_list(
                Kr[i], [q_pred[3 * k + 2] for k in free], atol, its
            )
            if plain:
                for j, k in enumerate(free):
                    th[k] = thf[j]
                for j, k in enumerate(fixed):
                    th[k] = thp[i][j]
                xs, ys = red.poses_one(th, Px[i], Py[i])
                q = [v for k in range(nb) for v in (xs[k], ys[k], th[k])]
                if hq:
                    jump = max(abs(a - b) * w for a, b, w in zip(q, q_pred, jw))
                    plain = jump <= MAX_JUMP
            if not plain:  # the general step, as sweep_sequential takes it
                Ki = [k[i : i + 1] for k in Kall]
                if hq:
                    hqa = [np.array(v) for v in hq]
                    qa, stats, good = self._advance(None, ui, hu, hqa, i - 1, prefix, Ki)
                else:
                    qa, stats = self._solve_one(None, u[i : i + 1], q_start, Ki)
                    good = stats.converged
                if not good:
                    return None
                q = qa.tolist()
                it = stats.iterations
            out.append(q)
            iters[i] = it
            if len(hq) == 3:
                hu, hq = [hu[1], hu[2], ui], [hq[1], hq[2], q]
            else:
                hu, hq = hu + [ui], hq + [q]
        self._set_q_rows(st, np.array(out))
        return iters

    def _tangent_floats(self, q0: list, Kr: list, thp: list, Px: list, Py: list) -> list:
        """A prediction of the next position from the pose ``q0`` (body coordinates) of
        the previous one: the first Newton iterate from ``q0`` with the next position's
        constant part ``Kr`` (the tangent step, ``-F_theta^-1 dF``, with the driver's
        increment of the solved bodies' terms), the frames placed from those angles.
        ``q0`` itself when that step cannot be taken (an exactly singular Jacobian)."""
        red = self.red
        free, fixed = red.free.tolist(), red.fixed.tolist()
        th0 = [q0[3 * k + 2] for k in free]
        thf = red.sub.newton_list(Kr, th0, self.atol, 1)[0]
        th = [q0[3 * k + 2] for k in range(red.nb)]
        for j, k in enumerate(free):
            th[k] = thf[j]
        for j, k in enumerate(fixed):
            th[k] = thp[j]
        if not all(math.isfinite(v) for v in th):
            return list(q0)
        xs, ys = red.poses_one(th, Px, Py)
        return [v for k in range(red.nb) for v in (xs[k], ys[k], th[k])]

    def _refine_angles(self, st: State, u, pred, coarse, qc):
        """Batched Newton in the links' angles from the prediction; the poses are written
        into ``st``. Returns the iterations per position, or None."""
        red = self.red
        sub = red.sub
        n = st.n
        K, Px, Py = red.known(st)
        Kr, thp = red.reduce(red.with_driver(K, u))
        th = pred[:, 2::3][:, red.free]
        th[coarse] = qc[:, 2::3][:, red.free]
        iters = np.zeros(n, int)
        todo = np.ones(n, bool)
        todo[coarse] = False
        if sub.nb == 0:
            todo[:] = False
        if sub.nb == 2:
            if not self._refine2(th, Kr, iters, todo):
                return None
            self._put_angles(st, red.join(th, thp), Px, Py)
            return iters
        last = np.full(n, np.inf)
        J = np.empty((n, sub.nb, sub.nb))
        tol = 1e-3 * self.atol
        for _ in range(self.max_iterations):
            count = np.count_nonzero(todo)
            if count == 0:
                break
            if 2 * count >= n:  # most positions still iterate: whole arrays, masked
                idx, t, Kk, lastk = None, th, Kr, last
            else:
                idx = np.flatnonzero(todo)
                t, Kk, lastk = th[idx], Kr[idx], last[idx]
            C, S = np.cos(t), np.sin(t)
            f = sub.residual(t, C, S, Kk)
            r = _rowmax_abs(f)
            if sub.nb <= 2:  # by the adjugate; a singular one gives NaN and fails below
                dq = sub.step_small(C, S, f)
            else:
                Jk = sub.jacobian(C, S, out=J[: t.shape[0]])
                try:
                    dq = np.linalg.solve(Jk, -f[..., None])[..., 0]
                except np.linalg.LinAlgError:
                    return None
            step = _rowmax_abs(dq)
            # as below: converged when the residual is small and the step tiny or no
            # longer shrinking (the rounding level); that last step is not taken
            done = (r <= self.atol) & ((step <= tol) | (step >= lastk))
            take = ~done | (step <= tol)
            if idx is None:
                take &= todo
                th += np.where(take[:, None], dq, 0.0)
                iters += todo
                last = np.where(todo, step, last)
                todo &= ~done
            else:
                th[idx[take]] += dq[take]
                iters[idx] += 1
                last[idx] = step
                todo[idx[done]] = False
        if todo.any() or not np.all(np.isfinite(th)):
            return None
        self._put_angles(st, red.join(th, thp), Px, Py)
        return iters

    def _refine2(self, th: np.ndarray, Kr: np.ndarray, iters: np.ndarray, todo: np.ndarray):
        """:meth:`_refine_angles`'s iterations for two angles (the four-bar's loop), on
        each angle's own 1-D array: the same residual, step (by the adjugate), tests and
        updates, without the (N, 2) products and reductions, which cost more than the
        arithmetic. Updates ``th`` (N, 2), ``iters`` and ``todo`` in place; False when a
        position does not converge."""
        n = th.shape[0]
        ((a1, a2, a3), (b1, b2, b3)), ((c1, c2, c3), (d1, d2, d3)) = self.red.sub._rows
        nd = self.red.sub.nd
        x0, x1 = th[:, 0].copy(), th[:, 1].copy()
        K0, K1 = Kr[:, 0].copy(), Kr[:, 1].copy()
        last = np.full(n, np.inf)
        tol = 1e-3 * self.atol
        cos, sin, absolute, maximum = np.cos, np.sin, np.abs, np.maximum
        for _ in range(self.max_iterations):
            count = np.count_nonzero(todo)
            if count == 0:
                break
            if 2 * count >= n:  # most positions still iterate: whole arrays, masked
                idx, t0, t1, k0, k1, lastk = None, x0, x1, K0, K1, last
            else:
                idx = np.flatnonzero(todo)
                t0, t1, k0, k1, lastk = x0[idx], x1[idx], K0[idx], K1[idx], last[idx]
            C0, S0, C1, S1 = cos(t0), sin(t0), cos(t1), sin(t1)
            f0 = k0 + a1 * C0
            f0 += a2 * S0
            f0 += b1 * C1
            f0 += b2 * S1
            f1 = k1 + c1 * C0
            f1 += c2 * S0
            f1 += d1 * C1
            f1 += d2 * S1
            ja = a2 * C0
            ja -= a1 * S0
            jb = b2 * C1
            jb -= b1 * S1
            jc = c2 * C0
            jc -= c1 * S0
            jd = d2 * C1
            jd -= d1 * S1
            if nd:
                f0 += a3 * t0
                f0 += b3 * t1
                f1 += c3 * t0
                f1 += d3 * t1
                ja += a3
                jb += b3
                jc += c3
                jd += d3
            r = maximum(absolute(f0), absolute(f1))
            with np.errstate(divide="ignore", invalid="ignore"):
                det = ja * jd
                det -= jb * jc
                dq0 = jb * f1
                dq0 -= jd * f0
                dq0 /= det
                dq1 = jc * f0
                dq1 -= ja * f1
                dq1 /= det
            step = maximum(absolute(dq0), absolute(dq1))
            step[det == 0] = np.nan  # exactly singular: not converged, fails below
            # as _refine_angles: converged when the residual is small and the step tiny
            # or no longer shrinking (the rounding level); that last step is not taken
            small = step <= tol
            done = (r <= self.atol) & (small | (step >= lastk))
            take = ~done | small
            if idx is None:
                take &= todo
                x0 += np.where(take, dq0, 0.0)
                x1 += np.where(take, dq1, 0.0)
                iters += todo
                last = np.where(todo, step, last)
                todo &= ~done
            else:
                it = idx[take]
                x0[it] += dq0[take]
                x1[it] += dq1[take]
                iters[idx] += 1
                last[idx] = step
                todo[idx[done]] = False
        th[:, 0], th[:, 1] = x0, x1
        return not todo.any() and bool(np.isfinite(x0).all() and np.isfinite(x1).all())

    def _refine_bodies(self, st: State, u, pred, coarse, qc):
        """Batched Newton in body coordinates from the prediction. Returns ``(q,
        iterations)``, or ``(None, None)``."""
        n = st.n
        q = pred.copy()
        iters = np.zeros(n, int)
        todo = np.ones(n, bool)
        todo[coarse] = False
        q[coarse] = qc
        last = np.full(n, np.inf)
        for _ in range(self.max_iterations):
            idx = np.flatnonzero(todo)
            if idx.size == 0:
                break
            s1 = st.take(idx)
            self._set_q_rows(s1, q[idx])
            f = self.residual(s1, u[idx]).T  # (k, m)
            r = np.max(np.abs(f), axis=1)
            J = self.jacobian(s1)
            try:
                dq = np.linalg.solve(J, -f[..., None])[..., 0]
            except np.linalg.LinAlgError:
                return None, None
            step = np.max(np.abs(dq), axis=1)
            # converged: the residual was already small and the step tiny, or no longer
            # shrinking (the rounding level); the last step is then not taken
            done = (r <= self.atol) & ((step <= 1e-3 * self.atol) | (step >= last[idx]))
            take = ~done | (step <= 1e-3 * self.atol)
            q[idx[take]] += dq[take]
            iters[idx] += 1
            last[idx] = step
            todo[idx[done]] = False
        if todo.any():
            return None, None
        return q, iters

    def _set_q_rows(self, st1: State, q: np.ndarray) -> None:
        for b, k in self.col.items():
            st1.x[b] = q[:, 3 * k]
            st1.y[b] = q[:, 3 * k + 1]
            st1.set_angle(b, q[:, 3 * k + 2])

    def _set_q_rows_into(self, st: State, q: np.ndarray) -> None:
        self._set_q_rows(st, q)

    def sweep_sequential(
        self,
        st: State,
        drive: Drive,
        q_start: np.ndarray,
        ok_in: np.ndarray,
        prefix=None,
        restart=None,
    ):
        """Solve positions 0..N-1 in order by continuation from ``q_start`` at position 0.

        Each step predicts from the previous solutions (Lagrange extrapolation) and corrects
        by Newton-Raphson (scipy when Newton fails). A step is accepted when the correction
        is small (:data:`MAX_JUMP`); otherwise the interval is marched in 2, 4, 8, ...
        substeps (``prefix(u, k)`` solves the groups before this one at substep values), so
        that a coarse step cannot jump to another branch. After a gap (a dead zone) the
        sweep resumes from ``restart(i)`` when it gives a guess (the closed-form groups on
        the user's branches; ``False`` when those cannot close there: the position is then
        unassemblable), else from the last solution. Returns ``ok``, ``iterations``
        and ``methods`` over the positions.

        Raises
        ------
        SolverError
            When even the finest substeps jump: the branch cannot be followed.
        """
        n = st.n
        ok = np.zeros(n, bool)
        iters = np.zeros(n, int)
        methods = np.array(["" for _ in range(n)], dtype=object)
        hu: list[float] = []
        hq: list[np.ndarray] = []
        last_good = np.asarray(q_start, float)
        # a revolute group needs only the solved bodies' terms at each position
        Kall = self.red.known(st) if self.red is not None else None
        for i in range(n):
            if not ok_in[i]:
                self._nan(st, i)
                hu, hq = [], []
                continue
            Ki = None if Kall is None else [k[i : i + 1] for k in Kall]
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
                q, stats, good = self._advance(st1, ui, hu, hq, i - 1, prefix, Ki)
            iters[i] = stats.iterations
            methods[i] = stats.method
            if good:
                ok[i] = True
                self.set_q(st, i, q)
                last_good = q
                hu, hq = (hu + [ui])[-3:], (hq + [q])[-3:]
            else:
                self._nan(st, i)
                hu, hq = [], []
        return ok, iters, methods

    def _advance(self, st1: State | None, ui: float, hu, hq, k: int, prefix, K1=None):
        """One continuation step to ``ui``; substeps when the full step jumps. ``K1``:
        the solved bodies' terms at ``ui`` for a revolute group (``st1`` is then None)."""
        q_pred = _extrapolate(hu, hq, ui)
        q, stats = self._solve_one(st1, np.array([ui]), q_pred, K1)
        if stats.converged and self._jump(q, q_pred) <= MAX_JUMP:
            return q, stats, True
        converged_somewhere = stats.converged
        u0 = hu[-1]
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
                total += sj.iterations
                converged_somewhere |= sj.converged
                if not (sj.converged and self._jump(qj, qp) <= MAX_JUMP):
                    ok_all = False
                    break
                lu, lq = (lu + [uj])[-3:], (lq + [qj])[-3:]
            if ok_all:
                sj.iterations = total
                return qj, sj, True
            if not sj.converged and j == 0 and depth >= 4:
                break  # no solution even right next to the last one: a dead zone starts here
        if converged_somewhere and stats.converged:
            raise SolverError(
                f"cannot follow the branch of the {self.label} up to driver value {ui:.6g}: "
                f"the solution jumps even in {2**MAX_DEPTH} substeps (a singular position?); "
                "use a smaller step"
            )
        return q, stats, False

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

    # -- derivatives --------------------------------------------------------------------
    def _rhs(self, st: State, drive: Drive, order: int) -> np.ndarray:
        rows = []
        for c in self.constraints:
            if order == 1:
                r = c.nu(st, drive.ud)
                vel = (st.vx, st.vy, st.w)
            else:
                r = c.gamma(st, drive.udd)
                vel = (st.ax, st.ay, st.al)
            r = np.array(r, dtype=float)
            for body, blk in c.jacobian(st).items():
                if body in self.col:
                    continue
                r -= blk[:, 0] * vel[0][body] + blk[:, 1] * vel[1][body] + blk[:, 2] * vel[2][body]
            rows.append(r)
        return np.concatenate(rows, axis=0).T  # (N, m)

    def _solve_batch(self, st: State, rhs: np.ndarray) -> np.ndarray:
        J = self.jacobian(st)
        out = np.full((st.n, self.n), np.nan)
        good = np.all(np.isfinite(J), axis=(1, 2)) & np.all(np.isfinite(rhs), axis=1)
        if np.any(good):
            if self.m == self.n:
                try:
                    out[good] = np.linalg.solve(J[good], rhs[good][..., None])[..., 0]
                except np.linalg.LinAlgError:
                    for i in np.flatnonzero(good):
                        out[i] = np.linalg.lstsq(J[i], rhs[i], rcond=None)[0]
            else:
                for i in np.flatnonzero(good):
                    out[i] = np.linalg.lstsq(J[i], rhs[i], rcond=None)[0]
        return out

    # revolute groups: the rates of the links' angles, the frames' from the tree
    def _angle_inverse(self, st: State) -> np.ndarray:
        """The inverse of ``F_theta`` at every position of ``st`` (NaN where it is not
        finite or exactly singular), computed once for the velocities, accelerations and
        the singularity measure of the same poses."""
        red = self.red
        if red.sub.nb == 0:  # every angle fixed by a driver: a constant signed permutation
            return np.broadcast_to(red.inv_fixed, (st.n, red.nb, red.nb))
        th = st.th[self.bodies].T
        c = self._inv_cache
        if (
            c is not None
            and c[0] == st.token
            and c[1].shape == th.shape
            and (np.array_equal(c[1], th) or np.array_equal(c[1], th, equal_nan=True))
        ):  # the exact test first: the one with NaN costs ~15 us on thousands
            return c[2]
        inv = red.inverse(st.c[self.bodies].T, st.s[self.bodies].T)
        self._inv_cache = (st.token, th, inv)
        return inv

    def _angle_solve(self, st: State, rhs: np.ndarray) -> np.ndarray:
        red = self.red
        if red.sub.nb == 0:  # every angle fixed by a driver: theta_k' = sign (u' - K_d')
            out = np.empty((rhs.shape[0], red.nb))
            out[:, red.fixed] = rhs[:, red.frows] * red.fsign
            return out
        inv = self._angle_inverse(st)
        out = inv[:, :, 0] * rhs[:, None, 0]  # inv @ rhs, elementwise: small matrices
        for j in range(1, rhs.shape[1]):
            out += inv[:, :, j] * rhs[:, None, j]
        # exactly singular positions: least squares, as a singular body block would get
        sing = np.isnan(inv[:, 0, 0])
        for i in np.flatnonzero(sing & np.all(np.isfinite(rhs), axis=1)) if sing.any() else ():
            t = st.th[self.bodies, i][None]
            J = self.red.jacobian(np.cos(t), np.sin(t))[0]
            if np.all(np.isfinite(J)):
                out[i] = np.linalg.lstsq(J, rhs[i], rcond=None)[0]
        return out

    def _angle_rates(self, st: State, drive: Drive, order: int) -> None:
        red = self.red
        nb = red.nb
        K, Px, Py = red.known(st, order)  # fresh arrays: the right-hand side in place
        if red.nd:  # the driver values' rates off the drivers' equations
            K[:, 2 * red.ne :] -= (drive.ud if order == 1 else drive.udd)[:, None]
        rhs = np.negative(K, out=K)
        C, S = st.c[self.bodies].T, st.s[self.bodies].T
        # the frames' rates: r_b = P_b + sum_k A(theta_k) W[b, k] differentiated, with
        # A' = w A(theta + 90 deg) and A'' = al A(theta + 90 deg) - w^2 A: both are
        # P @ Wr[:nb] + Q @ Wr[nb:], P = S w, Q = C w (velocities) or P = S al + C w^2,
        # Q = C al - S w^2
        if order == 1:
            w = self._angle_solve(st, rhs)
            P, Q = S * w, C * w
            out = (st.vx, st.vy, st.w)
        else:
            wd = st.w[self.bodies].T
            w2 = wd * wd
            if red.ne:  # the closing joints' centripetal terms (none for drivers)
                rhs += red.accel_terms(C, S, w2)
            w = self._angle_solve(st, rhs)
            P, Q = S * w, C * w
            P += C * w2
            Q -= S * w2
            out = (st.ax, st.ay, st.al)
        v = P @ red.Wr[:nb]
        v += Q @ red.Wr[nb:]
        vx, vy = Px + v[:, :nb], Py + v[:, nb:]
        for b, k in self.col.items():
            out[0][b], out[1][b], out[2][b] = vx[:, k], vy[:, k], w[:, k]

    def rcond_bound(self, st: State) -> np.ndarray | None:
        """A lower bound of :func:`mechsolve.conditioning.rcond` of the group's block of
        Phi_q at every position, from the inverse of ``F_theta`` (revolute groups; None
        for others).

        With the group's block ordered as ``[[T_P, T_th], [L_P, L_th]]`` (the tree's
        joints and the others; the frames' positions and the angles), ``T_P`` is constant
        and unimodular and ``F_theta`` is the Schur complement ``S = L_th - L_P T_P^-1
        T_th``, so the block's inverse is ``[[T_P^-1 + M S^-1 K, -M S^-1], [-S^-1 K,
        S^-1]]`` with ``M = T_P^-1 T_th``, ``K = L_P T_P^-1``. In Frobenius norms,
        ``|J^-1| <= |T_P^-1| + (1 + |M|)(1 + |K|) |S^-1|``, where ``|T_P^-1|``, ``|K|`` and
        the bound ``|T_P^-1| |T_th|`` of ``|M|`` do not depend on the angles (the entries
        are 0, +-1 or rotated constant vectors). The equilibration's column norms are
        constant too and its row norms bounded, so that with ``A = D_r^-1 J D_c^-1``,
        ``rcond(A) >= 1 / (|A|_F |A^-1|_F) >= 1 / (sqrt(m) max D_c max D_r |J^-1|)``.
        The bound is within a constant factor of the exact value, so it separates the
        near-singular positions from the others at the cost of the inverse the
        velocities already use.
        """
        if self.red is None:
            return None
        if self._bound is None:
            self._bound = self._bound_constants(st)
        c, a0, a1 = self._bound
        red = self.red
        if red.sub.nb == 0:  # all angles fixed: F_theta^-1 is constant
            return np.full(st.n, 1.0 / (c * (a0 + a1 * float(np.linalg.norm(red.inv_fixed)))))
        inv = self._angle_inverse(st)
        nf = np.sqrt(np.einsum("nij,nij->n", inv, inv))
        return 1.0 / (c * (a0 + a1 * nf))

    def _bound_constants(self, st: State) -> tuple[float, float, float]:
        st1 = st.take([0])
        for b, k in self.col.items():  # any poses: the constants do not depend on them
            st1.x[b, 0] = st1.y[b, 0] = 0.0
            st1.set_angle(b, 0.3 + 0.7 * k, 0)
        J = self.jacobian(st1)[0]
        red = self.red
        rows, r = {}, 0
        for c in self.constraints:
            rows[id(c)] = list(range(r, r + c.m))
            r += c.m
        tree = [i for c in red.tree for i in rows[id(c)]]
        loop = [i for i in range(self.m) if i not in set(tree)]
        P = [i for i in range(self.n) if i % 3 != 2]
        T = list(range(2, self.n, 3))
        tpi = np.linalg.inv(J[np.ix_(tree, P)])
        a0 = float(np.linalg.norm(tpi))
        m_norm = a0 * float(np.linalg.norm(J[np.ix_(tree, T)]))
        k_norm = float(np.linalg.norm(J[np.ix_(loop, P)] @ tpi))
        cs = np.linalg.norm(J, axis=0)
        cs[cs == 0] = 1.0
        ub = np.abs(J)
        for c in self.constraints:  # a joint's two rows: (-r_y, r_x) has the norm |s|
            if type(c) is RevoluteConstraint:
                i = rows[id(c)][0]
                ub[i : i + 2, T] = np.hypot(J[i, T], J[i + 1, T])
        rs = float(np.max(np.sqrt(np.sum((ub / cs) ** 2, axis=1))))
        scale = math.sqrt(self.m) * float(np.max(cs)) * rs
        return scale, a0, (1.0 + m_norm) * (1.0 + k_norm)

    def velocity(self, st: State, drive: Drive) -> None:
        if self.red is not None:
            self._angle_rates(st, drive, 1)
            return
        qd = self._solve_batch(st, self._rhs(st, drive, 1))
        for b, k in self.col.items():
            st.vx[b], st.vy[b], st.w[b] = qd[:, 3 * k], qd[:, 3 * k + 1], qd[:, 3 * k + 2]

    def acceleration(self, st: State, drive: Drive) -> None:
        if self.red is not None:
            self._angle_rates(st, drive, 2)
            return
        qdd = self._solve_batch(st, self._rhs(st, drive, 2))
        for b, k in self.col.items():
            st.ax[b], st.ay[b], st.al[b] = qdd[:, 3 * k], qdd[:, 3 * k + 1], qdd[:, 3 * k + 2]


# -- revolute-only groups: the angles as the only unknowns ------------------------------


class _Eqs:
    """Equations ``F = K + [M1 M2 M3] (cos theta, sin theta, theta)`` in angles."""

    def __init__(self, M: np.ndarray) -> None:
        nb = M.shape[0]
        self.nb = nb
        self.MT = M.T.copy()
        self.M1, self.M2 = M[:, :nb].copy(), M[:, nb : 2 * nb].copy()
        self.M3 = M[:, 2 * nb :].copy()
        self.nd = bool(np.any(self.M3))
        # rows of (M1, M2, M3) as Python floats, for one small position at a time
        self._rows = [
            tuple(zip(self.M1[e].tolist(), self.M2[e].tolist(), self.M3[e].tolist()))
            for e in range(nb)
        ]

    def newton_floats(
        self, K, th0, atol: float, max_iterations: int
    ) -> tuple[np.ndarray, SolveStats]:
        """:func:`~mechsolve.solvers.newton.newton_lean` on ``F = 0`` at one position,
        with ``K`` (n,) the constant part, in Python floats (up to 3 angles: a stacked
        NumPy call per operation costs more than the arithmetic there). Same
        convergence test; no scipy fallback (the caller's)."""
        x, ok, it, r, nfev = self.newton_list(K, th0, atol, max_iterations)
        return np.array(x), SolveStats(ok, "newton", it, nfev, nfev, r)

    def newton_list(self, K, th0, atol: float, max_iterations: int):
        """:meth:`newton_floats` as ``(angles (list), converged, iterations, residual,
        evaluations)``:
        the coarse continuation's form, without an array and a record per position."""
        nb, rows = self.nb, self._rows
        x = [float(v) for v in th0]
        K = [float(v) for v in K]
        xtol = 1e-3 * atol
        last = r = r_prev = math.inf
        cos, sin = math.cos, math.sin
        if nb == 2:  # unrolled: the four-bar's loop, the commonest group
            ((a1, a2, a3), (b1, b2, b3)), ((c1, c2, c3), (d1, d2, d3)) = rows
            k0, k1 = K
            x0, x1 = x
            for it in range(max_iterations + 1):
                C0, C1, S0, S1 = cos(x0), cos(x1), sin(x0), sin(x1)
                f0 = k0 + a1 * C0 + a2 * S0 + a3 * x0 + b1 * C1 + b2 * S1 + b3 * x1
                f1 = k1 + c1 * C0 + c2 * S0 + c3 * x0 + d1 * C1 + d2 * S1 + d3 * x1
                r = max(abs(f0), abs(f1))
                if not r <= 1e300 or (it > 3 and r > 2 * r_prev):  # not finite, diverging
                    break
                r_prev = r
                if r <= atol and (last <= xtol or r == 0.0):
                    return [x0, x1], True, it, r, it + 1
                if it == max_iterations:
                    break
                ja, jb = a2 * C0 - a1 * S0 + a3, b2 * C1 - b1 * S1 + b3
                jc, jd = c2 * C0 - c1 * S0 + c3, d2 * C1 - d1 * S1 + d3
                det = ja * jd - jb * jc  # as _solve_small
                if det == 0:
                    break
                dx0, dx1 = -(jd * f0 - jb * f1) / det, -(ja * f1 - jc * f0) / det
                step = max(abs(dx0), abs(dx1))
                if not step <= 1e300:
                    break
                if r <= atol and step >= last:  # converged already: rounding level
                    return [x0, x1], True, it, r, it + 1
                x0, x1 = x0 + dx0, x1 + dx1
                last = step
            return [x0, x1], r <= atol, max_iterations, r, max_iterations
        for it in range(max_iterations + 1):
            c = [cos(v) for v in x]
            s = [sin(v) for v in x]
            f = []
            J = []
            for e in range(nb):
                fe = K[e]
                Je = []
                for k, (m1, m2, m3) in enumerate(rows[e]):
                    fe += m1 * c[k] + m2 * s[k] + m3 * x[k]
                    Je.append(m2 * c[k] - m1 * s[k] + m3)
                f.append(fe)
                J.append(Je)
            r = max(abs(v) for v in f)
            if not r <= 1e300 or (it > 3 and r > 2 * r_prev):  # not finite, or diverging
                break
            r_prev = r
            if r <= atol and (last <= xtol or r == 0.0):
                return x, True, it, r, it + 1
            if it == max_iterations:
                break
            dx = _solve_small(J, f)
            if dx is None:
                break
            step = max(abs(v) for v in dx)
            if not step <= 1e300:
                break
            if r <= atol and step >= last:  # converged already: rounding level
                return x, True, it, r, it + 1
            x = [a + b for a, b in zip(x, dx)]
            last = step
        return x, r <= atol, max_iterations, r, max_iterations

    def step_small(self, C, S, f) -> np.ndarray:
        """The Newton step ``-F_theta^-1 F`` (N, n) for one or two angles, elementwise
        (NaN where ``F_theta`` is exactly singular)."""
        M1, M2, M3 = self.M1, self.M2, self.M3
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.nb == 1:
                return -f / (M2[0, 0] * C - M1[0, 0] * S + M3[0, 0])
            c0, c1, s0, s1 = C[:, 0], C[:, 1], S[:, 0], S[:, 1]
            a = M2[0, 0] * c0 - M1[0, 0] * s0 + M3[0, 0]
            b = M2[0, 1] * c1 - M1[0, 1] * s1 + M3[0, 1]
            c = M2[1, 0] * c0 - M1[1, 0] * s0 + M3[1, 0]
            d = M2[1, 1] * c1 - M1[1, 1] * s1 + M3[1, 1]
            det = a * d - b * c
            out = np.empty_like(f)
            out[:, 0] = (b * f[:, 1] - d * f[:, 0]) / det
            out[:, 1] = (c * f[:, 0] - a * f[:, 1]) / det
        out[det == 0] = np.nan
        return out

    def residual(self, th, C, S, Ku) -> np.ndarray:
        """``F`` (N, n) at angles ``th`` (with their cosines ``C`` and sines ``S``);
        ``Ku``: the constant part (:meth:`_Angles.known` with :meth:`_Angles.with_driver`)."""
        f = Ku + C @ self.M1.T  # three small products: concatenating costs more
        f += S @ self.M2.T
        if self.nd:
            f += th @ self.M3.T
        return f

    def inverse(self, C, S) -> np.ndarray:
        """``F_theta^-1`` (N, n, n) as :func:`_batch_inverse` gives it; up to two angles
        from the entries directly (a broadcast product over (N, n, n) costs more)."""
        if self.nb != 2:
            return _batch_inverse(self.jacobian(C, S))
        (a1, b1), (c1, d1) = self.M1.tolist()
        (a2, b2), (c2, d2) = self.M2.tolist()
        (a3, b3), (c3, d3) = self.M3.tolist()
        c0, c1_, s0, s1 = C[:, 0], C[:, 1], S[:, 0], S[:, 1]
        J = np.empty((C.shape[0], 2, 2))
        J[:, 0, 0] = a2 * c0 - a1 * s0 + a3
        J[:, 0, 1] = b2 * c1_ - b1 * s1 + b3
        J[:, 1, 0] = c2 * c0 - c1 * s0 + c3
        J[:, 1, 1] = d2 * c1_ - d1 * s1 + d3
        return _batch_inverse(J)

    def jacobian(self, C, S, out=None) -> np.ndarray:
        """``F_theta`` (N, n, n), into ``out`` when given."""
        J = np.empty((C.shape[0], self.nb, self.nb)) if out is None else out
        np.multiply(C[:, None, :], self.M2, out=J)
        J -= S[:, None, :] * self.M1
        if self.nd:
            J += self.M3
        return J


class _Angles(_Eqs):
    """A group of revolute joints (and angle drivers) written in its links' angles alone.

    A spanning tree of the group's joints, grown from the bodies solved before it (the
    ground among them), places every link's frame from its angles: a child ``c`` pinned
    to its parent ``p`` at local points ``s_p``, ``s_c`` has ``r_c = r_p + A_p s_p -
    A_c s_c``, so that ``r_b = P_b + sum_k A(theta_k) W[b, k]`` with ``P_b`` a point of a
    solved body (the root of its branch of the tree) and constant local vectors ``W``.
    The tree's joints then hold identically; the others (the loops' closing joints, two
    equations each, and the drivers, one each) are as many equations as angles::

        F_e = K_e + sum_k A(theta_k) V[e, k]          (a closing joint)
        F_d = K_d + sum_k D[d, k] theta_k - u          (a driver)

    ``K`` collects the points (angles) of solved bodies. The Jacobian ``F_theta`` is the
    Schur complement of the tree's (constant, unimodular) block in the group's block of
    Phi_q, so both are singular at the same positions; see :meth:`rcond_bound`.
    """

    def __init__(self, bodies, constraints) -> None:
        self.k = {b: i for i, b in enumerate(bodies)}
        nb = len(bodies)
        self.nb = nb
        W = np.zeros((nb, nb, 2))
        anchor: dict[int, tuple[int, np.ndarray]] = {}
        revs = [c for c in constraints if type(c) is RevoluteConstraint]
        drivers = [c for c in constraints if type(c) is AngleDriverConstraint]
        if len(revs) + len(drivers) != len(constraints):
            raise ValueError("not a revolute group")
        inside = set(bodies)
        tree: list[int] = []
        grown = True
        while grown:
            grown = False
            for j, c in enumerate(revs):
                if j in tree:
                    continue
                for child, s_c, par, s_p in ((c.b, c.sb, c.a, c.sa), (c.a, c.sa, c.b, c.sb)):
                    if child not in inside or child in anchor:
                        continue
                    if par in inside and par not in anchor:
                        continue
                    kc = self.k[child]
                    if par in inside:
                        anchor[child] = anchor[par]
                        W[kc] = W[self.k[par]]
                        W[kc, self.k[par]] += s_p
                    else:
                        anchor[child] = (par, np.asarray(s_p, float))
                    W[kc, kc] -= s_c
                    tree.append(j)
                    grown = True
                    break
        if len(anchor) != nb:
            raise ValueError("a link is not reached through revolute joints")
        loops = [c for j, c in enumerate(revs) if j not in tree]
        if 2 * len(loops) + len(drivers) != nb:
            raise ValueError("not square")
        self.tree = [revs[j] for j in tree]
        self.loops = loops
        self.drivers = drivers
        self.anchor = [anchor[b] for b in bodies]
        self._kplan: tuple | None = None  # see _known_plan()
        self.Wx, self.Wy = W[..., 0].copy(), W[..., 1].copy()  # (body, angle)
        self._wx, self._wy = self.Wx.tolist(), self.Wy.tolist()
        self._wterms = [
            [(k, a, b) for k, (a, b) in enumerate(zip(wx, wy)) if a or b]
            for wx, wy in zip(self._wx, self._wy)
        ]
        self.Wr = np.block([[-self.Wx.T, -self.Wy.T], [-self.Wy.T, self.Wx.T]])
        ne = len(loops)
        V = np.zeros((ne, nb, 2))
        self.kterms: list[list[tuple[float, int, np.ndarray]]] = []
        for e, c in enumerate(loops):
            terms = []
            for sign, body, s in ((1.0, c.a, c.sa), (-1.0, c.b, c.sb)):
                if body in inside:
                    kb = self.k[body]
                    V[e] += sign * W[kb]
                    V[e, kb] += sign * np.asarray(s, float)
                    terms.append((sign,) + anchor[body])
                else:
                    terms.append((sign, body, np.asarray(s, float)))
            self.kterms.append(terms)
        self.Vx, self.Vy = V[..., 0].copy(), V[..., 1].copy()  # (equation, angle)
        self.ne = ne
        D = np.zeros((len(drivers), nb))
        self.dterms: list[list[tuple[float, int]]] = []
        for d, c in enumerate(drivers):  # theta_b + delta - theta_a - u
            terms = []
            for sign, body in ((1.0, c.b), (-1.0, c.a)):
                if body in inside:
                    D[d, self.k[body]] += sign
                else:
                    terms.append((sign, body))
            self.dterms.append(terms)
        self.D = D
        self.delta = np.array([c.delta for c in drivers])
        # a driver on one link of the group fixes its angle: theta_k = sign (u - K_d),
        # set exactly so (as the closed-form driver link does) after each solve
        self.pinned = [
            (int(np.flatnonzero(row)[0]), float(row[np.flatnonzero(row)[0]]), 2 * ne + d)
            for d, row in enumerate(D)
            if np.count_nonzero(row) == 1
        ]
        # F = K + [M1 M2 M3] (cos, sin, theta): one product for all equations
        M = np.zeros((nb, 3 * nb))
        M[:ne, :nb], M[:ne, nb : 2 * nb] = self.Vx, -self.Vy
        M[ne : 2 * ne, :nb], M[ne : 2 * ne, nb : 2 * nb] = self.Vy, self.Vx
        M[2 * ne :, 2 * nb :] = D
        _Eqs.__init__(self, M)
        self.nd = len(drivers)
        # what a Newton solve iterates on: the angles no driver fixes alone, in the other
        # equations (the fixed angles' terms move into the constant part, see reduce())
        fixed = [k for k, _, _ in self.pinned]
        if len(set(fixed)) != len(fixed):  # one angle fixed twice: iterate on all
            fixed = []
        frows = [row for k, _, row in self.pinned] if fixed else []
        self.fixed = np.array(fixed, int)
        self.fsign = np.array([sign for _, sign, _ in self.pinned] if fixed else [])
        self.frows = np.array(frows, int)
        self.free = np.array([k for k in range(nb) if k not in fixed], int)
        rows = [r for r in range(nb) if r not in frows]

        def cols(ks):
            return [k for k in ks] + [nb + k for k in ks] + [2 * nb + k for k in ks]

        self.sub = _Eqs(M[np.ix_(rows, cols(self.free))]) if fixed else self
        self.rows = np.array(rows, int)
        self.MTf = M[np.ix_(rows, cols(fixed))].T.copy()
        # all angles fixed: F_theta is the drivers' signed permutation, its inverse exact
        self.inv_fixed = np.linalg.inv(self.D) if not self.free.size else None

    def reduce(self, Ku: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The constant part ``Kr`` (N, free) of :attr:`sub`'s equations and the angles
        the drivers fix alone (N, fixed), exactly, from ``Ku`` (:meth:`with_driver`): a
        driver ``sign theta_k + K_d - u = 0`` gives ``theta_k = sign (u - K_d)``, and the
        Jacobian of the whole is that of :attr:`sub` bordered by those rows (+-1 on the
        diagonal), so both are singular together."""
        if not self.fixed.size:
            return Ku, Ku[:, :0]
        thp = self.fixed_angles(Ku)
        Kr = Ku[:, self.rows] + np.concatenate([np.cos(thp), np.sin(thp), thp], axis=1) @ self.MTf
        return Kr, thp

    def fixed_angles(self, Ku: np.ndarray) -> np.ndarray:
        """The angles the drivers fix alone (N, fixed), from ``Ku``: ``sign (u - K_d)``."""
        return -Ku[:, self.frows] * self.fsign

    def join(self, thf: np.ndarray, thp: np.ndarray) -> np.ndarray:
        """All angles (N, links) from the free ones and the fixed ones."""
        if not self.fixed.size:
            return thf
        th = np.empty((thf.shape[0], self.nb))
        th[:, self.free] = thf
        th[:, self.fixed] = thp
        return th

    # -- the solved bodies' part ---------------------------------------------------------
    def known(self, st: State, order: int = 0):
        """The solved bodies' terms ``K`` (N, n) in the order of the equations (closing
        joints' x, their y, drivers; order 0), or their first or second time derivatives,
        and the tree's root points ``(Px, Py)`` (N, links), or their derivatives."""
        f = (st.point, st.point_velocity, st.point_acceleration)[order]
        ang = (st.th, st.w, st.al)[order]
        kc, pxc, pyc, points, kmov, dmov, pmov = self._known_plan(st.nb)
        n, ne = st.n, self.ne
        pts = [f(body, s) for body, s in points]  # each moving point once
        K = np.empty((n, self.nb))
        K[:] = kc if order == 0 else 0.0
        for e, sign, j in kmov:
            px, py = pts[j]
            K[:, e] += sign * px
            K[:, ne + e] += sign * py
        for col, sign, body in dmov:
            K[:, col] += sign * ang[body]
        Px = np.empty((n, self.nb))
        Py = np.empty((n, self.nb))
        Px[:] = pxc if order == 0 else 0.0
        Py[:] = pyc if order == 0 else 0.0
        for kb, j in pmov:
            Px[:, kb], Py[:, kb] = pts[j]
        return K, Px, Py

    def _known_plan(self, ground: int):
        """:meth:`known`'s terms split once: the ground's points (fixed local vectors) and
        the drivers' offsets as constant rows of ``K`` and ``(Px, Py)`` at order 0 (zero
        at orders 1 and 2), and the moving bodies' terms, evaluated at each call."""
        plan = self._kplan
        if plan is not None and plan[0] == ground:
            return plan[1]
        ne = self.ne
        kc = np.zeros(self.nb)
        pxc, pyc = np.zeros(self.nb), np.zeros(self.nb)
        kmov, dmov, pmov = [], [], []
        points: list[tuple[int, np.ndarray]] = []  # the moving points, each once

        def point(body, s):
            for j, (b, v) in enumerate(points):
                if b == body and v.shape == s.shape and np.array_equal(v, s):
                    return j
            points.append((body, s))
            return len(points) - 1

        for e, terms in enumerate(self.kterms):
            for sign, body, s in terms:
                if body == ground and s.ndim == 1:
                    kc[e] += sign * s[0]
                    kc[ne + e] += sign * s[1]
                else:
                    kmov.append((e, sign, point(body, s)))
        for d, terms in enumerate(self.dterms):
            kc[2 * ne + d] = self.delta[d]
            dmov += [(2 * ne + d, sign, body) for sign, body in terms if body != ground]
        for kb, (body, s) in enumerate(self.anchor):
            if body == ground and s.ndim == 1:
                pxc[kb], pyc[kb] = s[0], s[1]
            else:
                pmov.append((kb, point(body, s)))
        out = (kc, pxc, pyc, points, kmov, dmov, pmov)
        self._kplan = (ground, out)
        return out

    def pin(self, th: np.ndarray, K: np.ndarray, u: np.ndarray) -> None:
        """Set the angles a driver fixes alone to their exact values, in place (a Newton
        solution has them to rounding, which can put a zero angle at -1e-32)."""
        for k, sign, row in self.pinned:
            th[:, k] = sign * (u - K[:, row])

    def with_driver(self, K: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``K`` with the driver values ``u`` (N,) taken off the drivers' equations."""
        if not self.nd:
            return K
        out = K.copy()
        out[:, 2 * self.ne :] -= u[:, None]
        return out

    def poses(self, C, S, Px, Py):
        """The links' frame origins (N, links) from their angles."""
        x = Px + C @ self.Wx.T - S @ self.Wy.T
        y = Py + S @ self.Wx.T + C @ self.Wy.T
        return x, y

    def poses_one(self, th, Px, Py) -> tuple[list, list]:
        """:meth:`poses` at one position, in floats (the angles ``th``, the roots'
        points ``Px``, ``Py``: (links,), arrays or lists)."""
        if isinstance(th, np.ndarray):
            th, Px, Py = th.tolist(), Px.tolist(), Py.tolist()
        c = [math.cos(v) for v in th]
        s = [math.sin(v) for v in th]
        xs, ys = [], []
        for px, py, terms in zip(Px, Py, self._wterms):
            for k, a, b in terms:  # the tree's nonzero local vectors only
                ck, sk = c[k], s[k]
                px += ck * a - sk * b
                py += sk * a + ck * b
            xs.append(px)
            ys.append(py)
        return xs, ys

    def accel_terms(self, C, S, wd2) -> np.ndarray:
        """``sum_k A(theta_k) V[e, k] w_k^2`` (N, n): the centripetal part of the
        closing joints' second derivative (zero for drivers)."""
        return (C * wd2) @ self.M1.T + (S * wd2) @ self.M2.T


def _rowmax_abs(a: np.ndarray) -> np.ndarray:
    """``max |a|`` along the rows of ``a`` (N, k), k small, NaN kept (a reduction along a
    short last axis costs more than k elementwise maxima)."""
    m = np.abs(a[:, 0])
    for k in range(1, a.shape[1]):
        np.maximum(m, np.abs(a[:, k]), out=m)
    return m


def _solve_small(J: list, f: list) -> list | None:
    """``J dx = -f`` for 1 to 3 unknowns by Cramer's rule in floats; None when ``J`` is
    exactly singular."""
    n = len(f)
    if n == 1:
        return None if J[0][0] == 0 else [-f[0] / J[0][0]]
    if n == 2:
        (a, b), (c, d) = J
        det = a * d - b * c
        if det == 0:
            return None
        return [-(d * f[0] - b * f[1]) / det, -(a * f[1] - c * f[0]) / det]
    (a, b, c), (d, e, g), (h, i, k) = J
    A, B, C = e * k - g * i, g * h - d * k, d * i - e * h
    det = a * A + b * B + c * C
    if det == 0:
        return None
    D, E, G = c * i - b * k, a * k - c * h, b * h - a * i
    H, I, L = b * g - c * e, c * d - a * g, a * e - b * d
    f0, f1, f2 = f
    return [
        -(A * f0 + D * f1 + H * f2) / det,
        -(B * f0 + E * f1 + I * f2) / det,
        -(C * f0 + G * f1 + L * f2) / det,
    ]


def _batch_inverse(J: np.ndarray) -> np.ndarray:
    """Inverses of the matrices (N, n, n); NaN where one is not finite or is exactly
    singular (a zero pivot in its LU factorisation, a zero determinant up to 2 x 2).
    Up to 2 x 2 by the adjugate, elementwise (a stacked LAPACK call costs more there)."""
    n = J.shape[1]
    if n <= 2:
        with np.errstate(divide="ignore", invalid="ignore"):
            if n == 1:
                out = 1.0 / J
            else:
                a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
                det = a * d - b * c
                out = np.empty_like(J)
                out[:, 0, 0], out[:, 0, 1] = d / det, -b / det
                out[:, 1, 0], out[:, 1, 1] = -c / det, a / det
        if not np.isfinite(out).all():  # (a reduction over two short axes costs ~50 us)
            out[~np.all(np.isfinite(out), axis=(1, 2))] = np.nan
        return out
    good = np.all(np.isfinite(J), axis=(1, 2))
    if good.all():
        try:
            return np.linalg.inv(J)
        except np.linalg.LinAlgError:
            pass
    out = np.full(J.shape, np.nan)
    idx = np.flatnonzero(good)
    if idx.size:
        d = np.linalg.det(J[idx])
        idx = idx[np.isfinite(d) & (d != 0)]
        if idx.size:
            out[idx] = np.linalg.inv(J[idx])
    return out


def _lagrange_weights(us: list[float], u: float) -> list[float] | None:
    """The weights of the Lagrange extrapolation from the driver values ``us`` to ``u``
    (None where two of them coincide)."""
    k = len(us)
    ws = []
    for i in range(k):
        w = 1.0
        for j in range(k):
            if j != i:
                den = us[i] - us[j]
                if den == 0:
                    return None
                w *= (u - us[j]) / den
        ws.append(w)
    return ws


def _extrapolate_floats(us: list[float], qs: list[list[float]], u: float) -> list[float]:
    """:func:`_extrapolate` on lists of floats."""
    k = len(qs)
    if k == 1:
        return list(qs[0])
    ws = _lagrange_weights(us[:k], u)
    if ws is None:
        return list(qs[-1])
    if k == 2:
        (w0, w1), (q0, q1) = ws, qs
        return [w0 * a + w1 * b for a, b in zip(q0, q1)]
    (w0, w1, w2), (q0, q1, q2) = ws, qs
    return [w0 * a + w1 * b + w2 * c for a, b, c in zip(q0, q1, q2)]


def _extrapolate(us: list[float], qs: list[np.ndarray], u: float) -> np.ndarray:
    """Lagrange extrapolation of the last (up to three) solutions to driver value ``u``."""
    k = len(qs)
    if k == 1:
        return qs[0].copy()
    ws = _lagrange_weights(us[:k], u)
    if ws is None:
        return qs[-1].copy()
    out = ws[0] * qs[0]
    for w, q in zip(ws[1:], qs[1:]):
        out = out + w * q
    return out
