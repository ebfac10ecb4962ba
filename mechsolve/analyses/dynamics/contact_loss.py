"""Loss of contact in a simulation: the motion ends where a force-closed cam's follower
leaves the cam.

A force-closed cam (``closure: force``: a spring or a load holds the follower on it) can
only push its follower. The equations of motion treat the contact as a joint, so past
the point where its normal force would turn negative they integrate a cam that pulls the
follower: a motion that is not the machine's. The run therefore ends at the first loss
of contact, as ``singular: stop`` ends it at a singular position: the rows before it are
kept, the last row is the located state where the contact force falls to zero, and the
trajectory says at which time and driver angle (``early``: exit 0, with the warning that
the motion stopped early).

On the reduced path the time is located to rounding of the motion: the contact force at
the states of one RK4 step from the row before (the integrator's own step for ``rk4``,
eight sub-steps between the rows of an adaptive method), by the Illinois rule on the
step's length. On the multibody path it is the zero of the force interpolated between the two
rows that straddle it (said to be about), and the last row kept is the one before it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from mechsolve.analyses.dynamics.integrators import _acceleration, _along
from mechsolve.core import evaluate as core


def force_closed(mech) -> list:
    """The force-closed cam contacts of ``mech`` (the joints whose contact force may not
    turn negative)."""
    return [j for j in mech.joints if getattr(j, "closure", None) == "force"]


def first_loss(mech, forces) -> tuple[int, str] | None:
    """``(row, joint)``: the first row where a force-closed cam contact's normal force is
    negative (the follower has left the cam), or None."""
    hits = []
    ok = np.asarray(forces.ok, bool)
    for j in force_closed(mech):
        N = np.asarray(forces.reactions[j.name]["N"], float)
        neg = np.flatnonzero(ok & (N < 0))
        if neg.size:
            hits.append((int(neg[0]), j.name))
    return min(hits) if hits else None


def _angle_words(an, mech, phi: float, phi0: float) -> str:
    """The driver's position in words, as the summary gives it."""
    if an.linear:
        return f"driver at {phi * 1e3:.6g} mm"
    deg = math.degrees(phi) % 360.0
    travel = abs(math.degrees(phi - phi0))
    return f"driver angle {deg:.6g}°, {travel:.6g}° from the start"


def _reason(name: str, t: float, where: str, about: bool) -> str:
    at = f"about t = {t:.6g} s" if about else f"t = {t:.6g} s"
    return (
        f"the follower leaves the cam at {name} at {at} ({where}): past it the contact "
        "force would be negative, and a force-closed cam cannot pull its follower (a "
        "stronger spring or load, or closure: form, keeps it on); the motion past it is "
        "not computed"
    )


def solve_states(model, phi, omega, eps, t):
    """The states at the driver's (phi, omega, eps) at times ``t``, as the run solves
    them (on the reference turn where the linkage repeats each turn)."""
    if model.full_turn:
        return model.states_by_turn(phi, omega, eps, t)
    return core.states(model.an, phi, omega, eps, t=t)


def reduced_cut(model, mech, traj, forces):
    """The reduced path's trajectory, states and forces ending at the first loss of
    contact (see the module's docstring), or None where the contact holds throughout."""
    hit = first_loss(mech, forces)
    if hit is None:
        return None
    i, name = hit
    ts, phi, omega = traj.t, traj.phi, traj.omega
    if i == 0:
        keep, row = 1, None
    else:
        keep, row = i, _locate(model, mech, traj, i, name)
    t = np.asarray(ts[:keep], float)
    Y = np.stack([phi[:keep], omega[:keep]], axis=1)
    if row is not None:
        t = np.append(t, row[0])
        Y = np.vstack([Y, [row[1], row[2]]])
    d = mech.driver.direction
    eps, J, mags = _along(model, mech.motor, d, t, Y)
    where = _angle_words(model.an, mech, float(Y[-1, 0]), float(phi[0]))
    cut = dataclasses.replace(
        traj,
        t=t,
        phi=Y[:, 0],
        omega=Y[:, 1],
        eps=eps,
        J=J,
        stopped=_reason(name, float(t[-1]), where, False),
        early=True,
        error=None,
        magnitudes=mags,
    )
    sol = solve_states(model, cut.phi, cut.omega, cut.eps, cut.t)
    # with joint friction each row's forces start from the equation of motion's
    # magnitudes there, as simulate's rows do (see _run.simulate)
    hint = None if mags is None else (None, mags)
    return cut, sol, core.forces(model.an, sol, model.extremes, hint)


