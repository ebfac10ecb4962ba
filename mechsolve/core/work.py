"""The driver's work over the sweep, by the energy method, with the work of the loads
that are not state functions integrated exactly (Gauss-Kronrod; see :mod:`.forces`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.numerics import EPS, brent_root
from mechsolve.core.force_result import ForceResult
from mechsolve.core.loads import _Q, _switch, apply_loads, states_between, stroke_function
from mechsolve.core.sweep import StateView
from mechsolve.model import PointForce, Spring, Torque

if TYPE_CHECKING:
    from mechsolve.core.sweep import Analysis, Solution


def driver_work(an: Analysis, sol: Solution, fr: ForceResult) -> float:
    """Work done by the driver over the sweep (J); NaN where it is not defined (see
    :func:`driver_work_why`)."""
    return driver_work_why(an, sol, fr)[0]


def driver_work_why(an: Analysis, sol: Solution, fr: ForceResult) -> tuple[float, str]:
    """Work done by the driver over the sweep (J), by the energy method, and why it is
    not defined when it is NaN (else "").

    ``W = (T + V)(end) - (T + V)(start) - W_loads``. The kinetic and potential energies are
    state functions, exact at the ends. A constant force (global components) or torque does
    work ``F . (r_1 - r_0)`` (``T (theta_1 - theta_0)``) over each interval where it acts;
    where a condition switches between two samples, the switch is located by bisection on
    the driver coordinate, so the result does not depend on the step. The work of the other
    loads (dampers, drag, springs under a condition, link-fixed forces) is the integral of
    their power over the motion, ``integral of P dt`` (a damper's ``-c v^2``), by adaptive
    quadrature on states solved between the samples (:func:`_power_integral`), to a
    relative 1e-11: not a rule on the samples, so it does not depend on the step either.
    The joints' friction losses are added (:func:`friction_work`, a rule on the samples).
    The energies need only the motion, so positions where the forces are indeterminate
    (singular) do not matter; if the mechanism could not be solved at some position, or
    cannot close somewhere between two solved positions (a dead zone the sweep stepped
    over, whose edges are toggle positions where the rates, and so the kinetic energy and
    the driving effort, grow without bound), the work is not defined (NaN).
    """
    why = motion_gap(an, sol)
    if why:
        return float("nan"), why
    mech, sys_ = an.mech, an.system
    st = sol.state
    energy = fr.kinetic + fr.potential
    work = energy[-1] - energy[0]
    if not np.isfinite(work):
        why = "the energies at the sweep's ends are not determined next to a singular position"
        return float("nan"), why
    integrated = []  # loads whose work is the integral of their power
    for load in mech.loads:
        # "pos" is the load's potential-like function: its work is a difference of it;
        # "phi" its values at every sample
        if isinstance(load, PointForce) and load.frame == "global":
            b = sys_.index[load.link]
            s = mech.local_point(load.link, load.point)
            f = load.force
            x, y = st.point(b, s)
            phi = f[0] * x + f[1] * y

            def pos(state, i, b=b, s=s, f=f):
                x, y = state.point(b, s, [i])
                return f[0] * float(x[0]) + f[1] * float(y[0])

        elif isinstance(load, Torque):
            b = sys_.index[load.link]
            phi = load.torque * st.th[b]

            def pos(state, i, b=b, t=load.torque):
                return t * float(state.th[b, i])

        else:
            if not (isinstance(load, Spring) and load.when is None):  # else in V
                integrated.append(load)
            continue
        on = fr.active.get(load.name)
        if on is None:
            work -= float(phi[-1] - phi[0])
            continue
        both = on[:-1] & on[1:]
        work -= float(np.sum(np.diff(phi)[both]))  # the intervals where it acts throughout
        for k in np.flatnonzero(on[:-1] != on[1:]):  # and the parts where it switches
            k = int(k)
            us, ss = _switch(an, sol, fr, load, k)
            if on[k]:
                work -= pos(ss, 0) - float(phi[k])
            else:
                work -= float(phi[k + 1]) - pos(ss, 0)
    if integrated:
        w_loads, why = _power_integral(an, sol, fr, integrated)
        if why:
            return float("nan"), why
        work -= w_loads
    if fr.friction is not None:
        w_friction, why = friction_work(sol, fr)
        if why:
            return float("nan"), why
        work += w_friction
    return float(work), ""


def motion_gap(an: Analysis, sol: Solution) -> str:
    """Why the motion of ``sol`` is not one continuous motion over its positions (too
    few of them, some not solved, or a dead zone the sweep stepped over between two),
    in words; "" when it is."""
    if len(sol.u) < 2:
        return "not enough positions"
    if not np.all(sol.ok):
        return f"{int(np.sum(~sol.ok))} position(s) not solved"
    zone = next((e for e in sol.events if e.kind == "dead zone"), None)
    if zone is None:
        return ""
    k = zone.after
    lo = zone.edge_in if np.isfinite(zone.edge_in) else float(sol.u[k])
    hi = zone.edge_out if np.isfinite(zone.edge_out) else float(sol.u[k + 1])
    return (
        f"{zone.group} cannot close between {an.format_u(lo)} and {an.format_u(hi)}, a "
        "dead zone the sweep stepped over: the driving effort grows without bound at its "
        "edges"
    )


def friction_work(sol: Solution, fr: ForceResult) -> tuple[float, str]:
    """The work the joints' friction dissipates over the sweep (J, >= 0) and why it is not
    defined when it is NaN: ``integral of P_friction dt = integral of P_friction / u' du``
    by the trapezoidal rule on the samples (second order in the step; a joint's slip
    changing sign between two samples makes that interval first order). A motion of
    varying speed is integrated over time, ``integral of P_friction dt``, by the same
    rule (the driver may stop and reverse there)."""
    if len(sol.u) < 2:
        return float("nan"), "not enough positions"
    if not np.all(fr.ok):
        bad = int(np.sum(~fr.ok))
        return float("nan"), f"the friction losses are not known at {bad} position(s)"
    rate = np.broadcast_to(np.asarray(fr.speed, float), np.shape(sol.u))
    t = np.asarray(sol.t, float) if sol.t is not None else None
    if t is not None and t.shape == np.shape(sol.u) and np.any(rate != rate[0]):
        # a motion of varying speed (a simulation, whose driver may reverse): over time,
        # where the power is continuous through a reversal (P / u' is not)
        p = fr.power_friction
        return float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t))), ""
    if np.any(rate == 0):
        return float("nan"), "the driver stands still at some position (friction losses)"
    per_u = fr.power_friction / rate
    return float(np.sum(0.5 * (per_u[1:] + per_u[:-1]) * np.diff(sol.u))), ""


# Gauss-Kronrod 7-15 on [-1, 1] (QUADPACK's qk15): the 15 Kronrod nodes and weights, and
# the weights of the 7-point Gauss rule on its nodes (every second Kronrod node)
_XK = np.array(
    [
        0.991455371120812639206854697526329,
        0.949107912342758524526189684047851,
        0.864864423359769072789712788640926,
        0.741531185599394439863864773280788,
        0.586087235467691130294144845693013,
        0.405845151377397166906606412076961,
        0.207784955007898467600689403773245,
    ]
)


_WK = np.array(
    [
        0.022935322010529224963732008058970,
        0.063092092629978553290700663189204,
        0.104790010322250183839876322541518,
        0.140653259715525918745189590510238,
        0.169004726639267902826583426598550,
        0.190350578064785409913256402421014,
        0.204432940075298892414161999234649,
    ]
)


_WG = np.array(
    [
        0.129484966168869693270611432679082,
        0.279705391489276667901467771423780,
        0.381830050505118944950369775488975,
    ]
)


GK_NODES = np.r_[-_XK, 0.0, _XK[::-1]]


GK_WEIGHTS = np.r_[_WK, 0.209482141084727828012999174891714, _WK[::-1]]


G7_WEIGHTS = np.r_[_WG, 0.417959183673469387755102040816327, _WG[::-1]]  # at nodes 1::2
WORK_RTOL = 1e-11  # the quadrature's tolerance, relative to the integral of |P|


def _power_integral(
    an: Analysis, sol: Solution, fr: ForceResult, loads: list, rtol: float = WORK_RTOL
) -> tuple[float, str]:
    """The work of ``loads`` over the motion of ``sol``, ``integral of P dt`` (J), and why
    it could not be found ("" if it was).

    Adaptive Gauss-Kronrod (7-15) quadrature in time: the panels start as the intervals
    between samples, cut where a condition of one of the loads switches (located by
    bisection, so that each panel's power is smooth); a panel whose Kronrod and Gauss
    estimates differ by more than its share of ``rtol`` times the integral of ``|P|`` is
    halved, all such panels of a round solved at once. The states at the nodes are the
    mechanism's own at those driver values (:func:`mechsolve.core.evaluate.states`, on the sweep's
    branches), with the driver's rates there: the file's speed, or its motion law of time.
    """
    t = np.asarray(sol.t, float)
    u = np.asarray(sol.u, float)
    ud, udd = sol.driver_rates()
    law = an.mech.driver.motion
    panels = _panels(an, sol, fr, loads)
    if not panels:
        return 0.0, ""
    total_time = float(t[-1] - t[0]) if t[-1] != t[0] else 1.0

    steady = law is None and np.all(ud == ud[0]) and not np.any(udd)

    def power(tau: np.ndarray, ks: np.ndarray) -> np.ndarray:
        if law is not None:
            uu, vv, ww = law.at(tau)
        elif steady:  # a constant speed: u is linear in t between samples
            frac = (tau - t[ks]) / (t[ks + 1] - t[ks])
            uu = u[ks] + (u[ks + 1] - u[ks]) * frac
            vv, ww = ud[ks], udd[ks]
        else:  # a simulated motion: its rows' u, u', u'' (quintic Hermite)
            uu, vv, ww = hermite5(t, u, ud, udd, tau, ks)
        return _load_power(an, sol, fr, loads, uu, vv, ww)

    lo = np.array([p[0] for p in panels])
    hi = np.array([p[1] for p in panels])
    ks = np.array([p[2] for p in panels])
    total = 0.0
    scale = None
    for _ in range(60):
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        tau = mid[:, None] + half[:, None] * GK_NODES[None, :]
        p = power(tau.ravel(), np.repeat(ks, len(GK_NODES))).reshape(tau.shape)
        if not np.all(np.isfinite(p)):
            i = int(np.argmax(~np.all(np.isfinite(p), axis=1)))
            return float("nan"), (
                "the mechanism could not be solved between the positions at "
                f"{an.format_u(float(u[ks[i]]))} and {an.format_u(float(u[ks[i] + 1]))}"
            )
        kron = half * (p @ GK_WEIGHTS)
        gauss = half * (p[:, 1::2] @ G7_WEIGHTS)
        if scale is None:  # the integral of |P|: what the tolerance is relative to
            scale = float(np.sum(half * (np.abs(p) @ GK_WEIGHTS)))
        err = np.abs(kron - gauss)
        done = (err <= rtol * scale * (hi - lo) / total_time) | (hi - lo <= 1e-13 * total_time)
        total += float(np.sum(kron[done]))
        if done.all():
            return total, ""
        lo, hi, ks, mid = lo[~done], hi[~done], ks[~done], mid[~done]
        lo, hi, ks = np.r_[lo, mid], np.r_[mid, hi], np.r_[ks, ks]
    return float("nan"), "the power of the loads could not be integrated to tolerance"


def _panels(an: Analysis, sol: Solution, fr: ForceResult, loads: list):
    """The quadrature's first panels (t_lo, t_hi, sample before): the intervals between
    samples where time passes, cut where a condition of one of ``loads`` switches."""
    t = np.asarray(sol.t, float)
    u = np.asarray(sol.u, float)
    law = an.mech.driver.motion
    panels: list[tuple[float, float, int]] = []
    for k in range(len(u) - 1):
        a, b = float(t[k]), float(t[k + 1])
        if not b > a:
            continue  # no time passes (a repeated sample, a sweep at rest): no work
        cuts = []
        if law is None and u[k + 1] != u[k]:
            for load in loads:
                on = fr.active.get(load.name)
                if on is not None and on[k] != on[k + 1]:
                    us = _switch(an, sol, fr, load, k)[0]
                    cuts.append(_time_at(sol, k, us))
        edges = [a, *sorted(c for c in cuts if a < c < b), b]
        panels += [(lo, hi, k) for lo, hi in zip(edges[:-1], edges[1:])]
    return panels


def _load_power(
    an: Analysis, sol: Solution, fr: ForceResult, loads: list, uu, vv, ww
) -> np.ndarray:
    """The power of ``loads`` at the driver values ``uu`` with rates ``vv``, ``ww`` (on
    the sweep's branches; each conditional load where its condition holds there); NaN
    where the mechanism cannot be solved."""

    st, ok = states_between(an, sol, uu, vv, ww)
    view = StateView(an, st)
    funcs = {"stroke": stroke_function(list(fr.stroke_extremes), True)}
    active = {}
    for ld in an.mech.loads:
        if ld.when is not None:
            with np.errstate(invalid="ignore"):
                on = np.asarray(ld.when.evaluate(view, funcs), bool)
            active[ld.name] = np.broadcast_to(on, uu.shape) & ok
    _, per_load, _ = apply_loads(an, st, active, _Q(an, st))
    p = sum(per_load[ld.name] for ld in loads)
    return np.where(ok, p, np.nan)


def hermite5(t, u, ud, udd, tau: np.ndarray, ks: np.ndarray):
    """The driver's motion between rows ``ks`` and ``ks + 1`` at times ``tau``: the
    quintic Hermite interpolant of ``u, u', u''`` at both rows (exact for a motion of
    constant speed or acceleration; error O(h^6) in u for a smooth one), with its first
    two time derivatives: ``(u, u', u'')``."""
    t0 = t[ks]
    h = t[ks + 1] - t0
    s = (tau - t0) / h
    s2 = s * s
    s3 = s2 * s
    s4, s5 = s3 * s, s3 * s2
    u0, u1, v0, v1 = u[ks], u[ks + 1], ud[ks] * h, ud[ks + 1] * h
    a0, a1 = udd[ks] * h * h, udd[ks + 1] * h * h
    h5 = 10 * s3 - 15 * s4 + 6 * s5
    uu = (
        u0
        + (u1 - u0) * h5
        + v0 * (s - 6 * s3 + 8 * s4 - 3 * s5)
        + v1 * (-4 * s3 + 7 * s4 - 3 * s5)
        + a0 * 0.5 * (s2 - 3 * s3 + 3 * s4 - s5)
        + a1 * 0.5 * (s3 - 2 * s4 + s5)
    )
    dh5 = 30 * s2 - 60 * s3 + 30 * s4
    vv = (
        (u1 - u0) * dh5
        + v0 * (1 - 18 * s2 + 32 * s3 - 15 * s4)
        + v1 * (-12 * s2 + 28 * s3 - 15 * s4)
        + a0 * 0.5 * (2 * s - 9 * s2 + 12 * s3 - 5 * s4)
        + a1 * 0.5 * (3 * s2 - 8 * s3 + 5 * s4)
    ) / h
    ddh5 = 60 * s - 180 * s2 + 120 * s3
    ww = (
        (u1 - u0) * ddh5
        + v0 * (-36 * s + 96 * s2 - 60 * s3)
        + v1 * (-24 * s + 84 * s2 - 60 * s3)
        + a0 * 0.5 * (2 - 18 * s + 36 * s2 - 20 * s3)
        + a1 * 0.5 * (6 * s - 24 * s2 + 20 * s3)
    ) / (h * h)
    return uu, vv, ww


def _time_at(sol: Solution, k: int, us: float) -> float:
    """The time between rows ``k`` and ``k + 1`` at which the driver is at ``us``:
    linear in time at a constant speed; on the quintic Hermite interpolant of a
    simulated motion (Brent's method, :func:`~mechsolve.base.numerics.brent_root`, to
    rounding), else (the interpolant does not pass ``us`` there) linear."""
    t = np.asarray(sol.t, float)
    u = np.asarray(sol.u, float)
    a, b = float(t[k]), float(t[k + 1])
    linear = a + (b - a) * (us - u[k]) / (u[k + 1] - u[k])
    ud, udd = sol.driver_rates()
    if ud[k] == ud[k + 1] and udd[k] == 0 and udd[k + 1] == 0:
        return linear
    ks = np.array([k])

    def f(tau: float) -> float:
        return float(hermite5(t, u, ud, udd, np.array([tau]), ks)[0][0]) - us

    try:
        return brent_root(f, a, b, xtol=EPS * (b - a))
    except ValueError:  # no change of sign between the rows (or not finite)
        return linear
