"""What a Newton group's continuation shares: its step limits and the extrapolation that
predicts each position from the ones before (see :mod:`.generic`)."""

from __future__ import annotations

import numpy as np

MAX_JUMP = 0.05  # largest accepted Newton correction: 5 % of the size, or 0.05 rad
MAX_DEPTH = 10  # at most 2**10 substeps per interval
BATCH_MIN = 64  # sweeps of at least this many positions are refined in one batch
COARSE = 32  # positions of the coarse continuation that predicts a batched sweep


def _lagrange_weights(us: list[float], u: float) -> list[float] | None:
    """The weights of the Lagrange extrapolation from the driver values ``us`` to ``u``
    (None where two of them coincide)."""
    k = len(us)
    ws = []
    for i in range(k):
        w = 1.0
        for j in range(k):
            if j != i:
                den = us[i] - us[j]
                if den == 0:
                    return None
                w *= (u - us[j]) / den
        ws.append(w)
    return ws


def _extrapolate_floats(us: list[float], qs: list[list[float]], u: float) -> list[float]:
    """:func:`_extrapolate` on lists of floats: the weights of
    :func:`_lagrange_weights` written out for two and three points (the same
    operations in the same order: ``w_i = prod_j (u - u_j) / (u_i - u_j)`` from 1.0)."""
    k = len(qs)
    if k == 1:
        return list(qs[0])
    if k == 2:
        u0, u1 = us[0], us[1]
        d01, d10 = u0 - u1, u1 - u0
        if d01 == 0:
            return list(qs[-1])
        w0, w1 = (u - u1) / d01, (u - u0) / d10
        q0, q1 = qs
        return [w0 * a + w1 * b for a, b in zip(q0, q1)]
    u0, u1, u2 = us[0], us[1], us[2]
    d01, d02, d12 = u0 - u1, u0 - u2, u1 - u2
    if d01 == 0 or d02 == 0 or d12 == 0:
        return list(qs[-1])
    a0, a1, a2 = u - u0, u - u1, u - u2
    w0 = (a1 / d01) * (a2 / d02)
    w1 = (a0 / (u1 - u0)) * (a2 / d12)
    w2 = (a0 / (u2 - u0)) * (a1 / (u2 - u1))
    q0, q1, q2 = qs
    return [w0 * a + w1 * b + w2 * c for a, b, c in zip(q0, q1, q2)]


def _extrapolate(us: list[float], qs: list[np.ndarray], u: float) -> np.ndarray:
    """Lagrange extrapolation of the last (up to three) solutions to driver value ``u``."""
    k = len(qs)
    if k == 1:
        return qs[0].copy()
    ws = _lagrange_weights(us[:k], u)
    if ws is None:
        return qs[-1].copy()
    out = ws[0] * qs[0]
    for w, q in zip(ws[1:], qs[1:]):
        out = out + w * q
    return out
