"""Driver motions of time: the driver coordinate u(t) with its exact rates u'(t), u''(t).

A constant speed is the driver's ``speed`` (no motion law). The laws here are what
machine designers and textbooks specify instead:

* :class:`ConstantAcceleration`: ``u = u0 + w0 t + a t^2 / 2`` (a crank started with a
  given speed and angular acceleration).
* :class:`Segments`: accelerate, run, decelerate, dwell, each for a duration, with a
  constant acceleration in each segment: continuous in position and speed; the
  acceleration jumps at the joins (:meth:`Segments.jumps`).
* :class:`TableMotion`: points (t, u) through a cubic interpolating spline (scipy's
  ``CubicSpline``), whose end conditions are ``not-a-knot`` (default), ``natural`` (zero
  second derivative at both ends) or ``clamped`` (zero first derivative: at rest at both
  ends); rates are the spline's own derivatives.
* :class:`ExpressionMotion`: ``u(t)`` written in the expression language; its rates are
  the expression's symbolic derivatives, not finite differences.

Every law returns SI values: rad (rad/s, rad/s^2) for a revolute driver, m for a slider.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


class MotionLaw:
    """The contract: :meth:`at` gives ``(u, u', u'')`` at times ``t`` (s, arrays);
    ``duration`` is the law's natural length (None: open-ended); ``start`` is u(0)."""

    duration: float | None = None
    start: float = 0.0

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError

    def direction(self) -> int:
        """+1 if the coordinate first moves up (or ends higher), -1 otherwise."""
        end = self.duration if self.duration else 1.0
        t = np.linspace(0.0, end, 257)
        u, ud, _ = self.at(t)
        moving = np.flatnonzero(np.abs(ud) > 0)
        if moving.size:
            return 1 if ud[moving[0]] > 0 else -1
        return 1 if u[-1] >= u[0] else -1

    def nominal_speed(self) -> float:
        """A typical speed (the largest over the natural duration, or over 1 s): sizes of
        rates for messages and tolerances; its sign is the direction."""
        end = self.duration if self.duration else 1.0
        _, ud, _ = self.at(np.linspace(0.0, end, 257))
        v = float(np.max(np.abs(ud))) if ud.size else 0.0
        return self.direction() * (v if v > 0 else 1.0)


@dataclass
class ConstantAcceleration(MotionLaw):
    start: float = 0.0
    speed0: float = 0.0  # signed, rad/s or m/s
    acceleration: float = 0.0  # signed

    def at(self, t):
        t = np.asarray(t, float)
        a, w0 = self.acceleration, self.speed0
        return (
            self.start + w0 * t + 0.5 * a * t * t,
            w0 + a * t,
            np.full(t.shape, a),
        )

    def time_at(self, travel: np.ndarray) -> np.ndarray:
        """The time at which the coordinate has moved ``travel`` (>= 0) in the direction
        of motion, for a motion that keeps that direction (NaN where never reached)."""
        d = self.direction()
        w0, a = d * self.speed0, d * self.acceleration  # along the motion
        s = np.asarray(travel, float)
        if a == 0:
            return s / w0 if w0 > 0 else np.full(s.shape, np.nan)
        disc = w0 * w0 + 2 * a * s
        with np.errstate(invalid="ignore", divide="ignore"):
            # the smaller positive root; stable form (no cancellation when a is small)
            t = np.where(disc >= 0, 2 * s / (w0 + np.sqrt(np.maximum(disc, 0))), np.nan)
        return np.where(s == 0, 0.0, t)


@dataclass
class Piece:
    """One segment: from time ``t0`` for ``length`` s at constant ``acc``, starting at
    coordinate ``u0`` with speed ``v0``."""

    kind: str
    t0: float
    length: float
    u0: float
    v0: float
    acc: float


@dataclass
class Segments(MotionLaw):
    start: float = 0.0
    pieces: list[Piece] = field(default_factory=list)
    duration: float | None = None

    @classmethod
    def build(cls, start: float, speed0: float, spec: list[tuple[str, float, float | None]]):
        """``spec``: (kind, duration, target speed or None) with kind ``accelerate``,
        ``run``, ``decelerate`` or ``dwell``; speeds are signed. ``decelerate`` ends at
        rest unless a target is given; ``dwell`` needs the driver at rest."""
        pieces = []
        t, u, v = 0.0, start, speed0
        for kind, length, target in spec:
            if kind == "run":
                acc = 0.0
            elif kind == "dwell":
                if v != 0:
                    raise ValueError(
                        f"a dwell needs the driver at rest; it moves at {v:.6g} here "
                        "(decelerate first)"
                    )
                acc = 0.0
            else:
                goal = 0.0 if (kind == "decelerate" and target is None) else target
                if goal is None:
                    raise ValueError(f"'{kind}' needs 'to': the speed to reach")
                acc = (goal - v) / length
            pieces.append(Piece(kind, t, length, u, v, acc))
            u += v * length + 0.5 * acc * length * length
            v += acc * length
            t += length
        return cls(start=start, pieces=pieces, duration=t)

    def at(self, t):
        t = np.asarray(t, float)
        starts = np.array([p.t0 for p in self.pieces])
        k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.pieces) - 1)
        t0 = starts[k]
        u0 = np.array([p.u0 for p in self.pieces])[k]
        v0 = np.array([p.v0 for p in self.pieces])[k]
        a = np.array([p.acc for p in self.pieces])[k]
        tau = t - t0
        return u0 + v0 * tau + 0.5 * a * tau * tau, v0 + a * tau, a

    def jumps(self) -> list[tuple[float, float, float]]:
        """(time, acceleration before, after) at each join where the acceleration jumps."""
        out = []
        for p, q in zip(self.pieces, self.pieces[1:]):
            if p.acc != q.acc:
                out.append((q.t0, p.acc, q.acc))
        return out


