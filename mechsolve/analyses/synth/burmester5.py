"""Five-position motion generation: Burmester's points.

A fixed pivot c serves four poses when it lies on their centre-point curve (see
:mod:`.burmester`); it serves five when it lies on the curve of poses 1-4 **and** on the
curve of poses 1, 2, 3, 5. Both curves are cubics, so they meet in nine points (Bezout):
the three poles P12, P13, P23 of the poses they share (every centre-point curve passes
through its poses' poles, where the circle point is undetermined), the two circular
points at infinity (every centre-point curve is circular), and the up to four real
**Burmester points**, the fixed pivots of the RR dyads through the five poses.

They are found here as the real roots of the resultant of the two cubics (the 6 x 6
Sylvester determinant, a polynomial of degree at most 9 in one coordinate, interpolated
exactly from its values), each completed by the common root of the other coordinate and
polished by Newton's method on both cubics; the poles are removed and every point is
checked on all five poses (its circle point's five positions on one circle). Each pair
of Burmester points is a four-bar through the five poses: driven from either pivot, each
is checked for branch and order defects over the five poses.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from mechsolve.analyses.synth.burmester import circle_point, cpc_det
from mechsolve.analyses.synth.common import Design, cross, dist, transmission_along
from mechsolve.base.errors import InputError

__all__ = ["burmester_points", "five_positions", "poles"]

# monomials x^i y^j of a cubic, i + j <= 3
_MONO = [(i, j) for i in range(4) for j in range(4 - i)]


def _normalise(poses):
    """Poses moved and scaled so that their points span about 1 around the origin, and
    the map back (centre, scale)."""
    pts = np.array([p for p, _ in poses], float)
    centre = pts.mean(axis=0)
    scale = max(float(np.ptp(pts[:, 0])), float(np.ptp(pts[:, 1])), 1e-300)
    out = [(((p[0] - centre[0]) / scale, (p[1] - centre[1]) / scale), f) for p, f in poses]
    return out, centre, scale


def _cubic(poses, rot: float) -> np.ndarray:
    """Coefficients (over _MONO) of the centre-point curve of four poses in coordinates
    (t, u) turned by ``rot`` from (x, y): fitted exactly on 25 points (a cubic)."""
    g = np.linspace(-1.0, 1.0, 5)
    T, U = (a.ravel() for a in np.meshgrid(g, g))
    cr, sr = math.cos(rot), math.sin(rot)
    X, Y = cr * T - sr * U, sr * T + cr * U
    z = cpc_det(X, Y, poses)
    M = np.column_stack([T**i * U**j for i, j in _MONO])
    coef, *_ = np.linalg.lstsq(M, z, rcond=None)
    return coef / max(float(np.max(np.abs(coef))), 1e-300)


def _in_u(coef: np.ndarray, t: complex) -> np.ndarray:
    """The cubic at t as a polynomial in u, highest power first (4 coefficients)."""
    out = np.zeros(4, complex)
    for (i, j), c in zip(_MONO, coef):
        out[3 - j] += c * t**i
    return out


def _value_grad(coef: np.ndarray, t: float, u: float) -> tuple[float, float, float]:
    f = gt = gu = 0.0
    for (i, j), c in zip(_MONO, coef):
        f += c * t**i * u**j
        if i:
            gt += c * i * t ** (i - 1) * u**j
        if j:
            gu += c * j * t**i * u ** (j - 1)
    return f, gt, gu


def _sylvester(p: np.ndarray, q: np.ndarray) -> complex:
    """Resultant of two cubics (highest power first) as the 6 x 6 Sylvester determinant."""
    S = np.zeros((6, 6), complex)
    for k in range(3):
        S[k, k : k + 4] = p
        S[k + 3, k : k + 4] = q
    return complex(np.linalg.det(S))


def _common_roots(c1: np.ndarray, c2: np.ndarray) -> list[tuple[float, float]]:
    """Real common points of two cubics (t, u): the resultant in u is a polynomial of
    degree <= 9 in t, interpolated at 10 points of the unit circle (exact: a discrete
    Fourier transform of the values), then each real t completed by its common u."""
    n = 10
    w = np.exp(2j * np.pi * np.arange(n) / n)
    vals = np.array([_sylvester(_in_u(c1, t), _in_u(c2, t)) for t in w])
    coef = np.fft.fft(vals) / n  # coefficients of t^0 .. t^9
    coef = coef[::-1]  # highest first
    big = np.max(np.abs(coef))
    while len(coef) > 1 and abs(coef[0]) < 1e-13 * big:
        coef = coef[1:]
    out = []
    for t in np.roots(coef):
        if abs(t.imag) > 1e-6 * max(1.0, abs(t)):
            continue
        t = float(t.real)
        us = np.roots(_in_u(c1, t))
        cand = [float(u.real) for u in us if abs(u.imag) <= 1e-6 * max(1.0, abs(u))]
        if not cand:
            continue
        u = min(cand, key=lambda u: abs(np.polyval(_in_u(c2, t), u)))
        out.append(_newton(c1, c2, t, u))
    return out


def _newton(c1, c2, t: float, u: float) -> tuple[float, float]:
    for _ in range(30):
        f1, a, b = _value_grad(c1, t, u)
        f2, c, d = _value_grad(c2, t, u)
        det = a * d - b * c
        if det == 0:
            break
        dt, du = (d * f1 - b * f2) / det, (-c * f1 + a * f2) / det
        t, u = t - dt, u - du
        if abs(dt) + abs(du) < 1e-15 * max(1.0, abs(t) + abs(u)):
            break
    return t, u


def poles(poses) -> list[tuple[float, float]]:
    """The poles P_ij (i < j) of the displacements between the poses: the point that
    takes the same place in both (None for a pure translation, left out)."""
    out = []
    for (p, f), (q, g) in itertools.combinations(poses, 2):
        dphi = g - f
        if abs(math.remainder(dphi, 2 * math.pi)) < 1e-12:
            continue
        # x = q + R(dphi)(x - p)  ->  (I - R) x = q - R p
        c, s = math.cos(dphi), math.sin(dphi)
        R = np.array([[c, -s], [s, c]])
        x = np.linalg.solve(np.eye(2) - R, np.array(q) - R @ np.array(p))
        out.append((float(x[0]), float(x[1])))
    return out


def burmester_points(poses) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The real Burmester points of five poses: (fixed pivot c, moving pivot m in the
    body's frame) pairs, at most four, each serving all five poses."""
    if len(poses) != 5:
        raise InputError(f"five poses are needed, got {len(poses)}")
    norm, centre, scale = _normalise(poses)
    sub1, sub2 = norm[:4], norm[:3] + norm[4:]
    found: list[tuple[float, float]] = []
    for rot in (0.5123, 1.3371, 2.2199):  # a generic turn: no two roots share t
        c1, c2 = _cubic(sub1, rot), _cubic(sub2, rot)
        cr, sr = math.cos(rot), math.sin(rot)
        pts = [(cr * t - sr * u, sr * t + cr * u) for t, u in _common_roots(c1, c2)]
        if len(pts) >= len(found):
            found = pts
    shared_poles = poles(norm[:3])
    out = []
    for c in found:
        if any(dist(c, p) < 1e-7 * max(1.0, math.hypot(*c)) for p in shared_poles):
            continue
        if any(dist(c, k) < 1e-7 * max(1.0, math.hypot(*c)) for k, _ in out):
            continue
        m = _circle_point5(c, norm)
        if m is None:
            continue
        out.append((c, m))
    return [
        ((centre[0] + scale * c[0], centre[1] + scale * c[1]), (scale * m[0], scale * m[1]))
        for c, m in out
    ]


