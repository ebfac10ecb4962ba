"""The Newton groups' compiled kernels (numba): the coarse continuation's plain steps of a
small revolute group, the same arithmetic in the same order as the Python floats of
:meth:`~mechsolve.groups.reduced._Eqs.newton_list`,
:meth:`~mechsolve.groups.reduced._Angles.poses_one` and
:meth:`~mechsolve.groups.newton_batched.BatchedSweep._coarse_floats` (bit for bit on one
machine: the same IEEE operations, no reassociation, the same libm ``cos`` and ``sin``).

This module imports numba: only :func:`mechsolve.groups.compiled.kernels` imports it,
when the compiled path is asked for (see :mod:`mechsolve.groups.compiled`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def _pymax_abs(v: np.ndarray) -> float:
    """``max(abs(x) for x in v)`` as Python computes it: a later item replaces the
    largest so far only if it compares greater (a NaN first stays; a NaN later is
    skipped)."""
    m = abs(v[0])
    for j in range(1, v.shape[0]):
        a = abs(v[j])
        if a > m:
            m = a
    return m


@njit(cache=True, error_model="numpy")
def _solve_small(J: np.ndarray, f: np.ndarray, dx: np.ndarray) -> bool:
    """:func:`~mechsolve.groups.reduced._solve_small` into ``dx``; False where ``J`` is
    exactly singular."""
    n = f.shape[0]
    if n == 1:
        if J[0, 0] == 0:
            return False
        dx[0] = -f[0] / J[0, 0]
        return True
    if n == 2:
        a, b, c, d = J[0, 0], J[0, 1], J[1, 0], J[1, 1]
        det = a * d - b * c
        if det == 0:
            return False
        dx[0] = -(d * f[0] - b * f[1]) / det
        dx[1] = -(a * f[1] - c * f[0]) / det
        return True
    if n == 3:
        a, b, c = J[0, 0], J[0, 1], J[0, 2]
        d, e, g = J[1, 0], J[1, 1], J[1, 2]
        h, i, k = J[2, 0], J[2, 1], J[2, 2]
        A, B, C = e * k - g * i, g * h - d * k, d * i - e * h
        det = a * A + b * B + c * C
        if det == 0:
            return False
        D, E, G = c * i - b * k, a * k - c * h, b * h - a * i
        H, II, L = b * g - c * e, c * d - a * g, a * e - b * d
        f0, f1, f2 = f[0], f[1], f[2]
        dx[0] = -(A * f0 + D * f1 + H * f2) / det
        dx[1] = -(B * f0 + E * f1 + II * f2) / det
        dx[2] = -(C * f0 + G * f1 + L * f2) / det
        return True
    if n == 4:
        return _solve4(J, f, dx)
    return _gauss_small(J, f, dx)


@njit(cache=True, error_model="numpy")
def _solve4(J: np.ndarray, f: np.ndarray, dx: np.ndarray) -> bool:
    """:func:`~mechsolve.groups.reduced._solve4`: the adjugate from the 2 x 2 minors."""
    a00, a01, a02, a03 = J[0, 0], J[0, 1], J[0, 2], J[0, 3]
    a10, a11, a12, a13 = J[1, 0], J[1, 1], J[1, 2], J[1, 3]
    a20, a21, a22, a23 = J[2, 0], J[2, 1], J[2, 2], J[2, 3]
    a30, a31, a32, a33 = J[3, 0], J[3, 1], J[3, 2], J[3, 3]
    s0, s1, s2 = a00 * a11 - a10 * a01, a00 * a12 - a10 * a02, a00 * a13 - a10 * a03
    s3, s4, s5 = a01 * a12 - a11 * a02, a01 * a13 - a11 * a03, a02 * a13 - a12 * a03
    c5, c4, c3 = a22 * a33 - a32 * a23, a21 * a33 - a31 * a23, a21 * a32 - a31 * a22
    c2, c1, c0 = a20 * a33 - a30 * a23, a20 * a32 - a30 * a22, a20 * a31 - a30 * a21
    det = s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0
    if det == 0:
        return False
    f0, f1, f2, f3 = f[0], f[1], f[2], f[3]
    r = -1.0 / det
    dx[0] = r * (
        (a11 * c5 - a12 * c4 + a13 * c3) * f0
        + (-a01 * c5 + a02 * c4 - a03 * c3) * f1
        + (a31 * s5 - a32 * s4 + a33 * s3) * f2
        + (-a21 * s5 + a22 * s4 - a23 * s3) * f3
    )
    dx[1] = r * (
        (-a10 * c5 + a12 * c2 - a13 * c1) * f0
        + (a00 * c5 - a02 * c2 + a03 * c1) * f1
        + (-a30 * s5 + a32 * s2 - a33 * s1) * f2
        + (a20 * s5 - a22 * s2 + a23 * s1) * f3
    )
    dx[2] = r * (
        (a10 * c4 - a11 * c2 + a13 * c0) * f0
        + (-a00 * c4 + a01 * c2 - a03 * c0) * f1
        + (a30 * s4 - a31 * s2 + a33 * s0) * f2
        + (-a20 * s4 + a21 * s2 - a23 * s0) * f3
    )
    dx[3] = r * (
        (-a10 * c3 + a11 * c1 - a12 * c0) * f0
        + (a00 * c3 - a01 * c1 + a02 * c0) * f1
        + (-a30 * s3 + a31 * s1 - a32 * s0) * f2
        + (a20 * s3 - a21 * s1 + a22 * s0) * f3
    )
    return True


@njit(cache=True, error_model="numpy")
def _gauss_small(J: np.ndarray, f: np.ndarray, dx: np.ndarray) -> bool:
    """:func:`~mechsolve.groups.reduced._gauss_small`: partial pivoting, then back
    substitution."""
    n = f.shape[0]
    A = np.empty((n, n + 1))
    for i in range(n):
        for j in range(n):
            A[i, j] = J[i, j]
        A[i, n] = -f[i]
    for j in range(n):
        p, big = j, abs(A[j, j])
        for i in range(j + 1, n):
            v = abs(A[i, j])
            if v > big:
                p, big = i, v
        if big == 0:
            return False
        piv = A[p, j]
        if p != j:
            for c in range(n + 1):
                A[j, c], A[p, c] = A[p, c], A[j, c]
        for i in range(j + 1, n):
            m = A[i, j] / piv
            if m != 0:
                for c in range(j + 1, n + 1):
                    A[i, c] -= m * A[j, c]
    for j in range(n - 1, -1, -1):
        acc = A[j, n]
        for c in range(j + 1, n):
            acc -= A[j, c] * dx[c]
        dx[j] = acc / A[j, j]
    return True


@njit(cache=True, error_model="numpy")
def newton(K, x, M1, M2, M3, nz, atol, max_iterations, predict):
    """:meth:`~mechsolve.groups.reduced._Eqs.newton_list` on ``x`` in place: returns
    ``(converged, iterations)``."""
    if x.shape[0] == 2:
        return _newton2(K, x, M1, M2, M3, atol, max_iterations, predict)
    return _newton_n(K, x, M1, M2, M3, nz, atol, max_iterations, predict)


@njit(cache=True, error_model="numpy")
def _newton2(K, x, M1, M2, M3, atol, max_iterations, predict):
    """:meth:`~mechsolve.groups.reduced._Eqs._newton_list2`, unrolled as there."""
    xtol = 1e-3 * atol
    inf = math.inf
    last = r = r_prev = inf
    a1, a2, a3 = M1[0, 0], M2[0, 0], M3[0, 0]
    b1, b2, b3 = M1[0, 1], M2[0, 1], M3[0, 1]
    c1, c2, c3 = M1[1, 0], M2[1, 0], M3[1, 0]
    d1, d2, d3 = M1[1, 1], M2[1, 1], M3[1, 1]
    k0, k1 = K[0], K[1]
    x0, x1 = x[0], x[1]
    for it in range(max_iterations + 1):
        C0, C1, S0, S1 = math.cos(x0), math.cos(x1), math.sin(x0), math.sin(x1)
        f0 = k0 + a1 * C0 + a2 * S0 + a3 * x0 + b1 * C1 + b2 * S1 + b3 * x1
        f1 = k1 + c1 * C0 + c2 * S0 + c3 * x0 + d1 * C1 + d2 * S1 + d3 * x1
        r = abs(f0)
        if abs(f1) > r:
            r = abs(f1)
        if not r <= 1e300 or (it > 3 and r > 2 * r_prev):
            break
        r_prev = r
        if r <= atol and (last <= xtol or r == 0.0):
            x[0], x[1] = x0, x1
            return True, it
        if it == max_iterations:
            break
        ja, jb = a2 * C0 - a1 * S0 + a3, b2 * C1 - b1 * S1 + b3
        jc, jd = c2 * C0 - c1 * S0 + c3, d2 * C1 - d1 * S1 + d3
        det = ja * jd - jb * jc
        if det == 0:
            break
        dx0, dx1 = -(jd * f0 - jb * f1) / det, -(ja * f1 - jc * f0) / det
        step = abs(dx0)
        if abs(dx1) > step:
            step = abs(dx1)
        if not step <= 1e300:
            break
        if r <= atol and step >= last:
            x[0], x[1] = x0, x1
            return True, it
        x0, x1 = x0 + dx0, x1 + dx1
        if predict and step <= 0.5 * last and 0.5 * last < inf:
            if 2 * step * step <= xtol * last:
                x[0], x[1] = x0, x1
                return True, it + 1
        last = step
    x[0], x[1] = x0, x1
    return r <= atol, max_iterations


@njit(cache=True, error_model="numpy")
def _newton_n(K, x, M1, M2, M3, nz, atol, max_iterations, predict):
    """:meth:`~mechsolve.groups.reduced._Eqs.newton_list` for other than two angles."""
    nb = x.shape[0]
    xtol = 1e-3 * atol
    inf = math.inf
    last = r = r_prev = inf
    c = np.empty(nb)
    s = np.empty(nb)
    f = np.empty(nb)
    J = np.empty((nb, nb))
    dx = np.empty(nb)
    for it in range(max_iterations + 1):
        for k in range(nb):
            c[k] = math.cos(x[k])
            s[k] = math.sin(x[k])
        for e in range(nb):
            fe = K[e]
            for k in range(nb):
                if nz[e, k]:  # the nonzero terms only, as _Eqs._terms
                    ck, sk = c[k], s[k]
                    m1, m2, m3 = M1[e, k], M2[e, k], M3[e, k]
                    fe += m1 * ck + m2 * sk + m3 * x[k]
                    J[e, k] = m2 * ck - m1 * sk + m3
                else:
                    J[e, k] = 0.0
            f[e] = fe
        r = _pymax_abs(f)
        if not r <= 1e300 or (it > 3 and r > 2 * r_prev):
            break
        r_prev = r
        if r <= atol and (last <= xtol or r == 0.0):
            return True, it
        if it == max_iterations:
            break
        if not _solve_small(J, f, dx):
            break
        step = _pymax_abs(dx)
        if not step <= 1e300:
            break
        if r <= atol and step >= last:
            return True, it
        for k in range(nb):
            x[k] = x[k] + dx[k]
        if predict and step <= 0.5 * last and 0.5 * last < inf:
            if 2 * step * step <= xtol * last:
                return True, it + 1
        last = step
    return r <= atol, max_iterations


@njit(cache=True, error_model="numpy")
def poses(th, Px, Py, wptr, wk, wa, wb, q):
    """:meth:`~mechsolve.groups.reduced._Angles.poses_one` into ``q`` (x, y, angle of
    each link in turn)."""
    nb = th.shape[0]
    c = np.empty(nb)
    s = np.empty(nb)
    for k in range(nb):
        c[k] = math.cos(th[k])
        s[k] = math.sin(th[k])
    for b in range(nb):
        px, py = Px[b], Py[b]
        for t in range(wptr[b], wptr[b + 1]):
            k, a, bb = wk[t], wa[t], wb[t]
            ck, sk = c[k], s[k]
            px += ck * a - sk * bb
            py += sk * a + ck * bb
        q[3 * b] = px
        q[3 * b + 1] = py
        q[3 * b + 2] = th[b]


@njit(cache=True, error_model="numpy")
def _extrapolate(hu, hq, nh, u, out):
    """:func:`~mechsolve.groups.newton_common._extrapolate_floats` from the ``nh`` rows
    of the history into ``out``."""
    n = out.shape[0]
    if nh == 1:
        for j in range(n):
            out[j] = hq[0, j]
        return
    w = np.empty(nh)
    for i in range(nh):
        wi = 1.0
        for j in range(nh):
            if j != i:
                den = hu[i] - hu[j]
                if den == 0:
                    for m in range(n):
                        out[m] = hq[nh - 1, m]
                    return
                wi *= (u - hu[j]) / den
        w[i] = wi
    if nh == 2:
        for j in range(n):
            out[j] = w[0] * hq[0, j] + w[1] * hq[1, j]
    else:
        for j in range(n):
            out[j] = w[0] * hq[0, j] + w[1] * hq[1, j] + w[2] * hq[2, j]


@njit(cache=True, error_model="numpy")
def _tangent_pose(q0, x, thp, Px, Py, free, fixed, w, th, q_pred):
    """The rest of :meth:`~mechsolve.groups.newton_batched.BatchedSweep._tangent_floats`
    into ``q_pred``: the pose whose free angles are the tangent step's ``x``, the fixed
    ones ``thp``, the others ``q0``'s; ``q0`` itself where an angle is not finite."""
    nb = th.shape[0]
    for k in range(nb):
        th[k] = q0[3 * k + 2]
    for j in range(free.shape[0]):
        th[free[j]] = x[j]
    for j in range(fixed.shape[0]):
        th[fixed[j]] = thp[j]
    for k in range(nb):
        if not math.isfinite(th[k]):
            for j in range(q_pred.shape[0]):
                q_pred[j] = q0[j]
            return
    poses(th, Px, Py, w[0], w[1], w[2], w[3], q_pred)


