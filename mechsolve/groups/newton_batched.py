"""A Newton group's sweep refined in one batch: a coarse continuation predicts every
position, then Newton iterates on all of them at once (see :mod:`.generic`)."""

from __future__ import annotations

import math

import numpy as np

from mechsolve.base.state import State
from mechsolve.groups.base import Drive
from mechsolve.groups.compiled import kernels
from mechsolve.groups.newton_common import COARSE, MAX_JUMP, _extrapolate_floats
from mechsolve.groups.newton_floats import coarse_runner, sparse_newton
from mechsolve.groups.reduced import FLOATS_UP_TO, STACKED_MIN, _lu_solve, _rowmax_abs


class BatchedSweep:
    """Methods of :class:`~mechsolve.groups.generic.NewtonGroup`: see the module
    docstring."""

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
        coarse = np.arange(0, n, k)  # every k-th position and the last
        if coarse[-1] != n - 1:
            coarse = np.append(coarse, n - 1)
        sub = st.take(coarse)
        dsub = drive.take(coarse)
        # the coarse pass counts its own positions; prefix() wants the sweep's sample
        sub_prefix = None if prefix is None else (lambda us, j: prefix(us, int(coarse[j])))
        if self.red is not None and self.red.sub.nb <= FLOATS_UP_TO:
            coarse_pass = self._coarse_compiled if self.compiled else self._coarse_floats
            if (itc := coarse_pass(sub, dsub, q_start, sub_prefix)) is None:
                return None
        else:
            okc, itc, _ = self.sweep_sequential(
                sub, dsub, q_start, np.ones(len(coarse), bool), prefix=sub_prefix
            )
            if not okc.all() or self.gaps:
                return None
        ones = Drive(dsub.u, np.ones(len(coarse)), np.zeros(len(coarse)))
        u = drive.u
        if self.red is not None:  # the free angles alone: the frames follow from them
            self._coarse_rates(sub, ones)
            fb = [self.bodies[k] for k in self.red.free.tolist()]
            qc, dqc = sub.th[fb].T, sub.w[fb].T  # (gathered rows: one call, not a stack)
            if not np.isfinite(dqc).all():
                return None
            pred = self._predict(u, coarse, qc, dqc)
            got = self._refine_angles(st, u, pred, coarse, qc)
            if got is None:
                return None
            iters, th = got
            d = np.abs(th - pred)
            wj = self._angle_jump_weights()
            if wj.count(1.0) != len(wj):
                d *= wj
            if d.size and not d.max() <= MAX_JUMP:  # (NaN too)
                return None
            iters[coarse] = itc
            return np.ones(n, bool), iters, "newton (batched)"
        self.velocity(sub, ones)
        qc = self._q_rows(sub)
        dqc = self._q_rows(sub, rates=True)
        if not np.all(np.isfinite(dqc)):
            return None
        pred = self._predict(u, coarse, qc, dqc)
        q, iters = self._refine_bodies(st, u, pred, coarse, qc)
        if q is None:
            return None
        d = np.abs(q - pred)
        d[:, 0::3] /= self.scale
        d[:, 1::3] /= self.scale
        if np.max(d) > MAX_JUMP or not np.all(np.isfinite(q)):
            return None
        self._set_q_rows_into(st, q)
        iters[coarse] = itc
        return np.ones(n, bool), iters, "newton (batched)"

    def _predict(self, u: np.ndarray, coarse: np.ndarray, qc: np.ndarray, dqc: np.ndarray):
        """Every position's prediction (N, k) from the coarse positions ``qc`` (a
        revolute group's free angles, else its body coordinates: (coarse, k)) and their
        rates ``dqc``: the cubic Hermite (or with ``predictor`` "linear", the chord)."""
        if self.compiled and self.predictor != "linear":  # the same, in one loop
            pred = np.empty((len(u), qc.shape[1]))
            kernels(self.compiled).hermite(u, coarse, qc, dqc, pred)
            return pred
        # cubic Hermite between coarse positions, in the driver coordinate: each
        # segment's polynomial in t = (u - u0) / (u1 - u0), by Horner; the positions of a
        # segment are consecutive (the last position belongs to the last segment), so its
        # coefficients are repeated rather than gathered (a fancy index costs 6x more);
        # on (k, N) rows, handed out transposed: a product of (N, k) rows of a few
        # entries by t (N, 1) costs several times one over rows of N
        counts = np.diff(coarse)
        counts[-1] += 1
        uc = u[coarse]
        hc = uc[1:] - uc[:-1]
        q0, q1 = qc[:-1].T, qc[1:].T
        t = (u - np.repeat(uc[:-1], counts)) / np.repeat(hc, counts)
        if self.predictor == "linear":  # first order: the chord between coarse positions
            pred = np.repeat(q1 - q0, counts, axis=1)
            pred *= t
            pred += np.repeat(q0, counts, axis=1)
        else:  # q0 + t (m0 + t (3 (q1 - q0) - 2 m0 - m1 + t (2 (q0 - q1) + m0 + m1)))
            m0, m1 = hc * dqc[:-1].T, hc * dqc[1:].T
            dq = q1 - q0
            c2 = 3 * dq - 2 * m0 - m1
            c3 = m0 + m1 - 2 * dq
            pred = np.repeat(c3, counts, axis=1)
            for c in (c2, m0, q0):
                pred *= t
                pred += np.repeat(c, counts, axis=1)
        return pred.T

    def _coarse_floats(self, st: State, drive: Drive, q_start: np.ndarray, prefix=None):
        """:meth:`sweep_sequential` over all positions of ``st`` for a small revolute
        group, its plain steps in floats and in the free angles alone: a step that
        converges by Newton from the extrapolated prediction and whose free angles move
        less than :data:`MAX_JUMP` from it (weighted by :meth:`_angle_jump_weights`) is
        taken as the general code would take it; any other goes through
        :meth:`_advance` (its substeps, scipy, its error) with the same history (the
        poses of its positions placed then). The angles (with their cosines and sines)
        are written into ``st`` at the end, all positions at once; not the frames, which
        nothing reads at the coarse positions (the batch places every position's).
        Returns the iterations per position, or None when a position fails."""
        red = self.red
        Kall = red.known(st)
        u = drive.u
        Kr, thp = red.reduce(red.with_driver(Kall[0], u))
        Kr, thp = Kr.tolist(), thp.tolist()
        free, fixed = red.free.tolist(), red.fixed.tolist()
        wj = self._angle_jump_weights()
        hu: list[float] = []
        hi: list[int] = []  # the history's positions ...
        ha: list[list[float]] = []  # ... and their free angles
        pred = [float(q_start[3 * k + 2]) for k in free]
        iters: list[int] = []
        out: list[list[float]] = []
        atol, its = self.atol, self.max_iterations
        newton = self._newton_floats()
        # the plain steps with three positions of history in a loop written out for the
        # group's size (coarse_runner: the same operations, the angles in locals)
        run = coarse_runner(len(free)) if len(free) > 1 else None
        ul = u.tolist()
        n, i = len(ul), 0
        while i < n:
            nh = len(ha)
            if nh == 3 and run is not None:
                i, hu, ha = run(i, ul, Kr, newton, hu, ha, wj, atol, its, out, iters, MAX_JUMP)
                if i == n:
                    break
                hi, ui, plain = [i - 3, i - 2, i - 1], ul[i], False  # (i: not plain)
            else:
                ui = ul[i]
                if nh == 1:  # the first step: along the tangent, not from the start's pose
                    pred = self._tangent_floats(ha[0], Kr[i], thp[i])
                elif nh:
                    pred = _extrapolate_floats(hu, ha, ui)
                thf, plain, it, _, _ = newton(Kr[i], pred, atol, its, True)
                if plain and nh:
                    plain = max([abs(a - b) * w for a, b, w in zip(thf, pred, wj)]) <= MAX_JUMP
            if not plain:  # the general step, as sweep_sequential takes it
                got = self._coarse_general(i, ui, u, Kall, thp, hu, hi, ha, q_start, prefix)
                if got is None:
                    return None
                thf, it = got
            out.append(thf)
            iters.append(it)
            if nh == 3:
                hu, hi, ha = [hu[1], hu[2], ui], [hi[1], hi[2], i], [ha[1], ha[2], thf]
            else:
                hu, hi, ha = hu + [ui], hi + [i], ha + [thf]
            i += 1
        if fixed:
            th = np.empty((st.n, red.nb))
            th[:, red.free] = out
            th[:, red.fixed] = thp
        else:  # (the free angles are all: no gathered columns)
            th = np.array(out, float)
        for b, k in self.col.items():  # (the frames: no reader of the coarse positions')
            st.set_angle(b, th[:, k])
        return np.array(iters)

    def _coarse_general(self, i: int, ui: float, u, Kall, thp, hu, hi, ha, q_start, prefix):
        """:meth:`_coarse_floats`'s step to position ``i`` that is not a plain one, as
        :meth:`sweep_sequential` takes it (:meth:`_advance` from the history ``hu``,
        ``hi``, ``ha``, or :meth:`_solve_one` at the start): ``(free angles, iterations)``,
        or None where it fails."""
        Ki = [k[i : i + 1] for k in Kall]
        if ha:
            hqa = [self._pose_floats(j, a, thp, Kall) for j, a in zip(hi, ha)]
            qa, stats, good = self._advance(None, ui, hu, hqa, i - 1, prefix, Ki)
        else:
            qa, stats = self._solve_one(None, u[i : i + 1], q_start, Ki)
            good = stats.converged
        if not good:
            return None
        return [float(qa[3 * k + 2]) for k in self.red.free.tolist()], stats.iterations

    def _newton_floats(self):
        """The coarse pass's Newton iterations in floats for the group's free angles:
        :meth:`~mechsolve.groups.reduced._Eqs.newton_list` (its own loop for two or
        four angles), written out for the equations' coefficients where it can be
        (:func:`~mechsolve.groups.newton_floats.sparse_newton`: the same iterates, the
        products of zero coefficients left out); made once per equations."""
        sub = self.red.sub
        got = getattr(self, "_newton_fl", None)
        if got is not None and got[0] is sub:
            return got[1]
        fn = sparse_newton(sub)
        if fn is None:
            fn = {2: sub._newton_list2, 4: sub._newton_list4}.get(sub.nb, sub.newton_list)
        self._newton_fl = (sub, fn)
        return fn

    def _pose_floats(self, i: int, thf: list, thp: list, Kall) -> np.ndarray:
        """The group's body coordinates at position ``i`` of the coarse pass from its
        free angles ``thf`` (the fixed ones ``thp[i]``), as :meth:`_solve_one` places
        them."""
        red = self.red
        th = [0.0] * red.nb
        for j, k in enumerate(red.free.tolist()):
            th[k] = thf[j]
        for j, k in enumerate(red.fixed.tolist()):
            th[k] = thp[i][j]
        q = np.empty(self.n)
        q[2::3] = th
        q[0::3], q[1::3] = red.poses_one(th, Kall[1][i], Kall[2][i])
        return q

    def _angle_jump_weights(self) -> list[float]:
        """The weights of the free angles' moves in a jump check that reads the free
        angles alone (radians, in the order of ``red.free``): ``max(1, max_b |W[b, k]| /
        size)`` for angle ``k``, over the links ``b`` (``W[b, k]``: the tree's vector of
        link ``b``'s frame on angle ``k``'s link). A link's frame is ``P_b + sum_k
        A(theta_k) W[b, k]`` with the solved bodies' ``P_b`` fixed at a position, so
        that an angle's weighted move below :data:`MAX_JUMP` moves no frame by more
        than :data:`MAX_JUMP` of the mechanism's size through that link; and a jump to
        another branch moves the angles, the frames following from them."""
        got = getattr(self, "_angle_w", None)
        if got is not None and got[0] == self.scale:
            return got[1]
        red = self.red
        w = [
            max(
                1.0,
                max(math.hypot(red._wx[b][k], red._wy[b][k]) for b in range(red.nb)) / self.scale,
            )
            for k in red.free.tolist()
        ]
        self._angle_w = (self.scale, w)
        return w

    def _coarse_compiled(self, st: State, drive: Drive, q_start: np.ndarray, prefix=None):
        """:meth:`_coarse_floats` with its plain steps in the compiled kernel
        (:func:`~mechsolve.groups.kernels.coarse_run`: the same predictions, Newton
        iterations, poses and jump check, in the same arithmetic); any other step goes
        through :meth:`_advance` (:meth:`_solve_one` at the start) in Python, with the
        same history, as there. Returns the iterations per position, or None."""
        kern = kernels(self.compiled)
        red = self.red
        Kall = red.known(st)
        u = np.ascontiguousarray(drive.u, float)
        Kr, thp = red.reduce(red.with_driver(Kall[0], u))
        Kr, thp = np.ascontiguousarray(Kr), np.ascontiguousarray(thp)
        Px, Py = np.ascontiguousarray(Kall[1]), np.ascontiguousarray(Kall[2])
        plan = self._kernel_plan()
        n, nq = st.n, self.n
        q0 = np.array([float(v) for v in q_start])
        hu, hq, nh = np.zeros(3), np.zeros((3, nq)), 0
        out = np.empty((n, nq))
        iters = np.zeros(n, np.int64)
        i = 0
        while True:
            i, nh = kern.coarse_run(
                i, u, Kr, thp, Px, Py, q0, hu, hq, nh, out, iters, *plan, MAX_JUMP
            )
            if i >= n:
                break
            # the general step, as _coarse_floats (and sweep_sequential) take it
            Ki = [k[i : i + 1] for k in Kall]
            if nh:
                hul, hqa = hu[:nh].tolist(), [hq[j].copy() for j in range(nh)]
                qa, stats, good = self._advance(None, float(u[i]), hul, hqa, i - 1, prefix, Ki)
            else:
                qa, stats = self._solve_one(None, u[i : i + 1], q_start, Ki)
                good = stats.converged
            if not good:
                return None
            out[i] = qa
            iters[i] = stats.iterations
            if nh == 3:
                hu[:2], hq[:2] = hu[1:].copy(), hq[1:].copy()
                hu[2], hq[2] = u[i], out[i]
            else:
                hu[nh], hq[nh] = u[i], out[i]
                nh += 1
            i += 1
        self._set_q_rows(st, out)
        return iters.astype(int)

    def _kernel_plan(self) -> tuple:
        """The group's constants as :func:`~mechsolve.groups.kernels.coarse_run` takes
        them (after the history): free and fixed angles, the free angles' equations
        (``M1``, ``M2``, ``M3``, their nonzero entries), the tree's local vectors by link
        (CSR: ``wptr``, ``wk``, ``wa``, ``wb``), the jump's weights, the tolerance and
        the iterations' limit."""
        red = self.red
        sub = red.sub
        key = (self.scale, self.atol, self.max_iterations)
        got = getattr(self, "_kplan_c", None)
        if got is not None and got[0] == key:
            return got[1]
        wptr, wk, wa, wb = [0], [], [], []
        for terms in red._wterms:
            for k, a, b in terms:
                wk.append(k)
                wa.append(a)
                wb.append(b)
            wptr.append(len(wk))
        jw = np.zeros(self.n)  # the free angles alone, as _coarse_floats checks them
        jw[3 * red.free + 2] = self._angle_jump_weights()
        plan = (
            np.asarray(red.free, np.int64),
            np.asarray(red.fixed, np.int64),
            np.ascontiguousarray(sub.M1, float),
            np.ascontiguousarray(sub.M2, float),
            np.ascontiguousarray(sub.M3, float),
            np.ascontiguousarray(sub.nzm, np.bool_),
            np.array(wptr, np.int64),
            np.array(wk, np.int64),
            np.array(wa, float),
            np.array(wb, float),
            jw,
            float(self.atol),
            int(self.max_iterations),
        )
        self._kplan_c = (key, plan)
        return plan

    def _tangent_floats(self, th0: list, Kr: list, thp: list) -> list:
        """A prediction of the next position's free angles from those of the previous
        one, ``th0``: the first Newton iterate from ``th0`` with the next position's
        constant part ``Kr`` (the tangent step, ``-F_theta^-1 dF``, with the driver's
        increment of the solved bodies' terms). ``th0`` itself when that step cannot be
        taken (an exactly singular Jacobian) or the angles are not finite (with the
        fixed ones ``thp``)."""
        thf = self._newton_floats()(Kr, th0, self.atol, 1, False)[0]
        if not all(math.isfinite(v) for v in thf) or not all(math.isfinite(v) for v in thp):
            return list(th0)
        return thf

    def _refine_angles(self, st: State, u, pred, coarse, qc):
        """Batched Newton in the free angles from their prediction ``pred`` (N, free),
        those of the coarse positions ``qc`` kept; the poses are written into ``st``.
        Returns the iterations per position and the free angles (N, free), or None."""
        red = self.red
        sub = red.sub
        n = st.n
        K, Px, Py = red.known(st)
        Kr, thp = red.reduce(red.with_driver(K, u))
        th = pred.copy(order="K")  # (columns contiguous as the prediction's)
        th[coarse] = qc
        iters = np.zeros(n, int)
        todo = np.ones(n, bool)
        todo[coarse] = False
        if sub.nb == 0:
            todo[:] = False
        if self.compiled and sub.elim is not None:  # the triad's: in the kernel
            return self._refine_elim_compiled(st, th, Kr, thp, (Px, Py), iters, todo)
        if sub.nb == 2:
            refine = self._refine2_compiled if self.compiled else self._refine2
        elif sub.elim is not None:  # the triad's: each angle on its own 1-D array
            refine = self._refine_elim
        else:
            refine = self._refine_stacked
        cs = refine(th, Kr, iters, todo)
        if cs is False:
            return None
        self._put_angles(st, red.join(th, thp), Px, Py, cs)
        return iters, th

    def _refine_stacked(self, th: np.ndarray, Kr: np.ndarray, iters: np.ndarray, todo):
        """:meth:`_refine_angles`'s iterations on the (N, n) arrays of the angles, by
        the stacked elimination (LAPACK where it must): updates ``th``, ``iters`` and
        ``todo`` in place. Returns the cosines and sines of the angles turned with the
        steps (lists of 1-D arrays, None when no iteration took whole arrays), or False
        when a position does not converge."""
        sub = self.red.sub
        n = th.shape[0]
        last = np.full(n, np.inf)
        J = np.empty((n, sub.nb, sub.nb))
        tol = 1e-3 * self.atol
        Cf = Sf = None  # cos and sin of th at every position, turned with its small steps
        for it_k in range(self.max_iterations):
            count = np.count_nonzero(todo)
            if count == 0:
                break
            if 2 * count >= n:  # most positions still iterate: whole arrays, masked
                idx, t, Kk, lastk = None, th, Kr, last
            else:
                idx = np.flatnonzero(todo)
                t, Kk, lastk = th[idx], Kr[idx], last[idx]
            if Cf is not None:
                C, S = (Cf, Sf) if idx is None else (Cf[idx], Sf[idx])
            else:
                C, S = np.cos(t), np.sin(t)
                if idx is None:
                    Cf, Sf = C, S
            f = sub.residual(t, C, S, Kk)
            r = _rowmax_abs(f)
            dq = _newton_step(sub, C, S, f, J[: t.shape[0]])
            if dq is None:
                return False
            step = _rowmax_abs(dq)
            # as below: converged when the residual is small and the step tiny or no
            # longer shrinking (the rounding level); that last step is not taken; or
            # when this step leaves an error predicted below tol (_converges_next)
            small = step <= tol
            pred = _converges_next(step, lastk, tol) if it_k else False
            done = ((r <= self.atol) & (small | (step >= lastk))) | pred
            take = ~done | small | pred
            if idx is None:
                take &= todo
                D = np.where(take[:, None], dq, 0.0)
                th += D
                iters += todo
                last = np.where(todo, step, last)
                todo &= ~done
                if Cf is not None:  # (after the last iteration too: the state's)
                    _rotate(Cf, Sf, D, th)
            else:
                it, D = idx[take], dq[take]
                th[it] += D
                iters[idx] += 1
                last[idx] = step
                todo[idx[done]] = False
                if Cf is not None:
                    Ci, Si = Cf[it], Sf[it]
                    _rotate(Ci, Si, D, th[it])
                    Cf[it], Sf[it] = Ci, Si
        if todo.any() or not np.all(np.isfinite(th)):
            return False
        return None if Cf is None else ([c for c in Cf.T], [s for s in Sf.T])

    def _refine2(self, th: np.ndarray, Kr: np.ndarray, iters: np.ndarray, todo: np.ndarray):
        """:meth:`_refine_angles`'s iterations for two angles (the four-bar's loop), on
        a (2, N) array of the angles (each angle's row contiguous): the same residual,
        step (by the adjugate), tests and updates, without the (N, 2) products and
        reductions, which cost more than the arithmetic; the steps and the turned
        cosines and sines of both angles in one pass. Updates ``th`` (N, 2), ``iters``
        and ``todo`` in place. Returns the angles' cosines and sines, turned with every
        step taken (the state's: see :meth:`_put_angles`), as ``([cos x0, cos x1],
        [sin x0, sin x1])``; False when a position does not converge."""
        n = th.shape[0]
        rows = self.red.sub._rows
        nd = self.red.sub.nd
        X = np.ascontiguousarray(th.T)  # (2, N): the angles, a row each
        K0, K1 = np.ascontiguousarray(Kr[:, 0]), np.ascontiguousarray(Kr[:, 1])
        last = np.full(n, np.inf)
        tol = 1e-3 * self.atol
        C = S = None  # cos and sin of X everywhere, turned with their small steps
        for it_k in range(self.max_iterations):
            count = np.count_nonzero(todo)
            if count == 0:
                break
            if 2 * count >= n:  # most positions still iterate: whole arrays, masked
                idx, t, k0, k1, lastk = None, X, K0, K1, last
                if C is None:
                    C, S = np.cos(X), np.sin(X)
                c, s = C, S
            else:
                idx = np.flatnonzero(todo)
                t, k0, k1, lastk = X[:, idx], K0[idx], K1[idx], last[idx]
                c, s = (None, None) if C is None else (C[:, idx], S[:, idx])
            r, dq, step = _newton_step2(rows, nd, t, k0, k1, c, s)
            # as _refine_angles: converged when the residual is small and the step tiny
            # or no longer shrinking (the rounding level); that last step is not taken;
            # or when this step leaves an error predicted below tol (_converges_next)
            small = step <= tol
            pred = _converges_next(step, lastk, tol) if it_k else False
            done = ((r <= self.atol) & (small | (step >= lastk))) | pred
            take = ~done | small | pred
            if idx is None:
                take &= todo  # (a boolean index costs some 10 us a row, copyto 2 us)
                np.copyto(dq, 0.0, where=~take)
                X += dq
                iters += todo
                np.copyto(last, step, where=todo)
                todo &= ~done
                _rotate(C, S, dq, X)  # (after the last iteration too: the state's)
            else:
                it, D = idx[take], dq[:, take]
                X[:, it] += D
                iters[idx] += 1
                last[idx] = step
                todo[idx[done]] = False
                if C is not None:
                    c, s = c[:, take], s[:, take]
                    _rotate(c, s, D, X[:, it])
                    C[:, it], S[:, it] = c, s
        th[:] = X.T
        if todo.any() or not np.isfinite(X).all():
            return False
        if C is None:  # (no iteration on whole arrays)
            C, S = np.cos(X), np.sin(X)
        return [C[0], C[1]], [S[0], S[1]]

    def _refine_elim(self, th: np.ndarray, Kr: np.ndarray, iters: np.ndarray, todo):
        """:meth:`_refine_angles`'s iterations for a group eliminated to 2 x 2 (the
        Stephenson triad), on each angle's and each equation's own 1-D array, as
        :meth:`_refine2` for two angles: the residual from the equations' nonzero
        coefficients (in the order of the compiled kernel's sums, not a matrix product
        over the (N, n) arrays), the step by the elimination, the same tests and
        updates. The angles and their cosines and sines are the rows of (n, N) arrays,
        so that the steps' update and turning take one call for all angles. Updates
        ``th`` (N, n), ``iters`` and ``todo`` in place. Returns the angles' cosines and
        sines, turned with every step taken, as ``([cos x_k], [sin x_k])``; False when
        a position does not converge."""
        sub = self.red.sub
        n, nb = th.shape
        X = np.ascontiguousarray(th.T)  # (nb, N): the angles, a row each
        K = [np.ascontiguousarray(Kr[:, e]) for e in range(nb)]
        last = np.full(n, np.inf)
        tol = 1e-3 * self.atol
        C = S = None  # cos and sin of X everywhere, turned with their small steps
        for it_k in range(self.max_iterations):
            count = np.count_nonzero(todo)
            if count == 0:
                break
            if 2 * count >= n:  # most positions still iterate: whole arrays, masked
                idx, t, k, lastk = None, list(X), K, last
                if C is None:
                    C, S = np.cos(X), np.sin(X)
                c, s = C, S
            else:
                idx = np.flatnonzero(todo)
                t, k, lastk = list(X[:, idx]), [v[idx] for v in K], last[idx]
                c, s = (None, None) if C is None else (C[:, idx], S[:, idx])
            D = np.empty((nb, n)) if idx is None else None  # (the step written into it)
            cs = None if c is None else (list(c), list(s))
            r, dq, step = _elim_step(sub, t, k, cs, None if D is None else list(D))
            # as _refine_angles: converged when the residual is small and the step tiny
            # or no longer shrinking (the rounding level); that last step is not taken;
            # or when this step leaves an error predicted below tol (_converges_next)
            small = step <= tol
            pred = _converges_next(step, lastk, tol) if it_k else False
            done = ((r <= self.atol) & (small | (step >= lastk))) | pred
            take = ~done | small | pred
            if idx is None:
                take &= todo
                np.copyto(D, 0.0, where=~take)
                X += D
                _rotate(C, S, D, X)  # (after the last iteration too: the state's)
                iters += todo
                np.copyto(last, step, where=todo)
                todo &= ~done
            else:
                it, D = idx[take], np.array(dq)[:, take]
                X[:, it] += D
                if C is not None:
                    c, s = c[:, take], s[:, take]
                    _rotate(c, s, D, X[:, it])
                    C[:, it], S[:, it] = c, s
                iters[idx] += 1
                last[idx] = step
                todo[idx[done]] = False
        th[:] = X.T
        if todo.any() or not np.isfinite(X).all():
            return False
        if C is None:  # (no iteration on whole arrays)
            C, S = np.cos(X), np.sin(X)
        return list(C), list(S)

    def _refine2_compiled(self, th: np.ndarray, Kr: np.ndarray, iters: np.ndarray, todo):
        """:meth:`_refine2` in the compiled kernel (:func:`~mechsolve.groups.kernels.
        refine2`: the same steps, tests and updates, position by position); the same
        arguments and result."""
        kern = kernels(self.compiled)
        n = th.shape[0]
        ((a1, a2, a3), (b1, b2, b3)), ((c1, c2, c3), (d1, d2, d3)) = self.red.sub._rows
        co = np.array([a1, a2, a3, b1, b2, b3, c1, c2, c3, d1, d2, d3], float)
        x0, x1 = th[:, 0].copy(), th[:, 1].copy()
        K0, K1 = Kr[:, 0].copy(), Kr[:, 1].copy()
        it = np.zeros(n, np.int64)
        # the first iteration over whole arrays (as nearly always): their cosines and
        # sines as the NumPy path takes them (vectorised: a fraction of scalar calls)
        whole = 2 * np.count_nonzero(todo) >= n
        if whole:
            C0, S0, C1, S1 = np.cos(x0), np.sin(x0), np.cos(x1), np.sin(x1)
        else:
            C0, S0, C1, S1 = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
        ok = kern.refine2(
            x0, x1, K0, K1, todo, it, co, bool(self.red.sub.nd), float(self.atol),
            int(self.max_iterations), C0, S0, C1, S1, whole,
        )  # fmt: skip
        iters += it
        th[:, 0], th[:, 1] = x0, x1
        if not ok:
            return False
        return [C0, C1], [S0, S1]

    def _refine_elim_compiled(self, st: State, th, Kr, thp, roots, iters, todo):
        """:meth:`_refine_angles`'s iterations for a group eliminated to 2 x 2 in the
        compiled kernel (:func:`~mechsolve.groups.kernels.refine_elim`); the poses are
        written into ``st``. Returns the iterations per position and the free angles,
        or None."""
        kern = kernels(self.compiled)
        sub = self.red.sub
        el = sub.elim
        plan = getattr(self, "_elim_plan", None)
        if plan is None or plan[0] is not el:
            coef = np.array(el.coef, float)  # (rows, 2, (m1, m2, m3))
            arrays = (
                np.array(el.priv, np.int64),
                np.array(el.rest, np.int64),
                np.array(el.V, float).reshape(len(el.priv), 2),
                np.array(el.n2, float),
                coef,
            )
            plan = self._elim_plan = (el, arrays)
        n = th.shape[0]
        th = np.ascontiguousarray(th)
        it = np.zeros(n, np.int64)
        whole = 2 * np.count_nonzero(todo) >= n  # (as in _refine2_compiled)
        if whole:
            Cf, Sf = np.cos(th), np.sin(th)
        else:
            Cf, Sf = np.empty(th.shape), np.empty(th.shape)
        ok = kern.refine_elim(
            th, np.ascontiguousarray(Kr), todo, it, Cf, Sf, whole, sub.M1, sub.M2, sub.M3,
            bool(sub.nd), plan[1], float(self.atol), int(self.max_iterations),
        )  # fmt: skip
        if not ok:
            return None
        iters += it
        cs = ([c for c in Cf.T], [s for s in Sf.T])
        self._put_angles(st, self.red.join(th, thp), roots[0], roots[1], cs)
        return iters, th

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


