"""The fused passes of :mod:`mechsolve.core.program`: the driver link on the ground and the
RRR dyad whose links' frames sit at their outer joints with x along the link (the
usual frames), written straight into the state's rows.

Each pass does the operations of the group's own methods (:class:`DriverLink` and
:class:`RRR` in :mod:`mechsolve.groups.closed`: position, discriminant, velocity,
acceleration) in the same order on the same operands, so the results are the same bit
for bit; what it leaves out is the calls between them (the group's cache, the state's
point helpers, the temporaries a whole-array assignment makes): the joint's point P is
computed into the coupler's origin row, its velocity and acceleration into the
coupler's rate rows, the link angles' rates into their rows. A dyad with other frames,
or with arms of equal length, is solved by its own methods.
"""

from __future__ import annotations

import numpy as np

from mechsolve.base.state import State
from mechsolve.groups.closed import RRR, DriverLink


def driver_fused(g: DriverLink, nb: int) -> bool:
    """Whether the driver link ``g`` is one :func:`driver_pass` solves: pinned to the
    ground at its frame's origin, its driver's other body the ground."""
    sp = g.sp
    return g.k == nb and nb in (g.drv.a, g.drv.b) and sp.ndim == 1 and not sp.any()


def rrr_fused(g: RRR, nb: int) -> bool:
    """Whether the dyad ``g`` is one :class:`RRRPass` solves: P on a moving body, each
    link's frame at its outer joint with x along the link, lengths in floats, arms of
    different lengths."""
    vecs = (g.sP1, g.sQ2, g.sM1, g.sM2, g.sPk, g.sQk)
    if any(v.ndim != 1 for v in vecs) or g.equal_arms or g.k1 == nb:
        return False
    return not (g.sP1.any() or g.sQ2.any() or g.sM1[1] or g.sM2[1]) and isinstance(g.L1, float)


def driver_pass(st: State, g: DriverLink, u: np.ndarray, acceleration: bool) -> None:
    """The driver link's rows per unit driver angle, as its position, velocity and
    acceleration write them (the rates of a link turning with the driver: 1 and 0)."""
    b, nb = g.b, st.nb
    sign = 1.0 if g.drv.b == b else -1.0
    off = -g.drv.delta if g.drv.b == b else g.drv.delta
    th = st.th[b]
    np.multiply(u, sign, out=th)
    if off:
        th += off
    np.cos(th, out=st.c[b])
    np.sin(th, out=st.s[b])
    # its origin is the ground point it is pinned at (the local point is its origin);
    # its rates: the ground's (0) plus the driver's. The constant rows in two writes
    # (rows x, y and vx, vy, w, ax, ay, al of the state's block, in that order)
    blk = st.block
    blk[0:2, b] = np.array([[g.sk[0] - 0.0], [g.sk[1] - 0.0]])
    w = st.w[nb, 0] + sign * 1.0
    if acceleration:
        blk[5:11, b] = np.array([[0.0], [0.0], [w], [0.0], [0.0], [st.al[nb, 0] + sign * 0.0]])
    else:
        blk[5:8, b] = np.array([[0.0], [0.0], [w]])


def _arm(st: State, i: int, s: np.ndarray):
    """``st.rotated(i, s)`` of a moving body's point (None for the frame's origin)."""
    if s[0] == 0.0 and s[1] == 0.0:
        return None
    return st.rotated(i, s)


def _point(st: State, i: int, s: np.ndarray, arm, ox: np.ndarray, oy: np.ndarray):
    """``st.point(i, s)`` written into ``ox, oy`` (a scalar pair for the ground), with
    ``arm`` the point's :func:`_arm`."""
    if i == st.nb:
        return float(s[0]), float(s[1])
    if arm is None:
        ox[...] = st.x[i]
        oy[...] = st.y[i]
    else:
        np.add(st.x[i], arm[0], out=ox)
        np.add(st.y[i], arm[1], out=oy)
    return ox, oy