@njit(cache=True, error_model="numpy")
def coarse_run(
    i0, u, Kr, thp, Px, Py, q_start, hu, hq, nh,
    out, iters, free, fixed, M1, M2, M3, nz, wptr, wk, wa, wb, jw, atol, max_iterations,
    max_jump,
):  # fmt: skip
    """The coarse continuation's plain steps from position ``i0``, as
    :meth:`~mechsolve.groups.newton_batched.BatchedSweep._coarse_floats` takes them:
    each position predicted (from the start's pose, along the tangent after one
    position, else by Lagrange extrapolation of the history ``hu``, ``hq``: its ``nh``
    rows, updated in place), solved by Newton in the free angles, posed, and checked
    against ``max_jump`` (:data:`~mechsolve.groups.newton_common.MAX_JUMP`); poses
    into ``out``, iterations into ``iters``. Returns ``(i, nh)``: the first position
    whose step is not plain (the caller takes it by the general step, then calls again
    from ``i + 1``), or the number of positions."""
    n = u.shape[0]
    nq = out.shape[1]
    nb = Px.shape[1]
    nf = free.shape[0]
    q_pred = np.empty(nq)
    q = np.empty(nq)
    th = np.empty(nb)
    x = np.empty(nf)
    # (typed variables, not literals: numba compiles a function again for each literal
    # argument value, which would double the first call's compilation of newton)
    one, yes = max_iterations // max_iterations, max_iterations > 0
    w = (wptr, wk, wa, wb)
    for i in range(i0, n):
        ui = u[i]
        if nh == 0:
            for j in range(nq):
                q_pred[j] = q_start[j]
        elif nh == 1:  # the tangent step (_tangent_floats)
            for j in range(nf):
                x[j] = hq[0, 3 * free[j] + 2]
            newton(Kr[i], x, M1, M2, M3, nz, atol, one, not yes)
            _tangent_pose(hq[0], x, thp[i], Px[i], Py[i], free, fixed, w, th, q_pred)
        else:
            _extrapolate(hu, hq, nh, ui, q_pred)
        for j in range(nf):
            x[j] = q_pred[3 * free[j] + 2]
        plain, it = newton(Kr[i], x, M1, M2, M3, nz, atol, max_iterations, yes)
        if not plain:
            return i, nh
        for j in range(nf):
            th[free[j]] = x[j]
        for j in range(fixed.shape[0]):
            th[fixed[j]] = thp[i, j]
        poses(th, Px[i], Py[i], wptr, wk, wa, wb, q)
        if nh:
            jump = abs(q[0] - q_pred[0]) * jw[0]
            for j in range(1, nq):
                d = abs(q[j] - q_pred[j]) * jw[j]
                if d > jump:
                    jump = d
            if not jump <= max_jump:
                return i, nh
        for j in range(nq):
            out[i, j] = q[j]
        iters[i] = it
        if nh == 3:
            hu[0], hu[1], hu[2] = hu[1], hu[2], ui
            for j in range(nq):
                hq[0, j], hq[1, j], hq[2, j] = hq[1, j], hq[2, j], q[j]
        else:
            hu[nh] = ui
            for j in range(nq):
                hq[nh, j] = q[j]
            nh += 1
    return n, nh


