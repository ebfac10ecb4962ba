"""Lean batched Newtons written by hand for the Newton groups' benchmark (issue 30).

Two mechanisms of :mod:`mechsolve_bench.references`: the benchmark four-bar (unknowns the
coupler's and rocker's angles) and the Stephenson triad six-bar (unknowns the angles of
L1, T, L2, L3). Each solver takes a uniform sweep of crank angles and returns the angles,
their rates and accelerations at every position, by

* a coarse continuation in plain floats (about 24 positions, each predicted along the
  previous tangent, Newton to ``tol``, the step halved when Newton fails or jumps more
  than :data:`MAX_JUMP` from the prediction),
* a cubic Hermite prediction of every position from the coarse positions and tangents
  (on a uniform grid the basis is the same in every segment: one small tensor product),
* batched Newton on all positions at once until the largest loop residual is ``tol``,
  each step eliminated to a 2x2 system solved by Cramer's rule (the triad: dotting the
  first loop with ``e(phi2)`` and the second with ``e(phi3)`` removes ``dphi2`` and
  ``dphi3``),
* the velocities and accelerations from the same eliminated system.

:func:`shared_triad` and :func:`shared_fourbar` follow, step by step, the lean reference
the issue points to (``../shared/reference/newton/``, read and written again here: the
bench does not import it). :func:`lean_triad` and :func:`lean_fourbar` are this bench's
own versions of the same algorithm with less work: the coarse positions predicted by
a cubic through the two previous ones (fewer Newton iterations in floats), the
cosines and sines after a small Newton step turned by the addition formulas instead of
evaluated again (:func:`_rotate`), the four angles' cosines and sines in two calls on
one (4, N) array, the residual's largest component from one stacked array, and the
products shared between the residual, the eliminated step and the rates computed once.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from mechsolve_bench import references as R

MAX_JUMP = 0.05  # rad: a Newton correction larger than this is a jump to another branch


# --- shared pieces ----------------------------------------------------------------------


def uniform_coarse(u: np.ndarray, ncoarse: int) -> tuple[np.ndarray, int, float]:
    """Coarse driver values every ``k``-th position of a uniform sweep, the last at or
    beyond its end, so that every segment has the same Hermite basis."""
    n = len(u)
    k = max(1, n // ncoarse)
    K = -(-(n - 1) // k) if n > 1 else 1
    du = (u[-1] - u[0]) / (n - 1) if n > 1 else 0.0
    H = k * du
    return u[0] + H * np.arange(K + 1), k, H


def hermite_uniform(Q: np.ndarray, T: np.ndarray, k: int, H: float, n: int) -> np.ndarray:
    """The cubic Hermite prediction (m, n) at every fine position from positions ``Q``
    and tangents ``T`` (K + 1, m) every ``k`` positions (spacing ``H``)."""
    K = len(Q) - 1
    t = np.arange(k) / k
    t2 = t * t
    t3 = t2 * t
    B = np.stack([2 * t3 - 3 * t2 + 1, (t3 - 2 * t2 + t) * H, 3 * t2 - 2 * t3, (t3 - t2) * H])
    M = np.stack([Q[:-1], T[:-1], Q[1:], T[1:]], axis=1)  # (K, 4, m)
    P = np.einsum("sbi,bj->isj", M, B).reshape(M.shape[2], K * k)
    if n > K * k:
        P = np.concatenate([P, Q[-1][:, None]], axis=1)
    return P[:, :n]


def _continue(step, tangent, us, q0, tol, max_depth=8, cubic=False):
    """The coarse continuation: ``step(u, q, tol) -> (q, converged)``, ``tangent(u, q)``
    in floats; positions and tangents (K, m). Each position is predicted along the
    previous tangent; with ``cubic`` (uniform ``us``), from the cubic Hermite through the
    two previous positions and tangents (error O(h^4) instead of O(h^2): fewer Newton
    iterations), the tangent's substeps kept for when that prediction fails."""
    m = len(q0)
    Q = np.empty((len(us), m))
    T = np.empty((len(us), m))
    q, _ = step(float(us[0]), tuple(q0), tol)
    t = tangent(float(us[0]), q)
    Q[0], T[0] = q, t
    pq = pt = None
    for i in range(1, len(us)):
        u0, u1 = float(us[i - 1]), float(us[i])
        if cubic and pq is not None:  # the Hermite basis at t = 2: (5, 2, -4, 4)
            h = u1 - u0
            p = tuple(5 * pq[r] + 2 * h * pt[r] - 4 * q[r] + 4 * h * t[r] for r in range(m))
            qn, conv = step(u1, p, tol)
            if conv and max(abs(qn[r] - p[r]) for r in range(m)) <= MAX_JUMP:
                pq, pt = q, t
                q, t = qn, tangent(u1, qn)
                Q[i], T[i] = q, t
                continue
        pq, pt = q, t
        for depth in range(max_depth + 1):
            parts = 1 << depth
            h = (u1 - u0) / parts
            qs, ts, good = q, t, True
            for j in range(1, parts + 1):
                p = tuple(qs[r] + ts[r] * h for r in range(m))
                qn, conv = step(u0 + h * j, p, tol)
                if not conv or max(abs(qn[r] - p[r]) for r in range(m)) > MAX_JUMP:
                    good = False
                    break
                qs, ts = qn, tangent(u0 + h * j, qn)
            if good:
                break
        else:
            raise RuntimeError("coarse continuation lost the branch")
        q, t = qs, ts
        Q[i], T[i] = q, t
    return Q, T


