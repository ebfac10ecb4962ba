"""The integrator's tables of the equation of motion over a turn.

See :mod:`mechsolve.analyses.dynamics`.
"""

from __future__ import annotations

import math

import numpy as np

from mechsolve.analyses.dynamics.constants import SPLINE_FLOOR, TABLE_FLOOR, TABLE_MAX, TABLE_MIN
from mechsolve.base.numerics import limit_from_both_sides


class _Table:
    """Piecewise cubic functions of the angle over [0, 2 pi) on a uniform grid, evaluated
    at one angle in plain Python (the integrator's inner loop: scipy's general evaluation
    costs more than the rest of a step) or at many with numpy.

    ``c`` has the layout of scipy's ``PPoly.c``: (4, intervals, columns), the highest
    power first, in powers of the distance from the interval's start."""

    def __init__(self, c: np.ndarray, step: float) -> None:
        self.c = np.asarray(c, float)
        self.step = step
        self.intervals, self.columns = self.c.shape[1], self.c.shape[2]
        self._rows: list | None = None

    @property
    def rows(self) -> list[list[float]]:
        """A list per interval of its columns' coefficients (unpacked in one step by the
        integrator), and the first interval's again for an angle that rounds to 2 pi."""
        if self._rows is None:
            self._rows = _rows(self.c)
        return self._rows

    @classmethod
    def hermite(cls, f: np.ndarray, df: np.ndarray) -> _Table:
        """The cubic Hermite table through values ``f`` and slopes ``df`` (columns, m) at
        m uniform angles over a turn."""
        step = 2 * math.pi / f.shape[1]
        f1, df1 = np.roll(f, -1, axis=1), np.roll(df, -1, axis=1)
        slope = (f1 - f) / step
        c = np.empty((4, f.shape[1], f.shape[0]))
        c[0] = ((df + df1 - 2.0 * slope) / step**2).T
        c[1] = ((3.0 * slope - 2.0 * df - df1) / step).T
        c[2], c[3] = df.T, f.T
        return cls(c, step)

    @classmethod
    def trigonometric(cls, spectrum: np.ndarray, rtol: float) -> _Table | None:
        """The cubic Hermite table of trigonometric interpolants (their harmonics
        ``spectrum``, see :func:`_harmonics`): values and slopes exact at the table's
        grid, whose step h keeps each column's Hermite error bound h^4 / 384 max|f^(4)|
        (the fourth derivative bounded by the sum of k^4 times the harmonics' sizes)
        within half its tolerance (:func:`_tolerances`). None if that needs more than
        ``TABLE_MAX`` intervals."""
        k = np.arange(spectrum.shape[1], dtype=float)
        size = 2.0 * np.abs(spectrum).sum(axis=1)  # bounds each column's largest size
        tol = _tolerances(size, rtol)
        d4 = 2.0 * (np.abs(spectrum) @ k**4)
        with np.errstate(divide="ignore"):
            h = float(np.min((192.0 * tol / d4) ** 0.25))
        m = max(math.ceil(2 * math.pi / h), TABLE_MIN) if h > 0 else TABLE_MIN
        m += -m % 24  # a size the FFT factors well
        if m > TABLE_MAX:
            return None
        return cls.hermite(*_on_grid(spectrum, m))

    @classmethod
    def spline(cls, samples: np.ndarray, rtol: float) -> _Table | None:
        """Periodic cubic splines through ``samples`` (columns, n) at n uniform angles,
        where the trigonometric interpolant did not converge; None unless each column
        is good to 1000 times its tolerance or to ``SPLINE_FLOOR`` of the largest
        column (samples next to a singular position carry the force analysis's
        rounding, amplified there: a parallelogram's J' is zero but for about 1e-7).
        Their error is estimated as that of the splines through every other sample at
        the samples between, divided by 16 (the error of a cubic spline falls as h^4)."""
        from scipy.interpolate import CubicSpline

        def through(V):
            n = V.shape[1]
            x = 2 * math.pi * np.arange(n + 1) / n
            return CubicSpline(x, np.c_[V, V[:, :1]].T, bc_type="periodic")

        n = samples.shape[1]
        half = through(samples[:, 0::2])
        between = half(2 * math.pi * (np.arange(0, n, 2) + 1) / n).T
        err = np.max(np.abs(between - samples[:, 1::2]), axis=1) / 16
        size = np.max(np.abs(samples), axis=1)
        if not np.all(err <= np.maximum(1000 * _tolerances(size, rtol), SPLINE_FLOOR * size.max())):
            return None
        return cls(through(samples).c, 2 * math.pi / n)

    def __call__(self, x: float) -> list[float]:
        i = int(x / self.step)
        h = x - i * self.step
        c = self.rows[i]
        return [
            ((c[j] * h + c[j + 1]) * h + c[j + 2]) * h + c[j + 3]
            for j in range(0, 4 * self.columns, 4)
        ]

    def evaluate(self, x) -> np.ndarray:
        """Every column at the angles ``x`` (in [0, 2 pi]): (columns, len(x))."""
        x = np.asarray(x, float)
        i = np.clip((x / self.step).astype(int), 0, self.intervals - 1)
        h = (x - i * self.step)[:, None]
        c = self.c[:, i]  # (4, len(x), columns)
        return (((c[0] * h + c[1]) * h + c[2]) * h + c[3]).T

    def minima(self, col: int) -> np.ndarray:
        """Candidate angles of the smallest value of column ``col``: the grid and the
        zeros of each piece's slope inside its interval."""
        a, b, c = 3 * self.c[0, :, col], 2 * self.c[1, :, col], self.c[2, :, col]
        disc = b * b - 4 * a * c
        with np.errstate(divide="ignore", invalid="ignore"):
            sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
            roots = np.concatenate([(-b + sq) / (2 * a), (-b - sq) / (2 * a), -c / b])
        start = np.tile(np.arange(self.intervals) * self.step, 3)
        inside = np.isfinite(roots) & (roots > 0) & (roots < self.step)
        return np.r_[np.arange(self.intervals) * self.step, start[inside] + roots[inside]]