@njit(cache=True, error_model="numpy", inline="always")
def _rotate1(C, S, p, D, th):
    """:func:`~mechsolve.groups.newton_batched._rotate` at position ``p``."""
    d2 = D * D
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0))
    sd = D * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0)))
    Cp, Sp = C[p], S[p]
    c = Cp * cd
    c -= Sp * sd
    s = Sp * cd
    s += Cp * sd
    if not abs(D) < 1e-3:
        c, s = math.cos(th), math.sin(th)
    C[p], S[p] = c, s


@njit(cache=True, error_model="numpy", inline="always")
def _rotate2(C, S, p, k, D, th):
    """:func:`_rotate1` at ``[p, k]`` of (N, n) arrays (no row views: each costs a
    reference count)."""
    d2 = D * D
    cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0))
    sd = D * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0)))
    Cp, Sp = C[p, k], S[p, k]
    c = Cp * cd
    c -= Sp * sd
    s = Sp * cd
    s += Cp * sd
    if not abs(D) < 1e-3:
        c, s = math.cos(th), math.sin(th)
    C[p, k], S[p, k] = c, s


@njit(cache=True, error_model="numpy", inline="always")
def _nanmax2(a, b):
    """``np.maximum(a, b)`` of two floats: NaN if either is."""
    if a != a or b != b:
        return math.nan
    return a if a >= b else b


