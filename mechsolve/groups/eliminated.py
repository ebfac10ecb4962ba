"""A revolute group's ``F_theta`` eliminated to 2 x 2 where each loop has a link of its
own (the Stephenson triad's two loops), for its batched Newton steps, determinants,
rates and conditioning bound over many positions (see :mod:`.reduced`).

A loop's closing equations are ``F_e = K_e + sum_k A(theta_k) V[e, k]`` (two rows, x
and y). When a link ``p`` appears in loop ``e`` only (its column of ``F_theta`` is zero
in every other row), its column there is ``perp(g)``, ``g = A(theta_p) V[e, p]``, so
that dotting the loop's two rows with ``g`` removes ``p`` and dotting them with
``perp(g)`` leaves ``|g|^2 = |V[e, p]|^2`` (a constant) in ``p``'s column. With one such
link per loop, the group's ``n`` angles split into the ``n - ne`` others, solved from
the dotted rows and the drivers' (an ``(n - ne)``-square system ``R``: here 2 x 2, by
Cramer's rule), and the loops' own links, each from its loop's perpendicular row. In
block form, with the orthogonal ``Q`` that turns each loop's rows onto ``g / |g|`` and
``perp(g) / |g|``, ``Q F_theta = [[A, 0], [X, D]]`` with ``A`` the rows of ``R`` over
``|g|`` (the drivers' unscaled), ``X`` the perpendicular rows' other entries over
``|g|`` and ``D = diag(|g|)``, so that

* ``det F_theta = sigma det R`` with a constant sign ``sigma`` (``det Q = 1``, and the
  block determinant is ``det A prod |g| = det R``);
* ``|F_theta^-1|_F^2 = |A^-1|_F^2 + |D^-1 X A^-1|_F^2 + sum 1 / |g|^2`` exactly
  (``F_theta^-1 = (Q F_theta)^-1 Q`` and ``Q`` is orthogonal).

The lean programs written by hand for one mechanism solve the triad this way; here the
split is found from the equations' coefficients, not from the links' names.
"""

from __future__ import annotations

import math

import numpy as np


class Eliminated:
    """The elimination of an :class:`~mechsolve.groups.reduced._Eqs` whose first ``2
    ne`` rows are ``ne`` loops' x and y rows (``e`` and ``ne + e``) and whose other rows
    are drivers'. Raises ValueError where the equations do not have a link of their own
    per loop, or the system left is not 2 x 2."""

    def __init__(self, eqs, ne: int) -> None:
        nb = eqs.nb
        M1, M2, M3, nz = eqs.M1, eqs.M2, eqs.M3, eqs.nzm
        if ne < 1 or nb - ne != 2:
            raise ValueError("not a 2 x 2 elimination")
        priv: list[int] = []
        for e in range(ne):
            ex, ey = e, ne + e
            for p in range(nb):
                rows = set(np.flatnonzero(nz[:, p]).tolist())
                vx, vy = float(M1[ex, p]), float(M1[ey, p])
                if (
                    p not in priv
                    and rows <= {ex, ey}
                    and not M3[:, p].any()
                    and (vx or vy)
                    and M2[ex, p] == -vy
                    and M2[ey, p] == vx
                ):
                    priv.append(p)
                    break
            else:
                raise ValueError("a loop without a link of its own")
        self.ne, self.priv = ne, priv
        self.rest = [k for k in range(nb) if k not in priv]
        self.V = [(float(M1[e, p]), float(M1[ne + e, p])) for e, p in enumerate(priv)]
        self.n2 = [vx * vx + vy * vy for vx, vy in self.V]
        # the rows of R: the loops' dotted rows, then the drivers'; A = R / s by rows
        self.s = [math.sqrt(v) for v in self.n2] + [1.0] * (2 - ne)
        self.coef = [
            [(float(M1[r, q]), float(M2[r, q]), float(M3[r, q])) for q in self.rest]
            for r in range(nb)
        ]
        self.nb = nb
        self.sigma = 1.0
        self.sigma = self._sign(eqs)

    def _sign(self, eqs) -> float:
        """``det F_theta / det R`` (+-1) at a few poses; ValueError if it is not +-1
        there (the structure is not the one assumed)."""
        rng = np.random.default_rng(7)
        th = rng.uniform(-math.pi, math.pi, (4, self.nb))
        C, S = np.cos(th), np.sin(th)
        want = np.linalg.det(eqs.jacobian(C, S))
        got = self.parts(C, S).det
        ratio = want / got
        if not np.allclose(np.abs(ratio), 1.0, rtol=1e-9, atol=0):
            raise ValueError("the elimination does not reproduce F_theta")
        sigma = float(np.sign(ratio[0]))
        if not np.all(np.sign(ratio) == sigma):
            raise ValueError("the elimination's sign is not constant")
        return sigma

    def parts(self, C, S) -> _Parts:
        """The elimination at the angles whose cosines and sines are ``C``, ``S``: (N,
        n) arrays, or sequences of n 1-D arrays (one per angle)."""
        return _Parts(self, C, S)


def _col(A, k):
    return A[:, k] if isinstance(A, np.ndarray) and A.ndim == 2 else A[k]


