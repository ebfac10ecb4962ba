"""The floor of the four-bar's one-design call: the vector-form closed form plus, written
by hand in the leanest NumPy, the trust work mechsolve's ``solve`` does for it.

:func:`fourbar_floor` returns what a whole ``solve`` call returns for the four-bar of the
benchmarks (positions, velocities and accelerations of its links, per-position ok flags,
the transmission-angle indicator, the branch events, the unassemblable ranges and the
positions whose rates are limits), with the same checks and no others:

1. **the branch, decided at the start from the assembly condition**: ``"B left of A -> O4"``
   is the dyad's own branch statement (B on the left of the directed line A -> O4), so it
   sets the sign of the height of B over that line without solving anything, as mechsolve
   reads it;
2. **closure and per-position ok flags**: the dyad closes where the squared height of B is
   not below ``-1e-12`` of its longer arm squared (a toggle within rounding closes); NaN
   in every pose, rate and acceleration of the coupler and rocker where it does not;
3. **the indicator**: the sine of the transmission angle (the angle at B) at every position,
   from the discriminant ``H = sin^2`` of that angle, 0 where the dyad does not close;
4. **branch events between samples**: with H's exact rate along the sweep, every interval
   between two closing samples where H' goes from negative to positive holds a minimum; its
   cubic Hermite estimate (17 points) below 0.25 is refined by bisection on H' = 0 (settled
   early once the bracket is shorter than 0.02 rad and the tangents' intersection bounds
   the minimum above 1e-6); a minimum below -1e-10 is a dead zone stepped over, one within
   1e-10 of zero a bifurcation (the branch flips after it), one below sin^2(3 deg) a
   near-singular position; samples that are themselves minima below sin^2(3 deg) are
   events too. Where the samples are further apart than 2 deg, H is evaluated on points in
   between first (no minimum hides between two samples);
5. **the singular-rate check**: where the indicator is at or below 1e-3 the rates are
   replaced by their limit along the motion (Richardson from ``u -+ d`` and ``u -+ 2d``,
   d = 5e-3 rad; one-sided cubic at the first and last sample), and left NaN (undetermined)
   where the indicator is below 1e-6 and no limit exists; when the indicator's minimum is
   above 1e-3 (the usual case) this is one reduction;
6. **unassemblable ranges**: runs of positions where the dyad does not close, each with its
   reason and its exact edges (the roots of H between the last sample that closes and the
   first that does not, by bisection).

mechsolve checks the whole constraint residual only where a Newton group solved a
position (a closed form closes by construction), so the floor does not check it either;
``residual=True`` adds that check (the largest loop-closure error of the two pins at
B), to show its cost.

Two of mechsolve's cases cost it nothing here and are left out: the limit pose of a dyad
whose arms are equal (its outer joints can coincide; the benchmark's coupler and rocker
differ in length, which mechsolve finds by one comparison when it builds the group), and
a sweep that starts where the dyad cannot close (mechsolve then assembles at the first
position that closes; here the branch comes from the condition alone, so the first
positions are simply not ok).

The thresholds are mechsolve's (``core/branches.py``, ``core/conditioning.py``,
``core/singular.py``), restated here: nothing in this module imports the solver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mechsolve_bench.references import A2, B3, C4, D1

TOUCH = 1e-10  # |H| at a minimum below this: the branches meet (a bifurcation)
NO_TOUCH = 1e-6  # a minimum proven above this needs no refinement
SETTLE_WIDTH = 0.02  # rad: brackets this short are convex about a minimum
EVENT_STEP = math.radians(2.0)  # the coarsest grid the minima are looked for on
EVENT_CHECK = 0.25  # minima whose Hermite estimate is below this are refined
NEAR2 = math.sin(math.radians(3.0)) ** 2  # near-singular: H below sin^2(3 deg)
NEAR_IND = 1e-3  # indicator at or below this: the rates are their limit
SING_IND = 1e-6  # below this, no limit means no rate (NaN)
LIMIT_STEP = 5e-3  # rad: the limit's samples u -+ d, u -+ 2d
_T = np.linspace(0.0, 1.0, 17)[:, None]
_HERMITE = (
    2 * _T**3 - 3 * _T**2 + 1,
    _T**3 - 2 * _T**2 + _T,
    -2 * _T**3 + 3 * _T**2,
    _T**3 - _T**2,
)


@dataclass
class FloorResult:
    """What the one-design call gives for the four-bar: each array over the positions."""

    t: np.ndarray  # time (s)
    th3: np.ndarray  # coupler and rocker angles (rad)
    th4: np.ndarray
    w3: np.ndarray  # their rates (rad/s)
    w4: np.ndarray
    al3: np.ndarray  # their accelerations (rad/s^2)
    al4: np.ndarray
    ax: np.ndarray  # A (the coupler's origin): position (m), velocity, acceleration
    ay: np.ndarray
    vax: np.ndarray
    vay: np.ndarray
    aax: np.ndarray
    aay: np.ndarray
    bx: np.ndarray  # B, the output point (m)
    by: np.ndarray
    ok: np.ndarray  # the dyad closes
    ind: np.ndarray  # sine of the transmission angle, 0 where it does not close
    events: list = field(default_factory=list)  # (kind, u*, sample before, transmission)
    failures: list = field(default_factory=list)  # (first, last, reason, edge in, edge out)
    by_limit: list = field(default_factory=list)  # positions whose rates are limits
    undetermined: list = field(default_factory=list)  # positions left without rates
    residual: float | None = None  # largest closure error (m), only when asked


def _geometry(th2, a, b, c, d):
    """A, O4 - A, |O4 - A|^2 and its half-rate, H and H' per unit crank angle (floats or
    arrays)."""
    if isinstance(th2, float):
        ax, ay = a * math.cos(th2), a * math.sin(th2)
    else:
        ax, ay = a * np.cos(th2), a * np.sin(th2)
    dx, dy = d - ax, -ay
    D2 = dx * dx + dy * dy
    b2, c2 = b * b, c * c
    aD2 = 0.5 * (b2 - c2 + D2)
    inv = 1.0 / (b2 * c2)
    H = (b2 * D2 - aD2 * aD2) * inv
    dH = ((b2 + c2) - D2) * (d * ay) * inv  # d(D^2)/2 per radian is d * ay (O4 on x)
    return ax, ay, dx, dy, D2, aD2, H, dH


def _kinematics(th2, w2, sigma, a, b, c, d):
    """The vector form with the chosen branch (+1: B left of A -> O4), NaN where the
    dyad does not close; also H, H' (per unit crank angle) and the closure mask."""
    ax, ay, dx, dy, D2, aD2, H, dH = _geometry(th2, a, b, c, d)
    inv = 1.0 / D2
    f = aD2 * inv
    h2 = b * b * inv - f * f
    if h2.min() >= 0.0:  # closes everywhere (one reduction instead of a mask)
        ok = np.ones(h2.shape, bool)
        h = np.sqrt(h2)
    else:
        ok = h2 * D2 >= -1e-12 * max(b, c) ** 2  # a toggle within rounding closes
        h = np.sqrt(np.maximum(h2, 0.0))
        h[~ok] = np.nan
    h *= sigma
    bx, by = ax + f * dx - h * dy, ay + f * dy + h * dx
    g1x, g1y, g2x, g2y = bx - ax, by - ay, bx - d, by
    cr = g1x * g2y - g1y * g2x
    vax, vay = -ay * w2, ax * w2
    w3 = (-vax * g2x - vay * g2y) / cr
    w4 = (-vax * g1x - vay * g1y) / cr
    w22 = w2 * w2
    aax, aay = -ax * w22, -ay * w22
    dax = ax * w22 - w4 * w4 * g2x + w3 * w3 * g1x
    day = ay * w22 - w4 * w4 * g2y + w3 * w3 * g1y
    al3 = (dax * g2x + day * g2y) / cr
    al4 = (dax * g1x + day * g1y) / cr
    th3, th4 = np.arctan2(g1y, g1x), np.arctan2(g2y, g2x)
    return (th3, th4, w3, w4, al3, al4, ax, ay, vax, vay, aax, aay, bx, by), ok, H, dH


