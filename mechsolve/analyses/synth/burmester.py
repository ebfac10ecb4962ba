"""Four-position motion generation: Burmester's centre-point curve.

A body (the coupler, its frame at P_j turned by phi_j in pose j) must take four poses. A
moving pivot m (in the body's frame) stays on a circle about a fixed pivot c when

    |R_j m + P_j - c|^2 = r^2,  j = 1..4.

Subtracting pose 1 removes |m|^2, |c|^2 and r^2::

    2 m . (R_j^T (P_j - c) - R_1^T (P_1 - c)) = |P_1 - c|^2 - |P_j - c|^2,  j = 2, 3, 4,

three equations linear in m: for a given c they have a solution exactly when the 3 x 3
determinant det[A(c) | b(c)] vanishes, a cubic in c: the **centre-point curve**. Every
point c of it gives its circle point m (the circle-point curve is their image in pose 1).
Two centre points on it, with their circle points, make a four-bar through the four
poses; its branch and order along the motion are then checked.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.analyses.synth.common import Design, cross, dist, transmission_along
from mechsolve.base.errors import InputError

__all__ = ["cpc_det", "circle_point", "snap", "curves", "four_positions"]


def _rows(cx, cy, poses):
    """A (3, 2, ...) and b (3, ...) of the linear equations in m."""
    (p1, f1) = poses[0]
    c1, s1 = math.cos(f1), math.sin(f1)
    u1x, u1y = p1[0] - cx, p1[1] - cy
    v1x, v1y = c1 * u1x + s1 * u1y, -s1 * u1x + c1 * u1y  # R_1^T (P_1 - c)
    A, b = [], []
    for p, f in poses[1:]:
        cj, sj = math.cos(f), math.sin(f)
        ux, uy = p[0] - cx, p[1] - cy
        vx, vy = cj * ux + sj * uy, -sj * ux + cj * uy
        A.append((2 * (vx - v1x), 2 * (vy - v1y)))
        b.append(u1x * u1x + u1y * u1y - ux * ux - uy * uy)
    return A, b


def cpc_det(cx, cy, poses):
    """det[A(c) | b(c)] (arrays of c): zero on the centre-point curve."""
    A, b = _rows(np.asarray(cx, float), np.asarray(cy, float), poses)
    (a11, a12), (a21, a22), (a31, a32) = A
    b1, b2, b3 = b
    return (
        a11 * (a22 * b3 - a32 * b2)
        - a12 * (a21 * b3 - a31 * b2)
        + b1 * (a21 * a32 - a31 * a22)
    )  # fmt: skip


def circle_point(c, poses) -> tuple[float, float]:
    """The moving pivot (body frame) whose four positions lie on a circle about c."""
    A, b = _rows(float(c[0]), float(c[1]), poses)
    m, *_ = np.linalg.lstsq(np.array(A, float), np.array(b, float), rcond=None)
    return float(m[0]), float(m[1])


def _scale(poses) -> float:
    pts = np.array([p for p, _ in poses], float)
    return max(float(np.ptp(pts[:, 0])), float(np.ptp(pts[:, 1])), 1e-9)


def snap(c0, poses, tol: float = 1e-13) -> tuple[float, float]:
    """The point of the centre-point curve nearest to c0 (Newton steps along the
    gradient of the determinant)."""
    c = np.array(c0, float)
    h = 1e-7 * _scale(poses)
    for _ in range(60):
        f = float(cpc_det(c[0], c[1], poses))
        g = np.array(
            [
                (cpc_det(c[0] + h, c[1], poses) - cpc_det(c[0] - h, c[1], poses)) / (2 * h),
                (cpc_det(c[0], c[1] + h, poses) - cpc_det(c[0], c[1] - h, poses)) / (2 * h),
            ],
            float,
        )
        gg = float(g @ g)
        if gg == 0:
            break
        step = f / gg * g
        c = c - step
        if np.hypot(*step) <= tol * _scale(poses):
            break
    return float(c[0]), float(c[1])


def curves(poses, extent: float = 2.0, n: int = 401):
    """The centre-point curve (polylines, global) and the circle-point curve (the circle
    points placed in pose 1), over a square ``extent`` times the poses' span around them."""
    import contourpy

    pts = np.array([p for p, _ in poses], float)
    mid, half = pts.mean(axis=0), extent * _scale(poses)
    xs = np.linspace(mid[0] - half, mid[0] + half, n)
    ys = np.linspace(mid[1] - half, mid[1] + half, n)
    X, Y = np.meshgrid(xs, ys)
    Z = cpc_det(X, Y, poses)
    lines = contourpy.contour_generator(X, Y, Z).lines(0.0)
    (p1, f1) = poses[0]
    c1, s1 = math.cos(f1), math.sin(f1)
    circle = []
    for ln in lines:
        ms = np.array([circle_point(c, poses) for c in ln])
        circle.append(
            np.column_stack(
                [p1[0] + c1 * ms[:, 0] - s1 * ms[:, 1], p1[1] + s1 * ms[:, 0] + c1 * ms[:, 1]]
            )
        )
    return lines, circle


