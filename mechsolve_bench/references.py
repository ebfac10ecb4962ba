"""Hand-written references for the benchmarks, independent of the solver.

Nothing here imports mechsolve's solver: these are the closed forms and free-body
solutions an engineer writes by hand in numpy, against which mechsolve's speed and error
are measured.

* :func:`fourbar_textbook`: Norton's half-angle closed form (Design of Machinery, 4.10,
  6.7, 7.3) for positions, velocities and accelerations, trigonometric throughout;
* :func:`fourbar_vector`: the same by circle intersection in vector form, with no
  trigonometry but the crank's, the fastest closed form we could write;
* :func:`fourbar_forces`: kinetostatics of the four-bar, free body by free body: the
  coupler-rocker dyad by the force polygon (tangential components from each link's
  moment about the inner joint, normal ones from the dyad's force balance), then the crank;
* :func:`crane_kinematics` and :func:`crane_forces`: the dock crane in complex numbers,
  dyad by dyad as its seed program does, and its free-body kinetostatics.
"""

from __future__ import annotations

import math

import numpy as np

# --- the four-bar of the benchmarks ---------------------------------------------------
A2, B3, C4, D1 = 0.0265, 0.1056, 0.059, 0.0875  # crank, coupler, rocker, ground (m)


def fourbar_textbook(th2, w2=1.0, a=A2, b=B3, c=C4, d=D1):
    """Open-branch four-bar by Norton's formulas: angles, rates, accelerations."""
    c2, s2 = np.cos(th2), np.sin(th2)
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    A = c2 - K1 - K2 * c2 + K3
    B = -2 * s2
    C = K1 - (K2 + 1) * c2 + K3
    th4 = 2 * np.arctan2(-B - np.sqrt(B * B - 4 * A * C), 2 * A)
    K4, K5 = d / b, (c * c - d * d - a * a - b * b) / (2 * a * b)
    D = c2 - K1 + K4 * c2 + K5
    E = -2 * s2
    F = K1 + (K4 - 1) * c2 + K5
    th3 = 2 * np.arctan2(-E - np.sqrt(E * E - 4 * D * F), 2 * D)
    c3, s3, c4, s4 = np.cos(th3), np.sin(th3), np.cos(th4), np.sin(th4)
    s34 = np.sin(th3 - th4)
    w3 = a * w2 * np.sin(th4 - th2) / (b * s34)
    w4 = a * w2 * np.sin(th2 - th3) / (-c * s34)
    Ap, Bp = c * s4, b * s3
    Cp = a * w2 * w2 * c2 + b * w3 * w3 * c3 - c * w4 * w4 * c4
    Dp, Ep = c * c4, b * c3
    Fp = -a * w2 * w2 * s2 - b * w3 * w3 * s3 + c * w4 * w4 * s4
    den = Ap * Ep - Bp * Dp
    al3 = (Cp * Dp - Ap * Fp) / den
    al4 = (Cp * Ep - Bp * Fp) / den
    return th3, th4, w3, w4, al3, al4


def fourbar_vector(th2, w2=1.0, a=A2, b=B3, c=C4, d=D1):
    """The same four-bar by circle intersection, vectors only."""
    ax, ay = a * np.cos(th2), a * np.sin(th2)
    dx, dy = d - ax, -ay
    D2 = dx * dx + dy * dy
    f = (b * b - c * c + D2) / (2 * D2)
    h = np.sqrt(b * b / D2 - f * f)
    bx, by = ax + f * dx - h * dy, ay + f * dy + h * dx
    g1x, g1y, g2x, g2y = bx - ax, by - ay, bx - d, by
    cr = g1x * g2y - g1y * g2x
    vax, vay = -ay * w2, ax * w2
    w3 = (-vax * g2x - vay * g2y) / cr
    w4 = (-vax * g1x - vay * g1y) / cr
    dax = ax * w2 * w2 - w4 * w4 * g2x + w3 * w3 * g1x
    day = ay * w2 * w2 - w4 * w4 * g2y + w3 * w3 * g1y
    al3 = (dax * g2x + day * g2y) / cr
    al4 = (dax * g1x + day * g1y) / cr
    return np.arctan2(g1y, g1x), np.arctan2(g2y, g2x), w3, w4, al3, al4