def _rotate(cs: np.ndarray, d: np.ndarray) -> bool:
    """Turn the cosines and sines ``cs`` (2, m, n) of angles by small steps ``d`` (m, n)
    in place, by the addition formulas with cos(d), sin(d) from their Taylor series to
    the 5th order (exact to rounding while |d| < 1e-3: the rest is below d^6 / 720),
    instead of evaluating cos and sin again; False (nothing done) when a step is larger."""
    if not float(np.abs(d).max()) < 1e-3:
        return False
    d2 = d * d
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0))
    sd = d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0)))
    c = cs[0] * cd - cs[1] * sd
    cs[1] *= cd
    cs[1] += cs[0] * sd
    cs[0] = c
    return True


# --- the triad six-bar --------------------------------------------------------------------


class TriadGeo:
    """The triad's numbers: ground pivots, crank radius, link lengths and T's two side
    vectors in its frame (from :func:`mechsolve_bench.references.triad_geometry`)."""

    def __init__(self) -> None:
        (self.l1, self.l2, self.l3), x0 = R.triad_geometry()
        self.q0 = tuple(float(z) for z in x0)
        self.G1, self.G2, self.r = R.TRIAD_G1, R.TRIAD_G2, R.TRIAD_R
        p1, p2, p3 = R.TRIAD_T
        self.v2 = (p2[0] - p1[0], p2[1] - p1[1])
        self.v3 = (p3[0] - p1[0], p3[1] - p1[1])


@functools.cache
def triad_geo() -> TriadGeo:
    """The triad's numbers, computed once (the hand-written solver takes them given)."""
    return TriadGeo()


