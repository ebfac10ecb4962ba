"""Joint friction on the general path of ``simulate`` (body coordinates).

The joints' friction is the one the force analysis models (see
:mod:`mechsolve.core.friction` and ``docs/guide/friction.md``): a revolute's friction
circle (a moment ``rho |F|``, ``rho = f r``), a slider's ``f |N|`` along its line, each
with an optional viscous part ``c |slip|``, opposing the joint's slip (its
:meth:`~mechsolve.joints.base.Constraint.slip`). In a simulation Coulomb's part is
regularised through a standstill of the joint, the same function as on the reduced
path but of each joint's own slip::

    t_j = k_j tanh(|slip_j| / v_j) L_j(lambda) + c_j |slip_j|

with ``k_j`` the Coulomb factor (``rho`` or ``f``), ``L_j`` the load Coulomb's law
multiplies (``|F|`` or ``|N|``, from the joint's multipliers) and ``v_j`` the smoothing
speed: :data:`SMOOTHING` (rad/s) for a revolute's relative angular speed, that times the
mechanism's size (m/s) for a slider's sliding speed. The friction is continuous in the
state, so that the integrator's error control holds; near a standstill (a few ``v_j``)
it fades to zero, which lets a joint that Coulomb's law would hold creep at a speed of
order ``v_j`` instead (a stick-slip-free model).

The multipliers depend on the friction and the friction on the multipliers. At every
evaluation the augmented system ``[M Phi_r^T; Phi_r 0] [q''; lambda] = [Q + sum_j t_j
g_j; gamma]`` (``g_j`` the generalised force of a unit friction at joint ``j`` opposing
its slip) is linear in the magnitudes ``t``, so it is solved once for the loads and once
per unit friction (one factorisation, several right-hand sides), and the magnitudes by
Newton's method on ``t - k tanh() L(lambda(t)) - c |slip| = 0`` (Jacobian ``I - G``,
``G_ji = k_j tanh_j (dL_j / dlambda) . Lambda_i``) to a relative :data:`TOLERANCE`.
The power of the friction ``sum_j t_j g_j . q' = -sum_j t_j |slip_j|`` is added to the
power of the non-conservative forces, so the energy balance ``T + V - W`` counts the
losses.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from mechsolve.base.state import State

#: The smoothing speed of a revolute's Coulomb friction (rad/s); a slider's is this
#: times the mechanism's size (m/s). Coulomb's part is tanh(|slip| / v) of its value.
SMOOTHING = 1e-3
TOLERANCE = 1e-12  # Newton's relative tolerance on each friction magnitude
MAX_ITERATIONS = 50


class JointFriction:
    """The friction of a :class:`~.multibody.Multibody`'s joints (those with a Coulomb or
    viscous part), solved with its multipliers at every evaluation.

    ``mb`` is the multibody model (its ``system``, ``nq``, ``nb``, ``nc``, ``scale``),
    ``fail(t, why)`` the exception raised where the motion cannot go on. ``last_Q`` is
    the generalised friction force (nq,) of the last evaluation, and ``last`` the
    joints' friction magnitudes there (N m or N)."""

    def __init__(self, mb: Any, fail: Callable[[float, str], Exception]) -> None:
        self.mb = mb
        self.fail = fail
        self.rows = [
            r for r in mb.system.rows if r.constraint.coulomb > 0 or r.constraint.viscous > 0
        ]
        self.smoothing = SMOOTHING
        self.last_Q = np.zeros(mb.nq)
        self.last = np.zeros(len(self.rows))

    @classmethod
    def of(cls, mb: Any, fail: Callable[[float, str], Exception]) -> JointFriction | None:
        """The friction of ``mb``'s joints, or None where every joint is ideal."""
        out = cls(mb, fail)
        return out if out.rows else None

    def describe(self) -> str:
        """The regularisation, in words, for the summary."""
        kinds = {r.constraint.slides for r in self.rows}
        parts = []
        if False in kinds:
            parts.append(f"{self.smoothing:.3g} rad/s in the pins")
        if True in kinds:
            parts.append(f"{self.smoothing * self.mb.scale:.3g} m/s in the sliders")
        return (
            "joint friction: Coulomb's part times tanh(|slip| / v_s), v_s = "
            + " and ".join(parts)
            + " (a joint slipping slower than a few v_s has less friction than Coulomb's)"
        )

    def speed(self, c) -> float:
        """The smoothing speed of constraint ``c``'s slip (rad/s, or m/s for a slider)."""
        return self.smoothing * (self.mb.scale if c.slides else 1.0)

    def laws(self, st: State) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """At a one-position state with rates: ``(g, k, v, slip)``: the generalised forces
        of a unit friction at each joint opposing its slip (K, nq), the regularised
        Coulomb factors ``k tanh(|slip| / v_s)``, the viscous frictions ``c |slip|`` and
        the slips."""
        nq, nb = self.mb.nq, self.mb.nb
        K = len(self.rows)
        g = np.zeros((K, nq))
        k, v, slip = np.zeros(K), np.zeros(K), np.zeros(K)
        for j, r in enumerate(self.rows):
            c = r.constraint
            s = float(c.slip(st)[0])
            slip[j] = s
            if s == 0.0 or not math.isfinite(s):
                continue  # no slip, no direction: no friction
            for body, x, y, fx, fy, t in c.friction_pull(st):
                if body == nb:
                    continue
                fx, fy = float(np.ravel(fx)[0]), float(np.ravel(fy)[0])
                dx = float(np.ravel(x)[0]) - st.x[body, 0]
                dy = float(np.ravel(y)[0]) - st.y[body, 0]
                g[j, 3 * body] += fx
                g[j, 3 * body + 1] += fy
                g[j, 3 * body + 2] += dx * fy - dy * fx + float(np.ravel(t)[0])
            k[j] = c.coulomb * math.tanh(abs(s) / self.speed(c))
            v[j] = c.viscous * abs(s)
        return g, k, v, slip

    def magnitudes(self, st: State, lam: np.ndarray) -> np.ndarray:
        """The friction magnitudes (K,) at a one-position state whose multipliers (of
        every equation) ``lam`` include the friction: the law read off them."""
        _, k, v, _ = self.laws(st)
        out = np.empty(len(self.rows))
        for j, r in enumerate(self.rows):
            c = r.constraint
            L, _ = c.load(lam[None, r.start : r.start + c.m])
            out[j] = k[j] * float(L[0]) + v[j]
        return out

    def solve(
        self,
        st: State,
        A: np.ndarray,
        b: np.ndarray,
        rows: np.ndarray,
        Jq: np.ndarray,
        M: np.ndarray,
        linear: Callable[[np.ndarray, np.ndarray], np.ndarray],
        qd: np.ndarray,
        t: float,
    ) -> tuple[np.ndarray, float]:
        """The augmented system's solution with friction and the friction's power.

        Parameters
        ----------
        st
            The state (positions and rates).
        A, b
            The augmented system without friction (its equations ``rows`` of all).
        Jq, M
            The constraint Jacobian (all equations) and the mass matrix.
        linear
            ``linear(A, B)``: the solution of ``A X = B`` for several right-hand sides.
        qd
            The rates (nq,), for the friction's power.
        t
            The time (for the message where the iteration fails).
        """
        mb = self.mb
        nq, nc = mb.nq, mb.nc
        g, k, v, slip = self.laws(st)
        on = np.flatnonzero(np.any(g != 0.0, axis=1))
        K = len(self.rows)
        rhs = np.zeros((len(b), 1 + on.size))
        rhs[:, 0] = b
        rhs[:nq, 1:] = g[on].T
        X = linear(A, rhs)
        if not np.all(np.isfinite(X)):
            raise self.fail(
                t, "the accelerations are not determined (a massless link that can move?)"
            )
        # the multipliers of every equation, linear in the magnitudes
        if len(rows) == nc:
            lam = np.zeros((nc, 1 + on.size))
            lam[rows] = X[nq:]
        else:  # redundant equations: the minimum-norm multipliers, as reported
            F = rhs[:nq] - M @ X[:nq]
            lam = np.linalg.lstsq(Jq.T, F, rcond=1e-10)[0]
        tt = np.zeros(K)
        if on.size:
            tt[on] = self._newton(lam, k[on], v[on], on, t)
        x = X[:, 0] + X[:, 1:] @ tt[on]
        Qf = g.T @ tt
        self.last_Q = Qf
        self.last = tt
        return x, float(Qf @ qd)

    def _newton(self, lam, k, v, on, t) -> np.ndarray:
        """The magnitudes of the joints ``on`` (with slip): Newton on
        ``s - k L(lambda0 + Lambda s) - v = 0`` from the viscous frictions."""
        n = on.size
        s = v.copy()
        big = np.max(np.abs(lam[:, 0]), initial=0.0)
        eye = np.eye(n)
        for _ in range(MAX_ITERATIONS):
            lm = lam[:, 0] + lam[:, 1:] @ s
            L = np.empty(n)
            G = np.zeros((n, n))
            for a, j in enumerate(on):
                r = self.rows[j]
                c = r.constraint
                sl = slice(r.start, r.start + c.m)
                Lj, grad = c.load(lm[None, sl])
                L[a] = float(Lj[0])
                G[a] = k[a] * (grad[0] @ lam[sl, 1:])
            F = s - k * L - v
            try:
                ds = np.linalg.solve(eye - G, -F)
            except np.linalg.LinAlgError:
                break
            s = s + ds
            if np.all(np.abs(ds) <= TOLERANCE * (np.abs(s) + k * big + v + 1e-300)):
                # physical where connected to the frictionless solution (as in the force
                # analysis, mechsolve.core.friction): det(I - G) > 0
                if np.linalg.det(eye - G) > 0:
                    return s
                break
        raise self.fail(
            t,
            f"the joints' friction has no solution with the reactions at t = {t:.6g} s: "
            "the friction feeds back on the reactions more than it can (too large a "
            "friction coefficient or journal radius for this motion, or a position next "
            "to a singular one, where the reactions to a friction grow without bound: "
            "the joints jam)",
        )

    def columns(self, st: State, lam: np.ndarray) -> list[tuple[str, str, np.ndarray]]:
        """``(name, unit, values)`` of every joint's friction magnitude and friction
        power, and the total power lost, along a trajectory's states ``st`` (N
        positions) and multipliers ``lam`` (N, nc)."""
        n = lam.shape[0]
        fr = np.zeros((n, len(self.rows)))
        slips = np.zeros((n, len(self.rows)))
        for i in range(n):
            one = _one(st, i)
            fr[i] = self.magnitudes(one, lam[i])
            slips[i] = [float(r.constraint.slip(one)[0]) for r in self.rows]
        out = []
        for j, r in enumerate(self.rows):
            c = r.constraint
            unit = "N" if c.slides else "N*m"
            out.append((f"{c.name}.friction", unit, fr[:, j]))
            out.append((f"{c.name}.friction_power", "W", fr[:, j] * np.abs(slips[:, j])))
        out.append(("power.friction", "W", np.sum(fr * np.abs(slips), axis=1)))
        return out


def _one(st: State, i: int) -> State:
    """Position ``i`` of a state over N positions, as a one-position state."""
    from mechsolve.base.state import State

    nb = st.nb
    one = State(nb, 1)
    for name in ("x", "y", "th", "c", "s", "vx", "vy", "w", "ax", "ay", "al"):
        getattr(one, name)[:nb, 0] = getattr(st, name)[:nb, i]
    return one
