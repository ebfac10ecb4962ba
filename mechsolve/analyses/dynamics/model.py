"""The reduced model: the equation of motion from the force analysis (see
:mod:`mechsolve.analyses.dynamics`)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from mechsolve.analyses.dynamics.constants import BESIDE_STEP, NEAR_EXACT, SWITCH_GRID
from mechsolve.analyses.dynamics.cycle import machine_cycle
from mechsolve.analyses.dynamics.tables import (
    _harmonics,
    _limit,
    _NoTable,
    _spectral_samples,
    _Table,
)
from mechsolve.base.errors import InputError, SolverError
from mechsolve.base.numerics import bisect_edge, limit_from_both_sides
from mechsolve.base.state import State
from mechsolve.core import evaluate as core
from mechsolve.core.friction import balance, frictional
from mechsolve.core.sweep import Analysis
from mechsolve.model import Mechanism

# Coulomb friction in a simulation is regularised: each joint's Coulomb part is scaled
# by tanh(|w| / w_s), w the driver's speed and w_s this fraction of the file's driver
# speed (1 rad/s or 1 m/s without one), so that it is continuous through a standstill
FRICTION_SMOOTHING = 1e-3


class ReducedModel:
    """The driver's equation of motion of a mechanism: J(phi), E(phi, omega, 0)."""

    def __init__(self, mech: Mechanism, method: str | None = None) -> None:
        self.mech = mech
        self.an = Analysis(mech, method)
        an = self.an
        self.u0 = an.start_value()
        # the reference sweep, 1 degree apart: the machine's cycle (a turn of a crank,
        # several of a pinion driving a wheel: see .cycle), or the file's sweep
        if an.linear:
            u, _ = an.sweep_values(self.u0)
            self.ref = core.states(an, u, 1.0, 0.0, velocity=True, acceleration=True)
            self.turns = None
        else:
            cyc = machine_cycle(an)
            self.ref, self.turns = cyc.sweep, cyc.turns
        # a crank that turns fully and whose linkage comes back as it started after a
        # turn (not, say, on its other branch): its motion is periodic in the angle
        self.full_turn = self.turns == 1
        # the extremes that stroke(q) in load conditions means (none without conditions),
        # over the machine's cycle
        conditions = any(ld.when is not None for ld in mech.loads)
        if self.turns == 0 and any(
            ld.when is not None and ld.when.uses("stroke") for ld in mech.loads
        ):
            cyc.require("stroke(q) in a load condition (its extremes over the cycle)", mech)
        self.extremes = core.forces(an, self.ref).stroke_extremes if conditions else []
        self.nfev = 0  # evaluations of the equation of motion
        # which conditional loads act, held fixed by an integrator between two switches
        # (see switch_angles), or None: decided at each angle
        self.frozen: list[bool] | None = None
        # joint friction: Coulomb's law regularised through a standstill of the driver
        # (see FRICTION_SMOOTHING), the equation solved at every stage (not tabulated)
        self.friction = bool(frictional(an))
        # the friction law of the last evaluation's force analysis, ((phi, omega, t),
        # FrictionResult), for the direct solve of the next acceleration (see _balanced)
        self._friction_law: tuple | None = None
        # the Coulomb magnitudes of the last acceleration accel solved with friction
        # (for the force analysis of the motion's rows: see _run.simulate)
        self.magnitudes: np.ndarray | None = None
        self._solved: tuple | None = None  # (eps, magnitudes) of the last accel solved
        # the last unit state solved, (key, solution) (see _unit_state)
        self._last_unit: tuple | None = None
        # False while terms() takes the limit from both sides (no second level of it)
        self._beside = True
        if self.friction:
            drv = mech.driver
            speed = abs(drv.speed) if drv.motion is None and drv.speed else 1.0
            an.friction_smoothing = FRICTION_SMOOTHING * speed

    def _wrap(self, phi: float) -> float:
        if not self.full_turn:
            return phi
        d = self.mech.driver.direction
        return self.u0 + d * math.fmod(d * (phi - self.u0), 2 * math.pi) % (2 * math.pi)

    def states(self, phi, omega, eps):
        """Solved states at driver values ``phi`` (each solved next to a sweep from the
        start, on its branches: see :meth:`_reaching`) with rates ``omega`` and ``eps``
        (arrays)."""
        phi = np.atleast_1d(np.asarray(phi, float))
        w = np.array([self._wrap(p) for p in phi])
        uniq, inv = np.unique(w, return_inverse=True)
        parts = []
        for wj in uniq:
            parts.append(self._unit_state(float(wj)))
        sol = core._concat(parts) if len(parts) > 1 else parts[0]
        if len(uniq) < len(w) or len(parts) > 1:
            sol = core._take(sol, inv)
        sol.u = phi
        core.scale_rates(sol.state, np.asarray(omega, float), np.asarray(eps, float))
        sol.ud = np.asarray(omega, float) * np.ones(len(phi))
        sol.udd = np.asarray(eps, float) * np.ones(len(phi))
        return sol

    def _unit_state(self, wj: float):
        """The state at the driver value ``wj`` per unit driver rate, solved next to a
        sweep from the start (a copy: the last one is kept, as an equation of motion
        with friction asks for the same position at several accelerations)."""
        an, span = self._reaching(wj)
        key = (wj, id(span))
        last = self._last_unit
        if last is not None and last[0] == key:
            return core._take(last[1], np.zeros(1, int))
        kj = int(np.abs(span.u - wj).argmin())
        one = an.solve(
            np.array([wj]), start=span.start, near=(span, kj), per_unit_driver=True, limits=False
        )
        self._last_unit = (key, one)
        return core._take(one, np.zeros(1, int))

    def _reaching(self, u: float):
        """``(analysis, sweep)``: a sweep from the start whose branches hold at the driver
        value ``u``, and the analysis that solved it. The reference turn, where the
        linkage repeats each turn; otherwise (a kite four-bar changes branch each turn)
        a sweep over as many whole turns as the motion has gone from the start, ahead of
        it or behind it (the latter by the analysis with the driver reversed, as
        :func:`mechsolve.core.evaluate.states` reaches positions behind the start), extended as
        the motion goes on."""
        if self.full_turn or self.an.linear:
            return self.an, self.ref
        d = self.mech.driver.direction
        travel = d * (u - self.u0)
        key = "_ahead" if travel >= 0 else "_behind"
        known = getattr(self, key, None)
        if known is None and travel >= 0:
            known = self.an, self.ref
        if known is not None and abs(travel) <= abs(known[1].u[-1] - self.u0) + 1e-12:
            return known
        turns = math.ceil(abs(travel) / (2 * math.pi)) + 1
        grid = np.radians(np.arange(0.0, 360.0 * turns + 0.5, 1.0))
        an = self.an if travel >= 0 else self.an.reversed()
        sense = d if travel >= 0 else -d
        span = an.solve_sweep(self.u0 + sense * grid, per_unit_driver=True)
        setattr(self, key, (an, span))
        return an, span

    def tabulate(self, rtol: float = 1e-11) -> bool:
        """Tabulate the equation of motion over one turn, where it allows: a crank that
        turns fully. Then ``E0(phi, omega) = a(phi) + b(phi) omega + c(phi) omega^2``
        exactly (gravity and springs in a; dampers and drag in b; the kinetic term
        1/2 J' omega^2 in c), and J, a, b, c are periodic functions of the angle.

        They are sampled by the force analysis at the reference sweep's 360 angles (its
        own states, rescaled), then on grids that double until, for every column, the
        trigonometric interpolant of every other sample predicts the samples between to
        ``rtol`` of the column's size (:func:`_spectral_samples`); a linkage's J is
        analytic in the angle, so a few hundred samples usually give it to rounding. The
        integrator then reads a cubic Hermite table whose values and slopes come from
        that interpolant, on a grid fine enough for its own error bound to stay within
        the same tolerance (:meth:`_Table.trigonometric`). Where the samples do not
        converge by 5760 angles (a sharp peak of J next to a toggle position), periodic
        cubic splines through them are used if they are good to ``1000 rtol``
        (:meth:`_Table.spline`); otherwise nothing is tabulated and the equation is
        solved at every stage.

        A load that switches on and off (``when:``) adds its own ``a_k + b_k omega +
        c_k omega^2`` (tabulated with the load always on, so smooth) times where it acts.
        Where it acts is a set of angle intervals, one set for each sense of motion,
        whose ends are located exactly (bisection of the condition to rounding), so the
        jump is where the load switches, not smeared over a grid cell. This holds when the
        condition depends on the angle and the sense of motion only (a stroke fraction,
        the sign of a velocity); a condition that reads the size of a speed or an
        acceleration is solved at every integrator stage instead. Returns whether it
        tabulated."""
        if not self.full_turn or self.friction:
            return False
        conditional = [ld for ld in self.mech.loads if ld.when is not None]
        d = self.mech.driver.direction
        masks = self._condition_intervals(np.arange(0.0, 2 * math.pi, SWITCH_GRID), conditional)
        if masks is None:
            return False
        sample = _EffortSampler(self, conditional)
        try:
            table, converged = _spectral_samples(sample, sample(None), rtol)
        except _NoTable:
            return False
        n = table.shape[1]
        x = 2 * math.pi * np.arange(n) / n
        _check_inertia(self, table[0], self.u0 + d * x)
        # the table's error bound within 1.5 rtol of each column (the bound is about
        # twice the error met: seed 004's J to 3e-12), so that its grid stays small
        tab = _Table.trigonometric(_harmonics(table), 3 * rtol) if converged else None
        if tab is None:
            tab = _Table.spline(table, rtol)
        if tab is None:
            return False  # J too sharp for a table: solved at every stage
        self._table = tab
        # J is a sum of squares: where it vanishes (between grid points) it touches zero,
        # so its minima are looked for on the curve, not only at the grid (needless
        # where J stays far from zero at every grid point: a piece between two cannot
        # dip by more than the table's error)
        Jg = tab.c[3, :, 0]
        if np.min(Jg) <= 1e-3 * np.max(np.abs(Jg)):
            xm = tab.minima(0)
            _check_inertia(self, tab.evaluate(xm)[0], self.u0 + d * xm, rel=1e-8)
        self._masks = masks
        return True

    def _loads_forced(self, conditional, on):
        """A context in which the conditional loads are left out, except ``on`` (if
        given), which acts everywhere."""
        import contextlib

        mech = self.an.mech

        @contextlib.contextmanager
        def forced():
            saved = mech.loads
            keep = [ld for ld in saved if ld.when is None]
            if on is not None:
                keep.append(dataclasses.replace(on, when=None))
            mech.loads = keep
            try:
                yield
            finally:
                mech.loads = saved

        return forced() if conditional else contextlib.nullcontext()

    def _condition_intervals(self, x: np.ndarray, conditional) -> dict | None:
        """Where each conditional load acts, for each sense of motion ``s`` (+1: the
        driver coordinate increasing): ``{(name, s): (on_at_0, switch_angles)}`` with the
        angles measured from the start along the driver's direction, in [0, 2 pi). None
        when a condition depends on more than the angle and the sense of motion."""
        from mechsolve.core.loads import stroke_function
        from mechsolve.core.solution import StateView

        if not conditional:
            return {}
        d = self.mech.driver.direction
        n = len(x)

        def acts(xx, speed, acc):
            sol = core.states(self.an, self.u0 + d * xx, speed, acc, within=self.ref)
            view = StateView(self.an, sol.state)
            # stroke(q) replays the reference sweep's extremes, in the loads' order
            funcs = {"stroke": stroke_function(list(self.extremes), True)}
            out = []
            for ld in conditional:
                with np.errstate(invalid="ignore"):
                    val = ld.when.evaluate(view, funcs)
                out.append(np.broadcast_to(np.asarray(val, bool), (len(xx),)))
            return out

        out = {}
        for s in (1.0, -1.0):
            base = acts(x, s, 0.0)
            faster, accelerating = acts(x, 2 * s, 0.0), acts(x, s, 3.0 * s)
            for k, (ld, m0, m1, m2) in enumerate(zip(conditional, base, faster, accelerating)):
                if not (np.array_equal(m0, m1) and np.array_equal(m0, m2)):
                    return None
                switches = []
                for i in np.flatnonzero(m0 != np.roll(m0, -1)):  # switches in (x_i, x_i+1]
                    lo, hi = float(x[i]), float(x[i + 1]) if i + 1 < n else 2 * math.pi

                    def same(mid, k=k, s=s, was=bool(m0[i])):
                        return bool(acts(np.array([mid]), s, 0.0)[k][0]) == was

                    hi = bisect_edge(same, lo, hi, 60)[1]
                    switches.append(hi)  # the first angle where the load has switched
                out[ld.name, s] = (bool(m0[0]), np.array(sorted(switches)))
        return out

    def _acting(self, x: float, omega: float) -> list[bool]:
        """Whether each conditional load acts at angle ``x`` from the start (along the
        driver's direction) with driver speed ``omega`` (not zero)."""
        s = 1.0 if omega > 0 else -1.0
        out = []
        for (_, sign), (on0, sw) in self._masks.items():
            if sign == s:
                out.append(on0 ^ bool(np.searchsorted(sw, x, side="right") % 2))
        return out

    def switch_angles(self) -> np.ndarray:
        """The angles (from the start along the driver's direction, in [0, 2 pi)) where a
        tabulated conditional load switches, in either sense of motion: where the
        equation of motion jumps (empty without a table or such loads)."""
        if getattr(self, "_table", None) is None or not getattr(self, "_masks", None):
            return np.empty(0)
        return np.unique(np.concatenate([sw for _, sw in self._masks.values()]))

    def terms(self, phi: float, omega: float, t: float = 0.0):
        """``(J, E0)``: the reduced inertia and the effort at zero driver acceleration."""
        self.nfev += 1
        tab = getattr(self, "_table", None)
        if tab is not None and (omega != 0.0 or not self._masks):
            d = self.mech.driver.direction
            x = (d * (phi - self.u0)) % (2 * math.pi)
            v = tab(x)
            w2 = omega * omega
            e0 = v[1] + v[2] * omega + v[3] * w2
            if self._masks:
                acting = self.frozen if self.frozen is not None else self._acting(x, omega)
                for k, on in enumerate(acting):
                    if on:
                        e0 += v[4 + 3 * k] + v[5 + 3 * k] * omega + v[6 + 3 * k] * w2
            return v[0], e0
        if self.friction:  # J from the kinetic energy at unit speed: 2 T(phi, 1)
            sol = self.states([phi, phi, phi], [omega, omega, 1.0], [0.0, 1.0, 0.0])
            sol.t = np.array([t, t, t])
        else:
            sol = self.states([phi, phi], [omega, omega], [0.0, 1.0])
            sol.t = np.array([t, t])
        f = core.forces(self.an, sol, self.extremes)
        e0, e1 = float(f.effort[0]), float(f.effort[1])
        ind = float(sol.indicator.min()) if sol.indicator.size else 1.0
        if self.friction:
            e1 = e0 + 2.0 * float(f.kinetic[2])
            self._friction_law = ((phi, omega, t), f.friction)
            if sol.ok.all() and ind > NEAR_EXACT and bool(f.friction.locked[:2].any()):
                # the force analysis self-locks at zero acceleration: no effort E0 (the
                # equation of motion, the acceleration free, may still balance: accel)
                J = 2.0 * float(f.kinetic[2])
                _check_inertia(self, np.array([J]), np.array([phi]))
                return J, math.nan
        finite = np.isfinite(e0) and np.isfinite(e1)
        if not finite or ind <= NEAR_EXACT:
            beside = self._beside
            if not sol.ok.all() or not (beside or finite):
                raise _LeftRange(phi)
            if beside:
                # next to a singular position on the motion the force analysis loses
                # accuracy (as 1 / distance^2): the limit from both sides a little away
                # (Richardson, O(h^4)), through which J and E0 are smooth
                self._beside = False
                try:
                    h = BESIDE_STEP
                    pts = [self.terms(phi + s, omega, t) for s in (-h, h, -2 * h, 2 * h)]
                finally:
                    self._beside = True
                self.nfev -= 4
                J, E0 = zip(*pts)
                return limit_from_both_sides(*J), limit_from_both_sides(*E0)
        _check_inertia(self, np.array([e1 - e0]), np.array([phi]))
        return e1 - e0, e0

    def accel(self, phi: float, omega: float, t: float, M: float) -> tuple[float, float]:
        """``(eps, J)``: the driver's acceleration under the motor's effort ``M`` and the
        reduced inertia. Ideal joints: ``eps = (M - E0) / J``. With friction the effort is
        not linear in the acceleration (each friction follows its reaction): ``eps`` is
        solved directly from the friction law (:meth:`_balanced`) and checked by the
        full force analysis (the effort balances ``M`` to a relative 1e-10), else
        corrected by the chord ``J``, then the secant, until it balances to 1e-12. Where
        no acceleration balances ``M`` with Coulomb's law (the friction would have to
        stop the motion at once), :class:`_FrictionJam`."""
        J, e0 = self.terms(phi, omega, t)
        eps = (M - e0) / J
        if not self.friction:
            return eps, J
        got = self._friction_law
        if not math.isfinite(e0) and got is not None:  # self-locking at eps = 0
            e0 = float(got[1].ideal_effort[0])  # a start: the effort without friction
            eps = (M - e0) / J
        scale = max(abs(M), abs(e0), abs(J * eps), 1e-300)
        eps, hint = self._balanced(phi, omega, t, M, eps)
        direct = hint is not None
        slope, last = J, None  # dE / d eps: J, then the secant's
        for _ in range(60):
            sol = self.states([phi], [omega], [eps])
            sol.t = np.array([t])
            # the checks start from the direct solution, then from the last one
            f = core.forces(self.an, sol, self.extremes, hint)
            r = M - float(f.effort[0])
            if not math.isfinite(r):
                if not sol.ok.all():
                    raise _LeftRange(phi)
                raise _FrictionJam(phi, omega, t, _slipping(f.friction))
            # the direct solution solved these equations to rounding; the check by the
            # full analysis agrees but for rounding, which a friction that feeds back
            # strongly (a large reaction braking the mechanism) amplifies
            if abs(r) <= (1e-10 if last is None and direct else 1e-12) * scale:
                self.magnitudes = f.friction.law.s[:, 0].copy()
                self._solved = (eps, self.magnitudes)
                return eps, J
            if hint is not None:
                hint = (f.friction.law, f.friction.law.s[:, 0])
            if last is not None and eps != last[0] and r != last[1]:
                slope = (last[1] - r) / (eps - last[0])
            last = (eps, r)
            eps += r / slope
        raise SolverError(
            f"the equation of motion with friction did not converge at "
            f"{self.an.format_u(phi)} (speed {omega:.6g}): the joints' friction feeds back "
            "on the acceleration too strongly"
        )

    def _balanced(self, phi: float, omega: float, t: float, M: float, eps: float):
        """``(eps, hint)``: the acceleration at which the effort with friction balances
        ``M``, solved directly from the friction law of :meth:`terms`' force analysis at
        this position and speed (:func:`~mechsolve.core.friction.balance`), with that
        law and the Coulomb magnitudes found (for the check by the full analysis in
        :meth:`accel`); ``(eps, None)`` where that is not at hand or does not converge."""
        got = self._friction_law
        self._friction_law = None
        if got is None or got[0] != (phi, omega, t) or getattr(got[1], "law", None) is None:
            return eps, None
        law = got[1].law
        if not (np.all(np.isfinite(law.lamv[:2])) and np.all(np.isfinite(law.s[:, :2]))):
            return eps, None
        drv = self.an.system.driver
        row = next(r.start for r in self.an.system.rows if r.constraint is drv)
        got = balance(law, 0, 1, row, M, eps)
        if (got is None or not math.isfinite(got[0])) and self._solved is not None:
            # Newton's method from the last acceleration solved (an integrator's stages
            # lie close together), where the chord's start is far from the solution: a
            # friction that brakes the mechanism, its reaction large, near a standstill
            got = balance(law, 0, 1, row, M, *self._solved)
        if got is None or not math.isfinite(got[0]):
            return eps, None
        return float(got[0]), (law, got[1])

    def states_by_turn(self, phi, omega, eps, t):
        """States at driver angles ``phi`` (any number of turns from the start) with rates
        ``omega``, ``eps`` at times ``t``, for a linkage that repeats each turn: solved at
        the same angle within the reference turn, on its branches
        (``core.states(within=...)``), then each body's angle carried on by the turns
        it makes per turn of the crank (0 for a rocker, one for a body that turns with
        it), so that angles run on continuously as a sweep over many turns gives them."""
        d = self.mech.driver.direction
        travel = d * (np.asarray(phi, float) - self.u0)
        turns = np.floor(travel / (2 * math.pi))
        u = self.u0 + d * (travel - 2 * math.pi * turns)
        sol = core.states(self.an, u, omega, eps, t=t, within=self.ref)
        th = self.ref.state.th
        per_turn = 2 * math.pi * np.round((th[:, -1] - th[:, 0]) / (2 * math.pi))
        sol.state.th += per_turn[:, None] * turns[None, :]
        sol.state.token = State.new_token()
        sol.u = np.asarray(phi, float)
        return sol

    def rates_at(self, idx: np.ndarray, omega: np.ndarray, eps: np.ndarray):
        """The reference sweep's positions ``idx`` (repeats allowed) with the driver's
        speeds ``omega`` and accelerations ``eps``: its states are per unit of the driver
        coordinate, so the rates follow by the chain rule, without solving again."""
        out = core._take(self.ref, idx)
        core.scale_rates(out.state, omega, eps)
        out.ud, out.udd = omega, eps
        return out

    def inertia_curve(self):
        """``(phi, J, J')`` over the reference sweep (one turn of a crank)."""
        ref = self.ref
        n = len(ref.u)
        both = self.rates_at(
            np.r_[np.arange(n), np.arange(n)], np.ones(2 * n), np.r_[np.zeros(n), np.ones(n)]
        )
        f = core.forces(self.an, both, self.extremes)
        J = f.effort[n:] - f.effort[:n]
        dJ = 2.0 * f.kinetic_rate[:n]
        return ref.u, J, dJ