def _converges_next(step: np.ndarray, last: np.ndarray, tol: float) -> np.ndarray:
    """Where the Newton step ``step`` (its largest component), following one of size
    ``last``, leaves an error predicted below ``tol``: the steps contract (``step <=
    last / 2``) and ``2 step^2 / last <= tol``. Under quadratic convergence the next step
    is about ``step^2 * (step / last^2)``, smaller than ``step^2 / last`` by the factor
    ``step / last``; under linear convergence with the ratio ``rho = step / last`` the
    error left is ``step rho / (1 - rho) <= 2 step^2 / last``. So a refinement can stop
    once the step is taken, instead of spending one more residual and step only to see
    the next step at rounding level (the lean hand-written programs stop after two
    updates). The whole system's residual is checked after the sweep as before
    (positions above the tolerance are polished)."""
    ok = 2.0 * step * step <= tol * last
    ok &= step <= 0.5 * last
    return ok


def _rotate(C: np.ndarray, S: np.ndarray, D: np.ndarray, th: np.ndarray) -> None:
    """Turn the cosines ``C`` and sines ``S`` of angles by the steps ``D`` in place, to
    those of ``th`` (the angles after the steps), by the addition formulas with cos D
    and sin D from their Taylor series to the 5th order (exact to rounding while |D| <
    1e-3: the rest is below D^6 / 720), instead of evaluating cos and sin again
    (several times the cost of the arithmetic); where a step is larger (or not finite),
    cos and sin of ``th`` there. Where no step exceeds 1e-8 (a refinement's last), the
    series round to ``cos D = 1.0`` and ``sin D = D`` exactly (``D^2 / 2 <= 5e-17`` is
    below half the spacing of floats under 1, 5.55e-17, and ``D^2 / 6`` below it too),
    so the same values come from ``C - S D`` and ``S + C D``: 5 passes instead of 17."""
    if np.abs(D).max(initial=0.0) <= 1e-8:  # (not NaN)
        c = S * D
        np.subtract(C, c, out=c)
        S += C * D
        C[...] = c
        return
    d2 = D * D
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0))
    sd = D * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0)))
    c = C * cd
    c -= S * sd
    S *= cd
    S += C * sd
    C[...] = c
    if not np.abs(D).max(initial=0.0) < 1e-3:  # (NaN too)
        big = ~(np.abs(D) < 1e-3)
        C[big] = np.cos(th[big])
        S[big] = np.sin(th[big])


