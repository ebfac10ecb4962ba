"""Independent hand-calculation reference for kinetostatic (inverse-dynamics) tests.

Method
------
This module does NOT use the solver under test and does NOT use a generic
constraint-Jacobian / Lagrange-multiplier formulation.  For each mechanism:

1. Kinematics are derived in closed form:
   * four-bar: B is found from the triangle (A, B, O4) by the law of cosines;
     angular velocities and accelerations follow from differentiating the
     vector loop  a e2 + b e3 = d i + c e4  and projecting it on e3 and e4;
   * slider-crank: sin(th3) = (e - r sin th2) / l, cos(th3) > 0; the vertical
     loop equation is differentiated for w3, al3 and the horizontal one gives
     the piston position, velocity and acceleration.
   Centre-of-mass accelerations use  a_G = a_Q + al k x r_QG - w^2 r_QG.

2. Kinetostatics are written link by link with d'Alembert's principle
   (sum of forces = m a_G, sum of moments about a chosen pin = J al plus the
   moment of the inertia force m a_G), and are solved by hand elimination:
   * four-bar: the moment equations of the coupler (about A) and of the rocker
     (about O4) give a 2x2 system for the pin force at B, solved by Cramer's
     rule; the force equations then give A, O4, O2, and the crank moment
     equation about O2 gives the driving torque;
   * slider-crank: the piston x-force equation gives C_x, the rod moment
     equation about A gives C_y, the piston y-equation gives N, the piston
     moment about C gives M (= 0, since every piston force passes through C),
     then the rod and crank force equations and the crank moment equation.

Conventions
-----------
* Angles CCW from +x, radians.  Crank at constant w2 (alpha2 = 0).
* Gravity acceleration vector (0, -g).
* Local coordinates of a point on a link: x along the base line (first point
  -> second point), y perpendicular to the left.  (gx, gy) = centre of mass,
  J = moment of inertia about the centre of mass.
* Reaction "X" between links (p, q) = force exerted ON q BY p, global axes.
* Td = torque applied to the crank by the ground (motor), CCW positive.

Array outputs have the shape of ``th2``; force vectors have shape
``(2,) + th2.shape`` (i.e. (2, n) for 1-D th2), rows = (Fx, Fy).
"""

import numpy as np

__all__ = ["fourbar_kinematics", "fourbar_forces", "slider_crank_kinematics", "slider_crank_forces"]


def _cross(u, v):
    """z-component of the 2-D cross product u x v (arrays with leading axis 2)."""
    return u[0] * v[1] - u[1] * v[0]


def _rot(th, p):
    """Rotate local point p = (px, py) by angle(s) th -> global vector (2, ...)."""
    c, s = np.cos(th), np.sin(th)
    px, py = float(p[0]), float(p[1])
    return np.array([c * px - s * py, s * px + c * py])


def _perp(w, r):
    """w k x r for scalar-field w and vector r (2, ...)."""
    return np.array([-w * r[1], w * r[0]])


# --------------------------------------------------------------------------
# Four-bar linkage
# --------------------------------------------------------------------------


def fourbar_kinematics(a, b, c, d, th2, w2, side=1):
    """Closed-form position/velocity/acceleration analysis of the four-bar.

    Returns dict with th3, th4, w3, w4, al3, al4 and the points A, B (2, ...).
    """
    th2 = np.asarray(th2, dtype=float)
    a, b, c, d, w2 = float(a), float(b), float(c), float(d), float(w2)
    al2 = 0.0
    if side not in (1, -1):
        raise ValueError("side must be +1 or -1")

    A = np.array([a * np.cos(th2), a * np.sin(th2)])
    D = np.array([d - A[0], -A[1]])  # A -> O4
    f = np.hypot(D[0], D[1])
    cpsi = (b * b + f * f - c * c) / (2.0 * b * f)
    if np.any(np.abs(cpsi) > 1.0):
        raise ValueError("four-bar cannot be assembled at some crank angles")
    spsi = side * np.sqrt(np.clip(1.0 - cpsi * cpsi, 0.0, None))
    ux, uy = D[0] / f, D[1] / f
    # rotate unit vector A->O4 by +/-psi (CCW for side=+1: B to the left)
    ex = ux * cpsi - uy * spsi
    ey = ux * spsi + uy * cpsi
    B = np.array([A[0] + b * ex, A[1] + b * ey])
    th3 = np.arctan2(ey, ex)
    th4 = np.arctan2(B[1], B[0] - d)

    s34 = np.sin(th3 - th4)
    w3 = a * w2 * np.sin(th4 - th2) / (b * s34)
    w4 = a * w2 * np.sin(th3 - th2) / (c * s34)
    # acceleration loop projected on e4 and on e3
    al3 = (
        -c * w4**2
        + a * w2**2 * np.cos(th2 - th4)
        + b * w3**2 * np.cos(th3 - th4)
        - a * al2 * np.sin(th4 - th2)
    ) / (b * np.sin(th4 - th3))
    al4 = (
        a * al2 * np.sin(th3 - th2)
        - a * w2**2 * np.cos(th2 - th3)
        - b * w3**2
        + c * w4**2 * np.cos(th3 - th4)
    ) / (c * s34)
    return dict(th3=th3, th4=th4, w3=w3, w4=w4, al3=al3, al4=al4, A=A, B=B)


