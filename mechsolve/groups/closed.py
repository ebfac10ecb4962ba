"""Groups solved in closed form: the driver link and the two-link Assur groups (dyads).

Notation: ``P`` and ``Q`` are the outer joints (on bodies already solved), ``M`` the inner
joint. Vectors are handled as pairs of arrays over positions; ``perp(v) = k x v``.
Velocities and accelerations solve the group's 2x2 system in the unknown angular
velocities (accelerations) by projection, which is Cramer's rule written out:
``omega_1 = (dv . g2) / (g1 x g2)`` for the RRR dyad, and likewise for the others.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from mechsolve.base.state import State
from mechsolve.groups.base import (
    Drive,
    Group,
    add_force,
    body_acceleration_from_point,
    body_velocity_from_point,
    diff,
    length,
    metres,
    pin_multiplier,
    resultant_about,
    set_pose_from_vectors,
)
from mechsolve.joints.revolute import RevoluteConstraint
from mechsolve.joints.slider import SliderConstraint
from mechsolve.system.constraints import AngleDriverConstraint, SliderDriverConstraint

COINCIDENT = 1e-7  # |PQ| below this fraction of the arms: the outer joints coincide


def _local(c: RevoluteConstraint, body: int) -> np.ndarray:
    return c.sa if c.a == body else c.sb


def _other(c, body: int) -> int:
    return c.b if c.a == body else c.a


class DriverLink(Group):
    """A link pinned to a solved body whose angle the driver sets (class I group)."""

    kind = "driver link"

    def __init__(self, body, pin: RevoluteConstraint, driver: AngleDriverConstraint, names):
        self.b = body
        self.pin = pin
        self.drv = driver
        self.k = _other(pin, body)  # the body it is pinned to
        self.sp = _local(pin, body)
        self.sk = _local(pin, self.k)
        super().__init__([body], [pin, driver], names)

    def _angle_terms(self, st: State, u, rate: str):
        d = self.drv
        if d.b == self.b:  # theta_b = theta_a + u - delta
            other, sign, off = d.a, 1.0, -d.delta
        else:  # theta_a = theta_b + delta - u
            other, sign, off = d.b, -1.0, d.delta
        return other, sign, off

    def position(self, st: State, drive: Drive, mode=1.0):
        other, sign, off = self._angle_terms(st, drive.u, "pos")
        th = np.multiply(drive.u, sign)
        if other != st.nb:  # (the ground's angle is zero: nothing to add)
            th += st.th[other]
        if off:
            th += off
        # on the ground with one offset the angle repeats with the driver (a batch)
        period = getattr(drive, "period", 0) if other == st.nb and np.ndim(off) == 0 else 0
        st.set_angle(self.b, th, period=period)
        px, py = st.point(self.k, self.sk)
        rx, ry = st.rotated(self.b, self.sp)
        st.x[self.b] = px - rx
        st.y[self.b] = py - ry
        n = st.n
        return np.ones(n, bool), np.ones(n)

    def velocity(self, st: State, drive: Drive) -> None:
        other, sign, _ = self._angle_terms(st, drive.u, "vel")
        w = np.multiply(drive.ud, sign)  # st.w[other] + sign ud, in one array
        w = np.add(st.w[other], w, out=w if np.shape(w) == (st.n,) else None)
        vpx, vpy = st.point_velocity(self.k, self.sk)
        body_velocity_from_point(st, self.b, self.sp, vpx, vpy, w)

    def acceleration(self, st: State, drive: Drive) -> None:
        other, sign, _ = self._angle_terms(st, drive.u, "acc")
        al = st.al[other] + sign * drive.udd
        apx, apy = st.point_acceleration(self.k, self.sk)
        body_acceleration_from_point(st, self.b, self.sp, apx, apy, al)

    def forces(self, st: State, R: np.ndarray, out: dict) -> None:
        """The pin carries the link's force, the driver its moment about the pin."""
        px, py = st.point(self.k, self.sk)
        fx, fy, tp = resultant_about(st, R, self.b, px, py)
        # on the link: F_P + F = 0 and M_driver + T_P = 0
        out[self.pin] = pin_multiplier(self.pin, self.b, -fx, -fy)
        drv, nb = self.drv, st.nb
        # m, the torque on the driver's second link, is -tp when that link is this one;
        # its multiplier is -m (tp itself then: -(-tp) is tp exactly)
        out[drv] = (tp,) if drv.b == self.b else (np.negative(tp),)
        add_force(st, R, self.k, px, py, fx, fy)
        # the driver applies m to its second link and -m to its first
        on_a = drv.a != nb and drv.a != self.b
        on_b = drv.b != nb and drv.b != self.b
        if on_a or on_b:
            m = -tp if drv.b == self.b else tp
            if on_a:
                R[3 * drv.a + 2] -= m
            if on_b:
                R[3 * drv.b + 2] += m


