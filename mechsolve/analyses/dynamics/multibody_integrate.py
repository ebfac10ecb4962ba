"""The integration of a :class:`~.multibody.Multibody` over time: adaptive (scipy's
``solve_ivp``) or fixed-step RK4 on the independent coordinates of a partition, a new
partition where the chosen one loses its conditioning, a bridge on all coordinates
across singular positions, and the events that end a run early (see
:mod:`.multibody_events`):

``stop`` (``simulate``'s ``stop when``)
    located by solve_ivp's event finder on the dense output (adaptive) or by Brent's
    method on the RK4 step (fixed step), to the integrator's accuracy; the state there
    is the last output row.
``singular: stop``
    the first singular position the motion reaches (the constraint equations lose
    rank): located on the motion integrated on all coordinates; the last output row.
``singular: keep branch``
    a singular position after which the branch of a loop (the side its assembly chose)
    would change: the run ends at the singular position.
A position the motion cannot pass (no partition closes and the bridge fails) ends the
run at the last closed state, with its reason.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from mechsolve.analyses.dynamics.multibody import (
    NEWTON_ITERATIONS,
    Multibody,
    NotClosing,
    Repartition,
    Stop,
    Trajectory,
    _lu,
)
from mechsolve.analyses.dynamics.multibody_events import (
    S_NEAR,
    all_coordinates,
    locate_singular,
    project,
    rk4,
    singular_measure,
)
from mechsolve.analyses.dynamics.multibody_full import full_output
from mechsolve.analyses.dynamics.multibody_lite import LiteEquations
from mechsolve.analyses.dynamics.multibody_rows import close_rows


def integrate(
    mb: Multibody,
    q0: np.ndarray,
    qd0: np.ndarray,
    duration: float,
    *,
    step: float | None = None,
    method: str = "DOP853",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    max_steps: int | None = None,
    stop: Stop | None = None,
    singular: str = "pass",
    branch: Callable[[np.ndarray], tuple] | None = None,
) -> Trajectory:
    """Integrate the motion from ``(q0, qd0)`` (consistent) over ``duration``.

    ``method`` ``"rk4"``: fixed steps of ``step``; otherwise scipy's ``solve_ivp`` with
    ``rtol``/``atol`` on the independent coordinates, their rates and the work,
    reporting every ``step`` (default: 500 outputs). ``stop``: a condition that ends
    the run; ``singular``: ``"pass"``, ``"stop"`` or ``"keep branch"`` (then ``branch``
    gives the loops' branches at a configuration)."""
    h = step if step is not None else duration / 500
    n_out = int(math.floor(duration / h + 1e-9))
    times = np.r_[np.arange(n_out + 1) * h, [duration] if n_out * h < duration - 1e-12 else []]
    run = _Run(mb, q0, qd0, times, method, rtol, atol)
    run.stop, run.singular, run.branch = stop, singular, branch
    run.branch0 = branch(run.q) if branch is not None else None
    if stop is not None and run.g(0.0, run.q, run.qd) <= 0:
        run.halt("stop when", f"'{stop.text}' holds at the start (t = 0 s)")
    else:
        run.go(max_steps)
    return run.trajectory(q0)


class _Run:
    """One integration: the state at the last output, the partition, the records."""

    KEYS = ("t", "q", "qd", "qdd", "lam", "T", "V", "W", "viol", "vviol")

    def __init__(self, mb: Multibody, q0, qd0, times, method, rtol, atol) -> None:
        self.mb, self.times, self.method, self.rtol, self.atol = mb, times, method, rtol, atol
        self.substeps = bridge_substeps(method, rtol)
        self.rec: dict[str, list] = {k: [] for k in self.KEYS}
        self.q, self.qd, self.W = q0.astype(float).copy(), qd0.astype(float).copy(), 0.0
        mb.rank = None
        self.part = mb.partition(self.q)
        self.rank = len(self.part.rows)
        if self.rank < mb.nc and _persists(mb, self.q, self.rank):
            mb.rank = self.rank  # redundant equations: this rank at every state
        self.partitions, self.bridges = 1, 0
        self.stopped, self.early, self.event = "", False, ""
        self.stop: Stop | None = None
        self.singular, self.branch, self.branch0 = "pass", None, None
        self.last_rc = None  # (t, y, rcond of Phi_d) of the last evaluation
        self.h_last = self.h_next = None  # the integrator's next step (see _adaptive)
        self.lite = LiteEquations(mb) if mb.lite else None  # the evaluation on arrays
        self.evaluated: dict = {}  # the evaluations of the closed outputs, by id(q)
        self.rows: dict = {}  # the outputs closed on arrays: what record() keeps, by id(q)
        self.record(0.0, self.q, self.qd, self.W)

    def halt(self, kind: str, why: str) -> None:
        self.event, self.stopped, self.early = kind, why, kind != "stop when"

    def g(self, t: float, q, qd) -> float:
        """The stop condition's function at a closed state (positive: not met)."""
        qdd = self.mb.accelerations(self.part, q, qd, t)[0]
        return float(self.stop.g(t, q, qd, qdd))

    def record(self, t, q, qd, W) -> None:
        """Keep an output: its state, accelerations, multipliers, energies, violations."""
        mb, rec = self.mb, self.rec
        done = self.rows.pop(id(q), None)
        if done is not None:  # closed with its stretch of rows (see _closed_rows)
            for key, value in zip(self.KEYS, (t, q.copy(), qd.copy(), *done[:4], W, *done[4:])):
                rec[key].append(value)
            mb._last = (t, q.copy(), qd.copy(), done[0])
            return
        mb._ev = self.evaluated.pop(id(q), None)
        if mb.rank is not None and mb.friction is None:  # redundant equations
            qdd, lam, T, V = full_output(mb, q, qd, t)
        else:
            qdd, lam, T, V = mb.output(self.part, q, qd, t)
        # pins: nu = 0 (no state to build for it)
        nu = 0.0 if mb.pins is not None else mb._nu_gamma(mb.state(q), t, gamma=False)
        for key, value in (
            ("t", t),
            ("q", q.copy()),
            ("qd", qd.copy()),
            ("qdd", qdd),
            ("lam", lam),
            ("T", T),
            ("V", V),
            ("W", W),
            ("viol", float(np.max(np.abs(mb.residual(q, t)), initial=0.0))),
            ("vviol", float(np.max(np.abs(mb.jacobian(q) @ qd - nu), initial=0.0))),
        ):
            rec[key].append(value)
        mb._last = (t, q.copy(), qd.copy(), qdd)

    def undetermined(self) -> None:
        """The last output is at a singular position: its accelerations and multipliers
        are not determined by the equations there (the equations' rank drops; a solve
        gives numbers of 1e13 N), so they are left empty."""
        rec = self.rec
        rec["qdd"][-1] = np.full_like(np.asarray(rec["qdd"][-1], float), np.nan)
        rec["lam"][-1] = np.full_like(np.asarray(rec["lam"][-1], float), np.nan)

    def rhs(self, t, y):
        """d/dt (z, z', W) on the current partition."""
        mb, part = self.mb, self.part
        if self.lite is not None and len(part.dep):  # pins, loads on arrays
            return self.lite.rhs(self, part, t, y)
        nq = mb.nq
        # Newton starts from the integrated dependent coordinates (the state carries
        # them all, a predictor to the integrator's accuracy)
        qq = mb.close(part, y[part.ind], t, y[:nq])
        qqd, Jq = mb.rates(part, qq, y[nq + part.ind], t)
        qdd, _, P, _ = mb.accelerations(part, qq, qqd, t, Jq)
        mb._last = (t, qq, qqd, qdd)
        self.last_rc = (t, y, mb.rc)
        return np.concatenate([qqd, qdd, [P]])

    def _closed(self, t1, y1):
        """``(t, q, q', W)`` from the partition's state ``y1`` at ``t1``."""
        mb, part = self.mb, self.part
        nq = mb.nq
        q1 = mb.close(part, y1[part.ind], t1, y1[:nq])
        qd1, _ = mb.rates(part, q1, y1[nq + part.ind], t1)
        mb._last = (t1, q1, qd1, mb.accelerations(part, q1, qd1, t1)[0])
        self.evaluated[id(q1)] = mb._ev  # record() takes its accelerations, multipliers
        return (t1, q1, qd1, float(y1[-1]))

    def _closed_rows(self, ts, ys) -> list:
        """The outputs ``(t, q, q', W)`` of the integrated states: all closed at once on
        arrays where the mechanism allows (their accelerations, multipliers, energies
        and violations kept for :meth:`record`), else one by one."""
        done = close_rows(self.mb, self.part, ys) if ts else None
        if done is None:
            return [self._closed(t1, y1) for t1, y1 in zip(ts, ys)]
        out = []
        for i, (t1, y1) in enumerate(zip(ts, ys)):
            q1 = done.q[i]
            self.rows[id(q1)] = (
                done.qdd[i],
                done.lam[i],
                float(done.T[i]),
                float(done.V[i]),
                float(done.viol[i]),
                float(done.vviol[i]),
            )
            out.append((t1, q1, done.qd[i], float(y1[-1])))
        return out

    def outputs(self, k: int) -> list:
        """The outputs from ``times[k]`` on (one RK4 step, or up to :data:`CHUNK` of an
        adaptive run until an event), each closed on the partition."""
        mb = self.mb
        t0 = self.times[k - 1]
        self.evaluated, self.rows = {}, {}
        y0 = np.concatenate([self.q, self.qd, [self.W]])
        fired = None
        if self.method == "rk4":
            ts, ys = [self.times[k]], [rk4(self.rhs, t0, y0, self.times[k] - t0)]
        else:
            # (redundant equations: the partition is checked against a fresh one
            # every few outputs, see Multibody._needs_repartition)
            window = self.times[k - 1 : k + (CHUNK if mb.rank is None else CHUNK_REDUNDANT)]
            ts, ys, fired = _adaptive(self, window, y0)
        if not ts and (fired is None or fired[0] == "conditioning"):
            raise Repartition  # the conditioning event at once: no partition here
        self.event_fired = fired[0] if fired else ""
        mb._last = (t0, self.q, self.qd, self.rec["qdd"][-1])
        out = self._closed_rows(ts, ys)
        if fired is not None and fired[0] == "stop":
            out.append(self._closed(fired[1], fired[2]))
        elif self.method == "rk4" and self.stop is not None:
            out = self._stop_in_step(out, t0, y0)
        return out

    def _stop_in_step(self, out, t0, y0):
        """The RK4 step's end meets the stop condition: its root within the step by
        Brent's method on RK4 steps from the step's start."""
        from scipy.optimize import brentq

        t1, q1, qd1, _ = out[-1]
        if self.g(t1, q1, qd1) > 0:
            return out

        def at(tau):
            self.mb._last = (t0, self.q, self.qd, self.rec["qdd"][-1])
            return self._closed(tau, rk4(self.rhs, t0, y0, tau - t0))

        def g(tau):
            s = at(tau)
            return self.g(s[0], s[1], s[2])

        tau = brentq(g, t0, t1, xtol=1e-14 * max(1.0, t1), rtol=4 * np.finfo(float).eps)
        self.event_fired = "stop"
        return [at(tau)]

    def go(self, max_steps: int | None) -> None:
        mb, times = self.mb, self.times
        k, retries = 1, 0
        self.event_fired = ""
        while k < len(times):
            if self.singular != "pass" and (
                self.event_fired == "near" or singular_measure(mb, self.q, self.rank) < S_NEAR
            ):
                self.event_fired = ""
                k = self.near_singular(k)
                if self.stopped:
                    return
                continue
            near = self._near()
            try:
                if near:
                    raise Repartition
                out = self.outputs(k)
            except Repartition:
                # at or next to a singular position no partition describes the motion:
                # the step is bridged on all the coordinates, then projected
                retries += 0 if near and mb.rank is not None else 1
                t0 = times[k - 1]
                bridged = retries <= BRIDGE_LIMIT and _bridge(
                    mb, t0, times[k], self.q, self.qd, self.W, self.substeps
                )
                if not bridged:
                    self.halt(
                        "cannot close",
                        f"the mechanism cannot close at t = {t0:.6g} s along the motion "
                        "(a singular or limit position it cannot pass)",
                    )
                    return
                out, self.event_fired = [(times[k], *bridged)], "bridge"
                self.bridges += 1
                if self.stop is not None:
                    out = self._stop_in_bridge(out, t0)
            except NotClosing as exc:
                self.halt("cannot close", str(exc))
                return
            else:
                retries = 0 if out else retries
            for t1, q, qd, W in out:
                self.record(t1, q, qd, W)
                self.q, self.qd, self.W = q, qd, W
            if self.event_fired == "stop":
                self.halt("stop when", f"'{self.stop.text}' was met")
                return
            k += len(out)
            if self.event_fired or mb._needs_repartition(self.part, self.q):
                self.part = mb.partition(self.q)
                self.partitions += 1
            if max_steps is not None and k > max_steps:
                self.halt("max steps", f"stopped after {max_steps} steps (--max-steps)")
                return

    def _near(self) -> bool:
        """The next output step is bridged at once: after an event next to a singular
        position (a new partition there is ill-conditioned itself: integrating on it
        loses energy) and, with redundant equations, wherever the motion is next to
        one (a partition there closes the state on its own equations only, and the
        state drifts off the set-aside one by tol / sigma; see multibody_full)."""
        redundant = self.mb.rank is not None
        if not (self.event_fired or redundant):
            return False
        if redundant and self.event_fired == "near":
            return True
        return singular_measure(self.mb, self.q, self.rank) < S_NEAR

    def q_time(self) -> float:
        return float(self.rec["t"][-1])

    def _stop_in_bridge(self, out, t0):
        """A bridged step that meets the stop condition: its root within the step."""
        from scipy.optimize import brentq

        t1, q1, qd1, _ = out[-1]
        if self.g(t1, q1, qd1) > 0:
            return out

        def at(tau):
            b = _bridge(self.mb, t0, tau, self.q, self.qd, self.W, self.substeps)
            if not b:
                raise Repartition
            return (tau, *b)

        def g(tau):
            s = at(tau)
            return self.g(s[0], s[1], s[2])

        tau = brentq(g, t0, t1, xtol=1e-14 * max(1.0, t1))
        self.event_fired = "stop"
        return [at(tau)]

    def near_singular(self, k: int) -> int:
        """Near a singular position (``singular: stop`` or ``keep branch``): the output
        step is taken on all coordinates; a singular position within it is located and
        ends the run (``stop``), or is passed where the branches stay."""
        mb, times = self.mb, self.times
        t0, t1 = times[k - 1], times[k]
        found = locate_singular(
            mb, self.rank, t0, self.q, self.qd, self.W, t1 - t0, t1, NEWTON_ITERATIONS
        )
        bridged = _bridge(mb, t0, t1, self.q, self.qd, self.W, self.substeps)
        # the stop condition met before the singular position (or the step's end)
        end = found[:4] if found is not None else (t1, *bridged) if bridged else None
        if self.stop is not None and end is not None:
            out = self._stop_in_bridge([end], t0)
            if self.event_fired == "stop":
                self.record(*out[0])
                self.halt("stop when", f"'{self.stop.text}' was met")
                return k
        if found is not None:
            ts, qs, qds, Ws, s = found
            where = (
                f"at t = {ts:.9g} s (the constraint equations lose rank there: the "
                f"smallest singular value of Phi_q is {s:.1e} of the largest)"
            )
            if self.singular == "stop":
                self.record(ts, qs, qds, Ws)
                self.undetermined()
                self.halt("singular", f"a singular position {where}")
                return k
            if bridged and self.branch is not None:
                after = self.branch(bridged[0])
                if after != self.branch0:
                    self.record(ts, qs, qds, Ws)
                    self.undetermined()
                    self.halt("branch", f"the branch would change at the singular position {where}")
                    return k
        if not bridged:
            self.halt(
                "cannot close",
                f"the mechanism cannot close at t = {t0:.6g} s along the motion "
                "(a singular or limit position it cannot pass)",
            )
            return k
        self.bridges += 1
        self.record(t1, *bridged)
        self.q, self.qd, self.W = bridged
        self.part = mb.partition(self.q)
        self.partitions += 1
        return k + 1

    def trajectory(self, q0) -> Trajectory:
        mb = self.mb
        arr = {k: np.array(v) for k, v in self.rec.items()}
        n = len(arr["t"])
        return Trajectory(
            t=arr["t"],
            q=arr["q"].reshape(-1, mb.nq),
            qd=arr["qd"].reshape(-1, mb.nq),
            qdd=arr["qdd"].reshape(-1, mb.nq),
            lam=arr["lam"].reshape(n, -1),
            kinetic=arr["T"],
            potential=arr["V"],
            work=arr["W"],
            violation=arr["viol"],
            velocity_violation=arr["vviol"],
            redundant=_redundant(mb, q0),
            stopped=self.stopped,
            early=self.early,
            event=self.event,
            nfev=mb.nfev,
            partitions=self.partitions,
            bridges=self.bridges,
        )


def _persists(mb: Multibody, q: np.ndarray, rank: int) -> bool:
    """The equations keep their rank ``rank`` (below their number) next to ``q``: they
    are redundant, not only at a singular position where the motion starts. Checked
    at a configuration closed from ``q`` moved by 1e-3 of the mechanism's size along
    the equations' null space."""
    _, _, Vt = np.linalg.svd(mb.jacobian(q))
    if Vt.shape[0] <= rank:
        return True
    moved = project(mb, 0.0, q + 1e-3 * mb.scale * Vt[rank], np.zeros(mb.nq), NEWTON_ITERATIONS)
    return moved is not None and len(mb.partition(moved[0]).rows) == rank


def _redundant(mb: Multibody, q: np.ndarray) -> bool:
    return len(mb.partition(q).rows) < mb.nc


BRIDGE_LIMIT = 40  # output steps in a row that may be bridged
BRIDGE_SUBSTEPS = 32  # RK4 steps per bridged output step at rtol 1e-8 and tighter
BRIDGE_FEWEST = 8  # and at the loosest rtol


def bridge_substeps(method: str, rtol: float) -> int:
    """RK4 steps per bridged output step: :data:`BRIDGE_SUBSTEPS` for the fixed-step
    integrator and at ``rtol`` 1e-8 or tighter; at a looser ``rtol`` fewer, as RK4's
    error goes with the fourth power of its step (``32 (1e-8 / rtol)^(1/4)``, at least
    :data:`BRIDGE_FEWEST`): the bridge's error then stays about as far below the
    tolerance as at 1e-8."""
    if method == "rk4" or rtol <= 1e-8:
        return BRIDGE_SUBSTEPS
    return max(BRIDGE_FEWEST, math.ceil(BRIDGE_SUBSTEPS * (1e-8 / rtol) ** 0.25))


def _bridge(mb: Multibody, t0: float, t1: float, q, qd, W: float, substeps: int):
    """``(q, q', W)`` at ``t1`` from ``t0`` across a singular position: RK4 on all the
    coordinates in ``substeps`` steps (the accelerations by least squares on
    every equation, which stays determined for the motion where the equations lose
    rank), each step's end projected onto ``Phi = 0`` (minimum-norm Newton) and
    ``Phi_q q' = nu``. None if a projection does not converge."""
    nq = mb.nq
    f = all_coordinates(mb)
    y = np.concatenate([q, qd, [W]])
    h = (t1 - t0) / substeps
    try:
        for i in range(substeps):
            y = rk4(f, t0 + i * h, y, h)
            # back onto the constraints after every step: the stages' departure from
            # them is what the least squares amplify next to the singular position
            got = project(mb, t0 + (i + 1) * h, y[:nq].copy(), y[nq : 2 * nq], NEWTON_ITERATIONS)
            if got is None:
                return None
            y = np.concatenate([got[0], got[1], y[-1:]])
    except (np.linalg.LinAlgError, NotClosing):
        return None
    return got[0], got[1], float(y[-1])


CHUNK = 50  # outputs per call of solve_ivp: what a failed stage can cost
CHUNK_REDUNDANT = 5  # with redundant equations


def _adaptive(run: _Run, times, y0):
    """solve_ivp from ``times[0]`` through ``times[1:]`` until an event: ``Phi_d`` loses
    its conditioning (the partition is chosen again from the last output), the stop
    condition is met, or (``singular`` other than pass) the equations near a singular
    position. Returns the outputs and the event that ended it, ``(kind, t, y)``."""
    from scipy.integrate import solve_ivp

    events, kinds = _events(run)
    for e in events:
        e.terminal = True
    # a stretch that goes on from where the last one ended (no event between) starts
    # with the step the integrator would have taken next, not a new first step
    first, run.h_next = run.h_next, None
    try:
        sol = solve_ivp(
            run.rhs,
            (times[0], times[-1]),
            y0,
            method=_stepper(run),
            rtol=run.rtol,
            atol=run.atol,
            t_eval=times[1:],
            events=events,
            first_step=min(first, times[-1] - times[0]) if first else None,
        )
    except ValueError as exc:
        # an event seen at a step's end (from the step's last evaluation) but not on
        # the fresh closures of the root finder (they differ within the constraint
        # tolerance, next to the threshold): no bracket to locate it, so the output
        # step is bridged, as where no partition closes
        if "different signs" not in str(exc):
            raise
        raise Repartition from exc
    if sol.status < 0:
        raise Repartition
    if sol.status == 0:
        run.h_next = run.h_last
    fired = None
    if sol.status == 1:
        for kind, te, ye in zip(kinds, sol.t_events, sol.y_events):
            if len(te) and (fired is None or te[0] < fired[1]):
                fired = (kind, float(te[0]), np.asarray(ye[0]))
    ts, ys = list(sol.t), list(np.asarray(sol.y).T)
    if fired is not None and fired[0] == "stop" and ts and ts[-1] >= fired[1]:
        ts, ys = ts[:-1], ys[:-1]  # the event's own row replaces an output at its time
    return ts, ys, fired


def _events(run: _Run):
    """The terminal events of :func:`_adaptive` and their kinds."""
    mb, part = run.mb, run.part
    fn = len(part.ind)

    def closed(t, y):
        return mb.close(part, y[part.ind], t, y[: mb.nq])

    def conditioning(t, y):
        """Phi_d's reciprocal condition (1-norm estimate) falls below 0.1 of its value
        when the partition was chosen: at a step's end that of the step's last
        evaluation (the same state), elsewhere (the event's root) from a closure."""
        if fn == 0 or len(part.dep) == 0:
            return 1.0
        last = run.last_rc
        if last is not None and last[0] == t and np.array_equal(last[1], y):
            rc = last[2]
        else:
            rc = _lu(mb.jacobian(closed(t, y))[part.dd])[1]
        return rc - 0.1 * part.rcond1

    events: list = [conditioning]
    kinds = ["conditioning"]
    if mb.rank is not None and fn and len(part.dep):

        def better(t, y):
            """Redundant equations: a partition chosen afresh would be 10x better
            conditioned (the one chosen where the motion left a singular position
            closes the equation it sets aside 1e-5 off where the cranks stand up)."""
            q = closed(t, y)
            return _lu(mb.jacobian(q)[part.dd])[1] - 0.1 * mb.partition(q).rcond1

        events.append(better)
        kinds.append("conditioning")
    if run.stop is not None:

        def stop(t, y):
            q = closed(t, y)
            qd, _ = mb.rates(part, q, y[mb.nq + part.ind], t)
            return run.g(t, q, qd)

        stop.direction = -1
        events.append(stop)
        kinds.append("stop")
    if run.singular != "pass" or mb.rank is not None:
        events.append(lambda t, y: singular_measure(mb, closed(t, y), run.rank) - S_NEAR)
        kinds.append("near")
    return events, kinds


def _stepper(run: _Run):
    """The run's integrator for ``solve_ivp``: scipy's explicit Runge-Kutta methods
    remembering their next step size in ``run.h_last`` (others: by name)."""
    from scipy.integrate import DOP853, RK23, RK45

    base = {"DOP853": DOP853, "RK45": RK45, "RK23": RK23}.get(run.method)
    if base is None:
        return run.method

    class Remembering(base):
        def _step_impl(self):
            done = super()._step_impl()
            run.h_last = self.h_abs
            return done

    return Remembering
