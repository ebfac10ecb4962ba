"""Friction in the joints: the force analysis iterated at every position.

A joint with friction (:attr:`~mechsolve.joints.base.Constraint.coulomb`,
:attr:`~mechsolve.joints.base.Constraint.viscous`) resists its relative motion (its
:meth:`~mechsolve.joints.base.Constraint.slip`: a pin's relative angular speed, a
slider's sliding speed) with a friction of magnitude

``t_j = k_j L_j(lambda) + c_j |slip_j|``

where ``L_j`` is the load Coulomb's law multiplies (a pin's force magnitude ``|F|``, a
slider's normal force ``|N|``), ``k_j`` its Coulomb factor (the friction circle
``rho = f r`` of a pin, the coefficient ``f`` of a slider) and ``c_j`` its viscous
coefficient. Where the slip is zero the Coulomb part has no direction and is left out
(a joint at rest relative to itself carries no Coulomb moment or force).

The reactions are linear in the known loads, ``lambda = A(Q)`` (the ideal force
analysis), so with frictions ``t``::

    lambda(t) = lambda_0 + sum_j t_j U_j,   U_j = A(g_j)

with ``g_j`` the generalised force of a unit friction at joint ``j`` opposing its slip.
The Coulomb magnitudes ``s_j = k_j L_j(lambda(s + v))`` (``v_j = c_j |slip_j|``) are
found by Newton's method on ``F(s) = s - k * L(lambda)``, whose Jacobian is
``I - G`` with ``G_ji = k_j (dL_j / dlambda) . U_i``, to a relative tolerance of
:data:`TOLERANCE` on every magnitude.

Self-locking: a solution is physical when ``det(I - G) > 0`` (it is connected to the
frictionless one: the ideal problem has ``G = 0``). Where Newton's method finds none, the
friction is raised from zero to its value step by step (a continuation in ``tau``, the
fraction of every coefficient); if ``det(I - tau G)`` falls to zero on the way, the
driving effort grows without bound there: the position is self-locking (no finite
driving effort moves the mechanism in the drive direction).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.errors import SolverError
from mechsolve.core.force_result import FrictionResult
from mechsolve.core.loads import _Q

if TYPE_CHECKING:
    from mechsolve.core.sweep import Analysis

TOLERANCE = 1e-12  # the Newton iteration's relative tolerance on each friction magnitude
MAX_ITERATIONS = 60
ZERO_SLIP = 1e-12  # a slip below this fraction of its largest over the sweep is zero
LOCK_DET = 1e-5  # det(I - G) below this on the continuation: the effort is unbounded


def frictional(an: Analysis) -> list:
    """The rows of the constraints with friction."""
    return [r for r in an.system.rows if r.constraint.coulomb > 0 or r.constraint.viscous > 0]


def solve_friction(
    an: Analysis,
    st,
    lam0: np.ndarray,
    solve: Callable[[np.ndarray], np.ndarray],
    effort_row: int,
    where: Callable[[int], str],
    smoothing: tuple[np.ndarray, float] | None = None,
    hint: tuple | None = None,
) -> tuple[np.ndarray, FrictionResult]:
    """The multipliers with friction and what friction changes.

    Parameters
    ----------
    lam0
        The multipliers without friction (N, nc).
    solve
        ``solve(Q)``: the multipliers (N, nc) that balance the generalised forces ``Q``
        (3 nb, N) alone (linear).
    effort_row
        The driver's row in the multipliers (its effort is ``-lambda[:, row]``).
    where
        A position in words, for the message when the iteration does not converge.
    smoothing
        ``(speed, s0)``: the Coulomb parts regularised by the driver's ``speed`` at each
        position, ``tanh(|speed| / s0)`` times their value (for the equation of motion,
        which needs friction continuous through a standstill); None: exact Coulomb.
    hint
        The equation of motion's friction (see :func:`balance`): ``(law, magnitudes)``.
        ``law``: the friction law at the same position and speed (one position; None
        else), whose unit frictions are reused; ``magnitudes`` (K,) or (K, N): the
        Coulomb magnitudes that start Newton's method (NaN: its usual start). A solution
        reached from them is kept even where ``det(I - G) <= 0``: at a given
        acceleration that marks the force analysis's self-locking, but the equation of
        motion (the acceleration free) has its own criterion, which :func:`balance`
        checked.
    """
    like = None if hint is None or st.n != 1 else hint[0]
    law = _Law(an, st, lam0, solve, smoothing, like)
    K, n = law.k.shape
    good = np.all(np.isfinite(law.lamv), axis=1) & np.all(np.isfinite(law.U), axis=(0, 2))
    s, done, steps = _newton(law, np.flatnonzero(good), None if hint is None else hint[1])
    locked = np.zeros(n, bool)
    rest = np.flatnonzero(good & ~done)
    if rest.size:
        sr, status, det_last = _continue(rest, law.k[:, rest], law)
        s[:, rest] = sr
        locked[rest[status == 1]] = True
        if np.any(status == 2):
            i = int(np.flatnonzero(status == 2)[0])
            raise SolverError(
                f"the force analysis with friction did not converge at {where(int(rest[i]))}: "
                f"the iteration stalled (det(I - G) = {det_last[i]:.3g}), more than "
                f"{MAX_ITERATIONS} Newton steps to a relative {TOLERANCE:g}"
            )
    tot = s + law.v
    lam = law.lamv + np.einsum("kn,knc->nc", s, law.U)
    lam[locked] = np.nan
    out = FrictionResult(iterations=steps)
    law.s = s
    out.law = law  # for the equation of motion: see balance
    out.locked = locked
    out.ideal_effort = -lam0[:, effort_row]
    for j, r in enumerate(law.rows):
        t = np.where(good & ~locked, tot[j], np.nan)
        out.friction[r.constraint.name] = t
        out.loss[r.constraint.name] = t * law.slips[j]
    return lam, out


class _Law:
    """The friction law of the joints with friction, linearised about the ideal solution:
    ``U`` (K, N, nc) the multipliers of a unit friction at each, ``k`` (K, N) their
    Coulomb factors (zero where the slip is), ``v`` (K, N) their viscous frictions,
    ``lamv`` the multipliers with the viscous frictions, ``slips`` their |slip|."""

    def __init__(
        self, an: Analysis, st, lam0: np.ndarray, solve: Callable, smoothing=None, like=None
    ) -> None:
        """``like``: the law at another state with the same positions and velocities
        (its first position), whose unit frictions are taken where its factors agree."""
        self.rows = frictional(an)
        n, K = st.n, len(self.rows)
        self.U = np.zeros((K, n, lam0.shape[1]))
        self.k = np.zeros((K, n))
        self.v = np.zeros((K, n))
        self.slips = []
        for j, r in enumerate(self.rows):
            c = r.constraint
            slip = c.slip(st)
            big = np.nanmax(np.abs(slip)) if np.any(np.isfinite(slip)) else 0.0
            on = np.where(np.abs(slip) > ZERO_SLIP * big, 1.0, 0.0)
            soft = 1.0
            if smoothing is not None:
                speed, s0 = smoothing
                soft = np.abs(np.tanh(np.asarray(speed, float) / s0))
            self.k[j] = on * soft * c.coulomb
            self.v[j] = on * c.viscous * np.abs(slip)
            if like is not None and like.k[j, 0] == self.k[j, 0] and like.v[j, 0] == self.v[j, 0]:
                self.U[j] = like.U[j, :1]
            else:
                acc = _Q(an, st)
                for body, x, y, fx, fy, t in c.friction_pull(st):
                    if body != an.system.nb:
                        acc.force(body, None, fx * on, fy * on, (x - st.x[body], y - st.y[body]))
                        acc.torque(body, t * on)
                self.U[j] = solve(acc.Q)
            self.slips.append(np.abs(slip))
        self.lamv = lam0 + np.einsum("kn,knc->nc", self.v, self.U)

    def __call__(self, s: np.ndarray, idx, kk=None) -> tuple[np.ndarray, np.ndarray]:
        """L (K, n) and G (n, K, K) at the Coulomb magnitudes s (K, n) of positions idx
        (``kk``: the Coulomb factors there, if not the joints' own)."""
        kk = self.k[:, idx] if kk is None else kk
        U = self.U[:, idx]
        lam = self.lamv[idx] + np.einsum("kn,knc->nc", s, U)
        L = np.empty_like(s)
        G = np.empty((s.shape[1], len(self.rows), len(self.rows)))
        for j, r in enumerate(self.rows):
            c = r.constraint
            L[j], grad = c.load(lam[:, r.start : r.start + c.m])
            G[:, j, :] = kk[j][:, None] * np.einsum(
                "nm,knm->nk", grad, U[..., r.start : r.start + c.m]
            )
        return L, G

    def scale(self, idx: np.ndarray) -> np.ndarray:
        """A magnitude's scale at positions idx, for the tolerance: the Coulomb factor
        times the largest multiplier (so that a friction that vanishes still converges)."""
        return self.k[:, idx] * np.max(np.abs(self.lamv[idx]), axis=1)[None] + 1e-300


def _newton(law: _Law, idx: np.ndarray, start=None) -> tuple[np.ndarray, np.ndarray, int]:
    """Newton's method on ``s - k L(lambda(s)) = 0`` at positions ``idx`` from the ideal
    solution's friction (or ``start``, (K,) or (K, n), where finite): the magnitudes,
    where a physical solution was found (converged, and ``det(I - G) > 0`` unless it
    started from ``start``: see :func:`solve_friction`) and the number of steps."""
    K, n = law.k.shape
    s = np.zeros((K, n))
    done = np.zeros(n, bool)
    given = np.zeros(n, bool)
    if start is not None:
        start = np.broadcast_to(np.asarray(start, float).reshape(K, -1), (K, n))
        given[idx] = np.all(np.isfinite(start[:, idx]), axis=0)
        s[:, given] = start[:, given]
    rest = idx[~given[idx]]
    if rest.size:
        s[:, rest] = law.k[:, rest] * law(s[:, rest], rest)[0]
    eye = np.eye(K)[None]
    steps = 0
    while idx.size and steps < MAX_ITERATIONS:
        steps += 1
        L, G = law(s[:, idx], idx)
        F = s[:, idx] - law.k[:, idx] * L
        with np.errstate(all="ignore"):
            ds = np.linalg.solve(eye - G, -F.T[..., None])[..., 0].T
        bad = ~np.all(np.isfinite(ds), axis=0)
        ds[:, bad] = 0.0
        # converged where the step is small, or the residual is rounding (next to
        # det(I - G) = 0 the step is rounding amplified by 1 / det and need not shrink)
        flat = np.all(np.abs(F) <= 1e-14 * (np.abs(s[:, idx]) + law.scale(idx)), axis=0)
        ds[:, flat] = 0.0
        s[:, idx] += ds
        small = np.all(np.abs(ds) <= TOLERANCE * (np.abs(s[:, idx]) + law.scale(idx)), axis=0)
        done[idx[small]] = True
        idx = idx[~(small | bad)]
    # a solution is kept where det(I - G) > 0 (connected to the frictionless one)
    idx = np.flatnonzero(done)
    if idx.size:
        L, G = law(s[:, idx], idx)
        det = np.linalg.det(eye - G)
        resid = np.abs(s[:, idx] - law.k[:, idx] * L)
        close = np.all(resid <= 1e-9 * (np.abs(s[:, idx]) + law.scale(idx)), axis=0)
        done[idx[((det <= 0) & ~given[idx]) | ~close]] = False
    return s, done, steps


def _continue(
    idx: np.ndarray, k: np.ndarray, loads: Callable
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raise the friction at positions ``idx`` from zero to its value (``tau`` from 0 to
    1, ``k`` the Coulomb factors there), Newton's method at each step from the last.

    Returns the magnitudes at ``tau = 1``, a status per position (0: solved, 1:
    ``det(I - tau G)`` fell to zero on the way: self-locking, 2: the iteration stalled
    elsewhere) and the last ``det(I - tau G)``.
    """
    K, m = k.shape
    tau = np.zeros(m)
    step = np.full(m, 1.0 / 16)
    s = np.zeros((K, m))
    det_last = np.ones(m)
    status = np.full(m, -1)
    eye = np.eye(K)[None]
    while np.any(status < 0):
        act = np.flatnonzero(status < 0)
        t1 = np.minimum(1.0, tau[act] + step[act])
        kk = k[:, act] * t1
        trial = s[:, act].copy()
        conv = np.zeros(act.size, bool)
        for _ in range(12):  # from a nearby solution: a few steps, or none exists
            L, G = loads(trial, idx[act], kk)
            F = trial - kk * L
            with np.errstate(all="ignore"):
                ds = np.linalg.solve(eye - G, -F.T[..., None])[..., 0].T
            ds[:, ~np.all(np.isfinite(ds), axis=0)] = np.nan
            trial = np.where(conv, trial, trial + np.nan_to_num(ds))
            conv |= np.all(np.abs(ds) <= TOLERANCE * (np.abs(trial) + 1e-300), axis=0)
            if conv.all():
                break
        L, G = loads(trial, idx[act], kk)
        det = np.linalg.det(eye - G)
        ok = conv & (det > 0)
        a_ok, a_no = act[ok], act[~ok]
        tau[a_ok], s[:, a_ok], det_last[a_ok] = t1[ok], trial[:, ok], det[ok]
        step[a_ok] = np.minimum(2 * step[a_ok], 1.0 / 16)
        status[a_ok[tau[a_ok] >= 1.0]] = 0
        step[a_no] /= 2
        stuck = a_no[step[a_no] < 1e-8]
        status[stuck] = np.where(det_last[stuck] < LOCK_DET, 1, 2)
    return s, status, det_last


def balance(
    law: _Law, i0: int, i1: int, row: int, target: float, x: float, s: np.ndarray | None = None
) -> tuple[float, np.ndarray] | None:
    """The driver acceleration ``x`` at which the driving effort is ``target``, from the
    friction law of a force analysis at two states that differ only in it (``i0`` at
    zero driver acceleration, ``i1`` at one), and the Coulomb magnitudes there; or None
    where Newton's method does not converge.

    At one position and speed the ideal multipliers are affine in the acceleration,
    ``lamv(x) = lamv_0 + x (lamv_1 - lamv_0)``, and the unit frictions ``U`` and the
    factors ``k`` do not depend on it. So the Coulomb magnitudes ``s`` and ``x`` solve
    together ``s - k L(lamv(x) + s U) = 0`` and ``target + lambda_row = 0`` (the effort
    is ``-lambda_row``): Newton's method on these ``K + 1`` equations, from ``x`` and
    the magnitudes ``s`` (default: interpolated between the two states). The caller
    checks the result by the full force analysis at ``x``.

    A solution is physical where the Jacobian ``A`` of these equations has the sign of
    its determinant without friction, ``d_row`` (minus the reduced inertia): it is then
    connected to the frictionless motion, as the force analysis's solutions with
    ``det(I - G) > 0`` are at a given acceleration. ``det A = d_row det(I - G_m)``, with
    ``G_m`` the friction's feedback with the acceleration free (the Schur complement),
    the criterion of the general path (:mod:`~mechsolve.analyses.dynamics.multibody_friction`).
    Where the force analysis self-locks (``det(I - G) <= 0``: no finite effort drives
    the mechanism at that acceleration), the motion's friction can still balance: it
    brakes the mechanism, its reactions and its acceleration found together. Where no
    physical solution is found: None (for instance where Coulomb's law would have to
    stop the motion at once: no acceleration balances the effort).
    """
    a = law.lamv[i0]
    d = law.lamv[i1] - a
    U = law.U[:, i0]  # (K, nc)
    k = law.k[:, i0]
    if s is None or not np.all(np.isfinite(s)):
        s = law.s[:, i0] + x * (law.s[:, i1] - law.s[:, i0])
    s = np.array(s, float)
    K = len(law.rows)
    A = np.zeros((K + 1, K + 1))
    A[:K, :K] = np.eye(K)
    A[K, :K] = U[:, row]
    A[K, K] = d[row]
    F = np.empty(K + 1)
    sl = [slice(r.start, r.start + r.constraint.m) for r in law.rows]
    # the scales of x and of the magnitudes, for the tolerance where they vanish
    xs = max(abs(target), abs(a[row]), 1e-300) / max(abs(d[row]), 1e-300)
    ss = k * np.max(np.abs(a)) + 1e-300
    for _ in range(MAX_ITERATIONS):
        lam = a + x * d + s @ U
        for j, r in enumerate(law.rows):
            L, grad = r.constraint.load(lam[None, sl[j]])
            F[j] = s[j] - k[j] * L[0]
            A[j, :K] = -k[j] * (U[:, sl[j]] @ grad[0])
            A[j, j] += 1.0
            A[j, K] = -k[j] * (d[sl[j]] @ grad[0])
        F[K] = target + lam[row]
        with np.errstate(all="ignore"):
            try:
                dz = np.linalg.solve(A, -F)
            except np.linalg.LinAlgError:
                return None
        if not np.all(np.isfinite(dz)):
            return None
        s += dz[:K]
        x += dz[K]
        if abs(dz[K]) <= 1e-15 * (abs(x) + xs) and np.all(
            np.abs(dz[:K]) <= TOLERANCE * (np.abs(s) + ss)
        ):
            # physical where connected to the frictionless motion (see above)
            return (x, s) if np.linalg.det(A) * d[row] > 0 else None
    return None