# masses of the benchmark four-bar: uniform bars, and a load at a coupler point
MASSES = (0.05, 0.2, 0.11)
LOAD = (1.0, -2.0)  # N, at the coupler point P
P_LOCAL = (0.05, 0.02)  # m, in the coupler's frame (x along A -> B)
G = 9.81


def fourbar_forces(th2, w2=1.0, a=A2, b=B3, c=C4, d=D1):
    """Driving torque and pin forces of the four-bar with uniform bars, gravity and the
    load at P, by free bodies. Returns Td and the forces on the crank at O2, on the
    coupler at A, on the rocker at B and on the rocker at O4 (each as complex Fx + i Fy).
    """
    m2, m3, m4 = MASSES
    th3, th4, w3, w4, al3, al4 = fourbar_textbook(th2, w2, a, b, c, d)
    e2, e3, e4 = np.exp(1j * th2), np.exp(1j * th3), np.exp(1j * th4)
    A = a * e2
    B = d + c * e4
    # accelerations of the centres (alpha2 = 0)
    aG2 = -(w2**2) * a / 2 * e2
    aA = -(w2**2) * A
    aG3 = aA + (1j * al3 - w3**2) * (b / 2) * e3
    aG4 = (1j * al4 - w4**2) * (c / 2) * e4
    G2, G3, G4 = A / 2, A + b / 2 * e3, d + c / 2 * e4
    P = A + (P_LOCAL[0] + 1j * P_LOCAL[1]) * e3
    J3, J4 = m3 * b * b / 12, m4 * c * c / 12
    # known forces (gravity, inertia, the load) and moments (inertia couples)
    F3 = m3 * (-1j * G) - m3 * aG3 + (LOAD[0] + 1j * LOAD[1])
    F4 = m4 * (-1j * G) - m4 * aG4

    def cross(u, v):
        return (u.conjugate() * v).imag

    # moments about B of everything known on the coupler and on the rocker
    M3B = cross(G3 - B, m3 * (-1j * G) - m3 * aG3) + cross(P - B, LOAD[0] + 1j * LOAD[1])
    M3B = M3B - J3 * al3
    M4B = cross(G4 - B, m4 * (-1j * G) - m4 * aG4) - J4 * al4
    # tangential components: A on the coupler, O4 on the rocker (moments about B)
    uA, uO = (A - B) / b, (d - B) / c  # unit vectors from B
    tA = -M3B / b  # component of the force at A along i * uA
    tO = -M4B / c
    # normal components from the dyad's force balance: nA uA + nO uO = S
    S = -(F3 + F4) - tA * 1j * uA - tO * 1j * uO
    det = cross(uA, uO)
    nA = cross(S, uO) / det
    nO = cross(uA, S) / det
    FA = tA * 1j * uA + nA * uA  # on the coupler at A, by the crank
    FO4 = tO * 1j * uO + nO * uO  # on the rocker at O4, by the ground
    FB = -FO4 - F4  # on the rocker at B, by the coupler
    # the crank: the coupler pushes it with -FA at A
    aG2f = m2 * (-1j * G) - m2 * aG2
    FO2 = FA - aG2f  # on the crank at O2, by the ground
    J2 = m2 * a * a / 12
    Td = -(cross(A, -FA) + cross(G2, aG2f) - J2 * 0.0)
    return Td, FO2, FA, FB, FO4


# --- the dock crane (seed 000) --------------------------------------------------------
O1, O3, O4 = 2.86 + 4.0j, 0.0 + 0.0j, 5.6 + 8.1j
L1, L2, L3B, L3C, L4, L5, L4K = 1.388, 2.780, 4.0, 28.525, 3.625, 25.15, 8.35
BETA_C, BETA_K = np.radians(25.0), np.radians(176.0)
S3 = (8.5, np.radians(7.0))
S4 = (1.0, np.radians(95.0))
S5 = (2.5, np.radians(24.0))
M3, M4, M5, Q = 3500.0, 3600.0, 5500.0, 50e3