class DrivenSlider(Group):
    """A block on a solved guide whose displacement the driver sets (linear actuator)."""

    kind = "driven slider"

    def __init__(self, body, slider: SliderConstraint, driver: SliderDriverConstraint, names):
        self.b = body
        self.sl = slider
        super().__init__([body], [slider, driver], names)

    def position(self, st: State, drive: Drive, mode=1.0):
        sl, b, g = self.sl, self.b, self.sl.a
        st.set_angle(b, st.th[g] + sl.beta)
        ux, uy = st.rotated(g, sl.u_loc)
        ox, oy = st.point(g, sl.o)
        rx, ry = st.rotated(b, sl.sb)
        st.x[b] = ox + drive.u * ux - rx
        st.y[b] = oy + drive.u * uy - ry
        return np.ones(st.n, bool), np.ones(st.n)

    def velocity(self, st: State, drive: Drive) -> None:
        sl, b, g = self.sl, self.b, self.sl.a
        ux, uy = st.rotated(g, sl.u_loc)
        px, py = st.point(b, sl.sb)
        # velocity of the guide-fixed point under P, plus the sliding velocity
        vgx, vgy = _carried_velocity(st, g, px, py)
        wg = st.w[g]
        vx = vgx + drive.ud * ux
        vy = vgy + drive.ud * uy
        body_velocity_from_point(st, b, sl.sb, vx, vy, wg)

    def acceleration(self, st: State, drive: Drive) -> None:
        sl, b, g = self.sl, self.b, self.sl.a
        ux, uy = st.rotated(g, sl.u_loc)
        px, py = st.point(b, sl.sb)
        agx, agy = _carried_acceleration(st, g, px, py)
        wg = st.w[g]
        ax = agx + drive.udd * ux + 2 * wg * drive.ud * (-uy)
        ay = agy + drive.udd * uy + 2 * wg * drive.ud * ux
        body_acceleration_from_point(st, b, sl.sb, ax, ay, st.al[g])

    def forces(self, st: State, R: np.ndarray, out: dict) -> None:
        sl, b, g = self.sl, self.b, self.sl.a
        ux, uy = st.rotated(g, sl.u_loc)
        nx, ny = -uy, ux
        sx, sy = st.point(b, sl.sb)
        fx, fy, ts = resultant_about(st, R, b, sx, sy)
        nrm = -(fx * nx + fy * ny)  # the guide's normal force on the block
        fd = -(fx * ux + fy * uy)  # the driving force along the line
        t = -ts  # the guide's moment on the block
        out[self.sl] = (-nrm, -t)
        out[self.constraints[1]] = (-fd,)
        add_force(st, R, g, sx, sy, -(nrm * nx + fd * ux), -(nrm * ny + fd * uy))
        if g != st.nb:
            R[3 * g + 2] -= t


def _point_and_arm(st: State, i: int, s: np.ndarray):
    """``st.point(i, s)``, and the arm ``st.rotated(i, s)`` it adds where that is an
    array of the state's size (a batch of designs' local points), which the point's
    velocity then reuses; else None."""
    if i == st.nb or s.ndim == 1:
        return st.point(i, s), None
    rx, ry = st.rotated(i, s)
    return (st.x[i] + rx, st.y[i] + ry), (rx, ry)


def _carried_velocity(st: State, g: int, px, py):
    """Velocity of the point of body ``g`` that is at (px, py) now."""
    w = st.w[g]
    return st.vx[g] - w * (py - st.y[g]), st.vy[g] + w * (px - st.x[g])


def _carried_acceleration(st: State, g: int, px, py):
    w2 = st.w[g] ** 2
    al = st.al[g]
    rx, ry = px - st.x[g], py - st.y[g]
    return st.ax[g] - al * ry - w2 * rx, st.ay[g] + al * rx - w2 * ry


def _cross(ax, ay, bx, by):
    """``ax by - ay bx`` as a new array (one temporary)."""
    out = ax * by
    out -= ay * bx
    return out


def _combine(alpha, g2, g1, beta, inv):
    """``(-alpha g2 + g1 beta) inv`` as a new array, the same rounding."""
    out = alpha * g2
    np.negative(out, out=out)  # -(alpha g2) is (-alpha) g2 exactly
    out += g1 * beta
    out *= inv
    return out