def _triad_step(g: TriadGeo):
    G1x, G1y = g.G1
    G2x, G2y = g.G2
    l1, l2, l3, r = g.l1, g.l2, g.l3, g.r
    (v2a, v2b), (v3a, v3b) = g.v2, g.v3

    def terms(f1, ps, f2, f3):
        c1, s1 = math.cos(f1), math.sin(f1)
        cp, sp = math.cos(ps), math.sin(ps)
        c2, s2 = math.cos(f2), math.sin(f2)
        c3, s3 = math.cos(f3), math.sin(f3)
        v2x, v2y = cp * v2a - sp * v2b, sp * v2a + cp * v2b
        v3x, v3y = cp * v3a - sp * v3b, sp * v3a + cp * v3b
        a1x, a1y = -l1 * s1, l1 * c1
        m11, m12 = c2 * a1x + s2 * a1y, s2 * v2x - c2 * v2y
        m21, m22 = c3 * a1x + s3 * a1y, s3 * v3x - c3 * v3y
        return c1, s1, c2, s2, c3, s3, v2x, v2y, v3x, v3y, a1x, a1y, m11, m12, m21, m22

    def step(u, q, tol):
        f1, ps, f2, f3 = q
        ax, ay = r * math.cos(u), r * math.sin(u)
        for _ in range(31):
            c1, s1, c2, s2, c3, s3, v2x, v2y, v3x, v3y, a1x, a1y, m11, m12, m21, m22 = terms(
                f1, ps, f2, f3
            )
            e1x = G1x + l1 * c1 + v2x - G2x - l2 * c2
            e1y = G1y + l1 * s1 + v2y - G2y - l2 * s2
            e2x = G1x + l1 * c1 + v3x - ax - l3 * c3
            e2y = G1y + l1 * s1 + v3y - ay - l3 * s3
            if max(abs(e1x), abs(e1y), abs(e2x), abs(e2y)) <= tol:
                return (f1, ps, f2, f3), True
            b1, b2 = -(c2 * e1x + s2 * e1y), -(c3 * e2x + s3 * e2y)
            det = m11 * m22 - m12 * m21
            d1 = (b1 * m22 - b2 * m12) / det
            dp = (m11 * b2 - m21 * b1) / det
            r1x, r1y = e1x + a1x * d1 - v2y * dp, e1y + a1y * d1 + v2x * dp
            r2x, r2y = e2x + a1x * d1 - v3y * dp, e2y + a1y * d1 + v3x * dp
            f1, ps = f1 + d1, ps + dp
            f2 += (c2 * r1y - s2 * r1x) / l2
            f3 += (c3 * r2y - s3 * r2x) / l3
        return (f1, ps, f2, f3), False

    def tangent(u, q):
        c1, s1, c2, s2, c3, s3, v2x, v2y, v3x, v3y, a1x, a1y, m11, m12, m21, m22 = terms(*q)
        hx, hy = -r * math.sin(u), r * math.cos(u)
        b2 = c3 * hx + s3 * hy
        det = m11 * m22 - m12 * m21
        d1, dp = -b2 * m12 / det, m11 * b2 / det
        r1x, r1y = a1x * d1 - v2y * dp, a1y * d1 + v2x * dp
        r2x, r2y = a1x * d1 - v3y * dp - hx, a1y * d1 + v3x * dp - hy
        return (d1, dp, (c2 * r1y - s2 * r1x) / l2, (c3 * r2y - s3 * r2x) / l3)

    return step, tangent


