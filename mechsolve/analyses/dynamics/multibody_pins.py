"""The equations of a mechanism whose joints are all pins, evaluated on arrays of all
the pins at once (the multibody integration evaluates them a few times per step at one
configuration, where the joint-by-joint path spends its time building states).

For pin ``k`` between bodies ``a`` and ``b`` at local points ``s_a``, ``s_b`` (the ground
is the body at rest at the origin)::

    Phi_k = r_a + R(theta_a) s_a - r_b - R(theta_b) s_b
    gamma_k = R(theta_a) s_a omega_a^2 - R(theta_b) s_b omega_b^2      (nu_k = 0)

the same equations, in the same rows, as :class:`~mechsolve.joints.revolute.
RevoluteConstraint` (tests/test_issue26_andrews.py compares them).
"""

from __future__ import annotations

import numpy as np


class Pins:
    """All pins' residual, Jacobian and ``gamma`` at one configuration.

    The index arrays are built once: the Jacobian's constant entries (the unit blocks of
    the bodies' positions) are kept in a template and only its angle columns are
    written at each configuration, by flat index."""

    def __init__(self, constraints: list, nb: int) -> None:
        self.nb, self.nq = nb, 3 * nb
        self.a = np.array([c.a for c in constraints])
        self.b = np.array([c.b for c in constraints])
        self.sa = np.array([c.sa for c in constraints], float)
        self.sb = np.array([c.sb for c in constraints], float)
        n = len(constraints)
        k = np.arange(n)
        self.rows_x, self.rows_y = 2 * k, 2 * k + 1
        self.moving_a, self.moving_b = self.a != nb, self.b != nb
        nq = self.nq
        self.template = np.zeros((2 * n, nq))
        flat = []
        for moving, body, sign in ((self.moving_a, self.a, 1.0), (self.moving_b, self.b, -1.0)):
            rx_, ry_, col = self.rows_x[moving], self.rows_y[moving], 3 * body[moving]
            self.template[rx_, col] = sign
            self.template[ry_, col + 1] = sign
            flat.append((rx_ * nq + col + 2, ry_ * nq + col + 2))
        (self.fa_x, self.fa_y), (self.fb_x, self.fb_y) = flat
        self._pa = np.maximum(self.template, 0.0)  # picks r_a of each pin
        self._pb = np.maximum(-self.template, 0.0)  # picks r_b
        self._ra, self._rb = np.empty(2 * n), np.empty(2 * n)
        self._th = np.zeros(nb + 1)
        self._we = np.zeros(nb + 1)
        # the pins whose end a (b) is on a moving body, by index
        self._ka, self._kb = np.flatnonzero(self.moving_a), np.flatnonzero(self.moving_b)
        self._sax, self._say = self.sa[:, 0].copy(), self.sa[:, 1].copy()
        self._sbx, self._sby = self.sb[:, 0].copy(), self.sb[:, 1].copy()
        self._arms_key: bytes | None = None
        self._arms_val: tuple = ()

    @staticmethod
    def applies(constraints: list) -> bool:
        return bool(constraints) and all(c.joins_points for c in constraints)

    def _arms(self, th: np.ndarray):
        """The rotated local points ``R(theta) s`` of both ends (``th``: the bodies'
        angles; the ground's is appended). Those of the last angles are kept: the
        residual, the Jacobian and ``gamma`` of one configuration ask for the same."""
        key = th.tobytes()
        if key == self._arms_key:
            return self._arms_val
        the = self._th
        the[: self.nb] = th  # the ground's stays 0
        c, s = np.cos(the), np.sin(the)
        ca, sa_, cb, sb_ = c[self.a], s[self.a], c[self.b], s[self.b]
        rax = ca * self._sax - sa_ * self._say
        ray = sa_ * self._sax + ca * self._say
        rbx = cb * self._sbx - sb_ * self._sby
        rby = sb_ * self._sbx + cb * self._sby
        self._arms_key, self._arms_val = key, (rax, ray, rbx, rby)
        return self._arms_val

    def residual(self, q: np.ndarray) -> np.ndarray:
        # the ends' body positions by matrix products (the ground's: the origin), summed
        # in the order (r_a + R s_a) - r_b - R s_b
        rax, ray, rbx, rby = self._arms(q[2::3])
        ra, rb = self._ra, self._rb
        ra[0::2], ra[1::2], rb[0::2], rb[1::2] = rax, ray, rbx, rby
        out = self._pa @ q
        out += ra
        out -= self._pb @ q
        out -= rb
        return out

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        rax, ray, rbx, rby = self._arms(q[2::3])
        J = self.template.copy()
        flat = J.reshape(-1)
        ma, mb = self._ka, self._kb
        flat[self.fa_x] = -ray[ma]
        flat[self.fa_y] = rax[ma]
        flat[self.fb_x] = rby[mb]
        flat[self.fb_y] = -rbx[mb]
        return J

    def gamma(self, th: np.ndarray, w: np.ndarray) -> np.ndarray:
        """``gamma`` from the bodies' angles ``th`` and angular velocities ``w``."""
        rax, ray, rbx, rby = self._arms(th)
        we = self._we
        we[: self.nb] = w  # the ground's stays 0
        wa2, wb2 = we[self.a] ** 2, we[self.b] ** 2
        out = np.empty(2 * len(self.a))
        out[0::2] = rax * wa2 - rbx * wb2
        out[1::2] = ray * wa2 - rby * wb2
        return out

    # -- the same equations at many configurations at once (the output rows) ----------
    def arms_rows(self, th: np.ndarray):
        """:meth:`_arms` for the rows of ``th`` (n, nb): each (n, pins)."""
        the = np.zeros((th.shape[0], self.nb + 1))
        the[:, : self.nb] = th
        c, s = np.cos(the), np.sin(the)
        ca, sa_, cb, sb_ = c[:, self.a], s[:, self.a], c[:, self.b], s[:, self.b]
        return (
            ca * self._sax - sa_ * self._say,
            sa_ * self._sax + ca * self._say,
            cb * self._sbx - sb_ * self._sby,
            sb_ * self._sbx + cb * self._sby,
        )

    def residual_rows(self, q: np.ndarray, arms) -> np.ndarray:
        """:meth:`residual` of each row of ``q`` (n, nq), summed in the same order."""
        rax, ray, rbx, rby = arms
        n = q.shape[0]
        ra, rb = np.empty((n, 2 * len(self.a))), np.empty((n, 2 * len(self.a)))
        ra[:, 0::2], ra[:, 1::2], rb[:, 0::2], rb[:, 1::2] = rax, ray, rbx, rby
        out = q @ self._pa.T
        out += ra
        out -= q @ self._pb.T
        out -= rb
        return out

    def jacobian_rows(self, arms) -> np.ndarray:
        """:meth:`jacobian` of each row: (n, 2 pins, nq)."""
        rax, ray, rbx, rby = arms
        n = rax.shape[0]
        J = np.repeat(self.template[None], n, axis=0)
        flat = J.reshape(n, -1)
        ma, mb = self._ka, self._kb
        flat[:, self.fa_x] = -ray[:, ma]
        flat[:, self.fa_y] = rax[:, ma]
        flat[:, self.fb_x] = rby[:, mb]
        flat[:, self.fb_y] = -rbx[:, mb]
        return J

    def gamma_rows(self, arms, w: np.ndarray) -> np.ndarray:
        """:meth:`gamma` of each row (``w``: (n, nb))."""
        rax, ray, rbx, rby = arms
        we = np.zeros((w.shape[0], self.nb + 1))
        we[:, : self.nb] = w
        wa2, wb2 = we[:, self.a] ** 2, we[:, self.b] ** 2
        out = np.empty((w.shape[0], 2 * len(self.a)))
        out[:, 0::2] = rax * wa2 - rbx * wb2
        out[:, 1::2] = ray * wa2 - rby * wb2
        return out
