"""Path generation for any template the design batch solves in closed form (six-bars).

A ``path:`` problem whose template is not a four-bar (a Watt or Stephenson six-bar, or
any chain of dyads the file format expresses) is evaluated through the design batch of
:mod:`mechsolve.analyses.batch`: the varied numbers of every design of a generation are
stacked into the model's numbers, one column per design, combination of the dyads'
assembly branches and crank angle, and the template's own group plan (driver link, then
RRR dyads ...) solves all of them in one pass. Each design keeps the combination with
the smallest objective among those that meet the constraints.

Constraints (rows >= 0, scipy's feasibility rule, no penalty):

* every dyad closes and keeps its branch over the whole motion (from the first target
  to the last, or a full turn when ``closed``), with its transmission angle (the angle at
  its middle joint) at least ``min_transmission``, proven for every crank angle, not on
  samples (:meth:`ChainBatch.margins`). A dyad's discriminant ``H = sin^2`` of that angle is
  a function of the distance ``D`` between its outer joints alone, concave in ``D^2``, so
  its least value over an interval of crank angles is at one end of ``D``'s range there.
  ``D`` is Lipschitz in the crank angle with the constant ``V_P + V_Q``, bounds of the
  outer joints' speeds (per radian of crank), and a dyad whose ``H`` stays above
  ``H_min > 0`` turns its links at most ``(V_P + V_Q) / (L sqrt(H_min))``: these bounds,
  carried from the crank (speed 1) through the group plan, give ``D``'s range, hence a
  lower bound of ``H``, on every interval between two solved crank angles. The motion is
  solved at 73 crank angles, and every interval whose bound does not prove the margin
  is halved (the midpoints of all designs and branch combinations solved as one batch)
  until it is proven or a solved crank angle violates it (a real defect); one still
  undecided after 24 halvings counts as a violation (a design that grazes the limit is
  refused, never accepted unproven);
* without timing: the crank turns less than one turn from the first target to the last
  (the targets are reached in order).

The design written is also run by mechsolve's own sweep of the file, with its
branch-event detection (:func:`mechsolve.analyses.synth.path_gen.verify_path`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from typing import Any

import numpy as np

from mechsolve.analyses.synth.common import Design, batch_least_squares
from mechsolve.base.errors import InputError, MechsolveError
from mechsolve.groups.closed import RRR, DriverLink

__all__ = ["ChainBatch", "polish", "design", "assembly_lines"]

TWO_PI = 2 * math.pi
SAMPLES = 73  # crank angles solved first over the motion, before the intervals are halved
MAX_HALVINGS = 24  # an interval still unproven after this many halvings is refused
MIN_TOL = 1e-7  # the reported smallest sin^2 of a transmission angle is this close (below)


def C_at(c: dict, d: np.ndarray) -> dict:
    """A group's constants (arrays over designs) at the designs ``d``."""
    return {k: (v[d] if isinstance(v, np.ndarray) else v) for k, v in c.items()}


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

        odd = [g for g in an0.plan if g.n_modes == 2 and not isinstance(g, RRR)]
        if odd:
            raise InputError(
                f"the template's {odd[0].describe()} is not a revolute dyad: path "
                "generation on a chain takes revolute dyads (RRR) only"
            )
        odd = [g for g in an0.plan if not isinstance(g, (RRR, DriverLink))]
        if odd:
            raise InputError(
                f"the template's {odd[0].describe()} is neither a driven crank nor a "
                "revolute dyad: path generation on a chain takes a crank driving "
                "revolute dyads (RRR) only"
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
        X = np.asarray(X, float)
        combos = np.broadcast_to(np.asarray(combo, float)[:, None], (len(combo), X.shape[1]))
        return self._evaluate_columns(X, combos)

    def _evaluate_columns(self, X: np.ndarray, combos: np.ndarray, tol: float | None = None):
        """As :meth:`evaluate_combo`, each design (column of X) on its own branches (the
        column of ``combos``): all of them solved as one batch."""
        from mechsolve.analyses.batch import _design_states

        S = X.shape[1]
        u = np.asarray(self.angles(X), float)
        su, _ = self._samples(u)
        allu = np.vstack([u, su]).T  # (S, N + SAMPLES)
        L = allu.shape[1]
        modes = np.ones((len(self.an0.plan), S))
        for gi, m in zip(self.branch_groups, combos):
            modes[gi] = m
        num = self.numbers(X)
        solve = _design_states(self.an0, num, modes, 1.0)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            a, st, ok = solve(allu)
            ref = a.points[self.spec.names["P"]]
            px, py = st.point(ref.body, ref.local)
            px, py = px.reshape(S, L)[:, : self.n].T, py.reshape(S, L)[:, : self.n].T
            t = self.spec.targets
            dx, dy = px - t[:, 0:1], py - t[:, 1:2]
            cols = (np.arange(S)[:, None] * L + np.arange(self.n, L)[None, :]).ravel()
            rows = list(self.margins(num, modes, su.T, a, st, ok, cols, tol))
            okm = ok.reshape(S, L)
            for gi in range(len(self.an0.plan)):
                if gi not in self.branch_groups:  # a group that must close everywhere
                    rows.append(np.where(np.all(okm, axis=1), 1.0, -1.0))
        if self.spec.timing is None:
            rows.append((TWO_PI - np.sum(X[self.nv + 1 :], axis=0)) / TWO_PI)
        return dx, dy, np.vstack(rows)

    # -- the exact check of the dyads between the solved crank angles -------------------
    def _constants(self, a, cols: np.ndarray) -> list[dict]:
        """What the bounds need of each group, at the columns ``cols`` of a solve of the
        group plan ``a.plan``: the bodies, and the distances of the joints from the
        bodies' frames (constant over the motion)."""
        n = len(cols)

        def norm(v):
            v = np.asarray(v, float)
            if v.ndim == 1:
                return np.full(n, math.hypot(v[0], v[1]))
            return np.hypot(v[0], v[1])[cols]

        def per(v):
            v = np.asarray(v, float)
            return np.full(n, float(v)) if v.ndim == 0 else v[cols]

        out = []
        for g in a.plan:
            if isinstance(g, DriverLink):
                other = g._angle_terms(None, None, "")[0]
                out.append({"b": g.b, "k": g.k, "other": other, "rk": norm(g.sk),
                            "rb": norm(g.sp)})  # fmt: skip
            else:
                L1, L2 = per(g.L1), per(g.L2)
                out.append({"b1": g.b1, "b2": g.b2, "k1": g.k1, "k2": g.k2,
                            "rP": norm(g.sPk), "rQ": norm(g.sQk), "r1": norm(g.sP1),
                            "r2": norm(g.sQ2), "L1": L1, "L2": L2})  # fmt: skip
        return out

    def _distances(self, a, st, n: int) -> dict[int, np.ndarray]:
        """Each dyad's distance D between its outer joints at every column (NaN where a
        group before it does not close there)."""
        return {gi: np.sqrt(np.broadcast_to(a.plan[gi].ends(st)[6], (n,)))
                for gi in self.branch_groups}  # fmt: skip

    def _sin2(self, c: dict, D: np.ndarray) -> np.ndarray:
        """``sin^2`` of the angle at the middle joint as a function of D (negative where
        the dyad cannot close)."""
        L1s, L2s = c["L1"] ** 2, c["L2"] ** 2
        D2 = D * D
        half = 0.5 * (L1s - L2s + D2)
        return (L1s * D2 - half * half) / (L1s * L2s)

    def _interval_margins(self, C: list[dict], Da: dict, Db: dict, w: np.ndarray):
        """A lower bound of each dyad's ``H - sin^2(min transmission)`` over intervals of
        crank angles of width ``w`` whose ends have the distances ``Da``, ``Db``.

        Speeds are per radian of crank. Ground: 0. The driven link turns at most 1 plus
        the angular speed of the body it is driven from. A dyad whose outer joints move
        at most ``V_P``, ``V_Q`` has ``|dD/du| <= V_P + V_Q = K``, so over the interval
        ``D`` lies within ``(Da + Db) / 2 -+ K w / 2``; ``H`` is concave in ``D^2``, so its
        least value is at one end of that range. With ``H >= H_min > 0`` the dyad's links
        turn at most ``K / (L1 sqrt(H_min))`` and ``K / (L2 sqrt(H_min))`` (the rate of
        its closure equations projected on the other link). A dyad that is not proven
        leaves the ones after it unbounded (their bound is not positive)."""
        nb = self.an0.system.nb
        V: dict[int, Any] = {nb: 0.0}
        Om: dict[int, Any] = {nb: 0.0}

        def times(x, r):
            return np.where(r > 0, x * r, 0.0)

        out = {}
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            for gi, c in enumerate(C):
                if "other" in c:  # the driven link
                    Om[c["b"]] = Om[c["other"]] + 1.0
                    V[c["b"]] = V[c["k"]] + times(Om[c["k"]], c["rk"]) + times(Om[c["b"]], c["rb"])
                    continue
                vp = V[c["k1"]] + times(Om[c["k1"]], c["rP"])
                vq = V[c["k2"]] + times(Om[c["k2"]], c["rQ"])
                K = vp + vq
                half = np.where(w > 0, 0.5 * K * w, 0.0)
                mid = 0.5 * (Da[gi] + Db[gi])
                lo = np.maximum(mid - half, 0.0)
                hi = np.minimum(mid + half, 2.0 * (c["L1"] + c["L2"]))
                H = np.minimum(self._sin2(c, lo), self._sin2(c, hi))
                H = np.where(np.isfinite(H), H, -1.0)
                out[gi] = H - self.sin2_min
                root = np.sqrt(np.maximum(H, 0.0))
                w1 = np.where(H > 0, K / (c["L1"] * root), np.inf)
                w2 = np.where(H > 0, K / (c["L2"] * root), np.inf)
                Om[c["b1"]], Om[c["b2"]] = w1, w2
                V[c["b1"]] = vp + times(w1, c["r1"])
                V[c["b2"]] = vq + times(w2, c["r2"])
        return out

    def _solve_at(self, num, modes, d: np.ndarray, u: np.ndarray, Cd: list[dict]):
        """The designs ``d`` (one column each) solved at the crank angles ``u``, as one
        batch: each dyad's distance D between its outer joints, and its
        ``H - sin^2(min transmission)`` there (-1 where a group before it is open)."""
        from mechsolve.analyses.batch import _design_states

        solve = _design_states(self.an0, num[d], modes[:, d], 1.0)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            a, st, ok = solve(u[:, None])
            D = self._distances(a, st, len(ok))
            v = {}
            for gi in self.branch_groups:
                h = self._sin2(C_at(Cd[gi], d), D[gi]) - self.sin2_min
                v[gi] = np.where(np.isfinite(h), h, -1.0)
        return D, v

    def margins(
        self,
        num: np.ndarray,
        modes: np.ndarray,
        su: np.ndarray,
        a: Any,
        st: Any,
        ok: np.ndarray,
        cols: np.ndarray,
        tol: float | None = None,
    ) -> Iterator[np.ndarray]:
        """Each dyad's least ``H - sin^2(min transmission)`` over the whole motion: one
        row per dyad (S,), positive only where proven positive at every crank angle.

        ``su`` (S, SAMPLES) are the crank angles solved in ``a``/``st`` at the columns
        ``cols`` (design by design). Every interval between two solved angles gets the
        lower bound of :meth:`_interval_margins`; those not proven are halved, their
        midpoints solved as one batch, until proven, or a solved angle shows a real
        violation (the row is then that value, the design is infeasible), or after
        :data:`MAX_HALVINGS` (the row is then the bound, not positive). With ``tol``, the
        intervals whose bound is more than ``tol`` below the least solved value are halved
        too, so that a proven row is the least value to within ``tol`` (below)."""
        S, Ls = su.shape
        gs = self.branch_groups
        if not gs:
            return
        first = cols.reshape(S, Ls)[:, 0]
        Cd = self._constants(a, first)
        Dc = self._distances(a, st, len(ok))
        Ds = {gi: Dc[gi][cols].reshape(S, Ls) for gi in gs}
        real = {}
        for gi in gs:
            c = {key: val[:, None] for key, val in Cd[gi].items() if key in ("L1", "L2")}
            v = self._sin2(c, Ds[gi]) - self.sin2_min
            v = np.where(np.isfinite(v), v, -1.0)
            real[gi] = np.min(v, axis=1)
        worst = np.min(np.vstack([real[gi] for gi in gs]), axis=0)
        lb = {gi: np.full(S, np.inf) for gi in gs}
        d = np.repeat(np.arange(S), Ls - 1)
        ua, ub = su[:, :-1].ravel(), su[:, 1:].ravel()
        Da = {gi: Ds[gi][:, :-1].ravel() for gi in gs}
        Db = {gi: Ds[gi][:, 1:].ravel() for gi in gs}
        for depth in range(MAX_HALVINGS + 1):
            live = worst[d] > 0  # designs with a real violation are decided
            d, ua, ub = d[live], ua[live], ub[live]
            Da = {gi: v[live] for gi, v in Da.items()}
            Db = {gi: v[live] for gi, v in Db.items()}
            if not len(d):
                break
            C = [C_at(c, d) for c in Cd]
            m = self._interval_margins(C, Da, Db, np.abs(ub - ua))
            low = np.min(np.vstack([m[gi] for gi in gs]), axis=0)
            need = low <= 0
            if tol is not None:
                need |= low < worst[d] - tol
            final = ~need if depth < MAX_HALVINGS else np.ones(len(d), bool)
            for gi in gs:
                np.minimum.at(lb[gi], d[final], m[gi][final])
            if depth == MAX_HALVINGS or not need.any():
                break
            d, ua, ub = d[need], ua[need], ub[need]
            Da = {gi: v[need] for gi, v in Da.items()}
            Db = {gi: v[need] for gi, v in Db.items()}
            um = 0.5 * (ua + ub)
            Dm, vm = self._solve_at(num, modes, d, um, Cd)
            for gi in gs:
                np.minimum.at(real[gi], d, vm[gi])
                np.minimum.at(worst, d, vm[gi])
            d = np.concatenate([d, d])
            ua, ub = np.concatenate([ua, um]), np.concatenate([um, ub])
            Da = {gi: np.concatenate([Da[gi], Dm[gi]]) for gi in gs}
            Db = {gi: np.concatenate([Dm[gi], Db[gi]]) for gi in gs}
        for gi in gs:
            yield np.where(worst > 0, np.minimum(real[gi], lb[gi]), real[gi])

    def evaluate(self, X: np.ndarray):
        """(objective (S,), constraints (M, S), combo index (S,)) with each design on its
        best feasible branch combination (or, if none is feasible, the least infeasible)."""
        X = np.asarray(X, float)
        key = X.tobytes() + bytes(str(X.shape), "ascii")
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        S, nc = X.shape[1], len(self.combos)
        # every design on every branch combination, as one batch
        dx, dy, call = self._evaluate_columns(np.tile(X, nc), np.repeat(self.combos.T, S, 1))
        best_f = best_c = best_k = None
        for k in range(nc):
            part = slice(k * S, (k + 1) * S)
            c = call[:, part]
            f = np.sum(dx[:, part] ** 2 + dy[:, part] ** 2, axis=0)
            f = np.where(np.isfinite(f), f, np.inf)
            feas = np.all(c > 0, axis=0)
            score = np.where(feas, f, np.inf)
            viol = np.min(c, axis=0)
            if best_f is None:
                best_f, best_c, best_k = score, c, np.zeros(S, int)
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
    lo, hi = np.array(bounds).T
    x0 = np.clip(np.asarray(x0, float), lo, hi)
    k = int(batch.evaluate(x0[:, None])[2][0])
    combo = batch.combos[k]

    def columns(X):
        dx, dy, _ = batch.evaluate_combo(X, combo)
        return np.vstack([dx, dy])

    r = batch_least_squares(columns, x0, lo, hi, max_nfev=300)
    if r is None:
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
    # the smallest transmission angle over the motion: the dyads' proven margins, refined
    # to within MIN_TOL of the least value (a lower bound)
    dx, dy, c = batch._evaluate_columns(X, combo[:, None], tol=MIN_TOL)
    dist = np.hypot(dx[:, 0], dy[:, 0])
    u = np.asarray(batch.angles(X), float)[:, 0]
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