def _hermite_min(h0, h1, d0, d1):
    b00, b10, b01, b11 = _HERMITE
    return (b00 * h0 + b10 * d0 + b01 * h1 + b11 * d1).min(axis=0)


def _refine(lo, hi, hlo, hhi, slo, shi, a, b, c, d, s):
    """The minimum of H between ``lo`` and ``hi`` (values and rates along the sweep at both
    ends): bisection on H' = 0, settled early once it is proven above NO_TOUCH."""
    for _ in range(80):
        w = abs(hi - lo)
        den = slo - shi
        x = (hhi - hlo - shi * w) / den if den else math.nan
        bound = hlo + slo * min(max(x, 0.0), w) if x == x else math.nan
        if w <= SETTLE_WIDTH and bound > NO_TOUCH:
            t = _hermite_min(np.array([hlo]), np.array([hhi]), np.array([slo * w]), shi * w)
            return 0.5 * (lo + hi), max(bound, float(t[0]))
        if w <= 4e-16 * (1 + abs(lo)):
            break
        mid = 0.5 * (lo + hi)
        *_, hm, dm = _geometry(mid, a, b, c, d)
        sm = dm * s
        if sm < 0:
            lo, hlo, slo = mid, hm, sm
        else:
            hi, hhi, shi = mid, hm, sm
    um = 0.5 * (lo + hi)
    return um, _geometry(um, a, b, c, d)[6]


