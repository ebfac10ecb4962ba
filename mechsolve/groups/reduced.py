"""A revolute Newton group in its links' angles alone (reduced coordinates): a spanning
tree places the frames, the loop equations F = K + sum A(theta) V are solved in the
angles (see :mod:`.generic`)."""

from __future__ import annotations

import math

import numpy as np

from mechsolve.base.newton import SolveStats
from mechsolve.base.state import State
from mechsolve.groups.eliminated import Eliminated
from mechsolve.system.constraints import AngleDriverConstraint


class _Eqs:
    """Equations ``F = K + [M1 M2 M3] (cos theta, sin theta, theta)`` in angles."""

    def __init__(self, M: np.ndarray) -> None:
        nb = M.shape[0]
        self.nb = nb
        self.MT = M.T.copy()
        self.M1, self.M2 = M[:, :nb].copy(), M[:, nb : 2 * nb].copy()
        self.M3 = M[:, 2 * nb :].copy()
        self.nd = bool(np.any(self.M3))
        # which entries of F_theta can be nonzero (the stacked elimination skips others)
        self.nzm = (self.M1 != 0) | (self.M2 != 0) | (self.M3 != 0)
        # F_theta eliminated to 2 x 2 where each loop has a link of its own (see
        # _Angles: set there, where the loops' rows are known)
        self.elim: Eliminated | None = None
        # rows of (M1, M2, M3) as Python floats, for one small position at a time
        self._rows = [
            tuple(zip(self.M1[e].tolist(), self.M2[e].tolist(), self.M3[e].tolist()))
            for e in range(nb)
        ]
        self._terms = [
            [(k, m1, m2, m3) for k, (m1, m2, m3) in enumerate(row) if m1 or m2 or m3]
            for row in self._rows
        ]

    def det_ratio(self, th: list) -> float:
        """Hadamard's ratio of ``F_theta`` at the angles ``th`` (a list of up to four
        floats): ``det F_theta`` over the product of its rows' lengths, between -1 and 1,
        0 where it is singular or not finite. The same operations in the same order as
        the NumPy form (``M2 cos - M1 sin + M3``, :func:`_det_small`, the rows' norms
        and their product, both summed left to right as NumPy does for so few terms),
        in Python floats: a sequential sweep asks for it at every position, where a
        NumPy call per operation cost more than the arithmetic (~25 us a position)."""
        if len(th) == 2:  # unrolled: the four-bar's loop (the same operations)
            return self._det_ratio2(th[0], th[1])
        cos, sin = math.cos, math.sin
        nd = self.nd
        try:
            c = [cos(v) for v in th]
            s = [sin(v) for v in th]
        except ValueError:  # an infinite angle (NumPy's cosine gives NaN there)
            return 0.0
        J = []
        p = 1.0
        for row in self._rows:
            Je = [
                m2 * ck - m1 * sk + (m3 if nd else 0.0) for (m1, m2, m3), ck, sk in zip(row, c, s)
            ]
            J.append(Je)
            q = 0.0
            for v in Je:
                q += v * v
            p *= math.sqrt(q)
        det = _det_list(J)
        if p == 0.0:  # (NumPy's division gives inf or NaN there: not finite)
            return 0.0
        d = det / p
        return d if math.isfinite(d) else 0.0

    def _det_ratio2(self, x0: float, x1: float) -> float:
        """:meth:`det_ratio` for two angles, unrolled."""
        ((a1, a2, a3), (b1, b2, b3)), ((c1, c2, c3), (d1, d2, d3)) = self._rows
        if not self.nd:
            a3 = b3 = c3 = d3 = 0.0
        try:
            C0, C1, S0, S1 = math.cos(x0), math.cos(x1), math.sin(x0), math.sin(x1)
        except ValueError:  # an infinite angle (NumPy's cosine gives NaN there)
            return 0.0
        ja, jb = a2 * C0 - a1 * S0 + a3, b2 * C1 - b1 * S1 + b3
        jc, jd = c2 * C0 - c1 * S0 + c3, d2 * C1 - d1 * S1 + d3
        p = math.sqrt(ja * ja + jb * jb) * math.sqrt(jc * jc + jd * jd)
        if p == 0.0:
            return 0.0
        d = (ja * jd - jb * jc) / p
        return d if math.isfinite(d) else 0.0

    def newton_floats(
        self, K, th0, atol: float, max_iterations: int
    ) -> tuple[np.ndarray, SolveStats]:
        """:func:`~mechsolve.base.newton.newton_lean` on ``F = 0`` at one position,
        with ``K`` (n,) the constant part, in Python floats (up to :data:`FLOATS_UP_TO`
        angles: a stacked NumPy call per operation costs more than the arithmetic
        there). Same
        convergence test; no scipy fallback (the caller's)."""
        x, ok, it, r, nfev = self.newton_list(K, th0, atol, max_iterations)
        return np.array(x), SolveStats(ok, "newton", it, nfev, nfev, r)

    def newton_list(self, K, th0, atol: float, max_iterations: int, predict: bool = False):
        """:meth:`newton_floats` as ``(angles (list), converged, iterations, residual,
        evaluations)``:
        the coarse continuation's form, without an array and a record per position.

        With ``predict``, a step that leaves an error predicted below ``1e-3 atol`` (the
        steps contracting, ``2 step^2 / last <= 1e-3 atol``: see
        :func:`~mechsolve.groups.newton_batched._converges_next`) is taken and ends the
        iteration, converged, without evaluating the residual once more; the residual
        returned is then the one before that step (the caller checks the whole system's
        residual afterwards)."""
        nb = self.nb
        x = [float(v) for v in th0]
        K = [float(v) for v in K]
        xtol = 1e-3 * atol
        last = r = r_prev = math.inf
        cos, sin = math.cos, math.sin
        if nb == 2:  # unrolled: the four-bar's loop, the commonest group
            return self._newton_list2(K, x, atol, max_iterations, predict)
        if nb == 4:  # unrolled: the Stephenson triad's four angles
            return self._newton_list4(K, x, atol, max_iterations, predict)
        terms = self._terms
        for it in range(max_iterations + 1):
            c = [cos(v) for v in x]
            s = [sin(v) for v in x]
            f = []
            J = []
            for e in range(nb):
                fe = K[e]
                Je = [0.0] * nb
                for k, m1, m2, m3 in terms[e]:  # the nonzero ones only
                    ck, sk = c[k], s[k]
                    fe += m1 * ck + m2 * sk + m3 * x[k]
                    Je[k] = m2 * ck - m1 * sk + m3
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
            if predict and step <= 0.5 * last < math.inf and 2 * step * step <= xtol * last:
                return x, True, it + 1, r, it + 1
            last = step
        return x, r <= atol, max_iterations, r, max_iterations

    def _newton_list2(self, K, x, atol: float, max_iterations: int, predict: bool):
        """:meth:`newton_list` for two angles, unrolled (the four-bar's loop)."""
        rows = self._rows
        xtol = 1e-3 * atol
        last = r = r_prev = math.inf
        cos, sin = math.cos, math.sin
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
            if predict and step <= 0.5 * last < math.inf and 2 * step * step <= xtol * last:
                return [x0, x1], True, it + 1, r, it + 1
            last = step
        return [x0, x1], r <= atol, max_iterations, r, max_iterations

    def _newton_list4(self, K, x, atol: float, max_iterations: int, predict: bool):
        """:meth:`newton_list` for four angles, unrolled: every coefficient a local,
        the residual's terms added in the order of :meth:`newton_list` (a term of zero
        coefficients adds a zero: no bit changes but a zero's sign), the step by
        :func:`_solve4`."""
        (
            ((p00, q00, r00), (p01, q01, r01), (p02, q02, r02), (p03, q03, r03)),
            ((p10, q10, r10), (p11, q11, r11), (p12, q12, r12), (p13, q13, r13)),
            ((p20, q20, r20), (p21, q21, r21), (p22, q22, r22), (p23, q23, r23)),
            ((p30, q30, r30), (p31, q31, r31), (p32, q32, r32), (p33, q33, r33)),
        ) = self._rows
        xtol = 1e-3 * atol
        last = r = r_prev = math.inf
        cos, sin = math.cos, math.sin
        k0, k1, k2, k3 = K
        x0, x1, x2, x3 = x
        for it in range(max_iterations + 1):
            c0, c1, c2, c3 = cos(x0), cos(x1), cos(x2), cos(x3)
            s0, s1, s2, s3 = sin(x0), sin(x1), sin(x2), sin(x3)
            f0 = k0 + (p00 * c0 + q00 * s0 + r00 * x0)
            f0 += p01 * c1 + q01 * s1 + r01 * x1
            f0 += p02 * c2 + q02 * s2 + r02 * x2
            f0 += p03 * c3 + q03 * s3 + r03 * x3
            f1 = k1 + (p10 * c0 + q10 * s0 + r10 * x0)
            f1 += p11 * c1 + q11 * s1 + r11 * x1
            f1 += p12 * c2 + q12 * s2 + r12 * x2
            f1 += p13 * c3 + q13 * s3 + r13 * x3
            f2 = k2 + (p20 * c0 + q20 * s0 + r20 * x0)
            f2 += p21 * c1 + q21 * s1 + r21 * x1
            f2 += p22 * c2 + q22 * s2 + r22 * x2
            f2 += p23 * c3 + q23 * s3 + r23 * x3
            f3 = k3 + (p30 * c0 + q30 * s0 + r30 * x0)
            f3 += p31 * c1 + q31 * s1 + r31 * x1
            f3 += p32 * c2 + q32 * s2 + r32 * x2
            f3 += p33 * c3 + q33 * s3 + r33 * x3
            r = max(abs(f0), abs(f1), abs(f2), abs(f3))
            if not r <= 1e300 or (it > 3 and r > 2 * r_prev):  # not finite, diverging
                break
            r_prev = r
            if r <= atol and (last <= xtol or r == 0.0):
                return [x0, x1, x2, x3], True, it, r, it + 1
            if it == max_iterations:
                break
            a00, a01 = q00 * c0 - p00 * s0 + r00, q01 * c1 - p01 * s1 + r01
            a02, a03 = q02 * c2 - p02 * s2 + r02, q03 * c3 - p03 * s3 + r03
            a10, a11 = q10 * c0 - p10 * s0 + r10, q11 * c1 - p11 * s1 + r11
            a12, a13 = q12 * c2 - p12 * s2 + r12, q13 * c3 - p13 * s3 + r13
            a20, a21 = q20 * c0 - p20 * s0 + r20, q21 * c1 - p21 * s1 + r21
            a22, a23 = q22 * c2 - p22 * s2 + r22, q23 * c3 - p23 * s3 + r23
            a30, a31 = q30 * c0 - p30 * s0 + r30, q31 * c1 - p31 * s1 + r31
            a32, a33 = q32 * c2 - p32 * s2 + r32, q33 * c3 - p33 * s3 + r33
            dx = _solve4(
                (
                    (a00, a01, a02, a03),
                    (a10, a11, a12, a13),
                    (a20, a21, a22, a23),
                    (a30, a31, a32, a33),
                ),
                (f0, f1, f2, f3),
            )
            if dx is None:
                break
            dx0, dx1, dx2, dx3 = dx
            step = max(abs(dx0), abs(dx1), abs(dx2), abs(dx3))
            if not step <= 1e300:
                break
            if r <= atol and step >= last:  # converged already: rounding level
                return [x0, x1, x2, x3], True, it, r, it + 1
            x0, x1, x2, x3 = x0 + dx0, x1 + dx1, x2 + dx2, x3 + dx3
            if predict and step <= 0.5 * last < math.inf and 2 * step * step <= xtol * last:
                return [x0, x1, x2, x3], True, it + 1, r, it + 1
            last = step
        return [x0, x1, x2, x3], r <= atol, max_iterations, r, max_iterations

    def entries(self, C, S) -> list:
        """``F_theta``'s entries as :class:`_StackedLU` takes them: 1-D arrays over the
        positions (None where always zero), from the angles' cosines and sines ``C``,
        ``S`` (N, n): no (N, n, n) array, whose broadcast products over a last axis of
        n cost several times more than the n^2 entries' arithmetic."""
        out = []
        for row in self._rows:
            r = []
            for k, (m1, m2, m3) in enumerate(row):
                if not (m1 or m2 or m3):
                    r.append(None)
                    continue
                c, s = C[:, k], S[:, k]
                if m1 and m2:
                    a = m2 * c
                    a -= m1 * s
                elif m2:
                    a = m2 * c
                elif m1:
                    a = -m1 * s
                else:
                    a = np.zeros(C.shape[0])
                if m3:
                    a += m3
                r.append(a)
            out.append(r)
        return out

    def lu(self, C, S) -> _StackedLU:
        """:class:`_StackedLU` of ``F_theta`` at the angles whose cosines and sines are
        ``C``, ``S`` (N, n)."""
        return _StackedLU(self.entries(C, S), C.shape[0])

    def lu_kept(self, C, S) -> _StackedLU:
        """:meth:`lu`, kept for the same cosines and sines: a sweep's determinants
        (the sign-change test) and its rates' inverse factor ``F_theta`` at the same
        solved poses, one after the other."""
        c = getattr(self, "_lu_kept", None)
        if c is not None and c[0].shape == C.shape and np.array_equal(c[0], C):
            if np.array_equal(c[1], S):
                return c[2]
        lu = self.lu(C, S)
        self._lu_kept = (np.array(C), np.array(S), lu)
        return lu

    def dets(self, C, S) -> np.ndarray:
        """``det F_theta`` (N,) at the angles whose cosines and sines are ``C``, ``S``."""
        if self.nb == 1:
            return self.M2[0, 0] * C[:, 0] - self.M1[0, 0] * S[:, 0] + self.M3[0, 0]
        if self.nb == 2:  # from the entries: no (N, 2, 2) array
            (a, b), (c, d) = self.entries(C, S)
            if a is None or d is None:
                return -(b * c) if b is not None and c is not None else np.zeros(C.shape[0])
            det = a * d
            if b is not None and c is not None:
                det -= b * c
            return det
        if self.elim is not None:  # from the 2 x 2 elimination
            return self.elim.parts(C, S).dets()
        if self.nb <= FLOATS_UP_TO and C.shape[0] >= STACKED_MIN:
            return _lu_det(self.lu_kept(C, S))
        return np.linalg.det(self.jacobian(C, S))

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
        if 2 < self.nb <= FLOATS_UP_TO and C.shape[0] >= STACKED_MIN:
            return _lu_inverse(self.lu_kept(C, S))
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
        revs = [c for c in constraints if c.letter == "R"]
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
        self.free_list = self.free.tolist()  # (one position in floats: join_one, _det)
        self.fixed_list = [int(k) for k in fixed]
        rows = [r for r in range(nb) if r not in frows]

        def cols(ks):
            return [k for k in ks] + [nb + k for k in ks] + [2 * nb + k for k in ks]

        self.sub = _Eqs(M[np.ix_(rows, cols(self.free))]) if fixed else self
        # the loops' rows stay first in sub (the drivers' rows left are the fixed angles')
        for eqs in {id(self): self, id(self.sub): self.sub}.values():
            if eqs.nb > 2:  # (two angles: Cramer's rule on F_theta itself)
                try:
                    eqs.elim = Eliminated(eqs, ne)
                except ValueError:
                    pass
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

    def join_one(self, thf, thp) -> list:
        """:meth:`join` at one position, as a list of floats (``thf``, ``thp``: the free
        and the fixed angles, arrays or lists)."""
        thf = thf.tolist() if isinstance(thf, np.ndarray) else list(thf)
        if not self.fixed.size:
            return thf
        th = [0.0] * self.nb
        for j, k in enumerate(self.free_list):
            th[k] = thf[j]
        thp = thp.tolist() if isinstance(thp, np.ndarray) else thp
        for j, k in enumerate(self.fixed_list):
            th[k] = thp[j]
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
        # (N, n) arrays whose columns are contiguous (transposed (n, N) blocks): each
        # term is added into, and each reader takes, one column at a time; a row of
        # constants broadcast over (N, n) rows of a few entries costs some 15 us
        nb = self.nb
        Kt, Pxt, Pyt = np.empty((nb, n)), np.empty((nb, n)), np.empty((nb, n))
        if order == 0:
            Kt[:] = kc[:, None]
            Pxt[:] = pxc[:, None]
            Pyt[:] = pyc[:, None]
        else:
            Kt.fill(0.0)
            Pxt.fill(0.0)
            Pyt.fill(0.0)
        for e, sign, j in kmov:
            px, py = pts[j]
            Kt[e] += sign * px
            Kt[ne + e] += sign * py
        for col, sign, body in dmov:
            Kt[col] += sign * ang[body]
        for kb, j in pmov:
            Pxt[kb], Pyt[kb] = pts[j]
        return Kt.T, Pxt.T, Pyt.T

    def known_one(self, st: State, order: int = 0) -> tuple[list, list, list]:
        """:meth:`known` at the one position of ``st`` as lists of floats (``K``, ``Px``,
        ``Py``), the same operations in the same order (a NumPy call on one-element
        arrays costs more than its arithmetic)."""
        kc, pxc, pyc, points, kmov, dmov, pmov = self._known_plan(st.nb)
        if any(s.ndim != 1 for _, s in points):  # one local vector per position
            K, Px, Py = self.known(st, order)
            return K[0].tolist(), Px[0].tolist(), Py[0].tolist()
        nb, ne, ground = self.nb, self.ne, st.nb
        pts = []
        for body, s in points:  # as State.point, point_velocity, point_acceleration
            s0, s1 = s.tolist()
            if body == ground:
                pts.append((s0, s1) if order == 0 else (0.0, 0.0))
                continue
            a = ((st.x, st.y), (st.vx, st.vy), (st.ax, st.ay))[order]
            px, py = float(a[0][body, 0]), float(a[1][body, 0])
            if s0 == 0.0 and s1 == 0.0:
                pts.append((px, py))
                continue
            c, sn = float(st.c[body, 0]), float(st.s[body, 0])
            rx, ry = c * s0 - sn * s1, sn * s0 + c * s1
            if order == 0:
                pts.append((px + rx, py + ry))
            elif order == 1:
                w = float(st.w[body, 0])
                pts.append((px - w * ry, py + w * rx))
            else:
                w = float(st.w[body, 0])
                w2, al = w * w, float(st.al[body, 0])
                pts.append((px - al * ry - w2 * rx, py + al * rx - w2 * ry))
        K = kc.tolist() if order == 0 else [0.0] * nb
        for e, sign, j in kmov:
            px, py = pts[j]
            K[e] += sign * px
            K[ne + e] += sign * py
        ang = (st.th, st.w, st.al)[order]
        for col, sign, body in dmov:
            K[col] += sign * float(ang[body, 0])
        Px = pxc.tolist() if order == 0 else [0.0] * nb
        Py = pyc.tolist() if order == 0 else [0.0] * nb
        for kb, j in pmov:
            Px[kb], Py[kb] = pts[j]
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

    def mtf_list(self) -> list:
        """:attr:`MTf` as lists of floats (:meth:`reduce` at one position)."""
        m = getattr(self, "_mtf_list", None)
        if m is None:
            m = self._mtf_list = self.MTf.tolist()
        return m

    def wr_list(self) -> list:
        """:attr:`Wr` as lists of floats (the frames' rates at one position)."""
        wr = getattr(self, "_wr_list", None)
        if wr is None:
            wr = self._wr_list = self.Wr.tolist()
        return wr

    def wr_terms(self) -> list:
        """:attr:`Wr`'s nonzero entries per link ``k``: ``(j, Wr[j, k], Wr[nb + j, k],
        Wr[j, nb + k], Wr[nb + j, nb + k])`` for the angles ``j`` that move its frame (the
        coefficients of ``P_j`` and ``Q_j`` in its x and y rates)."""
        t = getattr(self, "_wr_terms", None)
        if t is None:
            nb, Wr = self.nb, self.wr_list()
            t = self._wr_terms = [
                [
                    (j, Wr[j][k], Wr[nb + j][k], Wr[j][nb + k], Wr[nb + j][nb + k])
                    for j in range(nb)
                    if Wr[j][k] or Wr[nb + j][k] or Wr[j][nb + k] or Wr[nb + j][nb + k]
                ]
                for k in range(nb)
            ]
        return t


