"""What every synthesis method shares: the designs it returns, the Grashof check, the
transmission angle of a four-bar over a full turn of its crank, and the picking rule."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mechsolve.base.errors import InputError

Point = tuple[float, float]


@dataclass
class Design:
    """One solution of a synthesis problem.

    Lengths are in m, angles in rad. ``ground`` holds the fixed pivots (global, m);
    ``valid`` is False for a solution listed only to say why it fails (``notes``)."""

    method: str
    family: str
    lengths: dict[str, float]
    ground: dict[str, Point]
    grashof: str
    min_transmission: float
    time_ratio: float | None = None
    valid: bool = True
    notes: list[str] = field(default_factory=list)
    extra: dict = field(default_factory=dict)


def grashof_type(crank: float, coupler: float, rocker: float, frame: float) -> str:
    """Grashof type of a four-bar, named after what the input link (``crank``) does.

    With s the shortest and l the longest of the four and p, q the others: s + l < p + q
    lets the shortest link turn fully (crank-rocker if it is the input, double crank if it
    is the frame, Grashof double rocker if it is the coupler); s + l > p + q gives a
    triple rocker (no link turns fully); equality is a change-point linkage."""
    bars = {"crank": crank, "coupler": coupler, "rocker": rocker, "frame": frame}
    vals = sorted(bars.values())
    s_name = "crank" if crank <= vals[0] else min(bars, key=bars.get)
    lhs, rhs = vals[0] + vals[3], vals[1] + vals[2]
    if abs(lhs - rhs) <= 1e-12 * rhs:
        return "change point (s + l = p + q)"
    if lhs > rhs:
        return "non-Grashof triple rocker (s + l > p + q)"
    if s_name == "crank":
        return "crank-rocker (Grashof, the crank is the shortest link)"
    if s_name == "frame":
        return "double crank (Grashof, the frame is the shortest link)"
    if s_name == "coupler":
        return "Grashof double rocker (the coupler is the shortest link)"
    return "rocker-crank (Grashof, the output link is the shortest and turns fully)"


def is_crank_rocker(kind: str) -> bool:
    return kind.startswith("crank-rocker")


def fourbar_min_transmission(crank: float, coupler: float, rocker: float, frame: float) -> float:
    """Smallest transmission angle (rad, the acute angle between coupler and rocker) of a
    four-bar whose crank turns fully: it occurs with the crank along the frame line,
    cos mu = (b^2 + c^2 - (d -+ a)^2) / (2 b c)."""
    a, b, c, d = crank, coupler, rocker, frame
    out = math.pi / 2
    for e in (d - a, d + a):
        cosmu = (b * b + c * c - e * e) / (2 * b * c)
        mu = math.acos(min(1.0, max(-1.0, cosmu)))
        out = min(out, mu, math.pi - mu)
    return out


def transmission_along(crank, coupler, rocker, frame, theta) -> np.ndarray:
    """Acute transmission angle (rad) of a four-bar at crank angles ``theta`` measured
    from the frame line (pivot to pivot); NaN where the loop cannot close."""
    a, b, c, d = crank, coupler, rocker, frame
    th = np.asarray(theta, float)
    e2 = a * a + d * d - 2 * a * d * np.cos(th)
    cosmu = (b * b + c * c - e2) / (2 * b * c)
    with np.errstate(invalid="ignore"):
        mu = np.where(np.abs(cosmu) <= 1, np.arccos(np.clip(cosmu, -1, 1)), np.nan)
    return np.minimum(mu, np.pi - mu)


def time_ratio_angle(k: float) -> float:
    """Crank angle between the two limit positions: theta = 180 deg (K - 1) / (K + 1)."""
    if not (math.isfinite(k) and k >= 1):
        raise InputError(f"time ratio K = {k!r}: it must be a number >= 1")
    if k > 1e6:
        raise InputError(f"time ratio K = {k:g} is absurd: theta would be 180 deg")
    return math.pi * (k - 1) / (k + 1)


def time_ratio_of(theta: float) -> float:
    """K = (180 + theta) / (180 - theta)."""
    return (math.pi + theta) / (math.pi - theta)


def cross(o, a, b) -> float:
    """z of (a - o) x (b - o): positive when b is left of the directed line o -> a."""
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def dist(p, q) -> float:
    return math.hypot(q[0] - p[0], q[1] - p[1])


def polar(o, r: float, ang: float) -> Point:
    return (o[0] + r * math.cos(ang), o[1] + r * math.sin(ang))


RULES = ("transmission", "shortest-crank", "smallest")


def pick(designs: list[Design], rule: str = "transmission") -> Design:
    """The solution chosen among the valid ones.

    ``transmission`` (default): the largest minimum transmission angle; ``shortest-crank``:
    the shortest input link; ``smallest``: the smallest sum of link lengths."""
    ok = [d for d in designs if d.valid]
    if not ok:
        why = "; ".join(f"{d.family}: {', '.join(d.notes)}" for d in designs) or "none found"
        raise InputError(f"no valid solution ({why})")
    if rule == "transmission":
        return max(ok, key=lambda d: d.min_transmission)
    first = next(iter(ok[0].lengths))
    if rule == "shortest-crank":
        return min(ok, key=lambda d: d.lengths[first])
    if rule == "smallest":
        return min(ok, key=lambda d: sum(d.lengths.values()))
    raise InputError(f"unknown rule {rule!r}: choose one of {', '.join(RULES)}")


def fd_columns(x: np.ndarray, lo: np.ndarray, hi: np.ndarray):
    """Central-difference steps ``h`` (zero for a variable with no room between its
    bounds) and the 2n perturbed designs as one batch's columns: ``(h, X, n)``."""
    h = 1e-7 * np.maximum(1.0, np.abs(x)) * (hi - lo > 0)
    n = len(x)
    return h, np.hstack([x[:, None] + np.diag(h), x[:, None] - np.diag(h)]), n


def batch_least_squares(columns, x0: np.ndarray, lo: np.ndarray, hi: np.ndarray, max_nfev: int):
    """scipy's ``least_squares`` from ``x0`` within the bounds, of the residuals
    ``columns(X)`` (one column of residuals per design of ``X``'s columns; a residual
    that is not finite counts as 1e3), its Jacobian by central differences with every
    perturbed design in one batch. The result, or None where scipy refuses the problem."""
    from scipy.optimize import least_squares

    def cols(X):
        r = columns(X)
        return np.where(np.isfinite(r), r, 1e3)

    def fun(x):
        return cols(np.asarray(x, float)[:, None])[:, 0]

    def jac(x):
        h, X, n = fd_columns(np.asarray(x, float), lo, hi)
        r = cols(X)
        return (r[:, :n] - r[:, n:]) / np.where(h > 0, 2 * h, 1.0)

    try:
        return least_squares(fun, np.clip(x0, lo, hi), jac=jac, bounds=(lo, hi), xtol=1e-15,
                             ftol=1e-15, gtol=1e-15, max_nfev=max_nfev)  # fmt: skip
    except ValueError:
        return None