def _events(u, H, dH, ok, a, b, c, d):
    """Minima of H along the sweep (between samples, refined; and at samples), in order:
    (kind, u*, sample before, transmission angle)."""
    n = len(u)
    s = 1.0 if n < 2 or u[-1] >= u[0] else -1.0  # the sweep's direction
    gaps = np.abs(np.diff(u))
    everywhere = n > 0 and H.min() >= -TOUCH and bool(ok.all())
    cl = ok if everywhere else ok & (H >= -TOUCH)  # the samples where the dyad closes
    if n > 1 and gaps.max() > EVENT_STEP:  # points between samples: no minimum hides
        k = np.maximum(np.ceil(gaps / EVENT_STEP).astype(int), 1)
        owner = np.repeat(np.arange(n - 1), k)
        frac = (np.arange(len(owner)) - np.repeat(np.cumsum(k) - k, k)) / np.repeat(k, k)
        ug = np.append(u[owner] + frac * (u[owner + 1] - u[owner]), u[-1])
        near = np.append(owner, n - 1)
        *_, Hg, dHg = _geometry(ug, a, b, c, d)
        pair = cl[owner] & cl[owner + 1]  # each interval of the grid: both samples close
        ptok = np.append(pair, cl[-1]) & (Hg >= -TOUCH)
    else:
        ug, Hg, dHg, near = u, H, dH, np.arange(n)
        pair = None if everywhere else cl[:-1] & cl[1:]
        ptok = cl
    Hs = dHg if s > 0 else -dHg  # H' along the sweep
    turns = (Hs[:-1] < 0) & (Hs[1:] > 0)
    inside = np.flatnonzero(turns if pair is None else pair & turns)
    found = []
    if inside.size:
        w = np.abs(ug[inside + 1] - ug[inside])
        est = _hermite_min(Hg[inside], Hg[inside + 1], Hs[inside] * w, Hs[inside + 1] * w)
        for i in inside[est < EVENT_CHECK].tolist():
            args = (ug[i], ug[i + 1], Hg[i], Hg[i + 1], Hs[i], Hs[i + 1])
            um, hm = _refine(*(float(v) for v in args), a, b, c, d, s)
            found.append((int(near[i]), um, hm))
    if np.any(Hg[1:-1] < NEAR2):  # grid points that are minima themselves
        for k in (np.flatnonzero(ptok[1:-1] & (Hg[1:-1] < NEAR2)) + 1).tolist():
            span = abs(ug[k + 1] - ug[k - 1])
            if ptok[k - 1] and ptok[k + 1] and Hg[k - 1] >= Hg[k] <= Hg[k + 1]:
                if not any(abs(f[1] - ug[k]) <= span for f in found):
                    found.append((int(near[k - 1]), float(ug[k]), float(Hg[k])))
    found.sort(key=lambda f: s * f[1])
    out = []
    for k, um, hm in found:
        j = int(np.argmin(np.abs(u - um)))
        if abs(u[j] - um) <= 1e-12 * (1.0 + abs(um)) or (j == 0 and abs(u[0] - um) <= 1e-6):
            um = float(u[j])
            if j == 0:
                continue  # the start's branch is the one taken from the start
        mu = math.asin(math.sqrt(max(min(hm, 1.0), 0.0)))
        if hm < -TOUCH:
            out.append(("dead zone", um, k, 0.0))
        elif hm <= TOUCH:
            out.append(("bifurcation", um, k, mu))
        elif hm < NEAR2:
            out.append(("near-singular", um, k, mu))
    return out