@njit(cache=True, error_model="numpy")
def refine2(x0, x1, K0, K1, todo, iters, co, nd, atol, max_iterations, C0, S0, C1, S1, have_cs):
    """:meth:`~mechsolve.groups.newton_batched.BatchedSweep._refine2` in one loop per
    iteration over the positions: the same residual, step (by the adjugate), tests and
    updates, position by position in the same order of operations as the NumPy
    path's elementwise arithmetic (whole arrays while at least half the positions
    iterate, as there: the cosines and sines then kept and turned with every step).
    ``co``: the loop's coefficients ``a1, a2, a3, b1, b2, b3, c1, c2, c3, d1, d2, d3``.
    Updates the angles, ``todo`` and ``iters`` in place and the cosines and sines
    ``C0, S0, C1, S1`` (the state's; ``have_cs``: they hold those of the angles
    already, as NumPy's vectorised ``cos`` and ``sin`` give them at the first iteration
    over whole arrays). Returns whether every position converged."""
    n = x0.shape[0]
    last = np.full(n, math.inf)
    tol = 1e-3 * atol
    for it_k in range(max_iterations):
        count = 0
        for p in range(n):
            if todo[p]:
                count += 1
        if count == 0:
            break
        whole = 2 * count >= n
        if whole and not have_cs:
            for p in range(n):
                C0[p], S0[p] = math.cos(x0[p]), math.sin(x0[p])
                C1[p], S1[p] = math.cos(x1[p]), math.sin(x1[p])
            have_cs = True
        for p in range(n):
            tp = todo[p]
            if not (whole or tp):
                continue
            t0, t1 = x0[p], x1[p]
            if have_cs:
                cc0, ss0, cc1, ss1 = C0[p], S0[p], C1[p], S1[p]
            else:
                cc0, ss0, cc1, ss1 = math.cos(t0), math.sin(t0), math.cos(t1), math.sin(t1)
            r, dq0, dq1, step = _step2(t0, t1, K0[p], K1[p], cc0, ss0, cc1, ss1, co, nd)
            lastk = last[p]
            small = step <= tol
            pred = it_k > 0 and 2.0 * step * step <= tol * lastk and step <= 0.5 * lastk
            done = (r <= atol and (small or step >= lastk)) or pred
            take = (not done) or small or pred
            if whole:
                take = take and tp
                D0 = dq0 if take else 0.0
                D1 = dq1 if take else 0.0
                x0[p] += D0
                x1[p] += D1
                if tp:
                    iters[p] += 1
                    last[p] = step
                    if done:
                        todo[p] = False
                _rotate1(C0, S0, p, D0, x0[p])
                _rotate1(C1, S1, p, D1, x1[p])
            else:
                iters[p] += 1
                last[p] = step
                if done:
                    todo[p] = False
                if take:
                    x0[p] += dq0
                    x1[p] += dq1
                    if have_cs:
                        _rotate1(C0, S0, p, dq0, x0[p])
                        _rotate1(C1, S1, p, dq1, x1[p])
    ok = True
    for p in range(n):
        if todo[p] or not (math.isfinite(x0[p]) and math.isfinite(x1[p])):
            ok = False
    if ok and not have_cs:
        for p in range(n):
            C0[p], S0[p] = math.cos(x0[p]), math.sin(x0[p])
            C1[p], S1[p] = math.cos(x1[p]), math.sin(x1[p])
    return ok