def _dyad(P, vP, aP, Qp, l1, l2, side):
    """Links P-M (l1) and Q-M (l2), Q fixed, M on the ``side`` (+1 left) of P -> Q:
    angles of P -> M and Q -> M with their rates and accelerations (complex algebra)."""
    dq = Qp - P
    D = np.abs(dq)
    gam = np.arccos((l1 * l1 + D * D - l2 * l2) / (2 * l1 * D))
    t1 = np.angle(dq) + side * gam
    M = P + l1 * np.exp(1j * t1)
    t2 = np.angle(M - Qp)
    e1, e2 = np.exp(1j * t1), np.exp(1j * t2)
    # vP + i w1 l1 e1 = i w2 l2 e2: project on e2 and e1 to eliminate
    w1 = (-vP * e2.conjugate()).real / (1j * l1 * e1 * e2.conjugate()).real
    w2 = (vP * e1.conjugate()).real / (1j * l2 * e2 * e1.conjugate()).real
    rhs = -aP + w1**2 * l1 * e1 - w2**2 * l2 * e2  # = i al1 l1 e1 - i al2 l2 e2
    a1 = (rhs * e2.conjugate()).real / (1j * l1 * e1 * e2.conjugate()).real
    a2 = -(rhs * e1.conjugate()).real / (1j * l2 * e2 * e1.conjugate()).real
    return t1, t2, w1, w2, a1, a2, M


def crane_kinematics(th1, w1):
    """Link angles (crank, coupler, jib, boom, tie), their rates and accelerations, and
    the points of the crane, as complex numbers."""
    e1 = np.exp(1j * th1)
    A = O1 + L1 * e1
    vA = 1j * w1 * L1 * e1
    aA = -(w1**2) * L1 * e1
    # B on the right of A -> O3 ("B left of O3 -> A")
    t2, t3, w2, w3, a2, a3, B = _dyad(A, vA, aA, O3, L2, L3B, -1)
    eC = np.exp(1j * (t3 + BETA_C))
    C = O3 + L3C * eC
    vC = 1j * w3 * L3C * eC
    aC = (1j * a3 - w3**2) * L3C * eC
    t4, t5, w4, w5, a4, a5, D = _dyad(C, vC, aC, O4, L4, L5, +1)
    eK = np.exp(1j * (t4 + BETA_K))
    K = C + L4K * eK
    vK = vC + 1j * w4 * L4K * eK
    aK = aC + (1j * a4 - w4**2) * L4K * eK
    return dict(
        th=(th1, t2, t3, t4, t5),
        w=(w1, w2, w3, w4, w5),
        al=(0.0, a2, a3, a4, a5),
        A=A,
        B=B,
        C=C,
        D=D,
        K=K,
        vK=vK,
        aK=aK,
        aC=aC,
        vC=vC,
    )


