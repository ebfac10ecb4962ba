"""Offset slider-cranks for a given stroke H and time ratio K.

With the crank pivot O at the origin and the slider's line y = e (e > 0), the slider's
limit positions are x1 = sqrt((b - a)^2 - e^2) (folded) and x2 = sqrt((b + a)^2 - e^2)
(extended), the stroke H = x2 - x1, and the crank turns 180 deg +- theta between them,
theta = angle C1 O C2. The textbook construction: O lies on the circle through C1 and C2
from whose arc the stroke is seen under theta = 180 deg (K - 1) / (K + 1), at the distance
e from the slider's line. Then a = (|OC2| - |OC1|) / 2 and b = (|OC2| + |OC1|) / 2.

The minimum transmission angle (between the rod and the normal of the slider's line) is
reached with the crank perpendicular to the line, on the side away from it:
cos gamma_min = (a + e) / b. Without a given offset, e is chosen where gamma_min is
largest.
"""

from __future__ import annotations

import math

from mechsolve.analyses.synth.common import Design, time_ratio_angle, time_ratio_of
from mechsolve.base.errors import InputError

__all__ = ["slider_crank", "slider_crank_at"]


def slider_crank_at(stroke: float, theta: float, offset: float) -> Design:
    """The slider-crank with the crank pivot at distance ``offset`` from the line through
    the two limit positions C1 = (x1, e), C2 = (x1 + stroke, e), seeing them under
    ``theta``."""
    h_len, e = stroke, offset
    if theta < 1e-12:  # K = 1: the pivot on the line
        if e > 1e-12 * h_len:
            raise InputError("a time ratio K = 1 needs a centred slider-crank (offset 0)")
        raise InputError(
            "K = 1 with no offset: any crank a = H/2 works with any longer rod; give K > 1"
        )
    # pivot P = (0, 0), C1 = (x1, e), C2 = (x1 + H, e); angle C1 P C2 = theta:
    # atan(e / x1) - atan(e / (x1 + H)) = theta  =>  x1 (x1 + H) + e^2 = H e / tan(theta)
    q = h_len * e / math.tan(theta) - e * e
    disc = h_len * h_len + 4 * q
    if e <= 0 or q <= 0 or disc < 0:
        raise InputError(
            f"offset {e:g} m: no crank pivot this far from the slider's line sees the stroke "
            f"{h_len:g} m under theta = {math.degrees(theta):.4g} deg (the largest offset is "
            f"{_max_offset(h_len, theta):.6g} m)"
        )
    x1 = (-h_len + math.sqrt(disc)) / 2
    x2 = x1 + h_len
    r1, r2 = math.hypot(x1, e), math.hypot(x2, e)
    a, b = (r2 - r1) / 2, (r2 + r1) / 2
    notes: list[str] = []
    valid = True
    cos_g = (a + e) / b
    if cos_g >= 1:
        valid = False
        notes.append(f"the crank cannot turn fully: a + e = {a + e:.6g} >= b = {b:.6g}")
        gmin = 0.0
    else:
        gmin = math.acos(cos_g)
    th = math.atan2(e, x1) - math.atan2(e, x2)
    return Design(
        method=f"stroke {h_len:g} m, time ratio K = {time_ratio_of(theta):.6g}",
        family="pivot before the near limit (mirror: the same lengths)",
        lengths={"crank": a, "rod": b, "offset": e},
        ground={"O": (0.0, 0.0)},
        grashof="slider-crank, the crank turns fully" if valid else "the crank cannot turn",
        min_transmission=gmin,
        time_ratio=time_ratio_of(th),
        valid=valid,
        notes=notes,
        extra={"limits_x": (x1, x2), "theta": th, "stroke": h_len},
    )


def _max_offset(h_len: float, theta: float) -> float:
    """The largest offset of the locus circle from the chord's line: R + h."""
    r = h_len / (2 * math.sin(theta))
    return r + h_len / (2 * math.tan(theta))


def slider_crank(stroke: float, k: float, offset: float | None = None) -> list[Design]:
    """Slider-cranks for stroke ``stroke`` (m) and time ratio ``k``; with ``offset``
    None, the offset with the largest minimum transmission angle (Brent's method)."""
    if not (math.isfinite(stroke) and stroke > 0):
        raise InputError(f"stroke {stroke!r}: it must be positive")
    theta = time_ratio_angle(k)
    if offset is not None:
        if not (math.isfinite(offset) and offset > 0):
            raise InputError(
                f"offset {offset!r}: it must be positive (K > 1 needs an offset; the side is "
                "chosen by the drawing, the lengths do not depend on it)"
            )
        return [slider_crank_at(stroke, theta, offset)]
    if theta < 1e-12:
        raise InputError("K = 1: a centred slider-crank, a = H/2 and any longer rod")
    from scipy.optimize import minimize_scalar

    emax = _max_offset(stroke, theta)
    # the offsets whose pivot sees the stroke under theta: (0, H / tan(theta))
    ehi = min(emax, stroke / math.tan(theta)) * (1 - 1e-9)

    def neg(e: float) -> float:
        try:
            return -slider_crank_at(stroke, theta, e).min_transmission
        except InputError:
            return 1.0

    grid = [ehi * (i + 0.5) / 400 for i in range(400)]
    best = min(grid, key=neg)
    step = ehi / 400
    res = minimize_scalar(
        neg,
        bounds=(max(best - step, 1e-12 * stroke), min(best + step, ehi)),
        method="bounded",
        options={"xatol": 1e-12 * stroke},
    )
    e = float(res.x) if res.fun <= neg(best) else best
    d = slider_crank_at(stroke, theta, e)
    d.family += "; offset chosen for the largest minimum transmission angle"
    return [d]