def _rowmax_abs(a: np.ndarray) -> np.ndarray:
    """``max |a|`` along the rows of ``a`` (N, k), k small, NaN kept (a reduction along a
    short last axis costs more than k elementwise maxima)."""
    m = np.abs(a[:, 0])
    for k in range(1, a.shape[1]):
        np.maximum(m, np.abs(a[:, k]), out=m)
    return m


FLOATS_UP_TO = 6  # groups of up to this many angles are solved position by position in floats


def _solve_small(J: list, f: list) -> list | None:
    """``J dx = -f`` in floats: 1 to 4 unknowns by Cramer's rule (:func:`_solve4`), more
    (up to :data:`FLOATS_UP_TO`) by Gaussian elimination with partial pivoting, as LAPACK's
    ``gesv`` (a NumPy call costs ~10 us there, more than the arithmetic); None when
    ``J`` is exactly singular."""
    n = len(f)
    if n == 4:
        return _solve4(J, f)
    if n > 3:
        return _gauss_small(J, f)
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


def _det_small(J: np.ndarray) -> float:
    """``det J`` of one small matrix, in floats up to 4 x 4 (Laplace's expansion, as
    :func:`_solve4`; a LAPACK call costs ~20 us there), by LAPACK beyond."""
    n = J.shape[0]
    if n > 4:
        return float(np.linalg.det(J))
    return _det_list(J.tolist())


