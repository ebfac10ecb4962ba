"""Independent references for the force-element, moving-guide and design-figure tests.

Nothing here imports mechsolve. Three tools:

* :class:`Rigid` - the motion of a rigid link from its frame origin's motion and its
  angle, angular velocity and acceleration (``a_P = a_O + al k x r - w^2 r``);
* :func:`newton_euler` - free-body equations written body by body, with the joint forces
  as explicit unknowns: for every moving body ``sum F = sum m_i a_i`` and ``sum M_G =
  J al + moments of the particles' inertia``. A body is a list of *particles* (mass,
  point) plus an inertia about its own centre, so a link with point masses is never
  combined by the parallel-axis theorem here: each particle carries its own inertia force.
  The unknowns are pin forces (on ``b`` by ``a``), slider contacts (a normal force along
  the line's left normal at the slider point, on the block by the guide, and a couple) and
  the driver's torque (on the driven link by the ground). The square linear system is
  solved at every position;
* :func:`fd_rates` - first and second derivatives of a position solution by central
  differences at two step sizes and Richardson's extrapolation, with the convergence of
  the raw differences returned so the tests can show it.
"""

from __future__ import annotations

import numpy as np


def rot(th, p):
    """The local vector ``p`` of a link at angle(s) ``th``, in global axes (2, N)."""
    c, s = np.cos(th), np.sin(th)
    return np.array([c * p[0] - s * p[1], s * p[0] + c * p[1]])


def perp(w, r):
    """``w k x r``."""
    return np.array([-w * r[1], w * r[0]])


def cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


class Rigid:
    """A link's motion: frame origin O (position, velocity, acceleration, each (2, N))
    and its angle, angular velocity and angular acceleration (N)."""

    def __init__(self, O, vO, aO, th, w, al):
        n = np.shape(th)
        self.O = np.broadcast_to(np.asarray(O, float).reshape(2, -1), (2,) + n)
        self.vO = np.broadcast_to(np.asarray(vO, float).reshape(2, -1), (2,) + n)
        self.aO = np.broadcast_to(np.asarray(aO, float).reshape(2, -1), (2,) + n)
        self.th, self.w, self.al = np.asarray(th), np.asarray(w), np.asarray(al)

    def pos(self, p):
        return self.O + rot(self.th, p)

    def vel(self, p):
        return self.vO + perp(self.w, rot(self.th, p))

    def acc(self, p):
        r = rot(self.th, p)
        return self.aO + perp(self.al, r) - self.w**2 * r

    def vec(self, p):
        """A local direction in global axes."""
        return rot(self.th, p)


class Body:
    """A moving body of the free-body solution: particles, inertia, applied loads."""

    def __init__(self, link: Rigid):
        self.link = link
        self.particles: list[tuple[float, tuple[float, float]]] = []  # (m, local point)
        self.inertias: list[float] = []  # about the particles' own centres (J al)
        self.forces: list[tuple[np.ndarray, np.ndarray]] = []  # (global point, force)
        self.torque = 0.0

    def mass(self, m, p, J=0.0):
        self.particles.append((float(m), tuple(p)))
        self.inertias.append(float(J))
        return self

    def force(self, P, F):
        self.forces.append((np.asarray(P, float), np.asarray(F, float)))
        return self


