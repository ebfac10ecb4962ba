"""A Newton group's velocities and accelerations: its block of the differentiated
constraints, solved for all positions at once, and the bound of its conditioning."""

from __future__ import annotations

import math

import numpy as np

from mechsolve.base.state import State
from mechsolve.groups.base import Drive
from mechsolve.groups.reduced import FLOATS_UP_TO, _solve_small


class NewtonRates:
    """Methods of :class:`~mechsolve.groups.generic.NewtonGroup`: see the module
    docstring."""

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

    def _angle_solve(self, st: State, rhs: np.ndarray, rows=None) -> list:
        """``F_theta w = rhs`` (rhs (N, n)) at every position: the angles' rates as one
        1-D array per angle. Two angles by Cramer's rule from the entries
        (:meth:`_angle_entries2`), more from the kept inverse; least squares where
        ``F_theta`` is exactly singular, as a singular body block would get. ``rows``:
        one array per angle (the state's rows) that Cramer's rule and the elimination
        write their rates into, returned as they are where no position is singular."""
        red = self.red
        if red.sub.nb == 0:  # every angle fixed by a driver: theta_k' = sign (u' - K_d')
            w = [None] * red.nb
            for k, r, sg in zip(red.fixed.tolist(), red.frows.tolist(), red.fsign.tolist()):
                w[k] = rhs[:, r] * sg
            return w
        if red.elim is not None:  # eliminated to 2 x 2 (each loop a link of its own)
            parts, nf = self._angle_elim(st)
            w = parts.solve([-rhs[:, k] for k in range(red.nb)], rows)
            sing = ~np.isfinite(nf)
            if sing.any():
                for v in w:
                    v[sing] = np.nan
                out = np.stack(w, axis=1)
            else:
                return w
        elif red.nb == 2:
            a, b, c, d, det, nf = self._angle_entries2(st)
            r0, r1 = rhs[:, 0], rhs[:, 1]
            w0, w1 = (np.empty(st.n), np.empty(st.n)) if rows is None else rows
            with np.errstate(divide="ignore", invalid="ignore"):
                np.multiply(d, r0, out=w0)
                w0 -= b * r1
                w0 /= det
                np.multiply(a, r1, out=w1)
                w1 -= c * r0
                w1 /= det
            sing = ~np.isfinite(nf)
            if not sing.any():  # (nothing to stack for least squares)
                return [w0, w1]
            out = np.stack([w0, w1], axis=1)
            out[sing] = np.nan
        else:
            inv = self._angle_inverse(st)
            out = inv[:, :, 0] * rhs[:, None, 0]  # inv @ rhs, elementwise: small matrices
            for j in range(1, rhs.shape[1]):
                out += inv[:, :, j] * rhs[:, None, j]
            sing = np.isnan(inv[:, 0, 0])
        # exactly singular positions: least squares, as a singular body block would get
        for i in np.flatnonzero(sing & np.all(np.isfinite(rhs), axis=1)) if sing.any() else ():
            t = st.th[self.bodies, i][None]
            J = self.red.jacobian(np.cos(t), np.sin(t))[0]
            if np.all(np.isfinite(J)):
                out[i] = np.linalg.lstsq(J, rhs[i], rcond=None)[0]
        return [out[:, k] for k in range(red.nb)]

    def _angle_elim(self, st: State) -> tuple:
        """:class:`~mechsolve.groups.eliminated.Eliminated` at the poses of ``st`` and
        ``|F_theta^-1|_F`` there (NaN where exactly singular), kept for the same poses (the
        velocities, accelerations, determinants and conditioning bound read them)."""
        th = st.th[self.bodies]
        c = self._elim_cache
        if c is not None and c[0] == st.token and c[1].shape == th.shape and _same(c[1], th):
            return c[2]
        bodies = self.bodies
        parts = self.red.elim.parts([st.c[b] for b in bodies], [st.s[b] for b in bodies])
        out = (parts, parts.inverse_norm())
        self._elim_cache = (st.token, th, out)
        return out

    def _angle_entries2(self, st: State) -> tuple:
        """``F_theta``'s entries ``a, b, c, d`` (rows ``(a, b), (c, d)``) of a group of two
        angles at every position of ``st``, its determinant and ``|F_theta^-1|_F =
        |F_theta|_F / |det|`` (the inverse being the adjugate over the determinant; NaN
        where ``F_theta`` is exactly singular or not finite, as :meth:`_angle_inverse`
        gives the inverse), kept for the same poses as the inverse is."""
        th0, th1 = st.th[self.bodies[0]], st.th[self.bodies[1]]
        c = self._entries2_cache
        if (
            c is not None
            and c[0] == st.token
            and c[1][0].shape == th0.shape
            and _same(c[1][0], th0)
            and _same(c[1][1], th1)
        ):
            return c[2]
        ((a1, a2, a3), (b1, b2, b3)), ((c1, c2, c3), (d1, d2, d3)) = self.red._rows
        C0, C1 = st.c[self.bodies[0]], st.c[self.bodies[1]]
        S0, S1 = st.s[self.bodies[0]], st.s[self.bodies[1]]
        a, b = _entry(a1, a2, a3, C0, S0), _entry(b1, b2, b3, C1, S1)
        cc, d = _entry(c1, c2, c3, C0, S0), _entry(d1, d2, d3, C1, S1)
        det = a * d - b * cc
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            nf = a * a + b * b + cc * cc + d * d
            np.sqrt(nf, out=nf)
            nf /= np.abs(det)
        bad = ~np.isfinite(nf)
        if bad.any():
            nf[bad] = np.nan
        out = (a, b, cc, d, det, nf)
        self._entries2_cache = (st.token, (th0.copy(), th1.copy()), out)
        return out

    def _angle_rates(self, st: State, drive: Drive, order: int, frames: bool = True) -> None:
        """The angles' rates of ``order`` (1, 2) into ``st``, and with ``frames`` the
        frames' (the coarse positions of a batched sweep need the angles' alone)."""
        red = self.red
        nb = red.nb
        if st.n == 1 and nb <= FLOATS_UP_TO:  # (a driven crank too: F_theta = +-1)
            if self._angle_rates_one(st, drive, order):
                return
        K, Px, Py = red.known(st, order)  # fresh arrays: the right-hand side in place
        if red.nd:  # the driver values' rates off the drivers' equations
            K[:, 2 * red.ne :] -= (drive.ud if order == 1 else drive.udd)[:, None]
        rhs = np.negative(K, out=K)
        bodies = self.bodies
        C, S = [st.c[b] for b in bodies], [st.s[b] for b in bodies]  # rows: no copies
        # the frames' rates: r_b = P_b + sum_k A(theta_k) W[b, k] differentiated, with
        # A' = w A(theta + 90 deg) and A'' = al A(theta + 90 deg) - w^2 A: both are
        # sum_k P_k Wr[k] + Q_k Wr[nb + k], P = S w, Q = C w (velocities) or
        # P = S al + C w^2, Q = C al - S w^2
        if order == 1:
            out = (st.vx, st.vy, st.w)
            rows = [out[2][b] for b in bodies]
            w = self._angle_solve(st, rhs, rows)
        else:
            w2 = [st.w[b] * st.w[b] for b in bodies]
            for e, row in enumerate(red._rows[: 2 * red.ne]):  # the closing joints'
                for k, (m1, m2, _) in enumerate(row):  # centripetal terms (no drivers')
                    if m1:
                        rhs[:, e] += (m1 * C[k]) * w2[k]
                    if m2:
                        rhs[:, e] += (m2 * S[k]) * w2[k]
            out = (st.ax, st.ay, st.al)
            rows = [out[2][b] for b in bodies]
            w = self._angle_solve(st, rhs, rows)
        for b, k in self.col.items():  # (written there already by Cramer's rule and the
            if w[k] is not rows[k]:  # elimination: the state's rows given to them)
                out[2][b] = w[k]
        if not frames:
            return
        terms = red.wr_terms()
        if not any(terms):  # every frame at a solved body's point (the four-bar's)
            for b, k in self.col.items():
                out[0][b], out[1][b] = Px[:, k], Py[:, k]
            return
        P, Q = [], []
        for k in range(nb):
            p, q = S[k] * w[k], C[k] * w[k]
            if order == 2:
                p += C[k] * w2[k]
                q -= S[k] * w2[k]
            P.append(p)
            Q.append(q)
        for b, k in self.col.items():  # (into the state's rows: no copies to write back)
            vx, vy = out[0][b], out[1][b]
            vx[...] = Px[:, k]
            vy[...] = Py[:, k]
            for j, px, qx, py, qy in terms[k]:  # the nonzero entries of Wr only
                if px:
                    vx += px * P[j]
                if qx:
                    vx += qx * Q[j]
                if py:
                    vy += py * P[j]
                if qy:
                    vy += qy * Q[j]

    def _coarse_rates(self, st: State, drive: Drive) -> None:
        """The angles' rates (order 1) at the coarse positions of a batched sweep into
        ``st``, as :meth:`_angle_rates` gives them without the frames'. A group
        eliminated to 2 x 2 solves them from the elimination alone: its conditioning
        bound (:meth:`_angle_elim`'s norm of the inverse: some 45 NumPy calls on a few
        dozen positions) is not read there. That bound is NaN only where ``F_theta`` is
        exactly singular, a value is not finite or its square overflows, where
        :meth:`_angle_rates` takes least squares: any rate not finite or determinant
        below 1e-100 (no product of a mechanism's lengths comes near the overflow then)
        sends all positions through :meth:`_angle_rates`, so the rates are the same."""
        red = self.red
        if red.elim is None or red.sub.nb == 0 or (st.n == 1 and red.nb <= FLOATS_UP_TO):
            self._angle_rates(st, drive, 1, frames=False)
            return
        K = red.known(st, 1)[0]  # (fresh: the right-hand side in place)
        if red.nd:
            K[:, 2 * red.ne :] -= drive.ud[:, None]
        rhs = np.negative(K, out=K)
        bodies = self.bodies
        parts = red.elim.parts([st.c[b] for b in bodies], [st.s[b] for b in bodies])
        w = parts.solve([-rhs[:, k] for k in range(red.nb)])
        with np.errstate(invalid="ignore"):
            fine = np.isfinite(w).all() and (np.abs(parts.det) >= 1e-100).all()
        if not fine:
            self._angle_rates(st, drive, 1, frames=False)
            return
        for b, k in self.col.items():
            st.w[b] = w[k]

    def _angle_rates_one(self, st: State, drive: Drive, order: int) -> bool:
        """:meth:`_angle_rates` at one position in Python floats (a NumPy call on
        one-element arrays costs more than its arithmetic): ``F_theta w = rhs`` by
        :func:`~mechsolve.groups.reduced._solve_small`, the frames' rates as there. False
        (nothing written) where ``F_theta`` is exactly singular or a rate is not finite:
        the batched code then takes the position (its least squares)."""
        red = self.red
        nb, ne = red.nb, red.ne
        K, px, py = red.known_one(st, order)
        rhs = [-v for v in K]
        if red.nd:  # the driver values' rates off the drivers' equations
            dv = float((drive.ud if order == 1 else drive.udd)[0])
            for e in range(2 * ne, nb):
                rhs[e] += dv
        bodies = self.bodies
        c = st.c[bodies, 0].tolist()
        s = st.s[bodies, 0].tolist()
        J = [
            [m2 * c[k] - m1 * s[k] + m3 for k, (m1, m2, m3) in enumerate(row)] for row in red._rows
        ]
        if order == 2:
            wd = st.w[bodies, 0].tolist()
            w2 = [v * v for v in wd]
            for e in range(2 * ne):  # the closing joints' centripetal terms
                rhs[e] += sum(
                    (m1 * c[k] + m2 * s[k]) * w2[k] for k, (m1, m2, _) in enumerate(red._rows[e])
                )
        w = _solve_small(J, [-v for v in rhs])
        if w is None or not all(math.isfinite(v) for v in w):
            return False
        P = [sk * wk for sk, wk in zip(s, w)]
        Q = [ck * wk for ck, wk in zip(c, w)]
        if order == 2:
            P = [p + ck * v for p, ck, v in zip(P, c, w2)]
            Q = [q - sk * v for q, sk, v in zip(Q, s, w2)]
        out = (st.vx, st.vy, st.w) if order == 1 else (st.ax, st.ay, st.al)
        Wr = red.wr_list()
        for b, k in self.col.items():
            vx, vy = px[k], py[k]
            for j in range(nb):
                pj, qj = P[j], Q[j]
                vx += pj * Wr[j][k] + qj * Wr[nb + j][k]
                vy += pj * Wr[j][nb + k] + qj * Wr[nb + j][nb + k]
            out[0][b, 0], out[1][b, 0], out[2][b, 0] = vx, vy, w[k]
        return True

    def rcond_bound(self, st: State) -> np.ndarray | None:
        """A lower bound of :func:`mechsolve.core.conditioning.rcond` of the group's block of
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
        if st.n == 1 and red.nb <= FLOATS_UP_TO:  # one position: in floats
            return np.array([1.0 / (c * (a0 + a1 * self._inverse_norm_one(st)))])
        if red.elim is not None:  # from the elimination's blocks, exactly
            nf = self._angle_elim(st)[1]
        elif red.nb == 2:  # from the entries: |F_theta^-1|_F = |F_theta|_F / |det|
            nf = self._angle_entries2(st)[5]
        else:
            inv = self._angle_inverse(st)
            nf = np.sqrt(np.einsum("nij,nij->n", inv, inv))
        return 1.0 / (c * (a0 + a1 * nf))

    def _inverse_norm_one(self, st: State) -> float:
        """``|F_theta^-1|_F`` at the one position of ``st``, in floats: the inverse's
        columns by :func:`~mechsolve.groups.reduced._solve_small` (NaN where ``F_theta``
        is exactly singular or not finite, as :meth:`_angle_inverse` gives it)."""
        red = self.red
        c = st.c[self.bodies, 0].tolist()
        s = st.s[self.bodies, 0].tolist()
        J = [
            [m2 * c[k] - m1 * s[k] + m3 for k, (m1, m2, m3) in enumerate(row)] for row in red._rows
        ]
        nb = red.nb
        if nb == 2:  # the inverse is the adjugate over det: |J^-1|_F = |J|_F / |det J|
            (a, b), (c_, d) = J
            det = a * d - b * c_
            if det == 0:
                return math.nan
            return math.sqrt(a * a + b * b + c_ * c_ + d * d) / abs(det)
        total = 0.0
        for j in range(nb):
            col = _solve_small(J, [-1.0 if i == j else 0.0 for i in range(nb)])
            if col is None:
                return math.nan
            total += sum(v * v for v in col)
        return math.sqrt(total)

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
            if c.letter == "R":
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


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal arrays, NaN equal to NaN (the exact test first, by one comparison: the
    one with NaN costs more)."""
    if a.shape != b.shape:
        return False
    return bool((a == b).all() or np.array_equal(a, b, equal_nan=True))


def _entry(m1: float, m2: float, m3: float, C: np.ndarray, S: np.ndarray) -> np.ndarray:
    """``F_theta``'s entry ``m2 C - m1 S + m3`` (evaluated left to right), its zero
    coefficient's product left out: with ``m2`` zero, ``(+-0) - y = -y`` exactly for
    ``y = m1 S`` nonzero, and a zero ``y`` gives ``m3``, or ``+0`` when ``m3`` is ``+0``
    (as ``(+-0) - (+-0) + 0`` does); likewise with ``m1`` zero. So the values are the
    same bit for bit, in two passes instead of four (the four-bar's loop has a zero
    coefficient in each entry)."""
    plus = m3 != 0.0 or math.copysign(1.0, m3) > 0.0
    if not m2 and plus:
        out = S * -m1
        out += m3
        return out
    if not m1 and plus:
        out = m2 * C
        out += m3
        return out
    return m2 * C - m1 * S + m3
