"""A hand-written numpy reference for a batch of four-bar crank-rockers: kinematics and
kinetostatics of D designs at P positions at once, every result an array of shape (D, P).

The mechanism is the design study's (``_FOURBAR`` in :mod:`mechsolve_bench.study`):
ground pivots O2 = (0, 0) and O4 = (d, 0); the crank O2-A (length a) driven at the angle
u with the speed w2 and the acceleration al2; the coupler A-B (length b) with the point
P at the distance ``p_len`` from A and the angle ``p_ang`` from A->B (counter-clockwise);
the rocker O4-B (length c); B on the left of the directed line A -> O4. Each link is a
uniform bar between its two joints (centre of mass at the middle, centroidal inertia
m L^2 / 12, as mechsolve's ``uniform_bar``); gravity along -y; a force ``load`` at P
acting only where P's velocity has a positive x component (the file's ``pull``).

SI units throughout (m, s, kg, rad, N). This module is the speed and accuracy reference
that mechsolve's batch solver is measured against: it imports nothing from mechsolve,
only numpy and math, and it has no Python loop over designs or positions.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["kinematics", "kinematics_only", "kinetostatics"]

_POINTS = ("A", "B", "P", "G2", "G3", "G4")
_COMPS = ("x", "y", "vx", "vy", "ax", "ay")


def _col(x) -> np.ndarray:
    """A per-design value as a column (D, 1) (a scalar as (1, 1)), to broadcast on (D, P)."""
    x = np.asarray(x, dtype=float)
    return x.reshape(-1, 1) if x.ndim <= 1 else x


def kinematics(
    a,
    b,
    c,
    d,
    u,
    *,
    w2: float = 1.0,
    al2: float = 0.0,
    p_len: float = 0.060,
    p_ang: float = math.radians(30.0),
) -> dict[str, np.ndarray]:
    """Positions, velocities and accelerations of the four-bar, closed form.

    Parameters
    ----------
    a, b, c, d
        Crank, coupler, rocker and ground lengths (m): scalars or arrays of D designs.
    u
        Crank angles (rad), P positions (counter-clockwise from +x).
    w2, al2
        The crank's angular speed (rad/s) and acceleration (rad/s^2), the same at every
        position.
    p_len, p_ang
        The coupler point P in the coupler's frame (x along A -> B): distance from A (m)
        and angle from A -> B (rad, counter-clockwise).

    Returns
    -------
    dict of arrays (D, P):

    * ``th3``, ``th4`` -- the angles of A -> B and O4 -> B (rad, in (-pi, pi]);
      ``w3``, ``w4`` (rad/s), ``al3``, ``al4`` (rad/s^2) -- their rates;
    * ``"<Q>.<c>"`` for the points Q in A, B, P, G2, G3, G4 (G2, G3, G4: the centres of
      mass of the crank, coupler, rocker, the bars' midpoints) and c in x, y (m),
      vx, vy (m/s), ax, ay (m/s^2).

    and, to carry the design to :func:`kinetostatics`: ``a``, ``b``, ``c``, ``d`` as
    columns (D, 1), ``u`` as a row (1, P), ``w2`` and ``al2`` as floats.

    B is the intersection of the circles |AB| = b and |O4 B| = c on the left of A -> O4;
    where they do not meet (not the case for a Grashof crank-rocker) the values are NaN.
    The rates solve the loop equation A + (B - A) = O4 + (B - O4) differentiated once and
    twice, by Cramer's rule on its 2 x 2 system.
    """
    a, b, c, d = _col(a), _col(b), _col(c), _col(d)
    u = np.asarray(u, dtype=float).reshape(1, -1)
    cu, su = np.cos(u), np.sin(u)
    # crank: A = a (cos u, sin u)
    Ax, Ay = a * cu, a * su
    Avx, Avy = -w2 * Ay, w2 * Ax
    Aax = -al2 * Ay - w2 * w2 * Ax
    Aay = al2 * Ax - w2 * w2 * Ay
    # B: the circle about A (radius b) meets the circle about O4 (radius c) at the
    # distance f from A along A -> O4 and h to its left
    ex, ey = d - Ax, -Ay
    r2 = ex * ex + ey * ey
    r = np.sqrt(r2)
    ex /= r
    ey /= r
    f = (b * b - c * c + r2) / (2.0 * r)
    with np.errstate(invalid="ignore"):
        h = np.sqrt(b * b - f * f)  # NaN where the circles do not meet
    ABx = f * ex - h * ey  # B - A
    ABy = f * ey + h * ex
    Bx, By = Ax + ABx, Ay + ABy
    CBx, CBy = Bx - d, By  # B - O4
    # velocities: w3 k x AB - w4 k x CB = -vA; det = CB x AB
    det = CBx * ABy - CBy * ABx
    w3 = (Avx * CBx + Avy * CBy) / det
    w4 = (Avx * ABx + Avy * ABy) / det
    Bvx, Bvy = -w4 * CBy, w4 * CBx
    # accelerations: al3 k x AB - al4 k x CB = -(aA - w3^2 AB + w4^2 CB)
    Rx = Aax - w3 * w3 * ABx + w4 * w4 * CBx
    Ry = Aay - w3 * w3 * ABy + w4 * w4 * CBy
    al3 = (Rx * CBx + Ry * CBy) / det
    al4 = (Rx * ABx + Ry * ABy) / det
    Bax = -al4 * CBy - w4 * w4 * CBx
    Bay = al4 * CBx - w4 * w4 * CBy
    # P = A + p_len (cos, sin)(th3 + p_ang): the offset in the frame (AB / b, k x AB / b)
    px, py = p_len * math.cos(p_ang) / b, p_len * math.sin(p_ang) / b
    APx = px * ABx - py * ABy
    APy = px * ABy + py * ABx
    Px, Py = Ax + APx, Ay + APy
    Pvx, Pvy = Avx - w3 * APy, Avy + w3 * APx
    Pax = Aax - al3 * APy - w3 * w3 * APx
    Pay = Aay + al3 * APx - w3 * w3 * APy
    out = {
        "th3": np.arctan2(ABy, ABx),
        "th4": np.arctan2(CBy, CBx),
        "w3": w3,
        "w4": w4,
        "al3": al3,
        "al4": al4,
    }
    pts = {
        "A": (Ax, Ay, Avx, Avy, Aax, Aay),
        "B": (Bx, By, Bvx, Bvy, Bax, Bay),
        "P": (Px, Py, Pvx, Pvy, Pax, Pay),
        # the bars' midpoints: the crank's and rocker's other ends are fixed
        "G2": (0.5 * Ax, 0.5 * Ay, 0.5 * Avx, 0.5 * Avy, 0.5 * Aax, 0.5 * Aay),
        "G3": (
            0.5 * (Ax + Bx),
            0.5 * (Ay + By),
            0.5 * (Avx + Bvx),
            0.5 * (Avy + Bvy),
            0.5 * (Aax + Bax),
            0.5 * (Aay + Bay),
        ),
        "G4": (0.5 * (Bx + d), 0.5 * By, 0.5 * Bvx, 0.5 * Bvy, 0.5 * Bax, 0.5 * Bay),
    }
    for name, vals in pts.items():
        for comp, v in zip(_COMPS, vals):
            out[f"{name}.{comp}"] = v
    out.update(a=a, b=b, c=c, d=d, u=u, w2=float(w2), al2=float(al2))
    return out


def kinematics_only(
    a, b, c, d, u, *, w2: float = 1.0, al2: float = 0.0, acceleration: bool = True
) -> dict[str, np.ndarray]:
    """What a kinematics-only design study reads of the four-bar, closed form.

    The same mechanism and branch as :func:`kinematics`, written for the figures of a
    study without forces: the coupler's and rocker's angles and rates (the rocker's
    swing and time ratio are located from its angle and angular velocity), the sine of
    the transmission angle at B, and the moving joints A and B. No coupler point and no
    centres of mass (nothing reads them), accelerations only with ``acceleration``.

    Parameters
    ----------
    a, b, c, d
        Crank, coupler, rocker and ground lengths (m): scalars or arrays of D designs.
    u
        Crank angles (rad), P positions.
    w2, al2
        The crank's angular speed (rad/s) and acceleration (rad/s^2).
    acceleration
        Also the angular accelerations ``al3``, ``al4``.

    Returns
    -------
    dict of arrays (D, P): ``th3``, ``th4`` (rad, in (-pi, pi]), ``w3``, ``w4`` (rad/s),
    ``al3``, ``al4`` (rad/s^2, with ``acceleration``), ``sin_mu`` (the sine of the angle
    between coupler and rocker at B, 0 at a toggle position), ``A.x``, ``A.y``, ``B.x``,
    ``B.y`` (m).

    B - A = f e + h (k x e), with e the unit vector from A to O4 at the distance r,
    f = (b^2 - c^2 + r^2) / (2 r) and h = sqrt(b^2 - f^2); the rates solve
    w3 k x AB - w4 k x O4B = -v_A and its derivative by Cramer's rule.
    """
    a, b, c, d = _col(a), _col(b), _col(c), _col(d)
    u = np.asarray(u, dtype=float).reshape(1, -1)
    Ax = a * np.cos(u)
    Ay = a * np.sin(u)
    # e r = O4 - A; AB = (f e r + h k x e r) / r
    erx = d - Ax
    r2 = erx * erx + Ay * Ay
    r = np.sqrt(r2)
    f = (b * b - c * c + r2) / (2.0 * r)
    with np.errstate(invalid="ignore"):
        h = np.sqrt(b * b - f * f)  # NaN where the loop cannot close
    ABx = (f * erx + h * Ay) / r
    ABy = (h * erx - f * Ay) / r
    Bx, By = Ax + ABx, Ay + ABy
    CBx = Bx - d  # O4 -> B
    det = CBx * ABy - By * ABx
    # v_A = w2 k x A
    Avx, Avy = -w2 * Ay, w2 * Ax
    w3 = (Avx * CBx + Avy * By) / det
    w4 = (Avx * ABx + Avy * ABy) / det
    out = {
        "th3": np.arctan2(ABy, ABx),
        "th4": np.arctan2(By, CBx),
        "w3": w3,
        "w4": w4,
        "sin_mu": np.abs(det) / (b * c),
        "A.x": Ax,
        "A.y": Ay,
        "B.x": Bx,
        "B.y": By,
    }
    if acceleration:
        # a_A = al2 k x A - w2^2 A
        Rx = -al2 * Ay - w2 * w2 * Ax - w3 * w3 * ABx + w4 * w4 * CBx
        Ry = al2 * Ax - w2 * w2 * Ay - w3 * w3 * ABy + w4 * w4 * By
        out["al3"] = (Rx * CBx + Ry * By) / det
        out["al4"] = (Rx * ABx + Ry * ABy) / det
    return out


def kinetostatics(
    kin: dict[str, np.ndarray],
    m2: float = 0.05,
    m3: float = 0.2,
    m4: float = 0.11,
    *,
    g: float = 9.81,
    load: tuple[float, float] = (0.0, -2.0),
) -> dict[str, np.ndarray]:
    """Joint reactions and the driving torque, Newton-Euler with d'Alembert inertia forces.

    Parameters
    ----------
    kin
        The output of :func:`kinematics`.
    m2, m3, m4
        Masses (kg) of the crank, coupler and rocker: uniform bars between their joints
        (centre at the middle, J = m L^2 / 12 about it), scalars or arrays of D designs.
    g
        Gravity (m/s^2), along -y.
    load
        The force (N) at P, acting where ``P.vx > 0`` (the file's conditional ``pull``).

    Returns
    -------
    dict of arrays (D, P):

    * ``<J>.Fx``, ``<J>.Fy`` (N) for the joints J in O2, A, B, O4. Sign convention (that of
      mechsolve, whose joints are ``O2: [ground, crank]``, ``A: [crank, coupler]``,
      ``B: [coupler, rocker]``, ``O4: [ground, rocker]``): the reaction of a joint
      [first, second] is the force exerted ON THE SECOND body BY THE FIRST, i.e. O2 on
      the crank by the ground, A on the coupler by the crank, B on the rocker by the
      coupler, O4 on the rocker by the ground;
    * ``torque`` (N m): the driving torque applied to the crank (by the ground, through
      the driver), counter-clockwise positive; ``torque * w2`` is the driving power;
    * ``pull.active`` (bool): where the load acts.

    The classic dyad-by-dyad solution: the moments of the rocker about O4 and of the
    coupler about A give the force at B (a 2 x 2 system, Cramer's rule); the coupler's
    and rocker's force balances then give A and O4; last, the crank's force balance
    gives O2 and its moment about O2 the torque.
    """
    a, b, c = kin["a"], kin["b"], kin["c"]
    al2 = kin["al2"]
    m2, m3, m4 = _col(m2), _col(m3), _col(m4)
    J2, J3, J4 = m2 * a * a / 12.0, m3 * b * b / 12.0, m4 * c * c / 12.0
    Ax, Ay = kin["A.x"], kin["A.y"]
    Bx, By = kin["B.x"], kin["B.y"]
    d = kin["d"]
    active = kin["P.vx"] > 0.0
    Lx = active * load[0] if load[0] else 0.0
    Ly = active * load[1] if load[1] else 0.0
    # the d'Alembert-augmented external forces on each centre: weight - m aG
    F3x = -m3 * kin["G3.ax"]
    F3y = -m3 * (kin["G3.ay"] + g)
    F4x = -m4 * kin["G4.ax"]
    F4y = -m4 * (kin["G4.ay"] + g)
    ABx, ABy = Bx - Ax, By - Ay
    CBx, CBy = Bx - d, By
    # rocker about O4: CB x F_B + M4 = 0, with M4 the moment of its weight and inertia
    # force at G4 = O4 + CB / 2 and its inertia couple
    M4 = 0.5 * (CBx * F4y - CBy * F4x) - J4 * kin["al4"]
    # coupler about A: -AB x F_B + M3 = 0 (the force on the coupler at B is -F_B), M3 the
    # moment of its weight and inertia force at G3 = A + AB / 2, the load at P and the
    # inertia couple
    M3 = (
        0.5 * (ABx * F3y - ABy * F3x)
        + (kin["P.x"] - Ax) * Ly
        - (kin["P.y"] - Ay) * Lx
        - J3 * kin["al3"]
    )
    # [-CBy CBx; -ABy ABx] F_B = [-M4; M3]
    det = CBx * ABy - CBy * ABx
    FBx = -(M4 * ABx + M3 * CBx) / det
    FBy = -(M4 * ABy + M3 * CBy) / det
    # coupler: F_A - F_B + L + F3 = 0; rocker: F_B + F_O4 + F4 = 0
    FAx = FBx - Lx - F3x
    FAy = FBy - Ly - F3y
    # crank: F_O2 - F_A + F2 = 0 with F2 = -m2 (aG2 + g j); about O2:
    # -A x F_A + G2 x F2 + T - J2 al2 = 0, G2 = A / 2
    F2x = -m2 * kin["G2.ax"]
    F2y = -m2 * (kin["G2.ay"] + g)
    torque = Ax * (FAy - 0.5 * F2y) - Ay * (FAx - 0.5 * F2x)
    if al2:
        torque = torque + J2 * al2
    return {
        "O2.Fx": FAx - F2x,
        "O2.Fy": FAy - F2y,
        "A.Fx": FAx,
        "A.Fy": FAy,
        "B.Fx": FBx,
        "B.Fy": FBy,
        "O4.Fx": -FBx - F4x,
        "O4.Fy": -FBy - F4y,
        "torque": torque,
        "pull.active": active,
    }
