"""Function generation: a four-bar whose output angle follows psi = f(phi) over a range.

The four-bar O2-A-B-O4 has its frame O2 -> O4 (length d) along +x; the input angle phi
is the crank O2A's, the output angle psi the rocker O4B's, both measured from the frame
line, counter-clockwise. The function y = f(x), x in [x_s, x_f], is mapped linearly onto
phi = phi_s + (x - x_s) / (x_f - x_s) * dphi and psi = psi_s + (y - y_s) / (y_f - y_s) *
dpsi.

Freudenstein's equation (Freudenstein 1955, Trans. ASME 77, 853-861), from the loop
a e^{i phi} + b e^{i theta} = d + c e^{i psi} squared to eliminate the coupler angle::

    K1 cos psi - K2 cos phi + K3 = cos(phi - psi),
    K1 = d / a,  K2 = d / c,  K3 = (a^2 - b^2 + c^2 + d^2) / (2 a c),

is linear in K: three precision points give K exactly, more give it by least squares.
A negative a or c is a link pointing the other way (the written file puts A or B at a
negative x in the link's frame). Precision points are Chebyshev-spaced by default,
x_j = (x_s + x_f)/2 - (x_f - x_s)/2 cos((2j - 1) pi / (2n)).

Then differential evolution (:mod:`.optimise`) minimises the structural error over the
whole range, max |psi_generated - psi_desired| on ``samples`` positions, each generation
one batch of the closed form (:mod:`.fourbar_batch`), under exact constraints: the dyad
closes and keeps its branch over the whole range, and the transmission angle stays above
the minimum asked. A Nelder-Mead polish follows (it only accepts feasible designs).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from mechsolve.analyses.synth.common import Design, grashof_type
from mechsolve.analyses.synth.fourbar_batch import dyad_point, l2_range, transmission_margin
from mechsolve.analyses.synth.optimise import Search, distinct, search
from mechsolve.base.errors import InputError

__all__ = ["FunctionSpec", "chebyshev", "freudenstein", "solve_function", "function_yaml", "verify"]


@dataclass
class FunctionSpec:
    """A function-generation problem (angles in rad, lengths in m).

    ``f`` maps an array of x to y; ``at`` the precision points' x (None: Chebyshev
    spacing of ``points`` of them); ``bounds`` the optimiser's bounds by variable name
    (crank, coupler, rocker, input_start, output_start), None for a default."""

    f: Callable[[np.ndarray], np.ndarray]
    x_range: tuple[float, float]
    phi_start: float
    phi_range: float
    psi_start: float
    psi_range: float
    frame: float
    points: int = 3
    at: list[float] | None = None
    optimise: bool = True
    samples: int = 101
    max_iter: int = 300
    popsize: int = 30
    min_transmission: float = 0.0
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    top: int = 5
    description: str = "y = f(x)"


def chebyshev(lo: float, hi: float, n: int) -> np.ndarray:
    """Chebyshev spacing of n precision points in [lo, hi]."""
    j = np.arange(1, n + 1)
    return (lo + hi) / 2 - (hi - lo) / 2 * np.cos((2 * j - 1) * np.pi / (2 * n))


def freudenstein(phi, psi, frame: float) -> tuple[float, float, float, np.ndarray]:
    """Signed crank a, coupler b, rocker c from Freudenstein's equation through the
    (phi, psi) pairs (exact for three, least squares for more) and the residuals of the
    equation at the pairs."""
    phi, psi = np.asarray(phi, float), np.asarray(psi, float)
    m = np.column_stack([np.cos(psi), -np.cos(phi), np.ones_like(phi)])
    rhs = np.cos(phi - psi)
    if len(phi) == 3:
        if abs(np.linalg.det(m)) < 1e-12:
            raise InputError(
                "the precision points make Freudenstein's equations singular (two "
                "points give the same input or output angle): choose other points"
            )
        k = np.linalg.solve(m, rhs)
    else:
        k = np.linalg.lstsq(m, rhs, rcond=None)[0]
    k1, k2, k3 = k
    if abs(k1) < 1e-12 or abs(k2) < 1e-12:
        raise InputError(
            "Freudenstein's solution has an infinite crank or rocker (K1 or K2 = 0): "
            "choose other angle ranges or precision points"
        )
    d = frame
    a, c = d / k1, d / k2
    b2 = a * a + c * c + d * d - 2 * a * c * k3
    if b2 <= 0:
        raise InputError(
            f"Freudenstein's solution has no real coupler (b^2 = {b2 / d**2:.6g} d^2): "
            "choose other angle ranges or precision points"
        )
    return float(a), math.sqrt(b2), float(c), m @ k - rhs


class _Problem:
    """The maps of a spec: t in [0, 1] along the range -> phi, psi desired."""

    def __init__(self, spec: FunctionSpec) -> None:
        self.spec = spec
        xs, xf = spec.x_range
        self.t = np.linspace(0.0, 1.0, spec.samples)
        y = self._f(np.array([xs, xf]))
        self.ys, self.yf = float(y[0]), float(y[1])
        if not (math.isfinite(self.ys) and math.isfinite(self.yf)) or self.ys == self.yf:
            raise InputError(
                f"f(x_s) = {self.ys:g} and f(x_f) = {self.yf:g}: the function must take two "
                "different finite values at the ends of the range"
            )
        self.g = self.unit(xs + self.t * (xf - xs))

    def _f(self, x: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):
            y = np.asarray(self.spec.f(np.asarray(x, float)), float)
        return np.broadcast_to(y, np.shape(x)).astype(float)

    def unit(self, x) -> np.ndarray:
        y = self._f(np.asarray(x, float))
        if not np.all(np.isfinite(y)):
            raise InputError("the function is not finite over the whole range of x")
        return (y - self.ys) / (self.yf - self.ys)

    def angles(self, x, phi_s=None, psi_s=None):
        s = self.spec
        xs, xf = s.x_range
        phi_s = s.phi_start if phi_s is None else phi_s
        psi_s = s.psi_start if psi_s is None else psi_s
        x = np.asarray(x, float)
        return phi_s + (x - xs) / (xf - xs) * s.phi_range, psi_s + self.unit(x) * s.psi_range


def _psi(a, b, c, d, phi, sigma):
    """Output angle of the rocker's x axis (rad) for signed a and c."""
    ax, ay = a * np.cos(phi), a * np.sin(phi)
    bx, by, _ = dyad_point(ax, ay, d, 0.0, b, np.abs(c), sigma)
    return np.arctan2(by, bx - d) - np.where(c < 0, np.pi, 0.0)