@dataclass
class TableMotion(MotionLaw):
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    values: np.ndarray = field(default_factory=lambda: np.zeros(0))
    end: str = "not-a-knot"

    def __post_init__(self) -> None:
        from scipy.interpolate import CubicSpline  # only files with a table pay for it

        self.times = np.asarray(self.times, float)
        self.values = np.asarray(self.values, float)
        self.start = float(self.values[0])
        self.duration = float(self.times[-1] - self.times[0])
        self._t0 = float(self.times[0])
        self._spline = CubicSpline(self.times - self._t0, self.values, bc_type=self.end)

    def at(self, t):
        t = np.asarray(t, float)
        s = self._spline
        return s(t), s(t, 1), s(t, 2)


@dataclass
class ExpressionMotion(MotionLaw):
    """``u(t)`` from an expression of ``t``; ``first``, ``second``: its symbolic
    derivatives (expressions of ``t`` too)."""

    expr: object = None
    first: object = None
    second: object = None
    span: float | None = None

    def __post_init__(self) -> None:
        self.duration = self.span
        self.start = float(self.at(np.zeros(1))[0][0])

    def at(self, t):
        t = np.asarray(t, float)
        vals = []
        for e in (self.expr, self.first, self.second):
            v = np.asarray(e.evaluate_at({"t": t}), float)
            vals.append(np.broadcast_to(v, t.shape).astype(float))
        return tuple(vals)


def check_finite(law: MotionLaw, t: np.ndarray) -> int | None:
    """The index of the first time where the law is not finite, or None."""
    u, ud, udd = law.at(t)
    bad = ~(np.isfinite(u) & np.isfinite(ud) & np.isfinite(udd))
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


def describe(law: MotionLaw) -> str:
    """A few words for summaries."""
    if isinstance(law, ConstantAcceleration):
        return f"constant acceleration {law.acceleration:.6g} from speed {law.speed0:.6g}"
    if isinstance(law, Segments):
        return "segments: " + ", ".join(f"{p.kind} {p.length:.6g} s" for p in law.pieces)
    if isinstance(law, TableMotion):
        return f"table of {len(law.times)} points (cubic spline, {law.end} ends)"
    if isinstance(law, ExpressionMotion):
        return f"u(t) = {law.expr.text}"
    return "motion law"


__all__ = [
    "MotionLaw",
    "ConstantAcceleration",
    "Segments",
    "Piece",
    "TableMotion",
    "ExpressionMotion",
    "check_finite",
    "describe",
]