def _rate(st: State, i: int, s: np.ndarray, arm, ox, oy, acc: bool, unit: float):
    """``st.point_velocity(i, s)`` (``point_acceleration`` with ``acc``) written into
    ``ox, oy``; the ground's (0, 0) as scalars. ``unit``: 1.0 where body ``i`` is a driver
    link of :func:`driver_pass` turning at +1 per unit driver angle (its origin at rest,
    its angular acceleration 0), whose terms in zeros and ones are exact: v = (0 - ry,
    rx + 0) and a = (0 - rx, 0 - ry), the same values as the general formulas give."""
    if i == st.nb:
        return 0.0, 0.0
    if arm is None:
        ox[...] = (st.ax if acc else st.vx)[i]
        oy[...] = (st.ay if acc else st.vy)[i]
        return ox, oy
    rx, ry = arm
    if unit == 1.0:
        if acc:  # (0 - al ry) - 1 rx and (0 + al rx) - 1 ry with al = 0: exactly these
            np.subtract(0.0, rx, out=ox)
            np.subtract(0.0, ry, out=oy)
        else:  # 0 - 1 ry and 0 + 1 rx
            np.subtract(0.0, ry, out=ox)
            np.add(rx, 0.0, out=oy)
        return ox, oy
    w = st.w[i]
    if not acc:  # vx - w ry, vy + w rx
        np.multiply(w, ry, out=ox)
        np.subtract(st.vx[i], ox, out=ox)
        np.multiply(w, rx, out=oy)
        oy += st.vy[i]
        return ox, oy
    w2 = w**2  # ax - al ry - w^2 rx, ay + al rx - w^2 ry
    al = st.al[i]
    np.multiply(al, ry, out=ox)
    np.subtract(st.ax[i], ox, out=ox)
    ox -= w2 * rx
    np.multiply(al, rx, out=oy)
    oy += st.ay[i]
    oy -= w2 * ry
    return ox, oy