def four_positions(poses, near_a, near_b) -> list[Design]:
    """The four-bars through four poses whose fixed pivots are the points of the
    centre-point curve nearest to ``near_a`` and ``near_b``: driven from either pivot,
    each checked for branch and order defects over the four poses."""
    from mechsolve.analyses.synth.motion_gen import _place, three_positions

    if len(poses) != 4:
        raise InputError(f"four poses are needed, got {len(poses)}")
    ca, cb = snap(near_a, poses), snap(near_b, poses)
    if dist(ca, cb) < 1e-9 * _scale(poses):
        raise InputError("both pivots snap to the same point of the centre-point curve")
    ma, mb = circle_point(ca, poses), circle_point(cb, poses)
    designs = three_positions(poses[:3], ma, mb)
    for d in designs:
        inp = d.extra["input"]
        i0, o0 = d.ground[inp], d.ground["B0" if inp == "A0" else "A0"]
        mi, mo = (ma, mb) if inp == "A0" else (mb, ma)
        ip = [_place(p, f, mi) for p, f in poses]
        op = [_place(p, f, mo) for p, f in poses]
        # every pose on its circle: the fourth too (c is on the curve)
        r = [dist(i0, q) for q in ip] + [dist(o0, q) for q in op]
        d.extra["circle_error"] = max(abs(x - r[0]) for x in r[:4]) + max(
            abs(x - r[4]) for x in r[4:]
        )
        sides = [cross(o0, ip[i], op[i]) for i in range(4)]
        ang = [math.atan2(q[1] - i0[1], q[0] - i0[0]) for q in ip]
        dirn = d.extra["direction"]
        offs = [((a - ang[0]) * dirn) % (2 * math.pi) for a in ang]
        d.method = "four-position motion generation (Burmester)"
        d.extra.update(input_angles=ang, positions=list(poses), travel=offs[3],
                       moving=(ip, op), centre_points=(ca, cb))  # fmt: skip
        d.notes = [n for n in d.notes if not n.startswith("order defect")]
        d.valid = not any(n.startswith("branch defect") for n in d.notes)
        if not (all(s > 0 for s in sides) or all(s < 0 for s in sides)):
            d.valid = False
            if not d.notes:
                d.notes.append("branch defect: the poses lie on different assembly branches")
        if not offs[1] < offs[2] < offs[3]:
            d.valid = False
            d.notes.append("order defect: the input does not reach the poses in order")
        th = ang[0] + dirn * np.linspace(0, offs[3], 4001)
        fa = math.atan2(o0[1] - i0[1], o0[0] - i0[0])
        L = d.lengths
        mu = transmission_along(L["input"], L["coupler"], L["output"], L["frame"], th - fa)
        if np.isnan(mu).any():
            d.valid = False
            d.notes.append("order defect: the loop cannot close between the poses")
            d.min_transmission = math.nan  # not defined: the loop does not close
        else:
            d.min_transmission = float(np.min(mu))
    return designs


def confirm_poses(out) -> str:
    """Solve the written file with mechsolve at the input's angles of the four poses and
    compare the coupler line (P and Q, one length unit apart along it) with each pose."""
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.model.parse import loads

    d = out.chosen
    mech = loads(out.yaml)
    res = solve_instants(mech, [Instant(float(a), 1.0, 0.0) for a in d.extra["input_angles"]])
    p, q = res.point("P"), res.point("Q")
    errs = []
    for i, ((px, py), f) in enumerate(d.extra["positions"]):
        e_pos = math.hypot(p.x[i] - px, p.y[i] - py)
        e_ang = abs(math.remainder(math.atan2(q.y[i] - p.y[i], q.x[i] - p.x[i]) - f, 2 * math.pi))
        errs.append((e_pos, e_ang))
    out.check = {"poses": errs}
    from mechsolve.analyses.synth.writer import Numbers

    k = Numbers(out.unit).factor
    return "  mechsolve run of the written file: pose errors " + ", ".join(
        f"{i + 1}: {e / k:.2e} {out.unit}, {math.degrees(a):.2e} deg"
        for i, (e, a) in enumerate(errs)
    )


def plot_curves(plt, out):
    """The centre-point curve (fixed pivots), the circle-point curve (moving pivots in
    pose 1), the four poses of the coupler line and the chosen linkage in pose 1."""
    d = out.chosen
    poses = d.extra["positions"]
    centre, circle = curves(poses)
    fig, ax = plt.subplots(figsize=(7, 6))
    for i, ln in enumerate(centre):
        ax.plot(ln[:, 0], ln[:, 1], "-", color="C0", label="centre-point curve" if i == 0 else None)
    for i, ln in enumerate(circle):
        ax.plot(ln[:, 0], ln[:, 1], "--", color="C1",
                label="circle-point curve (pose 1)" if i == 0 else None)  # fmt: skip
    span = _scale(poses) * 0.15
    for j, ((px, py), f) in enumerate(poses):
        ax.annotate("", (px + span * math.cos(f), py + span * math.sin(f)), (px, py),
                    arrowprops={"arrowstyle": "->", "color": "k"})  # fmt: skip
        ax.text(px, py, f" {j + 1}")
    ip, op = d.extra["moving"]
    g = list(d.ground.values())
    xs = [g[0][0], ip[0][0], op[0][0], g[1][0]]
    ys = [g[0][1], ip[0][1], op[0][1], g[1][1]]
    ax.plot(xs, ys, "o-", color="C2", label=f"the design in pose 1 ({d.family})")
    ax.set_aspect("equal", adjustable="datalim")
    from mechsolve.base.units import OutputUnits
    from mechsolve.writers.plots import length_axes

    unit = length_axes(ax, OutputUnits(length=out.unit))
    ax.set_xlabel(f"x ({unit})")
    ax.set_ylabel(f"y ({unit})")
    ax.set_title(f"{out.name}: Burmester curves of four poses")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