def fourbar_forces(a, b, c, d, th2, w2, side, m, G, J, g, F, P, T4):
    """Newton-Euler (d'Alembert) kinetostatics of a four-bar, vectorised over th2.

    Ground pivots O2=(0,0), O4=(d,0); crank O2->A (a), coupler A->B (b),
    rocker O4->B (c).  side=+1: B left of directed line A->O4.
    m=(m2,m3,m4), G=((g2x,g2y),(g3x,g3y),(g4x,g4y)) local, J=(J2,J3,J4),
    g gravity magnitude (acceleration (0,-g)), F=(Fx,Fy) global force at
    coupler local point P=(px,py), T4 torque on rocker by ground (CCW +).

    Returns dict: th3, th4, w3, w4, al3, al4, Td, and forces (2, ...):
    O2 (on crank by ground), A (on coupler by crank), B (on rocker by
    coupler), O4 (on rocker by ground).
    """
    th2 = np.asarray(th2, dtype=float)
    w2 = float(w2)
    al2 = 0.0
    k = fourbar_kinematics(a, b, c, d, th2, w2, side)
    th3, th4, w3, w4, al3, al4 = (k[s] for s in ("th3", "th4", "w3", "w4", "al3", "al4"))
    A, B = k["A"], k["B"]
    m2, m3, m4 = (float(x) for x in m)
    J2, J3, J4 = (float(x) for x in J)
    gv = np.array([0.0, -float(g)])
    Fe = np.array([float(F[0]), float(F[1])])
    T4 = float(T4)
    zeros = np.zeros_like(th2)
    gvec = np.array([zeros + gv[0], zeros + gv[1]])
    Fvec = np.array([zeros + Fe[0], zeros + Fe[1]])

    # relative position vectors
    r2 = _rot(th2, G[0])  # O2 -> G2
    r3 = _rot(th3, G[1])  # A  -> G3
    r4 = _rot(th4, G[2])  # O4 -> G4
    rP = _rot(th3, P)  # A  -> P
    rAB = B - A  # A  -> B
    rO4B = np.array([B[0] - float(d), B[1]])  # O4 -> B

    # centre-of-mass accelerations
    aA = _perp(al2, A) - w2**2 * A
    aG2 = _perp(al2, r2) - w2**2 * r2
    aG3 = aA + _perp(al3, r3) - w3**2 * r3
    aG4 = _perp(al4, r4) - w4**2 * r4

    # "effective applied" forces: gravity minus inertia (d'Alembert)
    E2 = m2 * gvec - m2 * aG2
    E3 = m3 * gvec - m3 * aG3
    E4 = m4 * gvec - m4 * aG4

    # Coupler, moments about A:   rAB x (-FB) + r3 x E3 + rP x F - J3 al3 = 0
    #   =>  uy*FBx - ux*FBy = R3,   R3 = J3 al3 - r3 x E3 - rP x F
    R3 = J3 * al3 - _cross(r3, E3) - _cross(rP, Fvec)
    # Rocker, moments about O4:  rO4B x FB + r4 x E4 + T4 - J4 al4 = 0
    #   => -vy*FBx + vx*FBy = R4,   R4 = J4 al4 - r4 x E4 - T4
    R4 = J4 * al4 - _cross(r4, E4) - T4
    ux, uy = rAB
    vx, vy = rO4B
    det = uy * vx - ux * vy
    FB = np.array([(R3 * vx + ux * R4) / det, (uy * R4 + vy * R3) / det])

    # Coupler force balance: FA - FB + E3 + F = 0
    FA = FB - E3 - Fvec
    # Rocker force balance: FB + FO4 + E4 = 0
    FO4 = -FB - E4
    # Crank force balance: FO2 - FA + E2 = 0
    FO2 = FA - E2
    # Crank moments about O2: A x (-FA) + r2 x E2 + Td - J2 al2 = 0
    Td = J2 * al2 + _cross(A, FA) - _cross(r2, E2)

    return dict(th3=th3, th4=th4, w3=w3, w4=w4, al3=al3, al4=al4, Td=Td, O2=FO2, A=FA, B=FB, O4=FO4)