class RRRPass:
    """The dyad's pass over one state: :meth:`ends` (P, Q, the discriminant and its
    rate, before the branch is known), then :meth:`pose` and :meth:`rates`."""

    def __init__(self, st: State, g: RRR, units: dict) -> None:
        self.st, self.g = st, g
        # the bodies of P and Q where they are driver links turning at +1 (see _rate)
        self.uP, self.uQ = units.get(g.k1, 0.0), units.get(g.k2, 0.0)
        L1s, L2s = g.L1 * g.L1, g.L2 * g.L2
        self.L1s, self.L2s = L1s, L2s
        self.half = (L1s - L2s) * 0.5  # (in floats: the same double as the group forms)
        ex = g.sM1[0] - g.sP1[0]
        ey = g.sM1[1] - g.sP1[1]
        self.f1 = ex / (ex * ex + ey * ey)  # set_pose_from_vectors' factor of each link
        ex = g.sM2[0] - g.sQ2[0]
        ey = g.sM2[1] - g.sQ2[1]
        self.f2 = ex / (ex * ex + ey * ey)

    def ends(self) -> tuple[np.ndarray, np.ndarray]:
        """P (into link 1's origin), Q, Q - P, the triangle, H and H' (RRR.ends,
        _triangle, disc); returns ``H, H'``."""
        st, g = self.st, self.g
        b1, b2 = g.b1, g.b2
        nb = st.nb
        armP = _arm(st, g.k1, g.sPk) if g.k1 != nb else None
        armQ = _arm(st, g.k2, g.sQk) if g.k2 != nb else None
        self.arms = armP, armQ
        px, py = _point(st, g.k1, g.sPk, armP, st.x[b1], st.y[b1])
        qx, qy = _point(st, g.k2, g.sQk, armQ, st.x[b2], st.y[b2])
        dx = np.subtract(qx, px)
        dy = np.subtract(qy, py)
        D2 = dx * dx
        t = dy * dy
        D2 += t
        L1s, L2s = self.L1s, self.L2s
        inv = np.divide(1.0, D2)
        a = np.multiply(self.half, inv)
        a += 0.5
        h2 = L1s * inv
        np.multiply(a, a, out=t)
        h2 -= t
        np.add(D2, L1s - L2s, out=t)
        t *= 0.5
        t *= t
        H = L1s * D2
        H -= t
        H *= 1.0 / (L1s * L2s)
        # the rates of P and Q (into the links' velocity rows), and H'
        vpx, vpy = _rate(st, g.k1, g.sPk, armP, st.vx[b1], st.vy[b1], False, self.uP)
        vqx, vqy = _rate(st, g.k2, g.sQk, armQ, st.vx[b2], st.vy[b2], False, self.uQ)
        dvx = np.subtract(vqx, vpx)
        dvy = np.subtract(vqy, vpy)
        dD2 = dx * dvx
        dH = dy * dvy
        dD2 += dH
        np.subtract(L1s + L2s, D2, out=dH)
        dH *= dD2
        dH *= 1.0 / (L1s * L2s)
        self.P, self.Q, self.d, self.D2 = (px, py), (qx, qy), (dx, dy), D2
        self.a, self.h2, self.H = a, h2, H
        self.vP, self.dv = (vpx, vpy), (dvx, dvy)
        self.t = t
        return H, dH

    def closes(self) -> bool:
        """Whether the dyad closes at every sample (RRR._triangle's test, where H is at
        least sin^2(3 deg) everywhere: then D^2 > 0, and h^2 >= 0 is the whole test)."""
        return bool(self.h2.min() >= 0.0)

    def pose(self, mode: float, ind: np.ndarray) -> None:
        """Both links' poses on branch ``mode`` (RRR.position), the indicator into
        ``ind``."""
        st, g = self.st, self.g
        b1, b2 = g.b1, g.b2
        dx, dy = self.d
        h = np.maximum(self.h2, 0.0)
        np.sqrt(h, out=h)
        h *= mode
        t = self.t
        g1x = self.a * dx
        np.multiply(h, dy, out=t)
        g1x -= t
        g1y = np.multiply(self.a, dy, out=self.a)
        np.multiply(h, dx, out=t)
        g1y += t
        g2x = np.subtract(g1x, dx, out=h)
        g2y = g1y - dy
        self.g1, self.g2 = (g1x, g1y), (g2x, g2y)
        np.multiply(g1x, self.f1, out=st.c[b1])
        np.multiply(g1y, self.f1, out=st.s[b1])
        np.arctan2(st.s[b1], st.c[b1], out=st.th[b1])
        np.multiply(g2x, self.f2, out=st.c[b2])
        np.multiply(g2y, self.f2, out=st.s[b2])
        np.arctan2(st.s[b2], st.c[b2], out=st.th[b2])
        qx, qy = self.Q
        if not isinstance(qx, np.ndarray):  # Q on the ground: link 2's origin
            st.x[b2] = qx
            st.y[b2] = qy
        np.maximum(self.H, 0.0, out=ind)
        np.minimum(ind, 1.0, out=ind)
        np.sqrt(ind, out=ind)

    def rates(self, acceleration: bool) -> None:
        """The links' angular velocities (and accelerations) and their origins' rates
        (RRR.velocity, RRR.acceleration); the group's cache as those leave it for the
        force analysis (the ends and the closure's link vectors)."""
        st, g = self.st, self.g
        b1, b2 = g.b1, g.b2
        (g1x, g1y), (g2x, g2y) = self.g1, self.g2
        (vpx, vpy), (dvx, dvy) = self.vP, self.dv
        t = self.t
        inv = g1x * g2y
        np.multiply(g1y, g2x, out=t)
        inv -= t
        np.divide(1.0, inv, out=inv)
        w1 = np.multiply(dvx, g2x, out=st.w[b1])
        np.multiply(dvy, g2y, out=t)
        w1 += t
        w1 *= inv
        w2 = np.multiply(dvx, g1x, out=st.w[b2])
        np.multiply(dvy, g1y, out=t)
        w2 += t
        w2 *= inv
        np.add(vpx, dvx, out=st.vx[b2])
        np.add(vpy, dvy, out=st.vy[b2])
        if acceleration:
            armP, armQ = self.arms
            apx, apy = _rate(st, g.k1, g.sPk, armP, st.ax[b1], st.ay[b1], True, self.uP)
            aqx, aqy = _rate(st, g.k2, g.sQk, armQ, st.ax[b2], st.ay[b2], True, self.uQ)
            w1s = np.square(w1, out=t)
            w2s = w2**2
            p = np.empty_like(w2s)  # (each product into it: no temporary per term)
            dax = np.subtract(aqx, apx)
            dax -= np.multiply(w2s, g2x, out=p)
            dax += np.multiply(w1s, g1x, out=p)
            day = np.subtract(aqy, apy)
            day -= np.multiply(w2s, g2y, out=p)
            day += np.multiply(w1s, g1y, out=p)
            del p
            a1 = np.multiply(dax, g2x, out=st.al[b1])
            np.multiply(day, g2y, out=w2s)
            a1 += w2s
            a1 *= inv
            a2 = np.multiply(dax, g1x, out=st.al[b2])
            np.multiply(day, g1y, out=w2s)
            a2 += w2s
            a2 *= inv
            if not isinstance(aqx, np.ndarray):
                st.ax[b2] = aqx
                st.ay[b2] = aqy
        px, py = self.P
        qx, qy = self.Q
        dx, dy = self.d
        c = g.cache(st)
        if not isinstance(qx, np.ndarray):  # (the general path's Q: the ground's constants)
            qx, qy = st.point(g.k2, g.sQk)
        c["ends"] = (px, py, qx, qy, dx, dy, self.D2)
        c["g"] = (g1x, g1y, g2x, g2y)
