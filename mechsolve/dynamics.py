"""Forward dynamics of a one-degree-of-freedom machine driven by a motor
(``mechsolve simulate``).

The equation of motion comes from the force analysis itself. At a state (phi, omega,
epsilon) of the driver, the driver effort that the kinetostatic analysis returns
(:func:`mechsolve.core.forces`: inertia of every body, gravity, springs, dampers,
conditional loads) is, by Lagrange's equation of the reduced system,

    E(phi, omega, epsilon) = J(phi) epsilon + 1/2 J'(phi) omega^2 - Q(phi, omega, t)

which is linear in epsilon: ``J(phi) = E(phi, omega, 1) - E(phi, omega, 0)``. The motor
supplies ``M(omega, t)``, so the driver's acceleration is

    epsilon = (M(omega, t) - E(phi, omega, 0)) / J(phi).

Nothing is reduced by hand: a model that the sweep can analyse can be simulated, with the
same loads. ``J'(phi) = 2 dT/dt`` at omega = 1, epsilon = 0.

The kinematics at a new angle is solved next to a reference sweep over one turn (which
fixes the branches; a crank's configuration repeats every turn), and the integration is
RK4 with a fixed step (Mathcad's ``rkfixed``) or scipy's ``solve_ivp``. Along the computed
motion the states and every joint force follow from :mod:`mechsolve.core`.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import re
from dataclasses import dataclass

import numpy as np

from . import core
from .errors import InputError
from .model import Mechanism
from .numerics import limit_from_both_sides
from .results import Column, Results
from .solution import angle_deg
from .state import State
from .sweep import Analysis

__all__ = ["ReducedModel", "check_size", "simulate", "SimulationResults"]

NEAR_SINGULAR = 1e-6  # sin of a loop's transmission angle below this: solved beside it
# the exact path (every stage solved): within this indicator of a singular position, the
# equation of motion is its limit from points BESIDE_STEP and twice that away
NEAR_EXACT, BESIDE_STEP = 3e-4, 1e-3
SWITCH_GRID = math.radians(0.05)  # where a switching load's switches are looked for first
TABLE_MIN, TABLE_MAX = 360, 61440  # intervals of the integrator's table over a turn
TABLE_FLOOR = 1e-13  # the tables' tolerance for a column, at least this of the largest's
SPLINE_FLOOR = 1e-8  # splines through unconverged samples: good to this of the largest
MAX_STEPS = 200_000  # integrator steps (and output rows) allowed unless asked for more
# memory per value of the results along a motion (its states, forces, CSV and plots): the
# peak resident memory of seed 004 over 11 001 rows of 84 columns is 87-130 bytes a value
BYTES_PER_VALUE = 100
# at rest (stalled): the driver stays this close (rad, or m) to its last position over this
# part of the run at its end
REST_BAND, REST_SPAN = math.radians(0.01), 0.05
REST_BAND_LINEAR = 1e-4  # m: the band for a linear driver


class ReducedModel:
    """The driver's equation of motion of a mechanism: J(phi), E(phi, omega, 0)."""

    def __init__(self, mech: Mechanism, method: str | None = None) -> None:
        self.mech = mech
        self.an = Analysis(mech, method)
        an = self.an
        self.u0 = an.start_value()
        d = mech.driver.direction
        # the reference sweep: a turn of a crank (or the file's sweep), 1 degree apart
        if an.linear:
            u, _ = an.sweep_values(self.u0)
        else:
            u = self.u0 + d * np.radians(np.arange(0.0, 360.0 + 0.5, 1.0))
        self.ref = core.states(an, u, 1.0, 0.0, velocity=True, acceleration=True)
        # a crank that turns fully and whose linkage comes back as it started after a
        # turn (not, say, on its other branch): its motion is periodic in the angle
        self.full_turn = (
            (not an.linear) and bool(self.ref.ok.all()) and _repeats(self.ref.state, an.scale)
        )
        # the extremes that stroke(q) in load conditions means (none without conditions)
        conditions = any(ld.when is not None for ld in mech.loads)
        self.extremes = core.forces(an, self.ref).stroke_extremes if conditions else []
        self.nfev = 0  # evaluations of the equation of motion

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
            an, span = self._reaching(float(wj))
            kj = int(np.abs(span.u - wj).argmin())
            one = an.solve(
                np.array([wj]),
                start=span.start,
                near=(span, kj),
                per_unit_driver=True,
                limits=False,
            )
            parts.append(one)
        sol = core._concat(parts) if len(parts) > 1 else parts[0]
        if len(uniq) < len(w) or len(parts) > 1:
            sol = core._take(sol, inv)
        sol.u = phi
        core.scale_rates(sol.state, np.asarray(omega, float), np.asarray(eps, float))
        sol.ud = np.asarray(omega, float) * np.ones(len(phi))
        sol.udd = np.asarray(eps, float) * np.ones(len(phi))
        return sol

    def _reaching(self, u: float):
        """``(analysis, sweep)``: a sweep from the start whose branches hold at the driver
        value ``u``, and the analysis that solved it. The reference turn, where the
        linkage repeats each turn; otherwise (a kite four-bar changes branch each turn)
        a sweep over as many whole turns as the motion has gone from the start, ahead of
        it or behind it (the latter by the analysis with the driver reversed, as
        :func:`mechsolve.core.states` reaches positions behind the start), extended as
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
        if not self.full_turn:
            return False
        conditional = [ld for ld in self.mech.loads if ld.when is not None]
        d = self.mech.driver.direction
        masks = self._condition_intervals(np.arange(0.0, 2 * math.pi, SWITCH_GRID), conditional)
        if masks is None:
            return False
        # columns: (speed, acceleration). J = E(0, 1) - E(0, 0); the speeds 0, 1, -1 at
        # zero acceleration fit E0 = a + b w + c w^2
        cols = [(0.0, 1.0), (0.0, 0.0), (1.0, 0.0), (-1.0, 0.0)]
        variants = [None, *conditional]  # the machine without its conditional loads; each

        speeds, accelerations = [c[0] for c in cols], [c[1] for c in cols]
        nref = len(self.ref.u) - 1  # the reference sweep's turn: its own states, rescaled
        at_ref = self.rates_at(
            np.tile(np.arange(nref), len(cols)),
            np.repeat(speeds, nref),
            np.repeat(accelerations, nref),
        )

        def efforts(xx, on, ref=False):
            m = len(xx)
            if ref:
                sol = at_ref
            else:
                sol = core.states(
                    self.an,
                    np.tile(self.u0 + d * xx, len(cols)),
                    np.repeat(speeds, m),
                    np.repeat(accelerations, m),
                    within=self.ref,
                )
            with self._loads_forced(conditional, on):
                f = core.forces(self.an, sol, self.extremes)
            E = f.effort.reshape(len(cols), m)
            ind = (
                sol.indicator.min(axis=0).reshape(len(cols), m).min(axis=0)
                if sol.indicator.size
                else np.ones(m)
            )
            return E, ind

        def sample(x):
            """Every variant's efforts at the angles ``x`` (None: the reference sweep's
            angles, 2 pi k / nref): (4 * variants, len(x))."""
            out = []
            ref = x is None
            if ref:
                x = 2 * math.pi * np.arange(nref) / nref
            for on in variants:
                E, ind = efforts(x, on, ref)
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
                        lambda xx, on=on: efforts(xx, on)[0], x[bad], len(cols), BESIDE_STEP
                    )
                out.append(E)
            # the table's columns: J, a, b, c, then each conditional load alone and always
            # on, less the machine without it (a_k, b_k, c_k)
            E = out[0]
            table = [E[0] - E[1], *np.linalg.solve(vander, E[1:])]
            for Ek in out[1:]:
                table += list(np.linalg.solve(vander, Ek[1:] - E[1:]))
            return np.array(table)

        vander = np.vander(np.array(speeds[1:]), 3, increasing=True)
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
        from .solution import StateView
        from .solvers.forces import stroke_function

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
                    for _ in range(60):
                        mid = 0.5 * (lo + hi)
                        if mid in (lo, hi):
                            break
                        now = acts(np.array([mid]), s, 0.0)[k]
                        if bool(now[0]) == bool(m0[i]):
                            lo = mid
                        else:
                            hi = mid
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
                for k, on in enumerate(self._acting(x, omega)):
                    if on:
                        e0 += v[4 + 3 * k] + v[5 + 3 * k] * omega + v[6 + 3 * k] * w2
            return v[0], e0
        sol = self.states([phi, phi], [omega, omega], [0.0, 1.0])
        sol.t = np.array([t, t])
        f = core.forces(self.an, sol, self.extremes)
        e0, e1 = float(f.effort[0]), float(f.effort[1])
        ind = float(sol.indicator.min()) if sol.indicator.size else 1.0
        finite = np.isfinite(e0) and np.isfinite(e1)
        if not finite or ind <= NEAR_EXACT:
            beside = getattr(self, "_beside", True)
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


class _Table:
    """Piecewise cubic functions of the angle over [0, 2 pi) on a uniform grid, evaluated
    at one angle in plain Python (the integrator's inner loop: scipy's general evaluation
    costs more than the rest of a step) or at many with numpy.

    ``c`` has the layout of scipy's ``PPoly.c``: (4, intervals, columns), the highest
    power first, in powers of the distance from the interval's start."""

    def __init__(self, c: np.ndarray, step: float) -> None:
        self.c = np.asarray(c, float)
        self.step = step
        self.intervals, self.columns = self.c.shape[1], self.c.shape[2]
        self._rows: list | None = None

    @property
    def rows(self) -> list[list[float]]:
        """A list per interval of its columns' coefficients (unpacked in one step by the
        integrator), and the first interval's again for an angle that rounds to 2 pi."""
        if self._rows is None:
            self._rows = _rows(self.c)
        return self._rows

    @classmethod
    def hermite(cls, f: np.ndarray, df: np.ndarray) -> _Table:
        """The cubic Hermite table through values ``f`` and slopes ``df`` (columns, m) at
        m uniform angles over a turn."""
        step = 2 * math.pi / f.shape[1]
        f1, df1 = np.roll(f, -1, axis=1), np.roll(df, -1, axis=1)
        slope = (f1 - f) / step
        c = np.empty((4, f.shape[1], f.shape[0]))
        c[0] = ((df + df1 - 2.0 * slope) / step**2).T
        c[1] = ((3.0 * slope - 2.0 * df - df1) / step).T
        c[2], c[3] = df.T, f.T
        return cls(c, step)

    @classmethod
    def trigonometric(cls, spectrum: np.ndarray, rtol: float) -> _Table | None:
        """The cubic Hermite table of trigonometric interpolants (their harmonics
        ``spectrum``, see :func:`_harmonics`): values and slopes exact at the table's
        grid, whose step h keeps each column's Hermite error bound h^4 / 384 max|f^(4)|
        (the fourth derivative bounded by the sum of k^4 times the harmonics' sizes)
        within half its tolerance (:func:`_tolerances`). None if that needs more than
        ``TABLE_MAX`` intervals."""
        k = np.arange(spectrum.shape[1], dtype=float)
        size = 2.0 * np.abs(spectrum).sum(axis=1)  # bounds each column's largest size
        tol = _tolerances(size, rtol)
        d4 = 2.0 * (np.abs(spectrum) @ k**4)
        with np.errstate(divide="ignore"):
            h = float(np.min((192.0 * tol / d4) ** 0.25))
        m = max(math.ceil(2 * math.pi / h), TABLE_MIN) if h > 0 else TABLE_MIN
        m += -m % 24  # a size the FFT factors well
        if m > TABLE_MAX:
            return None
        return cls.hermite(*_on_grid(spectrum, m))

    @classmethod
    def spline(cls, samples: np.ndarray, rtol: float) -> _Table | None:
        """Periodic cubic splines through ``samples`` (columns, n) at n uniform angles,
        where the trigonometric interpolant did not converge; None unless each column
        is good to 1000 times its tolerance or to ``SPLINE_FLOOR`` of the largest
        column (samples next to a singular position carry the force analysis's
        rounding, amplified there: a parallelogram's J' is zero but for about 1e-7).
        Their error is estimated as that of the splines through every other sample at
        the samples between, divided by 16 (the error of a cubic spline falls as h^4)."""
        from scipy.interpolate import CubicSpline

        def through(V):
            n = V.shape[1]
            x = 2 * math.pi * np.arange(n + 1) / n
            return CubicSpline(x, np.c_[V, V[:, :1]].T, bc_type="periodic")

        n = samples.shape[1]
        half = through(samples[:, 0::2])
        between = half(2 * math.pi * (np.arange(0, n, 2) + 1) / n).T
        err = np.max(np.abs(between - samples[:, 1::2]), axis=1) / 16
        size = np.max(np.abs(samples), axis=1)
        if not np.all(err <= np.maximum(1000 * _tolerances(size, rtol), SPLINE_FLOOR * size.max())):
            return None
        return cls(through(samples).c, 2 * math.pi / n)

    def __call__(self, x: float) -> list[float]:
        i = int(x / self.step)
        h = x - i * self.step
        c = self.rows[i]
        return [
            ((c[j] * h + c[j + 1]) * h + c[j + 2]) * h + c[j + 3]
            for j in range(0, 4 * self.columns, 4)
        ]

    def evaluate(self, x) -> np.ndarray:
        """Every column at the angles ``x`` (in [0, 2 pi]): (columns, len(x))."""
        x = np.asarray(x, float)
        i = np.clip((x / self.step).astype(int), 0, self.intervals - 1)
        h = (x - i * self.step)[:, None]
        c = self.c[:, i]  # (4, len(x), columns)
        return (((c[0] * h + c[1]) * h + c[2]) * h + c[3]).T

    def minima(self, col: int) -> np.ndarray:
        """Candidate angles of the smallest value of column ``col``: the grid and the
        zeros of each piece's slope inside its interval."""
        a, b, c = 3 * self.c[0, :, col], 2 * self.c[1, :, col], self.c[2, :, col]
        disc = b * b - 4 * a * c
        with np.errstate(divide="ignore", invalid="ignore"):
            sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
            roots = np.concatenate([(-b + sq) / (2 * a), (-b - sq) / (2 * a), -c / b])
        start = np.tile(np.arange(self.intervals) * self.step, 3)
        inside = np.isfinite(roots) & (roots > 0) & (roots < self.step)
        return np.r_[np.arange(self.intervals) * self.step, start[inside] + roots[inside]]


