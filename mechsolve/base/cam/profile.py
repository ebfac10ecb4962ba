"""The cam profile by inversion, for every follower type, with the pressure angle and the
radius of curvature.

Frame (fixed): the cam centre O at the origin. A translating follower moves along +y on
the line x = e (the offset). An oscillating follower turns about the pivot A = (a, 0);
its arm (length l) points from A up and to the left, at the angle phi0 + psi from the
line A -> O, so that the roller centre is at distance
r0 = sqrt(a^2 + l^2 - 2 a l cos phi0) from O when psi = 0. The cam turns by
``sense * theta`` (sense +1 counter-clockwise, -1 clockwise).

Inversion: a point p fixed in the frame is seen from the cam at P = R(-sense theta) p. Its
derivatives with respect to theta, written back in the fixed frame, are

    P'  ~ q1 = p' - sense J p
    P'' ~ q2 = p'' - 2 sense J p' - p          (J: a quarter turn counter-clockwise)

so that the pitch curve's tangent, normal and curvature come from the follower's motion
s, s', s'' analytically. A flat face is an envelope of lines: its support function h
(the face's distance from O) and the angle mu of its normal in the cam frame give the
contact point and the radius of curvature rho = h + d2h/dmu2.

The pressure angle is measured where the force acts, between the common normal at the
contact and the direction in which that point of the follower moves: along the guide
(translating), or perpendicular to the line from the pivot (oscillating); it is the acute
angle between them, 0...90 deg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from mechsolve.base.cam.program import Program

KINDS = ("translating", "oscillating")
CONTACTS = ("knife-edge", "roller", "flat-faced")


def _J(v: np.ndarray) -> np.ndarray:
    """Quarter turn counter-clockwise of row vectors."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def _rot(v: np.ndarray, ang: np.ndarray) -> np.ndarray:
    c, s = np.cos(ang), np.sin(ang)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def base_radius_of(a: float, l: float, phi0: float) -> float:
    """r0 of an oscillating follower: r0^2 = a^2 + l^2 - 2 a l cos(phi0)."""
    return math.sqrt(max(a * a + l * l - 2.0 * a * l * math.cos(phi0), 0.0))


def start_angle_of(a: float, l: float, r0: float) -> float:
    """phi0 of an oscillating roller follower from a, l and r0 (ValueError if the
    triangle O-A-B cannot close)."""
    c = (a * a + l * l - r0 * r0) / (2.0 * a * l)
    if not -1.0 < c < 1.0:
        raise ValueError(
            f"no triangle with pivot distance {a * 1e3:g} mm, arm {l * 1e3:g} mm and base "
            f"radius {r0 * 1e3:g} mm (need |a - l| < r0 < a + l)"
        )
    return math.acos(c)


@dataclass(frozen=True)
class Follower:
    """The follower and the cam's base size (SI: m, rad).

    ``base_radius`` is the smallest radius of the pitch curve (the roller centre's path, or
    the knife edge's) for knife-edge and roller followers, and of the cam profile itself
    for a flat-faced one. ``offset`` is the guide's x for a translating follower and the
    distance of the face from the pivot, toward the cam, for an oscillating flat face.
    ``start_angle`` (phi0) is the arm's angle from the line pivot -> cam centre at the
    lowest position.
    """

    kind: str
    contact: str
    base_radius: float
    roller: float = 0.0
    offset: float = 0.0
    arm: float = 0.0
    pivot: float = 0.0
    start_angle: float = 0.0

    @property
    def oscillating(self) -> bool:
        return self.kind == "oscillating"

    def with_base(self, **kw) -> Follower:
        return replace(self, **kw)

    def describe(self, unit: str = "mm", factor: float = 1e-3) -> str:
        """In words, lengths in ``unit`` (``factor`` metres each)."""

        def ln(x: float) -> str:
            return f"{x / factor:g} {unit}"

        if self.oscillating:
            t = f"oscillating {self.contact} follower: arm l = {ln(self.arm)}"
            if self.contact == "roller":
                t += f", roller radius {ln(self.roller)}"
            if self.contact == "flat-faced" and self.offset:
                t += f", face {ln(self.offset)} from the pivot"
            return t
        t = f"translating {self.contact} follower"
        if self.contact == "roller":
            t += f", roller radius {ln(self.roller)}"
        t += f", offset e = {ln(self.offset)}"
        return t