def crane_forces(th1, w1):
    """Driving torque and the fixed-hinge reactions of the crane (point masses at S3, S4,
    S5, gravity, the load at K while K moves left), free body by free body."""
    k = crane_kinematics(th1, w1)
    _, t2, t3, t4, t5 = k["th"]
    _, w2, w3, w4, w5 = k["w"]
    _, a2, a3, a4, a5 = k["al"]
    A, B, C, D, K = k["A"], k["B"], k["C"], k["D"], k["K"]

    def point(origin, r, ang, t, w, al, a_origin):
        e = np.exp(1j * (t + ang))
        return origin + r * e, a_origin + (1j * al - w * w) * r * e

    g = -1j * 9.81
    pS3, aS3 = point(O3, S3[0], S3[1], t3, w3, a3, 0.0)
    pS4, aS4 = point(C, S4[0], S4[1], t4, w4, a4, k["aC"])
    pS5, aS5 = point(O4, S5[0], S5[1], t5, w5, a5, 0.0)
    load = np.where(k["vK"].real < 0, -1j * Q, 0.0)
    F3 = M3 * (g - aS3)
    F4 = M4 * (g - aS4) + load
    F5 = M5 * (g - aS5)

    def cross(u, v):
        return (u.conjugate() * v).imag

    # dyad boom (4) and tie (5), inner joint D: tangential components by moments about D
    M4D = cross(pS4 - D, M4 * (g - aS4)) + cross(K - D, load)
    M5D = cross(pS5 - D, F5)
    u4, u5 = (C - D) / L4, (O4 - D) / L5
    t4c, t5c = -M4D / L4, -M5D / L5
    S = -(F4 + F5) - t4c * 1j * u4 - t5c * 1j * u5
    det = cross(u4, u5)
    n4, n5 = cross(S, u5) / det, cross(u4, S) / det
    FC = t4c * 1j * u4 + n4 * u4  # on the boom at C, by the jib
    RO4 = t5c * 1j * u5 + n5 * u5  # on the tie at O4, by the ground
    # the jib: -FC at C, its weight and inertia, the two-force coupler's push at B
    eAB = (B - A) / np.abs(B - A)
    M3O3 = cross(C - O3, -FC) + cross(pS3 - O3, F3)
    f = -M3O3 / cross(B - O3, eAB)  # the coupler pushes the jib with f eAB at B
    FB = f * eAB
    RO3 = -(FB - FC + F3)  # on the jib at O3, by the ground
    RO1 = FB  # on the crank at O1: the coupler pulls the crank with -FB at A
    Td = cross(A - O1, FB)
    return Td, RO1, RO3, RO4


def crane_limits():
    """Positions of the crane used by the benchmarks: crank angles of one turn."""
    return np.linspace(0.0, 2 * np.pi, 3600, endpoint=False)


# --- seed 004: the motor-driven machine, as its Mathcad program reduces it ---------------
def seed004_startup(h: float = 0.002, T: float = 2.2):
    """The start-up of seed 004 written as its program does: the closed-form positions,
    the velocity coefficients from the 3x3 system A(phi) x = B(phi), the reduced inertia
    J(phi) and the reduced moment of gravity tabulated over a turn (periodic cubic
    splines, J' their derivative), then ``rkfixed``: RK4 with a fixed step.

    Returns (t, phi, omega, eps)."""
    from scipy.interpolate import CubicSpline

    OA, AB, O1B, O1K, KD = 0.15, 0.97, 0.66, 0.25, 0.86
    a, b, g = 0.5, 0.37, 9.81
    m0, m1, m2, m3, m4 = 1.5, 9.7, 6.6, 8.6, 2.0
    JO, J1, J2, J3 = m0 * OA**2 / 3, m1 * AB**2 / 12, m2 * O1B**2 / 3, m3 * KD**2 / 12
    M0, nu0, mu = 50.0, 1.25, 15.0
    x = np.linspace(0.0, 2 * np.pi, 7201)
    Ax, Ay = OA * np.cos(x), OA * np.sin(x)
    dx, dy = Ax - a, Ay - b
    O1A = np.hypot(dx, dy)
    al = np.arctan2(dy, dx)
    f2 = al + np.arccos((O1A**2 + O1B**2 - AB**2) / (2 * O1A * O1B))
    Bx, By = a + O1B * np.cos(f2), b + O1B * np.sin(f2)
    f1 = np.arctan2(By - Ay, Bx - Ax)
    f3 = np.arccos(-O1K * np.cos(f2) / KD)
    # velocity coefficients (per unit crank rate): A(phi) [f1', f2', f3'] = B(phi)
    A = np.zeros((len(x), 3, 3))
    A[:, 0, 0], A[:, 0, 1] = -AB * np.sin(f1), O1B * np.sin(f2)
    A[:, 1, 0], A[:, 1, 1] = AB * np.cos(f1), -O1B * np.cos(f2)
    A[:, 2, 1], A[:, 2, 2] = -O1K * np.sin(f2), -KD * np.sin(f3)
    Bv = np.stack([OA * np.sin(x), -OA * np.cos(x), np.zeros_like(x)], axis=1)
    w1, w2, w3 = np.linalg.solve(A, Bv[..., None])[..., 0].T
    # centres of mass: velocity coefficients
    vc1 = (-OA * np.sin(x) - AB / 2 * np.sin(f1) * w1, OA * np.cos(x) + AB / 2 * np.cos(f1) * w1)
    vc2 = (-O1B / 2 * np.sin(f2) * w2, O1B / 2 * np.cos(f2) * w2)
    vK = (-O1K * np.sin(f2) * w2, O1K * np.cos(f2) * w2)
    vc3 = (vK[0] - KD / 2 * np.sin(f3) * w3, vK[1] + KD / 2 * np.cos(f3) * w3)
    vD = vK[1] + KD * np.cos(f3) * w3  # the slider moves along y
    vc0y = OA / 2 * np.cos(x)
    J = (
        JO
        + m1 * (vc1[0] ** 2 + vc1[1] ** 2)
        + J1 * w1**2
        + J2 * w2**2
        + m3 * (vc3[0] ** 2 + vc3[1] ** 2)
        + J3 * w3**2
        + m4 * vD**2
    )
    Mg = -g * (m0 * vc0y + m1 * vc1[1] + m2 * vc2[1] + m3 * vc3[1] + m4 * vD)
    Js = CubicSpline(x, J, bc_type="periodic")
    dJs = Js.derivative()
    Ms = CubicSpline(x, Mg, bc_type="periodic")
    Vs = CubicSpline(x, vD**2, bc_type="periodic")
    tau = 2 * np.pi

    def rhs(y):
        p = y[0] % tau
        w = y[1]
        return np.array([w, (M0 + Ms(p) - (nu0 + mu * Vs(p)) * w - 0.5 * dJs(p) * w * w) / Js(p)])

    n = int(round(T / h))
    Y = np.zeros((n + 1, 2))
    for i in range(n):
        y = Y[i]
        k1 = rhs(y)
        k2 = rhs(y + h / 2 * k1)
        k3 = rhs(y + h / 2 * k2)
        k4 = rhs(y + h * k3)
        Y[i + 1] = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    eps = np.array([rhs(y)[1] for y in Y])
    return np.arange(n + 1) * h, Y[:, 0], Y[:, 1], eps


