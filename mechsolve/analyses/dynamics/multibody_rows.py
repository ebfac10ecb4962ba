"""The output rows of a multibody run closed all at once, on arrays over the rows.

After the integrator has passed a stretch of output times, each row (its integrated
state ``y``) is closed as every evaluation is (:meth:`~.multibody.Multibody.close`,
:meth:`~.multibody.Multibody.rates`, :meth:`~.multibody.Multibody.accelerations`):
Newton on the partition's equations for the dependent coordinates, their rates from
``Phi_q q' = nu``, the accelerations and multipliers from the augmented system
``[M Phi_r^T; Phi_r 0] [q''; lambda] = [Q; gamma]`` (the multipliers of all equations by
least squares with minimum norm where some are redundant). Here the rows' small systems
are stacked and solved by one call each, instead of one evaluation in Python per row:
the same equations, the same tolerance, the same checks (a row that does not close, or
whose ``Phi_d`` has lost its conditioning, sends the whole stretch back to the row by
row closing, which repartitions or bridges as it does). Newton here takes full steps
where the row by row closing reuses the last factors (a chord): both stop within the
constraint tolerance, so the rows agree to about that tolerance.

Only for mechanisms evaluated on arrays (:attr:`~.multibody.Multibody.lite`: pins, the
loads that always act, no motor, no friction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mechsolve.analyses.dynamics.multibody import NEWTON_ITERATIONS, RECONDITION
from mechsolve.analyses.dynamics.multibody_events import S_NEAR


@dataclass
class Rows:
    """The closed rows: coordinates, rates, accelerations, multipliers of every
    equation, kinetic and potential energies, position and velocity violations."""

    q: np.ndarray  # (n, nq)
    qd: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray  # (n, nc)
    T: np.ndarray  # (n,)
    V: np.ndarray
    viol: np.ndarray
    vviol: np.ndarray


def close_rows(mb, part, ys: np.ndarray) -> Rows | None:
    """Close the integrated states ``ys`` (n, 2 nq + 1) on the partition ``part``; None
    where the rows cannot all be closed so (then close them one by one)."""
    if not mb.lite or len(part.dep) == 0 or len(ys) == 0:
        return None
    try:
        with np.errstate(all="ignore"):
            closed = _positions(mb, part, np.asarray(ys, float))
            if closed is None:
                return None
            q, arms, phi = closed
            Jq = mb.pins.jacobian_rows(arms)
            qd = _rates(mb, part, Jq, np.asarray(ys, float))
            if qd is None:
                return None
            return _dynamics(mb, part, q, qd, arms, phi, Jq)
    except np.linalg.LinAlgError:  # a singular block: the rows one by one
        return None


def _positions(mb, part, ys: np.ndarray):
    """Newton on every row at once: ``(q, arms, Phi)`` at the closed rows."""
    pins, rows, dep = mb.pins, part.rows, part.dep
    every = len(rows) == mb.nc
    q = ys[:, : mb.nq].copy()  # the integrated coordinates: z and Newton's start
    for _ in range(NEWTON_ITERATIONS + 1):
        arms = pins.arms_rows(q[:, 2::3])
        phi = pins.residual_rows(q, arms)
        size = np.abs(phi if every else phi[:, rows]).max(axis=1)
        if not np.isfinite(size).all():
            return None
        todo = np.flatnonzero(size > mb.tol)
        if todo.size == 0:
            return q, arms, phi
        Jd = pins.jacobian_rows(tuple(a[todo] for a in arms))[:, rows][:, :, dep]
        step = np.linalg.solve(Jd, phi[todo][:, rows, None])[..., 0]
        q[np.ix_(todo, dep)] -= step
    return None


def _rates(mb, part, Jq: np.ndarray, ys: np.ndarray) -> np.ndarray | None:
    """The rates of every row from its independent ones (``nu = 0`` for pins); None
    where a row's ``Phi_d`` has lost its conditioning (as :meth:`rates` checks it)."""
    nq, rows, dep, ind = mb.nq, part.rows, part.dep, part.ind
    Jr = Jq[:, rows]
    Jd, Jz = Jr[:, :, dep], Jr[:, :, ind]
    # the reciprocal condition in the 1-norm (exact; LAPACK's estimate is not smaller)
    inv = np.linalg.inv(Jd)
    rc = 1.0 / (np.abs(Jd).sum(axis=1).max(axis=1) * np.abs(inv).sum(axis=1).max(axis=1))
    if not (rc >= RECONDITION * part.rcond1).all():
        return None
    zd = ys[:, nq + ind]
    qd = np.zeros((len(ys), nq))
    qd[:, ind] = zd
    qd[:, dep] = np.linalg.solve(Jd, -(Jz @ zd[:, :, None]))[..., 0]
    return qd


def _dynamics(mb, part, q, qd, arms, phi, Jq) -> Rows | None:
    """The accelerations, multipliers and energies of every row."""
    n, nq, rows = len(q), mb.nq, part.rows
    c, s = np.cos(q[:, 2::3]), np.sin(q[:, 2::3])
    rx, ry = c * mb._sx - s * mb._sy, s * mb._sx + c * mb._sy
    m = mb.m
    M = np.zeros((n, nq * nq))
    M[:, mb._m_diag] = mb._m_const
    M[:, mb._m_x] = M[:, mb._m_xt] = -m * ry
    M[:, mb._m_y] = M[:, mb._m_yt] = m * rx
    M = M.reshape(n, nq, nq)
    w2 = qd[:, 2::3] ** 2
    Q = np.empty((n, nq))
    Q[:, 0::3] = m * (mb.gx + w2 * rx)
    Q[:, 1::3] = m * (mb.gy + w2 * ry)
    Q[:, 2::3] = m * (rx * mb.gy - ry * mb.gx)
    V = -((q[:, 0::3] + rx) @ mb._mg + (q[:, 1::3] + ry) @ mb._mgy)
    if mb.array_loads is not None:
        V = V + mb.array_loads.apply_rows(q, Q)
    Jr = Jq[:, rows]
    r = len(rows)
    A = np.zeros((n, nq + r, nq + r))
    A[:, :nq, :nq] = M
    A[:, :nq, nq:] = Jr.transpose(0, 2, 1)
    A[:, nq:, :nq] = Jr
    b = np.concatenate([Q, mb.pins.gamma_rows(arms, qd[:, 2::3])[:, rows]], axis=1)
    x = np.linalg.solve(A, b[:, :, None])[..., 0]
    if not np.isfinite(x).all():
        return None
    qdd = x[:, :nq]
    if r == mb.nc:  # every equation independent: its multipliers are unique
        lam = x[:, nq:]
    else:  # redundant equations: the multipliers of least norm on the run's rank
        w = mb.weights
        U, S, Vt = np.linalg.svd(Jq * w)
        if not (S[:, r - 1] >= S_NEAR * S[:, 0]).all():
            return None  # next to a singular position: on every equation, row by row
        rhs = w * (Q - (M @ qdd[:, :, None])[..., 0])
        lam = np.einsum(
            "nkr,nr->nk", U[:, :, :r], np.einsum("nrj,nj->nr", Vt[:, :r], rhs) / S[:, :r]
        )
    T = 0.5 * np.einsum("ni,nij,nj->n", qd, M, qd)
    vviol = np.abs(Jq @ qd[:, :, None]).max(axis=(1, 2), initial=0.0)
    viol = np.abs(phi).max(axis=1, initial=0.0)
    return Rows(q, qd, qdd, lam, T, V, viol, vviol)