def _locate(model, mech, traj, i: int, name: str) -> tuple[float, float, float]:
    """``(t, phi, omega)`` where the contact force of ``name`` falls to zero between rows
    ``i - 1`` (positive) and ``i`` (negative): the end of one RK4 step of length ``tau``
    from row ``i - 1`` (``rk4``: one step, the integrator's; else eight), ``tau`` found by
    the Illinois rule to 1e-7 of the step, the state returned on the side where the force is
    not negative."""
    d = mech.driver.direction
    accel = _acceleration(model, mech.motor, d)
    t0, p0, w0 = float(traj.t[i - 1]), float(traj.phi[i - 1]), float(traj.omega[i - 1])
    h = float(traj.t[i]) - t0
    sub = 1 if mech.simulation.method == "rk4" else 8

    def state(tau: float) -> tuple[float, float]:
        p, w, t = p0, w0, t0
        s = tau / sub
        for _ in range(sub):  # RK4, as the integrator steps
            a1 = accel(t, p, w)
            w2 = w + s / 2 * a1
            a2 = accel(t + s / 2, p + s / 2 * w, w2)
            w3 = w + s / 2 * a2
            a3 = accel(t + s / 2, p + s / 2 * w2, w3)
            w4 = w + s * a3
            a4 = accel(t + s, p + s * w3, w4)
            p, w = p + s / 6 * (w + 2 * w2 + 2 * w3 + w4), w + s / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            t += s
        return p, w

    def force(tau: float) -> float:
        p, w = state(tau)
        y = np.array([[p, w]])
        tt = np.array([t0 + tau])
        eps, _, mags = _along(model, mech.motor, d, tt, y)
        sol = solve_states(model, y[:, 0], y[:, 1], eps, tt)
        hint = None if mags is None else (None, mags)
        f = core.forces(model.an, sol, model.extremes, hint)
        return float(f.reactions[name]["N"][0])

    a, b = 0.0, h
    fa, fb = force(a), force(b)
    if not (fa >= 0 > fb):  # (the rows' forces say so; rounding of a sub-stepped motion)
        p, w = state(0.0)
        return t0, p, w
    side = 0
    for _ in range(100):
        if b - a <= 1e-7 * h:  # (a jump of the force at a join: bisection's ~24 steps)
            break
        c = (a * fb - b * fa) / (fb - fa)
        if not a < c < b:
            c = 0.5 * (a + b)
        fc = force(c)
        if fc >= 0:
            a, fa = c, fc
            fb = fb / 2 if side == -1 else fb
            side = -1
        else:
            b, fb = c, fc
            fa = fa / 2 if side == 1 else fa
            side = 1
    p, w = state(a)
    return t0 + a, p, w


def multibody_cut(mech, an, tr, forces, fields: tuple[str, ...]):
    """The multibody path's trajectory ending at the row before the first loss of
    contact (its rows ``fields`` cut), the time where the contact force's zero is,
    interpolated between the two rows that straddle it, said to be about; None where
    the contact holds throughout."""
    hit = first_loss(mech, forces)
    if hit is None:
        return None
    i, name = hit
    keep = max(i, 1)
    t = np.asarray(tr.t, float)
    u = np.asarray(tr.u, float) if tr.u is not None else np.zeros(len(t))
    N = np.asarray(forces.reactions[name]["N"], float)
    tc, uc = float(t[0]), float(u[0])
    if i > 0:
        s = N[i - 1] / (N[i - 1] - N[i])
        tc, uc = float(t[i - 1] + s * (t[i] - t[i - 1])), float(u[i - 1] + s * (u[i] - u[i - 1]))
    where = _angle_words(an, mech, uc, float(u[0]))
    rows = {f: getattr(tr, f)[:keep] for f in fields}
    before = f"; the last row kept is at t = {t[keep - 1]:.6g} s" if i > 0 else ""
    return dataclasses.replace(
        tr,
        **rows,
        stopped=_reason(name, tc, where, True) + before,
        early=True,
        event="",
        error=None,
    )
