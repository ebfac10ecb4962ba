"""Integrating the equation of motion: RK4 and scipy's solve_ivp, and where a run
stops (see :mod:`mechsolve.analyses.dynamics`)."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from mechsolve.analyses.dynamics.constants import MAX_STEPS
from mechsolve.analyses.dynamics.model import (
    ReducedModel,
    _FrictionJam,
    _LeftRange,
    drive_torque,
)
from mechsolve.analyses.dynamics.tables import _rows
from mechsolve.base.errors import InputError
from mechsolve.model import Mechanism
from mechsolve.model.expr.poles import first_pole_along

#: The energy balance's check: a residual T + V - W - (T0 + V0) above this fraction of
#: the largest energy term (T, |V - V0|, |W|) fails it (the summary warns)
ENERGY_TOLERANCE = 1e-2


def energy_check(residual: np.ndarray, scale: float, method: str) -> tuple[str, str]:
    """The summary's energy-balance line from the residual ``T + V - W - (T0 + V0)``
    along the motion (J) and its ``scale`` (J, the largest energy term), and the warning
    where the residual exceeds :data:`ENERGY_TOLERANCE` of the scale ('' else): the
    integration then did not follow the motion (a fixed step through a stiff motion,
    such as joint friction regularised through a standstill, chatters)."""
    res = float(np.nanmax(np.abs(residual))) if np.any(np.isfinite(residual)) else 0.0
    rel = res / scale if scale > 0 else 0.0
    line = (
        f"energy balance: T + V - W changed by at most {res:.3g} J ({rel:.2g} of the "
        f"largest of T, |V - V0|, |W|: {scale:.6g} J)"
    )
    if not rel > ENERGY_TOLERANCE:
        return line, ""
    what = "a smaller step" if method == "rk4" else "a smaller rtol and atol"
    return line, (
        f"the energy balance T + V - W changed by {res:.3g} J, {rel:.2g} of the largest "
        f"energy term ({scale:.6g} J; the check allows {ENERGY_TOLERANCE:g}): the "
        f"integration ({method}) did not follow the motion, and the results fail this "
        f"check; give {what}, or an adaptive or stiff method (method: RK45, Radau or "
        "BDF), which a stiff motion (a joint's friction holding it near a standstill) needs"
    )


class _MotorNotFinite(Exception):
    """The motor's law gives ``value`` (inf or nan) at the speed ``omega`` (along the
    driver's direction) and the time ``t``."""

    def __init__(self, omega: float, t: float, value: float) -> None:
        self.omega, self.t, self.value = omega, t, value


# why an integration cannot go on: the mechanism does not close, the joints' friction
# jams it, the motor's law is not finite, or numbers beyond float range (int(inf) and the
# like: the step is too large)
_STOPS = (_LeftRange, _FrictionJam, _MotorNotFinite, OverflowError, ValueError, ZeroDivisionError)


@dataclass
class _End:
    """How an integration ended: ``reason`` ('' if it ran its whole duration), ``early``
    if before what was asked (not after its revolutions or at a steady state), ``error``
    the input error behind it (a motor law that is not finite), if any."""

    reason: str = ""
    early: bool = False
    error: InputError | None = None


def motor_end(
    mech: Mechanism, lin: bool, omega: float, t: float, value: float, pole: bool = False
) -> _End:
    """The end of a motion whose motor law gives ``value`` (inf, nan) at the speed
    ``omega`` along the driver and the time ``t``, or has a ``pole`` there that the motion
    passed between two steps: the file's input error, naming the motor's key."""
    speed, unit = ("v", "m/s") if lin else ("omega", "rad/s")
    law = mech.motor.describe(lin, units=False) if mech.motor is not None else "the motor's law"
    gives = "grows without bound" if pole else f"gives {value:g}"
    text = (
        f"the motor's law {law} {gives} at {speed} = {omega:.6g} {unit}, "
        f"t = {t:.6g} s: it must give a finite {'force' if lin else 'torque'} at "
        "every speed and time the motion reaches"
    )
    raw = mech.source.data.get("motor") if mech.source is not None else None
    keys = [k for k in ("torque", "force") if isinstance(raw, dict) and k in raw]
    key = keys[0] if keys else ("force" if lin else "torque")
    return _End(text, early=True, error=mech.error(("motor", key), text))