@dataclass
class Profile:
    """The cam over one turn, sampled at cam angles ``theta`` (rad, SI lengths).

    Cam-frame curves (the drawing of the cam at theta = 0): ``pitch`` (roller centre or
    knife edge; None for a flat face) and ``profile`` (the working surface). Fixed-frame
    values at each theta: ``point`` (the roller centre, knife edge or contact),
    ``contact``, ``normal`` (unit, from the cam toward the follower) and ``pressure``
    (the pressure angle, rad). ``rho_pitch`` and ``rho_profile`` are signed radii of
    curvature (positive where the cam is convex, +inf on a straight or circular-free
    stretch is not special: a circle of radius r gives r).
    """

    theta: np.ndarray
    s: np.ndarray
    ds: np.ndarray
    d2s: np.ndarray
    d3s: np.ndarray
    sense: int
    follower: Follower
    pitch: np.ndarray | None
    profile: np.ndarray
    point: np.ndarray
    contact: np.ndarray
    normal: np.ndarray
    pressure: np.ndarray
    rho_pitch: np.ndarray | None
    rho_profile: np.ndarray
    valid: bool = True  # False: the base size leaves no cam (the face never reaches it)

    def undercut(self, margin: float = 0.0) -> np.ndarray:
        """Where the profile cannot be cut: a convex stretch whose radius of curvature
        is at most ``margin`` (the roller larger than the pitch curve's radius, or a
        flat face's s + s'' + r0 <= 0)."""
        rp = self.rho_profile
        if self.follower.contact == "roller":
            assert self.rho_pitch is not None
            return (self.rho_pitch > 0.0) & (rp <= margin)
        if self.follower.contact == "flat-faced":
            return rp <= margin
        return np.zeros_like(rp, dtype=bool)


def solve(program: Program, f: Follower, sense: int, theta: np.ndarray) -> Profile:
    """The cam of ``program`` for follower ``f`` turning in ``sense`` (+1 ccw, -1 cw)."""
    theta = np.asarray(theta, dtype=float)
    s, ds, d2s, d3s = program.eval(theta)
    sg = float(sense)
    if f.contact == "flat-faced":
        return _flat(program, f, sg, theta, s, ds, d2s, d3s)
    n = theta.size
    if f.oscillating:
        a, l = f.pivot, f.arm
        g = f.start_angle + s
        sin_g, cos_g = np.sin(g), np.cos(g)
        p = np.stack([a - l * cos_g, l * sin_g], axis=-1)
        perp = np.stack([sin_g, cos_g], axis=-1)  # the roller centre's direction of motion
        along = np.stack([cos_g, -sin_g], axis=-1)  # unit vector from B toward A
        p1 = l * ds[:, None] * perp
        p2 = l * d2s[:, None] * perp + l * (ds**2)[:, None] * along
        w = perp
    else:
        e = f.offset
        if f.base_radius <= abs(e):
            raise ValueError(
                f"the base radius {f.base_radius * 1e3:g} mm must exceed the offset "
                f"|e| = {abs(e) * 1e3:g} mm"
            )
        s0 = math.sqrt(f.base_radius**2 - e**2)
        p = np.stack([np.full(n, e), s0 + s], axis=-1)
        z = np.zeros(n)
        p1 = np.stack([z, ds], axis=-1)
        p2 = np.stack([z, d2s], axis=-1)
        w = np.stack([z, np.ones(n)], axis=-1)
    q1 = p1 - sg * _J(p)
    q2 = p2 - 2.0 * sg * _J(p1) - p
    # orientation of the pitch curve seen from the cam (+1 counter-clockwise)
    orient = 1.0 if float(np.sum(_cross(p, q1))) > 0.0 else -1.0
    speed = np.linalg.norm(q1, axis=-1)
    normal = -orient * _J(q1) / speed[:, None]  # outward: from the cam toward the roller
    cr = _cross(q1, q2)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho_p = np.where(cr != 0.0, orient * speed**3 / np.where(cr != 0.0, cr, 1.0), np.inf)
    r = f.roller if f.contact == "roller" else 0.0
    contact = p - r * normal
    cam_ang = -sg * theta
    pitch = _rot(p, cam_ang)
    prof = _rot(contact, cam_ang)
    pressure = _acute(normal, w)
    return Profile(
        theta, s, ds, d2s, d3s, int(sense), f, pitch, prof, p, contact, normal, pressure,
        rho_p, rho_p - r,
    )  # fmt: skip