def shared_triad(th, w=1.0, tol=1e-12, ncoarse=24, maxit=30):
    """The shared reference's algorithm for the triad: angles, rates, accelerations
    (N, 4) of L1, T, L2, L3, and the batched iterations."""
    g = triad_geo()
    th = np.asarray(th, float)
    n = len(th)
    uc, k, H = uniform_coarse(th, ncoarse)
    Qc, Tc = _continue(*_triad_step(g), uc, g.q0, tol)
    pred = hermite_uniform(Qc, Tc, k, H, n)
    q = pred.copy()
    ax, ay = g.r * np.cos(th), g.r * np.sin(th)
    k1x, k1y = g.G1[0] - g.G2[0], g.G1[1] - g.G2[1]
    k2x, k2y = g.G1[0] - ax, g.G1[1] - ay
    (v2a, v2b), (v3a, v3b) = g.v2, g.v3
    for its in range(maxit + 1):
        c1, s1, cp, sp = np.cos(q[0]), np.sin(q[0]), np.cos(q[1]), np.sin(q[1])
        c2, s2, c3, s3 = np.cos(q[2]), np.sin(q[2]), np.cos(q[3]), np.sin(q[3])
        v2x, v2y = cp * v2a - sp * v2b, sp * v2a + cp * v2b
        v3x, v3y = cp * v3a - sp * v3b, sp * v3a + cp * v3b
        l1c, l1s = g.l1 * c1, g.l1 * s1
        e1x = k1x + l1c + v2x - g.l2 * c2
        e1y = k1y + l1s + v2y - g.l2 * s2
        e2x = k2x + l1c + v3x - g.l3 * c3
        e2y = k2y + l1s + v3y - g.l3 * s3
        res = max(np.max(np.abs(e1x)), np.max(np.abs(e1y)), np.max(np.abs(e2x)))
        res = max(res, np.max(np.abs(e2y)))
        if res <= tol:
            break
        if not np.isfinite(res) or its == maxit:
            raise RuntimeError("batched Newton did not converge")
        T = (c1, s1, c2, s2, c3, s3, v2x, v2y, v3x, v3y)
        d = _triad_elim(g, T, -e1x, -e1y, -e2x, -e2y)
        q[0] += d[0]
        q[1] += d[1]
        q[2] += d[2]
        q[3] += d[3]
    if np.max(np.abs(q - pred)) > MAX_JUMP:
        raise RuntimeError("batched Newton jumped off the predicted branch")
    T = (c1, s1, c2, s2, c3, s3, v2x, v2y, v3x, v3y)
    z = np.zeros(n)
    d1, dp, d2, d3 = _triad_elim(g, T, z, z, -ay * w, ax * w)
    l1w = g.l1 * d1 * d1
    g1x = l1w * c1 + v2x * dp * dp - g.l2 * c2 * d2 * d2
    g1y = l1w * s1 + v2y * dp * dp - g.l2 * s2 * d2 * d2
    g2x = l1w * c1 + v3x * dp * dp - g.l3 * c3 * d3 * d3 - ax * w * w
    g2y = l1w * s1 + v3y * dp * dp - g.l3 * s3 * d3 * d3 - ay * w * w
    a = _triad_elim(g, T, g1x, g1y, g2x, g2y)
    return q.T, np.stack([d1, dp, d2, d3], 1), np.stack(a, 1), its


def _triad_elim(g, T, rhs1x, rhs1y, rhs2x, rhs2y):
    """``J dq = rhs`` by elimination to 2x2 (the shared reference's ``_elim_solve``)."""
    c1, s1, c2, s2, c3, s3, v2x, v2y, v3x, v3y = T
    a1x, a1y = -g.l1 * s1, g.l1 * c1
    m11 = c2 * a1x + s2 * a1y
    m12 = s2 * v2x - c2 * v2y
    m21 = c3 * a1x + s3 * a1y
    m22 = s3 * v3x - c3 * v3y
    b1 = c2 * rhs1x + s2 * rhs1y
    b2 = c3 * rhs2x + s3 * rhs2y
    idet = 1.0 / (m11 * m22 - m12 * m21)
    d1 = (b1 * m22 - b2 * m12) * idet
    dp = (m11 * b2 - m21 * b1) * idet
    r1x, r1y = a1x * d1 - v2y * dp - rhs1x, a1y * d1 + v2x * dp - rhs1y
    r2x, r2y = a1x * d1 - v3y * dp - rhs2x, a1y * d1 + v3x * dp - rhs2y
    return d1, dp, (c2 * r1y - s2 * r1x) / g.l2, (c3 * r2y - s3 * r2x) / g.l3