def _circle_point5(c, poses):
    """The moving pivot whose five positions lie on one circle about c, or None."""
    m = circle_point(c, poses[:4])
    pts = [_place(p, f, m) for p, f in poses]
    r = [dist(c, q) for q in pts]
    if max(r) - min(r) > 1e-7 * max(1.0, max(r)):
        return None
    return m


def _place(p, phi: float, local) -> tuple[float, float]:
    c, s = math.cos(phi), math.sin(phi)
    return (p[0] + c * local[0] - s * local[1], p[1] + s * local[0] + c * local[1])


def five_positions(poses) -> list[Design]:
    """The four-bars through five poses: every pair of real Burmester points, driven from
    either pivot, each checked for branch and order defects over the five poses."""
    from mechsolve.analyses.synth.motion_gen import three_positions

    _distinct_poses(poses)
    pts = burmester_points(poses)
    if len(pts) < 2:
        raise InputError(
            f"the five poses have {len(pts)} real Burmester point(s): no four-bar with "
            "revolute joints reaches them (two are needed for its two fixed pivots)"
        )
    designs = []
    for (ca, ma), (cb, mb) in itertools.combinations(pts, 2):
        for d in three_positions(poses[:3], ma, mb):
            _check_five(d, poses, ma, mb, (ca, cb))
            designs.append(d)
    return designs


def _distinct_poses(poses) -> None:
    """Refuse poses that determine no Burmester points: two alike, or all of them turns
    about one point (a body on a single crank there)."""
    if len(poses) != 5:
        raise InputError(f"five poses are needed, got {len(poses)}")
    _, _, scale = _normalise(poses)
    for i, j in itertools.combinations(range(len(poses)), 2):
        (p, f), (q, g) = poses[i], poses[j]
        if dist(p, q) <= 1e-12 * scale and abs(math.remainder(f - g, 2 * math.pi)) < 1e-12:
            raise InputError(f"positions {i + 1} and {j + 1} are the same")
    ps = poles(poses)
    if len(ps) == 10 and all(dist(p, ps[0]) <= 1e-9 * scale for p in ps):
        x, y = (0.0 if abs(v) <= 1e-9 * scale else v for v in ps[0])
        raise InputError(
            f"the poses are turns about one point ({x:.6g}, {y:.6g}): a single crank pivoted "
            "there carries the body, and no four-bar is determined"
        )