def _failures(u, ok, a, b, c, d):
    """Runs of positions where the dyad does not close: (first, last, reason, edge in,
    edge out), the edges being the roots of H between the samples (bisection)."""
    bad = ~ok
    starts = np.flatnonzero(bad & np.r_[True, ~bad[:-1]])
    ends = np.flatnonzero(bad & np.r_[~bad[1:], True])
    out = []

    def H(x):
        return _geometry(x, a, b, c, d)[6]

    def root(x_in, x_out):  # H(x_in) >= 0 > H(x_out); the end kept on the closing side
        for _ in range(200):
            mid = 0.5 * (x_in + x_out)
            if mid in (x_in, x_out):
                break
            if H(mid) >= 0:
                x_in = mid
            else:
                x_out = mid
        return x_in

    for f, e in zip(starts.tolist(), ends.tolist()):
        ax, ay = a * math.cos(u[f]), a * math.sin(u[f])
        D = math.hypot(d - ax, ay)
        why = (
            f"|AO4| = {D:.6g} m > {b:.6g} + {c:.6g} m"
            if D > b + c
            else f"|AO4| = {D:.6g} m < |{b:.6g} - {c:.6g}| m"
        )
        e_in = root(float(u[f - 1]), float(u[f])) if f > 0 else math.nan
        e_out = root(float(u[e + 1]), float(u[e])) if e + 1 < len(u) else math.nan
        out.append((f, e, f"the dyad cannot close: {why}", e_in, e_out))
    return out