# --- a Stephenson III six-bar whose triad has no closed form ----------------------------
# The triad of tests/test_hard_cases.py with a 0.2 crank: the crank O-A drives the
# ternary link T (points P1, P2, P3) through the binary link L3 (A-P3); T is held by
# L1 (G1-P1) and L2 (G2-P2). The lengths are those of a configuration built first (link
# L1 at -60 deg, T turned 0.2 rad, the crank at 0.3 rad), so that it closes there.
TRIAD_G1, TRIAD_G2 = (0.0, 1.2), (0.96, 1.63)
TRIAD_R = 0.2
TRIAD_T = ((0.0, 0.0), (0.9, 0.1), (0.4, -0.5))  # P1, P2, P3 in T's frame
TRIAD_START = 0.3  # rad, the crank at the built configuration
TRIAD_L1 = 0.7


def triad_geometry():
    """Lengths ``l1, l2, l3`` and the start angles ``(phi1, psi, phi2, phi3)`` (L1, T, L2,
    L3, each a link's direction from its ground or crank end) of the triad six-bar."""
    (g1x, g1y), (g2x, g2y) = TRIAD_G1, TRIAD_G2
    p1, p2, p3 = (np.asarray(p, float) for p in TRIAD_T)
    phi1, psi = np.radians(-60.0), 0.2
    P1 = np.array([g1x, g1y]) + TRIAD_L1 * np.array([np.cos(phi1), np.sin(phi1)])
    c, s = np.cos(psi), np.sin(psi)
    rot = np.array([[c, -s], [s, c]])
    P2, P3 = P1 + rot @ (p2 - p1), P1 + rot @ (p3 - p1)
    A = TRIAD_R * np.array([np.cos(TRIAD_START), np.sin(TRIAD_START)])
    l2 = float(np.hypot(*(P2 - (g2x, g2y))))
    l3 = float(np.hypot(*(P3 - A)))
    phi2 = float(np.arctan2(P2[1] - g2y, P2[0] - g2x))
    phi3 = float(np.arctan2(P3[1] - A[1], P3[0] - A[0]))
    return (TRIAD_L1, l2, l3), np.array([phi1, psi, phi2, phi3])