def newton_euler(bodies: dict[str, Body], joints: list[tuple], gravity=(0.0, -9.81)):
    """Solve the free-body equations of every body for the joint forces.

    ``joints``: ``("pin", name, a, b, P)`` - force (Fx, Fy) on ``b`` by ``a`` at P;
    ``("slider", name, guide, block, S, n)`` - normal force N n at S and couple M, on
    the block by the guide (and their opposites on the guide); ``("driver", name, b)`` -
    torque on ``b`` by the ground. ``"ground"`` has no equations. Returns a dict of the
    unknowns by joint: pins (Fx, Fy), sliders (N, M), the driver T.
    """
    names = list(bodies)
    n = np.shape(next(iter(bodies.values())).link.th)[0]
    unknowns = []
    for j in joints:
        k = {"pin": 2, "slider": 2, "driver": 1}[j[0]]
        unknowns += [(j[1], i) for i in range(k)]
    nu, ne = len(unknowns), 3 * len(names)
    assert nu == ne, f"{nu} unknowns, {ne} equations"
    A = np.zeros((n, ne, nu))
    rhs = np.zeros((n, ne))
    col = {u: i for i, u in enumerate(unknowns)}
    gx, gy = gravity
    ref = {}
    for bi, name in enumerate(names):
        B = bodies[name]
        lk = B.link
        O = lk.O  # moments about the body's frame origin
        ref[name] = O
        r0 = 3 * bi
        # sum of known forces minus inertia: goes to the right-hand side with a minus
        Fx = np.zeros(n)
        Fy = np.zeros(n)
        Mz = np.zeros(n) + B.torque
        for (m, p), J in zip(B.particles, B.inertias):
            P = lk.pos(p)
            a = lk.acc(p)
            fx, fy = m * (gx - a[0]), m * (gy - a[1])
            Fx += fx
            Fy += fy
            Mz += (P[0] - O[0]) * fy - (P[1] - O[1]) * fx - J * lk.al
        for P, F in B.forces:
            Fx += F[0]
            Fy += F[1]
            Mz += (P[0] - O[0]) * F[1] - (P[1] - O[1]) * F[0]
        rhs[:, r0] = -Fx
        rhs[:, r0 + 1] = -Fy
        rhs[:, r0 + 2] = -Mz

    def put(body, c, fx, fy, P, sign, couple=0.0):
        if body == "ground":
            return
        r0 = 3 * names.index(body)
        O = ref[body]
        A[:, r0, c] += sign * fx
        A[:, r0 + 1, c] += sign * fy
        A[:, r0 + 2, c] += sign * ((P[0] - O[0]) * fy - (P[1] - O[1]) * fx + couple)

    one, zero = np.ones(n), np.zeros(n)
    for j in joints:
        if j[0] == "pin":
            _, nm, a, b, P = j
            for i, (fx, fy) in enumerate(((one, zero), (zero, one))):
                put(b, col[(nm, i)], fx, fy, P, 1.0)
                put(a, col[(nm, i)], fx, fy, P, -1.0)
        elif j[0] == "slider":
            _, nm, g, blk, S, nv = j
            put(blk, col[(nm, 0)], nv[0], nv[1], S, 1.0)
            put(g, col[(nm, 0)], nv[0], nv[1], S, -1.0)
            put(blk, col[(nm, 1)], zero, zero, S, 1.0, one)
            put(g, col[(nm, 1)], zero, zero, S, -1.0, one)
        else:
            _, nm, b = j
            put(b, col[(nm, 0)], zero, zero, ref[b], 1.0, one)
    x = np.linalg.solve(A, rhs[..., None])[..., 0]
    out = {}
    for j in joints:
        k = {"pin": 2, "slider": 2, "driver": 1}[j[0]]
        vals = [x[:, col[(j[1], i)]] for i in range(k)]
        out[j[1]] = vals[0] if k == 1 else np.array(vals)
    return out


def fd_rates(position, x, hs=(2e-3, 1e-3), angles=()):
    """Derivatives of ``position(x) -> dict of arrays`` with respect to x, by central
    differences at the steps ``hs = (h, h/2)`` and Richardson's extrapolation.

    Returns ``{key: (value, d1, d2, raw)}`` where ``raw`` holds the plain central
    differences ``((d1(h), d2(h)), (d1(h/2), d2(h/2)))``: second-order estimates whose
    errors must fall by about 4 from h to h/2. Keys listed in ``angles`` are angles whose
    differences are taken modulo 2 pi.
    """
    h1, h2 = hs
    assert abs(h1 - 2 * h2) < 1e-15 * h1
    f0 = position(x)
    out = {}
    evals = {h: (position(x + h), position(x - h)) for h in hs}
    for key, v0 in f0.items():
        raw = []
        for h in hs:
            fp, fm = evals[h][0][key], evals[h][1][key]
            dp, dm = fp - v0, fm - v0
            if key in angles:
                dp = (dp + np.pi) % (2 * np.pi) - np.pi
                dm = (dm + np.pi) % (2 * np.pi) - np.pi
            raw.append(((dp - dm) / (2 * h), (dp + dm) / h**2))
        d1 = (4 * raw[1][0] - raw[0][0]) / 3
        d2 = (4 * raw[1][1] - raw[0][1]) / 3
        out[key] = (v0, d1, d2, raw)
    return out
