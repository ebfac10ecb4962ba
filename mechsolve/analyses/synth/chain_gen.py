"""Path generation for any template the design batch solves in closed form (six-bars).

A ``path:`` problem whose template is not a four-bar (a Watt or Stephenson six-bar, or
any chain of dyads the file format expresses) is evaluated through the design batch of
:mod:`mechsolve.analyses.batch`: the varied numbers of every design of a generation are
stacked into the model's numbers, one column per design and crank angle, and the
template's own group plan (driver link, then RRR dyads ...) solves all of them in one
pass, once per combination of the dyads' assembly branches. Each design keeps the
combination with the smallest objective among those that meet the constraints.

Constraints (rows >= 0, scipy's feasibility rule, no penalty):

* every dyad closes and keeps its branch over the whole motion (from the first target
  to the last, or a full turn when ``closed``): the dyad's discriminant (``sin^2`` of the
  angle at its middle joint, :meth:`mechsolve.groups.closed.RRR.disc`) stays above
  ``sin^2`` of the minimum transmission angle at 73 crank angles spread over the motion
  and on the cubic Hermite interpolant between them (a lower bound from its value and
  rate at both ends, as the design batch bounds a sweep), so that no branch point is
  passed between samples;
* without timing: the crank turns less than one turn from the first target to the last
  (the targets are reached in order).

The design written is confirmed by mechsolve's own sweep of the file, whose branch-event
detection is the final check (:func:`mechsolve.analyses.synth.path_gen.verify_path`).
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from mechsolve.analyses.synth.common import Design
from mechsolve.base.errors import InputError, MechsolveError

__all__ = ["ChainBatch", "polish", "design", "assembly_lines"]

TWO_PI = 2 * math.pi
SAMPLES = 73  # crank angles over the motion where the dyads' discriminants are bounded


class ChainBatch:
    """Designs (columns of X: the varied numbers, then without timing the crank's angle
    at the first target and its advances) solved by the template's group plan."""

    def __init__(self, spec: Any, mech, geometry: Any) -> None:
        """``spec`` the path problem, ``mech`` its template, ``geometry`` the reader of
        the template's numbers with the varied ones as arrays (``path_gen.Geometry``)."""
        from mechsolve.analyses.batch import _not_batchable, _numbers
        from mechsolve.core.sweep import Analysis

        self.spec = spec
        self.nv = len(spec.vary)
        self.n = len(spec.targets)
        try:
            an0 = Analysis(mech, None)
        except MechsolveError as exc:
            raise InputError(f"the template cannot be solved: {exc}") from None
        why = _not_batchable(mech, an0, None)
        if why is not None:
            raise InputError(
                f"the template has {why}: path generation needs a mechanism that the "
                "design batch solves in closed form (a four-bar, or a chain of dyads "
                "such as a Watt or Stephenson six-bar)"
            )
        self.an0 = an0
        from mechsolve.groups.closed import RRR

        odd = [g for g in an0.plan if g.n_modes == 2 and not isinstance(g, RRR)]
        if odd:
            raise InputError(
                f"the template's {odd[0].describe()} is not a revolute dyad: path "
                "generation on a chain takes revolute dyads (RRR) only"
            )
        self.base = np.array(_numbers(mech), float)
        self.slots: dict[tuple[str, str], int] = {}
        k = 0
        for p in mech.ground:
            self.slots[("ground", p)] = k
            k += 2
        for lk in mech.links:
            for p in lk.points:
                self.slots[(lk.name, p)] = k
                k += 2
            k += (lk.mass is not None) + (lk.inertia is not None) + 2 * (lk.com is not None)
        self.geo = geometry
        touched_links = {v.path[1] for v in spec.vary if v.path[0] == "links"}
        self.ground_names = sorted({v.path[1] for v in spec.vary if v.path[0] == "ground"})
        self.link_points = [(lk.name, p) for lk in mech.links if lk.name in touched_links
                            for p in lk.points]  # fmt: skip
        self._check_reader(mech)
        self.branch_groups = [i for i, g in enumerate(an0.plan) if g.n_modes == 2]
        self.combos = np.array(
            list(itertools.product((1.0, -1.0), repeat=len(self.branch_groups))), float
        ).reshape(-1, len(self.branch_groups))
        self.sin2_min = math.sin(spec.min_transmission) ** 2
        self._cache: dict[bytes, tuple] = {}

    # -- the model's numbers ------------------------------------------------------------
    def _check_reader(self, mech) -> None:
        """The synthesis' reading of the varied links agrees with the model's."""
        geo = self.geo
        X = np.zeros((0, 1))
        saved, geo.index = geo.index, {}
        try:
            links = {lk.name: lk for lk in mech.links}
            for link, pt in self.link_points:
                got = np.array([float(np.ravel(c)[0]) for c in geo.local(X, link, pt)])
                if not np.allclose(got, links[link].points[pt], atol=1e-12, rtol=1e-12):
                    raise InputError(
                        f"links.{link}.points.{pt}: a point form the synthesis cannot vary "
                        "(write it as [x, y] or {length, angle})"
                    )
        finally:
            geo.index = saved

    def numbers(self, X: np.ndarray) -> np.ndarray:
        """The model's stacked numbers of each design, (designs, numbers)."""
        S = X.shape[1]
        out = np.tile(self.base, (S, 1))
        for p in self.ground_names:
            k = self.slots[("ground", p)]
            out[:, k], out[:, k + 1] = self.geo.ground(X, p)
        for link, p in self.link_points:
            k = self.slots[(link, p)]
            out[:, k], out[:, k + 1] = self.geo.local(X, link, p)
        return out

    # -- the crank angles -----------------------------------------------------------------
    def angles(self, X: np.ndarray) -> np.ndarray:
        s = self.spec
        if s.timing is not None:
            return np.broadcast_to(s.timing[:, None], (self.n, X.shape[1]))
        u1 = X[self.nv]
        adv = X[self.nv + 1 :]
        return u1[None, :] + s.direction * np.vstack([np.zeros_like(u1), np.cumsum(adv, 0)])

    def _samples(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The crank angles over each design's motion (SAMPLES, S) and their step (S,)."""
        t = np.linspace(0.0, 1.0, SAMPLES)[:, None]
        if self.spec.closed:
            span = np.full(u.shape[1], TWO_PI) * self.spec.direction
        else:
            span = u[-1] - u[0]
        return u[0] + t * span, np.abs(span) / (SAMPLES - 1)

    # -- one evaluation of every design on every branch combination ----------------------
    def evaluate_combo(self, X: np.ndarray, combo: np.ndarray):
        """(dx, dy) residuals (N, S) and constraint rows (M, S) on branches ``combo``."""
        from mechsolve.analyses.batch import _design_states

        S = X.shape[1]
        u = np.asarray(self.angles(X), float)
        su, h = self._samples(u)
        allu = np.vstack([u, su]).T  # (S, N + SAMPLES)
        L = allu.shape[1]
        modes = np.ones((len(self.an0.plan), S))
        for gi, m in zip(self.branch_groups, combo):
            modes[gi] = m
        solve = _design_states(self.an0, self.numbers(X), modes, 1.0)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            a, st, ok = solve(allu)
            ref = a.points[self.spec.names["P"]]
            px, py = st.point(ref.body, ref.local)
            px, py = px.reshape(S, L)[:, : self.n].T, py.reshape(S, L)[:, : self.n].T
            t = self.spec.targets
            dx, dy = px - t[:, 0:1], py - t[:, 1:2]
            rows = []
            okm = ok.reshape(S, L)
            for gi in self.branch_groups:
                H, dH = a.plan[gi].disc(st)
                H = np.broadcast_to(H, (S * L,)).reshape(S, L)[:, self.n :]
                dH = np.abs(np.broadcast_to(dH, (S * L,)).reshape(S, L)[:, self.n :])
                hd = h[:, None] * dH
                low = np.minimum(H[:, :-1], H[:, 1:]) - (4.0 / 27.0) * (hd[:, :-1] + hd[:, 1:])
                m = np.minimum(np.min(H, axis=1), np.min(low, axis=1)) - self.sin2_min
                m = np.where(np.all(okm, axis=1) & np.isfinite(m), m, -1.0)
                rows.append(m)
            for gi in range(len(self.an0.plan)):
                if gi not in self.branch_groups:  # a group that must close everywhere
                    rows.append(np.where(np.all(okm, axis=1), 1.0, -1.0))
        if self.spec.timing is None:
            rows.append((TWO_PI - np.sum(X[self.nv + 1 :], axis=0)) / TWO_PI)
        return dx, dy, np.vstack(rows)

    def evaluate(self, X: np.ndarray):
        """(objective (S,), constraints (M, S), combo index (S,)) with each design on its
        best feasible branch combination (or, if none is feasible, the least infeasible)."""
        X = np.asarray(X, float)
        key = X.tobytes() + bytes(str(X.shape), "ascii")
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        best_f = best_c = best_k = None
        for k, combo in enumerate(self.combos):
            dx, dy, c = self.evaluate_combo(X, combo)
            f = np.sum(dx * dx + dy * dy, axis=0)
            f = np.where(np.isfinite(f), f, np.inf)
            feas = np.all(c > 0, axis=0)
            score = np.where(feas, f, np.inf)
            viol = np.min(c, axis=0)
            if best_f is None:
                best_f, best_c, best_k = score, c, np.zeros(X.shape[1], int)
                best_v, best_raw = viol, f
                continue
            better = (score < best_f) | (~np.isfinite(best_f) & ~feas & (viol > best_v))
            better |= ~np.isfinite(best_f) & feas
            best_f = np.where(better, score, best_f)
            best_raw = np.where(better, f, best_raw)
            best_v = np.where(better, viol, best_v)
            best_c = np.where(better[None, :], c, best_c)
            best_k = np.where(better, k, best_k)
        obj = np.where(np.isfinite(best_f), best_f, best_raw)
        out = (np.where(np.isfinite(obj), obj, 1e300), best_c, best_k)
        if len(self._cache) > 4:
            self._cache.clear()
        self._cache[key] = out
        return out

    def objective(self, X):
        X = np.asarray(X, float)
        if X.ndim == 1:
            return float(self.evaluate(X[:, None])[0][0])
        return self.evaluate(X)[0]

    def constraints(self, X):
        X = np.asarray(X, float)
        if X.ndim == 1:
            return self.evaluate(X[:, None])[1][:, 0]
        return self.evaluate(X)[1]

    def labels(self) -> list[str]:
        out = [f"({self.an0.plan[gi].describe()} closes and keeps its branch over the motion"
               + (", transmission angle" if self.sin2_min > 0 else "") + ")"
               for gi in self.branch_groups]  # fmt: skip
        out += ["(the loop closes over the motion)"] * (
            len(self.an0.plan) - len(self.branch_groups)
        )
        if self.spec.timing is None:
            out.append("(less than a turn from first to last point)")
        return out


def polish(batch: ChainBatch, x0: np.ndarray, bounds) -> tuple[float, np.ndarray] | None:
    """Least squares from ``x0`` on its branch combination, within the bounds; kept only
    if the result meets the constraints."""
    from scipy.optimize import least_squares

    lo, hi = np.array(bounds).T
    x0 = np.clip(np.asarray(x0, float), lo, hi)
    k = int(batch.evaluate(x0[:, None])[2][0])
    combo = batch.combos[k]

    def cols(X):
        dx, dy, _ = batch.evaluate_combo(X, combo)
        r = np.vstack([dx, dy])
        return np.where(np.isfinite(r), r, 1e3)

    def fun(x):
        return cols(np.asarray(x)[:, None])[:, 0]

    def jac(x):
        x = np.asarray(x, float)
        h = 1e-7 * np.maximum(1.0, np.abs(x)) * (hi - lo > 0)
        n = len(x)
        X = np.hstack([x[:, None] + np.diag(h), x[:, None] - np.diag(h)])
        r = cols(X)
        return (r[:, :n] - r[:, n:]) / np.where(h > 0, 2 * h, 1.0)

    try:
        r = least_squares(fun, x0, jac=jac, bounds=(lo, hi), xtol=1e-15, ftol=1e-15,
                          gtol=1e-15, max_nfev=300)  # fmt: skip
    except ValueError:
        return None
    dx, dy, c = batch.evaluate_combo(r.x[:, None], combo)
    if np.all(c > 0):
        return float(np.sum(dx * dx + dy * dy)), np.array(r.x)
    return None


def design(batch: ChainBatch, names: list[str], x: np.ndarray, family: str) -> Design:
    """The design ``x`` on its best branch combination, with what the table shows."""
    X = np.asarray(x, float)[:, None]
    _, c, kk = batch.evaluate(X)
    combo = batch.combos[int(kk[0])]
    dx, dy, c = batch.evaluate_combo(X, combo)
    dist = np.hypot(dx[:, 0], dy[:, 0])
    u = np.asarray(batch.angles(X), float)[:, 0]
    # the smallest transmission angle over the motion, from the dyads' margins
    sin2 = [float(c[i, 0]) + batch.sin2_min for i in range(len(batch.branch_groups))]
    mu = math.asin(math.sqrt(min(1.0, max(0.0, min(sin2))))) if sin2 else math.pi / 2
    ground = {}
    for p in batch.ground_names:
        gx, gy = batch.geo.ground(X, p)
        ground[p] = (float(np.ravel(gx)[0]), float(np.ravel(gy)[0]))
    return Design(
        method="path generation",
        family=family,
        lengths={},
        ground=ground,
        grashof="-",
        min_transmission=mu,
        extra={"x": dict(zip(names, map(float, x))), "combo": combo,
               "objective": float(np.sum(dist**2)), "distances": dist, "u": u,
               "chain": True},
    )  # fmt: skip


def assembly_lines(batch: ChainBatch, combo: np.ndarray) -> list[str]:
    """The file's assembly conditions that pick the branches ``combo``: an RRR dyad's
    branch +1 puts its middle joint left of the line from its first to its last joint."""
    out = []
    for gi, m in zip(batch.branch_groups, combo):
        g = batch.an0.plan[gi]
        side = "left" if m > 0 else "right"
        out.append(f"{g.j2.name} {side} of {g.j1.name} -> {g.j3.name}")
    return out
