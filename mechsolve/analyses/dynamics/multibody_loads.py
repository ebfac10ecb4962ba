"""The file's loads on arrays, for the multibody evaluation at one configuration: torques
and linear springs between points that always act (no ``when``), the common case of the
benchmarks (Andrews' mechanism: a torque and a stiff spring). The general load machinery
(:func:`mechsolve.core.loads.apply_loads`) builds its states and loops over loads for
every position; at one configuration, evaluated a few thousand times a run, that cost
more than the rest of the equations of motion. Any other load (forces, dampers,
conditional loads) keeps the general path; tests/test_issue26_speed.py checks that both
give the same forces, power and potential.

For a spring between point ``a`` (on body ``i``, local ``s_a``) and point ``b`` (body
``j``)::

    d = p_b - p_a,  L = |d|,  e = d / L,  T = k (L - L0)
    Q_i += T (e, r_a x e),   Q_j -= T (e, r_b x e),   V += k (L - L0)^2 / 2

with ``r = R(theta) s`` the point's arm from its body's frame origin.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.model import GROUND, Spring, Torque


class ArrayLoads:
    """Unconditional torques and linear springs of a mechanism, on arrays."""

    def __init__(self, mech, index: dict[str, int], nb: int) -> None:
        self.nb = nb
        torques = [ld for ld in mech.loads if type(ld) is Torque]
        springs = [ld for ld in mech.loads if type(ld) is Spring]
        self.t_body = np.array([index[ld.link] for ld in torques], int)
        self.t_value = np.array([ld.torque for ld in torques], float)
        ends = [[], []]
        for ld in springs:
            for k, (link, point) in enumerate(ld.ends):
                body = nb if link == GROUND else index[link]
                ends[k].append((body, *mech.local_point(link, point)))
        a = np.array(ends[0], float).reshape(-1, 3)
        b = np.array(ends[1], float).reshape(-1, 3)
        self.a, self.sa = a[:, 0].astype(int), a[:, 1:]
        self.b, self.sb = b[:, 0].astype(int), b[:, 1:]
        self.k = np.array([ld.stiffness for ld in springs], float)
        self.l0 = np.array([ld.free_length for ld in springs], float)
        # where each spring end's (fx, fy, moment) goes in Q (the ground's: past its end)
        self._spring_at = np.concatenate(
            [3 * self.a, 3 * self.a + 1, 3 * self.a + 2, 3 * self.b, 3 * self.b + 1, 3 * self.b + 2]
        )
        self._spring_len = 3 * nb + 3
        self._qe = np.zeros(3 * nb + 3)
        self._t_at = 3 * self.t_body + 2
        self._t_unique = len(set(self._t_at.tolist())) == self._t_at.size
        self._t_list: list | None = None  # the loads in Python floats (apply_fast)
        self._s_list: list = []

    @staticmethod
    def applies(mech) -> bool:
        return bool(mech.loads) and all(
            type(ld) in (Torque, Spring) and ld.when is None for ld in mech.loads
        )

    def apply(self, q: np.ndarray, qd: np.ndarray, Q: np.ndarray) -> tuple[float, float]:
        """Add the loads to ``Q`` (nq,); return their non-conservative power (the
        torques') and the springs' potential."""
        P = 0.0
        if self.t_body.size:
            t_at = self._t_at
            if self._t_unique:
                Q[t_at] += self.t_value
            else:
                np.add.at(Q, t_at, self.t_value)
            P = float(self.t_value @ qd[t_at])
        if not self.k.size:
            return P, 0.0
        qe = self._qe
        qe[: q.size] = q  # the ground: at the origin, not turned
        n = self.k.size
        xa, ya, tha, xb, yb, thb = qe[self._spring_at].reshape(6, n)
        ca, sa_, cb, sb_ = np.cos(tha), np.sin(tha), np.cos(thb), np.sin(thb)
        rax = ca * self.sa[:, 0] - sa_ * self.sa[:, 1]
        ray = sa_ * self.sa[:, 0] + ca * self.sa[:, 1]
        rbx = cb * self.sb[:, 0] - sb_ * self.sb[:, 1]
        rby = sb_ * self.sb[:, 0] + cb * self.sb[:, 1]
        xa, ya, xb, yb = xa + rax, ya + ray, xb + rbx, yb + rby
        dx, dy = xb - xa, yb - ya
        L = np.hypot(dx, dy)
        ex, ey = dx / L, dy / L
        T = self.k * (L - self.l0)  # tension: pulls b towards a and a towards b
        fx, fy = T * ex, T * ey
        # the ends' forces and moments summed into Q by one bincount (the ground's end,
        # at the coordinates after q, cut off)
        w = np.concatenate([fx, fy, rax * fy - ray * fx, -fx, -fy, -(rbx * fy - rby * fx)])
        Q += np.bincount(self._spring_at, w, minlength=self._spring_len)[: Q.size]
        return P, float(0.5 * np.sum(T * (L - self.l0)))

    def apply_rows(self, q: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """:meth:`apply` at the rows of ``q`` (n, nq): the loads added to ``Q`` (n, nq);
        returns the springs' potential of each row (the power is not needed there)."""
        n = q.shape[0]
        if self.t_body.size:
            for at, value in zip(self._t_at, self.t_value):
                Q[:, at] += value
        if not self.k.size:
            return np.zeros(n)
        qe = np.zeros((n, 3 * self.nb + 3))
        qe[:, : q.shape[1]] = q
        ns = self.k.size
        xa, ya, tha, xb, yb, thb = qe[:, self._spring_at].reshape(n, 6, ns).transpose(1, 0, 2)
        ca, sa_, cb, sb_ = np.cos(tha), np.sin(tha), np.cos(thb), np.sin(thb)
        rax = ca * self.sa[:, 0] - sa_ * self.sa[:, 1]
        ray = sa_ * self.sa[:, 0] + ca * self.sa[:, 1]
        rbx = cb * self.sb[:, 0] - sb_ * self.sb[:, 1]
        rby = sb_ * self.sb[:, 0] + cb * self.sb[:, 1]
        dx, dy = (xb + rbx) - (xa + rax), (yb + rby) - (ya + ray)
        L = np.hypot(dx, dy)
        T = self.k * (L - self.l0)
        fx, fy = T * (dx / L), T * (dy / L)
        w = np.concatenate([fx, fy, rax * fy - ray * fx, -fx, -fy, -(rbx * fy - rby * fx)], axis=1)
        scatter = np.zeros((6 * ns, self._spring_len))
        scatter[np.arange(6 * ns), self._spring_at] = 1.0
        Q += (w @ scatter)[:, : Q.shape[1]]
        return 0.5 * np.sum(T * (L - self.l0), axis=1)

    def apply_fast(
        self, q: np.ndarray, qd: np.ndarray, c: np.ndarray, s: np.ndarray, Q: np.ndarray
    ) -> float:
        """:meth:`apply` from the bodies' ``cos theta``, ``sin theta`` (``c``, ``s``),
        each load in Python floats (a few of them: cheaper than arrays); returns the
        torques' power (the springs' potential is not needed there)."""
        P = 0.0
        if self._t_list is None:
            self._t_list = [(int(at), float(v)) for at, v in zip(self._t_at, self.t_value)]
            self._s_list = [
                (int(ia), *map(float, sa), int(ib), *map(float, sb), float(k), float(l0))
                for ia, sa, ib, sb, k, l0 in zip(self.a, self.sa, self.b, self.sb, self.k, self.l0)
            ]
        for at, value in self._t_list:
            Q[at] += value
            P += value * float(qd[at])
        if not self._s_list:
            return P
        ql, cl, sl, nb = q.tolist(), c.tolist(), s.tolist(), self.nb
        for ia, sax, say, ib, sbx, sby, k, l0 in self._s_list:
            ca, sa_, xa, ya = (
                (cl[ia], sl[ia], ql[3 * ia], ql[3 * ia + 1]) if ia < nb else (1, 0, 0, 0)
            )
            cb, sb_, xb, yb = (
                (cl[ib], sl[ib], ql[3 * ib], ql[3 * ib + 1]) if ib < nb else (1, 0, 0, 0)
            )
            rax, ray = ca * sax - sa_ * say, sa_ * sax + ca * say
            rbx, rby = cb * sbx - sb_ * sby, sb_ * sbx + cb * sby
            dx, dy = (xb + rbx) - (xa + rax), (yb + rby) - (ya + ray)
            L = math.hypot(dx, dy)
            T = k * (L - l0)
            fx, fy = T * (dx / L), T * (dy / L)
            if ia < nb:
                Q[3 * ia] += fx
                Q[3 * ia + 1] += fy
                Q[3 * ia + 2] += rax * fy - ray * fx
            if ib < nb:
                Q[3 * ib] -= fx
                Q[3 * ib + 1] -= fy
                Q[3 * ib + 2] -= rbx * fy - rby * fx
        return P
