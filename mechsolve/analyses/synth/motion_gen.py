"""Three-position motion generation: a four-bar whose coupler line passes through three
given positions (the textbook method).

Each position i of the coupler line is a point P_i and an angle phi_i. Two moving pivots
are chosen on the coupler, in the line's own frame (origin P, x along the line): A' and B'.
In position i they are at A_i = P_i + R(phi_i) A' (and B_i likewise); each fixed pivot is
the centre of the circle through the three positions of its moving pivot (A0 for A, B0
for B). The input link A0 A then carries the coupler through the three positions, provided
the three lie on one assembly branch (no branch defect) and the input reaches them in
order (no order defect); both are checked, along with Grashof's type and the transmission
angle along the motion from position 1 to 3.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.analyses.synth.common import (
    Design,
    Point,
    cross,
    dist,
    grashof_type,
    transmission_along,
)
from mechsolve.base.errors import InputError

__all__ = ["three_positions", "circumcentre"]


def circumcentre(p1: Point, p2: Point, p3: Point) -> Point | None:
    """Centre of the circle through three points; None when they are collinear."""
    ax, ay = p1
    bx, by = p2
    cx, cy = p3
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    scale = max(dist(p1, p2), dist(p2, p3), dist(p1, p3)) ** 2
    if abs(d) <= 1e-12 * scale:
        return None
    a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    return (
        (a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / d,
        (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d,
    )


def _place(p: Point, phi: float, local: Point) -> Point:
    c, s = math.cos(phi), math.sin(phi)
    return (p[0] + c * local[0] - s * local[1], p[1] + s * local[0] + c * local[1])


def three_positions(
    positions: list[tuple[Point, float]], moving_a: Point, moving_b: Point
) -> list[Design]:
    """The four-bar through three positions of a coupler line.

    Parameters
    ----------
    positions
        Three (P_i, phi_i): a point of the line (m) and the line's angle (rad).
    moving_a, moving_b
        The moving pivots in the line's frame (m): origin P, x along the line.

    Returns
    -------
    list of Design
        Two: the linkage driven from A0 and from B0 (the same link lengths), each with its
        own order check and its Grashof type named for that input.
    """
    if len(positions) != 3:
        raise InputError(f"three positions are needed, got {len(positions)}")
    if dist(moving_a, moving_b) < 1e-12:
        raise InputError("the two moving pivots coincide")
    for i in range(3):
        for j in range(i + 1, 3):
            (p, f), (q, g) = positions[i], positions[j]
            if dist(p, q) < 1e-12 and abs(math.remainder(f - g, 2 * math.pi)) < 1e-12:
                raise InputError(f"positions {i + 1} and {j + 1} are the same")
    pa = [_place(p, f, moving_a) for p, f in positions]
    pb = [_place(p, f, moving_b) for p, f in positions]
    a0, b0 = circumcentre(*pa), circumcentre(*pb)
    for name, c in (("A", a0), ("B", b0)):
        if c is None:
            raise InputError(
                f"the three positions of the moving pivot {name} are collinear: its fixed "
                "pivot would be at infinity (a slider); choose another moving pivot"
            )
    ra, rb = dist(a0, pa[0]), dist(b0, pb[0])
    coupler, frame = dist(moving_a, moving_b), dist(a0, b0)
    out = []
    for inp, (i0, ip, o0, op, ri, ro) in (
        ("A0", (a0, pa, b0, pb, ra, rb)),
        ("B0", (b0, pb, a0, pa, rb, ra)),
    ):
        out.append(_design(inp, i0, ip, o0, op, ri, ro, coupler, frame, positions))
    return out


def _design(inp, i0, ip, o0, op, ri, ro, coupler, frame, positions) -> Design:
    notes: list[str] = []
    valid = True
    kind = grashof_type(ri, coupler, ro, frame)
    # branch: the side of the output's pin relative to the line from its fixed pivot to
    # the input's pin (the RRR dyad coupler + output)
    sides = [cross(o0, ip[i], op[i]) for i in range(3)]
    if not (all(s > 0 for s in sides) or all(s < 0 for s in sides)):
        valid = False
        notes.append("branch defect: the positions lie on different assembly branches")
    ang = [math.atan2(p[1] - i0[1], p[0] - i0[0]) for p in ip]
    # the input turns from position 1 through 2 to 3, one way or the other
    ccw12 = (ang[1] - ang[0]) % (2 * math.pi)
    ccw13 = (ang[2] - ang[0]) % (2 * math.pi)
    direction = 1 if ccw12 < ccw13 else -1
    travel = ccw13 if direction > 0 else 2 * math.pi - ccw13
    # the loop must close all the way (closed form, own check): |O0 A| within |b -+ c|
    th = ang[0] + direction * np.linspace(0, travel, 2001)
    frame_ang = math.atan2(o0[1] - i0[1], o0[0] - i0[0])
    mu = transmission_along(ri, coupler, ro, frame, th - frame_ang)
    if np.isnan(mu).any():
        valid = False
        k = int(np.argmax(np.isnan(mu)))
        notes.append(
            f"order defect: the loop cannot close between the positions (input at "
            f"{math.degrees(th[k]) % 360:.4g} deg)"
        )
        mu_min = math.nan  # not defined: the loop does not close
    else:
        mu_min = float(np.min(mu))
    return Design(
        method="three-position motion generation",
        family=f"driven from {inp}",
        lengths={"input": ri, "coupler": coupler, "output": ro, "frame": frame},
        ground={"A0": i0, "B0": o0} if inp == "A0" else {"B0": i0, "A0": o0},
        grashof=kind,
        min_transmission=mu_min,
        valid=valid,
        notes=notes,
        extra={
            "input": inp,
            "input_angles": ang,
            "direction": direction,
            "travel": travel,
            "moving": (ip, op),
            "output_left": sides[0] > 0,
            "positions": positions,
        },
    )