class _EffortSampler:
    """The columns of :meth:`ReducedModel.tabulate`'s table at given angles: J, a, b, c,
    then each conditional load's a_k, b_k, c_k, from the driving effort at four (speed,
    acceleration) columns: J = E(0, 1) - E(0, 0); the speeds 0, 1, -1 at zero
    acceleration fit E0 = a + b w + c w^2."""

    cols = ((0.0, 1.0), (0.0, 0.0), (1.0, 0.0), (-1.0, 0.0))  # (speed, acceleration)

    def __init__(self, model: ReducedModel, conditional: list) -> None:
        self.model = model
        self.conditional = conditional
        self.variants = [None, *conditional]  # the machine without its conditional loads; each
        self.speeds = [c[0] for c in self.cols]
        self.accelerations = [c[1] for c in self.cols]
        self.nref = len(model.ref.u) - 1  # the reference sweep's turn: its own states, rescaled
        self.at_ref = model.rates_at(
            np.tile(np.arange(self.nref), len(self.cols)),
            np.repeat(self.speeds, self.nref),
            np.repeat(self.accelerations, self.nref),
        )
        self.vander = np.vander(np.array(self.speeds[1:]), 3, increasing=True)

    def efforts(self, xx, on, ref=False):
        """The efforts of the columns at the angles ``xx`` with the conditional load
        ``on`` forced on (the others off), and the smallest singularity indicator there."""
        model, ncols = self.model, len(self.cols)
        m = len(xx)
        if ref:
            sol = self.at_ref
        else:
            sol = core.states(
                model.an,
                np.tile(model.u0 + model.mech.driver.direction * xx, ncols),
                np.repeat(self.speeds, m),
                np.repeat(self.accelerations, m),
                within=model.ref,
            )
        with model._loads_forced(self.conditional, on):
            f = core.forces(model.an, sol, model.extremes)
        E = f.effort.reshape(ncols, m)
        ind = (
            sol.indicator.min(axis=0).reshape(ncols, m).min(axis=0)
            if sol.indicator.size
            else np.ones(m)
        )
        return E, ind

    def __call__(self, x):
        """Every variant's efforts at the angles ``x`` (None: the reference sweep's
        angles, 2 pi k / nref): (4 * variants, len(x))."""
        out = []
        ref = x is None
        if ref:
            x = 2 * math.pi * np.arange(self.nref) / self.nref
        for on in self.variants:
            E, ind = self.efforts(x, on, ref)
            # next to a singular position the force analysis loses accuracy (as
            # 1 / distance^2), and at it the effort is not determined
            good = np.all(np.isfinite(E), axis=0) & (ind > NEAR_EXACT)
            if not good.all():
                # singular samples (a bifurcation: the reactions are indeterminate
                # there) are few; J and E0 are smooth through them on the followed
                # motion, so they are taken as its limit from both sides
                bad = np.flatnonzero(~good)
                if len(bad) > max(4, 0.01 * len(x)):
                    raise _NoTable
                E[:, bad] = _limit(
                    lambda xx, on=on: self.efforts(xx, on)[0], x[bad], len(self.cols), BESIDE_STEP
                )
            out.append(E)
        # the table's columns: J, a, b, c, then each conditional load alone and always
        # on, less the machine without it (a_k, b_k, c_k)
        E = out[0]
        table = [E[0] - E[1], *np.linalg.solve(self.vander, E[1:])]
        for Ek in out[1:]:
            table += list(np.linalg.solve(self.vander, Ek[1:] - E[1:]))
        return np.array(table)