def lean_triad(th, w=1.0, tol=1e-12, ncoarse=24, maxit=30):
    """This bench's own lean batched Newton of the triad (same algorithm and outputs as
    :func:`shared_triad`, fewer NumPy calls)."""
    g = triad_geo()
    th = np.asarray(th, float)
    n = len(th)
    uc, k, H = uniform_coarse(th, ncoarse)
    Qc, Tc = _continue(*_triad_step(g), uc, g.q0, tol, cubic=True)
    q = np.ascontiguousarray(hermite_uniform(Qc, Tc, k, H, n))
    pred = q.copy()
    cs = np.empty((2, 4, n))
    ax, ay = g.r * np.cos(th), g.r * np.sin(th)
    l1, l2, l3 = g.l1, g.l2, g.l3
    k1x, k1y = g.G1[0] - g.G2[0], g.G1[1] - g.G2[1]
    k2x, k2y = g.G1[0] - ax, g.G1[1] - ay
    (v2a, v2b), (v3a, v3b) = g.v2, g.v3
    E = np.empty((4, n))
    D = np.empty((4, n))
    fresh = False  # cs holds the cosines and sines of q
    for its in range(maxit + 1):
        if not fresh:
            np.cos(q, out=cs[0])
            np.sin(q, out=cs[1])
        (c1, cp, c2, c3), (s1, sp, s2, s3) = cs
        v2x, v2y = cp * v2a - sp * v2b, sp * v2a + cp * v2b
        v3x, v3y = cp * v3a - sp * v3b, sp * v3a + cp * v3b
        a1x, a1y = -l1 * s1, l1 * c1
        px, py = k1x + a1y, k1y - a1x  # = G1 - G2 + l1 e(phi1)
        np.subtract(px + v2x, l2 * c2, out=E[0])
        np.subtract(py + v2y, l2 * s2, out=E[1])
        np.subtract(a1y + k2x + v3x, l3 * c3, out=E[2])
        np.subtract(k2y - a1x + v3y, l3 * s3, out=E[3])
        res = float(np.abs(E).max())
        if res <= tol:
            break
        if not math.isfinite(res) or its == maxit:
            raise RuntimeError("batched Newton did not converge")
        e1x, e1y, e2x, e2y = E
        m11, m12 = c2 * a1x + s2 * a1y, s2 * v2x - c2 * v2y
        m21, m22 = c3 * a1x + s3 * a1y, s3 * v3x - c3 * v3y
        idet = 1.0 / (m11 * m22 - m12 * m21)
        b1 = -(c2 * e1x + s2 * e1y)
        b2 = -(c3 * e2x + s3 * e2y)
        d1 = (b1 * m22 - b2 * m12) * idet
        dp = (m11 * b2 - m21 * b1) * idet
        t1x, t1y = a1x * d1, a1y * d1
        D[0], D[1] = d1, dp
        np.divide(c2 * (e1y + t1y + v2x * dp) - s2 * (e1x + t1x - v2y * dp), l2, out=D[2])
        np.divide(c3 * (e2y + t1y + v3x * dp) - s3 * (e2x + t1x - v3y * dp), l3, out=D[3])
        q += D
        fresh = _rotate(cs, D)
    if float(np.abs(q - pred).max()) > MAX_JUMP:
        raise RuntimeError("batched Newton jumped off the predicted branch")
    m11, m12 = c2 * a1x + s2 * a1y, s2 * v2x - c2 * v2y
    m21, m22 = c3 * a1x + s3 * a1y, s3 * v3x - c3 * v3y
    idet = 1.0 / (m11 * m22 - m12 * m21)
    hx, hy = -ay * w, ax * w  # the crank point's velocity
    b2 = c3 * hx + s3 * hy
    w1, wp = -b2 * m12 * idet, m11 * b2 * idet
    t1x, t1y = a1x * w1, a1y * w1
    w2 = (c2 * (t1y + v2x * wp) - s2 * (t1x - v2y * wp)) / l2
    w3 = (c3 * (t1y + v3x * wp - hy) - s3 * (t1x - v3y * wp - hx)) / l3
    # accelerations: J qdd = sum R(x) v x'^2 - A'' on the second loop
    l1w = l1 * w1 * w1
    wp2 = wp * wp
    l2w, l3w = l2 * w2 * w2, l3 * w3 * w3
    g1x = l1w * c1 + v2x * wp2 - l2w * c2
    g1y = l1w * s1 + v2y * wp2 - l2w * s2
    g2x = l1w * c1 + v3x * wp2 - l3w * c3 - ax * (w * w)
    g2y = l1w * s1 + v3y * wp2 - l3w * s3 - ay * (w * w)
    b1 = c2 * g1x + s2 * g1y
    b2 = c3 * g2x + s3 * g2y
    e1 = (b1 * m22 - b2 * m12) * idet
    ep = (m11 * b2 - m21 * b1) * idet
    t1x, t1y = a1x * e1, a1y * e1
    e2 = (c2 * (t1y + v2x * ep - g1y) - s2 * (t1x - v2y * ep - g1x)) / l2
    e3 = (c3 * (t1y + v3x * ep - g2y) - s3 * (t1x - v3y * ep - g2x)) / l3
    return q.T, np.stack([w1, wp, w2, w3], 1), np.stack([e1, ep, e2, e3], 1), its


