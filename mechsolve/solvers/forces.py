"""Kinetostatics: joint reactions and the driver's effort at every solved position.

d'Alembert's principle in body coordinates: the constraint forces balance the applied
and inertia forces, ``Phi_q^T lambda = Q_applied + Q_inertia``, with
``Q_inertia = -(m a_G, m a_G, J alpha)`` per body, expressed at the body's frame origin.
The multipliers give the reactions directly:

* revolute joint ``[a, b]``: ``lambda`` is the force exerted on ``b`` by ``a``;
* slider joint ``[guide, block]``: ``-lambda_1`` is the normal force on the block by the guide
  (along the line's left normal) and ``-lambda_2`` the moment on the block by the guide;
* driver: ``-lambda`` is the torque (force) the driver applies to the driven link.

``Phi_q`` is block lower-triangular in the order of the structural groups, so its transpose
is solved group by group from the last group back to the first (the classic dyad-by-dyad
kinetostatics), each with the group's own small square block. A group whose block is
singular at a position (a toggle or dead-centre position) makes the reactions there
indeterminate: they are reported as such, never filled from a bad solve.

Power balance (a built-in check at every position)::

    P_driver = dT/dt + dV/dt - P_loads

T is the kinetic energy, V the potential energy of gravity and unconditional springs,
P_loads the power of the applied forces, torques, dampers and conditional springs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..conditioning import (
    NEAR_SINGULAR_INDICATOR,
    NEAR_SINGULAR_RCOND,
    SINGULAR_INDICATOR,
    SINGULAR_RCOND,
    group_block,
    rcond,
)
from ..groups.generic import NewtonGroup
from ..model import GROUND, Damper, PointForce, Spring, Torque

if TYPE_CHECKING:
    from ..sweep import Analysis, Solution


@dataclass
class ForceResult:
    """Reactions, driver effort, energies and the power balance over the positions.

    The energies and the power balance are computed when first read (a sweep that only
    wants reactions does not pay for them).
    """

    lam: np.ndarray  # (N, nc) Lagrange multipliers
    effort: np.ndarray  # (N,) driving torque (N m) or force (N) on the driven link
    reactions: dict[str, dict[str, np.ndarray]]
    active: dict[str, np.ndarray]  # per conditional load: where it acts
    power_loads: np.ndarray  # power of the applied loads (W)
    singular: list[tuple[int, str]] = field(default_factory=list)  # (position, group label)
    ok: np.ndarray | None = None
    load_power: dict[str, np.ndarray] = field(default_factory=dict)  # power of each load
    nonunique: dict[str, set[str]] = field(default_factory=dict)  # joint -> components
    stroke_extremes: list[tuple[float, float]] = field(default_factory=list)
    speed: np.ndarray | float = 0.0  # the driver's speed at each position (rad/s or m/s)
    # singular positions whose driver effort is its limit along the motion
    effort_by_limit: list[int] = field(default_factory=list)
    # positions next to a singular one (see mechsolve.conditioning), where the computed
    # effort carries rounding amplified by 1/s^3; and those of them whose effort is its
    # limit along the motion
    near_singular: dict[int, float] = field(default_factory=dict)  # position -> s
    effort_near_limit: list[int] = field(default_factory=list)
    # (kinetic, kinetic rate, potential, potential rate) on demand
    energy_terms: Callable[[], tuple] | None = field(default=None, repr=False)
    _energies: tuple | None = field(default=None, repr=False)

    def _terms(self) -> tuple:
        if self._energies is None:
            self._energies = self.energy_terms()
        return self._energies

    @property
    def kinetic(self) -> np.ndarray:
        """Kinetic energy T (J)."""
        return self._terms()[0]

    @property
    def kinetic_rate(self) -> np.ndarray:
        """dT/dt (W)."""
        return self._terms()[1]

    @property
    def potential(self) -> np.ndarray:
        """Potential energy V of gravity and unconditional springs (J)."""
        return self._terms()[2]

    @property
    def potential_rate(self) -> np.ndarray:
        """dV/dt (W)."""
        return self._terms()[3]

    @property
    def power_input(self) -> np.ndarray:
        """Power of the driver (W)."""
        return self.effort * self.speed

    @property
    def residual(self) -> np.ndarray:
        """Power balance: P_driver - dT/dt - dV/dt + P_loads (W), zero to rounding."""
        return self.power_input - self.kinetic_rate - self.potential_rate + self.power_loads


class _Q:
    """Accumulates generalised forces (nq, N) and their power."""

    def __init__(self, an: Analysis, st) -> None:
        self.st = st
        self.nb = an.system.nb
        self.Q = np.zeros((3 * self.nb, st.n))

    def force(self, b: int, s, fx, fy, r=None) -> None:
        """A force (fx, fy) at the local point ``s`` of body ``b`` (``r``: the point's
        arm from the frame's origin, global components, when known)."""
        if b == self.nb:
            return
        rx, ry = self.st.rotated(b, np.asarray(s, float)) if r is None else r
        self.Q[3 * b] += fx
        self.Q[3 * b + 1] += fy
        self.Q[3 * b + 2] += rx * fy - ry * fx

    def torque(self, b: int, t) -> None:
        if b != self.nb:
            self.Q[3 * b + 2] += t


def stroke_function(
    extremes: list[tuple[float, float]], replay: bool = False, blocks: int | None = None
):
    """``stroke(q)``: the fraction of ``q`` between its extremes over the sweep.

    Over the sweep, the extremes are found from the samples and refined by a parabola
    through the three samples around each one (so that a coarse sweep still finds the true
    ends of the stroke), and recorded in ``extremes``. With ``replay``, the recorded
    extremes are used again, in the same order: for evaluating a condition at a single
    position between samples. With ``blocks``, the positions are that many sweeps one
    after another (designs solved as one batch, :mod:`mechsolve.batch`): each has its own
    extremes, recorded as arrays over the blocks.
    """
    calls = iter(extremes) if replay else None

    def stroke(q):
        q = np.asarray(q, float)
        if blocks is not None and calls is None:
            rows = np.broadcast_to(q, (q.size,)).reshape(blocks, -1)
            lo, hi = np.empty(blocks), np.empty(blocks)
            for j, r in enumerate(rows):
                good = np.flatnonzero(np.isfinite(r))
                if good.size < 2:
                    lo[j] = hi[j] = np.nan
                else:
                    lo[j] = _extreme(r, good, np.argmin, -1.0)
                    hi[j] = _extreme(r, good, np.argmax, 1.0)
            extremes.append((lo, hi))
            span = hi - lo
            with np.errstate(invalid="ignore", divide="ignore"):
                frac = (rows - lo[:, None]) / np.where(span > 0, span, np.inf)[:, None]
            return frac.ravel()
        if calls is not None:
            lo, hi = next(calls)
            if blocks is not None and np.ndim(lo):  # each design's own extremes
                rows = np.broadcast_to(q, (q.size,)).reshape(blocks, -1)
                span = np.asarray(hi) - np.asarray(lo)
                with np.errstate(invalid="ignore", divide="ignore"):
                    frac = (rows - np.asarray(lo)[:, None]) / np.where(span > 0, span, np.inf)[
                        :, None
                    ]
                return frac.ravel()
        else:
            good = np.flatnonzero(np.isfinite(q))
            if good.size < 2:
                # no stroke over fewer than two positions; recorded all the same, so
                # that a replay meets its calls in the same order
                extremes.append((np.nan, np.nan))
                return np.full_like(q, np.nan)
            lo = _extreme(q, good, np.argmin, -1.0)
            hi = _extreme(q, good, np.argmax, 1.0)
            extremes.append((lo, hi))
        span = hi - lo
        if not np.isfinite(span):
            return np.full_like(q, np.nan)
        return (q - lo) / span if span > 0 else np.zeros_like(q)

    return stroke


def _extreme(q, good, arg, sign):
    vals = q[good]
    k = int(arg(vals))
    best = vals[k]
    if 0 < k < len(vals) - 1 and good[k + 1] - good[k - 1] == 2:
        a, b, c = vals[k - 1], vals[k], vals[k + 1]
        den = a - 2 * b + c
        if den * sign < 0:  # a true parabola vertex
            best = b - (c - a) ** 2 / (8 * den)
    return best


def condition_masks(
    an: Analysis, sol: Solution, view, extremes: list, replay: bool = False
) -> dict[str, np.ndarray]:
    """Where each conditional load acts (False where a position was not solved).

    Without ``replay``, the extremes that ``stroke(q)`` uses are found over ``sol`` and
    recorded in ``extremes``: each located between the samples on the motion itself
    (:func:`exact_extremes`), not read off the samples, so that a conditional load acts
    over the same part of the motion whatever the step."""
    if not replay and any(ld.when is not None and ld.when.uses("stroke") for ld in an.mech.loads):
        found: list = []
        args = stroke_arguments(an, view, found)
        extremes += exact_extremes(an, sol, args, found)
        replay = True
    out = {}
    funcs = {"stroke": stroke_function(extremes, replay, getattr(an, "blocks", None))}
    n = len(sol.u)
    for load in an.mech.loads:
        if load.when is None:
            continue
        with np.errstate(invalid="ignore"):
            val = load.when.evaluate(view, funcs)
        out[load.name] = np.broadcast_to(np.asarray(val, bool), (n,)) & sol.ok
    return out


def stroke_arguments(an: Analysis, view, extremes: list | None = None) -> list[np.ndarray]:
    """The values of the argument ``q`` of every ``stroke(q)`` in the load conditions, in
    the order the conditions evaluate them (the order of ``extremes``). With
    ``extremes``, each call also records the extremes over the samples there."""
    args: list[np.ndarray] = []
    inner = (
        stroke_function(extremes, False, getattr(an, "blocks", None))
        if extremes is not None
        else None
    )
    n = view.st.n

    def capture(q):
        q = np.broadcast_to(np.asarray(q, float), (n,))
        args.append(q)
        return inner(q) if inner is not None else np.zeros(n)

    for load in an.mech.loads:
        if load.when is not None:
            with np.errstate(invalid="ignore"):
                load.when.evaluate(view, {"stroke": capture})
    return args


EXTREME_POINTS = 65  # points per bracket and round in exact_extremes (shrinks it 32-fold)


def exact_extremes(an: Analysis, sol: Solution, args: list, sampled: list) -> list[tuple]:
    """The extremes of each ``stroke(q)`` argument over the motion of ``sol``.

    ``args``: the arguments' values at the samples; ``sampled``: their extremes over the
    samples (parabola-refined). Each extreme is located next to its extreme sample: the
    bracket of the two neighbouring samples (across the ends of a full turn, which are
    one pose) is sampled at :data:`EXTREME_POINTS` positions solved on the sweep's
    branches, then again around the best of them, until it is 1e-11 of the travel wide.
    The result is never less extreme than the samples. Designs solved as one batch
    (``an.blocks``) are located together, each on its own motion, when the batch gives
    their states (``an.design_states``); a driver with a motion law of time keeps the
    samples' extremes.
    """
    from ..limits import full_cycle

    blocks = getattr(an, "blocks", None)
    B = blocks or 1
    u_all = np.asarray(sol.u, float)
    P = len(u_all) // B
    if not args or P < 3 or an.mech.driver.motion is not None:
        return list(sampled)
    evaluate = _design_evaluator(an, sol) if blocks else _sweep_evaluator(an, sol)
    if evaluate is None:
        return list(sampled)
    u = u_all[:P]
    d = 1.0 if u[-1] >= u[0] else -1.0
    x = d * (u - u[0])  # travel from the first sample, increasing
    T = float(x[-1])
    if not T > 0:
        return list(sampled)
    periodic = full_cycle(an.linear, u)
    # brackets: one per (argument, block, min/max)
    nq = len(args)
    Q = np.stack([np.asarray(q, float).reshape(B, P) for q in args])  # (nq, B, P)
    sign = np.array([-1.0, 1.0])  # min, max
    score = sign[:, None, None, None] * Q[None]  # (2, nq, B, P): larger is better
    score = np.where(np.isfinite(score), score, -np.inf)
    k = np.argmax(score, axis=-1)  # (2, nq, B)
    best = np.take_along_axis(score, k[..., None], -1)[..., 0]
    lo_k, hi_k = np.maximum(k - 1, 0), np.minimum(k + 1, P - 1)
    a, b = x[lo_k], x[hi_k]
    if periodic:  # the ends of a full turn are one pose: the bracket goes across
        a = np.where(k == 0, x[P - 2] - T, a)
        b = np.where(k == P - 1, x[1] + T, b)
    active = np.isfinite(best)
    frac = np.linspace(0.0, 1.0, EXTREME_POINTS)
    for _ in range(12):
        if not active.any() or np.all((b - a)[active] <= 1e-11 * T):
            break
        nodes = a[..., None] + (b - a)[..., None] * frac  # (2, nq, B, M)
        if periodic:
            nodes = np.where(nodes < 0, nodes + T, np.where(nodes > T, nodes - T, nodes))
        nodes = np.clip(nodes, 0.0, T)
        # every block's nodes of every bracket, solved together: (B, 2 * nq * M)
        per_block = np.moveaxis(nodes, 2, 0).reshape(B, -1)
        vals = evaluate(u[0] + d * per_block)  # list over arguments of (B, L)
        if vals is None:
            break
        V = np.stack(vals)  # (nq, B, L)
        V = V.reshape(nq, B, 2, nq, EXTREME_POINTS)  # value of q_i at bracket (s, j)
        idx = np.arange(nq)
        mine = V[idx, :, :, idx, :]  # (nq, B, 2, M): q_j at its own brackets
        got = sign[None, None, :, None] * mine
        got = np.moveaxis(got, 2, 0)  # (2, nq, B, M)
        got = np.where(np.isfinite(got), got, -np.inf)
        i = np.argmax(got, axis=-1)
        top = np.take_along_axis(got, i[..., None], -1)[..., 0]
        found = active & np.isfinite(top)
        best = np.where(found & (top > best), top, best)
        width = (b - a) / (EXTREME_POINTS - 1)
        centre = a + width * i
        a = np.where(found, centre - width, a)
        b = np.where(found, centre + width, b)
        active = found
    values = sign[:, None, None] * best  # (2, nq, B)
    out = []
    for j in range(nq):
        lo, hi = values[0, j], values[1, j]
        slo, shi = sampled[j]
        lo = np.where(np.isfinite(lo), lo, np.asarray(slo, float).reshape(-1))
        hi = np.where(np.isfinite(hi), hi, np.asarray(shi, float).reshape(-1))
        out.append((lo, hi) if blocks else (float(lo[0]), float(hi[0])))
    return out


def states_between(an: Analysis, sol: Solution, u: np.ndarray, ud, udd):
    """The mechanism's states at driver values ``u`` between the samples of ``sol``, on
    its branches, with the driver's rates ``ud``, ``udd``: (state, where it closes).

    Closed forms take the sweep's start and branch switches; Newton groups continue from
    the nearest sample, one run of values per sample."""
    from ..state import State, scale_rates

    u = np.asarray(u, float)
    n = u.size
    if not any(isinstance(g, NewtonGroup) for g in an.plan):
        ns = an.solve(u, start=sol.start, near=(sol, 0), per_unit_driver=True)
        st, ok = ns.state, ns.ok
    else:
        st = State(an.system.nb, n)
        ok = np.zeros(n, bool)
        su = np.asarray(sol.u, float)
        order = np.argsort(su)
        pos = np.clip(np.searchsorted(su[order], u), 1, len(su) - 1)
        left, right = order[pos - 1], order[pos]
        nearest = np.where(np.abs(u - su[left]) <= np.abs(u - su[right]), left, right)
        for k in np.unique(nearest):
            idx = np.flatnonzero(nearest == k)
            idx = idx[np.argsort(np.abs(u[idx] - su[k]), kind="stable")]  # outwards
            part = an.solve(u[idx], start=sol.start, near=(sol, int(k)), per_unit_driver=True)
            st.block[..., idx] = part.state.block
            ok[idx] = part.ok
        st.token = State.new_token()
    scale_rates(st, np.broadcast_to(ud, (n,)), np.broadcast_to(udd, (n,)))
    return st, ok


def _sweep_evaluator(an: Analysis, sol: Solution):
    """``stroke(q)``'s arguments at driver values ``u`` (1, L): the mechanism solved
    there on the sweep's branches, at the file's speed."""
    from ..sweep import StateView

    def evaluate(u: np.ndarray):
        st, ok = states_between(an, sol, u.ravel(), an.speed, 0.0)
        args = stroke_arguments(an, StateView(an, st))
        return [np.where(ok, q, np.nan).reshape(u.shape) for q in args]

    return evaluate


def _design_evaluator(an: Analysis, sol: Solution):
    """As :func:`_sweep_evaluator` for designs solved as one batch: ``an.design_states``
    (given by :mod:`mechsolve.batch`) solves each design at its own driver values."""
    from ..sweep import StateView

    solve = getattr(an, "design_states", None)
    if solve is None:
        return None

    def evaluate(u: np.ndarray):
        a, st, ok = solve(u)
        args = stroke_arguments(a, StateView(a, st))
        return [np.where(ok, q, np.nan).reshape(u.shape) for q in args]

    return evaluate


def solve_forces(
    an: Analysis, sol: Solution, stroke_extremes: list[tuple[float, float]] | None = None
) -> ForceResult:
    """Kinetostatic analysis of a solved sweep (positions, velocities, accelerations).

    ``stroke_extremes``: the extremes that ``stroke(q)`` in load conditions uses, when
    they come from elsewhere (a long sweep solved in chunks); found over ``sol`` if None.
    """
    from ..sweep import StateView

    mech, sys_ = an.mech, an.system
    st = sol.state
    n = st.n
    view = StateView(an, st)
    acc = _Q(an, st)
    gx, gy = mech.gravity_vector()

    # inertia and gravity, at each body's centre of mass
    massive = []
    for lk in mech.links:
        # numbers, or arrays over the positions of designs solved as one batch
        m = 0.0 if lk.mass is None else lk.mass
        J = 0.0 if lk.inertia is None else lk.inertia
        if not np.any(m) and not np.any(J):
            continue
        b = sys_.index[lk.name]
        s = np.asarray(lk.com if lk.com is not None else (0.0, 0.0), float)
        if s.ndim == 1 and not s.any():  # the centre at the frame's origin
            acc.force(b, s, m * (gx - st.ax[b]), m * (gy - st.ay[b]))
        else:
            r = st.rotated(b, s)  # the centre's arm: for its acceleration and moment
            rx, ry = r
            w2 = st.w[b] * st.w[b]
            ax = st.ax[b] - st.al[b] * ry - w2 * rx
            ay = st.ay[b] + st.al[b] * rx - w2 * ry
            acc.force(b, s, m * (gx - ax), m * (gy - ay), r)
        if np.any(J):
            acc.torque(b, -J * st.al[b])
        massive.append((b, m, J, s))

    def energy_terms():
        kinetic = np.zeros(n)
        kinetic_rate = np.zeros(n)
        potential = np.zeros(n) + springs[0]
        potential_rate = np.zeros(n) + springs[1]
        with np.errstate(invalid="ignore"):  # unsolved positions stay NaN
            for b, m, J, s in massive:
                xg, yg = st.point(b, s)
                vx, vy = st.point_velocity(b, s)
                ax, ay = st.point_acceleration(b, s)
                w, al = st.w[b], st.al[b]
                kinetic += 0.5 * m * (vx * vx + vy * vy) + 0.5 * J * w * w
                kinetic_rate += m * (vx * ax + vy * ay) + J * w * al
                potential += -m * (gx * xg + gy * yg)
                potential_rate += -m * (gx * vx + gy * vy)
        return kinetic, kinetic_rate, potential, potential_rate

    replay = stroke_extremes is not None
    extremes: list[tuple[float, float]] = list(stroke_extremes) if replay else []
    active = condition_masks(an, sol, view, extremes, replay)
    power_loads, load_power, springs = apply_loads(an, st, active, acc)

    lam, singular, nonunique, near = _solve_groups(an, st, acc.Q, sol.indicator, sol.ok)
    drv = sys_.driver
    row = next(r.start for r in sys_.rows if r.constraint is drv)
    effort = -lam[:, row]
    reactions = _reactions(an, st, lam)
    ok = sol.ok & np.all(np.isfinite(lam), axis=1)
    return ForceResult(
        lam,
        effort,
        reactions,
        active,
        power_loads,
        singular,
        ok,
        load_power=load_power,
        stroke_extremes=extremes,
        nonunique=_nonunique_components(an, nonunique),
        speed=sol.driver_rates()[0],
        energy_terms=energy_terms,
        near_singular=near,
    )


def apply_loads(
    an: Analysis, st, active: dict[str, np.ndarray], acc: _Q
) -> tuple[np.ndarray, dict[str, np.ndarray], list]:
    """Add the model's loads to the generalised forces ``acc`` in the states ``st``.

    ``active``: where each conditional load acts. Returns the power of the loads whose
    work is not in a potential (W, per position), the power of each load, and the
    potential of the unconditional springs with its rate, ``[V, dV/dt]``.
    """
    mech, sys_ = an.mech, an.system
    nb = sys_.nb
    power_loads = np.zeros(st.n)
    springs = [0.0, 0.0]  # potential of unconditional springs and its rate
    load_power: dict[str, np.ndarray] = {}
    with np.errstate(invalid="ignore"):  # unsolved positions stay NaN
        for load in mech.loads:
            before = power_loads.copy()
            on = active.get(load.name)
            f = on.astype(float) if on is not None else 1.0
            if isinstance(load, PointForce):
                b = sys_.index[load.link]
                s = an.mech.local_point(load.link, load.point)
                fx, fy = load.force
                if load.frame == "link":
                    fx, fy = st.rotated(b, np.array(load.force))
                fx, fy = fx * f, fy * f
                acc.force(b, s, fx, fy)
                vx, vy = st.point_velocity(b, s)
                power_loads += fx * vx + fy * vy
            elif isinstance(load, Torque):
                b = sys_.index[load.link]
                acc.torque(b, load.torque * f)
                power_loads += load.torque * f * st.w[b]
            elif isinstance(load, Damper) and load.slider is not None:
                sl = sys_.by_joint[load.slider]
                ux, uy, *_ = sl.frame(st)
                sd = sl.velocity(st)
                fmag = -load.coefficient * sd * f  # on the block, along the line
                acc.force(sl.b, sl.sb, fmag * ux, fmag * uy)
                xp, yp = st.point(sl.b, sl.sb)
                # the reaction acts on the guide at the material point under the block
                _force_at_global(acc, st, sl.a, xp, yp, -fmag * ux, -fmag * uy)
                power_loads += fmag * sd
            elif isinstance(load, Damper) and load.drag is not None:
                b = sys_.index[load.drag[0]]
                s = an.mech.local_point(*load.drag)
                vx, vy = st.point_velocity(b, s)
                c = load.coefficient * f
                acc.force(b, s, -c * vx, -c * vy)
                power_loads += -c * (vx * vx + vy * vy)
            else:  # spring or damper between two points
                (la, pa), (lb, pb) = load.ends
                ba = nb if la == GROUND else sys_.index[la]
                bb = nb if lb == GROUND else sys_.index[lb]
                sa, sb = mech.local_point(la, pa), mech.local_point(lb, pb)
                xa, ya = st.point(ba, sa)
                xb, yb = st.point(bb, sb)
                vax, vay = st.point_velocity(ba, sa)
                vbx, vby = st.point_velocity(bb, sb)
                dx, dy = xb - xa, yb - ya
                L = np.hypot(dx, dy)
                with np.errstate(invalid="ignore", divide="ignore"):
                    ex, ey = dx / L, dy / L
                Ld = ex * (vbx - vax) + ey * (vby - vay)
                if isinstance(load, Spring):
                    t = load.stiffness * (L - load.free_length)  # tension
                    if load.when is None:
                        springs[0] = springs[0] + 0.5 * load.stiffness * (L - load.free_length) ** 2
                        springs[1] = springs[1] + t * Ld
                    else:
                        power_loads += -t * f * Ld
                    t = t * f
                else:
                    t = load.coefficient * Ld * f
                    power_loads += -t * Ld
                # tension t pulls b towards a and a towards b
                acc.force(bb, sb, -t * ex, -t * ey)
                acc.force(ba, sa, t * ex, t * ey)
            load_power[load.name] = power_loads - before
    return power_loads, load_power, springs


def _nonunique_components(an: Analysis, free: np.ndarray) -> dict[str, set[str]]:
    """Reaction components that redundant constraints leave indeterminate."""
    out: dict[str, set[str]] = {}
    for row in an.system.rows:
        c = row.constraint
        f = free[row.start : row.start + c.m]
        if not np.any(f):
            continue
        if c.kind == "revolute":
            comps = {k for k, on in zip(("Fx", "Fy"), f) if on} | {"F"}
        elif c.kind == "slider":
            comps = ({"N", "Fx", "Fy"} if f[0] else set()) | ({"M"} if f[1] else set())
        else:
            comps = {"effort"}
        out[c.name] = comps
    return out


def _force_at_global(acc: _Q, st, b: int, x, y, fx, fy) -> None:
    if b == acc.nb:
        return
    rx, ry = x - st.x[b], y - st.y[b]
    acc.Q[3 * b] += fx
    acc.Q[3 * b + 1] += fy
    acc.Q[3 * b + 2] += rx * fy - ry * fx


def _solve_groups(an: Analysis, st, Q: np.ndarray, indicator: np.ndarray, solved: np.ndarray):
    """Solve Phi_q^T lambda = Q group by group, last group first.

    Groups with a closed form solve their own equilibrium explicitly (the dyad-by-dyad
    kinetostatics of the textbooks); a group is singular where its indicator vanishes.
    Other groups solve their block of Phi_q^T, singular where its condition number is.
    Positions not ``solved`` (the mechanism does not close there) are not singular: they
    are reported as failures of the sweep, not here.
    """
    sys_ = an.system
    n = st.n
    # stored equation-major: each joint's multipliers are rows of N values (a group
    # writes and the reactions read them whole); lam itself is the (N, nc) view
    lam = np.full((sys_.nc, n), np.nan).T
    R = Q.copy()  # applied + inertia + reactions of the groups solved so far
    row_of = {id(r.constraint): r.start for r in sys_.rows}
    singular: list[tuple[int, str]] = []
    near = np.full(n, np.inf)  # how near a singular position: smallest indicator/rcond
    nonunique = np.zeros(sys_.nc, bool)
    for gi in reversed(range(len(an.plan))):
        g = an.plan[gi]
        if hasattr(g, "forces") and not isinstance(g, NewtonGroup):
            out: dict = {}
            ind = indicator[gi] if len(indicator) > gi else np.ones(n)
            sing = np.isfinite(ind) & (ind <= SINGULAR_INDICATOR)
            close = np.isfinite(ind) & (ind <= NEAR_SINGULAR_INDICATOR) & solved
            near = np.where(close, np.minimum(near, ind), near)
            any_sing = bool(sing.any())
            before = R[:, sing].copy() if any_sing else None
            with np.errstate(invalid="ignore", divide="ignore"):
                g.forces(st, R, out)
            if any_sing:
                # what the group passes on to the links it hangs on is not determined
                # either (it was +-inf or rounding noise): those reactions stay empty
                Rs = R[:, sing]
                Rs[Rs != before] = np.nan
                R[:, sing] = Rs
            for c, comps in out.items():
                r0 = row_of[id(c)]
                for k, v in enumerate(comps):
                    lam[:, r0 + k] = np.where(sing, np.nan, v) if any_sing else v
            singular += [(int(i), g.label) for i in np.flatnonzero(sing & solved)]
            continue
        J, blocks = group_block(g, st)
        m = J.shape[1]
        rhs = np.stack([R[3 * b + k] for b in g.bodies for k in range(3)], axis=1)  # (N, nn)
        x = np.full((n, m), np.nan)
        good = np.all(np.isfinite(J), axis=(1, 2))
        if m > J.shape[2]:  # redundant constraints: the minimum-norm multipliers
            x, rc, free = _min_norm(J, rhs, good)
            r0 = 0
            for c in g.constraints:
                nonunique[row_of[id(c)] : row_of[id(c)] + c.m] |= free[r0 : r0 + c.m]
                r0 += c.m
            regular = good & (rc > SINGULAR_RCOND)
            x[~regular] = np.nan
        else:
            rc = rcond(J)
            regular = good & (rc > SINGULAR_RCOND)
            idx = np.flatnonzero(regular & np.all(np.isfinite(rhs), axis=1))
            if idx.size:
                JT = np.transpose(J[idx], (0, 2, 1))
                x[idx] = np.linalg.solve(JT, rhs[idx][..., None])[..., 0]
        singular += [(int(i), g.label) for i in np.flatnonzero(good & ~regular & solved)]
        close = good & (rc <= NEAR_SINGULAR_RCOND) & solved
        near = np.where(close, np.minimum(near, rc), near)
        for c, r0, jac in blocks:
            lc = x[:, r0 : r0 + c.m]  # (N, m_c)
            lam[:, row_of[id(c)] : row_of[id(c)] + c.m] = lc
            for body, blk in jac.items():  # blk (m_c, 3, N)
                if body == sys_.nb:
                    continue
                for k in range(3):
                    R[3 * body + k] -= np.einsum("mn,nm->n", blk[:, k, :], lc)
    singular.sort()
    return lam, singular, nonunique, {int(i): float(near[i]) for i in np.flatnonzero(near < 1)}


def _min_norm(J: np.ndarray, rhs: np.ndarray, good: np.ndarray):
    """Minimum-norm solutions of the under-determined ``J^T x = rhs`` (N, m > n).

    Returns the solutions, the reciprocal condition of the determined part (the smallest
    of the first n singular values over the largest) and which unknowns are not unique
    (those with a component along the null space of ``J^T``).
    """
    n, m, nn = J.shape
    x = np.full((n, m), np.nan)
    rc = np.zeros(n)
    free = np.zeros(m, bool)
    idx = np.flatnonzero(good & np.all(np.isfinite(rhs), axis=1))
    if idx.size == 0:
        return x, rc, free
    JT = np.transpose(J[idx], (0, 2, 1))  # (k, nn, m)
    U, sv, Vt = np.linalg.svd(JT, full_matrices=True)  # sv (k, nn)
    tol = 1e-10 * sv[:, :1]
    rank_ok = sv[:, -1:] > tol  # the nn equations are independent
    inv = np.where(sv > tol, 1.0 / np.where(sv > 0, sv, 1.0), 0.0)
    y = np.einsum("kij,ki->kj", U, rhs[idx]) * inv  # (k, nn)
    x[idx] = np.einsum("kij,ki->kj", Vt[:, :nn, :], y)
    rc[idx] = np.where(rank_ok[:, 0], sv[:, -1] / sv[:, 0], 0.0)
    null = Vt[:, nn:, :]  # (k, m - nn, m)
    free = np.max(np.abs(null), axis=(0, 1)) > 1e-8
    return x, rc, free


def _reactions(an: Analysis, st, lam: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """Named reaction components of every joint, with the sign conventions above."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for row in an.system.rows:
        c = row.constraint
        if c.kind == "revolute":
            fx, fy = lam[:, row.start], lam[:, row.start + 1]
            out[c.name] = {"Fx": fx, "Fy": fy, "F": np.sqrt(fx * fx + fy * fy)}
        elif c.kind == "slider":
            nrm = -lam[:, row.start]
            mom = -lam[:, row.start + 1]
            ux, uy, nx, ny, _, _ = c.frame(st)
            out[c.name] = {"N": nrm, "M": mom, "Fx": nrm * nx, "Fy": nrm * ny}
    return out


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
    The energies need only the motion, so positions where the forces are indeterminate
    (singular) do not matter; if the mechanism could not be solved at some position, the
    work is not defined (NaN).
    """
    if len(sol.u) < 2:
        return float("nan"), "not enough positions"
    if not np.all(sol.ok):
        missing = int(np.sum(~sol.ok))
        return float("nan"), f"{missing} position(s) not solved"
    mech, sys_ = an.mech, an.system
    st = sol.state
    energy = fr.kinetic + fr.potential
    work = energy[-1] - energy[0]
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
    return float(work), ""


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
    mechanism's own at those driver values (:func:`mechsolve.core.states`, on the sweep's
    branches), with the driver's rates there: the file's speed, or its motion law of time.
    """
    from ..sweep import StateView

    t = np.asarray(sol.t, float)
    u = np.asarray(sol.u, float)
    ud, udd = sol.driver_rates()
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
                    cuts.append(a + (b - a) * (us - u[k]) / (u[k + 1] - u[k]))
        edges = [a, *sorted(c for c in cuts if a < c < b), b]
        panels += [(lo, hi, k) for lo, hi in zip(edges[:-1], edges[1:])]
    if not panels:
        return 0.0, ""
    total_time = float(t[-1] - t[0]) if t[-1] != t[0] else 1.0

    def power(tau: np.ndarray, ks: np.ndarray) -> np.ndarray:
        if law is not None:
            uu, vv, ww = law.at(tau)
        else:  # a constant speed: u is linear in t between samples
            frac = (tau - t[ks]) / (t[ks + 1] - t[ks])
            uu = u[ks] + (u[ks + 1] - u[ks]) * frac
            vv, ww = ud[ks], udd[ks]
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


def switch_points(an: Analysis, sol: Solution, fr: ForceResult) -> list[float]:
    """The driver values, bisected to rounding, where a conditional load switches between
    two samples of ``sol``."""
    out = []
    for load in an.mech.loads:
        on = fr.active.get(load.name)
        if on is None:
            continue
        for k in np.flatnonzero(on[1:] != on[:-1]):
            if sol.ok[k] and sol.ok[k + 1]:
                out.append(_switch(an, sol, fr, load, int(k))[0])
    return sorted(out)


def _switch(an: Analysis, sol: Solution, fr: ForceResult, load, k: int, points: int = 127):
    """The driver coordinate between samples k and k+1 where ``load`` switches, to
    rounding: the interval is cut into ``points + 1`` parts per round, all solved at once
    (about 8 vectorised solves instead of some 50 single ones of a bisection)."""
    from ..sweep import StateView

    lo, hi = float(sol.u[k]), float(sol.u[k + 1])
    on_lo = bool(fr.active[load.name][k])
    conditional = [ld for ld in an.mech.loads if ld.when is not None]
    which = conditional.index(load)
    state = None
    frac = np.arange(1, points + 1) / (points + 1)
    for _ in range(40):
        xs = lo + (hi - lo) * frac
        keep = (xs != lo) & (xs != hi) & np.r_[True, np.diff(xs) != 0]
        xs = xs[keep]
        if xs.size == 0:
            break
        many = an.solve(xs, start=sol.start, near=(sol, k))
        view = StateView(an, many.state)
        # stroke(q) replays the sweep's extremes in the order of the conditional loads
        funcs = {"stroke": stroke_function(list(fr.stroke_extremes), True)}
        with np.errstate(invalid="ignore"):
            vals = [
                np.broadcast_to(np.asarray(ld.when.evaluate(view, funcs), bool), xs.shape)
                for ld in conditional
            ]
        flip = np.flatnonzero((vals[which] != on_lo) & many.ok)
        if flip.size == 0:
            lo = float(xs[-1])
            continue
        j = int(flip[0])
        hi = float(xs[j])
        state = many.state.take(np.array([j]))
        if j > 0:
            lo = float(xs[j - 1])
    one = an.solve(np.array([0.5 * (lo + hi)]), start=sol.start, near=(sol, k))
    return 0.5 * (lo + hi), one.state if one.ok[0] else state
