"""The generic group: any block of the constraint system, solved by Newton-Raphson.

Used for groups with no closed form (class III groups, triads, cylinders between two
moving links, ...) and, with ``solver.method: newton``, for the whole mechanism at once.
Positions are solved one after another; each starts from a prediction extrapolated from
the previous solutions (continuation), so that the solution stays on the branch it
started on. Velocities and accelerations solve the group's block of
``Phi_q qdot = nu`` and ``Phi_q qddot = gamma`` for all positions in one batched solve.
"""

from __future__ import annotations

import numpy as np

from ..errors import SolverError
from ..solvers.newton import SolveStats, solve
from ..state import State
from .base import Drive, Group

MAX_JUMP = 0.05  # largest accepted Newton correction: 5 % of the size, or 0.05 rad
MAX_DEPTH = 10  # at most 2**10 substeps per interval
BATCH_MIN = 64  # sweeps of at least this many positions are refined in one batch
COARSE = 48  # positions of the coarse continuation that predicts a batched sweep


class NewtonGroup(Group):
    """A group solved numerically. Keeps per-position solver statistics."""

    kind = "Newton"
    n_modes = 0  # the branch follows from the start guess and continuity

    def __init__(self, bodies, constraints, names, atol: float, max_iterations: int = 30):
        self.col = {b: k for k, b in enumerate(bodies)}
        self.n = 3 * len(bodies)
        self.m = sum(c.m for c in constraints)
        self.atol = atol
        self.scale = 1.0  # the mechanism's size; the analysis sets it
        self.batched = True
        self.predictor = "hermite"  # batched prediction between coarse positions: or "linear"
        self.max_iterations = max_iterations
        super().__init__(bodies, constraints, names)

    def describe(self) -> str:
        joints = ", ".join(c.name for c in self.constraints)
        return f"group of {', '.join(self.body_names)} (joints {joints})"

    # -- one position ------------------------------------------------------------------
    def get_q(self, st: State, i: int) -> np.ndarray:
        q = np.empty(self.n)
        for b, k in self.col.items():
            q[3 * k] = st.x[b, i]
            q[3 * k + 1] = st.y[b, i]
            q[3 * k + 2] = st.th[b, i]
        return q

    def set_q(self, st: State, i, q: np.ndarray) -> None:
        for b, k in self.col.items():
            st.x[b, i] = q[3 * k]
            st.y[b, i] = q[3 * k + 1]
            st.set_angle(b, q[3 * k + 2], i)

    def residual(self, st: State, u) -> np.ndarray:
        return np.concatenate([c.residual(st, u) for c in self.constraints], axis=0)

    def jacobian(self, st: State) -> np.ndarray:
        """The group's own block of Phi_q, shape (N, m, n)."""
        J = np.zeros((st.n, self.m, self.n))
        r = 0
        for c in self.constraints:
            for body, blk in c.jacobian(st).items():
                k = self.col.get(body)
                if k is not None:
                    J[:, r : r + c.m, 3 * k : 3 * k + 3] = blk.transpose(2, 0, 1)
            r += c.m
        return J

    def solve_at(self, st1: State, u1: np.ndarray, q0: np.ndarray) -> tuple[np.ndarray, SolveStats]:
        """Solve the group at the single position held by ``st1`` (N == 1) from ``q0``."""

        def fun(q):
            self.set_q(st1, 0, q)
            return self.residual(st1, u1)[:, 0]

        def jac(q):
            self.set_q(st1, 0, q)
            return self.jacobian(st1)[0]

        q, stats = solve(fun, jac, q0, self.atol, self.max_iterations)
        self.set_q(st1, 0, q)
        return q, stats

    # -- the sweep ----------------------------------------------------------------------
    def get_qdot(self, st: State, i: int) -> np.ndarray:
        q = np.empty(self.n)
        for b, k in self.col.items():
            q[3 * k], q[3 * k + 1], q[3 * k + 2] = st.vx[b, i], st.vy[b, i], st.w[b, i]
        return q

    def _jump(self, q: np.ndarray, q_pred: np.ndarray) -> float:
        """Size of the Newton correction from the prediction: lengths over the mechanism's
        size, angles in radians."""
        d = np.abs(q - q_pred)
        d[0::3] /= self.scale
        d[1::3] /= self.scale
        return float(d.max()) if d.size else 0.0

    def sweep(
        self,
        st: State,
        drive: Drive,
        q_start: np.ndarray,
        ok_in: np.ndarray,
        prefix=None,
        restart=None,
    ):
        """Solve positions 0..N-1: batched when possible (:meth:`sweep_batched`), else by
        continuation (:meth:`sweep_sequential`). Returns ``ok``, ``iterations``, ``methods``."""
        if self.batched and st.n >= BATCH_MIN and self.m == self.n and ok_in.all():
            out = self.sweep_batched(st, drive, q_start, prefix)
            if out is not None:
                return out
        return self.sweep_sequential(st, drive, q_start, ok_in, prefix, restart)

    def sweep_batched(self, st: State, drive: Drive, q_start: np.ndarray, prefix=None):
        """Predict every position from a coarse continuation, then refine all positions
        at once by batched Newton-Raphson.

        1. every k-th position (about :data:`COARSE` of them) is solved by continuation
           (:meth:`sweep_sequential`, with its jump checks and substeps);
        2. the group's rates dq/du there (a linear solve) give a cubic Hermite
           prediction of every position in between;
        3. Newton-Raphson iterates on all positions together (one batched linear solve per
           iteration); each position must converge and stay within :data:`MAX_JUMP` of
           its prediction.

        Returns None when any of this fails, so that the caller marches sequentially.
        """
        n = st.n
        k = max(1, n // COARSE)
        coarse = np.unique(np.r_[np.arange(0, n, k), n - 1])
        sub = st.take(coarse)
        dsub = drive.take(coarse)
        # the coarse pass counts its own positions; prefix() wants the sweep's sample
        sub_prefix = None if prefix is None else (lambda us, j: prefix(us, int(coarse[j])))
        okc, itc, _ = self.sweep_sequential(
            sub, dsub, q_start, np.ones(len(coarse), bool), prefix=sub_prefix
        )
        if not okc.all():
            return None
        self.velocity(sub, Drive(dsub.u, np.ones(len(coarse)), np.zeros(len(coarse))))
        qc = np.stack([self.get_q(sub, j) for j in range(len(coarse))])
        dqc = np.stack([self.get_qdot(sub, j) for j in range(len(coarse))])
        if not np.all(np.isfinite(dqc)):
            return None
        # cubic Hermite between coarse positions, in the driver coordinate
        u = drive.u
        seg = np.clip(np.searchsorted(coarse, np.arange(n), side="right") - 1, 0, len(coarse) - 2)
        u0, u1 = u[coarse[seg]], u[coarse[seg + 1]]
        h = (u1 - u0)[:, None]
        t = ((u - u0) / (u1 - u0))[:, None]
        if self.predictor == "linear":  # first order: the chord between coarse positions
            pred = (1 - t) * qc[seg] + t * qc[seg + 1]
        else:
            h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
            h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
            pred = h00 * qc[seg] + h10 * h * dqc[seg] + h01 * qc[seg + 1] + h11 * h * dqc[seg + 1]
        q = pred.copy()
        iters = np.zeros(n, int)
        todo = np.ones(n, bool)
        todo[coarse] = False
        q[coarse] = qc
        last = np.full(n, np.inf)
        for _ in range(self.max_iterations):
            idx = np.flatnonzero(todo)
            if idx.size == 0:
                break
            s1 = st.take(idx)
            self._set_q_rows(s1, q[idx])
            f = self.residual(s1, u[idx]).T  # (k, m)
            r = np.max(np.abs(f), axis=1)
            J = self.jacobian(s1)
            try:
                dq = np.linalg.solve(J, -f[..., None])[..., 0]
            except np.linalg.LinAlgError:
                return None
            step = np.max(np.abs(dq), axis=1)
            # converged: the residual was already small and the step tiny, or no longer
            # shrinking (the rounding level); the last step is then not taken
            done = (r <= self.atol) & ((step <= 1e-3 * self.atol) | (step >= last[idx]))
            take = ~done | (step <= 1e-3 * self.atol)
            q[idx[take]] += dq[take]
            iters[idx] += 1
            last[idx] = step
            todo[idx[done]] = False
        if todo.any():
            return None
        d = np.abs(q - pred)
        d[:, 0::3] /= self.scale
        d[:, 1::3] /= self.scale
        if np.max(d) > MAX_JUMP or not np.all(np.isfinite(q)):
            return None
        self._set_q_rows_into(st, q)
        iters[coarse] = itc
        methods = np.full(n, "newton (batched)", dtype=object)
        return np.ones(n, bool), iters, methods

    def _set_q_rows(self, st1: State, q: np.ndarray) -> None:
        for b, k in self.col.items():
            st1.x[b] = q[:, 3 * k]
            st1.y[b] = q[:, 3 * k + 1]
            st1.set_angle(b, q[:, 3 * k + 2])

    def _set_q_rows_into(self, st: State, q: np.ndarray) -> None:
        self._set_q_rows(st, q)

    def sweep_sequential(
        self,
        st: State,
        drive: Drive,
        q_start: np.ndarray,
        ok_in: np.ndarray,
        prefix=None,
        restart=None,
    ):
        """Solve positions 0..N-1 in order by continuation from ``q_start`` at position 0.

        Each step predicts from the previous solutions (Lagrange extrapolation) and corrects
        by Newton-Raphson (scipy when Newton fails). A step is accepted when the correction
        is small (:data:`MAX_JUMP`); otherwise the interval is marched in 2, 4, 8, ...
        substeps (``prefix(u, k)`` solves the groups before this one at substep values), so
        that a coarse step cannot jump to another branch. After a gap (a dead zone) the
        sweep resumes from ``restart(i)`` when it gives a guess (the closed-form groups on
        the user's branches; ``False`` when those cannot close there: the position is then
        unassemblable), else from the last solution. Returns ``ok``, ``iterations``
        and ``methods`` over the positions.

        Raises
        ------
        SolverError
            When even the finest substeps jump: the branch cannot be followed.
        """
        n = st.n
        ok = np.zeros(n, bool)
        iters = np.zeros(n, int)
        methods = np.array(["" for _ in range(n)], dtype=object)
        hu: list[float] = []
        hq: list[np.ndarray] = []
        last_good = np.asarray(q_start, float)
        for i in range(n):
            if not ok_in[i]:
                self._nan(st, i)
                hu, hq = [], []
                continue
            st1 = st.take([i])
            ui = float(drive.u[i])
            if not hq:  # the start, or the first position after a gap
                guess = restart(i) if (restart is not None and i > 0) else None
                if guess is False:  # it cannot close on the user's branch here
                    self._nan(st, i)
                    methods[i] = "failed"
                    continue
                q0 = guess if guess is not None else last_good
                q, stats = self.solve_at(st1, drive.u[i : i + 1], q0)
                good = stats.converged
            else:
                q, stats, good = self._advance(st1, ui, hu, hq, i - 1, prefix)
            iters[i] = stats.iterations
            methods[i] = stats.method
            if good:
                ok[i] = True
                self.set_q(st, i, q)
                last_good = q
                hu, hq = (hu + [ui])[-3:], (hq + [q])[-3:]
            else:
                self._nan(st, i)
                hu, hq = [], []
        return ok, iters, methods

    def _advance(self, st1: State, ui: float, hu, hq, k: int, prefix):
        """One continuation step to ``ui``; substeps when the full step jumps."""
        q_pred = _extrapolate(hu, hq, ui)
        q, stats = self.solve_at(st1, np.array([ui]), q_pred)
        if stats.converged and self._jump(q, q_pred) <= MAX_JUMP:
            return q, stats, True
        converged_somewhere = stats.converged
        u0 = hu[-1]
        for depth in range(1, MAX_DEPTH + 1):
            m = 2**depth
            us = u0 + (ui - u0) * np.arange(1, m + 1) / m
            sub = prefix(us[:-1], k) if (prefix is not None and m > 1) else None
            lu, lq = list(hu), list(hq)
            total = 0
            ok_all = True
            for j, uj in enumerate(us):
                stj = st1 if j == m - 1 else (sub.take([j]) if sub is not None else st1)
                qp = _extrapolate(lu, lq, uj)
                qj, sj = self.solve_at(stj, np.array([uj]), qp)
                total += sj.iterations
                converged_somewhere |= sj.converged
                if not (sj.converged and self._jump(qj, qp) <= MAX_JUMP):
                    ok_all = False
                    break
                lu, lq = (lu + [uj])[-3:], (lq + [qj])[-3:]
            if ok_all:
                sj.iterations = total
                return qj, sj, True
            if not sj.converged and j == 0 and depth >= 4:
                break  # no solution even right next to the last one: a dead zone starts here
        if converged_somewhere and stats.converged:
            raise SolverError(
                f"cannot follow the branch of the {self.label} up to driver value {ui:.6g}: "
                f"the solution jumps even in {2**MAX_DEPTH} substeps (a singular position?); "
                "use a smaller step"
            )
        return q, stats, False

    def _nan(self, st: State, i: int) -> None:
        for b in self.bodies:
            for arr in (st.x, st.y, st.th, st.c, st.s):
                arr[b, i] = np.nan

    def position(self, st: State, drive: Drive, mode=1.0):
        """Solve all positions by continuation from the poses already in ``st`` at 0."""
        q0 = self.get_q(st, 0)
        ok, _, _ = self.sweep(st, drive, q0, np.ones(st.n, bool))
        return ok, self.indicator(st)

    def indicator(self, st: State) -> np.ndarray:
        """Reciprocal condition number of the group's Jacobian block at each position."""
        J = self.jacobian(st)
        good = np.all(np.isfinite(J), axis=(1, 2))
        out = np.zeros(st.n)
        if np.any(good):
            sv = np.linalg.svd(J[good], compute_uv=False)
            with np.errstate(divide="ignore", invalid="ignore"):
                out[good] = np.where(sv[:, 0] > 0, sv[:, -1] / sv[:, 0], 0.0)
        return out

    # -- derivatives --------------------------------------------------------------------
    def _rhs(self, st: State, drive: Drive, order: int) -> np.ndarray:
        rows = []
        for c in self.constraints:
            if order == 1:
                r = c.nu(st, drive.ud)
                vel = (st.vx, st.vy, st.w)
            else:
                r = c.gamma(st, drive.udd)
                vel = (st.ax, st.ay, st.al)
            r = np.array(r, dtype=float)
            for body, blk in c.jacobian(st).items():
                if body in self.col:
                    continue
                r -= blk[:, 0] * vel[0][body] + blk[:, 1] * vel[1][body] + blk[:, 2] * vel[2][body]
            rows.append(r)
        return np.concatenate(rows, axis=0).T  # (N, m)

    def _solve_batch(self, st: State, rhs: np.ndarray) -> np.ndarray:
        J = self.jacobian(st)
        out = np.full((st.n, self.n), np.nan)
        good = np.all(np.isfinite(J), axis=(1, 2)) & np.all(np.isfinite(rhs), axis=1)
        if np.any(good):
            if self.m == self.n:
                try:
                    out[good] = np.linalg.solve(J[good], rhs[good][..., None])[..., 0]
                except np.linalg.LinAlgError:
                    for i in np.flatnonzero(good):
                        out[i] = np.linalg.lstsq(J[i], rhs[i], rcond=None)[0]
            else:
                for i in np.flatnonzero(good):
                    out[i] = np.linalg.lstsq(J[i], rhs[i], rcond=None)[0]
        return out

    def velocity(self, st: State, drive: Drive) -> None:
        qd = self._solve_batch(st, self._rhs(st, drive, 1))
        for b, k in self.col.items():
            st.vx[b], st.vy[b], st.w[b] = qd[:, 3 * k], qd[:, 3 * k + 1], qd[:, 3 * k + 2]

    def acceleration(self, st: State, drive: Drive) -> None:
        qdd = self._solve_batch(st, self._rhs(st, drive, 2))
        for b, k in self.col.items():
            st.ax[b], st.ay[b], st.al[b] = qdd[:, 3 * k], qdd[:, 3 * k + 1], qdd[:, 3 * k + 2]


def _extrapolate(us: list[float], qs: list[np.ndarray], u: float) -> np.ndarray:
    """Lagrange extrapolation of the last (up to three) solutions to driver value ``u``."""
    k = len(qs)
    if k == 1:
        return qs[0].copy()
    out = np.zeros_like(qs[0])
    for i in range(k):
        w = 1.0
        for j in range(k):
            if j != i:
                den = us[i] - us[j]
                if den == 0:
                    return qs[-1].copy()
                w *= (u - us[j]) / den
        out += w * qs[i]
    return out
