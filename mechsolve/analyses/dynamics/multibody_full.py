"""The accelerations and multipliers on every constraint equation at once, with the rank
decided once for the run, for a mechanism whose equations are redundant (a
parallelogram's third crank).

On a partition the accelerations come from its independent equations alone. That is
exact where the state satisfies every equation, but next to a singular position (a
parallelogram's cranks along the ground line) the set-aside equation is what fixes the
motion: the closure's tolerance leaves the state up to ``tol / sigma`` off it along the
direction the equations are about to lose (``sigma`` their smallest singular value
kept), and the partition's accelerations, which cannot see it, came out wrong by tens
of per cent, the multipliers by 1e4 N (review 6, item 1). Here:

- the state is first closed to rounding on every equation (minimum-norm Newton, rates
  of least kinetic energy), where the equations' relative singular value is below
  :data:`~.multibody_events.S_NEAR`;
- ``Phi_q q'' = gamma`` is solved on the ``r`` largest singular values of ``Phi_q W``
  (``W``: the angle columns times the mechanism's size, as the partition weighs them),
  ``r`` the number of independent equations of the mechanism, the same at every
  state, so that the equation that is about to lose rank is kept and only the
  redundant ones are set aside; ``M q'' + Phi_q^T lambda = Q`` on the rest (the
  ``f`` directions of the motion);
- the multipliers are the minimum-norm solution of ``Phi_q^T lambda = Q - M q''`` on
  those same ``r`` directions.

Where that ``r``-th relative singular value is below :data:`S_UNDETERMINED` (at the
singular position itself, to about 1e-5 of the mechanism's size) the equations do not
determine the accelerations and the multipliers (their rounding is divided by its
square): they are left empty (NaN: blank in the CSV, a warning with the time).
"""

from __future__ import annotations

import numpy as np

from mechsolve.analyses.dynamics.multibody import NEWTON_ITERATIONS, rank_solve
from mechsolve.analyses.dynamics.multibody_events import S_NEAR, project, singular_measure

S_UNDETERMINED = 1e-5  # below this r-th relative singular value q'' and lambda are not given
NUDGE = 1e-12  # the closures' starts apart, of the mechanism's size
AGREE = 1e-6  # how closely they must agree for q'' and lambda to be given


def full_output(mb, q: np.ndarray, qd: np.ndarray, t: float):
    """``(q'', lambda, T, V)`` at an output of a mechanism with redundant equations: the
    energies at ``(q, q')``, the accelerations and multipliers on every equation; NaN
    where they are not determined (see :func:`_determined`)."""
    T, V = mb.energy(q, qd, t)
    if singular_measure(mb, q, mb.rank) >= S_NEAR:
        try:
            qdd, lam, _ = rank_solve(*_terms(mb, q, qd, t), mb.rank, mb.weights)
            return qdd, lam, T, V
        except np.linalg.LinAlgError:  # a massless direction of the motion
            return np.full(mb.nq, np.nan), np.full(mb.nc, np.nan), T, V
    got = _determined(mb, q, qd, t)
    if got is None:
        return np.full(mb.nq, np.nan), np.full(mb.nc, np.nan), T, V
    return got[0], got[1], T, V


def _terms(mb, q, qd, t):
    Jq, M, Q, _, _, g = mb.terms(q, qd, t)
    return Jq, M, Q, g


def _determined(mb, q, qd, t):
    """``(q'', lambda)`` next to a singular position, or None where the equations do
    not determine them. The state is closed to rounding on every equation, three
    times: from ``q`` and from ``q`` moved by :data:`NUDGE` of the mechanism's size
    either way. Next to the singular position rounding leaves each closure up to
    ``eps / sigma`` off the motion along the direction the equations lose, and its
    tangent (the rates) turned by that over ``sigma`` again, so the accelerations carry
    about ``eps / sigma^3``: they and the multipliers are given where the three agree to
    :data:`AGREE` of their size (and the ``r``-th singular value is above
    :data:`S_UNDETERMINED`)."""
    nudge = NUDGE * mb.scale * np.cos(np.arange(mb.nq) + 1.0)
    out = []
    for k in (0.0, 1.0, -1.0):
        got = project(mb, t, q + k * nudge, qd, NEWTON_ITERATIONS)
        if got is None:
            return None
        try:
            qdd, lam, s = rank_solve(*_terms(mb, got[0], got[1], t), mb.rank, mb.weights)
        except np.linalg.LinAlgError:
            return None
        if not s >= S_UNDETERMINED:
            return None
        out.append((qdd, lam))
    (qdd, lam), rest = out[0], out[1:]
    a = AGREE * max(float(np.abs(qdd).max()), 1e-300)
    f = AGREE * max(float(np.abs(lam).max()), 1e-300)
    if any(np.abs(x - qdd).max() > a or np.abs(y - lam).max() > f for x, y in rest):
        return None
    return qdd, lam