def _harmonics(samples: np.ndarray) -> np.ndarray:
    """The harmonics F_k (k = 0 .. n/2 - 1) of the trigonometric interpolants of
    ``samples`` (rows, n) at ``x = 2 pi j / n``: f(x) = Re sum_k F_k (2 - [k = 0]) e^(ikx),
    the Nyquist term left out (below the tolerance once the samples converged)."""
    n = samples.shape[1]
    return (np.fft.rfft(samples, axis=1) / n)[:, : (n + 1) // 2]


def _on_grid(spectrum: np.ndarray, m: int, shift: float = 0.0):
    """Values and slopes of the interpolants with harmonics ``spectrum`` at the m
    uniform angles ``2 pi (j + shift) / m``: two arrays (rows, m)."""
    kk = min(spectrum.shape[1], m // 2)
    pad = np.zeros((spectrum.shape[0], m // 2 + 1), complex)
    k = np.arange(kk)
    pad[:, :kk] = spectrum[:, :kk] * (np.exp(2j * math.pi * shift * k / m) if shift else 1.0)
    f = np.fft.irfft(pad, m, axis=1) * m
    pad[:, :kk] *= 1j * k
    return f, np.fft.irfft(pad, m, axis=1) * m


def _rows(c: np.ndarray) -> list[list[float]]:
    """Coefficients ``c`` (4, intervals, columns) as a list per interval of its
    columns' four coefficients, highest power first (unpacked in one step by the
    integrator), and the first interval's again for an angle that rounds to 2 pi."""
    rows = c.transpose(1, 2, 0).reshape(c.shape[1], -1).tolist()
    rows.append(rows[0])
    return rows


class _NoTable(Exception):
    """The equation of motion cannot be tabulated over the angle."""


def _limit(f, x: np.ndarray, rows: int, h: float = 1e-3) -> np.ndarray:
    """The values at singular angles ``x`` of functions smooth through them, from
    ``f`` (rows, len) at ``x -+ h`` and ``x -+ 2 h``: Richardson's extrapolation of the
    two sides' means, O(h^4) (:func:`~mechsolve.numerics.limit_from_both_sides`). Next
    to a singular position the force analysis loses accuracy as 1 / distance^2: at 1e-5
    its accelerations carry errors of 1e-6; at h = 1e-3, about 1e-10."""
    E = f(np.r_[x - h, x + h, x - 2 * h, x + 2 * h])
    if not np.all(np.isfinite(E)):
        raise _NoTable
    return limit_from_both_sides(*E.reshape(rows, 4, len(x)).transpose(1, 0, 2))


def _tolerances(size: np.ndarray, rtol: float) -> np.ndarray:
    """Each row's absolute tolerance from its largest size: ``rtol`` of it, and not below
    ``TABLE_FLOOR`` of the largest row's (a row that is zero but for rounding, such as
    the damping column of a machine without dampers, meets it at once)."""
    return rtol * size + TABLE_FLOOR * float(np.max(size))


def _spectral_samples(sample, V: np.ndarray, rtol: float, nmax: int = 5760):
    """Samples of smooth periodic functions over a turn at uniform grids that double
    until, for every function, the trigonometric interpolant of every other sample
    predicts the samples between them to its tolerance (:func:`_tolerances`).

    ``V`` holds the functions (rows) at ``x = 2 pi k / n`` (n even), and ``sample(x)``
    returns them at other angles. Returns the samples at the last grid and whether they
    converged (then their own interpolant, on twice the grid that met the test, is far
    more accurate still); at ``nmax`` samples they are returned unconverged."""
    while True:
        n = V.shape[1] // 2
        F = np.fft.rfft(V[:, 0::2], axis=1)
        shifted = F * np.exp(1j * np.arange(F.shape[1]) * math.pi / n)
        if n % 2 == 0:
            shifted[:, -1] = 0.0  # the Nyquist term vanishes at the midpoints
        err = np.max(np.abs(np.fft.irfft(shifted, n, axis=1) - V[:, 1::2]), axis=1)
        if not np.all(np.isfinite(err)):
            raise _NoTable
        if np.all(err <= _tolerances(np.max(np.abs(V), axis=1), rtol)):
            return V, True
        if 2 * n >= nmax:
            return V, False
        Vm = sample(2 * math.pi * (np.arange(2 * n) + 0.5) / (2 * n))
        both = np.empty((V.shape[0], 4 * n))
        both[:, 0::2], both[:, 1::2] = V, Vm
        V = both


def _repeats(st, scale: float) -> bool:
    """Whether the first and last positions of a state are the same configuration
    (poses and rates per unit of the driver)."""
    rows = [0, 1, 3, 4, 5, 6, 7]  # x, y, cos, sin, vx, vy, w
    blk = st.block
    return bool(np.allclose(blk[rows, :, 0], blk[rows, :, -1], rtol=0, atol=1e-8 * max(1, scale)))


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


class _MotorNotFinite(Exception):
    """The motor's law gives ``value`` (inf or nan) at the speed ``omega`` (along the
    driver's direction) and the time ``t``."""

    def __init__(self, omega: float, t: float, value: float) -> None:
        self.omega, self.t, self.value = omega, t, value


# why an integration cannot go on: the mechanism does not close, the motor's law is not
# finite, or numbers beyond float range (int(inf) and the like: the step is too large)
_STOPS = (_LeftRange, _MotorNotFinite, OverflowError, ValueError, ZeroDivisionError)


@dataclass
class _End:
    """How an integration ended: ``reason`` ('' if it ran its whole duration), ``early``
    if before what was asked (not after its revolutions or at a steady state), ``error``
    the input error behind it (a motor law that is not finite), if any."""

    reason: str = ""
    early: bool = False
    error: InputError | None = None


def _stop_for(model: ReducedModel, exc: Exception, step: float | None = None) -> _End:
    """The end of an integration that cannot go on because of ``exc`` (one of
    :data:`_STOPS`); ``step``: the fixed step of RK4."""
    if isinstance(exc, _LeftRange):
        return _End(_left_text(model, exc.phi), early=True)
    if isinstance(exc, _MotorNotFinite):
        mech = model.mech
        lin = model.an.linear
        speed, unit = ("v", "m/s") if lin else ("omega", "rad/s")
        law = mech.motor.describe() if mech.motor is not None else "the motor's law"
        text = (
            f"the motor's law {law} gives {exc.value:g} at {speed} = {exc.omega:.6g} {unit}, "
            f"t = {exc.t:.6g} s: it must give a finite {'force' if lin else 'torque'} at "
            "every speed and time the motion reaches"
        )
        raw = mech.source.data.get("motor") if mech.source is not None else None
        keys = [k for k in ("torque", "force") if isinstance(raw, dict) and k in raw]
        key = keys[0] if keys else ("force" if lin else "torque")
        return _End(text, early=True, error=mech.error(("motor", key), text))
    if step is not None:
        return _End(
            f"the step {step:.6g} s is too large for this motion (the driver would turn more "
            "than half a turn in one step, or its speed grows without bound)",
            early=True,
        )
    return _End("the driver's motion left the range of numbers (inf or nan)", early=True)


@dataclass
class Trajectory:
    t: np.ndarray
    phi: np.ndarray
    omega: np.ndarray
    eps: np.ndarray
    J: np.ndarray
    stopped: str = ""  # why the integration ended before its duration ("" if it did not)
    nfev: int = 0
    early: bool = False  # it stopped before what was asked (stopped says why)
    error: InputError | None = None  # the input error that stopped it, if any


def _with_flywheel(mech: Mechanism) -> Mechanism:
    fw = mech.flywheel
    if fw is None:
        return mech
    out = copy.copy(mech)
    out.links = [copy.copy(lk) for lk in mech.links]
    lk = out.link(fw.link)
    lk.inertia = (lk.inertia or 0.0) + fw.inertia
    if not lk.mass:
        # an inertia alone: a balanced disc about the link's frame origin
        lk.com = lk.com if lk.com is not None else (0.0, 0.0)
    return out


class _Turns:
    """The driver's completed revolutions along the integration, and whether to stop:
    after ``revolutions`` turns, or when ``steady`` (the mean speed over the last
    revolution, 2 pi over its time, differs from the one before by at most this
    fraction)."""

    def __init__(self, phi0: float, revolutions: float | None, steady: float | None) -> None:
        self.phi0, self.revolutions, self.steady = phi0, revolutions, steady
        self.times = [0.0]  # when each revolution ended (the start: 0)

    @property
    def wanted(self) -> bool:
        return bool(self.revolutions or self.steady)

    def next_angle(self) -> float:
        """The angle travelled at the end of the next revolution (or of the stop)."""
        k = len(self.times)
        if self.revolutions and self.revolutions < k:
            return 2 * math.pi * self.revolutions
        return 2 * math.pi * k

    def passed(self, t: float) -> str:
        """Record that the angle of :meth:`next_angle` was reached at ``t``; the reason
        to stop, or ''."""
        self.times.append(t)
        n = len(self.times) - 1
        if self.revolutions and n >= self.revolutions:
            return f"after {self.revolutions:g} revolutions"
        if self.steady and n >= 2:
            t0, t1, t2 = self.times[-3:]
            w_last, w_before = 2 * math.pi / (t2 - t1), 2 * math.pi / (t1 - t0)
            if abs(w_last - w_before) <= self.steady * abs(w_last):
                return (
                    f"steady after {n} revolutions (t = {t:.6g} s): the mean speed over a "
                    f"revolution changed by {abs(w_last - w_before) / abs(w_last):.2g} "
                    f"(asked: at most {self.steady:g})"
                )
        return ""


def _crossing(y0, y1, h: float, phi0: float, turns: _Turns) -> float:
    """Where in a step (0..1) the travelled angle reaches ``turns.next_angle()``: the root
    of the cubic Hermite interpolant of the angle through the step's ends (angles and
    speeds), whose error is O(h^4) like the step's own."""
    sign = 1.0 if y1[0] >= phi0 else -1.0
    goal = phi0 + sign * turns.next_angle()
    p0, p1, m0, m1 = y0[0], y1[0], h * y0[1], h * y1[1]
    s = min(max((goal - p0) / (p1 - p0), 0.0), 1.0) if p1 != p0 else 0.5
    for _ in range(30):
        s2, s3 = s * s, s * s * s
        f = (
            (2 * s3 - 3 * s2 + 1) * p0
            + (s3 - 2 * s2 + s) * m0
            + (-2 * s3 + 3 * s2) * p1
            + (s3 - s2) * m1
            - goal
        )
        df = (6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * m0 + (6 * s - 6 * s2) * p1
        df += (3 * s2 - 2 * s) * m1
        if df == 0:
            break
        step = f / df
        s = min(max(s - step, 0.0), 1.0)
        if abs(step) < 1e-15:
            break
    return s


def _acceleration(model: ReducedModel, motor, d: int):
    """The driver's acceleration ``f(t, phi, omega)`` in plain floats. With a table, no
    switching loads and the linear motor law, the table's polynomials are evaluated in
    line (the inner loop of RK4, four times a step); otherwise through
    :meth:`ReducedModel.terms`.

    (A table of the acceleration itself, ``A + B omega + C omega^2`` with A = (M0 - a) / J
    and so on, would save a division and a polynomial, but 1 / J is far less smooth than
    J: on seed 004 it needs four times the intervals for the same error.)"""
    tab = getattr(model, "_table", None)
    if tab is not None and tab.columns == 4 and motor.kind == "linear":
        # epsilon = (M0 d - a - (nu + b) w - c w^2) / J: the motor's constants folded into
        # the constant coefficients of a and b, and J's sign turned, in the rows the loop
        # reads: (a - d M0 + (b + nu + c w) w) / (-J)
        cm = tab.c.copy()
        cm[3, :, 1] -= d * motor.stall
        cm[3, :, 2] += motor.slope
        cm[:, :, 0] *= -1.0
        rows = _rows(cm)
        step, u0, turn = tab.step, model.u0, 2 * math.pi

        def fast(t: float, p: float, w: float) -> float:
            x = (d * (p - u0)) % turn
            i = int(x / step)
            h = x - i * step
            j3, j2, j1, j0, a3, a2, a1, a0, b3, b2, b1, b0, c3, c2, c1, c0 = rows[i]
            a = ((a3 * h + a2) * h + a1) * h + a0
            b = ((b3 * h + b2) * h + b1) * h + b0
            c = ((c3 * h + c2) * h + c1) * h + c0
            return (a + (b + c * w) * w) / (((j3 * h + j2) * h + j1) * h + j0)

        fast.counted = False  # the integrator counts its calls
        return fast

    def torque(w: float, t: float) -> float:
        if motor.kind == "linear":  # the common law, without numpy's overhead
            return d * (motor.stall - motor.slope * d * w)
        with np.errstate(all="ignore"):
            M = float(drive_torque(motor, d, np.array([w]), t)[0])
        if not math.isfinite(M):
            raise _MotorNotFinite(d * w, t, M)
        return M

    def general(t: float, p: float, w: float) -> float:
        J, e0 = model.terms(p, w, t)
        return (torque(w, t) - e0) / J

    general.counted = True  # terms() counts
    return general


def _rk4(model, sim, accel, y0, turns: _Turns, progress):
    """Fixed-step RK4 (Mathcad's ``rkfixed``) in plain floats: the times, the states
    (phi, omega) and how it ended (:class:`_End`)."""
    h = sim.step
    n = max(1, math.ceil(sim.duration / h - 1e-9))
    h2, h6 = h / 2, h / 6
    phi0 = y0[0]
    p, w = y0
    ts, ys = [0.0], [(p, w)]
    wanted = turns.wanted
    end = _End()
    try:
        for i in range(n):
            t = i * h
            a1 = accel(t, p, w)
            w2 = w + h2 * a1
            a2 = accel(t + h2, p + h2 * w, w2)
            w3 = w + h2 * a2
            a3 = accel(t + h2, p + h2 * w2, w3)
            w4 = w + h * a3
            a4 = accel(t + h, p + h * w3, w4)
            p_new = p + h6 * (w + 2 * w2 + 2 * w3 + w4)
            w_new = w + h6 * (a1 + 2 * a2 + 2 * a3 + a4)
            if not (math.isfinite(p_new) and math.isfinite(w_new) and abs(p_new - p) < math.pi):
                raise OverflowError
            p, w = p_new, w_new
            ts.append(t + h)
            ys.append((p, w))
            if progress is not None and (i + 1) % 50 == 0:
                progress(50)
            while wanted and abs(p - phi0) >= turns.next_angle() and not end.reason:
                end.reason = turns.passed(t + h * _crossing(ys[-2], ys[-1], h, phi0, turns))
            if end.reason:
                break
    except _STOPS as exc:
        end = _stop_for(model, exc, h)
    if not accel.counted:
        model.nfev += 4 * (len(ts) - 1)
    return ts, ys, end


def integrate(
    model: ReducedModel, sim, motor, progress=None, max_steps: int | None = None
) -> Trajectory:
    """Integrate phi'' = (M(omega, t) - E0(phi, omega)) / J(phi) from the start;
    ``progress(k)`` is called as k more steps are done (RK4). An adaptive integrator
    stops after ``max_steps`` steps of its own (default :data:`MAX_STEPS`). Where the
    motion cannot go on (the mechanism cannot close, the motor's law is not finite, the
    step is too large), the motion up to there is returned, with the reason."""
    d = model.mech.driver.direction
    phi0 = model.u0
    w0 = d * abs(sim.speed0) if sim.speed0 else 0.0
    accel = _acceleration(model, motor, d)
    turns = _Turns(phi0, sim.revolutions, sim.steady)
    if sim.method == "rk4":
        ts, ys, end = _rk4(model, sim, accel, (phi0, w0), turns, progress)
    else:
        limit = MAX_STEPS if max_steps is None else max_steps
        ts, ys, end = _adaptive(model, sim, accel, (phi0, w0), turns, limit)
    ts = np.array(ts)
    Y = np.array(ys, float).reshape(-1, 2)
    eps, J = _along(model, motor, d, ts, Y)
    return Trajectory(ts, Y[:, 0], Y[:, 1], eps, J, end.reason, model.nfev, end.early, end.error)


def _along(model: ReducedModel, motor, d: int, ts: np.ndarray, Y: np.ndarray):
    """The driver's acceleration and the reduced inertia at the integrated states (nan
    where the mechanism does not close)."""
    tab = getattr(model, "_table", None)
    phi, omega = Y[:, 0], Y[:, 1]
    if tab is not None and not model._masks:
        x = np.mod(d * (phi - model.u0), 2 * math.pi)
        J, a, b, c = tab.evaluate(x)[:4]
        model.nfev += len(ts)
        return (drive_torque(motor, d, omega, ts) - (a + (b + c * omega) * omega)) / J, J
    eps = np.empty(len(ts))
    J = np.empty(len(ts))
    for i, (t, (p, w)) in enumerate(zip(ts, Y)):
        try:
            Ji, e0 = model.terms(p, w, t)
            J[i] = Ji
            eps[i] = (float(drive_torque(motor, d, np.array([w]), t)[0]) - e0) / Ji
        except _LeftRange:
            J[i] = eps[i] = np.nan
    return eps, J


def _adaptive(model, sim, accel, y0, turns: _Turns, max_steps: int):
    """scipy's ``solve_ivp`` on a grid of output times, one revolution at a time when
    revolutions are counted (a terminal event at each). Where the motion cannot go on,
    the integrator's step fails (:func:`_guarded`) and the rows computed so far, with its
    last accepted state, are kept."""
    from scipy.integrate import solve_ivp

    phi0 = y0[0]

    def rhs(t, y):
        return np.array([y[1], accel(t, y[0], y[1])])

    step = sim.step or sim.duration / 500
    grid = np.minimum(np.arange(0, math.ceil(sim.duration / step - 1e-9) + 1) * step, sim.duration)
    ts, ys = [0.0], [tuple(y0)]
    t0, y = 0.0, np.array(y0, float)
    end = _End()
    guard = _guarded(sim.method, model, max_steps)
    while True:
        events = None
        if turns.wanted:
            target = turns.next_angle()

            def turn(t, y, target=target):
                return abs(y[0] - phi0) - target

            turn.terminal = True
            events = [turn]
        try:
            with np.errstate(all="ignore"):
                out = solve_ivp(
                    rhs,
                    (t0, sim.duration),
                    y,
                    method=guard,
                    t_eval=grid[grid > t0] if t0 > 0 else grid,
                    rtol=sim.rtol,
                    atol=sim.atol,
                    events=events,
                )
        except _STOPS as exc:  # at the first evaluations, before any step
            end = _stop_for(model, exc)
            break
        if not accel.counted:
            model.nfev += out.nfev
        start = 1 if t0 == 0 else 0
        ts += list(out.t[start:])
        ys += [tuple(v) for v in out.y.T[start:]]
        if out.status == 1:
            te, ye = float(out.t_events[0][0]), out.y_events[0][0]
            end.reason = turns.passed(te)
            if not end.reason and te < sim.duration:
                t0, y = te, ye
                continue
            if end.reason and te > ts[-1]:
                ts.append(te)
                ys.append(tuple(ye))
        elif out.status < 0:
            end = guard.end or _End(f"the integrator {sim.method} failed: {out.message}", True)
            if guard.last is not None and guard.last[0] > ts[-1]:  # its last accepted state
                ts.append(guard.last[0])
                ys.append(tuple(guard.last[1]))
        break
    return ts, ys, end


def _guarded(method: str, model: ReducedModel, max_steps: int):
    """scipy's integrator class ``method`` whose step fails, instead of raising, where
    the motion cannot go on (:data:`_STOPS`) or after ``max_steps`` steps, so that
    ``solve_ivp`` returns the output computed so far. The class records why (``end``) and
    the last accepted state (``last``)."""
    import scipy.integrate

    base = getattr(scipy.integrate, method)

    class Guarded(base):
        end: _End | None = None
        last: tuple | None = None
        steps = 0

        def _step_impl(self):
            cls = type(self)
            cls.last = (float(self.t), np.array(self.y, float))
            if cls.steps >= max_steps:
                cls.end = _End(
                    f"the integrator took {max_steps} steps, the limit (--max-steps raises "
                    "it; max_steps in Python)",
                    early=True,
                )
                return False, cls.end.reason
            cls.steps += 1
            try:
                return super()._step_impl()
            except _STOPS as exc:
                cls.end = _stop_for(model, exc)
                return False, cls.end.reason

    return Guarded


def _left_text(model: ReducedModel, phi: float) -> str:
    return (
        "the motion left the range where the mechanism closes (the next step reached "
        f"near {model.an.format_u(model._wrap(phi))})"
    )


class SimulationResults(Results):
    """Results along a simulated motion: the sweep's columns, with the driver's speed,
    acceleration, reduced inertia and the motor's torque and power first."""

    def __init__(self, an, sol, forces, traj: Trajectory, motor) -> None:
        super().__init__(an, sol, forces)
        self.trajectory = traj
        self.motor = motor

    def motor_torque(self) -> np.ndarray:
        """The motor's torque on the driver (counter-clockwise positive, as the driving
        torque of the force analysis)."""
        d = self.mechanism.driver.direction
        return drive_torque(self.motor, d, self.trajectory.omega, self.trajectory.t)

    def columns(self) -> list[Column]:
        tr = self.trajectory
        lin = self.linear
        cols = super().columns()
        extra = [
            Column("omega" if not lin else "v", "m/s" if lin else "rad/s", tr.omega),
            Column("epsilon" if not lin else "a", "m/s^2" if lin else "rad/s^2", tr.eps),
            Column("J", "kg" if lin else "kg*m^2", tr.J),
            Column(
                "motor.torque" if not lin else "motor.force",
                "N" if lin else "N*m",
                self.motor_torque(),
            ),
            Column("motor.power", "W", self.motor_torque() * tr.omega),
            Column("energy.residual", "J", self.energy_residual()),
        ]
        return cols[:3] + extra + cols[3:]

    def energy_residual(self) -> np.ndarray:
        """The energy balance along the motion: the work of the motor and the loads since
        the start (the trapezoid rule over the time steps) minus the change of kinetic and
        potential energy (J). It measures the integration: zero to the step's accuracy."""
        f = self.forces
        if f is None:
            return np.full(len(self.t), np.nan)
        P = self.motor_torque() * self.trajectory.omega + f.power_loads
        t = self.trajectory.t
        work = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))])
        E = f.kinetic + f.potential
        return work - (E - E[0])

    def summary(self) -> str:
        tr = self.trajectory
        lines = [super().summary()]
        lin = self.linear
        wu, au = ("m/s", "m/s^2") if lin else ("rad/s", "rad/s^2")
        sim = self.mechanism.simulation
        how = (
            f"rk4, {len(tr.t) - 1} steps of {sim.step:.6g} s"
            if sim.method == "rk4"
            else f"{sim.method}, {len(tr.t)} output rows"
        )
        lines.append(f"  simulation: {how} to t = {tr.t[-1]:.6g} s; motor {self._motor_text()}")
        parts = []
        if np.any(np.isfinite(tr.omega)):
            k = int(np.nanargmax(np.abs(tr.omega)))  # the fastest, either way
            parts.append(
                f"fastest |{'v' if lin else 'omega'}| = {abs(tr.omega[k]):.6g} {wu} at "
                f"t = {tr.t[k]:.6g} s" + (f", {self._sense(tr.omega[k])}" if tr.omega[k] else "")
            )
        if np.any(np.isfinite(tr.eps)):
            parts.append(
                f"{'a' if lin else 'epsilon'} from {np.nanmin(tr.eps):.8g} to "
                f"{np.nanmax(tr.eps):.8g} {au}"
            )
        if np.any(np.isfinite(tr.J)):
            what, unit = ("reduced mass", "kg") if lin else ("reduced inertia J", "kg*m^2")
            parts.append(f"{what} from {np.nanmin(tr.J):.6g} to {np.nanmax(tr.J):.6g} {unit}")
        if parts:
            lines.append("  " + "; ".join(parts))
        M = self.motor_torque()
        kind, unit = self.effort_name
        if f"  driving {kind} (" not in lines[0]:  # else that line gives the same
            lines.append(
                f"  motor {kind}: from {np.nanmin(M):.6g} to {np.nanmax(M):.6g} {unit}, "
                f"time mean {self.time_mean(M):.6g} {unit}"
            )
        rest = self.stall()
        # a machine come to rest has no cycle to speak of
        dl = steady_fluctuation(tr) if not (lin or rest.startswith("stalled")) else None
        if dl is not None:
            mean, delta = dl
            lines.append(
                f"  last full revolution: time mean of |omega| {mean:.6g} rad/s, coefficient "
                f"of fluctuation delta = (max - min) / mean = {delta:.4g}"
            )
        if rest:
            lines.append("  " + rest)
        if tr.early:
            lines.append(
                f"  stopped early at t = {tr.t[-1]:.6g} s: {tr.stopped}; the motion up to "
                "there is kept"
            )
        elif tr.stopped:
            lines.append(f"  ended {tr.stopped}")
        return "\n".join(lines)

    def _motor_text(self) -> str:
        """The motor's law with its units (``M = 50 N*m - 1.25 N*m*s * omega``)."""
        m = self.motor
        if m.kind != "linear":
            return m.describe()
        if self.linear:
            return f"F = {m.stall:.6g} N - {m.slope:.6g} N*s/m * v"
        return f"M = {m.stall:.6g} N*m - {m.slope:.6g} N*m*s * omega"

    def _sense(self, omega: float) -> str:
        """The sense of a signed driver speed in words, against the driver's direction."""
        d = self.mechanism.driver.direction
        with_driver = omega * d > 0
        if self.linear:
            return (
                "along the driver's direction"
                if with_driver
                else ("against the driver's direction (backwards)")
            )
        turn = "counter-clockwise" if omega > 0 else "clockwise"
        return (
            f"{turn} (the driver's direction)"
            if with_driver
            else (f"{turn}: backwards, against the driver's direction")
        )

    def time_mean(self, y: np.ndarray) -> float:
        """The mean of ``y`` over the time of the motion (trapezoid rule over the rows):
        the mean that the summary and the plots give."""
        t = self.trajectory.t
        ok = np.isfinite(y)
        if ok.sum() < 2 or t[ok][-1] <= t[ok][0]:
            return float(np.nanmean(y)) if ok.any() else math.nan
        return float(np.trapezoid(y[ok], t[ok]) / (t[ok][-1] - t[ok][0]))

    def mean_effort(self) -> tuple[float, str]:
        """The driver's mean effort over the time of the motion (the summary's and the
        plot's), said so."""
        e = np.where(self.forces.ok, self.forces.effort, np.nan)
        return self.time_mean(e), "time mean"

    def sample_spacing(self) -> str:
        return f"{len(self.t)} time"  # "driving torque (1101 time samples)"

    def force_summary(self, figures: Results | None = None) -> list[str]:
        lines = super().force_summary(figures)
        e = np.where(self.forces.ok, self.forces.effort, np.nan)
        if lines and lines[0].startswith("  driving ") and np.any(np.isfinite(e)):
            # the RMS over time too (the rows of an adaptive method are not evenly spaced)
            rms = math.sqrt(self.time_mean(e * e))
            kind, unit = self.effort_name
            scale, sym = (1e3, "k") if np.nanmax(np.abs(e)) >= 1e4 else (1.0, "")  # as super's
            lines[0] = re.sub(
                r", RMS [^,]*, time mean",
                f", RMS over time {rms / scale:.6g} {sym}{unit}, time mean",
                lines[0],
            )
        return lines

    def describe_u(self, i: int) -> str:
        """Where along the motion row ``i`` is: its time, and the driver's angle with the
        turns made from the start (``t = 1.682 s (driver angle 113.5°, 11 turns + 113.5°
        from the start)``)."""
        t = float(self.trajectory.t[i])
        u = float(self.u[i])
        if self.linear:
            return f"t = {t:.6g} s ({self.analysis.format_u(u)})"
        d = self.mechanism.driver.direction
        travel = math.degrees(d * (u - float(self.u[0])))
        turns, part = divmod(abs(travel), 360.0)
        back = " backwards" if travel < 0 else ""
        where = f"driver angle {angle_deg(u):.6g}°"
        plain = float(self.u[0]) == 0 and d > 0 and not back  # the angle is the turn's part
        n = f"{int(turns)} turn{'s' if turns > 1 else ''}"
        if turns and plain:
            where += f" after {n}"
        elif turns:
            where += f", {n} + {part:.6g}°{back} from the start"
        elif travel and not plain:
            where += f", {abs(travel):.6g}°{back} from the start"
        return f"t = {t:.6g} s ({where})"

    def stall(self) -> str:
        """``stalled at …`` when the machine comes to rest and stays (a motor too weak to
        start it, or one that stops it): the driver stays within :data:`REST_BAND` (a linear
        driver: :data:`REST_BAND_LINEAR`) of its last position for the last
        :data:`REST_SPAN` of the run (at least 10 rows). The position given is where the
        motor's effort at standstill balances the static load (``M(0, t) = E0(phi, 0)``,
        solved next to the last position), if found there; else the last position.
        ``does not turn …`` for a crank that swings to and fro without completing a
        revolution. '' otherwise."""
        tr = self.trajectory
        n = len(tr.t)
        if n < 12 or tr.early:
            return ""
        phi, t = tr.phi, tr.t
        band = REST_BAND_LINEAR if self.linear else REST_BAND
        off = np.abs(phi - phi[-1]) > band
        k = int(np.flatnonzero(off)[-1]) + 1 if off.any() else 0
        if n - k >= 10 and t[-1] - t[k] >= REST_SPAN * t[-1]:
            u, balance = self._balance(float(phi[-1]), float(t[-1]), band)
            where = self.describe_u(n - 1).split("(", 1)[1].rstrip(")")
            if u is not None:
                where = self._with_u(u)
            kind, unit = self.effort_name
            within = f"{band * 1e3:g} mm" if self.linear else f"{math.degrees(band):.2g}°"
            text = f"stalled at {where} after t = {t[k]:.6g} s (at rest from then on, to {within})"
            if balance is not None:
                text += (
                    f": the motor's {kind} at standstill, {balance:.6g} {unit}, balances the "
                    "static load there"
                )
            return text
        if not self.linear and np.max(np.abs(phi - phi[0])) < 2 * math.pi:
            moving = tr.omega[np.abs(tr.omega) > 0]
            if moving.size and np.any(np.sign(moving[1:]) != np.sign(moving[:-1])):
                lo, hi = np.argmin(phi), np.argmax(phi)
                return (
                    f"does not turn: no full revolution in {t[-1]:.6g} s; the driver swings "
                    f"between {self._with_u(float(phi[lo]))} and {self._with_u(float(phi[hi]))}"
                )
        return ""

    def _with_u(self, u: float) -> str:
        """A driver position in words, with the travel from the start."""
        if self.linear:
            return self.analysis.format_u(u)
        d = self.mechanism.driver.direction
        travel = math.degrees(d * (u - float(self.u[0])))
        back = " backwards" if travel < 0 else ""
        if not travel:
            return f"driver angle {angle_deg(u):.6g}° (the start)"
        return f"driver angle {angle_deg(u):.6g}° ({abs(travel):.6g}°{back} from the start)"

    def _balance(self, u: float, t: float, band: float):
        """``(u*, M)``: the driver position next to ``u`` where the motor's effort at
        standstill ``M = M(0, t)`` balances the static load ``E0(u*, 0)`` (secant
        iterations on the equation of motion; None if they leave ``band`` of ``u`` or
        fail), and ``M``."""
        model = getattr(self, "model", None)
        d = self.mechanism.driver.direction
        M = float(drive_torque(self.motor, d, np.array([0.0]), t)[0])
        if model is None or not math.isfinite(M):
            return None, (M if math.isfinite(M) else None)

        def g(x: float) -> float:
            return M - model.terms(x, 0.0, t)[1]

        try:
            x0, x1 = u + 1e-3 * band, u
            g0, g1 = g(x0), g(x1)
            for _ in range(50 if abs(g1) > 1e-9 * max(1.0, abs(M)) else 0):
                if g1 == g0:
                    break
                x0, x1, g0 = x1, x1 - g1 * (x1 - x0) / (g1 - g0), g1
                g1 = g(x1)
                if abs(x1 - x0) <= 1e-13 * max(1.0, abs(x1)):
                    break
        except _STOPS:
            return None, M
        if not (math.isfinite(x1) and abs(x1 - u) <= band and abs(g1) <= 1e-9 * max(1.0, abs(M))):
            return None, M
        return x1, M

    def incomplete(self) -> bool:
        """Also when the motion stopped before what was asked (see :class:`Trajectory`)."""
        return super().incomplete() or self.trajectory.early


def steady_fluctuation(tr: Trajectory):
    """(mean speed, delta = (max - min) / mean) over the last full revolution, or None."""
    if len(tr.phi) < 3:
        return None
    turn = 2 * math.pi
    end = tr.phi[-1]
    k = np.flatnonzero(np.abs(tr.phi - end) >= turn)
    if not k.size:
        return None
    w = np.abs(tr.omega[k[-1] :])  # speeds along the motion (a clockwise crank too)
    t = tr.t[k[-1] :]
    mean = float(np.trapezoid(w, t) / (t[-1] - t[0])) if t[-1] > t[0] else float(np.mean(w))
    return mean, float((np.max(w) - np.min(w)) / mean)


def check_size(mech: Mechanism, max_steps: int | None = None) -> None:
    """Refuse, before any work, a simulation of more than ``max_steps`` steps (output rows
    for an adaptive integrator; default :data:`MAX_STEPS`) or whose results would not fit
    in the memory available: an input error at the ``simulate`` section's step (or
    duration) with the numbers.

    The memory is estimated as rows times the columns of the results (from the numbers
    of points, links and joints) times :data:`BYTES_PER_VALUE`."""
    sim = mech.simulation
    if sim is None:
        return
    limit = MAX_STEPS if max_steps is None else max_steps
    step = sim.step or sim.duration / 500
    ratio = sim.duration / step  # inf for a step of 1e-300 s over 1e10 s
    steps = math.ceil(ratio - 1e-9) if math.isfinite(ratio) else math.inf
    rows = steps + 1
    memory = rows * _columns_estimate(mech) * BYTES_PER_VALUE
    available = _available_memory()
    over_memory = available is not None and memory > available
    if steps <= limit and not over_memory:
        return
    what = "steps" if sim.method == "rk4" else f"output times ({sim.method}'s output step)"
    whole = (
        " (the limit counts the whole duration; 'revolutions' or 'steady' may end it sooner)"
        if sim.revolutions or sim.steady
        else ""
    )
    limits = f"the limit is {limit} steps" if steps > limit else ""
    if over_memory:
        limits += (" and " if limits else "") + (
            f"this machine has {_bytes_text(available)} of memory available"
        )
    raise mech.error(
        ("simulate", "step") if sim.step else ("simulate", "duration"),
        f"a duration of {sim.duration:g} s in steps of {step:g} s is {steps:.6g} {what}, "
        f"about {_bytes_text(memory)} of results ({rows:.6g} rows of about "
        f"{_columns_estimate(mech)} values){whole}; {limits}: give a longer step or a "
        "shorter duration" + (", or raise the limit with --max-steps N" if steps > limit else ""),
    )


def _columns_estimate(mech: Mechanism) -> int:
    """About how many columns the results of a motion have: the driver's and the
    motor's, six a moving point (position, velocity, acceleration), three a link, three a
    pin's reaction and seven a slider's (reaction and travel), the energies and powers."""
    ground = set(mech.ground)
    points = {p for lk in mech.links for p in lk.points} - ground
    sliders = sum(1 for j in mech.joints if type(j).__name__ == "SliderJoint")
    return 20 + 6 * len(points) + 3 * len(mech.links) + 3 * len(mech.joints) + 4 * sliders


def _available_memory() -> int | None:
    """The memory available to a new process (bytes; Linux's MemAvailable), or None."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _bytes_text(n: float) -> str:
    """``12.3 GB``: a number of bytes in decimal units."""
    for unit, size in (("EB", 1e18), ("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


def simulate(
    mech: Mechanism,
    *,
    method: str | None = None,
    exact: bool = False,
    progress=None,
    max_steps: int | None = None,
) -> SimulationResults:
    """Simulate the motor-driven machine of ``mech`` (its ``motor:`` and ``simulate:``
    sections) and solve the states and joint forces along the motion. ``exact``: solve
    the equation of motion at every integrator stage instead of from its tabulation over
    a turn (see :meth:`ReducedModel.tabulate`; always so where it cannot tabulate: a
    crank that does not turn fully or whose linkage does not come back after a turn, a
    condition that reads the size of a speed, a J too sharp for a table).

    Where the motion cannot go on (the mechanism does not close, the step is too large,
    the motor's law is not finite), the results hold the motion up to there and
    ``trajectory.stopped`` says why (``trajectory.early``); a motor law that is not finite
    is an input error (``trajectory.error``), raised at once if it stops the motion at its
    start.

    ``max_steps``: refuse more steps than this (see :func:`check_size`; an adaptive
    integrator also stops after that many steps of its own)."""
    if mech.motor is None:
        raise mech.error(
            ("motor",), "a simulation needs a 'motor' section (the driver's torque law)"
        )
    if mech.simulation is None:
        raise mech.error(("simulate",), "a simulation needs a 'simulate' section (duration, step)")
    check_size(mech, max_steps)
    machine = _with_flywheel(mech)
    if machine.driver.motion is not None:
        machine = copy.copy(machine)
        machine.driver = dataclasses.replace(machine.driver, motion=None)
    model = ReducedModel(machine, method)
    if not model.ref.ok[0]:
        raise mech.error(("driver", "start"), "the mechanism cannot close at the driver's start")
    if not exact:
        model.tabulate()
    traj = integrate(model, mech.simulation, mech.motor, progress, max_steps)
    if traj.error is not None and len(traj.t) < 2:
        raise traj.error  # the file's motor law at the start: nothing to keep
    good = np.isfinite(traj.J)
    an = model.an
    phi = traj.phi[good]
    if model.full_turn:  # the linkage repeats each turn: solved on the reference turn
        sol = model.states_by_turn(phi, traj.omega[good], traj.eps[good], traj.t[good])
    else:
        sol = core.states(an, phi, traj.omega[good], traj.eps[good], t=traj.t[good])
    if not good.all():
        traj = dataclasses.replace(
            traj, **{f: getattr(traj, f)[good] for f in ("t", "phi", "omega", "eps", "J")}
        )
    forces = core.forces(an, sol, model.extremes)
    res = SimulationResults(an, sol, forces, traj, mech.motor)
    res.model = model
    return res