def _jac2(m2: float, C: np.ndarray, m1: float, S: np.ndarray) -> np.ndarray:
    """``m2 C - m1 S``, a zero coefficient's product left out (a zero product changes
    no bit of the difference but a zero's sign)."""
    if m2 and m1:
        j = m2 * C
        j -= m1 * S
        return j
    if m2:
        return m2 * C
    if m1:
        return S * -m1
    return np.zeros_like(C)


def _sum_terms(k: np.ndarray, terms) -> np.ndarray:
    """``k + m v + ...`` over the ``(m, v)`` of ``terms`` in their order, the zero
    coefficients' products left out (adding a zero changes no bit but a zero's
    sign)."""
    f = None
    for m, v in terms:
        if m:
            t = m * v
            if f is None:
                f = k + t
            else:
                f += t
    return k.copy() if f is None else f


def _newton_step2(rows, nd, t, k0, k1, C=None, S=None):
    """One Newton step of the two-angle loop at the angles ``t`` (2, N): the residual's
    size, the step (2, N) (by the adjugate of the 2 x 2 Jacobian) and its size (NaN
    where the Jacobian is exactly singular). ``rows``: the loop's coefficients ((a, b),
    (c, d)) of cos, sin and (``nd``) the angle itself; ``k0``, ``k1`` the constant
    terms; ``C``, ``S`` (2, N): the angles' cosines and sines when known. In-place
    arithmetic on the rows, the products of zero coefficients left out (a four-bar's
    loop has four): no (N, 2) products or reductions."""
    ((a1, a2, a3), (b1, b2, b3)), ((c1, c2, c3), (d1, d2, d3)) = rows
    absolute, maximum = np.abs, np.maximum
    if C is None:
        C, S = np.cos(t), np.sin(t)
    C0, C1, S0, S1 = C[0], C[1], S[0], S[1]
    t0, t1 = t[0], t[1]
    ja, jb = _jac2(a2, C0, a1, S0), _jac2(b2, C1, b1, S1)
    jc, jd = _jac2(c2, C0, c1, S0), _jac2(d2, C1, d1, S1)
    if not nd and a1 and b1 and not (a2 or b2 or c1 or d1) and (c2, d2) == (a1, b1):
        # a loop of two links' vectors along their x axes (the four-bar's): its x row
        # sums a1 cos, b1 cos and its y row a1 sin, b1 sin, the very products of the
        # Jacobian (jc = a1 C0, jd = b1 C1; ja = -a1 S0, jb = -b1 S1, negated exactly):
        # the same residual from them, four passes fewer
        f0 = k0 + jc
        f0 += jd
        f1 = k1 - ja
        f1 -= jb
    else:
        ends = ((a3, t0), (b3, t1)) if nd else ()
        f0 = _sum_terms(k0, ((a1, C0), (a2, S0), (b1, C1), (b2, S1)) + ends)
        ends = ((c3, t0), (d3, t1)) if nd else ()
        f1 = _sum_terms(k1, ((c1, C0), (c2, S0), (d1, C1), (d2, S1)) + ends)
    if nd:
        ja += a3
        jb += b3
        jc += c3
        jd += d3
    r = maximum(absolute(f0), absolute(f1))
    dq = np.empty(t.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        det = ja * jd
        det -= jb * jc
        dq0, dq1 = dq
        np.multiply(jb, f1, out=dq0)
        dq0 -= jd * f0
        dq0 /= det
        np.multiply(jc, f0, out=dq1)
        dq1 -= ja * f1
        dq1 /= det
    step = maximum(absolute(dq0), absolute(dq1))
    if not det.all():
        step[det == 0] = np.nan  # exactly singular: never converged (the caller fails it)
    return r, dq, step


def _elim_step(sub, t: list, k: list, cs=None, out=None):
    """One Newton step of a group eliminated to 2 x 2 (``sub.elim``) at the angles
    ``t`` (a 1-D array per angle), ``k`` the equations' constant terms (one per
    equation), ``cs`` the angles' cosines and sines when known: the residual's largest
    component, the step (a 1-D array per angle: inf or NaN where ``F_theta`` is exactly
    singular) and its largest component. Each equation's residual sums its nonzero
    terms ``K + sum m1 cos + sum m2 sin (+ sum m3 theta)`` in that order, as the
    compiled kernel does. ``out``: one array per angle to write the step into."""
    C, S = ([np.cos(v) for v in t], [np.sin(v) for v in t]) if cs is None else cs
    f = []
    for e, terms in enumerate(sub._terms):
        a = b = d = None
        for j, m1, m2, m3 in terms:
            a = _acc(a, C[j], m1)
            b = _acc(b, S[j], m2)
            if sub.nd:
                d = _acc(d, t[j], m3)
        fe = k[e] if a is None else k[e] + a
        if b is not None:
            fe = fe + b if fe is k[e] else _iadd(fe, b)
        if d is not None:
            fe = fe + d if fe is k[e] else _iadd(fe, d)
        f.append(fe)
    r = np.abs(f[0])
    for fe in f[1:]:
        np.maximum(r, np.abs(fe), out=r)
    dq = sub.elim.parts(C, S).solve(f, out)
    step = np.abs(dq[0])
    for v in dq[1:]:
        np.maximum(step, np.abs(v), out=step)
    return r, dq, step


def _acc(total, a: np.ndarray, m: float):
    """``total + a * m`` (``total`` None: ``a * m``; ``m`` zero: ``total``)."""
    if not m:
        return total
    t = a * m
    if total is None:
        return t
    total += t
    return total


def _iadd(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    a += b
    return a


def _newton_step(sub, C: np.ndarray, S: np.ndarray, f: np.ndarray, J: np.ndarray):
    """The batched Newton step ``-F_theta^-1 f`` at every position (``J``: room for the
    Jacobians); None where LAPACK finds a matrix singular."""
    if sub.nb <= 2:  # by the adjugate; a singular one gives NaN and fails the caller
        return sub.step_small(C, S, f)
    if sub.elim is not None:  # eliminated to 2 x 2: likewise NaN where singular
        x = sub.elim.parts(C, S).solve([f[:, k] for k in range(sub.nb)])
        out = np.empty(f.shape)
        for k, v in enumerate(x):
            out[:, k] = v
        return out
    try:  # by elimination over the positions (LAPACK where it must)
        if sub.nb <= FLOATS_UP_TO and C.shape[0] >= STACKED_MIN:
            return _lu_solve(sub.lu(C, S), -f)
        Jk = sub.jacobian(C, S, out=J)
        return np.linalg.solve(Jk, -f[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return None