# --------------------------------------------------------------------------
# Offset slider-crank
# --------------------------------------------------------------------------


def slider_crank_kinematics(r, l, e, th2, w2):
    """Closed-form kinematics of the offset slider-crank (C ahead of A).

    Returns dict: th3, w3, al3, x, xd, xdd, A (2, ...), C (2, ...).
    """
    th2 = np.asarray(th2, dtype=float)
    r, l, e, w2 = float(r), float(l), float(e), float(w2)
    al2 = 0.0
    s3 = (e - r * np.sin(th2)) / l
    if np.any(np.abs(s3) > 1.0):
        raise ValueError("slider-crank cannot be assembled at some crank angles")
    c3 = np.sqrt(np.clip(1.0 - s3 * s3, 0.0, None))
    th3 = np.arctan2(s3, c3)
    c2, s2 = np.cos(th2), np.sin(th2)
    x = r * c2 + l * c3
    w3 = -r * w2 * c2 / (l * c3)
    al3 = (r * w2**2 * s2 - r * al2 * c2 + l * w3**2 * s3) / (l * c3)
    xd = -r * w2 * s2 - l * w3 * s3
    xdd = -r * al2 * s2 - r * w2**2 * c2 - l * al3 * s3 - l * w3**2 * c3
    A = np.array([r * c2, r * s2])
    C = np.array([x, np.zeros_like(x) + e])
    return dict(th3=th3, w3=w3, al3=al3, x=x, xd=xd, xdd=xdd, A=A, C=C)


def slider_crank_forces(r, l, e, th2, w2, m, G, J, mp, g, Fp):
    """Newton-Euler (d'Alembert) kinetostatics of the offset slider-crank.

    Crank O->A (r), rod A->C (l), piston C on y=e with x_C > x_A.
    m=(m2,m3), G=((g2x,g2y),(g3x,g3y)) local, J=(J2,J3), mp piston mass
    (centre of mass at C), g gravity magnitude, Fp external +x force on piston.

    Returns dict: x, Td, O (on crank by ground), A (on rod by crank),
    C (on piston by rod), N (y-force on piston by ground), M (moment on
    piston by ground about C; identically 0 here).
    """
    th2 = np.asarray(th2, dtype=float)
    w2 = float(w2)
    al2 = 0.0
    k = slider_crank_kinematics(r, l, e, th2, w2)
    th3, w3, al3, x, xdd = k["th3"], k["w3"], k["al3"], k["x"], k["xdd"]
    A, C = k["A"], k["C"]
    m2, m3 = float(m[0]), float(m[1])
    J2, J3 = float(J[0]), float(J[1])
    mp, g, Fp = float(mp), float(g), float(Fp)
    zeros = np.zeros_like(th2)
    gvec = np.array([zeros, zeros - g])

    r2 = _rot(th2, G[0])  # O -> G2
    r3 = _rot(th3, G[1])  # A -> G3
    rAC = C - A  # A -> C

    aA = _perp(al2, A) - w2**2 * A
    aG2 = _perp(al2, r2) - w2**2 * r2
    aG3 = aA + _perp(al3, r3) - w3**2 * r3

    E2 = m2 * gvec - m2 * aG2
    E3 = m3 * gvec - m3 * aG3

    # Piston x: FCx + Fp = mp xdd
    FCx = mp * xdd - Fp
    # Rod moments about A: rAC x (-FC) + r3 x E3 - J3 al3 = 0
    #   => -(ux FCy - uy FCx) = J3 al3 - r3 x E3
    ux, uy = rAC
    FCy = (uy * FCx + _cross(r3, E3) - J3 * al3) / ux
    FC = np.array([FCx, FCy])
    # Piston y: FCy + N - mp g = 0 (piston does not move in y)
    N = mp * g - FCy
    # Piston moments about C: every force acts through C -> M = 0
    M = np.zeros_like(x)
    # Rod force balance: FA - FC + E3 = 0
    FA = FC - E3
    # Crank force balance: FO - FA + E2 = 0
    FO = FA - E2
    # Crank moments about O: A x (-FA) + r2 x E2 + Td - J2 al2 = 0
    Td = J2 * al2 + _cross(A, FA) - _cross(r2, E2)

    return dict(x=x, Td=Td, O=FO, A=FA, C=FC, N=N, M=M)