def fourbar_floor(
    th2,
    w2: float = 1.0,
    side: str = "left",
    a: float = A2,
    b: float = B3,
    c: float = C4,
    d: float = D1,
    residual: bool = False,
) -> FloorResult:
    """The four-bar's sweep at crank angles ``th2`` (the first one the start) at a constant
    crank speed ``w2``, with the checks of mechsolve's one-design call (module docstring).

    ``side`` is the assembly condition's ``B <side> of A -> O4``.
    """
    th2 = np.asarray(th2, float)
    sigma = 1.0 if side == "left" else -1.0  # 1. the branch, from the condition
    # 2., 3. the closed form, NaN where the dyad does not close; the indicator
    out, ok, H, dH = _kinematics(th2, w2, sigma, a, b, c, d)
    ind = np.sqrt(np.minimum(np.maximum(H, 0.0), 1.0))
    closes = bool(ok.all())
    if not closes:
        ind[~ok] = 0.0
    # 4. branch events: flip the branch after each bifurcation
    events = _events(th2, H, dH, ok, a, b, c, d)
    flips = [e[1] for e in events if e[0] == "bifurcation"]
    if flips:
        s = 1.0 if th2[-1] >= th2[0] else -1.0
        sig = np.full(th2.shape, sigma)
        for uf in flips:
            sig = np.where(s * (th2 - uf) > 0, -sig, sig)
        out, ok, H, dH = _kinematics(th2, w2, sig, a, b, c, d)
    res = FloorResult(th2 / w2 - th2[0] / w2, *out, ok, ind, events)
    # 5. rates at (near) singular positions: their limits along the motion
    if len(th2) and ind.min() <= NEAR_IND:
        _limits(res, th2, w2, sigma, flips, a, b, c, d)
    # 6. the unassemblable ranges
    if not closes:
        res.failures = _failures(th2, ok, a, b, c, d)
    if residual:  # |B - A| = b and |B - O4| = c
        e1 = np.hypot(res.bx - res.ax, res.by - res.ay) - b
        e2 = np.hypot(res.bx - d, res.by) - c
        res.residual = float(np.nanmax(np.maximum(np.abs(e1), np.abs(e2))))
    return res


def _limits(res: FloorResult, th2, w2, sigma, flips, a, b, c, d) -> None:
    """Rates at the positions whose indicator is at or below NEAR_IND: Richardson from
    ``u -+ d, u -+ 2d`` (cubic from one side at the ends); NaN below SING_IND where the
    motion has no limit there."""
    n = len(th2)
    s = 1.0 if th2[-1] >= th2[0] else -1.0
    rates = ("w3", "w4", "al3", "al4")
    for i in np.flatnonzero(res.ok & (res.ind <= NEAR_IND)).tolist():
        ui = float(th2[i])
        if 0 < i < n - 1:
            x = ui + LIMIT_STEP * np.array([-1.0, 1.0, -2.0, 2.0])
        else:
            x = ui + s * (1 if i == 0 else -1) * LIMIT_STEP * np.arange(1.0, 5.0)
        sig = np.full(4, sigma)
        for uf in flips:
            sig = np.where(s * (x - uf) > 0, -sig, sig)
        kin, ok, _, _ = _kinematics(x, w2, sig, a, b, c, d)
        r = np.array(kin[2:6])  # w3, w4, al3, al4 at the four points
        kind = np.array([1.0, 1.0, abs(w2), abs(w2)])[:, None] * abs(w2)  # natural sizes
        deep = res.ind[i] < SING_IND
        est = None
        if not ok.all():
            pass
        elif 0 < i < n - 1:
            lo1, hi1, lo2, hi2 = r[:, 0], r[:, 1], r[:, 2], r[:, 3]
            jump = (
                np.abs((hi2 - lo2) - 2 * (hi1 - lo1))
                > 0.1 * np.abs(hi2 - lo2) + 1e-6 * kind[:, 0] + 1e-300
            )
            if not jump.any():
                est = (4 * (lo1 + hi1) - (lo2 + hi2)) / 6
                if not deep:  # near, not at, the singular point: keep what agrees
                    comp = np.array([getattr(res, k)[i] for k in rates])
                    err = np.abs(est - 0.5 * (lo1 + hi1)) + 1e-6 * kind[:, 0]
                    better = np.abs(comp - est) > err
                    if not better.any():
                        continue
                    est = np.where(better, est, comp)
        else:
            e4 = r @ np.array([4.0, -6.0, 4.0, -1.0])
            quad = r[:, :3] @ np.array([3.0, -3.0, 1.0])
            if np.all(np.abs(e4 - quad) <= 1e-3 * np.abs(e4) + 1e-6 * kind[:, 0]):
                est = e4
        if est is None:
            if deep:
                for k in rates:
                    getattr(res, k)[i] = np.nan
                res.undetermined.append(i)
            continue
        for k, v in zip(rates, est):
            getattr(res, k)[i] = v
        res.by_limit.append(i)