def _acc(total, a, b, out=None):
    """``total + a * b`` (None for zero terms); ``out``: where a first term goes."""
    if a is None or b is None:
        return total
    if total is None:
        return a * b if out is None else np.multiply(a, b, out=out)
    t = a * b
    total += t
    return total


class _Parts:
    """:class:`Eliminated` at given poses: each loop's ``g``, the entries of ``R`` and of
    the perpendicular rows ``P`` over the other angles, and ``det R``."""

    def __init__(self, el: Eliminated, C, S) -> None:
        self.el = el
        ne = el.ne
        cols = [(_col(C, q), _col(S, q)) for q in el.rest]

        def entry(r: int, j: int):
            m1, m2, m3 = el.coef[r][j]
            c, s = cols[j]
            if m1 and m2:
                a = m2 * c
                a -= m1 * s
            elif m2:
                a = m2 * c
            elif m1:
                a = -m1 * s
            else:
                return m3 if m3 else None
            if m3:
                a += m3
            return a

        g = []
        for e, p in enumerate(el.priv):
            vx, vy = el.V[e]
            c, s = _col(C, p), _col(S, p)
            if vy == 0.0:  # (a link's x axis along it: the products by zero left out,
                g.append((vx * c, vx * s))  # which change no bit but a zero's sign)
                continue
            gx = vx * c
            gx -= vy * s
            gy = vy * c
            gy += vx * s
            g.append((gx, gy))
        R, P = [], []
        for e in range(ne):
            gx, gy = g[e]
            Jx = [entry(e, j) for j in range(2)]
            Jy = [entry(ne + e, j) for j in range(2)]
            R.append([_acc(_acc(None, gx, Jx[j]), gy, Jy[j]) for j in range(2)])
            P.append([_acc(_acc(None, -gy, Jx[j]), gx, Jy[j]) for j in range(2)])
        for r in range(2 * ne, el.nb):  # the drivers' rows: their own entries
            R.append([entry(r, j) for j in range(2)])
        self.g, self.R, self.P = g, R, P
        (a, b), (c, d) = R
        n = cols[0][0].shape[0]
        det = _acc(_acc(None, a, d), b, c if c is None else -c)
        self.det = np.zeros(n) if det is None else det + np.zeros(n) if np.ndim(det) == 0 else det

    def solve(self, f: list, out=None) -> list:
        """``delta`` (a 1-D array per angle) with ``F_theta delta = -f`` (``f``: a 1-D
        array per equation); NaN or inf where ``F_theta`` is exactly singular. ``out``:
        one array per angle to write ``delta`` into (the same operations)."""
        el, ne = self.el, self.el.ne
        o = [None] * el.nb if out is None else out
        rhs = []
        for e in range(ne):
            gx, gy = self.g[e]
            r = gx * f[e]
            r += gy * f[ne + e]
            rhs.append(r)
        rhs += [f[r] for r in range(2 * ne, el.nb)]
        (a, b), (c, d) = self.R
        with np.errstate(divide="ignore", invalid="ignore"):
            r0, r1 = el.rest
            x0 = _acc(_acc(None, b, rhs[1], o[r0]), d if d is None else -d, rhs[0], o[r0])
            x0 /= self.det
            x1 = _acc(_acc(None, c, rhs[0], o[r1]), a if a is None else -a, rhs[1], o[r1])
            x1 /= self.det
        res: list = [None] * el.nb
        res[el.rest[0]], res[el.rest[1]] = x0, x1
        for e, p in enumerate(el.priv):
            gx, gy = self.g[e]
            t = gx * f[ne + e] if o[p] is None else np.multiply(gx, f[ne + e], out=o[p])
            t -= gy * f[e]
            t = _acc(_acc(t, self.P[e][0], x0), self.P[e][1], x1)
            t *= -1.0 / el.n2[e]
            res[p] = t
        return res

    def dets(self) -> np.ndarray:
        """``det F_theta``."""
        return self.det * self.el.sigma if self.el.sigma != 1.0 else self.det

    def inverse_norm(self) -> np.ndarray:
        """``|F_theta^-1|_F`` (NaN where ``F_theta`` is exactly singular or a value is
        not finite), from the block formulas of the module docstring."""
        el, ne = self.el, self.el.ne
        (a, b), (c, d) = self.R
        s0, s1 = el.s
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            inv = 1.0 / self.det
            # A^-1 = R^-1 diag(s): [[d s0, -b s1], [-c s0, a s1]] / det
            Ai = [
                [None if d is None else d * (s0 * inv), None if b is None else b * (-s1 * inv)],
                [None if c is None else c * (-s0 * inv), None if a is None else a * (s1 * inv)],
            ]
            total = sum(1.0 / v for v in el.n2) + np.zeros_like(inv)
            for row in Ai:
                for v in row:
                    if v is not None:
                        total += v * v
            for e in range(ne):
                P0, P1 = self.P[e]
                for j in range(2):
                    y = _acc(_acc(None, P0, Ai[0][j]), P1, Ai[1][j])
                    if y is not None:
                        y *= 1.0 / el.n2[e]
                        total += y * y
            np.sqrt(total, out=total)
        bad = ~np.isfinite(total)
        if bad.any():
            total[bad] = np.nan
        return total