def _det_list(a: list) -> float:
    """:func:`_det_small` of a matrix of up to 4 x 4 given as rows of floats."""
    n = len(a)
    if n == 1:
        return a[0][0]
    if n == 2:
        return a[0][0] * a[1][1] - a[0][1] * a[1][0]
    if n == 3:
        (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
        return (
            a00 * (a11 * a22 - a12 * a21)
            - a01 * (a10 * a22 - a12 * a20)
            + a02 * (a10 * a21 - a11 * a20)
        )
    (a00, a01, a02, a03), (a10, a11, a12, a13), (a20, a21, a22, a23), (a30, a31, a32, a33) = a
    s0, s1, s2 = a00 * a11 - a10 * a01, a00 * a12 - a10 * a02, a00 * a13 - a10 * a03
    s3, s4, s5 = a01 * a12 - a11 * a02, a01 * a13 - a11 * a03, a02 * a13 - a12 * a03
    c5, c4, c3 = a22 * a33 - a32 * a23, a21 * a33 - a31 * a23, a21 * a32 - a31 * a22
    c2, c1, c0 = a20 * a33 - a30 * a23, a20 * a32 - a30 * a22, a20 * a31 - a30 * a21
    return s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0


def _solve4(J: list, f: list) -> list | None:
    """:func:`_solve_small` for four unknowns by the adjugate, from the 2 x 2 minors of
    the first two rows and of the last two (Laplace's expansion): straight-line
    arithmetic, a third of the elimination's time in Python. A Newton step's accuracy
    only decides how fast it converges (the residual decides when), so Cramer's rule,
    less stable than pivoting near a singular matrix, is enough here. None when the
    determinant is exactly zero."""
    (a00, a01, a02, a03), (a10, a11, a12, a13), (a20, a21, a22, a23), (a30, a31, a32, a33) = J
    s0, s1, s2 = a00 * a11 - a10 * a01, a00 * a12 - a10 * a02, a00 * a13 - a10 * a03
    s3, s4, s5 = a01 * a12 - a11 * a02, a01 * a13 - a11 * a03, a02 * a13 - a12 * a03
    c5, c4, c3 = a22 * a33 - a32 * a23, a21 * a33 - a31 * a23, a21 * a32 - a31 * a22
    c2, c1, c0 = a20 * a33 - a30 * a23, a20 * a32 - a30 * a22, a20 * a31 - a30 * a21
    det = s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0
    if det == 0:
        return None
    f0, f1, f2, f3 = f
    r = -1.0 / det
    return [
        r
        * (
            (a11 * c5 - a12 * c4 + a13 * c3) * f0
            + (-a01 * c5 + a02 * c4 - a03 * c3) * f1
            + (a31 * s5 - a32 * s4 + a33 * s3) * f2
            + (-a21 * s5 + a22 * s4 - a23 * s3) * f3
        ),
        r
        * (
            (-a10 * c5 + a12 * c2 - a13 * c1) * f0
            + (a00 * c5 - a02 * c2 + a03 * c1) * f1
            + (-a30 * s5 + a32 * s2 - a33 * s1) * f2
            + (a20 * s5 - a22 * s2 + a23 * s1) * f3
        ),
        r
        * (
            (a10 * c4 - a11 * c2 + a13 * c0) * f0
            + (-a00 * c4 + a01 * c2 - a03 * c0) * f1
            + (a30 * s4 - a31 * s2 + a33 * s0) * f2
            + (-a20 * s4 + a21 * s2 - a23 * s0) * f3
        ),
        r
        * (
            (-a10 * c3 + a11 * c1 - a12 * c0) * f0
            + (a00 * c3 - a01 * c1 + a02 * c0) * f1
            + (-a30 * s3 + a31 * s1 - a32 * s0) * f2
            + (a20 * s3 - a21 * s1 + a22 * s0) * f3
        ),
    ]


def _gauss_small(J: list, f: list) -> list | None:
    """:func:`_solve_small` for four or more unknowns: elimination with partial pivoting
    (the largest entry of the column below the diagonal), then back substitution."""
    n = len(f)
    A = [list(row) + [-v] for row, v in zip(J, f)]
    for j in range(n):
        p, big = j, abs(A[j][j])
        for i in range(j + 1, n):
            v = abs(A[i][j])
            if v > big:
                p, big = i, v
        if big == 0:
            return None
        piv = A[p][j]
        if p != j:
            A[j], A[p] = A[p], A[j]
        rj = A[j]
        for i in range(j + 1, n):
            ri = A[i]
            m = ri[j] / piv
            if m:
                for c in range(j + 1, n + 1):
                    ri[c] -= m * rj[c]
    x = [0.0] * n
    for j in range(n - 1, -1, -1):
        rj = A[j]
        acc = rj[n]
        for c in range(j + 1, n):
            acc -= rj[c] * x[c]
        x[j] = acc / rj[j]
    return x


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


# -- small matrices stacked over positions: elimination on 1-D arrays -------------------
#
# np.linalg.solve / inv on (N, n, n) with n = 3..6 spend most of their time per matrix
# (LAPACK is called once per position: ~0.4 us a 4 x 4 solve, ~0.8 us an inverse);
# Gaussian elimination written over the positions, one 1-D array per entry, costs about
# n^3 / 3 array operations in all: 5-10x less at thousands of positions. The row order
# is chosen once per call by partial pivoting on a few sample positions; a position
# whose pivot is not within THRESHOLD of the largest entry below it (threshold pivoting,
# as sparse LU codes use), or is zero, or not finite, is solved by LAPACK instead.

THRESHOLD = 0.1  # a pivot at least this fraction of its column's largest entry below it
STACKED_MIN = 32  # fewer positions: LAPACK (its per-matrix cost is then below n^3 / 3 calls)


class _StackedLU:
    """LU factors of N small matrices (n x n), given by their entries ``A[i][j]``: 1-D
    arrays over the positions, or None where an entry is zero at every position (see
    :func:`_entries_of`). ``bad``: the positions LAPACK must take (see above); ``ok``:
    False when the row order has a structural zero pivot (then every position is bad).
    :meth:`matrices` gives the stacked matrices back at some positions (for LAPACK)."""

    def __init__(self, A: list, N: int) -> None:
        n = len(A)
        self.n, self.N = n, N
        self.entries = A
        # the row order: partial pivoting on |A| summed over three sample positions
        m = N // 2  # (scalars: a NumPy call per entry would cost more than the order)
        s = [[0.0 if a is None else abs(a[0]) + abs(a[m]) + abs(a[-1]) for a in row] for row in A]
        s = [[float(v) if math.isfinite(v) else 0.0 for v in row] for row in s]
        rows = list(range(n))
        for k in range(n):
            p = max(range(k, n), key=lambda i: abs(s[rows[i]][k]))
            rows[k], rows[p] = rows[p], rows[k]
            pr = s[rows[k]]
            if pr[k] == 0:
                continue
            for i in range(k + 1, n):
                r = s[rows[i]]
                m = r[k] / pr[k]
                if m:
                    s[rows[i]] = [a - m * b if c > k else a for c, (a, b) in enumerate(zip(r, pr))]
        self.rows = rows
        A = [list(A[r]) for r in rows]
        L: list[list] = [[None] * n for _ in range(n)]
        bad = np.zeros(N, bool)
        inv_piv = []
        self.ok = True
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            for k in range(n):
                piv = A[k][k]
                if piv is None:
                    self.ok = False
                    bad[:] = True
                    return
                apiv = np.abs(piv)
                bad |= ~(apiv > 0)
                ip = 1.0 / piv
                inv_piv.append(ip)
                rk = A[k]
                for i in range(k + 1, n):
                    ri = A[i]
                    a = ri[k]
                    if a is None:
                        continue
                    bad |= ~(apiv >= THRESHOLD * np.abs(a))
                    m = a * ip
                    L[i][k] = m
                    for j in range(k + 1, n):
                        b = rk[j]
                        if b is None:
                            continue
                        ri[j] = -(m * b) if ri[j] is None else ri[j] - m * b
        self.U, self.L, self.inv_piv, self.bad = A, L, inv_piv, bad

    def matrices(self, idx) -> np.ndarray:
        """The matrices (k, n, n) at the positions ``idx``."""
        n = self.n
        J = np.zeros((np.count_nonzero(idx) if idx.dtype == bool else len(idx), n, n))
        for i, row in enumerate(self.entries):
            for j, a in enumerate(row):
                if a is not None:
                    J[:, i, j] = a[idx]
        return J

    def solve_cols(self, b: list) -> list:
        """The solution's columns (n 1-D arrays) of ``J x = b`` for ``b`` given as its n
        columns (1-D arrays, or None for zero); not valid at :attr:`bad` positions."""
        n, rows, L, U = self.n, self.rows, self.L, self.U
        y = [b[r] for r in rows]
        for i in range(1, n):
            acc = y[i]
            for k in range(i):
                m, yk = L[i][k], y[k]
                if m is None or yk is None:
                    continue
                acc = -(m * yk) if acc is None else acc - m * yk
            y[i] = acc
        x: list = [None] * n
        for i in range(n - 1, -1, -1):
            acc = y[i]
            for j in range(i + 1, n):
                u, xj = U[i][j], x[j]
                if u is None or xj is None:
                    continue
                acc = -(u * xj) if acc is None else acc - u * xj
            x[i] = None if acc is None else acc * self.inv_piv[i]
        return [np.zeros(self.N) if v is None else v for v in x]

    def det(self) -> np.ndarray:
        """The determinants (not valid at :attr:`bad` positions)."""
        d = np.prod(np.array([self.U[k][k] for k in range(self.n)]), axis=0)
        # the row permutation's sign: the parity of its inversions
        r = self.rows
        inv = sum(1 for i in range(self.n) for j in range(i + 1, self.n) if r[i] > r[j])
        return -d if inv % 2 else d


def _entries_of(J: np.ndarray, nz: np.ndarray | None = None) -> list:
    """The entries of the stacked matrices ``J`` (N, n, n) as :class:`_StackedLU` takes
    them (None where ``nz`` says an entry is always zero)."""
    n = J.shape[1]
    return [
        [np.ascontiguousarray(J[:, i, j]) if nz is None or nz[i, j] else None for j in range(n)]
        for i in range(n)
    ]


def _lu_solve(lu: _StackedLU, b: np.ndarray) -> np.ndarray:
    """``J x = b`` (N, n) from the factors (LAPACK at the positions they cannot take; its
    LinAlgError for an exactly singular one, as np.linalg.solve raises it)."""
    out = np.empty(b.shape)
    if lu.ok:
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            x = lu.solve_cols([b[:, j] for j in range(b.shape[1])])
        for j, v in enumerate(x):
            out[:, j] = v
    bad = lu.bad
    if bad.any():
        out[bad] = np.linalg.solve(lu.matrices(bad), b[bad][..., None])[..., 0]
    return out


def _lu_inverse(lu: _StackedLU) -> np.ndarray:
    """The inverses (N, n, n) from the factors, as :func:`_batch_inverse` gives them
    (which takes the positions the factors cannot)."""
    N, n = lu.N, lu.n
    out = np.empty((N, n, n))
    if lu.ok:
        one = np.ones(N)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            for c in range(n):
                x = lu.solve_cols([one if j == c else None for j in range(n)])
                for i, v in enumerate(x):
                    out[:, i, c] = v
    bad = lu.bad
    if bad.any():
        out[bad] = _batch_inverse(lu.matrices(bad))
    if not np.isfinite(out).all():  # NaN in an entry: the whole inverse, as LAPACK's
        out[~np.all(np.isfinite(out), axis=(1, 2))] = np.nan
    return out


def _lu_det(lu: _StackedLU) -> np.ndarray:
    """The determinants from the factors (LAPACK at the positions they cannot take)."""
    if not lu.ok:
        return np.linalg.det(lu.matrices(np.arange(lu.N)))
    with np.errstate(invalid="ignore", over="ignore"):
        d = lu.det()
    bad = lu.bad
    if bad.any():
        d[bad] = np.linalg.det(lu.matrices(bad))
    return d


def _stacked_solve(J: np.ndarray, b: np.ndarray, nz: np.ndarray | None = None) -> np.ndarray:
    """``np.linalg.solve(J, b[..., None])[..., 0]`` for J (N, n, n), b (N, n), by
    :class:`_StackedLU`."""
    return _lu_solve(_StackedLU(_entries_of(J, nz), J.shape[0]), b)


def _stacked_inverse(J: np.ndarray, nz: np.ndarray | None = None) -> np.ndarray:
    """:func:`_batch_inverse` for 3 x 3 to 6 x 6 matrices by :class:`_StackedLU`."""
    return _lu_inverse(_StackedLU(_entries_of(J, nz), J.shape[0]))


def _stacked_det(J: np.ndarray, nz: np.ndarray | None = None) -> np.ndarray:
    """``np.linalg.det(J)`` by :class:`_StackedLU`."""
    return _lu_det(_StackedLU(_entries_of(J, nz), J.shape[0]))
