"""Crank-rocker four-bars from the rocker's two limit positions.

At a limit position of the rocker the crank and the coupler are in line, so the crank
pivot O1 is at distance b + a (extended) from one limit position B2 of the rocker's pin
and b - a (folded) from the other, B1. Hence the **extreme-distance method** (seed 000,
task 2):

    a = (|O1 B2| - |O1 B1|) / 2,    b = (|O1 B2| + |O1 B1|) / 2.

Between the two limits the crank turns 180 deg + theta one way and 180 deg - theta the
other, theta being the angle B1 O1 B2; the time ratio is K = (180 + theta) / (180 - theta).
The **time-ratio method** inverts this: for a given K, theta = 180 deg (K - 1) / (K + 1)
and O1 lies on the locus of points from which the chord B1 B2 is seen under theta: two
circular arcs through B1 and B2 (radius |B1 B2| / (2 sin theta)), one on each side of the
chord. A point of the locus is a valid crank pivot only when B1 and B2 lie on the same side
of the frame line O1 O3 (the same assembly branch) and the result is a Grashof crank-rocker;
the valid points fall into separate arcs, the families of solutions (the folded position
at one limit or the other). Along each arc the pivot is chosen by a given frame length
|O1 O3|, or else where the minimum transmission angle is largest.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.analyses.synth.common import (
    Design,
    Point,
    cross,
    dist,
    fourbar_min_transmission,
    grashof_type,
    is_crank_rocker,
    polar,
    time_ratio_angle,
    time_ratio_of,
)
from mechsolve.base.errors import InputError

__all__ = ["extreme_distance", "from_time_ratio", "from_one_limit", "crank_rocker_at"]


def _check_rocker(rocker: float, psi1: float, psi2: float) -> None:
    if not (math.isfinite(rocker) and rocker > 0):
        raise InputError(f"rocker length {rocker!r}: it must be positive")
    swing = abs(psi2 - psi1)
    if not (1e-9 < swing < math.pi):
        raise InputError(
            f"rocker limits {math.degrees(psi1):g} and {math.degrees(psi2):g} deg: the swing "
            "must be between 0 and 180 deg"
        )


def crank_rocker_at(
    crank_pivot: Point, rocker_pivot: Point, rocker: float, psi1: float, psi2: float, method: str
) -> Design:
    """The crank-rocker with its crank pivot at ``crank_pivot`` whose rocker (pivot
    ``rocker_pivot``, length ``rocker``) has its limit positions at the angles ``psi1`` and
    ``psi2`` (rad, of the line pivot -> pin), by the extreme distances. Invalid designs are
    returned with ``valid = False`` and the reason in ``notes``."""
    o1, o3 = crank_pivot, rocker_pivot
    b1, b2 = polar(o3, rocker, psi1), polar(o3, rocker, psi2)
    d1, d2 = dist(o1, b1), dist(o1, b2)
    a, b = abs(d2 - d1) / 2, (d1 + d2) / 2
    frame = dist(o1, o3)
    notes: list[str] = []
    valid = True
    if frame < 1e-12 * rocker:
        raise InputError("the crank pivot coincides with the rocker pivot")
    if a <= 1e-12 * b:
        valid = False
        notes.append("the pivot is as far from both limit positions: the crank would be 0")
        kind = "degenerate"
        mu = 0.0
    else:
        kind = grashof_type(a, b, rocker, frame)
        mu = fourbar_min_transmission(a, b, rocker, frame) if is_crank_rocker(kind) else 0.0
    s1, s2 = cross(o1, o3, b1), cross(o1, o3, b2)
    if valid and s1 * s2 <= 0:
        valid = False
        notes.append(
            "the two limit positions lie on opposite sides of the frame line O1-O3 "
            "(different assembly branches)"
        )
    if valid and not is_crank_rocker(kind):
        valid = False
        notes.append(f"not a crank-rocker: {kind}")
    u1 = math.atan2(b1[1] - o1[1], b1[0] - o1[0])
    u2 = math.atan2(b2[1] - o1[1], b2[0] - o1[0])
    theta = abs((u2 - u1 + math.pi) % (2 * math.pi) - math.pi)  # angle B1 O1 B2
    folded = 1 if d1 < d2 else 2
    # crank angles at the limits: towards the pin when extended, away when folded
    crank_at = (u1 + (math.pi if folded == 1 else 0.0), u2 + (math.pi if folded == 2 else 0.0))
    a_pts = [polar(o1, a, crank_at[0]), polar(o1, a, crank_at[1])]
    side = [cross(o3, a_pts[0], b1), cross(o3, a_pts[1], b2)]
    if valid and side[0] * side[1] <= 0:  # cannot happen for a Grashof crank-rocker
        valid = False
        notes.append("the limit positions are on different branches of the dyad A-B-O3")
    return Design(
        method=method,
        family=f"folded at limit {folded}",
        lengths={"crank": a, "coupler": b, "rocker": rocker, "frame": frame},
        ground={"O1": tuple(o1), "O3": tuple(o3)},
        grashof=kind,
        min_transmission=mu,
        time_ratio=time_ratio_of(theta),
        valid=valid,
        notes=notes,
        extra={
            "limits": (psi1, psi2),
            "B_limits": (b1, b2),
            "extreme_distances": (d1, d2),
            "theta": theta,
            "crank_at_limits": crank_at,
            "B_left_of_O3_A": side[0] > 0,
        },
    )


def extreme_distance(
    crank_pivot: Point, rocker_pivot: Point, rocker: float, psi1: float, psi2: float
) -> list[Design]:
    """Crank and coupler lengths for given ground pivots, rocker length and limit angles
    (rad, of the line rocker pivot -> pin): the extreme-distance method. One solution."""
    _check_rocker(rocker, psi1, psi2)
    return [crank_rocker_at(crank_pivot, rocker_pivot, rocker, psi1, psi2, "extreme distances")]


def _locus_circles(b1: Point, b2: Point, theta: float):
    """The two circles through b1 and b2 from whose arcs the chord is seen under theta:
    (centre, radius) each."""
    mx, my = (b1[0] + b2[0]) / 2, (b1[1] + b2[1]) / 2
    chord = dist(b1, b2)
    nx, ny = -(b2[1] - b1[1]) / chord, (b2[0] - b1[0]) / chord  # left normal of b1 -> b2
    r = chord / (2 * math.sin(theta))
    h = chord / (2 * math.tan(theta))
    return [((mx + s * h * nx, my + s * h * ny), r) for s in (1, -1)]


def _angle_at(p: Point, b1: Point, b2: Point) -> float:
    v1 = (b1[0] - p[0], b1[1] - p[1])
    v2 = (b2[0] - p[0], b2[1] - p[1])
    return math.atan2(abs(v1[0] * v2[1] - v1[1] * v2[0]), v1[0] * v2[0] + v1[1] * v2[1])


def from_time_ratio(
    rocker_pivot: Point,
    rocker: float,
    psi1: float,
    psi2: float,
    k: float,
    frame: float | None = None,
    step: float = math.radians(0.05),
) -> list[Design]:
    """Crank-rockers whose rocker swings between ``psi1`` and ``psi2`` (rad) with time
    ratio ``k``.

    Parameters
    ----------
    rocker_pivot, rocker
        The rocker's fixed pivot (m) and length (m).
    psi1, psi2
        The angles of the rocker's line (pivot -> pin) at its limits (rad).
    k
        Time ratio K >= 1.
    frame
        The frame length |O1 O3| (m): the crank pivot where the circle of this radius
        about O3 meets the locus (up to four points). Without it, the point of each arc of
        valid pivots with the largest minimum transmission angle (scanned in ``step`` of
        the locus circle, then refined by Brent's method).

    Returns
    -------
    list of Design
        Every solution found, valid or not (the invalid ones say why).
    """
    _check_rocker(rocker, psi1, psi2)
    theta = time_ratio_angle(k)
    o3 = rocker_pivot
    b1, b2 = polar(o3, rocker, psi1), polar(o3, rocker, psi2)
    method = f"time ratio K = {k:g} (theta = {math.degrees(theta):.6g} deg)"
    if theta < 1e-9:
        return _on_chord_line(o3, rocker, psi1, psi2, b1, b2, frame, method)
    circles = _locus_circles(b1, b2, theta)
    out: list[Design] = []
    if frame is not None:
        if not (math.isfinite(frame) and frame > 0):
            raise InputError(f"frame length {frame!r}: it must be positive")
        for ci, (c, r) in enumerate(circles):
            for p in _circle_circle(o3, frame, c, r):
                if abs(_angle_at(p, b1, b2) - theta) < 1e-9:
                    d = crank_rocker_at(p, o3, rocker, psi1, psi2, method)
                    d.family += f", pivot on locus circle {ci + 1}"
                    out.append(d)
        if not out:
            raise InputError(
                f"no crank pivot at {frame:g} m from the rocker pivot sees the two limit "
                f"positions under theta = {math.degrees(theta):.4g} deg: choose another frame "
                "length, or leave it out to have the best pivot on the locus chosen"
            )
        return out
    for ci, (c, r) in enumerate(circles):
        out.extend(_best_on_arcs(c, r, o3, rocker, psi1, psi2, b1, b2, theta, step, method, ci))
    if not out:
        raise InputError(
            f"no point of the locus gives a crank-rocker with K = {k:g} for this rocker"
        )
    return out


def _circle_circle(c1: Point, r1: float, c2: Point, r2: float) -> list[Point]:
    d = dist(c1, c2)
    if d < 1e-15 or d > r1 + r2 or d < abs(r1 - r2):
        return []
    x = (d * d + r1 * r1 - r2 * r2) / (2 * d)
    h = math.sqrt(max(0.0, r1 * r1 - x * x))
    ux, uy = (c2[0] - c1[0]) / d, (c2[1] - c1[1]) / d
    px, py = c1[0] + x * ux, c1[1] + x * uy
    pts = [(px - h * uy, py + h * ux), (px + h * uy, py - h * ux)]
    return pts[:1] if h == 0 else pts


def _best_on_arcs(c, r, o3, rocker, psi1, psi2, b1, b2, theta, step, method, ci):
    from scipy.optimize import minimize_scalar

    n = max(720, int(round(2 * math.pi / step)))
    ts = np.linspace(0, 2 * math.pi, n, endpoint=False)

    def design_at(t: float) -> Design:
        p = polar(c, r, t)
        return crank_rocker_at(p, o3, rocker, psi1, psi2, method)

    def good(t: float) -> float:  # the transmission angle where valid, else -1
        p = polar(c, r, t)
        if abs(_angle_at(p, b1, b2) - theta) > 1e-7 or dist(p, o3) < 1e-9 * rocker:
            return -1.0
        d = design_at(t)
        return d.min_transmission if d.valid else -1.0

    vals = np.array([good(t) for t in ts])
    ok = vals > 0
    if not ok.any():
        return []
    # the runs of valid samples round the circle
    start = int(np.argmin(ok)) if not ok.all() else 0
    order = np.roll(np.arange(n), -start)
    runs, cur = [], []
    for i in order:
        if ok[i]:
            cur.append(i)
        elif cur:
            runs.append(cur)
            cur = []
    if cur:
        runs.append(cur)
    out = []
    for run in runs:
        j = max(run, key=lambda i: vals[i])
        lo, hi = ts[j] - 2 * math.pi / n, ts[j] + 2 * math.pi / n
        res = minimize_scalar(
            lambda t: -good(t), bounds=(lo, hi), method="bounded", options={"xatol": 1e-12}
        )
        t = res.x if -res.fun >= vals[j] else ts[j]
        d = design_at(t)
        d.family += (
            f", pivot on locus circle {ci + 1}, best of an arc of "
            f"{math.degrees(len(run) * 2 * math.pi / n):.3g} deg"
        )
        out.append(d)
    return out


def _on_chord_line(o3, rocker, psi1, psi2, b1, b2, frame, method):
    """K = 1: the crank pivot on the line B1 B2, outside the segment."""
    if frame is None:
        raise InputError(
            "with K = 1 the crank pivot lies on the line through the two limit positions and "
            "the transmission angle improves without end as it moves away: give the frame "
            "length"
        )
    ux, uy = (b2[0] - b1[0]) / dist(b1, b2), (b2[1] - b1[1]) / dist(b1, b2)
    # points b1 + s u at distance frame from o3
    wx, wy = b1[0] - o3[0], b1[1] - o3[1]
    bq = wx * ux + wy * uy
    cq = wx * wx + wy * wy - frame * frame
    disc = bq * bq - cq
    out = []
    if disc >= 0:
        for s in (-bq - math.sqrt(disc), -bq + math.sqrt(disc)):
            if s < 0 or s > dist(b1, b2):
                p = (b1[0] + s * ux, b1[1] + s * uy)
                out.append(crank_rocker_at(p, o3, rocker, psi1, psi2, method))
    if not out:
        raise InputError(f"no crank pivot at {frame:g} m from the rocker pivot on the line B1 B2")
    return out


def from_one_limit(
    crank_pivot: Point, rocker_pivot: Point, rocker: float, psi: float, k: float
) -> list[Design]:
    """Crank-rockers with both pivots given (so the frame's length and direction), the
    rocker's length, **one** of its limit positions (``psi``, rad, of the line pivot ->
    pin) and the time ratio ``k``: the textbook problem with two solutions.

    The crank pivot O1 sees the two limit positions B1, B2 under
    theta = 180 deg (K - 1) / (K + 1), so B2 lies on one of the two rays from O1 at
    +-theta from O1 B1, where a ray meets the rocker's circle; each such point is a
    candidate (up to four), solved by the extreme distances (a = (|O1B2| - |O1B1|) / 2,
    b = (|O1B2| + |O1B1|) / 2) and listed, the invalid ones with the reason (limits on
    opposite sides of the frame line, not a crank-rocker)."""
    if not (math.isfinite(rocker) and rocker > 0):
        raise InputError(f"rocker length {rocker!r}: it must be positive")
    theta = time_ratio_angle(k)
    o1, o3 = crank_pivot, rocker_pivot
    if dist(o1, o3) < 1e-12 * rocker:
        raise InputError("the crank pivot coincides with the rocker pivot")
    b1 = polar(o3, rocker, psi)
    if dist(o1, b1) < 1e-12 * rocker:
        raise InputError("the given limit position of the rocker's pin is on the crank pivot")
    u1 = math.atan2(b1[1] - o1[1], b1[0] - o1[0])
    method = f"time ratio K = {k:g} (theta = {math.degrees(theta):.6g} deg), one limit"
    wx, wy = o1[0] - o3[0], o1[1] - o3[1]
    out: list[Design] = []
    seen: list[float] = []
    for sgn in (1, -1):
        dx, dy = math.cos(u1 + sgn * theta), math.sin(u1 + sgn * theta)
        bq = wx * dx + wy * dy
        disc = bq * bq - (wx * wx + wy * wy - rocker * rocker)
        if disc < 0:
            continue
        for t in (-bq - math.sqrt(disc), -bq + math.sqrt(disc)):
            if t <= 1e-12 * rocker:
                continue  # behind the crank pivot: not seen under theta
            b2 = (o1[0] + t * dx, o1[1] + t * dy)
            psi2 = math.atan2(b2[1] - o3[1], b2[0] - o3[0])
            psi2 = psi + (psi2 - psi + math.pi) % (2 * math.pi) - math.pi
            if abs(psi2 - psi) < 1e-9 or any(abs(psi2 - q) < 1e-9 for q in seen):
                continue
            seen.append(psi2)
            if abs(abs(psi2 - psi) - math.pi) < 1e-12:
                continue  # a swing of 180 deg: the pin would pass through the pivot line
            d = crank_rocker_at(o1, o3, rocker, psi, psi2, method)
            d.family = f"other limit at {math.degrees(psi2):.6f} deg, {d.family}"
            d.extra["other_limit"] = psi2
            out.append(d)
    if not out:
        raise InputError(
            f"no position of the rocker's pin is seen from the crank pivot under theta = "
            f"{math.degrees(theta):.4g} deg from the given limit: the rocker is too short "
            "for this frame, or K too large"
        )
    out.sort(key=lambda d: (not d.valid, d.extra["other_limit"]))
    return out
