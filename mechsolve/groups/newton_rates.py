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
        if st.n == 1 and nb <= FLOATS_UP_TO:  # (a driven crank too: F_theta = +-1)
            if self._angle_rates_one(st, drive, order):
                return
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