def _wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


class _Batch:
    """Objective and constraints over columns of designs (a, b, c[, phi_s][, psi_s])."""

    def __init__(self, prob: _Problem, names: list[str]) -> None:
        self.prob = prob
        self.names = names

    def unpack(self, X: np.ndarray):
        s = self.prob.spec
        X = np.atleast_2d(np.asarray(X, float).T).T if np.ndim(X) == 1 else np.asarray(X)
        cols = {n: X[i] for i, n in enumerate(self.names)}
        phi_s = cols.get("input_start", np.full(X.shape[1], s.phi_start))
        psi_s = cols.get("output_start", np.full(X.shape[1], s.psi_start))
        return cols["crank"], cols["coupler"], cols["rocker"], phi_s, psi_s

    def errors(self, X: np.ndarray):
        """(max |error| per design for sigma = +1 and -1), each (S,)."""
        s = self.prob.spec
        a, b, c, phi_s, psi_s = self.unpack(X)
        t, g = self.prob.t[None, :], self.prob.g[None, :]
        phi = phi_s[:, None] + t * s.phi_range
        psi_want = psi_s[:, None] + g * s.psi_range
        out = []
        for sigma in (1.0, -1.0):
            e = _wrap(_psi(a[:, None], b[:, None], c[:, None], s.frame, phi, sigma) - psi_want)
            with np.errstate(invalid="ignore"):
                m = np.max(np.abs(e), axis=1)
            out.append(np.where(np.isfinite(m), m, np.pi))
        return out

    def objective(self, X: np.ndarray) -> np.ndarray:
        ep, em = self.errors(X)
        return np.minimum(ep, em)

    def constraints(self, X: np.ndarray) -> np.ndarray:
        s = self.prob.spec
        a, b, c, phi_s, _ = self.unpack(X)
        shift = np.where(a < 0, np.pi, 0.0)
        m = transmission_margin(
            np.abs(a), b, np.abs(c), s.frame, phi_s + shift, phi_s + shift + s.phi_range,
            s.min_transmission,
        )  # fmt: skip
        return m[None, :]