# --- the four-bar -------------------------------------------------------------------------


def _fourbar_step(a, b, c, d):
    def step(u, q, tol):
        t3, t4 = q
        ca, sa = a * math.cos(u) - d, a * math.sin(u)
        for _ in range(31):
            c3, s3, c4, s4 = math.cos(t3), math.sin(t3), math.cos(t4), math.sin(t4)
            f1, f2 = ca + b * c3 - c * c4, sa + b * s3 - c * s4
            if abs(f1) <= tol and abs(f2) <= tol:
                return (t3, t4), True
            j11, j12, j21, j22 = -b * s3, c * s4, b * c3, -c * c4
            det = j11 * j22 - j12 * j21
            t3 -= (f1 * j22 - f2 * j12) / det
            t4 -= (j11 * f2 - j21 * f1) / det
        return (t3, t4), False

    def tangent(u, q):
        c3, s3, c4, s4 = math.cos(q[0]), math.sin(q[0]), math.cos(q[1]), math.sin(q[1])
        j11, j12, j21, j22 = -b * s3, c * s4, b * c3, -c * c4
        det = j11 * j22 - j12 * j21
        r1, r2 = a * math.sin(u), -a * math.cos(u)
        return (r1 * j22 - r2 * j12) / det, (j11 * r2 - j21 * r1) / det

    return step, tangent


def _fourbar_start(th2):
    t3, t4, *_ = R.fourbar_vector(np.asarray(th2[:1], float))  # the open branch's start
    return float(t3[0]), float(t4[0])


def shared_fourbar(th2, w2=1.0, tol=1e-12, ncoarse=24, maxit=30):
    """The shared reference's algorithm for the four-bar: th3, th4, w3, w4, al3, al4 and
    the batched iterations."""
    a, b, c, d = R.A2, R.B3, R.C4, R.D1
    th2 = np.asarray(th2, float)
    n = len(th2)
    uc, k, H = uniform_coarse(th2, ncoarse)
    Qc, Tc = _continue(*_fourbar_step(a, b, c, d), uc, _fourbar_start(th2), tol)
    pred = hermite_uniform(Qc, Tc, k, H, n)
    t3, t4 = pred[0].copy(), pred[1].copy()
    ca, sa = a * np.cos(th2), a * np.sin(th2)
    ca_d = ca - d
    for its in range(maxit + 1):
        c3, s3, c4, s4 = np.cos(t3), np.sin(t3), np.cos(t4), np.sin(t4)
        f1 = ca_d + b * c3 - c * c4
        f2 = sa + b * s3 - c * s4
        res = max(np.max(np.abs(f1)), np.max(np.abs(f2)))
        if res <= tol:
            break
        if not np.isfinite(res) or its == maxit:
            raise RuntimeError("batched Newton did not converge")
        j11, j12, j21, j22 = -b * s3, c * s4, b * c3, -c * c4
        idet = 1.0 / (j11 * j22 - j12 * j21)
        t3 -= (f1 * j22 - f2 * j12) * idet
        t4 -= (j11 * f2 - j21 * f1) * idet
    if max(np.max(np.abs(t3 - pred[0])), np.max(np.abs(t4 - pred[1]))) > MAX_JUMP:
        raise RuntimeError("batched Newton jumped off the predicted branch")
    j11, j12, j21, j22 = -b * s3, c * s4, b * c3, -c * c4
    r1, r2 = sa * w2, -ca * w2
    idet = 1.0 / (j11 * j22 - j12 * j21)
    w3 = (r1 * j22 - r2 * j12) * idet
    w4 = (j11 * r2 - j21 * r1) * idet
    g1 = ca * (w2 * w2) + b * c3 * (w3 * w3) - c * c4 * (w4 * w4)
    g2 = sa * (w2 * w2) + b * s3 * (w3 * w3) - c * s4 * (w4 * w4)
    return t3, t4, w3, w4, (g1 * j22 - g2 * j12) * idet, (j11 * g2 - j21 * g1) * idet, its