class RRR(Group):
    """Two links joined at M, each pinned to a solved body (P on link 1, Q on link 2).

    Branch ``mode = +1``: M lies on the left of the directed line P -> Q, where link 1 is
    the one listed first in the file.
    """

    kind = "RRR"
    n_modes = 2
    # kept for the force analysis: P, Q and Q - P, M - P and M - Q
    POSITION_KEYS = ("ends", "g", "arms")

    def __init__(self, b1, b2, j1, j2, j3, names):
        # j1: b1-known at P, j2: b1-b2 at M, j3: b2-known at Q
        self.b1, self.b2 = b1, b2
        self.j1, self.j2, self.j3 = j1, j2, j3
        self.k1, self.k2 = _other(j1, b1), _other(j3, b2)
        self.sP1, self.sPk = _local(j1, b1), _local(j1, self.k1)
        self.sQ2, self.sQk = _local(j3, b2), _local(j3, self.k2)
        self.sM1, self.sM2 = _local(j2, b1), _local(j2, b2)
        self.L1 = length(diff(self.sM1, self.sP1))
        self.L2 = length(diff(self.sM2, self.sQ2))
        if isinstance(self.L1, float) and isinstance(self.L2, float):  # (in floats: 4 us less)
            self.Lmax2 = max(self.L1, self.L2) ** 2
            self.equal_arms = abs(self.L1 - self.L2) <= 1e-12 * math.sqrt(self.Lmax2)
        else:  # a batch of designs: one length per position
            self.Lmax2 = np.maximum(self.L1, self.L2) ** 2
            self.equal_arms = bool(np.any(np.abs(self.L1 - self.L2) <= 1e-12 * np.sqrt(self.Lmax2)))
        self.direction = 1.0  # the sweep's direction along the driver; the analysis sets it
        super().__init__([b1, b2], [j1, j2, j3], names)

    def describe(self) -> str:
        return (
            f"loop {self.j2.name} ({self.body_names[0]} {self.j1.name}-{self.j2.name}, "
            f"{self.body_names[1]} {self.j2.name}-{self.j3.name})"
        )

    def ends(self, st: State):
        """P and Q, and Q - P with its squared length (cached for this state)."""
        c = self.cache(st)
        if "ends" not in c:
            (px, py), armP = _point_and_arm(st, self.k1, self.sPk)
            (qx, qy), armQ = _point_and_arm(st, self.k2, self.sQk)
            if armP is not None or armQ is not None:  # for the velocities of P and Q
                c["arms"] = (armP, armQ)
            dx, dy = qx - px, qy - py
            c["ends"] = (px, py, qx, qy, dx, dy, dx * dx + dy * dy)
        return c["ends"]

    def _dv(self, st: State):
        """v_P and v_Q - v_P (cached)."""
        c = self.cache(st)
        if "dv" not in c:
            armP, armQ = c["arms"] if "arms" in c else (None, None)
            vpx, vpy = st.point_velocity(self.k1, self.sPk, arm=armP)
            vqx, vqy = st.point_velocity(self.k2, self.sQk, arm=armQ)
            c["dv"] = (vpx, vpy, vqx - vpx, vqy - vpy)
        return c["dv"]

    def _triangle(self, st: State):
        """The branch-free part of the closure (cached): M's distance along P -> Q and
        its squared height, both as fractions of |PQ|, where the loop closes, the
        discriminant ``H`` (see :meth:`disc`) and where the outer joints coincide."""
        c = self.cache(st)
        if "tri" not in c:
            D2 = self.ends(st)[6]
            L1, L2 = self.L1, self.L2
            L1s, L2s = L1 * L1, L2 * L2
            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                # (in place where the terms are arrays, one temporary ``t``: the same
                # operations in the same order as the formulas in the comments)
                inv = 1.0 / D2
                # a = (0.5 (L1^2 - L2^2)) / D^2 + 0.5: along P->Q, fraction of D
                a = np.multiply(L1s - L2s, 0.5)
                a = np.multiply(a, inv, out=a if np.ndim(a) else None)
                a += 0.5
                h2 = L1s * inv  # h2 = L1^2 / D^2 - a^2: (height / D)^2
                t = a * a
                h2 -= t
                # 16 area^2 of the triangle P-M-Q over (2 L1 L2)^2, written without a
                # division so that it stays finite where P and Q coincide:
                # H = (L1^2 D^2 - aD2^2) / (L1^2 L2^2), aD2 = 0.5 (L1^2 - L2^2 + D^2)
                np.subtract(L1s, L2s, out=t)
                t += D2
                t *= 0.5
                t *= t
                H = L1s * D2
                H -= t
                H *= 1.0 / (L1s * L2s)
                # a toggle position (h = 0) within rounding still closes:
                # h2 >= -(1e-12 Lmax^2) / D^2
                np.multiply(1e-12 * self.Lmax2, inv, out=t)
                np.negative(t, out=t)
                ok = h2 >= t
                ok &= D2 > 0
                del t
                coincident = None
                if self.equal_arms:
                    # P and Q (nearly) coincide: with equal arms every position of M on
                    # the circle about them closes the loop (a bifurcation point)
                    coincident = D2 <= (COINCIDENT * L1) ** 2
                    if coincident.any():
                        ok = ok | coincident
                        H = np.where(coincident, np.maximum(H, 0.0), H)
                    else:
                        coincident = None
            c["tri"] = (a, h2, ok, H, coincident)
        return c["tri"]

    def coincident(self, st: State) -> np.ndarray | None:
        """Where the outer joints P and Q coincide (arms of equal length only), or None."""
        return self._triangle(st)[4]

    def position(self, st: State, drive: Drive, mode=1.0):
        px, py, qx, qy, dx, dy, D2 = self.ends(st)
        a, h2, ok, H, coincident = self._triangle(st)
        with np.errstate(invalid="ignore", divide="ignore"):
            h = np.maximum(h2, 0.0)
            np.sqrt(h, out=h)
            h *= mode
            # M - P = a (dx, dy) + h (-dy, dx), in place
            g1x = a * dx
            t = h * dy
            g1x -= t
            g1y = a * dy
            np.multiply(h, dx, out=t)
            g1y += t
            del t
            if coincident is not None:
                g1x, g1y = self._coincident_pose(st, coincident, mode, g1x, g1y)
        closes = bool(ok.all())
        if not closes:
            g1x = np.where(ok, g1x, np.nan)
            g1y = np.where(ok, g1y, np.nan)
        g2x, g2y = g1x - dx, g1y - dy  # M - Q
        self.cache(st)["g"] = (g1x, g1y, g2x, g2y)
        set_pose_from_vectors(st, self.b1, self.sP1, self.sM1, px, py, g1x, g1y)
        set_pose_from_vectors(st, self.b2, self.sQ2, self.sM2, qx, qy, g2x, g2y)
        # sin of the angle between the two links at M (np.clip costs twice this)
        with np.errstate(invalid="ignore"):
            ind = np.maximum(H, 0.0)
            np.minimum(ind, 1.0, out=ind)
            np.sqrt(ind, out=ind)
        if not closes:
            ind[~ok] = 0.0
        return ok, ind

    def _coincident_pose(self, st: State, where, mode, g1x, g1y):
        """M - P where P and Q coincide: the limit along the motion.

        Near the coincidence Q - P = d(u) ~ d'(u*) (u - u*), and M - P tends to
        ``mode L1 perp(d / |d|)``: the direction of d flips as the joints pass through each
        other, so the smooth motion flips the branch there (a bifurcation, which the
        sweep records). At the coincident position itself the direction of d is
        rounding, so the limit is taken from the side the sweep comes from (``-direction``
        along d'); at the sweep's start, from the side it goes to (the sweep flips the
        branch of that one position, see :meth:`Analysis.solve`). The rate d' of Q - P
        comes from the groups solved before (per unit of the driver coordinate).
        """
        _, _, dvx, dvy = self._dv(st)
        nv = np.hypot(dvx, dvy)
        s = -self.direction / np.where(nv > 0, nv, np.nan)
        ex, ey = s * dvx, s * dvy  # unit vector along d on the incoming side
        m = np.broadcast_to(mode, np.shape(g1x))
        # within the tolerance the joints are apart by up to 1e-7 of the arms: M lies
        # beside the midpoint of P-Q, not beside P, square to P-Q itself where that is
        # known better than the rate's direction (|PQ| above sqrt(eps) of the arms:
        # rounding turns d by eps L / |d|, the rate differs from it by about |d| / L)
        dx, dy, D2 = self.ends(st)[4:]
        hh = np.sqrt(np.maximum(self.L1 * self.L1 - 0.25 * D2, 0.0))
        with np.errstate(invalid="ignore", divide="ignore"):
            D = np.sqrt(D2)
            own = where & (D > 1.5e-8 * self.L1) & np.isfinite(ex)
            side = np.sign(dx * ex + dy * ey)
            ex = np.where(own, side * dx / D, ex)
            ey = np.where(own, side * dy / D, ey)
        return (
            np.where(where, 0.5 * dx - m * hh * ey, g1x),
            np.where(where, 0.5 * dy + m * hh * ex, g1y),
        )

    def disc(self, st: State):
        """``sin^2`` of the angle at M: 16 area^2 of the triangle P-M-Q over (2 L1 L2)^2,
        which is ``(h / D)^2 D^4 / (L1 L2)^2`` (negative where the loop cannot close).
        Cached for the state: the branch analysis and the start's checks read it."""
        c = self.cache(st)
        if "disc" not in c:
            dx, dy, D2 = self.ends(st)[4:]
            _, _, dvx, dvy = self._dv(st)
            H = self._triangle(st)[3]
            L1s, L2s = self.L1**2, self.L2**2
            # dH = ((L1^2 + L2^2) - D^2) dD2 / (L1^2 L2^2), dD2 = d . d' (half the
            # rate of D^2); in place
            dD2 = dx * dvx
            dH = dy * dvy
            dD2 += dH
            np.subtract(L1s + L2s, D2, out=dH)
            dH *= dD2
            del dD2
            dH *= 1.0 / (L1s * L2s)
            c["disc"] = (H, dH)
        return c["disc"]

    def _g(self, st: State):
        c = self.cache(st)
        if "g" not in c:
            g1x, g1y = st.rotated(self.b1, diff(self.sM1, self.sP1))
            g2x, g2y = st.rotated(self.b2, diff(self.sM2, self.sQ2))
            c["g"] = (g1x, g1y, g2x, g2y)
        return c["g"]

    def velocity(self, st: State, drive: Drive) -> None:
        g1x, g1y, g2x, g2y = self._g(st)
        vpx, vpy, dvx, dvy = self._dv(st)
        # inv = 1 / (g1 x g2), w1 = (dv . g2) inv, w2 = (dv . g1) inv; in place
        inv = g1x * g2y
        t = g1y * g2x
        inv -= t
        np.divide(1.0, inv, out=inv)
        self.cache(st)["inv"] = inv
        w1 = dvx * g2x
        np.multiply(dvy, g2y, out=t)
        w1 += t
        w1 *= inv
        w2 = dvx * g1x
        np.multiply(dvy, g1y, out=t)
        w2 += t
        w2 *= inv
        del t
        body_velocity_from_point(st, self.b1, self.sP1, vpx, vpy, w1)
        body_velocity_from_point(st, self.b2, self.sQ2, vpx + dvx, vpy + dvy, w2)

    def acceleration(self, st: State, drive: Drive) -> None:
        g1x, g1y, g2x, g2y = self._g(st)
        apx, apy = st.point_acceleration(self.k1, self.sPk)
        aqx, aqy = st.point_acceleration(self.k2, self.sQk)
        w1s, w2s = st.w[self.b1] ** 2, st.w[self.b2] ** 2
        dax = aqx - apx - w2s * g2x + w1s * g1x
        day = aqy - apy - w2s * g2y + w1s * g1y
        inv = self.cache(st).get("inv")
        if inv is None:
            inv = 1.0 / (g1x * g2y - g1y * g2x)
        a1 = (dax * g2x + day * g2y) * inv
        a2 = (dax * g1x + day * g1y) * inv
        body_acceleration_from_point(st, self.b1, self.sP1, apx, apy, a1)
        body_acceleration_from_point(st, self.b2, self.sQ2, aqx, aqy, a2)

    def forces(self, st: State, R: np.ndarray, out: dict) -> None:
        """Dyad equilibrium: moments of each link about M give the force in M (Cramer),
        then the forces at P and Q."""
        px, py, qx, qy, *_ = self.ends(st)
        g1x, g1y, g2x, g2y = self._g(st)
        mx, my = px + g1x, py + g1y
        f1x, f1y, t1 = resultant_about(st, R, self.b1, mx, my)
        f2x, f2y, t2 = resultant_about(st, R, self.b2, mx, my)
        del mx, my  # (each temporary freed once read: a lower peak of memory)
        # e1 = P - M = -g1, e2 = Q - M = -g2; e1 x F_M = alpha, e2 x F_M = beta.
        # Written in place (t1, t2 are resultant_about's own arrays), the same operations
        # in the same order as alpha = -t1 - (g1 x f1), beta = t2 + (g2 x f2),
        # F_M = (-alpha g2 + beta g1) / (g1 x g2): the same rounding, fewer temporaries
        alpha = np.negative(t1, out=t1)
        alpha -= _cross(g1x, g1y, f1x, f1y)
        beta = t2
        beta += _cross(g2x, g2y, f2x, f2y)
        inv = _cross(g1x, g1y, g2x, g2y)
        np.divide(1.0, inv, out=inv)
        fmx = _combine(alpha, g2x, g1x, beta, inv)
        fmy = _combine(alpha, g2y, g1y, beta, inv)
        del alpha, beta, inv, t1, t2
        fpx, fpy = fmx - f1x, fmy - f1y  # on link 1 at P
        fqx = np.negative(fmx)  # on link 2 at Q: -F_M - f2
        fqx -= f2x
        fqy = np.negative(fmy)
        fqy -= f2y
        out[self.j1] = pin_multiplier(self.j1, self.b1, fpx, fpy)
        out[self.j2] = pin_multiplier(self.j2, self.b2, fmx, fmy)
        out[self.j3] = pin_multiplier(self.j3, self.b2, fqx, fqy)
        add_force(st, R, self.k1, px, py, -fpx, -fpy)
        add_force(st, R, self.k2, qx, qy, -fqx, -fqy)

    def mode_text(self, st: State, mode: float, pn) -> str:
        side = "left" if mode > 0 else "right"
        return f"{pn[self.j2]} {side} of {pn[self.j1]} -> {pn[self.j3]}"

    def mode_of_side(self, point, side, start, end, pn):
        """``M left of P -> Q`` is branch +1 (M - P = a (Q - P) + h n, n the left normal
        of P -> Q, h > 0), and ``M left of Q -> P`` branch -1."""
        m, p, q = pn[self.j2], pn[self.j1], pn[self.j3]
        if point != m or {start, end} != {p, q} or p == q:
            return None
        sign = 1.0 if side == "left" else -1.0
        return sign if (start, end) == (p, q) else -sign

    def fail_reason(self, st: State, i: int, words: Callable[[float], str] = metres) -> str:
        px, py, qx, qy = (v[i] for v in self.ends(st)[:4])
        D = float(np.hypot(qx - px, qy - py))
        L1, L2 = self.L1, self.L2
        d, a, b = words(D), words(L1), words(L2)
        if D > L1 + L2:
            why = f"|{self.j1.name}{self.j3.name}| = {d} > {a} + {b}"
        else:
            why = f"|{self.j1.name}{self.j3.name}| = {d} < |{a} - {b}|"
        return f"{self.label} cannot close: {why}"


