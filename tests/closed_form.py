"""Independent closed-form kinematics used as references by the tests.

Written from textbook formulas (Norton, "Design of Machinery", ch. 4, 6, 7), not from
mechsolve's code: the four-bar by Freudenstein's half-angle solution, the offset
slider-crank by the sine rule, the inverted slider-crank (slotted bar) by polar
coordinates. All angles in rad, counter-clockwise from +x; the crank turns at constant
omega2 (alpha2 = 0).
"""

from __future__ import annotations

import numpy as np


def fourbar(a, b, c, d, th2, w2, branch, al2=0.0):
    """Four-bar: crank a (pivot at the origin), coupler b, rocker c, ground d along +x.

    ``branch`` is +1 (Norton's "open") or -1 ("crossed"); the crank may accelerate
    (``al2``). Returns th3, th4, w3, w4, al3, al4, or NaN where the linkage cannot close.
    """
    th2 = np.asarray(th2, float)
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    A = np.cos(th2) - K1 - K2 * np.cos(th2) + K3
    B = -2 * np.sin(th2)
    C = K1 - (K2 + 1) * np.cos(th2) + K3
    K4, K5 = d / b, (c * c - d * d - a * a - b * b) / (2 * a * b)
    D = np.cos(th2) - K1 + K4 * np.cos(th2) + K5
    E = -2 * np.sin(th2)
    F = K1 + (K4 - 1) * np.cos(th2) + K5
    with np.errstate(invalid="ignore"):
        th4 = 2 * np.arctan2(-B - branch * np.sqrt(B * B - 4 * A * C), 2 * A)
        th3 = 2 * np.arctan2(-E - branch * np.sqrt(E * E - 4 * D * F), 2 * D)
    w3 = a * w2 * np.sin(th4 - th2) / (b * np.sin(th3 - th4))
    w4 = a * w2 * np.sin(th2 - th3) / (c * np.sin(th4 - th3))
    Ap, Bp = c * np.sin(th4), b * np.sin(th3)
    Cp = (
        a * al2 * np.sin(th2)
        + a * w2**2 * np.cos(th2)
        + b * w3**2 * np.cos(th3)
        - c * w4**2 * np.cos(th4)
    )
    Dp, Ep = c * np.cos(th4), b * np.cos(th3)
    Fp = (
        a * al2 * np.cos(th2)
        - a * w2**2 * np.sin(th2)
        - b * w3**2 * np.sin(th3)
        + c * w4**2 * np.sin(th4)
    )
    al3 = (Cp * Dp - Ap * Fp) / (Ap * Ep - Bp * Dp)
    al4 = (Cp * Ep - Bp * Fp) / (Ap * Ep - Bp * Dp)
    return th3, th4, w3, w4, al3, al4


def slider_crank(r, l, e, th, w, ahead=True):
    """Offset slider-crank: crank r at the origin, rod l, slider on the line y = e.

    Returns x, xdot, xddot of the slider and phi, phidot, phiddot of the rod (angle of
    the line from the crank pin to the slider).
    """
    th = np.asarray(th, float)
    s = (e - r * np.sin(th)) / l
    with np.errstate(invalid="ignore"):
        phi = np.arcsin(s) if ahead else np.pi - np.arcsin(s)
    cphi = np.cos(phi)
    x = r * np.cos(th) + l * cphi
    phid = -r * w * np.cos(th) / (l * cphi)
    phidd = (r * w * w * np.sin(th) + l * phid**2 * np.sin(phi)) / (l * cphi)
    xd = -r * w * np.sin(th) - l * phid * np.sin(phi)
    xdd = -r * w * w * np.cos(th) - l * phidd * np.sin(phi) - l * phid**2 * cphi
    return x, xd, xdd, phi, phid, phidd


def slotted_bar(r, d, th, w):
    """Inverted slider-crank: crank r about (0, d), bar pivoted at the origin through the
    crank pin. Returns the bar angle psi, psidot, psiddot and the pin's distance s from
    the bar pivot with sdot, sddot."""
    th = np.asarray(th, float)
    x, y = r * np.cos(th), d + r * np.sin(th)
    xd, yd = -r * w * np.sin(th), r * w * np.cos(th)
    xdd, ydd = -r * w * w * np.cos(th), -r * w * w * np.sin(th)
    s = np.hypot(x, y)
    psi = np.arctan2(y, x)
    sd = (x * xd + y * yd) / s
    psid = (x * yd - y * xd) / s**2
    sdd = (xd * xd + yd * yd + x * xdd + y * ydd) / s - sd**2 / s
    psidd = (x * ydd - y * xdd) / s**2 - 2 * sd * psid / s
    return psi, psid, psidd, s, sd, sdd