def lean_fourbar(th2, w2=1.0, tol=1e-12, ncoarse=24, maxit=30):
    """This bench's own lean batched Newton of the four-bar (as :func:`shared_fourbar`,
    the two angles' cosines and sines in two calls, the residual from one array)."""
    a, b, c, d = R.A2, R.B3, R.C4, R.D1
    th2 = np.asarray(th2, float)
    n = len(th2)
    uc, k, H = uniform_coarse(th2, ncoarse)
    Qc, Tc = _continue(*_fourbar_step(a, b, c, d), uc, _fourbar_start(th2), tol, cubic=True)
    q = np.ascontiguousarray(hermite_uniform(Qc, Tc, k, H, n))
    pred = q.copy()
    ca, sa = a * np.cos(th2), a * np.sin(th2)
    ca_d = ca - d
    cs = np.empty((2, 2, n))
    cq, sq = cs
    F = np.empty((2, n))
    D = np.empty((2, n))
    fresh = False
    for its in range(maxit + 1):
        if not fresh:
            np.cos(q, out=cq)
            np.sin(q, out=sq)
        bc3, cc4 = b * cq[0], c * cq[1]
        bs3, cs4 = b * sq[0], c * sq[1]
        np.subtract(ca_d + bc3, cc4, out=F[0])
        np.subtract(sa + bs3, cs4, out=F[1])
        res = float(np.abs(F).max())
        if res <= tol:
            break
        if not math.isfinite(res) or its == maxit:
            raise RuntimeError("batched Newton did not converge")
        f1, f2 = F
        idet = 1.0 / (bs3 * cc4 - cs4 * bc3)  # J = [[-b s3, c s4], [b c3, -c c4]]
        np.multiply(cc4 * f1 + cs4 * f2, idet, out=D[0])
        np.multiply(bc3 * f1 + bs3 * f2, idet, out=D[1])
        q += D
        fresh = _rotate(cs, D)
    if float(np.abs(q - pred).max()) > MAX_JUMP:
        raise RuntimeError("batched Newton jumped off the predicted branch")
    idet = 1.0 / (bs3 * cc4 - cs4 * bc3)
    r1, r2 = sa * w2, -ca * w2
    w3 = -(cc4 * r1 + cs4 * r2) * idet
    w4 = -(bc3 * r1 + bs3 * r2) * idet
    g1 = ca * (w2 * w2) + bc3 * (w3 * w3) - cc4 * (w4 * w4)
    g2 = sa * (w2 * w2) + bs3 * (w3 * w3) - cs4 * (w4 * w4)
    al3 = -(cc4 * g1 + cs4 * g2) * idet
    al4 = -(bc3 * g1 + bs3 * g2) * idet
    return q[0], q[1], w3, w4, al3, al4, its
