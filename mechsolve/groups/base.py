"""The contract every group solver keeps.

A *group* is a set of bodies whose poses follow from bodies solved before it (and from
the driver). Groups are solved in order; each reads only the rows of the
:class:`~mechsolve.base.state.State` of earlier groups and writes only its own bodies' rows.

Contract of a subclass:

``position(st, drive, mode)``
    Fill ``x, y, th, c, s`` of the group's bodies at all N positions. ``mode`` selects the
    assembly branch (+1 or -1, a scalar or an array over positions) for groups with
    ``n_modes == 2``. Return ``(ok, indicator)``: ``ok`` is False where the group cannot
    close (its rows are then NaN); ``indicator`` in [0, 1] measures how far the group is
    from a singular (toggle) configuration, 0 being singular.
``disc(st)``
    For groups with two branches: a discriminant that vanishes at the singular
    configurations where the branches meet, and its rate (see :meth:`Group.disc`).
``velocity(st, drive)`` / ``acceleration(st, drive)``
    Fill ``vx, vy, w`` / ``ax, ay, al`` of the group's bodies, given earlier groups'.
    They solve exactly ``Phi_q qdot = nu`` and ``Phi_q qddot = gamma`` restricted to the
    group, with explicit formulas where the group is recognised.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mechsolve.base.state import State
from mechsolve.joints.base import Constraint


def metres(x: float) -> str:
    """A length in m in words (the default of :meth:`Group.fail_reason`)."""
    return f"{x:.6g} m"


@dataclass
class Drive:
    """The driver coordinate and its first two time derivatives at N positions.

    ``period``: when positive, ``u`` repeats every ``period`` positions (designs solved
    as one batch, each over the same driver values): what depends on ``u`` alone is the
    same in every period and may be computed over one.
    """

    u: np.ndarray
    ud: np.ndarray
    udd: np.ndarray
    period: int = 0

    def take(self, idx) -> Drive:
        return Drive(self.u[idx], self.ud[idx], self.udd[idx])


class Group:
    """Base class; see the module docstring for the contract."""

    kind = "group"
    n_modes = 1

    def __init__(self, bodies: list[int], constraints: list[Constraint], names: list[str]) -> None:
        self.bodies = bodies
        self.constraints = constraints
        self.body_names = [names[b] for b in bodies]
        self.label = self.describe()

    def describe(self) -> str:
        joints = ", ".join(c.name for c in self.constraints)
        return f"{self.kind} group of {', '.join(self.body_names)} (joints {joints})"

    def position(self, st: State, drive: Drive, mode=1.0):
        raise NotImplementedError

    def velocity(self, st: State, drive: Drive) -> None:
        raise NotImplementedError

    def acceleration(self, st: State, drive: Drive) -> None:
        raise NotImplementedError

    def cache(self, st: State) -> dict:
        """Intermediate results shared by this group's passes over the same state (the
        discriminant, positions, velocities and accelerations reuse the solved ends)."""
        if getattr(self, "_ctoken", None) != st.token:
            self._ctoken = st.token
            self._cache = {}
        return self._cache

    # the entries of the cache that depend on the positions alone (see rates_rescaled)
    POSITION_KEYS: tuple[str, ...] = ()

    def rates_rescaled(self, old: int, new: int) -> None:
        """The state of token ``old`` had its rates rescaled in place (time derivatives
        from rates per unit driver coordinate), and is now token ``new``: the cached
        results that depend on its positions alone stay valid, the others are dropped."""
        if getattr(self, "_ctoken", None) != old:
            return
        c = self._cache
        self._cache = {k: c[k] for k in self.POSITION_KEYS if k in c}
        self._ctoken = new

    def disc(self, st: State) -> tuple[np.ndarray, np.ndarray] | None:
        """The group's discriminant and its rate, for branch groups (``n_modes == 2``).

        A smooth, dimensionless function of the already solved bodies that is positive
        where the group closes on two distinct branches, zero at a singular (toggle)
        configuration where the branches meet, and negative where it cannot close; and its
        time derivative from their velocities. Returns None for other groups.
        """
        return None

    def mode_text(self, st: State, mode: float, point_names: dict) -> str:
        """Describe branch ``mode`` in words (for ``mechsolve check``)."""
        return ""

    def mode_of_side(self, point: str, side: str, start: str, end: str, point_names: dict):
        """The branch that the condition ``point side of start -> end`` states, when it
        is exactly this group's own branch statement (so that it needs no evaluation);
        None otherwise."""
        return None

    def fail_reason(self, st: State, i: int, words: Callable[[float], str] = metres) -> str:
        """Why the group cannot close at position ``i`` (for messages); ``words``
        gives a length in m in words in the file's unit (``'74.1847 mm'``)."""
        return "the loop cannot close"


def is_zero(s) -> bool:
    """Whether the local vector ``s`` is the frame's origin (False for a batch of
    vectors, one per position: see :mod:`mechsolve.base.state`)."""
    return s.ndim == 1 and s[0] == 0.0 and s[1] == 0.0


def diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a - b`` of two local vectors, either of which may be a batch ``(2, N)``."""
    if a.ndim == b.ndim:
        return a - b
    return a.reshape(2, -1) - b.reshape(2, -1)


def length(v):
    """``|v|`` of a local vector (a float), or of a batch of them (an array)."""
    if np.ndim(v) > 1 and not v[1].any():  # a batch along x: hypot(x, 0) is |x| exactly
        return np.abs(v[0])
    r = np.hypot(v[0], v[1])
    return float(r) if np.ndim(r) == 0 else r


def set_pose_from_vectors(st: State, b: int, s0, sm, px, py, gx, gy) -> None:
    """Place body ``b`` so that its local vector ``sm - s0`` maps to global ``(gx, gy)``
    and its local point ``s0`` lies at ``(px, py)``.

    The rotation follows from the two vectors without trigonometry; the angle is then
    read with ``arctan2``.
    """
    ex, ey = sm[0] - s0[0], sm[1] - s0[1]
    c, s = st.c[b], st.s[b]
    if np.ndim(ey) == 0:
        l2 = ex * ex + ey * ey
        if ey == 0.0:  # the usual frame: x along the segment
            np.multiply(gx, ex / l2, out=c)
            np.multiply(gy, ex / l2, out=s)
        else:
            c[...] = (ex * gx + ey * gy) / l2
            s[...] = (ex * gy - ey * gx) / l2
    elif not ey.any():
        # a batch of designs whose frames all have x along the segment (lengths that
        # differ): the general formula's terms in ey are zeros, dropped (the same
        # values, but for the sign of a zero where g itself is zero); written in place
        l2 = ex * ex
        np.multiply(ex, gx, out=c)
        c /= l2
        np.multiply(ex, gy, out=s)
        s /= l2
    else:  # the general formula, in place (the same operations in the same order)
        l2 = ex * ex
        t = ey * ey
        l2 += t
        np.multiply(ex, gx, out=c)
        np.multiply(ey, gy, out=t)
        c += t
        c /= l2
        np.multiply(ex, gy, out=s)
        np.multiply(ey, gx, out=t)
        s -= t
        s /= l2
    np.arctan2(s, c, out=st.th[b])
    if is_zero(s0):
        st.x[b] = px
        st.y[b] = py
    else:
        st.x[b] = px - (c * s0[0] - s * s0[1])
        st.y[b] = py - (s * s0[0] + c * s0[1])


def body_velocity_from_point(st: State, b: int, s0, vpx, vpy, w) -> None:
    """Body ``b``'s frame velocity from its point ``s0``'s velocity and angular velocity."""
    st.w[b] = w
    if is_zero(s0):
        st.vx[b] = vpx
        st.vy[b] = vpy
        return
    rx, ry = st.rotated(b, s0)
    st.vx[b] = vpx + w * ry
    st.vy[b] = vpy - w * rx


def body_acceleration_from_point(st: State, b: int, s0, apx, apy, al) -> None:
    st.al[b] = al
    if is_zero(s0):
        st.ax[b] = apx
        st.ay[b] = apy
        return
    rx, ry = st.rotated(b, s0)
    w2 = st.w[b] ** 2
    st.ax[b] = apx + al * ry + w2 * rx
    st.ay[b] = apy - al * rx + w2 * ry


# --- force analysis helpers ------------------------------------------------------------
# R holds, per body, the generalised force (Fx, Fy, moment about the body's frame origin)
# of everything acting on it that is known so far: applied loads, inertia forces and the
# reactions of the groups solved after this one. A group computes the forces in its own
# joints and adds their reactions onto the bodies before it.


def resultant_about(st: State, R: np.ndarray, b: int, X, Y):
    """Body ``b``'s known force (Fx, Fy) and its moment about the global point (X, Y)."""
    fx, fy, t = R[3 * b], R[3 * b + 1], R[3 * b + 2]
    m = st.x[b] - X  # t + (x - X) fy - (y - Y) fx, in place (the same rounding)
    m *= fy
    m += t
    k = st.y[b] - Y
    k *= fx
    m -= k
    return fx, fy, m


def add_force(st: State, R: np.ndarray, b: int, X, Y, fx, fy) -> None:
    """Add a force (fx, fy) acting at the global point (X, Y) on body ``b``."""
    if b == st.nb:
        return
    R[3 * b] += fx
    R[3 * b + 1] += fy
    m = X - st.x[b]  # the moment (X - x) fy - (Y - y) fx, in place
    m *= fy
    k = Y - st.y[b]
    k *= fx
    m -= k
    R[3 * b + 2] += m


def pin_multiplier(joint, on: int, fx, fy):
    """The multipliers of a revolute joint (the force on its second link by its first)
    from the force (fx, fy) the joint exerts on body ``on``."""
    return (fx, fy) if joint.b == on else (-fx, -fy)