def _flat(program, f: Follower, sg, theta, s, ds, d2s, d3s) -> Profile:
    n = theta.size
    if f.oscillating:
        a = f.pivot
        g = f.start_angle + s
        sin_g, cos_g = np.sin(g), np.cos(g)
        h = a * sin_g - f.offset
        h1 = a * cos_g * ds
        h2 = a * cos_g * d2s - a * sin_g * ds**2
        m = np.stack([sin_g, cos_g], axis=-1)  # the face's normal, away from the cam
        mu1 = -ds - sg
        mu2 = -d2s
    else:
        h = f.base_radius + s
        h1, h2 = ds, d2s
        m = np.stack([np.zeros(n), np.ones(n)], axis=-1)
        mu1 = np.full(n, -sg)
        mu2 = np.zeros(n)
    valid = bool(np.all(mu1 * -sg > 0.0))  # the face's normal turns one way only
    with np.errstate(divide="ignore", invalid="ignore"):
        contact = h[:, None] * m + (h1 / mu1)[:, None] * _J(m)
        rho = h + (h2 * mu1 - h1 * mu2) / mu1**3
    if f.oscillating:
        w = _J(contact - np.array([f.pivot, 0.0]))
    else:
        w = np.stack([np.zeros(n), np.ones(n)], axis=-1)
    pressure = _acute(m, w)
    prof = _rot(contact, -sg * theta)
    return Profile(
        theta, s, ds, d2s, d3s, int(sg), f, None, prof, contact, contact, m, pressure, None,
        rho, valid,
    )  # fmt: skip


def _acute(n: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The acute angle between the lines of n and w (row vectors), accurate near 0."""
    return np.arctan2(np.abs(_cross(n, w)), np.abs(np.sum(n * w, axis=-1)))


# -- checks on the drawn curve -----------------------------------------------------------
def self_intersections(xy: np.ndarray, limit: int = 20) -> list[tuple[int, int]]:
    """Pairs of segments (i, j) of the closed polygon ``xy`` that cross (at most
    ``limit``). Empty: the curve is simple."""
    pts = np.asarray(xy, dtype=float)
    if np.allclose(pts[0], pts[-1]):
        pts = pts[:-1]
    n = len(pts)
    # a star-shaped curve around O whose polar angle turns one way only is simple
    ang = np.unwrap(np.arctan2(pts[:, 1], pts[:, 0]))
    d = np.diff(ang)
    if (np.all(d > 0) or np.all(d < 0)) and abs(abs(ang[-1] - ang[0]) - 2 * math.pi) < 0.5:
        return []
    a = pts
    b = np.roll(pts, -1, axis=0)
    found: list[tuple[int, int]] = []
    idx = np.arange(n)
    for i0 in range(0, n, 256):
        i = idx[i0 : i0 + 256]
        A, B = a[i][:, None, :], b[i][:, None, :]
        C, D = a[None, :, :], b[None, :, :]
        d1 = _cross(B - A, C - A)
        d2 = _cross(B - A, D - A)
        d3 = _cross(D - C, A - C)
        d4 = _cross(D - C, B - C)
        hit = (d1 * d2 < 0) & (d3 * d4 < 0)
        jj = idx[None, :]
        ii = i[:, None]
        near = (np.abs(ii - jj) <= 1) | (np.abs(ii - jj) >= n - 1)
        hit &= ~near & (jj > ii)
        for r, c in zip(*np.nonzero(hit)):
            found.append((int(i[r]), int(c)))
            if len(found) >= limit:
                return found
    return found


def closed(xy: np.ndarray, theta: np.ndarray) -> bool:
    """Whether the sampled curve closes: its last sample (one step before 360 deg) is
    as near its first as the samples are to each other."""
    step = np.linalg.norm(np.diff(xy, axis=0), axis=-1)
    gap = float(np.linalg.norm(xy[-1] - xy[0]))
    return gap <= 1.5 * float(np.max(step)) + 1e-12
