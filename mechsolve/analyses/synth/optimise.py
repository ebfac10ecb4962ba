"""The optimiser of dimensional synthesis: differential evolution on design batches.

scipy's :func:`~scipy.optimize.differential_evolution` with ``vectorized=True``: each
generation's whole population reaches the objective and the constraints as one array of
designs (columns), evaluated by the closed forms of :mod:`.fourbar_batch` in one call.
Constraints are scipy's (Lampinen's rule): a design that breaks one is ranked by how far
it breaks it, never by an objective made worse by a penalty, so an infeasible design can
never pass for a good one. The search stops at convergence, after ``max_iter``
generations, at the time budget or at Ctrl-C (SIGTERM); in every case the best feasible
design found so far and the last population are kept. A local polish (the problem's own)
follows.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Search", "search", "distinct"]


@dataclass
class Search:
    """What a search found.

    ``x`` the best feasible design (None if none was feasible), ``fun`` its objective;
    ``population`` and ``energies`` the last generation (infinite energy: infeasible);
    ``stopped`` why it ended: "converged", "iterations", "time budget" or "interrupted"."""

    x: np.ndarray | None
    fun: float
    population: np.ndarray
    energies: np.ndarray
    generations: int
    evaluations: int
    seconds: float
    stopped: str
    seed: int | None = None
    history: list[float] = field(default_factory=list)

    @property
    def interrupted(self) -> bool:
        return self.stopped == "interrupted"


def search(
    objective: Callable[[np.ndarray], np.ndarray],
    constraints: Callable[[np.ndarray], np.ndarray] | None,
    bounds: list[tuple[float, float]],
    *,
    seed: int | None = 0,
    max_time: float | None = None,
    max_iter: int = 1000,
    popsize: int = 30,
    x0: np.ndarray | None = None,
    tol: float = 1e-12,
    progress: Callable[[int, float], None] | None = None,
) -> Search:
    """Minimise ``objective`` (columns of designs (N, S) -> (S,)) subject to
    ``constraints`` (N, S) -> (M, S) all >= 0, within ``bounds``."""
    from scipy.optimize import NonlinearConstraint, differential_evolution

    t0 = time.monotonic()
    best: dict = {"x": None, "fun": np.inf, "population": None, "energies": None, "nit": 0}
    history: list[float] = []

    def callback(intermediate_result) -> bool:
        r = intermediate_result
        best["population"] = np.array(r.population)
        best["energies"] = np.array(r.population_energies)
        best["nit"] = r.nit
        best["nfev"] = r.nfev
        if np.isfinite(r.fun) and r.fun <= best["fun"]:
            best["x"], best["fun"] = np.array(r.x), float(r.fun)
        history.append(float(r.fun))
        if progress is not None:
            progress(r.nit, float(r.fun))
        if max_time is not None and time.monotonic() - t0 > max_time:
            best["stopped"] = "time budget"
            return True
        return False

    cons = ()
    if constraints is not None:
        cons = (NonlinearConstraint(constraints, 0.0, np.inf),)
    stopped = "iterations"
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*vectorized.*", category=UserWarning)
            warnings.filterwarnings("ignore", message=".*feasible.*", category=UserWarning)
            res = differential_evolution(
                objective,
                bounds,
                constraints=cons,
                vectorized=True,
                seed=seed,
                maxiter=max_iter,
                popsize=popsize,
                tol=tol,
                atol=0.0,
                polish=False,
                init="sobol" if x0 is None else "latinhypercube",
                x0=x0,
                callback=callback,
            )
        if best.get("stopped"):
            stopped = best["stopped"]
        elif res.success:
            stopped = "converged"
        best["population"] = np.array(res.population)
        best["energies"] = np.array(res.population_energies)
        best["nit"], best["nfev"] = res.nit, res.nfev
        feasible = getattr(res, "constr_violation", 0.0) <= 0
        if feasible and np.isfinite(res.fun) and res.fun <= best["fun"]:
            best["x"], best["fun"] = np.array(res.x), float(res.fun)
    except KeyboardInterrupt:
        stopped = "interrupted"
    pop = best["population"]
    if pop is None:
        pop = np.empty((0, len(bounds)))
        energies = np.empty(0)
    else:
        energies = best["energies"]
    return Search(
        x=best["x"],
        fun=best["fun"],
        population=pop,
        energies=energies,
        generations=int(best["nit"]),
        evaluations=int(best.get("nfev", 0)),
        seconds=time.monotonic() - t0,
        stopped=stopped,
        seed=seed,
        history=history,
    )


def distinct(
    candidates: list[tuple[float, np.ndarray]], bounds, k: int, rel: float = 0.05
) -> list[tuple[float, np.ndarray]]:
    """Up to ``k`` of (value, x), best first, no two closer than ``rel`` of the bounds'
    span in every variable's scale (the largest scaled difference): distinct designs,
    not k copies of one optimum."""
    span = np.array([hi - lo for lo, hi in bounds], float)
    span[span <= 0] = 1.0
    out: list[tuple[float, np.ndarray]] = []
    for f, x in sorted(candidates, key=lambda t: t[0]):
        if not np.isfinite(f):
            continue
        if all(np.max(np.abs((x - y) / span)) > rel for _, y in out):
            out.append((f, x))
        if len(out) == k:
            break
    return out