class RRP(Group):
    """A rod pinned at P to a solved body and at M to a block that slides on a line of a
    solved body (the slider-crank's connecting rod and piston).

    Branch ``mode = +1``: M lies ahead of the foot of P on the guide line (in the line's
    direction).
    """

    kind = "RRP"
    n_modes = 2

    def __init__(self, rod, block, j1, j2, sl: SliderConstraint, names):
        self.rod, self.blk = rod, block
        self.j1, self.j2, self.sl = j1, j2, sl
        self.k1 = _other(j1, rod)
        self.g = sl.a  # the guide (solved)
        self.sP1, self.sPk = _local(j1, rod), _local(j1, self.k1)
        self.sMr, self.sMb = _local(j2, rod), _local(j2, block)
        self.L = length(diff(self.sMr, self.sP1))
        super().__init__([rod, block], [j1, j2, sl], names)

    def describe(self) -> str:
        return (
            f"loop {self.j2.name} ({self.body_names[0]} {self.j1.name}-{self.j2.name}, "
            f"{self.body_names[1]} on {self.sl.name})"
        )

    def _line(self, st: State):
        """Line traced by M: a point on it and its unit direction (global); cached for
        the state (the discriminant and the position read the same arrays)."""
        c = self.cache(st)
        if "line" not in c:
            c["line"] = self._line_of(st)
        return c["line"]

    def _line_of(self, st: State):
        sl, g = self.sl, self.g
        ux, uy = st.rotated(g, sl.u_loc)
        ox, oy = st.point(g, sl.o)
        # M = O + lambda u + A_block (s_M - s_P): the block keeps the guide's orientation
        th = st.th[g] + sl.beta
        c, s = np.cos(th), np.sin(th)
        wx = self.sMb[0] - sl.sb[0]
        wy = self.sMb[1] - sl.sb[1]
        return ox + c * wx - s * wy, oy + s * wx + c * wy, ux, uy, th, c, s

    def position(self, st: State, drive: Drive, mode=1.0):
        px, py = st.point(self.k1, self.sPk)
        lx, ly, ux, uy, th, c, s = self._line(st)
        lam_f = (px - lx) * ux + (py - ly) * uy  # foot of P
        fx, fy = lx + lam_f * ux, ly + lam_f * uy
        dist2 = (px - fx) ** 2 + (py - fy) ** 2
        h2 = self.L**2 - dist2
        ok = h2 >= -1e-12 * self.L**2
        h = np.sqrt(np.maximum(h2, 0.0)) * mode
        mx = np.where(ok, fx + h * ux, np.nan)
        my = np.where(ok, fy + h * uy, np.nan)
        set_pose_from_vectors(st, self.rod, self.sP1, self.sMr, px, py, mx - px, my - py)
        b = self.blk
        st.th[b], st.c[b], st.s[b] = th, c, s
        st.x[b] = mx - (c * self.sMb[0] - s * self.sMb[1])
        st.y[b] = my - (s * self.sMb[0] + c * self.sMb[1])
        ind = np.sqrt(np.maximum(h2, 0.0)) / self.L  # |cos| of the rod to the guide
        return ok, np.where(ok, ind, 0.0)

    def disc(self, st: State):
        """``1 - (dist / L)^2``: ``cos^2`` of the rod's angle to the guide."""
        px, py = st.point(self.k1, self.sPk)
        lx, ly, ux, uy, *_ = self._line(st)
        nx, ny = -uy, ux
        dist = (px - lx) * nx + (py - ly) * ny
        vpx, vpy = st.point_velocity(self.k1, self.sPk)
        vkx, vky = _carried_velocity(st, self.g, px, py)
        ddist = (vpx - vkx) * nx + (vpy - vky) * ny  # relative to the guide's frame
        L2 = self.L**2
        return 1.0 - dist * dist / L2, -2.0 * dist * ddist / L2

    def velocity(self, st: State, drive: Drive) -> None:
        g = self.g
        ux, uy = st.rotated(g, self.sl.u_loc)
        nx, ny = -uy, ux
        g1x, g1y = st.rotated(self.rod, diff(self.sMr, self.sP1))
        mx, my = st.point(self.blk, self.sMb)
        vpx, vpy = st.point_velocity(self.k1, self.sPk)
        vkx, vky = _carried_velocity(st, g, mx, my)
        # v_P + w1 perp(g1) = v_k(M) + lamdot u
        w1 = ((vkx - vpx) * nx + (vky - vpy) * ny) / (g1x * ux + g1y * uy)
        vmx = vpx - w1 * g1y
        vmy = vpy + w1 * g1x
        body_velocity_from_point(st, self.rod, self.sP1, vpx, vpy, w1)
        body_velocity_from_point(st, self.blk, self.sMb, vmx, vmy, st.w[g])

    def acceleration(self, st: State, drive: Drive) -> None:
        g = self.g
        ux, uy = st.rotated(g, self.sl.u_loc)
        nx, ny = -uy, ux
        g1x, g1y = st.rotated(self.rod, diff(self.sMr, self.sP1))
        mx, my = st.point(self.blk, self.sMb)
        vmx, vmy = st.point_velocity(self.blk, self.sMb)
        vkx, vky = _carried_velocity(st, g, mx, my)
        lamdot = (vmx - vkx) * ux + (vmy - vky) * uy
        apx, apy = st.point_acceleration(self.k1, self.sPk)
        akx, aky = _carried_acceleration(st, g, mx, my)
        wg = st.w[g]
        w1s = st.w[self.rod] ** 2
        # a_P + al1 perp(g1) - w1^2 g1 = a_k(M) + lamddot u + 2 wg lamdot n
        rx = akx + 2 * wg * lamdot * nx - apx + w1s * g1x
        ry = aky + 2 * wg * lamdot * ny - apy + w1s * g1y
        al1 = (rx * nx + ry * ny) / (g1x * ux + g1y * uy)
        amx = apx - al1 * g1y - w1s * g1x
        amy = apy + al1 * g1x - w1s * g1y
        body_acceleration_from_point(st, self.rod, self.sP1, apx, apy, al1)
        body_acceleration_from_point(st, self.blk, self.sMb, amx, amy, st.al[g])

    def forces(self, st: State, R: np.ndarray, out: dict) -> None:
        """The rod's moment about M gives the guide's normal force on the block; then the
        pin forces and the guide's moment."""
        g = self.g
        ux, uy = st.rotated(g, self.sl.u_loc)
        nx, ny = -uy, ux
        px, py = st.point(self.k1, self.sPk)
        mx, my = st.point(self.blk, self.sMb)
        sx, sy = st.point(self.blk, self.sl.sb)
        fr_x, fr_y, tr = resultant_about(st, R, self.rod, mx, my)
        fs_x, fs_y, ts = resultant_about(st, R, self.blk, mx, my)
        ex, ey = px - mx, py - my
        alpha = -tr + (ex * fr_y - ey * fr_x)  # e x F_M
        nrm = -(alpha + (ex * fs_y - ey * fs_x)) / (ex * ny - ey * nx)
        fmx, fmy = -fs_x - nrm * nx, -fs_y - nrm * ny  # on the block at M, by the rod
        fpx, fpy = fmx - fr_x, fmy - fr_y  # on the rod at P
        t = -ts - ((sx - mx) * nrm * ny - (sy - my) * nrm * nx)  # guide's moment on block
        out[self.j1] = pin_multiplier(self.j1, self.rod, fpx, fpy)
        out[self.j2] = pin_multiplier(self.j2, self.blk, fmx, fmy)
        out[self.sl] = (-nrm, -t)
        add_force(st, R, self.k1, px, py, -fpx, -fpy)
        add_force(st, R, g, sx, sy, -nrm * nx, -nrm * ny)
        if g != st.nb:
            R[3 * g + 2] -= t

    def mode_text(self, st: State, mode: float, pn) -> str:
        where = "ahead of" if mode > 0 else "behind"
        return f"{pn[self.j2]} {where} the foot of {pn[self.j1]} along {self.sl.name}"

    def fail_reason(self, st: State, i: int, words: Callable[[float], str] = metres) -> str:
        px, py = (v[i] for v in st.point(self.k1, self.sPk))
        lx, ly, ux, uy, *_ = (np.atleast_1d(v)[i] if np.ndim(v) else v for v in self._line(st))
        dist = abs((px - lx) * -uy + (py - ly) * ux)
        return (
            f"{self.label} cannot close: {self.j1.name} is {words(dist)} from the guide "
            f"line, farther than the rod length {words(self.L)}"
        )