def _min_transmission(a, b, c, d, phi0, phi1) -> float:
    shift = math.pi if a < 0 else 0.0
    lo, hi = l2_range(abs(a), d, phi0 + shift, phi1 + shift)
    out = math.pi / 2
    for l2 in (lo, hi):
        cm = (b * b + c * c - float(l2)) / (2 * b * abs(c))
        mu = math.acos(min(1.0, max(-1.0, cm)))
        out = min(out, mu, math.pi - mu)
    return out


def _design(prob: _Problem, family: str, a, b, c, phi_s, psi_s, sigma=None, at=None) -> Design:
    s = prob.spec
    d = s.frame
    batch = _Batch(prob, ["crank", "coupler", "rocker", "input_start", "output_start"])
    X = np.array([[a], [b], [c], [phi_s], [psi_s]], float)
    ep, em = batch.errors(X)
    margin = float(batch.constraints(X)[0, 0])
    if sigma is None:
        sigma = 1.0 if ep[0] <= em[0] else -1.0
    err = float(ep[0] if sigma > 0 else em[0])
    notes, valid = [], True
    shift = math.pi if a < 0 else 0.0
    closes = transmission_margin(abs(a), b, abs(c), d, phi_s + shift, phi_s + shift + s.phi_range)
    if closes <= 0:
        err = math.nan  # the loop does not close over the range: no error to speak of
        valid = False
        notes.append("the dyad does not close, or changes branch, somewhere in the range")
    elif margin <= 0:
        valid = False
        notes.append(
            f"the transmission angle falls below {math.degrees(s.min_transmission):g} deg "
            "somewhere in the range"
        )
    extra = {
        "signed": (float(a), float(c)),
        "phi_start": float(phi_s),
        "psi_start": float(psi_s),
        "sigma": sigma,
        "max_error": err,
        "precision_x": None if at is None else [float(x) for x in at],
    }
    return Design(
        method="function generation",
        family=family,
        lengths={"crank": abs(a), "coupler": float(b), "rocker": abs(c), "frame": d},
        ground={"O2": (0.0, 0.0), "O4": (d, 0.0)},
        grashof=grashof_type(abs(a), b, abs(c), d),
        min_transmission=_min_transmission(a, b, c, d, phi_s, phi_s + s.phi_range),
        valid=valid,
        notes=notes,
        extra=extra,
    )


@dataclass
class FunctionResult:
    designs: list[Design]
    search: Search | None
    problem: _Problem


def solve_function(
    spec: FunctionSpec,
    *,
    seed: int | None = 0,
    max_time: float | None = None,
    progress: Callable[[int, float], None] | None = None,
) -> FunctionResult:
    """The precision-point design (Freudenstein), then the optimised ones (best first)."""
    prob = _Problem(spec)
    xs, xf = spec.x_range
    at = np.array(spec.at, float) if spec.at is not None else chebyshev(xs, xf, spec.points)
    if len(at) < 3:
        raise InputError(
            f"{len(at)} precision point(s): Freudenstein's equation has three unknowns, "
            "give at least 3"
        )
    phi, psi = prob.angles(at)
    a, b, c, _ = freudenstein(phi, psi, spec.frame)
    family = "3 precision points" if len(at) == 3 else f"{len(at)} points, least squares"
    first = _design(prob, family, a, b, c, spec.phi_start, spec.psi_start, at=at)
    # the branch that reaches the precision points: one branch for all, or a defect
    sig = []
    for p, q in zip(phi, psi):
        e = [abs(_wrap(_psi(a, b, c, spec.frame, p, sg) - q)) for sg in (1.0, -1.0)]
        sig.append(1.0 if e[0] <= e[1] else -1.0)
    if len(at) == 3 and len(set(sig)) > 1:
        first.valid = False
        first.notes.append("branch defect: the precision points lie on different branches")
    designs = [first]
    found: Search | None = None
    if spec.optimise:
        found, more = _optimise(prob, first, seed, max_time, progress)
        designs += more
    return FunctionResult(designs, found, prob)


def _bounds(prob: _Problem, first: Design) -> tuple[list[str], list[tuple[float, float]]]:
    s = prob.spec
    names = ["crank", "coupler", "rocker"]
    a, c = first.extra["signed"]
    ref = {"crank": a, "coupler": first.lengths["coupler"], "rocker": c}
    bounds = []
    for n in names:
        if n in s.bounds:
            bounds.append(s.bounds[n])
        elif first.valid:
            v = ref[n]
            lo, hi = sorted((v / 5, v * 5))
            bounds.append((lo, hi))
        else:
            bounds.append((s.frame / 20, 5 * s.frame))
    for n in ("input_start", "output_start"):
        if n in s.bounds:
            names.append(n)
            bounds.append(s.bounds[n])
    return names, bounds