def _triad_parts():
    """The loop equations ``F(x, th) = c(th) + sum_k R(x_k) v_k`` in the angles ``x =
    (phi1, psi, phi2, phi3)``: rows 0-1 close G1-P1-P2-G2, rows 2-3 close G1-P1-P3-A-O.
    Returns ``v`` (2 equations, 4 angles, 2) and the constant part of ``c``."""
    (l1, l2, l3), _ = triad_geometry()
    p1, p2, p3 = (np.asarray(p, float) for p in TRIAD_T)
    v = np.zeros((2, 4, 2))
    v[:, 0] = (l1, 0.0)
    v[0, 1], v[1, 1] = p2 - p1, p3 - p1
    v[0, 2] = (-l2, 0.0)
    v[1, 3] = (-l3, 0.0)
    c0 = np.array([np.subtract(TRIAD_G1, TRIAD_G2), np.asarray(TRIAD_G1, float)])
    return v, c0


def _triad_eval(x, th, v, c0):
    """Residual (N, 4) and Jacobian (N, 4, 4) at angles ``x`` (N, 4), crank ``th`` (N,),
    written out for this mechanism; also the rotated vectors ``R(x_k) v_k`` (for the
    accelerations) as ``rx, ry`` (N, 2, 4)."""
    n = len(th)
    c, s = np.cos(x), np.sin(x)
    rx = np.empty((n, 2, 4))
    ry = np.empty((n, 2, 4))
    for e in range(2):
        for k in range(4):
            a, b = v[e, k]
            if a == 0.0 and b == 0.0:
                rx[:, e, k] = ry[:, e, k] = 0.0
            elif b == 0.0:
                rx[:, e, k], ry[:, e, k] = a * c[:, k], a * s[:, k]
            else:
                rx[:, e, k] = a * c[:, k] - b * s[:, k]
                ry[:, e, k] = a * s[:, k] + b * c[:, k]
    f = np.empty((n, 4))
    f[:, 0] = c0[0, 0] + rx[:, 0, 0] + rx[:, 0, 1] + rx[:, 0, 2]
    f[:, 1] = c0[0, 1] + ry[:, 0, 0] + ry[:, 0, 1] + ry[:, 0, 2]
    f[:, 2] = c0[1, 0] + rx[:, 1, 0] + rx[:, 1, 1] + rx[:, 1, 3] - TRIAD_R * np.cos(th)
    f[:, 3] = c0[1, 1] + ry[:, 1, 0] + ry[:, 1, 1] + ry[:, 1, 3] - TRIAD_R * np.sin(th)
    J = np.empty((n, 4, 4))
    J[:, 0::2] = -ry
    J[:, 1::2] = rx
    return f, J, rx, ry


def _triad_scalar(x, v, c00, c01, c10, c11):
    """Residual and Jacobian at one position, in floats (``c1`` with the crank point)."""
    f = [c00, c01, c10, c11]
    J = [[0.0] * 4 for _ in range(4)]
    for k in range(4):
        c, s = math.cos(x[k]), math.sin(x[k])
        for e in range(2):
            a, b = v[e][k]
            rx, ry = c * a - s * b, s * a + c * b
            f[2 * e] += rx
            f[2 * e + 1] += ry
            J[2 * e][k] = -ry
            J[2 * e + 1][k] = rx
    return f, J


def _solve4(J, b) -> list[float]:
    return np.linalg.solve(np.array(J), np.array(b)).tolist()