def _stop_for(model: ReducedModel, exc: Exception, step: float | None = None) -> _End:
    """The end of an integration that cannot go on because of ``exc`` (one of
    :data:`_STOPS`); ``step``: the fixed step of RK4."""
    if isinstance(exc, _LeftRange):
        return _End(_left_text(model, exc.phi), early=True)
    if isinstance(exc, _FrictionJam):
        return _End(_jam_text(model, exc), early=True)
    if isinstance(exc, _MotorNotFinite):
        return motor_end(model.mech, model.an.linear, exc.omega, exc.t, exc.value)
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
    # with joint friction: the Coulomb magnitudes of the equation of motion at each row
    # (K, rows; NaN where not solved), which start the rows' force analysis
    magnitudes: np.ndarray | None = None


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
        return model.accel(p, w, t, torque(w, t))[0]

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
    pole = _motor_pole(model, motor, d, ts, Y)
    if pole is not None:
        ts, Y, end = pole
    eps, J, mags = _along(model, motor, d, ts, Y)
    out = Trajectory(ts, Y[:, 0], Y[:, 1], eps, J, end.reason, model.nfev, end.early, end.error)
    out.magnitudes = mags
    return out


def _motor_pole(model: ReducedModel, motor, d: int, ts: np.ndarray, Y: np.ndarray):
    """A motor law with a pole the motion passed between two of its samples (finite at
    every sample: the step jumped through infinity, and the motion after it is not the
    law's): ``(ts, Y, end)`` with the motion kept up to the sample before the pole and the
    law refused as the file's error; None where the law stays finite along the motion."""
    if motor is None or motor.kind != "law" or len(ts) < 2:
        return None
    w = d * Y[:, 1]  # the law is written along the driver's direction
    hit = first_pole_along(motor.expr, {"omega": w, "v": w, "t": ts})
    if hit is None:
        return None
    k, at = hit
    end = motor_end(model.mech, model.an.linear, at["omega"], at["t"], math.inf, pole=True)
    return ts[: k + 1], Y[: k + 1], end


def _along(model: ReducedModel, motor, d: int, ts: np.ndarray, Y: np.ndarray):
    """The driver's acceleration and the reduced inertia at the integrated states (nan
    where the mechanism does not close), and with friction the Coulomb magnitudes there
    (K, rows; else None)."""
    tab = getattr(model, "_table", None)
    phi, omega = Y[:, 0], Y[:, 1]
    if tab is not None and not model._masks:
        x = np.mod(d * (phi - model.u0), 2 * math.pi)
        J, a, b, c = tab.evaluate(x)[:4]
        model.nfev += len(ts)
        return (drive_torque(motor, d, omega, ts) - (a + (b + c * omega) * omega)) / J, J, None
    eps = np.empty(len(ts))
    J = np.empty(len(ts))
    mags = []
    for i, (t, (p, w)) in enumerate(zip(ts, Y)):
        model.magnitudes = None
        try:
            M = float(drive_torque(motor, d, np.array([w]), t)[0])
            eps[i], J[i] = model.accel(p, w, t, M)
        except (_LeftRange, _FrictionJam):
            J[i] = eps[i] = np.nan
        mags.append(model.magnitudes)
    if not model.friction:
        return eps, J, None
    K = next((len(m) for m in mags if m is not None), 0)
    out = np.array([np.full(K, np.nan) if m is None else m for m in mags]).reshape(-1, K).T
    return eps, J, out


def _adaptive(model, sim, accel, y0, turns: _Turns, max_steps: int):
    """scipy's ``solve_ivp`` on a grid of output times, one revolution at a time when
    revolutions are counted (a terminal event at each), and from one switch of a
    conditional load to the next (:func:`_switch_events`), so that the equation it
    integrates is smooth over each run and the result meets its tolerance. Where the
    motion cannot go on, the integrator's step fails (:func:`_guarded`) and the rows
    computed so far, with its last accepted state, are kept."""
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
    switches = model.switch_angles()
    try:
        while True:
            events = []
            if turns.wanted:
                target = turns.next_angle()

                def turn(t, y, target=target):
                    return abs(y[0] - phi0) - target

                turn.terminal = True
                events.append(turn)
            events += _switch_events(model, switches, y)
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
                        events=events or None,
                    )
            except _STOPS as exc:  # at the first evaluations, before any step
                end = _stop_for(model, exc)
                break
            if not accel.counted:
                model.nfev += out.nfev
            start = 1 if t0 == 0 else 0
            ts += list(out.t[start:])
            # (no output time within a short run between two switches: an empty list)
            ys += [tuple(v) for v in np.reshape(out.y, (2, -1)).T[start:]]
            if out.status == 1:
                hit = next(i for i, te in enumerate(out.t_events) if len(te))
                te, ye = float(out.t_events[hit][0]), out.y_events[hit][0]
                if not (turns.wanted and hit == 0):  # a switch: on from there
                    t0, y = te, ye
                    continue
                end.reason = turns.passed(te)
                if not end.reason and te < sim.duration:
                    t0, y = te, ye
                    continue
                if end.reason and te > ts[-1]:
                    ts.append(te)
                    ys.append(tuple(ye))
            elif out.status < 0:
                end = guard.end or _End(f"the integrator {sim.method} failed: {out.message}", True)
                if guard.last is not None and guard.last[0] > ts[-1]:  # last accepted state
                    ts.append(guard.last[0])
                    ys.append(tuple(guard.last[1]))
            break
    finally:
        model.frozen = None
    return ts, ys, end