def _optimise(prob: _Problem, first: Design, seed, max_time, progress):
    from scipy.optimize import minimize

    s = prob.spec
    names, bounds = _bounds(prob, first)
    batch = _Batch(prob, names)
    x0 = None
    a, c = first.extra["signed"]
    start = {"crank": a, "coupler": first.lengths["coupler"], "rocker": c,
             "input_start": s.phi_start, "output_start": s.psi_start}  # fmt: skip
    cand = np.array([start[n] for n in names])
    if first.valid and all(lo <= v <= hi for v, (lo, hi) in zip(cand, bounds)):
        x0 = cand
    found = search(
        batch.objective, batch.constraints, bounds, seed=seed, max_time=max_time,
        max_iter=s.max_iter, popsize=s.popsize, x0=x0, progress=progress,
    )  # fmt: skip

    def scalar(x):
        X = np.asarray(x, float)[:, None]
        if batch.constraints(X)[0, 0] <= 0 or any(
            not lo <= v <= hi for v, (lo, hi) in zip(x, bounds)
        ):
            return np.inf
        return float(batch.objective(X)[0])

    cands: list[tuple[float, np.ndarray]] = []
    if found.x is not None and not found.interrupted:
        pol = minimize(scalar, found.x, method="Nelder-Mead",
                       options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 4000})  # fmt: skip
        if np.isfinite(pol.fun) and pol.fun < found.fun:
            cands.append((float(pol.fun), np.array(pol.x)))
    if found.x is not None:
        cands.append((found.fun, found.x))
    cons = batch.constraints(found.population.T)[0] if len(found.population) else []
    for f, x, m in zip(found.energies, found.population, cons):
        if m > 0 and np.isfinite(f):
            cands.append((float(f), x))
    out = []
    for i, (_, x) in enumerate(distinct(cands, bounds, s.top), 1):
        v = dict(zip(names, x))
        out.append(
            _design(
                prob,
                f"optimised {i}",
                v["crank"],
                v["coupler"],
                v["rocker"],
                v.get("input_start", s.phi_start),
                v.get("output_start", s.psi_start),
            )  # fmt: skip
        )
    return found, out


def function_yaml(
    d: Design,
    name: str,
    spec: FunctionSpec,
    step_deg: float = 1.0,
    unit: str = "m",
    digits: int | None = None,
) -> str:
    """The mechanism file of a function generator: the crank O2-A (driven from the
    range's start), the coupler A-B, the rocker O4-B; ``mechsolve run`` gives psi as the
    rocker's angle (``rocker`` link) against the crank's. Lengths in ``unit``, numbers
    to ``digits`` significant digits (every digit for ``None``)."""
    from mechsolve.analyses.synth.writer import Numbers

    f = Numbers(unit, None, digits)

    a, c = d.extra["signed"]
    b, fr = d.lengths["coupler"], d.lengths["frame"]
    side = "right" if d.extra["sigma"] > 0 else "left"
    direction = "ccw" if spec.phi_range > 0 else "cw"
    w = as_written(d, spec, f)  # the header's figures: those of the numbers as written
    lines = [
        f"# {name}: four-bar function generator ({spec.description})",
        f"# Written by mechsolve synth (function generation; {d.family}).",
        f"# Grashof: {w.grashof}; minimum transmission angle over the range "
        f"{math.degrees(w.min_transmission):.4f} deg.",
        f"# Input: the crank O2-A from {math.degrees(d.extra['phi_start']):.6f} deg through "
        f"{math.degrees(spec.phi_range):.6f} deg; output: the rocker's angle (x axis O4 -> B"
        + (", reversed" if c < 0 else "")
        + f") from {math.degrees(d.extra['psi_start']):.6f} deg through "
        f"{math.degrees(spec.psi_range):.6f} deg; angles from the frame line O2 -> O4.",
        *_error_lines(w, spec, f),
        f"name: {name}",
        f.units_line,
        "",
        "ground:",
        "  O2: [0, 0]",
        f"  O4: [{f.len(fr)}, 0]",
        "",
        "links:",
        f"  crank: {{points: {{O2: [0, 0], A: [{f.len(a)}, 0]}}}}",
        f"  coupler: {{points: {{A: [0, 0], B: [{f.len(b)}, 0]}}}}",
        f"  rocker: {{points: {{O4: [0, 0], B: [{f.len(c)}, 0]}}}}",
        "",
        "joints:",
        "  O2: [ground, crank]",
        "  A: [crank, coupler]",
        "  B: [coupler, rocker]",
        "  O4: [ground, rocker]",
        "",
        "assembly:",
        f"  - B {side} of O4 -> A",
        "",
        f"driver: {{joint: O2, speed: 1 rad/s, direction: {direction}, "
        f"start: {f.ang(math.degrees(d.extra['phi_start']))} deg}}",
        f"sweep: {{range: {_deg(abs(spec.phi_range))} deg, step: {f.ang(step_deg)} deg}}",
        "",
    ]
    return "\n".join(lines)


