"""Kinematic state of every body at many positions at once.

Each moving link is a rigid body with pose ``(x, y, theta)``: the global position of the
origin of its frame and the angle of its frame's x axis. A :class:`State` holds these
and their first and second time derivatives as arrays of shape ``(n_bodies + 1, N)``
over N positions; the last row is the ground (always at rest, ``theta = 0``).

Point kinematics follow from the body's: for a point with local coordinates ``s``,
``r = r_body + A(theta) s``, ``v = v_body + omega k x (A s)``,
``a = a_body + alpha k x (A s) - omega^2 (A s)``.

A local vector ``s`` is a pair ``(2,)``, or ``(2, N)`` with one vector per position when
designs that differ only in their numbers are solved as one batch
(:mod:`mechsolve.analyses.batch`).
"""

from __future__ import annotations

import numpy as np

# read-only constant arrays shared by all states, by (value, length): see State._const
_CONSTS: dict[tuple[float, int], np.ndarray] = {}


class State:
    """Poses, velocities and accelerations of all bodies over N positions."""

    __slots__ = (
        "nb",
        "n",
        "token",
        "consts",
        "block",
        "x",
        "y",
        "th",
        "c",
        "s",
        "vx",
        "vy",
        "w",
        "ax",
        "ay",
        "al",
    )

    _count = 0

    @staticmethod
    def new_token() -> int:
        """A fresh token: the state's content changed, group caches must not be reused."""
        State._count += 1
        return State._count

    def __init__(self, nb: int, n: int, written: int = 0) -> None:
        """``written``: how many of the arrays, in the order of :attr:`ARRAYS`, the
        caller fills for every body at every position (the closed-form groups write
        whole rows): those rows are not zeroed first. The ground's rows always are."""
        self.nb = nb
        self.n = n
        State._count += 1
        self.token = State._count  # tells group caches which state they belong to
        self.consts: dict = {}
        # one block for all arrays: a single zeroed allocation is far cheaper than eleven
        if written <= 0:
            block = np.zeros((11, nb + 1, n))
        else:  # (zeroing a block of 3600 positions costs some 30 us: not for rows written)
            block = np.empty((11, nb + 1, n))
            block[:written, nb] = 0.0
            block[written:] = 0.0
        self._unpack(block)
        self.c[nb] = 1.0  # the ground's frame; the bodies' are set by their groups

    def _unpack(self, block: np.ndarray) -> None:
        self.block = block
        (
            self.x,
            self.y,
            self.th,
            self.c,
            self.s,
            self.vx,
            self.vy,
            self.w,
            self.ax,
            self.ay,
            self.al,
        ) = block

    @property
    def ground(self) -> int:
        return self.nb

    def set_angle(self, i: int, th: np.ndarray, idx=slice(None), period: int = 0) -> None:
        """Set body ``i``'s angle (and its cosine and sine). ``period``: the angles repeat
        every ``period`` positions (see :class:`~mechsolve.groups.base.Drive`), so the
        cosine and sine of the first period are repeated, not computed again."""
        if isinstance(idx, slice) and idx == slice(None):  # in place: no temporaries
            self.th[i] = th
            if 0 < period < self.n and self.n % period == 0:
                for f, out in ((np.cos, self.c[i]), (np.sin, self.s[i])):
                    rows = out.reshape(-1, period)
                    f(self.th[i, :period], out=rows[0])
                    rows[1:] = rows[0]
                return
            np.cos(self.th[i], out=self.c[i])
            np.sin(self.th[i], out=self.s[i])
            return
        self.th[i, idx] = th
        self.c[i, idx] = np.cos(th)
        self.s[i, idx] = np.sin(th)

    ARRAYS = ("x", "y", "th", "c", "s", "vx", "vy", "w", "ax", "ay", "al")

    def take(self, idx) -> State:
        """A new state holding only the positions ``idx``."""
        out = State.__new__(State)
        out.nb = self.nb
        out.token = State.new_token()
        out.consts = {}
        block = self.block[:, :, idx]
        if isinstance(idx, slice):
            block = block.copy()
        out._unpack(block)
        out.n = block.shape[2]
        return out

    def put(self, idx, other: State) -> None:
        """Copy ``other``'s positions into positions ``idx`` of this state."""
        self.block[:, :, idx] = other.block
        self.token = State.new_token()  # its content changed: caches are stale

    def q(self) -> np.ndarray:
        """Generalised coordinates as an array (N, 3 * nb): x0, y0, th0, x1, ..."""
        return (
            np.stack([self.x[:-1], self.y[:-1], self.th[:-1]], axis=-1)
            .reshape(self.nb * 3, self.n)
            .T
            if self.nb
            else np.zeros((self.n, 0))
        )

    # -- points ----------------------------------------------------------------------
    # The ground (row nb) is at rest with the identity frame, and many local vectors are
    # zero (a link's frame at one of its joints): both have fast paths, which return
    # read-only arrays kept per state (broadcast views beyond a few positions).
    def _const(self, v: float, idx) -> np.ndarray:
        n = self.n if isinstance(idx, slice) and idx == slice(None) else len(self.x[0, idx])
        key = (v, n)
        arr = self.consts.get(key)
        if arr is None:
            # read-only, so one array per value and length serves every state (a
            # broadcast view costs some microseconds to make: several per solve)
            arr = _CONSTS.get(key)
            if arr is None:
                if n <= 8:  # a few positions: a plain array is cheaper to compute with
                    arr = np.full(n, float(v))
                    arr.flags.writeable = False  # shared, as the views are
                else:
                    arr = np.broadcast_to(np.float64(v), (n,))
                if len(_CONSTS) >= 512:  # bounded: the local points of the models in use
                    _CONSTS.clear()
                _CONSTS[key] = arr
            self.consts[key] = arr
        return arr

    def rotated(self, i: int, s: np.ndarray, idx=slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """Global components of the local vector ``s`` on body ``i``."""
        if s.ndim > 1:  # one local vector per position (designs solved as one batch)
            s0, s1 = s[0, idx], s[1, idx]
            if i == self.nb:
                return s0, s1
            c = self.c[i, idx]
            sn = self.s[i, idx]
            if not s1.any():  # along the frame's x axis in every design (as below)
                return c * s0, sn * s0
            return c * s0 - sn * s1, sn * s0 + c * s1
        if i == self.nb:
            return self._const(s[0], idx), self._const(s[1], idx)
        if s[1] == 0.0:  # along the frame's x axis (the usual frame: x along the link)
            if s[0] == 0.0:
                z = self._const(0.0, idx)
                return z, z
            # A s = (c s0, sn s0): the products by zero dropped (the same values, but
            # for the sign of a zero)
            return self.c[i, idx] * s[0], self.s[i, idx] * s[0]
        c = self.c[i, idx]
        sn = self.s[i, idx]
        return c * s[0] - sn * s[1], sn * s[0] + c * s[1]

    def point(self, i: int, s: np.ndarray, idx=slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """Global position of the point with local coordinates ``s`` on body ``i``."""
        if i == self.nb:
            return self.rotated(i, s, idx)
        if s.ndim == 1 and s[0] == 0.0 and s[1] == 0.0:
            return self.x[i, idx], self.y[i, idx]
        rx, ry = self.rotated(i, s, idx)
        return self.x[i, idx] + rx, self.y[i, idx] + ry

    def point_velocity(
        self, i: int, s: np.ndarray, idx=slice(None), arm=None
    ) -> tuple[np.ndarray, np.ndarray]:
        """``arm``: ``rotated(i, s, idx)`` when the caller has it already."""
        if i == self.nb:
            z = self._const(0.0, idx)
            return z, z
        if s.ndim == 1 and s[0] == 0.0 and s[1] == 0.0:
            return self.vx[i, idx], self.vy[i, idx]
        rx, ry = self.rotated(i, s, idx) if arm is None else arm
        w = self.w[i, idx]
        return self.vx[i, idx] - w * ry, self.vy[i, idx] + w * rx

    def point_acceleration(
        self, i: int, s: np.ndarray, idx=slice(None)
    ) -> tuple[np.ndarray, np.ndarray]:
        if i == self.nb:
            z = self._const(0.0, idx)
            return z, z
        if s.ndim == 1 and s[0] == 0.0 and s[1] == 0.0:
            return self.ax[i, idx], self.ay[i, idx]
        rx, ry = self.rotated(i, s, idx)
        w2 = self.w[i, idx] ** 2
        al = self.al[i, idx]
        return self.ax[i, idx] - al * ry - w2 * rx, self.ay[i, idx] + al * rx - w2 * ry


def scale_rates(st: State, ud: np.ndarray, udd: np.ndarray, acceleration: bool = True) -> None:
    """Turn rates per unit driver coordinate (``q'``, ``q''``) into time rates, in place."""
    vel = st.block[5:8]  # vx, vy, w of every body
    acc = st.block[8:11]  # ax, ay, al
    ud = np.asarray(ud, float)
    udd = np.asarray(udd, float)
    if ud.ndim == 0 and udd.ndim == 0:  # one speed for every position (no array tests)
        constant = float(udd) == 0.0
    else:
        constant = bool(ud.size and np.all(ud == ud.flat[0]) and not np.any(udd))
    if constant:
        w = float(ud.flat[0])  # a constant speed: two scalar products, as the sweep does
        if acceleration and w != 1.0:
            acc *= w * w
        if w != 1.0:
            vel *= w
    else:
        ud = np.broadcast_to(ud, (st.n,))
        udd = np.broadcast_to(udd, (st.n,))
        if acceleration:
            acc *= ud * ud
            acc += vel * udd
        vel *= ud
    st.token = State.new_token()