@njit(cache=True, error_model="numpy", inline="always")
def _step2(t0, t1, k0, k1, cc0, ss0, cc1, ss1, co, nd):
    """:func:`~mechsolve.groups.newton_batched._newton_step2` at one position: the
    residual's size, the step and its size (NaN where the Jacobian is exactly
    singular), in the same order of operations."""
    a1, a2, a3, b1, b2, b3 = co[0], co[1], co[2], co[3], co[4], co[5]
    c1, c2, c3, d1, d2, d3 = co[6], co[7], co[8], co[9], co[10], co[11]
    f0 = k0 + a1 * cc0
    f0 += a2 * ss0
    f0 += b1 * cc1
    f0 += b2 * ss1
    f1 = k1 + c1 * cc0
    f1 += c2 * ss0
    f1 += d1 * cc1
    f1 += d2 * ss1
    ja = a2 * cc0
    ja -= a1 * ss0
    jb = b2 * cc1
    jb -= b1 * ss1
    jc = c2 * cc0
    jc -= c1 * ss0
    jd = d2 * cc1
    jd -= d1 * ss1
    if nd:
        f0 += a3 * t0
        f0 += b3 * t1
        f1 += c3 * t0
        f1 += d3 * t1
        ja += a3
        jb += b3
        jc += c3
        jd += d3
    r = _nanmax2(abs(f0), abs(f1))
    det = ja * jd
    det -= jb * jc
    dq0 = jb * f1
    dq0 -= jd * f0
    dq1 = jc * f0
    dq1 -= ja * f1
    dq0 /= det  # (IEEE: inf or NaN where det is 0, as NumPy gives them)
    dq1 /= det
    step = _nanmax2(abs(dq0), abs(dq1)) if det != 0 else math.nan
    return r, dq0, dq1, step


