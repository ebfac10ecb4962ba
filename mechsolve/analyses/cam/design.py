"""Base size of a cam: the smallest base radius (and, for an oscillating follower, the
pivot distance a and start angle phi0) that keeps the pressure angle within its
allowance on the rise and on the return and leaves no undercut.

Translating knife-edge or roller follower, offset e, cam sense sigma (+1 ccw): the
pressure angle is tan(alpha) = |s' - sigma e| / (s0 + s) with s0 = sqrt(r0^2 - e^2), so
the allowance [alpha] holds everywhere when

    s0 >= max over theta of ( |s' - sigma e| / tan[alpha] - s ),

a closed form (the allowance of the segment at theta: rise or return). A flat face has
no pressure angle to speak of (0 for a translating one); its base radius comes from the
curvature: r0 + s + s'' >= rho_min. A roller's base radius for curvature and every
oscillating follower's base are found by bisection on r0 (for an oscillating follower,
at each r0 the best pivot distance a by a scan and a bounded search), each trial solving
the whole cam by :func:`mechsolve.base.cam.profile.solve`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mechsolve.base.cam.profile import Follower, Profile, base_radius_of, solve, start_angle_of
from mechsolve.base.cam.program import Program

COARSE = 720  # cam angles per turn while searching (0.5 deg); results checked finely


@dataclass(frozen=True)
class Allowance:
    """Allowable pressure angles (rad) on the rise and the return (None: no limit) and
    the smallest radius of curvature the profile may have (m)."""

    rise: float | None = None
    ret: float | None = None
    rho_min: float = 0.0

    def of(self, kind: str) -> float | None:
        return self.ret if kind == "return" else self.rise


def extremes(prof: Profile, program: Program) -> dict[str, tuple[float, float]]:
    """The largest pressure angle on the rises, on the returns (and in dwells): kind ->
    (angle in rad, cam angle in rad where it occurs)."""
    kinds = _kinds(program, prof.theta)
    out = {}
    for k in ("rise", "return", "dwell"):
        m = kinds == k
        if np.any(m):
            i = int(np.argmax(np.where(m, prof.pressure, -1.0)))
            out[k] = (float(prof.pressure[i]), float(prof.theta[i]))
    return out


def _kinds(program: Program, theta: np.ndarray) -> np.ndarray:
    out = np.empty(theta.shape, dtype=object)
    th = np.mod(theta, 2 * math.pi)
    for g in program.segments:
        out[(th >= g.start) & (th < g.end)] = g.kind
    return out


def excess(prof: Profile, program: Program, allow: Allowance) -> float:
    """How far the cam is from acceptable (<= 0: within the allowances, no undercut):
    the largest excess of a pressure angle over its allowance (rad), or of the
    curvature margin over the profile's radius (m, scaled to be comparable)."""
    worst = -math.inf
    kinds = _kinds(program, prof.theta)
    for k in ("rise", "return"):  # in a dwell the cam does no work on the follower
        lim = allow.of(k)
        m = kinds == k
        if lim is not None and np.any(m):
            worst = max(worst, float(np.max(prof.pressure[m])) - lim)
    if prof.follower.contact != "knife-edge":
        und = _curvature_shortfall(prof, allow.rho_min)
        worst = max(worst, und)
    if not prof.valid:
        worst = max(worst, 1.0)
    return worst


def _curvature_shortfall(prof: Profile, rho_min: float) -> float:
    """max over convex stretches of (rho_min - rho_profile), over the base radius."""
    rp = prof.rho_profile
    convex = (prof.rho_pitch > 0.0) if prof.rho_pitch is not None else np.ones(rp.shape, bool)
    if not np.any(convex):
        return -math.inf
    short = float(np.max(np.where(convex, rho_min - rp, -np.inf)))
    return short / max(prof.follower.base_radius, 1e-9)


@dataclass
class Sizing:
    """A designed base size: the follower with it, what it reaches, and how."""

    follower: Follower
    sense: int
    reached: dict[str, tuple[float, float]]
    rho_min: float
    method: str


def min_base_translating(program: Program, e: float, sense: int, allow: Allowance) -> float:
    """Closed form: the smallest base radius of a translating knife-edge or roller
    follower's pitch curve for the pressure-angle allowances (see the module text)."""
    th = np.linspace(0.0, 2 * math.pi, 20 * COARSE, endpoint=False)
    s, ds, _, _ = program.eval(th)
    kinds = _kinds(program, th)
    tan = np.empty_like(th)
    for k in ("rise", "return", "dwell"):
        lim = allow.of(k) if k != "dwell" else None
        tan[kinds == k] = math.tan(lim) if lim is not None else np.inf
    need = np.abs(ds - sense * e) / tan - s
    s0 = max(float(np.max(need)), 0.0)
    # refine the maximum with the exact law around the best sample
    i = int(np.argmax(need))
    from scipy.optimize import minimize_scalar

    h = 2 * math.pi / th.size

    def neg(t):
        ss, dd, _, _ = program.eval(np.array([t]))
        k = program.segment_at(t).kind
        lim = allow.of(k) if k != "dwell" else None
        tn = math.tan(lim) if lim is not None else math.inf
        return -(abs(dd[0] - sense * e) / tn - ss[0])

    r = minimize_scalar(neg, bounds=(th[i] - h, th[i] + h), method="bounded",
                        options={"xatol": 1e-12})  # fmt: skip
    s0 = max(s0, -float(r.fun), 0.0)
    return math.hypot(s0, e)


def _bisect(ok, lo: float, hi: float, rel: float = 1e-7) -> float:
    """Smallest x in [lo, hi] with ok(x) (ok monotonic: False then True)."""
    while hi - lo > rel * hi:
        mid = 0.5 * (lo + hi)
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi


def size(program: Program, f: Follower, sense: int, allow: Allowance) -> Sizing:
    """The smallest base size for ``f`` (its type, roller, offset and arm kept)."""
    th = np.linspace(0.0, 2 * math.pi, COARSE, endpoint=False)
    stroke = program.stroke
    if f.oscillating:
        return _size_oscillating(program, f, sense, allow, th)
    if f.contact == "flat-faced":
        s, _, d2s, _ = program.eval(np.linspace(0, 2 * math.pi, 20 * COARSE, endpoint=False))
        r0 = max(allow.rho_min - float(np.min(s + d2s)), 1e-6)
        method = "r0 + s + s'' >= rho_min (closed form)"
        fol = f.with_base(base_radius=r0)
    else:
        r_alpha = min_base_translating(program, f.offset, sense, allow)
        r_alpha = max(r_alpha, abs(f.offset) * (1 + 1e-9) + 1e-9)
        method = "pressure angle: s0 = max(|s' - sigma e| / tan[alpha] - s) (closed form)"
        fol = f.with_base(base_radius=r_alpha)
        if f.contact == "roller":

            def ok(r):  # noqa: E306
                return _curvature_shortfall(solve(program, f.with_base(base_radius=r), sense,
                                                  th), allow.rho_min) <= 0.0  # fmt: skip

            if not ok(r_alpha):
                hi = max(r_alpha, stroke, f.roller) * 2
                while not ok(hi):
                    hi *= 2
                r_c = _bisect(ok, r_alpha, hi)
                fol = f.with_base(base_radius=r_c)
                method = "curvature: the pitch curve's radius >= roller + rho_min (bisection)"
    fine = solve(program, fol, sense, np.linspace(0, 2 * math.pi, 3600, endpoint=False))
    return Sizing(fol, sense, extremes(fine, program), _rho_min(fine), method)


def _rho_min(prof: Profile) -> float:
    rp = prof.rho_profile
    convex = (prof.rho_pitch > 0.0) if prof.rho_pitch is not None else np.ones(rp.shape, bool)
    return float(np.min(np.where(convex, rp, np.inf)))


def _oscillating(f: Follower, a: float, r0: float) -> Follower:
    if f.contact == "flat-faced":
        phi0 = math.asin(min((r0 + f.offset) / a, 1.0))
    else:
        phi0 = start_angle_of(a, f.arm, r0)
    return f.with_base(base_radius=r0, pivot=a, start_angle=phi0)


def _best_pivot(program, f, sense, allow, th, r0) -> tuple[float, float]:
    """(excess, a): the pivot distance that makes the cam of base radius r0 best."""
    from scipy.optimize import minimize_scalar

    l = f.arm
    if f.contact == "flat-faced":
        lo, hi = (r0 + f.offset) * 1.0001, max(4 * l, 4 * r0)
    else:
        lo, hi = abs(l - r0) * 1.0001 + 1e-9, (l + r0) * 0.9999

    def g(a):
        try:
            return excess(solve(program, _oscillating(f, a, r0), sense, th), program, allow)
        except ValueError:
            return math.inf

    grid = np.linspace(lo, hi, 41)
    vals = np.array([g(a) for a in grid])
    i = int(np.argmin(vals))
    a0, a1 = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    r = minimize_scalar(g, bounds=(a0, a1), method="bounded", options={"xatol": 1e-7 * l})
    if r.fun < vals[i]:
        return float(r.fun), float(r.x)
    return float(vals[i]), float(grid[i])


def _size_oscillating(program, f, sense, allow, th) -> Sizing:
    l = f.arm

    def ok(r0):
        return _best_pivot(program, f, sense, allow, th, r0)[0] <= 0.0

    hi = 0.25 * l
    while not ok(hi):
        hi *= 1.5
        if hi > 50 * l:
            raise ValueError(
                "no base radius up to 50 arm lengths meets the allowances: the allowable "
                "pressure angles are too small for this swing and cam angle"
            )
    r0 = _bisect(ok, 1e-4 * l, hi, rel=1e-5)
    a = _best_pivot(program, f, sense, allow, th, r0)[1]
    fol = _oscillating(f, a, r0)
    fine = solve(program, fol, sense, np.linspace(0, 2 * math.pi, 3600, endpoint=False))
    return Sizing(
        fol, sense, extremes(fine, program), _rho_min(fine),
        "smallest r0 for which some pivot distance a meets the allowances (bisection on r0, "
        "a by scan and bounded search); phi0 from r0^2 = a^2 + l^2 - 2 a l cos(phi0)",
    )  # fmt: skip


def feasible_map(
    program: Program, f: Follower, sense: int, allow: Allowance, r0s, second
) -> np.ndarray:
    """The excess (see :func:`excess`) over a grid of base radius (rows) and pivot
    distance (oscillating) or offset (translating) (columns): <= 0 is feasible."""
    th = np.linspace(0.0, 2 * math.pi, COARSE // 2, endpoint=False)
    out = np.full((len(r0s), len(second)), np.nan)
    for i, r0 in enumerate(r0s):
        for j, x in enumerate(second):
            try:
                if f.oscillating:
                    fol = _oscillating(f, x, r0)
                else:
                    fol = f.with_base(base_radius=r0, offset=x)
                out[i, j] = excess(solve(program, fol, sense, th), program, allow)
            except ValueError:
                pass
    return out


__all__ = [
    "Allowance",
    "Sizing",
    "base_radius_of",
    "excess",
    "extremes",
    "feasible_map",
    "min_base_translating",
    "size",
]
