"""Rates at singular positions: the limits along the followed motion.

:class:`SingularRates` is a part of :class:`~mechsolve.core.sweep.Analysis`.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.base.numerics import limit_from_both_sides
from mechsolve.base.state import State
from mechsolve.core.conditioning import (
    NEAR_SINGULAR_INDICATOR,
    NEAR_SINGULAR_RCOND,
    SINGULAR_INDICATOR,
    SINGULAR_RCOND,
    near_singular,
)
from mechsolve.core.solution import Solution
from mechsolve.groups import NewtonGroup


class SingularRates:
    """Methods of :class:`~mechsolve.core.sweep.Analysis`: see the module docstring."""

    def _downstream(self) -> list[set[int]]:
        """For each group of the plan, its bodies and those of every later group that
        depends on them (through a joint, directly or through other groups)."""
        if getattr(self, "_down", None) is None:
            down = []
            for gi, g in enumerate(self.plan):
                bodies = set(g.bodies)
                for h in self.plan[gi + 1 :]:
                    touches = {b for c in h.constraints for b in (c.a, c.b)}
                    if touches & bodies:
                        bodies |= set(h.bodies)
                down.append(bodies)
            self._down = down
        return self._down

    def _rates_at_singular(
        self, sol: Solution, velocity: bool, acceleration: bool, per_unit_driver: bool
    ) -> None:
        """Rates at the positions where a group is singular or near it (a toggle or a
        bifurcation point: the sine of a loop's transmission angle below
        ``NEAR_SINGULAR_INDICATOR``, or a Newton group's reciprocal condition number below
        ``NEAR_SINGULAR_RCOND``; see :mod:`mechsolve.core.conditioning` for the measurements).

        At a singular position the differentiated constraints do not determine the rates
        (0 / 0 in the group's formulas, rounding noise in practice); next to it they carry
        the pose's rounding amplified by 1/s^2 (accelerations 1/s^3). The motion the
        sweep follows is
        smooth through such a point, so its rates are their limits: the analytic rates
        are evaluated at ``u -+ d`` and ``u -+ 2d`` on the followed branches and
        extrapolated to ``u`` (Richardson, error O(d^4)); at the first or last sample of
        a sweep, from the side the sweep follows (``u + d ... u + 4d``, cubic). ``d`` is
        5e-3 rad, or 5e-3 of the mechanism's size for a linear driver: rounding grows
        near the singular point as d shrinks (about eps / d^3 in accelerations), the
        extrapolation error as d^4; the limits are good to about 1e-9 of the rates'
        natural sizes. A Newton group's points on each side are reached by continuation
        from the neighbouring sample on that side, which lies on the followed motion.
        Where the motion does not exist on both sides (a limit position of a driven
        rocker: the rates grow without bound) or the two sides disagree, the computed
        rates are kept where the group is only near singular (they are large there, and
        right), and below ``SINGULAR_INDICATOR`` / ``SINGULAR_RCOND`` the rates of the
        singular group and of the groups that depend on it stay NaN; the other rates
        (the driver's, groups before it or beside it) keep their values.
        """
        sing_by, newton, deep = self._singular_positions(sol)
        sol.rates_undetermined = []
        if not sing_by:
            return
        st = sol.state
        rows = slice(5, 8) if not acceleration else slice(5, 11)
        d = 5e-3 * (self.scale if self.linear else 1.0)
        kind = self._rate_sizes(rows, per_unit_driver)
        down = self._downstream()
        kw = dict(
            start=sol.start,
            velocity=velocity,
            acceleration=acceleration,
            per_unit_driver=per_unit_driver,
            limits=False,
        )
        n = len(sol.u)
        for i, groups in sorted(sing_by.items()):
            one_sided = n > 1 and i in (0, n - 1)
            if one_sided:
                r = self._samples_on_one_side(sol, i, d, bool(newton[i]), kw)
            else:  # (past the sweep's ends too: a branch it did not follow is not smooth)
                r = self._samples_on_both_sides(sol, i, d, bool(newton[i]), kw)
            bodies = sorted(set().union(*(down[gi] for gi in groups)))
            blank = (sol, i, rows, bodies, bool(deep[i]), self._transmission(sol, groups, i), kind)
            if r is None:
                self._undetermined(*blank)
                continue
            self._pose_by_limit(st, i, r[:3], one_sided)
            r = r[rows]
            if one_sided:
                if self._cubic_limit(st, i, r, rows, kind):
                    sol.rates_by_limit.append(int(i))
                else:  # not smooth there: the rates grow without bound (a limit position)
                    self._undetermined(*blank)
                continue
            if not self._two_sided_limit(sol, i, r, rows, kind, bool(deep[i])):
                if not newton[i] and self._one_sided(sol, i, d, rows, kind, kw, blank[5]):
                    sol.rates_by_limit.append(int(i))
                else:
                    self._undetermined(*blank)
        st.token = State.new_token()

    def _singular_positions(
        self, sol: Solution
    ) -> tuple[dict[int, list[int]], np.ndarray, np.ndarray]:
        """The solved positions where groups are singular or near it: position -> its
        (near) singular groups; where a Newton group is among them; where a group is
        singular to rounding (no value there but a limit)."""
        ind = sol.indicator
        st = sol.state
        n = len(sol.u)
        sing_by: dict[int, list[int]] = {}  # position -> its (near) singular groups
        newton = np.zeros(n, bool)
        deep = np.zeros(n, bool)  # singular to rounding: no value but a limit
        for gi, g in enumerate(self.plan):
            if g.n_modes == 2 and gi < len(ind):
                if not n or ind[gi].min() > NEAR_SINGULAR_INDICATOR:
                    continue  # far from singular everywhere (a NaN: the full test)
                where = ind[gi] <= NEAR_SINGULAR_INDICATOR
                deep |= ind[gi] <= SINGULAR_INDICATOR
            elif isinstance(g, NewtonGroup):
                # a Newton solve stops within the square root of the rounding error of
                # a singular point, so its block is only nearly singular there
                where = near_singular(g, st, NEAR_SINGULAR_RCOND)
                if where.any():
                    deep |= near_singular(g, st, SINGULAR_RCOND)
                newton |= where & sol.ok
            else:
                continue
            for i in np.flatnonzero(where & sol.ok):
                sing_by.setdefault(int(i), []).append(gi)
        return sing_by, newton, deep

    def _rate_sizes(self, rows: slice, per_unit_driver: bool) -> np.ndarray:
        """The natural sizes of the rates ``rows`` (a column), for telling a jump from
        rounding."""
        ws = (1.0 if per_unit_driver else abs(self.speed)) / (self.scale if self.linear else 1.0)
        kind = np.array([self.scale * ws, self.scale * ws, ws] + [self.scale * ws * ws] * 2)
        return np.append(kind, ws * ws)[rows.start - 5 : rows.stop - 5, None]  # rows 5.. of a block

    def _samples_on_one_side(
        self, sol: Solution, i: int, d: float, newton: bool, kw
    ) -> np.ndarray | None:
        """The first or last sample: the followed motion lies on one side only. The
        blocks at ``u + d ... u + 4d`` into the sweep (nearest first), or None."""
        ui = float(sol.u[i])
        into = math.copysign(1.0, sol.u[1] - sol.u[0]) * (1 if i == 0 else -1)
        d = _within(sol, i, d, 4.0, (into,))
        if d is None:
            return None
        x = ui + into * d * np.arange(1.0, 5.0)
        if newton:
            k = i + 1 if i == 0 else i - 1  # continue from the neighbour inward
            side = self._side_solve(sol, k, x[::-1], kw)
            return None if side is None else side.block[:, :, ::-1]
        near = self.solve(x, near=(sol, int(i)), **kw)
        return near.state.block if near.ok.all() else None

    def _samples_on_both_sides(
        self, sol: Solution, i: int, d: float, newton: bool, kw
    ) -> np.ndarray | None:
        """The blocks at ``u - d, u + d, u - 2d, u + 2d`` on the followed branches (a
        Newton group's reached by continuation from the neighbouring sample on each
        side), or None."""
        ui = float(sol.u[i])
        if newton:
            lo = self._side_solve(sol, i - 1, ui - d * np.array([2.0, 1.0]), kw)
            hi = self._side_solve(sol, i + 1, ui + d * np.array([2.0, 1.0]), kw)
            if lo is None or hi is None:
                return None
            a, b = lo.block, hi.block
            return np.stack([a[:, :, 1], b[:, :, 1], a[:, :, 0], b[:, :, 0]], axis=2)
        near = self.solve(ui + d * np.array([-1.0, 1.0, -2.0, 2.0]), near=(sol, i), **kw)
        return near.state.block if near.ok.all() else None

    def _transmission(self, sol: Solution, groups: list[int], i: int) -> float | None:
        """The smallest indicator (the sine of a loop's transmission angle) of the closed-form
        ``groups`` at position ``i``; None if none of them is a closed form."""
        ind = sol.indicator
        s = [float(ind[g][i]) for g in groups if self.plan[g].n_modes == 2 and g < len(ind)]
        return min(s) if s else None

    @staticmethod
    def _undetermined(
        sol: Solution,
        i: int,
        rows: slice,
        bodies: list[int],
        deep: bool,
        s: float | None = None,
        kind: np.ndarray | None = None,
    ) -> None:
        """No limit: near a singular position the computed rates are right (and large)
        unless the pose's rounding, amplified by ``1/s^2`` in velocities and ``1/s^3`` in
        accelerations (``s`` the loop's transmission sine), exceeds 1e-6 of their size
        (each body's largest rate of that order, in its natural size ``kind``, or that
        size); those, and all of them at the singular position (to rounding), are left
        blank."""
        if deep:
            sol.state.block[rows, bodies, i] = np.nan
            sol.rates_undetermined.append(int(i))
            return
        if s is None or kind is None or not s > 0:
            return
        blk = sol.state.block[rows, :, i][:, bodies]
        power = np.array([2.0, 2.0, 2.0, 3.0, 3.0, 3.0])[: blk.shape[0], None]
        sizes = np.asarray(kind, float).reshape(-1, 1)
        rounding = np.finfo(float).eps * sizes / s**power
        # against the size of the body's rates of that order (its velocities, or its
        # accelerations: the rounding is the body's motion's, and a frame origin on a
        # ground pivot, at rest, or a small component is right to the digits of the
        # largest; each in its natural size)
        rel = np.abs(blk) / sizes
        bad = np.zeros(blk.shape, bool)
        for order in (slice(0, 3), slice(3, 6)):
            part = rel[order]
            if not part.size:
                continue
            big = np.maximum(np.max(part, axis=0, initial=0.0), 1.0)  # (nan: blank)
            bad[order] = ~(rounding[order] <= 1e-6 * big * sizes[order])
        if bad.any():
            blk[bad] = np.nan
            sol.state.block[rows, bodies, i] = blk
            sol.rates_undetermined.append(int(i))

    @staticmethod
    def _cubic_limit(st: State, i: int, r: np.ndarray, rows: slice, kind: np.ndarray) -> bool:
        """The rates at ``i`` by cubic extrapolation from ``r`` (the rates at ``u + d ...
        u + 4d`` on one side), if it agrees with the quadratic one; False if not."""
        est = SingularRates._cubic(r, kind)
        if est is None:
            return False
        st.block[rows, :, i] = est
        return True

    @staticmethod
    def _cubic(r: np.ndarray, kind: np.ndarray) -> np.ndarray | None:
        """The cubic extrapolation of ``r`` (the rates at ``u + d ... u + 4d``) to ``u``,
        None where it disagrees with the quadratic one."""
        est = r @ np.array([4.0, -6.0, 4.0, -1.0])
        quad = r[:, :, :3] @ np.array([3.0, -3.0, 1.0])
        return est if np.all(np.abs(est - quad) <= 1e-3 * np.abs(est) + 1e-6 * kind) else None

    @staticmethod
    def _two_sided_limit(
        sol: Solution, i: int, r: np.ndarray, rows: slice, kind: np.ndarray, deep: bool
    ) -> bool:
        """The rates at ``i`` from the rates ``r`` at ``u -+ d`` and ``u -+ 2d``
        (Richardson): False where the two sides disagree (a jump, not a smooth motion)."""
        st = sol.state
        lo1, hi1, lo2, hi2 = (r[:, :, k] for k in range(4))
        # a smooth motion changes twice as much over 4d as over 2d; a jump does not
        smooth = np.abs((hi2 - lo2) - 2.0 * (hi1 - lo1)) <= (
            0.1 * np.abs(hi2 - lo2) + 1e-6 * kind + 1e-300
        )
        if not smooth.all():
            return False
        est = limit_from_both_sides(lo1, hi1, lo2, hi2)
        if not deep:
            # near (not at) a singular position: the computed values are kept where
            # they agree with the limit to within the limit's own error (bounded by
            # its difference from the plain mean of the two sides, and 1e-6 of the
            # rates' size: near a kite's fold the limit itself is good to only about
            # that); where they do not, rounding amplified by 1/s^2 (1/s^3 for
            # accelerations) spoiled them, and the limit is taken
            comp = st.block[rows, :, i]
            err_lim = np.abs(est - 0.5 * (lo1 + hi1)) + 1e-6 * kind[:, 0][:, None]
            better = np.abs(comp - est) > err_lim
            st.block[rows, :, i] = np.where(better, est, st.block[rows, :, i])
            if better.any():
                sol.rates_by_limit.append(int(i))
        else:
            st.block[rows, :, i] = est
            sol.rates_by_limit.append(int(i))
        return True

    def _one_sided(self, sol: Solution, i: int, d: float, rows, kind, kw, s=None) -> bool:
        """The rates at position ``i`` as their limit from one side, the side the sweep
        comes from, else the one it goes to: cubic extrapolation from ``u -+ dd ... 4dd``,
        checked against the quadratic one, with ``dd`` = ``d``, or ``d/2``, ``d/4`` where
        the motion changes too fast for ``d`` (next to a change point). The side samples
        stay within the sweep (see :func:`_within`), and where the computed velocities at
        ``i`` are good (``s``, the loop's transmission sine, not singular to rounding) the
        limit's must agree with them: a side that crosses a change point lies on the
        branch the motion does not follow, smooth there but with other rates."""
        st = sol.state
        ui = float(sol.u[i])
        back = -math.copysign(1.0, sol.u[-1] - sol.u[0])
        for side in (back, -back):
            for dd in (d, d / 2, d / 4):
                dd = _within(sol, i, dd, 4.0, (side,), d)
                if dd is None:
                    break
                near = self.solve(ui + side * dd * np.arange(1.0, 5.0), near=(sol, int(i)), **kw)
                if not near.ok.all():
                    break
                est = self._cubic(near.state.block[rows], kind)
                if est is None:
                    continue
                if not _agrees(st.block[5:8, :, i], est[:3], kind[:3], s):
                    break  # the other branch: so are the shorter spacings
                st.block[rows, :, i] = est
                return True
        return False

    @staticmethod
    def _pose_by_limit(st: State, i: int, p: np.ndarray, one_sided: bool) -> None:
        """Poses left undetermined at position ``i`` (NaN: a loop whose outer joints
        coincide at the same position where an earlier group is singular too, so that
        the direction of the limit is not known there) as the limit of the poses ``p``
        next to it (x, y, angle; the same points as the rates)."""
        lost = ~np.all(np.isfinite(st.block[:3, :, i]), axis=0)
        if not lost.any():
            return
        q = p[:, lost, :].copy()
        q[2] = np.unwrap(q[2], axis=-1)
        if one_sided:
            est = q @ np.array([4.0, -6.0, 4.0, -1.0])
        else:
            est = limit_from_both_sides(q[..., 0], q[..., 1], q[..., 2], q[..., 3])
        st.block[:3, lost, i] = est

    def _side_solve(self, sol: Solution, k: int, x: np.ndarray, kw) -> State | None:
        """Positions ``x`` reached by continuation from solved sample ``k`` (which is
        solved again first, so that the march starts on its pose); None if sample ``k``
        was not solved or a position does not close."""
        if not (0 <= k < len(sol.u)) or not sol.ok[k]:
            return None
        near = self.solve(np.r_[sol.u[k], x], near=(sol, k), **kw)
        if not near.ok.all():
            return None
        return near.state.take(np.arange(1, len(x) + 1))


# the shortest spacing of the side samples of a limit, as a fraction of the usual one:
# the rounding of the rates next to a singular point grows as the spacing shrinks (about
# eps / d^3 in accelerations), 125 times at a fifth
SHORTEST_SPACING = 0.2


def _agrees(comp: np.ndarray, est: np.ndarray, kind: np.ndarray, s: float | None) -> bool:
    """Whether the limit ``est`` of the velocities agrees with those computed at the
    position, ``comp``, to within their rounding (``eps / s^2`` of their size ``kind``,
    ``s`` the transmission sine) and 1e-3; True where they are not known well enough to
    tell (singular to rounding, or ``s`` not known)."""
    if s is None or not s > SINGULAR_INDICATOR:
        return True
    size = np.maximum(np.abs(est), kind)
    return bool(np.all(np.abs(est - comp) <= (1e-3 + 100 * np.finfo(float).eps / s**2) * size))


def _within(
    sol: Solution, i: int, d: float, reach: float, sides, d0: float | None = None
) -> float | None:
    """The spacing of the side samples of a limit at position ``i`` that reach ``reach``
    spacings towards each of ``sides`` (-1: smaller driver values, +1: larger): ``d``, or
    less so that they stay within the sweep's motion, or None where that would be below
    ``SHORTEST_SPACING d``.

    Past the sweep's ends the sweep has not followed the motion: past a change point the
    solution on the same assembly branch is the other branch, not the continuation (a
    sweep stopping 0.001 deg short of a four-bar's change point took the rates of the
    branch it does not follow for 77 positions)."""
    u = np.asarray(sol.u, float)[np.asarray(sol.ok, bool)]
    if len(sol.u) < 2:
        return d  # one position: no sweep to stay within
    ui = float(sol.u[i])
    room = {-1.0: ui - float(u.min()), 1.0: float(u.max()) - ui}
    dd = min([d] + [room[float(s)] / reach for s in sides])
    return dd if dd >= SHORTEST_SPACING * (d0 or d) else None