@njit(cache=True, error_model="numpy")
def hermite(u, coarse, qc, dqc, pred):
    """:meth:`~mechsolve.groups.newton_batched.BatchedSweep.sweep_batched`'s cubic
    Hermite prediction into ``pred`` (N, n): each position's segment between the
    coarse positions ``coarse`` (the last position in the last segment), its polynomial
    in ``t = (u - u0) / (u1 - u0)`` by Horner, in the NumPy path's order of
    operations."""
    n, nq = pred.shape
    ns = coarse.shape[0] - 1
    for s in range(ns):
        p0 = coarse[s]
        p1 = coarse[s + 1] if s + 1 < ns else n
        u0 = u[coarse[s]]
        h = u[coarse[s + 1]] - u0
        for j in range(nq):
            m0 = h * dqc[s, j]
            m1 = h * dqc[s + 1, j]
            dq = qc[s + 1, j] - qc[s, j]
            c2 = 3 * dq - 2 * m0 - m1
            c3 = m0 + m1 - 2 * dq
            q0 = qc[s, j]
            for p in range(p0, p1):
                t = (u[p] - u0) / h
                v = c3 * t
                v += c2
                v *= t
                v += m0
                v *= t
                v += q0
                pred[p, j] = v


@njit(cache=True, error_model="numpy", inline="always")
def _elim_step(p, th, C, S, Kr, M1, M2, M3, nd, priv, rest, V, n2, coef, f, dq, work):
    """Position ``p``'s residual ``f`` and Newton step ``dq`` (``F_theta dq = -f``) of a
    group whose ``F_theta`` is eliminated to 2 x 2
    (:class:`~mechsolve.groups.eliminated.Eliminated`: ``priv`` each loop's own link,
    ``V`` its local vector and ``n2`` its squared length, ``rest`` the other two angles,
    ``coef`` the equations' ``(m1, m2, m3)`` over those two); returns the residual's
    and the step's largest components (NaN if any is)."""
    nb = th.shape[1]
    ne = priv.shape[0]
    for e in range(nb):
        a = 0.0
        for k in range(nb):
            a += C[k] * M1[e, k]
        b = 0.0
        for k in range(nb):
            b += S[k] * M2[e, k]
        fe = Kr[p, e] + a
        fe += b
        if nd:
            d = 0.0
            for k in range(nb):
                d += th[p, k] * M3[e, k]
            fe += d
        f[e] = fe
    r = abs(f[0])
    for e in range(1, nb):
        r = _nanmax2(r, abs(f[e]))
    R, P, g, rhs = work  # (2, 2), (ne, 2), (ne, 2), (2,): room, allocated once
    for e in range(ne):
        p = priv[e]
        gx = V[e, 0] * C[p] - V[e, 1] * S[p]
        gy = V[e, 1] * C[p] + V[e, 0] * S[p]
        g[e, 0], g[e, 1] = gx, gy
        for j in range(2):
            q = rest[j]
            jx = coef[e, j, 1] * C[q] - coef[e, j, 0] * S[q] + coef[e, j, 2]
            jy = coef[ne + e, j, 1] * C[q] - coef[ne + e, j, 0] * S[q] + coef[ne + e, j, 2]
            R[e, j] = gx * jx + gy * jy
            P[e, j] = -gy * jx + gx * jy
        rhs[e] = gx * f[e] + gy * f[ne + e]
    for r_ in range(2 * ne, nb):  # the drivers' rows: their own entries
        for j in range(2):
            q = rest[j]
            R[r_ - ne, j] = coef[r_, j, 1] * C[q] - coef[r_, j, 0] * S[q] + coef[r_, j, 2]
        rhs[r_ - ne] = f[r_]
    a, b, c, d = R[0, 0], R[0, 1], R[1, 0], R[1, 1]
    det = a * d - b * c
    x0 = (b * rhs[1] - d * rhs[0]) / det
    x1 = (c * rhs[0] - a * rhs[1]) / det
    dq[rest[0]], dq[rest[1]] = x0, x1
    for e in range(ne):
        gx, gy = g[e, 0], g[e, 1]
        t = gx * f[ne + e] - gy * f[e]
        t += P[e, 0] * x0
        t += P[e, 1] * x1
        dq[priv[e]] = t * (-1.0 / n2[e])
    step = abs(dq[0])  # (inf or NaN where F_theta is exactly singular, as in NumPy)
    for k in range(1, nb):
        step = _nanmax2(step, abs(dq[k]))
    return r, step


