"""The cam's curves as a cam contact (:mod:`mechsolve.joints.cam_contact`) uses them:
periodic functions of an angle with their first two derivatives, the pitch curve's polar
radius ``rho(psi)`` about the cam's centre (a roller) or the profile's support function
``h(mu)`` (a flat face), for a circle (closed forms), a motion program (exact, by the
inversion of :mod:`mechsolve.base.cam.profile`) or a profile table (periodic cubic
splines); and their reading from a file's mapping (``r``: the model's file reader).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

Reader = Any  # the model's file reader (mechsolve.model.reader.Reader)
KeyPath = tuple
TWO_PI = 2.0 * math.pi
SAMPLES = 7200  # a program's cam: Newton's first guess from a sample every 0.05 deg
DENSE = 7200  # a table's profile is resampled this finely to offset it or take its support


class Curve:
    """A periodic function of an angle with its first two derivatives: the pitch curve's
    polar radius ``rho(psi)`` (a roller) or the profile's support function ``h(mu)`` (a
    flat face). ``accuracy`` (m) bounds its error against the exact curve (0: exact)."""

    accuracy: float = 0.0
    source: str = ""

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError

    def breaks(self) -> np.ndarray:
        """The angles x (rad, in [0, 2 pi)) where the curve's second derivative (or its
        first) jumps: where the follower's acceleration (or velocity) jumps, and with it
        the contact force. None for a smooth curve (a circle, a spline through a table)."""
        return np.zeros(0)


class CirclePolar(Curve):
    """The polar radius about O of a circle of radius ``R`` centred ``e`` from O on the x
    axis: ``rho = e cos psi + sqrt(R^2 - e^2 sin^2 psi)`` (exact)."""

    def __init__(self, R: float, e: float) -> None:
        self.R, self.e = R, e
        self.source = f"circle R {R * 1e3:g} mm, e {e * 1e3:g} mm"

    def __call__(self, x):
        e, c, s = self.e, np.cos(x), np.sin(x)
        S = np.sqrt(self.R**2 - (e * s) ** 2)
        rho = e * c + S
        d1 = -e * s - e * e * s * c / S
        d2 = -e * c - e * e * (c * c - s * s) / S - e**4 * (s * c) ** 2 / S**3
        return rho, d1, d2


class CircleSupport(Curve):
    """The support function about O of the same circle: ``h = R + e cos mu`` (exact)."""

    def __init__(self, R: float, e: float) -> None:
        self.R, self.e = R, e
        self.source = f"circle R {R * 1e3:g} mm, e {e * 1e3:g} mm"

    def __call__(self, x):
        return self.R + self.e * np.cos(x), -self.e * np.sin(x), -self.e * np.cos(x)


class Spline(Curve):
    """A periodic cubic spline through ``(x, y)`` (x increasing over less than a turn; the
    first sample is repeated a turn later)."""

    def __init__(self, x: np.ndarray, y: np.ndarray, source: str) -> None:
        from scipy.interpolate import CubicSpline  # lazy: start-up time

        x = np.asarray(x, float)
        y = np.asarray(y, float)
        self.x0 = float(x[0])
        xs = np.append(x - self.x0, TWO_PI)
        ys = np.append(y, y[0])
        self.f = CubicSpline(xs, ys, bc_type="periodic")
        self.d1 = self.f.derivative(1)
        self.d2 = self.f.derivative(2)
        self.source = source

    def __call__(self, x):
        t = np.mod(np.asarray(x, float) - self.x0, TWO_PI)
        return self.f(t), self.d1(t), self.d2(t)


def _monotone_angles(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The polar angles (increasing, within one turn from the first) and radii of the
    closed curve ``xy`` (no repeated end), or None if it is not star-shaped about O."""
    ang = np.unwrap(np.arctan2(xy[:, 1], xy[:, 0]))
    rad = np.hypot(xy[:, 0], xy[:, 1])
    if ang[-1] < ang[0]:
        ang, rad = ang[::-1], rad[::-1]
    if not np.all(np.diff(ang) > 0) or ang[-1] - ang[0] >= TWO_PI:
        return None
    return ang, rad