def triad_newton(th, w2: float = 1.0, coarse: int = 25, updates: int = 2):
    """The triad six-bar by a batched Newton written by hand in the links' angles.

    ``th`` is a sweep of crank angles from :data:`TRIAD_START`, in order. Every k-th
    position (``coarse`` of them) is solved by continuation (Newton from the previous
    one, predicted along its tangent); cubic Hermite interpolation of the angles and
    their rates predicts the positions in between, which ``updates`` batched Newton
    steps refine. Rates and accelerations by the differentiated loop equations. Returns
    the angles (N, 4) of L1, T, L2, L3, their rates and accelerations."""
    th = np.asarray(th, float)
    n = len(th)
    v, c0 = _triad_parts()
    _, x = triad_geometry()
    dA = np.zeros((n, 4))  # -dF/dth: the crank point's rate on rows 2-3
    dA[:, 2], dA[:, 3] = -TRIAD_R * np.sin(th), TRIAD_R * np.cos(th)
    ks = np.unique(np.linspace(0, n - 1, min(coarse, n)).round().astype(int))
    xc = np.empty((len(ks), 4))
    dxc = np.empty((len(ks), 4))
    # the coarse continuation one position at a time: plain floats, no arrays
    vv = [[(float(a), float(b)) for a, b in row] for row in v]
    c00, c01, c10, c11 = (float(z) for z in c0.ravel())
    xs = [float(z) for z in x]
    dx = [0.0] * 4
    prev_t = float(th[0])
    for j, k in enumerate(ks):
        t = float(th[k])
        xs = [xs[i] + dx[i] * (t - prev_t) for i in range(4)]
        ca, sa = math.cos(t), math.sin(t)
        for _ in range(20):
            f, J = _triad_scalar(xs, vv, c00, c01, c10 - TRIAD_R * ca, c11 - TRIAD_R * sa)
            step = _solve4(J, [-z for z in f])
            xs = [xs[i] + step[i] for i in range(4)]
            if max(abs(z) for z in step) < 1e-13:
                break
        _, J = _triad_scalar(xs, vv, c00, c01, c10 - TRIAD_R * ca, c11 - TRIAD_R * sa)
        dx = _solve4(J, [0.0, 0.0, -TRIAD_R * sa, TRIAD_R * ca])
        xc[j], dxc[j], prev_t = xs, dx, t
    if len(ks) > 1:
        seg = np.clip(np.searchsorted(ks, np.arange(n), side="right") - 1, 0, len(ks) - 2)
        t0, t1 = th[ks[seg]], th[ks[seg + 1]]
        h = (t1 - t0)[:, None]
        t = ((th - t0) / (t1 - t0))[:, None]
        x = (
            (2 * t**3 - 3 * t**2 + 1) * xc[seg]
            + (t**3 - 2 * t**2 + t) * h * dxc[seg]
            + (-2 * t**3 + 3 * t**2) * xc[seg + 1]
            + (t**3 - t**2) * h * dxc[seg + 1]
        )
    else:
        x = xc[[0] * n]
    for _ in range(updates):
        f, J, _, _ = _triad_eval(x, th, v, c0)
        x = x + np.linalg.solve(J, -f[..., None])[..., 0]
    f, J, rx, ry = _triad_eval(x, th, v, c0)
    inv = np.linalg.inv(J)
    w = (inv @ (dA * w2)[..., None])[..., 0]
    w_sq = w * w
    g = np.empty((n, 4))  # sum_k R(x_k) v_k w_k^2 - A'' w2^2 on rows 2-3
    g[:, 0::2] = (rx * w_sq[:, None, :]).sum(axis=2)
    g[:, 1::2] = (ry * w_sq[:, None, :]).sum(axis=2)
    g[:, 2] -= TRIAD_R * np.cos(th) * w2 * w2
    g[:, 3] -= TRIAD_R * np.sin(th) * w2 * w2
    al = (inv @ g[..., None])[..., 0]
    return x, w, al, np.max(np.abs(f), axis=1)