@njit(cache=True, error_model="numpy")
def refine_elim(th, Kr, todo, iters, Cf, Sf, have_cs, M1, M2, M3, nd, el, atol, max_iterations):
    """:meth:`~mechsolve.groups.newton_batched.BatchedSweep._refine_angles` for a group
    eliminated to 2 x 2 (the Stephenson triad), position by position: the same tests,
    updates and turned cosines and sines (whole arrays while at least half the
    positions iterate, as there), the residual and step by :func:`_elim_step` (to
    rounding those of the NumPy path, whose residual is a matrix product). ``el``:
    ``(priv, rest, V, n2, coef)``. Updates ``th``, ``todo``, ``iters`` and the cosines
    and sines ``Cf``, ``Sf`` (N, n) in place (``have_cs``: they hold those of ``th``
    already, as NumPy's vectorised ``cos`` and ``sin`` give them at the first
    iteration over whole arrays); returns whether every position converged."""
    priv, rest, V, n2, coef = el
    n, nb = th.shape
    last = np.full(n, math.inf)
    tol = 1e-3 * atol
    f = np.empty(nb)
    dq = np.empty(nb)
    C = np.empty(nb)
    S = np.empty(nb)
    ne = priv.shape[0]
    work = (np.empty((2, 2)), np.empty((ne, 2)), np.empty((ne, 2)), np.empty(2))
    for it_k in range(max_iterations):
        count = 0
        for p in range(n):
            if todo[p]:
                count += 1
        if count == 0:
            break
        whole = 2 * count >= n
        if whole and not have_cs:
            for p in range(n):
                for k in range(nb):
                    Cf[p, k], Sf[p, k] = math.cos(th[p, k]), math.sin(th[p, k])
            have_cs = True
        for p in range(n):
            tp = todo[p]
            if not (whole or tp):
                continue
            for k in range(nb):
                if have_cs:
                    C[k], S[k] = Cf[p, k], Sf[p, k]
                else:
                    C[k], S[k] = math.cos(th[p, k]), math.sin(th[p, k])
            r, step = _elim_step(
                p, th, C, S, Kr, M1, M2, M3, nd, priv, rest, V, n2, coef, f, dq, work
            )
            lastk = last[p]
            small = step <= tol
            pred = it_k > 0 and 2.0 * step * step <= tol * lastk and step <= 0.5 * lastk
            done = (r <= atol and (small or step >= lastk)) or pred
            take = (not done) or small or pred
            if whole:
                take = take and tp
            else:
                iters[p] += 1
                last[p] = step
                if done:
                    todo[p] = False
            if whole and tp:
                iters[p] += 1
                last[p] = step
                if done:
                    todo[p] = False
            if take or whole:
                for k in range(nb):
                    D = dq[k] if take else 0.0
                    th[p, k] += D
                    if have_cs:
                        _rotate2(Cf, Sf, p, k, D, th[p, k])
    ok = True
    for p in range(n):
        if todo[p]:
            ok = False
        for k in range(nb):
            if not math.isfinite(th[p, k]):
                ok = False
    if ok and not have_cs:
        for p in range(n):
            for k in range(nb):
                Cf[p, k], Sf[p, k] = math.cos(th[p, k]), math.sin(th[p, k])
    return ok
