"""Kinematic state of every body at many positions at once.

Each moving link is a rigid body with pose ``(x, y, theta)``: the global position of the
origin of its frame and the angle of its frame's x axis. A :class:`State` holds these
and their first and second time derivatives as arrays of shape ``(n_bodies + 1, N)``
over N positions; the last row is the ground (always at rest, ``theta = 0``).

Point kinematics follow from the body's: for a point with local coordinates ``s``,
``r = r_body + A(theta) s``, ``v = v_body + omega k x (A s)``,
``a = a_body + alpha k x (A s) - omega^2 (A s)``.
"""

from __future__ import annotations

import numpy as np


class State:
    """Poses, velocities and accelerations of all bodies over N positions."""

    __slots__ = (
        "nb",
        "n",
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

    def __init__(self, nb: int, n: int) -> None:
        self.nb = nb
        self.n = n
        shape = (nb + 1, n)
        self.x = np.zeros(shape)
        self.y = np.zeros(shape)
        self.th = np.zeros(shape)
        self.c = np.ones(shape)
        self.s = np.zeros(shape)
        self.vx = np.zeros(shape)
        self.vy = np.zeros(shape)
        self.w = np.zeros(shape)
        self.ax = np.zeros(shape)
        self.ay = np.zeros(shape)
        self.al = np.zeros(shape)

    @property
    def ground(self) -> int:
        return self.nb

    def set_angle(self, i: int, th: np.ndarray, idx=slice(None)) -> None:
        """Set body ``i``'s angle (and its cosine and sine)."""
        self.th[i, idx] = th
        self.c[i, idx] = np.cos(th)
        self.s[i, idx] = np.sin(th)

    def take(self, idx) -> State:
        """A new state holding only the positions ``idx``."""
        out = State.__new__(State)
        out.nb = self.nb
        for name in State.__slots__[2:]:
            setattr(out, name, getattr(self, name)[:, idx].copy())
        out.n = out.x.shape[1]
        return out

    def put(self, idx, other: State) -> None:
        """Copy ``other``'s positions into positions ``idx`` of this state."""
        for name in State.__slots__[2:]:
            getattr(self, name)[:, idx] = getattr(other, name)

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
    def rotated(self, i: int, s: np.ndarray, idx=slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """Global components of the local vector ``s`` on body ``i``."""
        c = self.c[i, idx]
        sn = self.s[i, idx]
        return c * s[0] - sn * s[1], sn * s[0] + c * s[1]

    def point(self, i: int, s: np.ndarray, idx=slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """Global position of the point with local coordinates ``s`` on body ``i``."""
        if s[0] == 0.0 and s[1] == 0.0:
            return self.x[i, idx], self.y[i, idx]
        rx, ry = self.rotated(i, s, idx)
        return self.x[i, idx] + rx, self.y[i, idx] + ry

    def point_velocity(
        self, i: int, s: np.ndarray, idx=slice(None)
    ) -> tuple[np.ndarray, np.ndarray]:
        if s[0] == 0.0 and s[1] == 0.0:
            return self.vx[i, idx], self.vy[i, idx]
        rx, ry = self.rotated(i, s, idx)
        w = self.w[i, idx]
        return self.vx[i, idx] - w * ry, self.vy[i, idx] + w * rx

    def point_acceleration(
        self, i: int, s: np.ndarray, idx=slice(None)
    ) -> tuple[np.ndarray, np.ndarray]:
        if s[0] == 0.0 and s[1] == 0.0:
            return self.ax[i, idx], self.ay[i, idx]
        rx, ry = self.rotated(i, s, idx)
        w2 = self.w[i, idx] ** 2
        al = self.al[i, idx]
        return self.ax[i, idx] - al * ry - w2 * rx, self.ay[i, idx] + al * rx - w2 * ry