def fourbar_newton(th2, w2: float = 1.0, coarse: int = 25, updates: int = 2):
    """The benchmark four-bar by a batched Newton written by hand in the coupler's and
    rocker's angles (as :func:`triad_newton`: a coarse continuation at ``coarse``
    positions, cubic Hermite prediction, ``updates`` batched Newton steps), for the
    open branch. ``th2`` is a sweep of crank angles from 0, in order. Returns
    ``th3, th4, w3, w4, al3, al4`` and the largest loop residual at each position."""
    a, b, c, d = A2, B3, C4, D1
    th2 = np.asarray(th2, float)
    n = len(th2)
    # the start: the open branch's closed form at th2[0], for the first guess only
    t30, t40, *_ = fourbar_vector(th2[:1])
    ks = np.unique(np.linspace(0, n - 1, min(coarse, n)).round().astype(int))
    xc = np.empty((len(ks), 2))
    dxc = np.empty((len(ks), 2))
    x3, x4 = float(t30[0]), float(t40[0])
    d3 = d4 = 0.0
    prev = float(th2[0])
    for j, k in enumerate(ks):
        t = float(th2[k])
        x3, x4 = x3 + d3 * (t - prev), x4 + d4 * (t - prev)
        ca, sa = a * math.cos(t), a * math.sin(t)
        for _ in range(20):  # a + b e3 - c e4 - d = 0, in floats
            c3, s3, c4, s4 = math.cos(x3), math.sin(x3), math.cos(x4), math.sin(x4)
            f0, f1 = ca + b * c3 - c * c4 - d, sa + b * s3 - c * s4
            j00, j01, j10, j11 = -b * s3, c * s4, b * c3, -c * c4
            det = j00 * j11 - j01 * j10
            s_3 = -(j11 * f0 - j01 * f1) / det
            s_4 = -(-j10 * f0 + j00 * f1) / det
            x3, x4 = x3 + s_3, x4 + s_4
            if max(abs(s_3), abs(s_4)) < 1e-13:
                break
        c3, s3, c4, s4 = math.cos(x3), math.sin(x3), math.cos(x4), math.sin(x4)
        j00, j01, j10, j11 = -b * s3, c * s4, b * c3, -c * c4
        det = j00 * j11 - j01 * j10
        r0, r1 = sa, -ca  # -d/dth2 of the crank's point
        d3, d4 = (j11 * r0 - j01 * r1) / det, (-j10 * r0 + j00 * r1) / det
        xc[j], dxc[j], prev = (x3, x4), (d3, d4), t
    seg = np.clip(np.searchsorted(ks, np.arange(n), side="right") - 1, 0, max(len(ks) - 2, 0))
    if len(ks) > 1:
        t0, t1 = th2[ks[seg]], th2[ks[seg + 1]]
        h = (t1 - t0)[:, None]
        t = ((th2 - t0) / (t1 - t0))[:, None]
        x = (
            (2 * t**3 - 3 * t**2 + 1) * xc[seg]
            + (t**3 - 2 * t**2 + t) * h * dxc[seg]
            + (-2 * t**3 + 3 * t**2) * xc[seg + 1]
            + (t**3 - t**2) * h * dxc[seg + 1]
        )
    else:
        x = xc[[0] * n]
    th3, th4 = x[:, 0].copy(), x[:, 1].copy()
    ca, sa = a * np.cos(th2), a * np.sin(th2)
    for it in range(updates + 1):
        c3, s3, c4, s4 = np.cos(th3), np.sin(th3), np.cos(th4), np.sin(th4)
        f0, f1 = ca + b * c3 - c * c4 - d, sa + b * s3 - c * s4
        j00, j01, j10, j11 = -b * s3, c * s4, b * c3, -c * c4
        det = j00 * j11 - j01 * j10
        if it == updates:
            break
        th3 = th3 - (j11 * f0 - j01 * f1) / det
        th4 = th4 - (-j10 * f0 + j00 * f1) / det
    r0, r1 = sa * w2, -ca * w2
    w3, w4 = (j11 * r0 - j01 * r1) / det, (-j10 * r0 + j00 * r1) / det
    # second derivative: J al = a w2^2 e2 + b w3^2 e3 - c w4^2 e4
    g0 = ca * w2 * w2 + b * c3 * w3 * w3 - c * c4 * w4 * w4
    g1 = sa * w2 * w2 + b * s3 * w3 * w3 - c * s4 * w4 * w4
    al3, al4 = (j11 * g0 - j01 * g1) / det, (-j10 * g0 + j00 * g1) / det
    return th3, th4, w3, w4, al3, al4, np.maximum(np.abs(f0), np.abs(f1))
