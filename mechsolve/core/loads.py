"""The loads of the force analysis: gravity and inertia, forces, torques, springs and
dampers, conditions (``when:``, ``stroke(q)`` over the exactly located extremes), the
states between samples they are evaluated at (see :mod:`.forces`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from mechsolve.base.state import State, scale_rates
from mechsolve.core.force_result import ForceResult
from mechsolve.core.solution import full_cycle
from mechsolve.core.sweep import StateView
from mechsolve.groups.generic import NewtonGroup
from mechsolve.model import GROUND, Damper, PointForce, Spring, Torque
from mechsolve.model.expr import Call, Ref, Var, walk

if TYPE_CHECKING:
    from mechsolve.core.sweep import Analysis, Solution


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
        t = rx * fy  # the moment rx fy - ry fx, with one temporary fewer
        t -= ry * fx
        self.Q[3 * b + 2] += t

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
    after another (designs solved as one batch, :mod:`mechsolve.analyses.batch`): each has its own
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
        extremes += stroke_extremes(an, sol, view)
        replay = True
    out = {}
    funcs = {"stroke": stroke_function(extremes, replay, getattr(an, "blocks", None))}
    n = len(sol.u)
    for load in an.mech.loads:
        if load.when is None:
            continue
        faults: list = []
        with np.errstate(invalid="ignore"):
            val = load.when.evaluate(view, funcs, faults)
        if faults:  # 1/0 (inf) compares as a number: a condition not determined there
            part, k = faults[0]
            k = int(np.unravel_index(k, np.broadcast_shapes(np.shape(val), (n,)))[-1])
            raise an.mech.error(
                load.where + ("when",),
                f"the condition is not determined at {an.format_u(float(sol.u[k]))}: "
                f"{part!r} is not finite there (a division by zero, or a function outside "
                "its domain)",
            )
        out[load.name] = np.broadcast_to(np.asarray(val, bool), (n,)) & sol.ok
    return out


def stroke_extremes(an: Analysis, sol: Solution, view=None) -> list[tuple]:
    """The extremes of every ``stroke(q)`` of the load conditions over the motion of
    ``sol``, in the order the conditions evaluate them: each located exactly
    (:func:`exact_extremes`, from the samples' extremes). The one place they are found:
    the force analysis of a sweep and the instants (:mod:`mechsolve.analyses.instants`,
    over the file's sweep) both take them from here, so that a conditional load switches
    at the same driver value in both."""
    found: list = []
    args = stroke_arguments(an, view if view is not None else StateView(an, sol.state), found)
    return exact_extremes(an, sol, args, found)


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

    A driver with a motion law of time: the positions it visits are those between the
    smallest and largest driver value of the samples, whatever the time it takes, so
    arguments that read positions only (coordinates, angles, slider displacements) are
    located over the samples ordered by the driver value (a dwell's repeats once) as at
    a constant speed; arguments that read rates keep the samples' extremes.
    """

    blocks = getattr(an, "blocks", None)
    B = blocks or 1
    u_all = np.asarray(sol.u, float)
    P = len(u_all) // B
    if not args or P < 3:
        return list(sampled)
    evaluate = _design_evaluator(an, sol) if blocks else _sweep_evaluator(an, sol)
    if evaluate is None:
        return list(sampled)
    if an.mech.driver.motion is not None:
        if blocks or not _positions_only(an.mech):
            return list(sampled)
        turns = _law_turning_points(an.mech.driver.motion, np.asarray(sol.t, float))
        if turns.size:  # where the law turns back between samples: its reach's ends
            extra = evaluate(turns[None, :])
            u_all = np.concatenate([u_all, turns])
            args = [np.concatenate([np.asarray(q, float), e.ravel()]) for q, e in zip(args, extra)]
        u_all, keep = np.unique(u_all, return_index=True)  # along the driver, each once
        args = [np.asarray(q, float)[keep] for q in args]
        P = len(u_all)
        if P < 3:
            return list(sampled)
    u = u_all[:P]
    d = 1.0 if u[-1] >= u[0] else -1.0
    x = d * (u - u[0])  # travel from the first sample, increasing
    T = float(x[-1])
    if not T > 0:
        return list(sampled)
    periodic = full_cycle(an.linear, u)
    Q = np.stack([np.asarray(q, float).reshape(B, P) for q in args])  # (nq, B, P)
    best, a, b = _brackets(Q, x, T, periodic)
    best = _refine_brackets(evaluate, u[0], d, T, periodic, best, a, b)
    values = _SIGN[:, None, None] * best  # (2, nq, B)
    out = []
    for j in range(len(args)):
        lo, hi = values[0, j], values[1, j]
        slo, shi = sampled[j]
        lo = np.where(np.isfinite(lo), lo, np.asarray(slo, float).reshape(-1))
        hi = np.where(np.isfinite(hi), hi, np.asarray(shi, float).reshape(-1))
        out.append((lo, hi) if blocks else (float(lo[0]), float(hi[0])))
    return out


def _law_turning_points(law, t: np.ndarray) -> np.ndarray:
    """The driver values where a motion law turns back between its time samples ``t``
    (its rate changes sign there; located to rounding): the ends of the range of
    positions it visits, which its samples can fall short of."""
    from mechsolve.base.numerics import brent_root

    _, ud, _ = law.at(t)
    out = []
    for k in np.flatnonzero(ud[:-1] * ud[1:] < 0):
        tk = brent_root(lambda x: float(law.at(np.array([x]))[1][0]), float(t[k]), float(t[k + 1]))
        out.append(float(law.at(np.array([tk]))[0][0]))
    return np.array(out)


_SIGN = np.array([-1.0, 1.0])  # min, max: the sign that makes each a maximum
_POSITION_ATTRS = frozenset({"x", "y", "angle", "s"})  # a pose's, not its rates'


def _positions_only(mech) -> bool:
    """Do the arguments of every ``stroke(q)`` in the load conditions read the pose only
    (no velocity, acceleration or time)?"""
    for load in mech.loads:
        if load.when is None or not load.when.uses("stroke"):
            continue
        for call in walk(load.when.tree):
            if isinstance(call, Call) and call.func == "stroke":
                for n in walk(call.args):
                    if isinstance(n, Var) or (isinstance(n, Ref) and n.attr not in _POSITION_ATTRS):
                        return False
    return True


def _brackets(Q: np.ndarray, x: np.ndarray, T: float, periodic: bool):
    """One bracket per (min/max, argument, block) around its extreme sample: the best
    sample's (signed) value, shape (2, nq, B), and the bracket's ends in travel ``x``
    (the two neighbouring samples; across the ends of a full turn, which are one pose)."""
    P = Q.shape[-1]
    score = _SIGN[:, None, None, None] * Q[None]  # (2, nq, B, P): larger is better
    score = np.where(np.isfinite(score), score, -np.inf)
    k = np.argmax(score, axis=-1)  # (2, nq, B)
    best = np.take_along_axis(score, k[..., None], -1)[..., 0]
    lo_k, hi_k = np.maximum(k - 1, 0), np.minimum(k + 1, P - 1)
    a, b = x[lo_k], x[hi_k]
    if periodic:  # the ends of a full turn are one pose: the bracket goes across
        a = np.where(k == 0, x[P - 2] - T, a)
        b = np.where(k == P - 1, x[1] + T, b)
    return best, a, b


def _refine_brackets(evaluate, u0: float, d: float, T: float, periodic: bool, best, a, b):
    """Narrow every bracket around the best of :data:`EXTREME_POINTS` positions in it,
    solved together (every block's nodes of every bracket at once), until each is 1e-11
    of the travel ``T`` wide; the best (signed) values found, never worse than ``best``."""
    nq, B = best.shape[1], best.shape[2]
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
        vals = evaluate(u0 + d * per_block)  # list over arguments of (B, L)
        if vals is None:
            break
        V = np.stack(vals)  # (nq, B, L)
        V = V.reshape(nq, B, 2, nq, EXTREME_POINTS)  # value of q_i at bracket (s, j)
        idx = np.arange(nq)
        mine = V[idx, :, :, idx, :]  # (nq, B, 2, M): q_j at its own brackets
        got = _SIGN[None, None, :, None] * mine
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
    return best


def states_between(an: Analysis, sol: Solution, u: np.ndarray, ud, udd):
    """The mechanism's states at driver values ``u`` between the samples of ``sol``, on
    its branches, with the driver's rates ``ud``, ``udd``: (state, where it closes).

    Closed forms take the sweep's start and branch switches; Newton groups continue from
    the nearest sample, one run of values per sample."""

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

    speed = an.speed or 1.0  # (a motion law: only the pose is read, see exact_extremes)

    def evaluate(u: np.ndarray):
        st, ok = states_between(an, sol, u.ravel(), speed, 0.0)
        args = stroke_arguments(an, StateView(an, st))
        return [np.where(ok, q, np.nan).reshape(u.shape) for q in args]

    return evaluate


def _design_evaluator(an: Analysis, sol: Solution):
    """As :func:`_sweep_evaluator` for designs solved as one batch: ``an.design_states``
    (given by :mod:`mechsolve.analyses.batch`) solves each design at its own driver values."""

    solve = getattr(an, "design_states", None)
    if solve is None:
        return None

    def evaluate(u: np.ndarray):
        a, st, ok = solve(u)
        args = stroke_arguments(a, StateView(a, st))
        return [np.where(ok, q, np.nan).reshape(u.shape) for q in args]

    return evaluate


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
                power_loads += _point_force(an, st, acc, load, f)
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
                r = None if b == nb else st.rotated(b, np.asarray(s, float))
                vx, vy = st.point_velocity(b, s, arm=r)
                c = load.coefficient * f
                acc.force(b, s, -c * vx, -c * vy, r)
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


def _point_force(an: Analysis, st, acc: _Q, load: PointForce, f) -> np.ndarray:
    """Add a point force (``f``: where it acts, 1 or 0) to ``acc``; its power."""
    sys_ = an.system
    b = sys_.index[load.link]
    s = an.mech.local_point(load.link, load.point)
    fx, fy = load.force
    if load.frame == "link":
        fx, fy = st.rotated(b, np.array(load.force))
    fx, fy = fx * f, fy * f
    # the point's arm, once for its moment and its velocity
    r = None if b == sys_.nb else st.rotated(b, np.asarray(s, float))
    acc.force(b, s, fx, fy, r)
    vx, vy = st.point_velocity(b, s, arm=r)
    return fx * vx + fy * vy


def _force_at_global(acc: _Q, st, b: int, x, y, fx, fy) -> None:
    if b == acc.nb:
        return
    rx, ry = x - st.x[b], y - st.y[b]
    acc.Q[3 * b] += fx
    acc.Q[3 * b + 1] += fy
    acc.Q[3 * b + 2] += rx * fy - ry * fx


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
