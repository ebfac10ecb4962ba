"""The follower's motion program over one turn of the cam: rise, dwell and return
segments, each with its law; displacement and its derivatives with respect to the cam
angle, and the continuity of the motion at every join.

Displacement is a length (m) for a translating follower and a swing angle (rad) for an
oscillating one; derivatives are with respect to the cam angle theta (rad) and become
time derivatives by omega, omega^2, omega^3 (constant cam speed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mechsolve.base.cam.laws import Law

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class Segment:
    """One segment of the program.

    Attributes
    ----------
    kind
        ``"rise"``, ``"return"`` or ``"dwell"``.
    start
        Cam angle where it starts (rad).
    angle
        Cam angle it lasts (rad).
    s0
        Displacement at its start.
    lift
        Change of displacement over it (positive on a rise, negative on a return).
    law
        Its motion law (None for a dwell).
    """

    kind: str
    start: float
    angle: float
    s0: float
    lift: float
    law: Law | None

    @property
    def end(self) -> float:
        return self.start + self.angle

    def eval(self, theta: np.ndarray):
        """s, s', s'', s''' at cam angles ``theta`` inside the segment."""
        if self.law is None or self.lift == 0.0:
            z = np.zeros_like(theta)
            return self.s0 + z, z, z.copy(), z.copy()
        u = (theta - self.start) / self.angle
        f, f1, f2, f3 = self.law(u)
        h, b = self.lift, self.angle
        return self.s0 + h * f, h * f1 / b, h * f2 / b**2, h * f3 / b**3

    def ends(self):
        """(s', s'') at the start and at the end of the segment."""
        a = self.eval(np.array([self.start, self.end]))
        return (a[1][0], a[2][0]), (a[1][1], a[2][1])


@dataclass(frozen=True)
class Remark:
    """A discontinuity of the motion: where, and what it means."""

    angle: float  # cam angle (rad)
    what: str  # "velocity" or "acceleration"
    jump: float  # of ds/dtheta or d2s/dtheta2
    text: str


class Program:
    """A closed motion program: segments covering 0...360 deg of cam angle."""

    def __init__(self, segments: list[Segment], angular: bool) -> None:
        self.segments = segments
        self.angular = angular  # True: an oscillating follower's swing (rad)
        self.stroke = max(max(g.s0, g.s0 + g.lift) for g in segments)
        self._starts = np.array([g.start for g in segments])

    def eval(self, theta) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """s, ds/dtheta, d2s/dtheta2, d3s/dtheta3 at cam angles ``theta`` (rad, any
        value: taken modulo one turn)."""
        th = np.mod(np.asarray(theta, dtype=float), TWO_PI)
        out = [np.zeros_like(th) for _ in range(4)]
        idx = np.searchsorted(self._starts, th, side="right") - 1
        idx = np.clip(idx, 0, len(self.segments) - 1)
        for i, g in enumerate(self.segments):
            m = idx == i
            if np.any(m):
                vals = g.eval(th[m])
                for o, v in zip(out, vals):
                    o[m] = v
        return out[0], out[1], out[2], out[3]

    def segment_at(self, theta: float) -> Segment:
        th = float(np.mod(theta, TWO_PI))
        i = int(np.clip(np.searchsorted(self._starts, th, side="right") - 1, 0, None))
        return self.segments[i]

    def remarks(self, tol: float = 1e-9) -> list[Remark]:
        """Jumps of velocity (infinite acceleration: rigid impact) and of acceleration
        (infinite jerk: soft impact) at the joins and inside the laws."""
        out: list[Remark] = []
        n = len(self.segments)
        scale_v = max(abs(g.lift) / g.angle for g in self.segments if g.angle > 0) or 1.0
        for i in range(n):
            a, b = self.segments[i], self.segments[(i + 1) % n]
            (_, _), (v1, a1) = a.ends()
            (v2, a2), (_, _) = b.ends()
            where = b.start
            if abs(v2 - v1) > tol * scale_v:
                out.append(
                    Remark(
                        where,
                        "velocity",
                        v2 - v1,
                        "velocity jumps: infinite acceleration, rigid impact",
                    )
                )
            elif abs(a2 - a1) > tol * scale_v:
                out.append(
                    Remark(
                        where,
                        "acceleration",
                        a2 - a1,
                        "acceleration jumps: infinite jerk, soft impact",
                    )
                )
        for g in self.segments:
            if g.law is None or g.lift == 0.0:
                continue
            for u, what in g.law.inner:
                th = g.start + u * g.angle
                eps = 1e-9
                lo = g.eval(np.array([th - eps * g.angle]))
                hi = g.eval(np.array([th + eps * g.angle]))
                k = 2 if what == "acceleration" else 1
                out.append(
                    Remark(
                        th,
                        what,
                        float(hi[k][0] - lo[k][0]),
                        f"{what} jumps inside the {g.law.title} {g.kind}: "
                        + ("infinite jerk, soft impact" if k == 2 else "rigid impact"),
                    )
                )
        out.sort(key=lambda r: r.angle)
        return out


def build_program(
    items: list[tuple[str, float, float | None, Law | None]], angular: bool
) -> Program:
    """Segments from (kind, cam angle, lift or None, law) in order from cam angle 0.

    A return without a lift goes back to the start (displacement 0). Raises ValueError
    with a plain message (the caller names the key) when the program does not close.
    """
    segs: list[Segment] = []
    start, s = 0.0, 0.0
    for kind, angle, lift, law in items:
        if kind == "dwell":
            d = 0.0
        elif kind == "rise":
            d = float(lift)  # type: ignore[arg-type]
        else:
            d = -(s if lift is None else float(lift))
        segs.append(Segment(kind, start, angle, s, d, law if kind != "dwell" else None))
        start += angle
        s += d
    return Program(segs, angular)
