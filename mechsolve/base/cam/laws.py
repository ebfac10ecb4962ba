"""Follower motion laws for a rise of 1 over a cam angle of 1 (u = 0...1), analytic.

Each law returns the normalised displacement f(u) and its derivatives f', f'', f''' with
respect to u. A segment of lift h over a cam angle beta has s = h f(u),
ds/dtheta = h f'/beta, d2s/dtheta2 = h f''/beta^2, d3s/dtheta3 = h f'''/beta^3; a return
is s = h (1 - f(u)). Jumps of f' or f'' inside a law (the parabolic law's acceleration at
u = 1/2) and at its ends are listed in :data:`INNER_JUMPS` and found at segment joins by
:mod:`mechsolve.base.cam.program`.

The modified trapezoid and modified sine are built from their acceleration pulses
(quarter and half sine waves joined to constants, Norton, *Design of Machinery*, ch. 8):
the displacement and velocity are the exact integrals of each piece, the pulse height is
fixed by f(1) = 1.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

Arrays = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _uniform(u: np.ndarray) -> Arrays:
    one = np.ones_like(u)
    return u.copy(), one, 0.0 * u, 0.0 * u


def _parabolic(u: np.ndarray) -> Arrays:
    first = u < 0.5
    w = 1.0 - u
    f = np.where(first, 2.0 * u**2, 1.0 - 2.0 * w**2)
    f1 = np.where(first, 4.0 * u, 4.0 * w)
    f2 = np.where(first, 4.0, -4.0)
    return f, f1, f2, 0.0 * u


def _harmonic(u: np.ndarray) -> Arrays:
    p = math.pi
    return (
        (1.0 - np.cos(p * u)) / 2.0,
        p / 2.0 * np.sin(p * u),
        p**2 / 2.0 * np.cos(p * u),
        -(p**3) / 2.0 * np.sin(p * u),
    )


def _cycloidal(u: np.ndarray) -> Arrays:
    t = 2.0 * math.pi
    return (
        u - np.sin(t * u) / t,
        1.0 - np.cos(t * u),
        t * np.sin(t * u),
        t**2 * np.cos(t * u),
    )


def _poly(coef: dict[int, float]) -> Callable[[np.ndarray], Arrays]:
    def law(u: np.ndarray) -> Arrays:
        out = [np.zeros_like(u) for _ in range(4)]
        for n, c in coef.items():
            for d in range(4):
                if n - d >= 0:
                    k = math.factorial(n) / math.factorial(n - d)
                    out[d] = out[d] + c * k * u ** (n - d)
        return out[0], out[1], out[2], out[3]

    return law


@dataclass(frozen=True)
class _Piece:
    """Acceleration c0 + c1 sin(k t) + c2 cos(k t) for u0 <= u <= u1, t = u - u0."""

    u0: float
    u1: float
    c0: float
    c1: float
    c2: float
    k: float


def _pulse_law(pieces: list[_Piece]) -> Callable[[np.ndarray], Arrays]:
    """A law from its acceleration pieces (unit height), integrated exactly, scaled so
    that f(1) = 1."""
    # displacement and velocity at each piece's start, integrating the unit pulse
    starts = []
    s, v = 0.0, 0.0
    for p in pieces:
        starts.append((s, v))
        s, v = _integrate(p, p.u1 - p.u0, s, v)
    height = 1.0 / s

    def law(u: np.ndarray) -> Arrays:
        f = np.zeros_like(u)
        f1 = np.zeros_like(u)
        f2 = np.zeros_like(u)
        f3 = np.zeros_like(u)
        for i, (p, (s0, v0)) in enumerate(zip(pieces, starts)):
            last = i == len(pieces) - 1
            m = (u >= p.u0) & ((u <= p.u1) if last else (u < p.u1))
            t = u[m] - p.u0
            sv, vv = _integrate(p, t, s0, v0)
            f[m] = sv
            f1[m] = vv
            f2[m] = p.c0 + p.c1 * np.sin(p.k * t) + p.c2 * np.cos(p.k * t)
            f3[m] = p.k * (p.c1 * np.cos(p.k * t) - p.c2 * np.sin(p.k * t))
        return f * height, f1 * height, f2 * height, f3 * height

    return law


def _integrate(p: _Piece, t, s0: float, v0: float):
    """Velocity and displacement after t of a piece (exact integrals)."""
    k = p.k
    v = v0 + p.c0 * t + p.c1 * (1.0 - np.cos(k * t)) / k + p.c2 * np.sin(k * t) / k
    s = (
        s0
        + v0 * t
        + p.c0 * t**2 / 2.0
        + p.c1 * (t / k - np.sin(k * t) / k**2)
        + p.c2 * (1.0 - np.cos(k * t)) / k**2
    )
    return s, v


_Q = 4.0 * math.pi  # a quarter sine wave over 1/8 of the rise
_MOD_TRAPEZOID = [
    _Piece(0.0, 0.125, 0.0, 1.0, 0.0, _Q),
    _Piece(0.125, 0.375, 1.0, 0.0, 0.0, 1.0),
    _Piece(0.375, 0.625, 0.0, 0.0, 1.0, _Q),
    _Piece(0.625, 0.875, -1.0, 0.0, 0.0, 1.0),
    _Piece(0.875, 1.0, 0.0, 0.0, -1.0, _Q),
]
_MOD_SINE = [
    _Piece(0.0, 0.125, 0.0, 1.0, 0.0, _Q),
    _Piece(0.125, 0.875, 0.0, 0.0, 1.0, _Q / 3.0),
    _Piece(0.875, 1.0, 0.0, 0.0, -1.0, _Q),
]


@dataclass(frozen=True)
class Law:
    """A motion law: its name as printed, the function of u, and what it does at joins."""

    key: str
    title: str
    func: Callable[[np.ndarray], Arrays]
    # (u, what jumps) inside the law itself
    inner: tuple[tuple[float, str], ...] = ()

    def __call__(self, u) -> Arrays:
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        return self.func(u)


LAWS: dict[str, Law] = {
    law.key: law
    for law in [
        Law("uniform-velocity", "uniform velocity", _uniform),
        Law(
            "parabolic",
            "constant acceleration/deceleration (parabolic)",
            _parabolic,
            ((0.5, "acceleration"),),
        ),
        Law("simple-harmonic", "simple harmonic", _harmonic),
        Law("cycloidal", "cycloidal", _cycloidal),
        Law("polynomial-345", "3-4-5 polynomial", _poly({3: 10.0, 4: -15.0, 5: 6.0})),
        Law(
            "polynomial-4567",
            "4-5-6-7 polynomial",
            _poly({4: 35.0, 5: -84.0, 6: 70.0, 7: -20.0}),
        ),
        Law("modified-trapezoid", "modified trapezoid", _pulse_law(_MOD_TRAPEZOID)),
        Law("modified-sine", "modified sine", _pulse_law(_MOD_SINE)),
    ]
}

# the names an engineer may write for each law (compared without case, spaces, '-', '_')
ALIASES: dict[str, str] = {
    "uniformvelocity": "uniform-velocity",
    "constantvelocity": "uniform-velocity",
    "linear": "uniform-velocity",
    "parabolic": "parabolic",
    "constantacceleration": "parabolic",
    "constantaccelerationdeceleration": "parabolic",
    "equalacceleration": "parabolic",
    "equalaccelerationdeceleration": "parabolic",
    "equalaccelerationequaldeceleration": "parabolic",
    "simpleharmonic": "simple-harmonic",
    "harmonic": "simple-harmonic",
    "cosine": "simple-harmonic",
    "cycloidal": "cycloidal",
    "sine": "cycloidal",
    "345": "polynomial-345",
    "polynomial345": "polynomial-345",
    "4567": "polynomial-4567",
    "polynomial4567": "polynomial-4567",
    "modifiedtrapezoid": "modified-trapezoid",
    "modifiedtrapezoidal": "modified-trapezoid",
    "modifiedsine": "modified-sine",
}

NAMES_HELP = (
    "uniform velocity, parabolic (constant acceleration), simple harmonic, cycloidal, "
    "3-4-5, 4-5-6-7, modified trapezoid, modified sine"
)


def find_law(name: str) -> Law | None:
    """The law an engineer's name means (``"equal acceleration"``, ``"3-4-5"``), or None."""
    key = "".join(ch for ch in str(name).lower() if ch not in " -_/")
    if key not in ALIASES:
        key = key.replace("polynomial", "")
    return LAWS.get(ALIASES.get(key, ""))