def _switch_events(model: ReducedModel, switches: np.ndarray, y) -> list:
    """Terminal events for the run from the state ``y`` to the next switch of a
    conditional load (``switches``: :meth:`ReducedModel.switch_angles`) the way the
    driver moves, or to a reversal of its motion (where the loads' intervals change
    with the sense), with the loads that act over that run held fixed in
    ``model.frozen``: the equation is then smooth up to the event and past it, so the
    integrator's steps and its location of the event keep their accuracy. From rest the
    way is not known: the switches on both sides end the run, and the loads are decided
    at each angle."""
    model.frozen = None
    if switches.size == 0:
        return []
    d = model.mech.driver.direction
    two_pi = 2 * math.pi
    x0 = d * (float(y[0]) - model.u0)  # travel from the start
    base = math.floor(x0 / two_pi) * two_pi
    near = np.concatenate([switches + base + k * two_pi for k in (-1.0, 0.0, 1.0)])
    tiny = 1e-10 * max(1.0, abs(x0))  # the switch just reached is behind
    ahead, behind = near[near > x0 + tiny].min(), near[near < x0 - tiny].max()
    sense = d * float(y[1])  # the travel's rate
    drv = model.mech.driver
    if abs(sense) <= 1e-9 * (abs(drv.speed) if drv.speed else 1.0):
        sense = 0.0  # at rest (where a reversal ended the last run): the way is not known

    def at(goal: float):
        def event(t, y):
            return d * (y[0] - model.u0) - goal

        event.terminal = True
        return event

    if sense == 0.0:
        return [at(ahead), at(behind)]
    goal = ahead if sense > 0 else behind
    model.frozen = model._acting(0.5 * (x0 + goal) % two_pi, float(y[1]))

    def reversal(t, y):
        return y[1]

    reversal.terminal = True
    return [at(goal), reversal]


def _guarded(method: str, model: ReducedModel, max_steps: int):
    """scipy's integrator class ``method`` whose step fails, instead of raising, where
    the motion cannot go on (:data:`_STOPS`) or after ``max_steps`` steps, so that
    ``solve_ivp`` returns the output computed so far. The class records why (``end``) and
    the last accepted state (``last``), only when a step fails: scipy's solvers assign
    ``t`` and ``y`` at the end of a successful step only, so that they still hold the
    last accepted state when the step is refused or raises (a copy at every step cost
    ~2 us a step)."""
    import scipy.integrate

    base = getattr(scipy.integrate, method)

    class Guarded(base):
        end: _End | None = None
        last: tuple | None = None
        steps = 0

        def _stop(self, end: _End) -> tuple[bool, str]:
            cls = type(self)
            cls.last = (float(self.t), np.array(self.y, float))
            cls.end = end
            return False, end.reason

        def _step_impl(self):
            cls = type(self)
            if cls.steps >= max_steps:
                return self._stop(
                    _End(
                        f"the integrator took {max_steps} steps, the limit (--max-steps "
                        "raises it; max_steps in Python)",
                        early=True,
                    )
                )
            cls.steps += 1
            try:
                done, message = super()._step_impl()
            except _STOPS as exc:
                return self._stop(_stop_for(model, exc))
            if not done:  # the solver's own failure (a step too small): its state as is
                cls.last = (float(self.t), np.array(self.y, float))
            return done, message

    return Guarded


def _left_text(model: ReducedModel, phi: float) -> str:
    return (
        "the motion left the range where the mechanism closes (the next step reached "
        f"near {model.an.format_u(model._wrap(phi))})"
    )


def _jam_text(model: ReducedModel, exc: _FrictionJam) -> str:
    """Why a motion stopped where the joints' friction jams the mechanism."""
    an = model.an
    speed = f"{exc.omega:.6g} m/s" if an.linear else f"{math.degrees(exc.omega):.6g} °/s"
    joints = ", ".join(exc.joints) or "with friction"
    return (
        f"the joints' friction jams the mechanism at t = {exc.t:.6g} s, "
        f"{an.format_u(model._wrap(exc.phi))} (speed {speed}): with Coulomb's law in the "
        f"joint(s) {joints} no acceleration balances the motor's effort (the friction would "
        "have to stop the motion at once, an impulse the equation of motion of a rigid "
        "mechanism does not follow)"
    )