def polar_spline(xy: np.ndarray, source: str) -> Spline | None:
    """The polar radius of the closed curve ``xy`` as a periodic spline (None: the curve is
    not star-shaped about its centre)."""
    got = _monotone_angles(xy)
    return None if got is None else Spline(got[0], got[1], source)


def support_spline(contact: np.ndarray, normal: np.ndarray, source: str) -> Spline | None:
    """The support function from contact points and their outward normals (None: the
    normal does not turn one way: the profile is not convex)."""
    mu = np.unwrap(np.arctan2(normal[:, 1], normal[:, 0]))
    h = np.sum(contact * normal, axis=1)
    if mu[-1] < mu[0]:
        mu, h = mu[::-1], h[::-1]
    if not np.all(np.diff(mu) > 0) or mu[-1] - mu[0] >= TWO_PI:
        return None
    return Spline(mu, h, source)


def outward(xy: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Unit outward normals of a counter-clockwise curve with tangents ``d``."""
    n = np.stack([d[:, 1], -d[:, 0]], axis=1)
    return n / np.linalg.norm(n, axis=1)[:, None]


# -- reading the profile
def read_table(r: Reader, v: Any, path: KeyPath) -> np.ndarray:
    """The profile's points (cam frame, SI), closed: the last entry repeats the first."""
    m = r.mapping(v, path, ("polar", "points"), "a profile table ({polar: ...} or {points: ...})")
    if len(m) != 1:
        raise r.fail(path, "give the table as 'polar' ([angle, radius] rows) or 'points'")
    key = next(iter(m))
    rows = m[key]
    p = path + (key,)
    if not isinstance(rows, list) or len(rows) < 9:
        raise r.fail(p, "a profile table needs at least 8 rows and the first repeated at the end")
    pts = []
    for i, row in enumerate(rows):
        if not (isinstance(row, list) and len(row) == 2):
            raise r.fail(p + (i,), "each row is a pair: " + ("[angle, radius]" if key == "polar"
                                                          else "[x, y]"))  # fmt: skip
        if key == "polar":
            a = r.quantity(row[0], p + (i, 0), "angle")
            rad = r.positive(row[1], p + (i, 1), "length")
            pts.append((a, rad))
        else:
            pts.append(r.xy(row, p + (i,)))
    arr = np.array(pts, float)
    if key == "polar":
        a, rad = arr[:, 0], arr[:, 1]
        turn = a[-1] - a[0]
        if abs(abs(turn) - TWO_PI) > 1e-9 * TWO_PI or abs(rad[-1] - rad[0]) > 1e-9 * rad.max():
            raise r.fail(
                p,
                "the profile table is not closed: its last row must repeat its first a turn "
                f"later (from {math.degrees(a[0]):.6g} deg, {rad[0] * 1e3:.6g} mm the table "
                f"ends at {math.degrees(a[-1]):.6g} deg, {rad[-1] * 1e3:.6g} mm)",
            )
        d = np.diff(a) * np.sign(turn)
        if np.any(d <= 0):
            i = int(np.flatnonzero(d <= 0)[0]) + 1
            raise r.fail(p + (i,), "the table's angles must increase (or decrease) row by row")
        xy = np.stack([rad * np.cos(a), rad * np.sin(a)], axis=1)
    else:
        xy = arr
        size = float(np.max(np.ptp(xy, axis=0)))
        gap = float(np.hypot(*(xy[-1] - xy[0])))
        if gap > 1e-9 * size:
            raise r.fail(
                p,
                "the profile table is not closed: its last point must repeat its first "
                f"(it ends {gap * 1e3:.6g} mm from where it starts)",
            )
    return xy[:-1]


def table_curve(r: Reader, xy: np.ndarray, path: KeyPath, roller: float | None) -> Curve:
    """The pitch curve's polar radius (a roller of radius ``roller``) or the support
    function (a flat face, ``roller`` None) of the profile table ``xy``."""
    prof = polar_spline(xy, "profile table")
    if prof is None:
        raise r.fail(path, "the profile table is not star-shaped about the cam's centre: seen "
                     "from the centre, its points must turn one way only, once")  # fmt: skip
    psi = prof.x0 + np.linspace(0.0, TWO_PI, DENSE, endpoint=False)
    rho, d1, _ = prof(psi)
    c, s = np.cos(psi), np.sin(psi)
    pts = np.stack([rho * c, rho * s], axis=1)
    tang = np.stack([d1 * c - rho * s, d1 * s + rho * c], axis=1)
    n = outward(pts, tang)
    if roller is not None:
        out = polar_spline(pts + roller * n, f"profile table + roller {roller * 1e3:g} mm")
        if out is None:
            raise r.fail(path, "the roller is too large for this profile: its pitch curve "
                         "folds over itself")  # fmt: skip
        return out
    sup = support_spline(pts, n, "profile table")
    if sup is None:
        raise r.fail(path, "a flat face needs a convex profile: this table's profile is "
                     "concave somewhere")  # fmt: skip
    return sup


class ProgramCurve(Curve):
    """The pitch curve's polar radius (a roller) or the support function (a flat face) of
    the cam that a motion program defines, exact: at an angle x (psi or mu, cam frame)
    the cam angle theta where the follower's point is seen at x is found by Newton's
    method (from the curve sampled every 0.05 deg), then rho or h and their derivatives
    with respect to x follow from the program's s, s', s'' at theta by the inversion of
    :mod:`mechsolve.base.cam.profile` (the same formulas)."""

    def __init__(self, program: Any, f: Any, sense: int, roller: bool, source: str) -> None:
        self.program, self.f, self.sg, self.roller = program, f, float(sense), roller
        self.source = source
        th = np.linspace(0.0, TWO_PI, SAMPLES + 1)
        x, _, _, _, dx = self._at(th)
        if not (np.all(dx > 0) or np.all(dx < 0)):
            raise ValueError("its curve does not turn one way about the cam's centre")
        x = np.unwrap(x)
        if x[-1] < x[0]:
            x, th = x[::-1], th[::-1]
        self.x0, self.xs, self.ths = float(x[0]), x - x[0], th

    def _at(self, th: np.ndarray):
        """x, the curve's value and its first two derivatives in x, and dx/dtheta."""
        s, s1, s2, _ = self.program.eval(th)
        f, sg = self.f, self.sg
        if not self.roller:
            if f.oscillating:
                g = f.start_angle + s
                sin_g, cos_g = np.sin(g), np.cos(g)
                h = f.pivot * sin_g - f.offset
                h1 = f.pivot * cos_g * s1
                h2 = f.pivot * (cos_g * s2 - sin_g * s1**2)
                x, m1, m2 = math.pi / 2 - g - sg * th, -s1 - sg, -s2
            else:
                h, h1, h2 = f.base_radius + s, s1, s2
                x, m1, m2 = math.pi / 2 - sg * th, np.full_like(th, -sg), np.zeros_like(th)
            return x, h, h1 / m1, (h2 * m1 - h1 * m2) / m1**3, m1
        if f.oscillating:
            a, ln = f.pivot, f.arm
            g = f.start_angle + s
            sin_g, cos_g = np.sin(g), np.cos(g)
            px, py = a - ln * cos_g, ln * sin_g
            p1x, p1y = ln * s1 * sin_g, ln * s1 * cos_g
            p2x = ln * s2 * sin_g + ln * s1**2 * cos_g
            p2y = ln * s2 * cos_g - ln * s1**2 * sin_g
        else:
            s0 = math.sqrt(f.base_radius**2 - f.offset**2)
            px, py = np.full_like(th, f.offset), s0 + s
            p1x, p1y, p2x, p2y = np.zeros_like(th), s1, np.zeros_like(th), s2
        q1x, q1y = p1x + sg * py, p1y - sg * px  # p' - sg J p
        q2x, q2y = p2x + 2 * sg * p1y - px, p2y - 2 * sg * p1x - py  # p'' - 2 sg J p' - p
        r2 = px * px + py * py
        r = np.sqrt(r2)
        dot1, cr1 = px * q1x + py * q1y, px * q1y - py * q1x
        A = dot1 / r  # d rho / d theta
        B = cr1 / r2  # d psi / d theta
        A1 = (q1x * q1x + q1y * q1y + px * q2x + py * q2y) / r - dot1**2 / (r2 * r)
        B1 = (px * q2y - py * q2x) / r2 - 2 * cr1 * dot1 / (r2 * r2)
        x = np.arctan2(py, px) - sg * th
        return x, r, A / B, (A1 * B - A * B1) / B**3, B

    def breaks(self) -> np.ndarray:
        """The program's joins where the follower's velocity or acceleration jumps (at the
        segments' ends and inside a law, :meth:`Program.remarks`), as the curve's angles x
        where the follower's point is seen when the cam is at each join."""
        th = np.array(sorted({float(r.angle) for r in self.program.remarks()}))
        if not th.size:
            return th
        return np.mod(self._at(th)[0], TWO_PI)

    def __call__(self, x):
        x = np.asarray(x, float)
        t = np.mod(x - self.x0, TWO_PI)
        th = np.interp(t, self.xs, self.ths)
        for _ in range(4):  # quadratic convergence from a guess within 1e-7 rad
            xt, _, _, _, dx = self._at(th)
            th = th - (np.mod(xt - x + math.pi, TWO_PI) - math.pi) / dx
        _, v, d1, d2, _ = self._at(th)
        return v, d1, d2


def program_curve(r: Reader, v: Any, path: KeyPath, roller: float | None) -> Curve:
    """The pitch curve (a roller) or the support function (a flat face) of the cam that a
    motion program as ``mechsolve cam`` reads it defines, exact (:class:`ProgramCurve`);
    its accuracy is measured against the inversion of :mod:`mechsolve.base.cam.profile`."""
    from mechsolve.base.cam.profile import solve
    from mechsolve.base.cam.read import SENSES, read_base, read_follower, read_motion

    keys = ("follower", "base_radius", "pivot_distance", "start_angle", "rotation",
            "motion", "law")  # fmt: skip
    m = r.mapping(v, path, keys, "'program'", ("follower", "motion", "rotation"))
    kind, contact, rr, arm, offset, _ = read_follower(r, m, path)
    osc = kind == "oscillating"
    if (roller is None) != (contact == "flat-faced"):
        want = "a flat-faced" if roller is None else "a roller (or knife-edge)"
        raise r.fail(path + ("follower", "type"), f"the joint's follower is {want} one; the "
                     f"program's is {kind} {contact}")  # fmt: skip
    if roller is not None and abs(rr - roller) > 1e-9:
        raise r.fail(path + ("follower", "roller_radius"), f"the program's roller radius "
                     f"{rr * 1e3:g} mm differs from the joint's {roller * 1e3:g} mm")  # fmt: skip
    t = str(m["rotation"]).strip().lower()
    if t not in SENSES:
        raise r.fail(path + ("rotation",), f"expected cw or ccw, got {m['rotation']!r}")
    sense = SENSES[t]
    limit = None if not osc else (math.pi / 2 if contact == "flat-faced" else math.pi)
    program = read_motion(r, m, osc, limit, path)
    follower, designed, _, _ = read_base(r, m, path, kind, contact, rr, offset, arm, program)
    if designed:
        raise r.fail(path, "a cam inside a linkage needs its base values (base_radius; "
                     "pivot_distance with start_angle for an oscillating follower): "
                     "'mechsolve cam' designs them")  # fmt: skip
    what = f"motion program ({kind} {contact}, {'cw' if sense < 0 else 'ccw'})"
    th = np.linspace(0.0, TWO_PI, 720, endpoint=False) + math.pi / 720
    try:
        ref = solve(program, follower, sense, th)
        if not ref.valid:
            raise ValueError("the face never reaches the cam with these base values")
        curve = ProgramCurve(program, follower, sense, roller is not None, what)
    except ValueError as exc:
        raise r.fail(path, f"this program gives no cam: {exc}") from None
    if roller is not None:
        assert ref.pitch is not None
        err = curve(np.arctan2(ref.pitch[:, 1], ref.pitch[:, 0]))[0] - np.hypot(*ref.pitch.T)
    else:
        c, s_ = np.cos(-sense * th), np.sin(-sense * th)
        n = ref.normal
        mu = np.arctan2(s_ * n[:, 0] + c * n[:, 1], c * n[:, 0] - s_ * n[:, 1])
        err = curve(mu)[0] - np.sum(ref.contact * n, axis=1)
    curve.accuracy = float(np.max(np.abs(err)))
    return curve