class RPR(Group):
    """A block pinned at P to a solved body slides along a line of a bar pinned at Q to a
    solved body (the slotted guide bar of the quick-return shaper).

    Branch ``mode = +1``: for a line through the bar's pivot, the bar's line direction
    points from Q towards P (the block is on the positive side of the line).
    """

    kind = "RPR"
    n_modes = 2

    def __init__(self, block, bar, jp, jq, sl: SliderConstraint, names):
        self.blk, self.bar = block, bar
        self.jp, self.jq, self.sl = jp, jq, sl
        self.kp, self.kq = _other(jp, block), _other(jq, bar)
        self.sPb, self.sPk = _local(jp, block), _local(jp, self.kp)
        self.sQb, self.sQk = _local(jq, bar), _local(jq, self.kq)
        # geometry in the bar's frame: the block's slider point relative to its pin,
        # expressed in the bar frame (block angle = bar angle + beta, or - beta)
        if sl.a == bar:  # the line is on the bar, the block carries the point
            self.beta = sl.beta
            self.sgn = 1.0
            cb, sb = np.cos(sl.beta), np.sin(sl.beta)
            w = diff(sl.sb, self.sPb)
            self.w_loc = np.array([cb * w[0] - sb * w[1], sb * w[0] + cb * w[1]])
            self.c_loc = diff(sl.o, self.sQb)
        else:  # the line is on the pinned "block" and the point on the "bar": swap roles
            raise ValueError("RPR with the line on the pinned block is solved generically")
        self.u_loc = sl.u_loc
        self.n_loc = np.array([-sl.u_loc[1], sl.u_loc[0]])
        e = self.n_loc[0] * (self.c_loc[0] - self.w_loc[0]) + self.n_loc[1] * (
            self.c_loc[1] - self.w_loc[1]
        )
        self.e = float(e) if np.ndim(e) == 0 else e
        # a length scale for the discriminant; the analysis sets the mechanism's size
        self.lref = 1.0
        super().__init__([block, bar], [jp, jq, sl], names)

    def describe(self) -> str:
        return (
            f"loop {self.sl.name} ({self.body_names[0]} at {self.jp.name} sliding on "
            f"{self.body_names[1]} pivoted at {self.jq.name})"
        )

    def position(self, st: State, drive: Drive, mode=1.0):
        px, py = st.point(self.kp, self.sPk)
        qx, qy = st.point(self.kq, self.sQk)
        dx, dy = px - qx, py - qy
        D2 = dx * dx + dy * dy
        e = self.e
        h2 = D2 - e * e
        ok = h2 >= -1e-12 * np.maximum(D2, e * e)
        h = np.sqrt(np.maximum(h2, 0.0)) * mode
        with np.errstate(invalid="ignore", divide="ignore"):
            # the bar's global normal n with n . d = e
            nx = np.where(ok, (e * dx - h * dy) / D2, np.nan)
            ny = np.where(ok, (e * dy + h * dx) / D2, np.nan)
        # rotation of the bar: maps n_loc to n
        c = self.n_loc[0] * nx + self.n_loc[1] * ny
        s = self.n_loc[0] * ny - self.n_loc[1] * nx
        bar = self.bar
        st.c[bar], st.s[bar] = c, s
        st.th[bar] = np.arctan2(s, c)
        st.x[bar] = qx - (c * self.sQb[0] - s * self.sQb[1])
        st.y[bar] = qy - (s * self.sQb[0] + c * self.sQb[1])
        blk = self.blk
        st.set_angle(blk, st.th[bar] + self.beta)
        rx, ry = st.rotated(blk, self.sPb)
        st.x[blk] = px - rx
        st.y[blk] = py - ry
        with np.errstate(invalid="ignore", divide="ignore"):
            ind = np.sqrt(np.maximum(h2, 0.0) / np.maximum(D2, 1e-300))
        return ok, np.where(ok, ind, 0.0)

    def disc(self, st: State):
        """``(D^2 - e^2) / Lref^2``: zero when the pin reaches the line's offset circle."""
        px, py = st.point(self.kp, self.sPk)
        qx, qy = st.point(self.kq, self.sQk)
        vpx, vpy = st.point_velocity(self.kp, self.sPk)
        vqx, vqy = st.point_velocity(self.kq, self.sQk)
        dx, dy = px - qx, py - qy
        ref = self.lref**2
        return (dx * dx + dy * dy - self.e**2) / ref, 2.0 * (
            dx * (vpx - vqx) + dy * (vpy - vqy)
        ) / ref

    def _frame(self, st: State):
        ux, uy = st.rotated(self.bar, self.u_loc)
        px, py = st.point(self.kp, self.sPk)
        qx, qy = st.point(self.kq, self.sQk)
        return ux, uy, -uy, ux, px - qx, py - qy

    def velocity(self, st: State, drive: Drive) -> None:
        ux, uy, nx, ny, dx, dy = self._frame(st)
        vpx, vpy = st.point_velocity(self.kp, self.sPk)
        vqx, vqy = st.point_velocity(self.kq, self.sQk)
        rvx, rvy = vpx - vqx, vpy - vqy
        # v_P - v_Q = w perp(d) + lamdot u  (the block turns with the bar)
        w = (rvx * nx + rvy * ny) / (-dy * nx + dx * ny)
        body_velocity_from_point(st, self.bar, self.sQb, vqx, vqy, w)
        body_velocity_from_point(st, self.blk, self.sPb, vpx, vpy, w)

    def acceleration(self, st: State, drive: Drive) -> None:
        ux, uy, nx, ny, dx, dy = self._frame(st)
        vpx, vpy = st.point_velocity(self.kp, self.sPk)
        vqx, vqy = st.point_velocity(self.kq, self.sQk)
        w = st.w[self.bar]
        lamdot = (vpx - vqx + w * dy) * ux + (vpy - vqy - w * dx) * uy
        apx, apy = st.point_acceleration(self.kp, self.sPk)
        aqx, aqy = st.point_acceleration(self.kq, self.sQk)
        # a_P - a_Q = al perp(d) - w^2 d + lamddot u + 2 w lamdot n
        rx = apx - aqx + w * w * dx - 2 * w * lamdot * nx
        ry = apy - aqy + w * w * dy - 2 * w * lamdot * ny
        al = (rx * nx + ry * ny) / (-dy * nx + dx * ny)
        body_acceleration_from_point(st, self.bar, self.sQb, aqx, aqy, al)
        body_acceleration_from_point(st, self.blk, self.sPb, apx, apy, al)

    def forces(self, st: State, R: np.ndarray, out: dict) -> None:
        """The moments of block and bar about their pins give the normal force between
        them; then the pin forces and the moment between block and bar."""
        ux, uy = st.rotated(self.bar, self.u_loc)
        nx, ny = -uy, ux
        px, py = st.point(self.kp, self.sPk)
        qx, qy = st.point(self.kq, self.sQk)
        sx, sy = st.point(self.blk, self.sl.sb)
        fb_x, fb_y, tb = resultant_about(st, R, self.blk, px, py)
        fr_x, fr_y, tr = resultant_about(st, R, self.bar, qx, qy)
        # N (Q - P) x n = -(T_block,P + T_bar,Q)
        nrm = -(tb + tr) / ((qx - px) * ny - (qy - py) * nx)
        t = -tb - ((sx - px) * nrm * ny - (sy - py) * nrm * nx)  # bar's moment on block
        fpx, fpy = -fb_x - nrm * nx, -fb_y - nrm * ny  # on the block at P
        fqx, fqy = nrm * nx - fr_x, nrm * ny - fr_y  # on the bar at Q
        out[self.jp] = pin_multiplier(self.jp, self.blk, fpx, fpy)
        out[self.jq] = pin_multiplier(self.jq, self.bar, fqx, fqy)
        out[self.sl] = (-nrm, -t)
        add_force(st, R, self.kp, px, py, -fpx, -fpy)
        add_force(st, R, self.kq, qx, qy, -fqx, -fqy)

    def mode_text(self, st: State, mode: float, pn) -> str:
        if self.e == 0:
            where = "positive" if mode > 0 else "negative"
            return f"{pn[self.jp]} on the {where} side of {pn[self.jq]} along {self.sl.name}"
        return f"branch {'+' if mode > 0 else '-'} of {self.sl.name}"

    def fail_reason(self, st: State, i: int, words: Callable[[float], str] = metres) -> str:
        px, py = (v[i] for v in st.point(self.kp, self.sPk))
        qx, qy = (v[i] for v in st.point(self.kq, self.sQk))
        D = float(np.hypot(px - qx, py - qy))
        return (
            f"{self.label} cannot close: {self.jp.name} is {words(D)} from {self.jq.name}, "
            f"nearer than the line's offset {words(abs(self.e))}"
        )
