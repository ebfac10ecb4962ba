"""Events that end a multibody run (:mod:`.multibody`): a singular position the motion
reaches, located in time.

A singular position is where the constraint equations lose rank: the ``r``-th singular
value of ``Phi_q`` (``r`` its rank at the start) vanishes. Coordinate partitioning
cannot integrate through it (every block ``Phi_d`` is singular there), so it is found
on the motion integrated on all the coordinates (the accelerations by least squares
on every equation, which stay determined for the motion where the equations lose
rank): the measure ``s(t) = sigma_r / sigma_1`` is sampled along that motion from the
last closed state, its smallest sample bracketed and the bracket narrowed by golden
section (``s`` has a V-shaped minimum there, zero at the singular position). The
state there is projected onto ``Phi = 0`` and ``Phi_q q' = nu``.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.analyses.dynamics.multibody import NEWTON_ITERATIONS, Stop
from mechsolve.core.loads import stroke_function

S_NEAR = 1e-2  # below this relative singular value the run looks for a singular position
S_SINGULAR = 1e-5  # a minimum of s below this is a singular position
SUBSTEPS = 64  # RK4 steps per span when looking for it
SPANS = 4  # how many spans (the output step) ahead it looks
ROUNDING = 1e-15  # the closures here go on to this of the mechanism's size
GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


def singular_measure(mb, q: np.ndarray, rank: int) -> float:
    """``sigma_r / sigma_1`` of ``Phi_q(q)``, its angle columns times the mechanism's
    size (as the partition weighs them: lengths and angles compete fairly): 1 for
    well-posed equations, 0 where they lose rank (``rank``: the number of independent
    equations at the start)."""
    if rank == 0:
        return 1.0
    J = mb.jacobian(q)
    J[:, 2::3] /= mb.scale
    sv = np.linalg.svd(J, compute_uv=False)
    return float(sv[rank - 1] / sv[0]) if sv[0] > 0 else 0.0


def rk4(rhs, t0: float, y0: np.ndarray, h: float) -> np.ndarray:
    """One classical Runge-Kutta step of ``h`` from ``(t0, y0)``."""
    k1 = rhs(t0, y0)
    k2 = rhs(t0 + h / 2, y0 + h / 2 * k1)
    k3 = rhs(t0 + h / 2, y0 + h / 2 * k2)
    k4 = rhs(t0 + h, y0 + h * k3)
    return y0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def all_coordinates(mb):
    """d/dt (q, q', W) on all the coordinates (least-squares accelerations). With
    redundant equations every stage's state is first closed onto the constraints (to
    rounding): next to a singular position the equation that fixes the motion there is
    nearly lost, and a stage's departure from the constraints (the square of the
    step) changed the motion by 0.3 deg and T + V by 0.05 J in one step."""
    nq = mb.nq

    def f(t, y):
        q, qd = y[:nq], y[nq : 2 * nq]
        if mb.rank is not None:
            got = project(mb, t, q.copy(), qd, NEWTON_ITERATIONS)
            if got is None:
                raise np.linalg.LinAlgError("a stage does not close")
            q, qd = got
        qdd, P = mb.free_accelerations(q, qd, t)
        return np.concatenate([qd, qdd, [P]])

    return f


def project(mb, t: float, q: np.ndarray, qd: np.ndarray, iterations: int):
    """``(q, q')`` moved onto ``Phi = 0`` (minimum-norm Newton) and ``Phi_q q' = nu``;
    None where Newton does not converge."""
    q1 = q.copy()
    last = np.inf
    for _ in range(iterations):
        phi = mb.residual(q1, t)
        size = np.max(np.abs(phi), initial=0.0)
        if size <= mb.tol and (
            mb.rank is None or size >= 0.5 * last or size <= ROUNDING * mb.scale
        ):
            break  # with redundant equations: on to rounding (see multibody_full)
        last = size
        q1 -= _newton_step(mb, q1, phi)
    else:
        if not last <= mb.tol:
            return None
    qd1 = mb.consistent_rates(q1, qd, t)
    if not (np.all(np.isfinite(q1)) and np.all(np.isfinite(qd1))):
        return None
    return q1, qd1


def _newton_step(mb, q: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """The minimum-norm Newton step: singular values below 1e-12 of the largest set
    aside, and with redundant equations all but the run's rank largest. (Off the
    constraints by ``d``, the redundant direction's singular value is about ``d``, not
    zero: divided by it, the residual's part along it moved a closed parallelogram by
    1.5e-6 m and changed its energy by 2e-5 J.)"""
    J = mb.jacobian(q)
    if mb.rank is None:
        return np.linalg.lstsq(J, phi, rcond=1e-12)[0]
    U, S, Vt = np.linalg.svd(J, full_matrices=False)
    k = min(mb.rank, int(np.sum(S > 1e-12 * S[0])))
    return Vt[:k].T @ ((U[:, :k].T @ phi) / S[:k])


def locate_singular(
    mb, rank: int, t0: float, q, qd, W: float, span: float, t_end: float, iterations: int = 25
):
    """The first singular position after ``t0`` within :data:`SPANS` spans (and before
    ``t_end``): ``(t, q, q', W, s)`` there, or None where the motion meets none (the
    smallest ``s`` on the way stays above :data:`S_SINGULAR`)."""
    f = all_coordinates(mb)
    nq = mb.nq
    h = span / SUBSTEPS
    ts, ys, ss = [t0], [np.concatenate([q, qd, [W]])], [singular_measure(mb, q, rank)]
    try:
        while ts[-1] < min(t0 + SPANS * span, t_end) - 1e-15:
            step = min(h, t_end - ts[-1])
            ys.append(rk4(f, ts[-1], ys[-1], step))
            ts.append(ts[-1] + step)
            ss.append(singular_measure(mb, ys[-1][:nq], rank))
            if len(ss) >= 3 and ss[-1] > ss[-2] and ss[-2] < S_NEAR:
                break  # past a minimum
        i = int(np.argmin(ss))
        lo, hi = max(i - 1, 0), min(i + 1, len(ts) - 1)

        def s_at(tau):
            y = rk4(f, ts[lo], ys[lo], tau - ts[lo]) if tau > ts[lo] else ys[lo]
            return singular_measure(mb, y[:nq], rank), y

        a, b = ts[lo], ts[hi]
        c, d = b - GOLDEN * (b - a), a + GOLDEN * (b - a)
        sc, sd = s_at(c)[0], s_at(d)[0]
        while b - a > 1e-13 * max(1.0, abs(b)):
            if sc < sd:
                b, d, sd = d, c, sc
                c = b - GOLDEN * (b - a)
                sc = s_at(c)[0]
            else:
                a, c, sc = c, d, sd
                d = a + GOLDEN * (b - a)
                sd = s_at(d)[0]
        tau = 0.5 * (a + b)
        s_min, y = s_at(tau)
    except (np.linalg.LinAlgError, ArithmeticError):
        return None
    if not s_min < S_SINGULAR:
        return None
    got = project(mb, tau, y[:nq], y[nq : 2 * nq], iterations)
    if got is None:
        return None
    return tau, got[0], got[1], float(y[-1]), s_min


def stop_condition(an, mb, expr) -> Stop:
    """``simulate``'s ``stop when`` as a function of the state: for one comparison
    ``a < b`` (``<=``, ``>``, ``>=``) the difference of its sides, signed so that it is
    positive while the condition does not hold (its root is the event); for any other
    condition +1 while it does not hold, -1 once it does."""
    from mechsolve.core.solution import StateView
    from mechsolve.model.expr.evaluate import _eval, _leaf
    from mechsolve.model.expr.tree import Compare

    tree = expr.tree
    funcs = {"stroke": stroke_function(list(mb.extremes), True)}

    def value(node, view):
        with np.errstate(all="ignore"):
            return float(np.asarray(_eval(node, lambda n: _leaf(n, view), funcs)).ravel()[0])

    smooth = (
        isinstance(tree, Compare) and len(tree.ops) == 1 and tree.ops[0] in ("<", "<=", ">", ">=")
    )
    sign = 1.0 if smooth and tree.ops[0].startswith("<") else -1.0

    def g(t, q, qd, qdd):
        view = StateView(an, mb.state(q, qd, qdd))
        if smooth:
            a, b = tree.operands
            return sign * (value(a, view) - value(b, view))
        return -1.0 if value(tree, view) else 1.0

    return Stop(g, expr.text)