def fourbar_disc(a, b, c, d, th2):
    """Norton's discriminant B^2 - 4AC of the rocker angle: negative where the four-bar
    cannot close."""
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    A = np.cos(th2) - K1 - K2 * np.cos(th2) + K3
    B = -2 * np.sin(th2)
    C = K1 - (K2 + 1) * np.cos(th2) + K3
    return B * B - 4 * A * C


def dyad(P, vP, aP, Q, L1, L2, branch):
    """Two links P-M (L1) and Q-M (L2), P moving, Q fixed; M on the left of P -> Q for
    branch +1. Law of cosines for the position; the loop P + L1 e1 = Q + L2 e2
    differentiated once and twice, solved by Cramer's rule. Returns phi1, phi2 (angles of
    P->M and Q->M), their rates and accelerations, and M."""
    px, py = P
    qx, qy = Q
    dx, dy = qx - px, qy - py
    D = np.hypot(dx, dy)
    with np.errstate(invalid="ignore"):
        gamma = np.arccos((L1 * L1 + D * D - L2 * L2) / (2 * L1 * D))
    phi1 = np.arctan2(dy, dx) + branch * gamma
    mx, my = px + L1 * np.cos(phi1), py + L1 * np.sin(phi1)
    phi2 = np.arctan2(my - qy, mx - qx)
    # L1 w1 (-s1, c1) - L2 w2 (-s2, c2) = -vP
    s1, c1, s2, c2 = np.sin(phi1), np.cos(phi1), np.sin(phi2), np.cos(phi2)
    a11, a12, a21, a22 = -L1 * s1, L2 * s2, L1 * c1, -L2 * c2
    det = a11 * a22 - a12 * a21
    r1, r2 = -vP[0], -vP[1]
    w1 = (r1 * a22 - a12 * r2) / det
    w2 = (a11 * r2 - r1 * a21) / det
    # second derivative: same matrix, centripetal terms on the right
    r1 = -aP[0] + L1 * w1**2 * c1 - L2 * w2**2 * c2
    r2 = -aP[1] + L1 * w1**2 * s1 - L2 * w2**2 * s2
    al1 = (r1 * a22 - a12 * r2) / det
    al2 = (a11 * r2 - r1 * a21) / det
    return phi1, phi2, w1, w2, al1, al2, (mx, my)


def slotted_bar_offset(r, d, e, th, w, branch):
    """Slotted bar pivoted at the origin whose line runs at distance e from the pivot
    (on the side of its normal); a crank r about (0, d) carries the block.

    Returns the bar angle psi with its rate and acceleration, and the block's displacement
    s along the line (from the foot of the pivot) with its rate and acceleration.
    """
    th = np.asarray(th, float)
    x, y = r * np.cos(th), d + r * np.sin(th)
    xd, yd = -r * w * np.sin(th), r * w * np.cos(th)
    xdd, ydd = -r * w * w * np.cos(th), -r * w * w * np.sin(th)
    D = np.hypot(x, y)
    Dd = (x * xd + y * yd) / D
    Ddd = (xd * xd + yd * yd + x * xdd + y * ydd) / D - Dd**2 / D
    al = np.arctan2(y, x)
    ald = (x * yd - y * xd) / D**2
    aldd = (x * ydd - y * xdd) / D**2 - 2 * ald * Dd / D
    S = np.sqrt(D * D - e * e)
    Sd = D * Dd / S
    beta = np.arccos(e / D)
    betad = e * Dd / (D * S)
    betadd = e * (Ddd * D * S - Dd * (Dd * S + D * Sd)) / (D * S) ** 2
    psi = al + branch * beta - np.pi / 2
    psid = ald + branch * betad
    psidd = aldd + branch * betadd
    ux, uy = np.cos(psi), np.sin(psi)
    pux, puy = -uy, ux
    s = ux * x + uy * y
    sd = psid * (pux * x + puy * y) + ux * xd + uy * yd
    sdd = (
        (psidd * pux - psid**2 * ux) * x
        + (psidd * puy - psid**2 * uy) * y
        + 2 * psid * (pux * xd + puy * yd)
        + ux * xdd
        + uy * ydd
    )
    return psi, psid, psidd, s, sd, sdd