def _check_five(d: Design, poses, ma, mb, centres) -> None:
    inp = d.extra["input"]
    i0, o0 = d.ground[inp], d.ground["B0" if inp == "A0" else "A0"]
    mi, mo = (ma, mb) if inp == "A0" else (mb, ma)
    ip = [_place(p, f, mi) for p, f in poses]
    op = [_place(p, f, mo) for p, f in poses]
    n = len(poses)
    sides = [cross(o0, ip[i], op[i]) for i in range(n)]
    ang = [math.atan2(q[1] - i0[1], q[0] - i0[0]) for q in ip]
    dirn = d.extra["direction"]
    offs = [((a - ang[0]) * dirn) % (2 * math.pi) for a in ang]
    d.method = "five-position motion generation (Burmester points)"
    d.extra.update(input_angles=ang, positions=list(poses), travel=offs[-1],
                   moving=(ip, op), centre_points=centres)  # fmt: skip
    d.notes = [s for s in d.notes if not s.startswith("order defect")]
    d.valid = not any(s.startswith("branch defect") for s in d.notes)
    if not (all(s > 0 for s in sides) or all(s < 0 for s in sides)):
        d.valid = False
        if not any(s.startswith("branch defect") for s in d.notes):
            d.notes.append("branch defect: the poses lie on different assembly branches")
    if not all(offs[i] < offs[i + 1] for i in range(1, n - 1)):
        d.valid = False
        d.notes.append("order defect: the input does not reach the poses in order")
    th = ang[0] + dirn * np.linspace(0, offs[-1], 4001)
    fa = math.atan2(o0[1] - i0[1], o0[0] - i0[0])
    L = d.lengths
    mu = transmission_along(L["input"], L["coupler"], L["output"], L["frame"], th - fa)
    if np.isnan(mu).any():
        d.valid = False
        d.notes.append("order defect: the loop cannot close between the poses")
        d.min_transmission = math.nan  # not defined: the loop does not close
    else:
        d.min_transmission = float(np.min(mu))


def plot_five(plt, out):
    """The centre-point curves of poses 1-4 and of poses 1, 2, 3, 5, the Burmester points
    where they meet, the five poses of the body's line and the chosen linkage in pose 1."""
    from mechsolve.analyses.synth.burmester import curves

    d = out.chosen
    poses = d.extra["positions"]
    pts = np.array([c for c, _ in burmester_points(poses)])
    _, _, scale = _normalise(poses)

    def extent(sub) -> float:  # the curve drawn out to every Burmester point
        _, mid, span = _normalise(sub)
        reach = np.max(np.abs(pts - mid)) / span
        return max(2.0, 1.1 * float(reach))

    fig, ax = plt.subplots(figsize=(7, 6))
    for k, (sub, style, label) in enumerate(
        ((poses[:4], "-", "centre-point curve, poses 1-4"),
         (poses[:3] + poses[4:], "--", "centre-point curve, poses 1, 2, 3, 5"))
    ):  # fmt: skip
        for i, ln in enumerate(curves(sub, extent=extent(sub), n=601)[0]):
            ax.plot(ln[:, 0], ln[:, 1], style, color=f"C{k}", label=label if i == 0 else None)
    ax.plot(pts[:, 0], pts[:, 1], "s", color="C3", ms=8, label="Burmester points")
    for j, ((px, py), f) in enumerate(poses):
        ax.annotate("", (px + 0.15 * scale * math.cos(f), py + 0.15 * scale * math.sin(f)),
                    (px, py), arrowprops={"arrowstyle": "->", "color": "k"})  # fmt: skip
        ax.text(px, py, f" {j + 1}")
    ip, op = d.extra["moving"]
    g = list(d.ground.values())
    ax.plot([g[0][0], ip[0][0], op[0][0], g[1][0]], [g[0][1], ip[0][1], op[0][1], g[1][1]],
            "o-", color="C2", label=f"the design in pose 1 ({d.family})")  # fmt: skip
    ax.set_aspect("equal", adjustable="datalim")
    from mechsolve.base.units import OutputUnits
    from mechsolve.writers.plots import length_axes

    unit = length_axes(ax, OutputUnits(length=out.unit))
    ax.set_xlabel(f"x ({unit})")
    ax.set_ylabel(f"y ({unit})")
    ax.set_title(f"{out.name}: Burmester points of five poses")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
