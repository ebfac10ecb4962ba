"""One evaluation of the integrator's right-hand side for a mechanism of pins with the
loads on arrays (:attr:`~.multibody.Multibody.lite`), in as few numpy calls as it takes:
at a mechanism's sizes (tens of coordinates) each call costs more than its arithmetic.

The same equations as :meth:`~.multibody.Multibody.close`, :meth:`~.multibody.Multibody.
rates` and :meth:`~.multibody.Multibody.accelerations` (tests/test_issue26_lite.py
compares them), written so that the configuration enters through ``(q, cos theta,
sin theta)`` linearly: a pin's equation ``r_a + R(theta_a) s_a - r_b - R(theta_b) s_b``
is, with ``R(theta) s = (c s_x - s s_y, s s_x + c s_y)``, one constant matrix times
``(q, c, s, 1)`` (the ground's ends in the last column); ``gamma = K (c w^2, s w^2)`` with
the same coefficients ``K`` of ``(c, s)``; the Jacobian's angle columns are
``K_s c - K_c s``. The augmented matrix ``[M Phi_r^T; Phi_r 0]`` is kept between
evaluations: only the entries that move (the centres of mass's arms in ``M``, the angle
columns of ``Phi_r``) are written, by flat index.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.analyses.dynamics.multibody import (
    NEWTON_ITERATIONS,
    RECONDITION,
    NotClosing,
    Repartition,
    _least_squares,
    _lu,
)


class LiteEquations:
    """The right-hand side ``d/dt (q, q', W)`` on a partition, for a lite mechanism."""

    def __init__(self, mb) -> None:
        pins, nb, nq = mb.pins, mb.nb, mb.nq
        self.mb, self.nb, self.nq = mb, nb, nq
        n = len(pins.a)
        Kc, Ks = np.zeros((2 * n, nb)), np.zeros((2 * n, nb))
        k0 = np.zeros(2 * n)  # the ground's ends (theta = 0)
        for k in range(n):
            for body, (sx, sy), sign in (
                (pins.a[k], pins.sa[k], 1.0),
                (pins.b[k], pins.sb[k], -1.0),
            ):
                if body == nb:
                    k0[2 * k] += sign * sx
                    k0[2 * k + 1] += sign * sy
                    continue
                Kc[2 * k, body] += sign * sx
                Ks[2 * k, body] -= sign * sy
                Kc[2 * k + 1, body] += sign * sy
                Ks[2 * k + 1, body] += sign * sx
        self.Kc, self.Ks, self.K = Kc, Ks, np.hstack([Kc, Ks])
        # Phi = R (q, c, s, 1)
        self.R = np.hstack([pins._pa - pins._pb, Kc, Ks, k0[:, None]])
        self.template = pins.template
        self._v = np.empty(nq + 2 * nb + 1)
        self._v[-1] = 1.0
        loads = mb.array_loads
        self.torques = loads is not None and loads.t_body.size > 0
        self.springs = loads is not None and loads.k.size > 0
        self._parts: dict = {}
        from scipy.linalg.lapack import dgesv, dgetrs

        self._gesv, self._getrs = dgesv, dgetrs  # looked up once, not at each call

    def _part(self, part):
        """What a partition fixes: the rows' matrices, the blocks' flat indices, the
        augmented matrix with its constant entries."""
        got = self._parts.get(id(part))
        if got is not None and got[0] is part:
            return got[1]
        mb, nq, nb = self.mb, self.nq, self.nb
        rows, dep, ind = part.rows, part.dep, part.ind
        r = len(rows)
        N = nq + r
        A = np.zeros((N, N))
        flat = A.reshape(-1)
        i = np.arange(nb) * 3
        # the mass matrix's constant diagonal and the constant entries of Phi_r
        flat[np.concatenate([i * (N + 1), (i + 1) * (N + 1), (i + 2) * (N + 1)])] = mb._m_const
        A[nq:, :nq] = self.template[rows]
        A[:nq, nq:] = self.template[rows].T
        j = nq + np.arange(r)
        th = i + 2
        p = {
            "every": r == mb.nc,
            "R": self.R[rows],
            "rows": rows,
            "dep": dep,
            "ind": ind,
            "dd": rows[:, None] * nq + dep[None, :],
            "dz": rows[:, None] * nq + ind[None, :],
            "A": A,
            "flat": flat,
            "b": np.empty(N),
            # M's arms: (x, theta), (theta, x), (y, theta), (theta, y)
            "mx": np.concatenate([i * N + i + 2, (i + 2) * N + i]),
            "my": np.concatenate([(i + 1) * N + i + 2, (i + 2) * N + i + 1]),
            # the angle columns of Phi_r and of its transpose
            "jt": np.concatenate(
                [(j[:, None] * N + th[None, :]).ravel(), (th[None, :] * N + j[:, None]).ravel()]
            ),
        }
        p["moving"] = np.concatenate([p["mx"], p["my"], p["jt"]])  # all written at once
        self._parts[id(part)] = (part, p)
        return p

    def _phi(self, p, q, c, s) -> np.ndarray:
        v = self._v
        nq, nb = self.nq, self.nb
        v[:nq] = q
        v[nq : nq + nb] = c
        v[nq + nb : nq + 2 * nb] = s
        return p["R"] @ v

    def rhs(self, run, part, t: float, y: np.ndarray) -> np.ndarray:
        """``d/dt (q, q', W)`` at the integrated state ``y`` (as :meth:`_Run.rhs`)."""
        mb, nq = self.mb, self.nq
        p = self._part(part)
        mb.nfev += 1
        q, c, s = self._close(p, part, y[:nq].copy())
        # the rates: Phi_q q' = 0 (pins)
        J = self.template.copy()
        J[:, 2::3] = self.Ks * c - self.Kc * s
        lu, rc = _lu(J.take(p["dd"]))
        mb.rc = rc
        if lu is None or rc < RECONDITION * part.rcond1:
            raise Repartition
        mb._chord = (part, lu)
        qd = np.empty(nq)
        zd = y[nq + part.ind]
        qd[part.ind] = zd
        qd[part.dep] = self._getrs(lu[0], lu[1], -(J.take(p["dz"]) @ zd))[0]
        x, P = self._accelerations(p, q, qd, c, s, J, t)
        out = np.empty(2 * nq + 1)
        out[:nq] = qd
        out[nq:-1] = x[:nq]
        out[-1] = P
        mb._last = (t, q, qd, out[nq:-1])
        run.last_rc = (t, y, rc)
        return out

    def _close(self, p, part, q: np.ndarray):
        """Newton (the chord of the last factors while it converges) on the partition's
        equations for the dependent coordinates: ``(q, cos theta, sin theta)``."""
        mb, dgetrs = self.mb, self._getrs
        chord = mb._chord
        lu = chord[1] if chord is not None and chord[0] is part else None
        dep, last = p["dep"], math.inf
        for _ in range(NEWTON_ITERATIONS):
            th = q[2::3]
            c, s = np.cos(th), np.sin(th)
            phi = self._phi(p, q, c, s)
            size = float(np.abs(phi).max())
            if not math.isfinite(size):
                raise Repartition
            if size <= mb.tol:
                return q, c, s
            if lu is None or size > 0.1 * last:
                J = self.template.copy()
                J[:, 2::3] = self.Ks * c - self.Kc * s
                lu = _lu(J.take(p["dd"]))[0]
                if lu is None:
                    raise Repartition
            last = size
            q[dep] -= dgetrs(lu[0], lu[1], phi)[0]
        raise Repartition

    def _accelerations(self, p, q, qd, c, s, J, t: float):
        """``(x, P)``: the augmented system's solution ``(q'', lambda_r)`` and the power
        of the torques."""
        mb, nq = self.mb, self.nq
        m = mb.m
        rx, ry = c * mb._sx - s * mb._sy, s * mb._sx + c * mb._sy
        flat, b = p["flat"], p["b"]
        jth = (J[:, 2::3] if p["every"] else J[p["rows"], 2::3]).ravel()
        mry, mrx = -m * ry, m * rx
        flat[p["moving"]] = np.concatenate([mry, mry, mrx, mrx, jth, jth])
        w = qd[2::3]
        w2 = w * w
        Q = b[:nq]
        Q[0::3] = m * (mb.gx + w2 * rx)
        Q[1::3] = m * (mb.gy + w2 * ry)
        Q[2::3] = m * (rx * mb.gy - ry * mb.gx)
        P = 0.0
        if self.torques or self.springs:
            P = mb.array_loads.apply_fast(q, qd, c, s, Q)
        g = self.K @ np.concatenate([c * w2, s * w2])
        b[nq:] = g if p["every"] else g[p["rows"]]
        A = p["A"]
        _, _, x, info = self._gesv(A, b)
        if info != 0:  # a singular position: the least-squares motion
            x = _least_squares(A, b)
        if not math.isfinite(float(x.sum())):
            raise NotClosing(
                t, "the accelerations are not determined (a massless link that can move?)"
            )
        return x, P