def _harmonics(samples: np.ndarray) -> np.ndarray:
    """The harmonics F_k (k = 0 .. n/2 - 1) of the trigonometric interpolants of
    ``samples`` (rows, n) at ``x = 2 pi j / n``: f(x) = Re sum_k F_k (2 - [k = 0]) e^(ikx),
    the Nyquist term left out (below the tolerance once the samples converged)."""
    n = samples.shape[1]
    return (np.fft.rfft(samples, axis=1) / n)[:, : (n + 1) // 2]


def _on_grid(spectrum: np.ndarray, m: int, shift: float = 0.0):
    """Values and slopes of the interpolants with harmonics ``spectrum`` at the m
    uniform angles ``2 pi (j + shift) / m``: two arrays (rows, m)."""
    kk = min(spectrum.shape[1], m // 2)
    pad = np.zeros((spectrum.shape[0], m // 2 + 1), complex)
    k = np.arange(kk)
    pad[:, :kk] = spectrum[:, :kk] * (np.exp(2j * math.pi * shift * k / m) if shift else 1.0)
    f = np.fft.irfft(pad, m, axis=1) * m
    pad[:, :kk] *= 1j * k
    return f, np.fft.irfft(pad, m, axis=1) * m


def _rows(c: np.ndarray) -> list[list[float]]:
    """Coefficients ``c`` (4, intervals, columns) as a list per interval of its
    columns' four coefficients, highest power first (unpacked in one step by the
    integrator), and the first interval's again for an angle that rounds to 2 pi."""
    rows = c.transpose(1, 2, 0).reshape(c.shape[1], -1).tolist()
    rows.append(rows[0])
    return rows


class _NoTable(Exception):
    """The equation of motion cannot be tabulated over the angle."""


def _limit(f, x: np.ndarray, rows: int, h: float = 1e-3) -> np.ndarray:
    """The values at singular angles ``x`` of functions smooth through them, from
    ``f`` (rows, len) at ``x -+ h`` and ``x -+ 2 h``: Richardson's extrapolation of the
    two sides' means, O(h^4) (:func:`~mechsolve.base.numerics.limit_from_both_sides`). Next
    to a singular position the force analysis loses accuracy as 1 / distance^2: at 1e-5
    its accelerations carry errors of 1e-6; at h = 1e-3, about 1e-10."""
    E = f(np.r_[x - h, x + h, x - 2 * h, x + 2 * h])
    if not np.all(np.isfinite(E)):
        raise _NoTable
    return limit_from_both_sides(*E.reshape(rows, 4, len(x)).transpose(1, 0, 2))


def _tolerances(size: np.ndarray, rtol: float) -> np.ndarray:
    """Each row's absolute tolerance from its largest size: ``rtol`` of it, and not below
    ``TABLE_FLOOR`` of the largest row's (a row that is zero but for rounding, such as
    the damping column of a machine without dampers, meets it at once)."""
    return rtol * size + TABLE_FLOOR * float(np.max(size))


def _spectral_samples(sample, V: np.ndarray, rtol: float, nmax: int = 5760):
    """Samples of smooth periodic functions over a turn at uniform grids that double
    until, for every function, the trigonometric interpolant of every other sample
    predicts the samples between them to its tolerance (:func:`_tolerances`).

    ``V`` holds the functions (rows) at ``x = 2 pi k / n`` (n even), and ``sample(x)``
    returns them at other angles. Returns the samples at the last grid and whether they
    converged (then their own interpolant, on twice the grid that met the test, is far
    more accurate still); at ``nmax`` samples they are returned unconverged."""
    while True:
        n = V.shape[1] // 2
        F = np.fft.rfft(V[:, 0::2], axis=1)
        shifted = F * np.exp(1j * np.arange(F.shape[1]) * math.pi / n)
        if n % 2 == 0:
            shifted[:, -1] = 0.0  # the Nyquist term vanishes at the midpoints
        err = np.max(np.abs(np.fft.irfft(shifted, n, axis=1) - V[:, 1::2]), axis=1)
        if not np.all(np.isfinite(err)):
            raise _NoTable
        if np.all(err <= _tolerances(np.max(np.abs(V), axis=1), rtol)):
            return V, True
        if 2 * n >= nmax:
            return V, False
        Vm = sample(2 * math.pi * (np.arange(2 * n) + 0.5) / (2 * n))
        both = np.empty((V.shape[0], 4 * n))
        both[:, 0::2], both[:, 1::2] = V, Vm
        V = both
