"""The four-bar in closed form over a whole population of designs at once.

A four-bar O2-A-B-O4 with the frame O2 -> O4 along a unit direction: the crank O2A
(length a) at angle phi, the dyad A-B-O4 (coupler b, rocker c) closed by the intersection
of the circles about A and O4. Every function takes arrays that broadcast (designs along
one axis, positions along the other), so that one call evaluates one generation of an
optimiser: no loop over designs.

Exact checks (not on samples): the dyad closes and keeps its branch over an interval of
crank angles exactly when the squared distance L^2 = |O4 A|^2 stays strictly inside
((b - c)^2, (b + c)^2): L^2 = a^2 + d^2 - 2 a d cos(phi - frame angle) is monotone in
cos, so its extremes over the interval are at the ends and at the angles k pi inside.
The transmission angle mu (between coupler and rocker, cos mu = (b^2 + c^2 - L^2) /
(2 b c)) stays within [mu_min, 180 deg - mu_min] exactly when L^2 stays within
[b^2 + c^2 - 2 b c cos mu_min, b^2 + c^2 + 2 b c cos mu_min]; mu_min = 0 is closure.
A branch change of the dyad needs mu = 0 or 180 deg (A, B, O4 in line), so a design whose
L^2 keeps a positive margin over the motion runs on one branch from end to end.
"""

from __future__ import annotations

import numpy as np

__all__ = ["dyad_point", "l2_range", "transmission_margin", "grashof_margin"]


def dyad_point(ax, ay, ox, oy, b, c, sigma):
    """The pin B of the dyad A-B-O: |AB| = b, |OB| = c, on the side ``sigma``.

    ``sigma`` = +1 puts B left of the directed line A -> O (right of O -> A); -1 the
    other side. Returns (bx, by, h2) with h2 the squared height of B over the line A-O
    (negative where the dyad cannot close; there B is NaN)."""
    ex, ey = ox - ax, oy - ay
    l2 = ex * ex + ey * ey
    L = np.sqrt(l2)
    with np.errstate(invalid="ignore", divide="ignore"):
        along = (b * b - c * c + l2) / (2 * L)
        h2 = b * b - along * along
        h = np.sqrt(np.where(h2 >= 0, h2, np.nan))
        ux, uy = ex / L, ey / L
    bx = ax + along * ux - sigma * h * uy
    by = ay + along * uy + sigma * h * ux
    return bx, by, h2


def l2_range(a, d, phi0, phi1):
    """Exact extremes of L^2 = a^2 + d^2 - 2 a d cos(phi) over the crank angles between
    ``phi0`` and ``phi1`` (rad, measured from the frame line O2 -> O4; arrays)."""
    lo_ang, hi_ang = np.minimum(phi0, phi1), np.maximum(phi0, phi1)
    cos_ends = (
        np.minimum(np.cos(lo_ang), np.cos(hi_ang)),
        np.maximum(np.cos(lo_ang), np.cos(hi_ang)),
    )
    # cos reaches +1 at 2k pi and -1 at (2k + 1) pi inside the interval
    k_even = np.ceil(lo_ang / (2 * np.pi))
    has_zero = k_even * 2 * np.pi <= hi_ang
    k_odd = np.ceil((lo_ang - np.pi) / (2 * np.pi))
    has_pi = k_odd * 2 * np.pi + np.pi <= hi_ang
    cmin = np.where(has_pi, -1.0, cos_ends[0])
    cmax = np.where(has_zero, 1.0, cos_ends[1])
    base = a * a + d * d
    return base - 2 * a * d * cmax, base - 2 * a * d * cmin


def transmission_margin(a, b, c, d, phi0, phi1, mu_min: float = 0.0):
    """Relative margin (> 0: kept) of the transmission angle within [mu_min, 180 deg -
    mu_min] over the crank angles phi0..phi1 (from the frame line), exactly. With
    ``mu_min`` = 0: the dyad closes, and keeps its branch, over the whole interval."""
    lo, hi = l2_range(a, d, phi0, phi1)
    cm = np.cos(mu_min)
    allow_lo = b * b + c * c - 2 * b * c * cm
    allow_hi = b * b + c * c + 2 * b * c * cm
    scale = (b + c) ** 2
    return np.minimum(lo - allow_lo, allow_hi - hi) / scale


def grashof_margin(a, b, c, d):
    """(p + q) - (s + l) over the sum of the lengths: positive for a Grashof linkage."""
    bars = np.sort(np.stack(np.broadcast_arrays(a, b, c, d)), axis=0)
    return (bars[1] + bars[2] - bars[0] - bars[3]) / bars.sum(axis=0)
