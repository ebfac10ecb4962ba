"""Newton-Raphson with an analytic Jacobian, and the scipy fallback.

:func:`newton` is the workhorse of the generic group solver: a plain Newton-Raphson
iteration that stops when the residual's infinity norm is below ``atol``. When it fails
(no convergence within ``max_iterations``, a singular Jacobian, or a growing residual),
:func:`solve` retries with :func:`scipy.optimize.root` (Powell's hybrid method, then
Levenberg-Marquardt) and finally :func:`scipy.optimize.least_squares`, which also copes
with rank-deficient (redundant) systems. The result says which method succeeded and how
many iterations and evaluations each took.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass
class SolveStats:
    """What one position solve cost and how it ended."""

    converged: bool
    method: str  # "newton", "scipy-hybr", "scipy-lm", "scipy-lsq" or "failed"
    iterations: int
    nfev: int
    njev: int
    residual: float


def newton(
    fun: Callable[[np.ndarray], np.ndarray],
    jac: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    atol: float,
    max_iterations: int = 30,
) -> tuple[np.ndarray, SolveStats]:
    """Solve ``fun(x) = 0`` by Newton-Raphson from ``x0``.

    Parameters
    ----------
    fun, jac
        Residual (m,) and Jacobian (m, n) functions; m == n, or m > n for a consistent
        over-determined system (solved by least squares at each step).
    atol
        Convergence when ``max |fun(x)| <= atol`` and the last step was below
        ``1e-3 atol`` (or stopped shrinking): near a singular position Newton converges
        only linearly and a small residual alone would stop it early.
    """
    x = np.array(x0, dtype=float)
    f = fun(x)
    nfev, njev = 1, 0
    r = float(np.max(np.abs(f))) if f.size else 0.0
    xtol = 1e-3 * atol
    last_dx = np.inf
    for it in range(max_iterations + 1):
        if not np.isfinite(r):
            break
        if r <= atol and (last_dx <= xtol or r == 0.0 or it == max_iterations):
            return x, SolveStats(True, "newton", it, nfev, njev, r)
        if it == max_iterations:
            break
        J = jac(x)
        njev += 1
        try:
            if J.shape[0] == J.shape[1]:
                dx = np.linalg.solve(J, -f)
            else:
                dx = np.linalg.lstsq(J, -f, rcond=None)[0]
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(dx)):
            break
        step = float(np.max(np.abs(dx))) if dx.size else 0.0
        x_new = x + dx
        f_new = fun(x_new)
        nfev += 1
        r_new = float(np.max(np.abs(f_new)))
        if r <= atol and (r_new > r or step >= last_dx):
            # converged already; the step no longer improves anything (rounding level)
            return x, SolveStats(True, "newton", it, nfev, njev, r)
        if it >= 3 and r_new > 2 * r:  # diverging
            r = r_new
            break
        x, f, r, last_dx = x_new, f_new, r_new, step
    if r <= atol:
        return x, SolveStats(True, "newton", max_iterations, nfev, njev, r)
    return x, SolveStats(False, "newton", max_iterations, nfev, njev, r)


def _step(jac, x, f):
    J = jac(x)
    try:
        if J.shape[0] == J.shape[1]:
            dx = np.linalg.solve(J, -f)
        else:
            dx = np.linalg.lstsq(J, -f, rcond=None)[0]
    except np.linalg.LinAlgError:
        return None
    return x + dx if np.all(np.isfinite(dx)) else None


def solve(
    fun: Callable[[np.ndarray], np.ndarray],
    jac: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    atol: float,
    max_iterations: int = 30,
) -> tuple[np.ndarray, SolveStats]:
    """Newton-Raphson, then scipy when Newton fails. See the module docstring."""
    x, st = newton(fun, jac, x0, atol, max_iterations)
    if st.converged or not np.all(np.isfinite(x0)):
        return x, st  # (from a guess that is not a pose, scipy has nothing to start from)
    from scipy.optimize import least_squares, root  # imported only when needed

    nfev, njev, its = st.nfev, st.njev, st.iterations
    m = len(fun(x0))
    square = m == len(x0)
    if square:
        for method in ("hybr", "lm"):
            sol = root(fun, x0, jac=jac, method=method, options={"xtol": 1e-14})
            nfev += int(getattr(sol, "nfev", 0) or 0)
            njev += int(getattr(sol, "njev", 0) or 0)
            xs = np.asarray(sol.x, float)
            # polish with Newton so that the answer meets the same tolerance
            xp, pst = newton(fun, jac, xs, atol, 5)
            nfev += pst.nfev
            njev += pst.njev
            if pst.converged:
                return xp, SolveStats(
                    True, f"scipy-{method}", its + pst.iterations, nfev, njev, pst.residual
                )
    sol = least_squares(
        fun, x0, jac=jac, method="trf" if not square else "lm", xtol=1e-15, ftol=1e-15, gtol=1e-15
    )
    nfev += int(sol.nfev or 0)
    njev += int(getattr(sol, "njev", 0) or 0)
    xs = np.asarray(sol.x, float)
    r = float(np.max(np.abs(fun(xs))))
    ok = r <= atol
    return xs, SolveStats(ok, "scipy-lsq" if ok else "failed", its, nfev, njev, r)


def newton_lean(
    fun_jac: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    x0: np.ndarray,
    atol: float,
    max_iterations: int = 30,
) -> tuple[np.ndarray, SolveStats]:
    """:func:`newton` for a small square system whose residual and Jacobian come from one
    evaluation ``fun_jac(x) -> (f, J)``, with the same convergence test (``max |f| <=
    atol`` and a step below ``1e-3 atol``, or a step that no longer shrinks) and a few
    array operations per iteration. It does not fall back to scipy: callers use
    :func:`solve` when it fails."""
    x = np.array(x0, dtype=float)
    xtol = 1e-3 * atol
    last = np.inf
    r = r_prev = np.inf
    for it in range(max_iterations + 1):
        f, J = fun_jac(x)
        r = float(np.max(np.abs(f)))
        if not r <= 1e300 or (it > 3 and r > 2 * r_prev):  # not finite, or diverging
            break
        r_prev = r
        if r <= atol and (last <= xtol or r == 0.0):
            return x, SolveStats(True, "newton", it, it + 1, it + 1, r)
        if it == max_iterations:
            break
        try:
            dx = np.linalg.solve(J, -f)
        except np.linalg.LinAlgError:
            break
        step = float(np.max(np.abs(dx)))
        if not step <= 1e300:
            break
        if r <= atol and step >= last:  # converged already: rounding level
            return x, SolveStats(True, "newton", it, it + 1, it + 1, r)
        x = x + dx
        last = step
    return x, SolveStats(r <= atol, "newton", max_iterations, max_iterations, max_iterations, r)