def as_written(d: Design, spec: FunctionSpec, f) -> Design:
    """The design ``d`` with the numbers its file holds (``f``: how they are written),
    evaluated by the synthesis' model: what the file's header states (its largest error,
    its errors at the precision points, its transmission angle) is the written file's,
    rounded numbers included. Angles scale with the lengths: the written ones are scaled
    to the problem's frame."""
    a, c = d.extra["signed"]
    k = spec.frame / f.written(d.lengths["frame"])
    aw, bw, cw = (k * f.written(x) for x in (a, d.lengths["coupler"], c))
    phi_s = math.radians(f.written_deg(math.degrees(d.extra["phi_start"])))
    at = d.extra["precision_x"]
    prob = _Problem(spec)
    w = _design(prob, d.family, aw, bw, cw, phi_s, d.extra["psi_start"], d.extra["sigma"], at)
    if at:
        phi, psi = prob.angles(np.array(at), phi_s, d.extra["psi_start"])
        w.extra["error_points"] = _wrap(_psi(aw, bw, cw, spec.frame, phi, d.extra["sigma"]) - psi)
    return w


def _error_lines(w: Design, spec: FunctionSpec, f) -> list[str]:
    """The header's lines of the errors of the written numbers ``w`` (:func:`as_written`)."""
    what = "every digit written" if f.digits is None else f"{f.digits} significant digits"
    err = w.extra["max_error"]
    text = f"{math.degrees(err):.6f} deg" if math.isfinite(err) else "- (the loop does not close)"
    lines = [
        f"# Largest structural error over the range: {text} ({spec.samples} positions, the "
        f"synthesis' model of the numbers as written: {what})."
    ]
    if w.extra["precision_x"]:
        lines.append(
            "# Error at the precision points: "
            + ", ".join(
                f"x = {x:.6g}: {math.degrees(e):.3e} deg"
                for x, e in zip(w.extra["precision_x"], w.extra["error_points"])
            )
            + "."
        )
    return lines


def _deg(x: float) -> str:
    """An angle (rad) in deg, to 12 significant digits (60 deg, not 59.99999999999999)."""
    return f"{math.degrees(x):.12g}"


@dataclass
class Check:
    """The written file solved by mechsolve: psi at the precision points and over the
    range, and the errors against the function (rad)."""

    phi_points: np.ndarray
    error_points: np.ndarray
    phi: np.ndarray
    psi: np.ndarray
    psi_want: np.ndarray
    error: np.ndarray


def verify(text: str, d: Design, result: FunctionResult) -> Check:
    """Solve the written mechanism with mechsolve's own solver at the precision points
    and along the range, and measure the output angle from the pin B's position."""
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.model.parse import loads

    prob, s = result.problem, result.problem.spec
    mech = loads(text)
    xs, xf = s.x_range
    at = d.extra["precision_x"]
    phi_s, psi_s = d.extra["phi_start"], d.extra["psi_start"]
    x_all = xs + prob.t * (xf - xs)
    xs_list = list(at or []) + list(x_all)
    phi, psi_want = prob.angles(np.array(xs_list), phi_s, psi_s)
    res = solve_instants(mech, [Instant(float(p), 1.0, 0.0) for p in phi], forces=False)
    pb = res.point("B")
    c = d.extra["signed"][1]
    psi = np.arctan2(pb.y, pb.x - s.frame) - (math.pi if c < 0 else 0.0)
    err = _wrap(psi - psi_want)
    n = len(at or [])
    return Check(phi[:n], err[:n], phi[n:], psi[n:], psi_want[n:], err[n:])