def _check_inertia(model: ReducedModel, J: np.ndarray, u: np.ndarray, rel: float = 1e-12) -> None:
    """The reduced moment of inertia must stay positive: where it vanishes (a massless
    crank whose massive links stop at a limit position) the motion is not determined."""
    k = int(np.argmin(J))
    if not J[k] > rel * max(1.0, float(np.max(np.abs(J)))):
        raise InputError(
            f"the machine's reduced moment of inertia is {J[k]:.3g} kg*m^2 at "
            f"{model.an.format_u(model._wrap(float(u[k])))}: its acceleration is not "
            "determined there; give the driven link an inertia (the motor's rotor and the "
            "gears reduced to its shaft), e.g. flywheel: {on: crank, inertia: 1 kg m^2}"
        )


def drive_torque(motor, d: int, omega, t=0.0) -> np.ndarray:
    """The motor's torque on the driver, counter-clockwise positive, at the signed speed
    ``omega``. A motor's law is written along its direction of motion ``d``: its speed
    and torque are positive when it drives the machine the way the driver turns."""
    return d * motor.torque(d * np.asarray(omega, float), t)


class _LeftRange(Exception):
    """The mechanism cannot close at the driver angle ``phi``."""

    def __init__(self, phi: float) -> None:
        self.phi = phi


class _FrictionJam(Exception):
    """The joints' friction jams the mechanism at the driver angle ``phi``, speed
    ``omega``, time ``t``: no acceleration balances the motor's effort with Coulomb's
    law in the joints ``joints`` (their friction would have to stop the motion at once,
    an impulse the equation of motion of a rigid mechanism does not follow)."""

    def __init__(self, phi: float, omega: float, t: float, joints: list[str]) -> None:
        self.phi, self.omega, self.t, self.joints = phi, omega, t, joints


def _slipping(fr) -> list[str]:
    """The names of the joints whose Coulomb friction acts in the force analysis's
    friction result ``fr`` (one position): those with friction that slip there."""
    law = getattr(fr, "law", None)
    if law is None:
        return []
    return [r.constraint.name for j, r in enumerate(law.rows) if law.k[j, 0] > 0]
