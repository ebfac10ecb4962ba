"""Path generation: a four-bar whose coupler point passes through target points.

The problem names a template mechanism file (a four-bar: a crank driven at a ground
pivot, a coupler, a rocker on the other ground pivot), its coupler point, the targets and
the numbers of the template that may vary, by their key paths with bounds (``vary:``, as
``mechsolve study`` names numbers)::

    path:
      mechanism: ../fourbar.yaml
      point: P
      targets: [[x, y], ...]            # in the template's length unit
      timing: [0, 30, 60, ...]          # optional: the crank's angle at each point
      closed: false                     # true: the crank turns fully (a closed curve)
      grashof: crank-rocker             # or any (default)
      min_transmission: 20 deg          # optional
      vary: {ground.O2[0]: [-50, 50], links.crank.points.A[0]: [5, 60], ...}
      optimise: {max_iter: 2000, popsize: 20, top: 5}

Objective: the sum of squared distances from the targets (m^2). Without timing, the
crank's angle at the first point and its advances between points are variables too;
advances are non-negative and add up to less than a turn, so the points are reached in
order along the driver's motion by construction (no order defect). Constraints, exact
(see :mod:`.fourbar_batch`): the dyad closes and keeps its branch over the whole motion
(from the first point to the last, or a full turn for a closed path), the transmission
angle above the minimum asked, and the Grashof type asked. Each generation of
differential evolution is one batch of the closed form over all designs x points; a
least-squares polish (trust region, within the bounds) follows and is kept only when it
stays feasible.

A template that is not a four-bar (a Watt or Stephenson six-bar: a crank and revolute
dyads) is evaluated through the design batch instead, by :mod:`.chain_gen`.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mechsolve.analyses.synth.common import Design, batch_least_squares, fd_columns, grashof_type
from mechsolve.analyses.synth.fourbar_batch import dyad_point, grashof_margin
from mechsolve.analyses.synth.fourbar_batch import transmission_margin as _margin
from mechsolve.analyses.synth.optimise import Search, distinct, search
from mechsolve.base.errors import InputError
from mechsolve.base.units import UnitError, parse_quantity, parse_unit

__all__ = ["PathSpec", "read_path", "solve_path", "path_yaml", "verify_path", "describe_rows"]

TWO_PI = 2 * math.pi
GRASHOF = ("any", "crank-rocker", "double-crank")


@dataclass
class Var:
    """A varied number: its key path, bounds (SI) and the template's unit there."""

    path: tuple
    name: str
    kind: str
    lo: float
    hi: float
    unit: str


@dataclass
class PathSpec:
    template: Path
    data: dict  # the template's YAML
    units: dict[str, str]
    names: dict[str, str]  # roles -> names: crank, coupler, rocker, O2, O4, A, B, P
    targets: np.ndarray  # (N, 2) m
    timing: np.ndarray | None  # crank angles (rad) or None
    closed: bool
    grashof: str = "any"
    min_transmission: float = 0.0
    vary: list[Var] = field(default_factory=list)
    max_iter: int = 2000
    popsize: int = 20
    top: int = 5
    direction: float = 1.0
    chain: Any = None  # a ChainBatch when the template is not a four-bar (a six-bar ...)


# -- the template ---------------------------------------------------------------------------


def _roles(mech) -> dict[str, str]:
    """Names of the four-bar's parts in the template, or an InputError."""
    joints = list(mech.joints)
    if len(joints) != 4 or any(getattr(j, "kind", "") != "revolute" for j in joints):
        raise InputError("the template must be a four-bar: four revolute joints")
    drv = mech.driver.joint
    j0 = next((j for j in joints if j.name == drv), None)
    if j0 is None or "ground" not in j0.links:
        raise InputError("the template's driver must turn a crank about a ground pivot")
    crank = next(k for k in j0.links if k != "ground")
    other = [j for j in joints if "ground" in j.links and j is not j0]
    if len(other) != 1:
        raise InputError("the template must be a four-bar with two ground pivots")
    rocker = next(k for k in other[0].links if k != "ground")
    ja = next((j for j in joints if crank in j.links and "ground" not in j.links), None)
    jb = next((j for j in joints if rocker in j.links and "ground" not in j.links), None)
    if ja is None or jb is None:
        raise InputError("the template must be a four-bar: crank - coupler - rocker")
    coupler = next(k for k in ja.links if k != crank)
    return {"crank": crank, "coupler": coupler, "rocker": rocker,
            "O2": j0.name, "O4": other[0].name, "A": ja.name, "B": jb.name}  # fmt: skip


def _default_unit(units: dict, kind: str) -> str:
    return units.get(kind, "m" if kind == "length" else "deg")


def _q(value: Any, kind: str, units: dict) -> float:
    return parse_quantity(value, kind, _default_unit(units, kind))


class Geometry:
    """The template's four-bar geometry with the varied numbers as arrays: the local
    coordinates of the points the closed form needs, read as the model reads them."""

    def __init__(self, spec: PathSpec) -> None:
        self.spec = spec
        self.index = {v.path: i for i, v in enumerate(spec.vary)}
        self._fixed: dict[tuple, float] = {}

    def value(self, X, path: tuple, kind: str):
        i = self.index.get(path)
        if i is not None:
            return X[i]
        if path not in self._fixed:
            node: Any = self.spec.data
            for k in path:
                node = node[k]
            self._fixed[path] = _q(node, kind, self.spec.units)
        return self._fixed[path]

    def ground(self, X, name: str):
        return self.value(X, ("ground", name, 0), "length"), self.value(
            X, ("ground", name, 1), "length"
        )

    def local(self, X, link: str, name: str, _depth: int = 0):
        pts = self.spec.data["links"][link]["points"]
        v = pts[name]
        base = ("links", link, "points", name)
        if isinstance(v, list):
            return self.value(X, base + (0,), "length"), self.value(X, base + (1,), "length")
        if _depth > 4:
            raise InputError(f"links.{link}.points.{name}: the points refer to each other")
        length = self.value(X, base + ("length",), "length")
        angle = self.value(X, base + ("angle",), "angle")
        order = list(pts)
        if "from" in v:
            ox, oy = self.local(X, link, str(v["from"]), _depth + 1)
        else:
            ox, oy = self.local(X, link, order[0], _depth + 1) if order[0] != name else (0, 0)
        ref = v.get("ref")
        if ref is None and "from" not in v and len(order) > 1 and name not in order[:2]:
            ref = order[:2]
        ref_angle = 0.0
        if ref is not None:
            (x0, y0), (x1, y1) = (self.local(X, link, str(p), _depth + 1) for p in ref)
            ref_angle = np.arctan2(y1 - y0, x1 - x0)
        a = ref_angle + angle
        return ox + length * np.cos(a), oy + length * np.sin(a)

    def parts(self, X):
        """Every number of the closed form, arrays over the designs (columns of X)."""
        n = self.spec.names
        g2, g4 = self.ground(X, n["O2"]), self.ground(X, n["O4"])
        c2 = self.local(X, n["crank"], n["O2"])
        ca = self.local(X, n["crank"], n["A"])
        pa = self.local(X, n["coupler"], n["A"])
        pb = self.local(X, n["coupler"], n["B"])
        pp = self.local(X, n["coupler"], n["P"])
        r4 = self.local(X, n["rocker"], n["O4"])
        rb = self.local(X, n["rocker"], n["B"])
        return g2, g4, c2, ca, pa, pb, pp, r4, rb


def _check_reader(spec: PathSpec, mech) -> None:
    """The geometry's reading of the template agrees with the model's (or we refuse)."""
    geo = Geometry(spec)
    X = np.zeros((0, 1))
    geo.index = {}  # the template's own values
    n = spec.names
    links = {lk.name: lk for lk in mech.links} if isinstance(mech.links, list) else mech.links
    pairs = [((n["crank"], n["O2"])), (n["crank"], n["A"]), (n["coupler"], n["A"]),
             (n["coupler"], n["B"]), (n["coupler"], n["P"]), (n["rocker"], n["O4"]),
             (n["rocker"], n["B"])]  # fmt: skip
    for link, pt in pairs:
        got = np.array([float(np.ravel(c)[0]) for c in geo.local(X, link, pt)])
        want = np.array(links[link].points[pt])
        if not np.allclose(got, want, atol=1e-12, rtol=1e-12):
            raise InputError(
                f"links.{link}.points.{pt}: a point form the synthesis cannot vary "
                "(write it as [x, y] or {length, angle})"
            )


# -- the closed form over the batch ---------------------------------------------------------


class Batch:
    """Designs as columns: the varied numbers, then (without timing) the crank's angle at
    the first point and its N - 1 advances (rad)."""

    def __init__(self, spec: PathSpec) -> None:
        self.spec = spec
        self.geo = Geometry(spec)
        self.nv = len(spec.vary)
        self.n = len(spec.targets)

    def angles(self, X):
        s = self.spec
        if s.timing is not None:
            return np.broadcast_to(s.timing[:, None], (self.n, X.shape[1]))
        u1 = X[self.nv]
        adv = X[self.nv + 1 :]
        return u1[None, :] + s.direction * np.vstack([np.zeros_like(u1), np.cumsum(adv, 0)])

    def points(self, X, sigma: float):
        """Coupler point at each target's crank angle, (N, S) x and y; plus the frame
        angle data for the constraints."""
        g2, g4, c2, ca, pa, pb, pp, r4, rb = self.geo.parts(X)
        u = self.angles(X)
        # crank: A = O2 + R(u) (A_local - O2_local)
        vx, vy = ca[0] - c2[0], ca[1] - c2[1]
        cu, su = np.cos(u), np.sin(u)
        ax = g2[0] + cu * vx - su * vy
        ay = g2[1] + su * vx + cu * vy
        b = np.hypot(pb[0] - pa[0], pb[1] - pa[1])
        c = np.hypot(rb[0] - r4[0], rb[1] - r4[1])
        bx, by, _ = dyad_point(ax, ay, g4[0], g4[1], b, c, sigma)
        # coupler frame: the line A -> B, turned by its local direction
        th = np.arctan2(by - ay, bx - ax) - np.arctan2(pb[1] - pa[1], pb[0] - pa[0])
        lx, ly = pp[0] - pa[0], pp[1] - pa[1]
        px = ax + np.cos(th) * lx - np.sin(th) * ly
        py = ay + np.sin(th) * lx + np.cos(th) * ly
        return px, py

    def residuals(self, X, sigma: float):
        px, py = self.points(X, sigma)
        t = self.spec.targets
        return px - t[:, 0:1], py - t[:, 1:2]

    def objective_both(self, X):
        out = []
        for sigma in (1.0, -1.0):
            dx, dy = self.residuals(X, sigma)
            with np.errstate(invalid="ignore"):
                f = np.sum(dx * dx + dy * dy, axis=0)
            out.append(np.where(np.isfinite(f), f, np.inf))
        return out

    def objective(self, X):
        X = np.asarray(X, float)
        one = X.ndim == 1
        fp, fm = self.objective_both(X[:, None] if one else X)
        f = np.minimum(fp, fm)
        f = np.where(np.isfinite(f), f, 1e300)
        return f[0] if one else f

    def lengths(self, X):
        g2, g4, c2, ca, pa, pb, pp, r4, rb = self.geo.parts(X)
        a = np.hypot(ca[0] - c2[0], ca[1] - c2[1])
        b = np.hypot(pb[0] - pa[0], pb[1] - pa[1])
        c = np.hypot(rb[0] - r4[0], rb[1] - r4[1])
        d = np.hypot(g4[0] - g2[0], g4[1] - g2[1])
        # crank angle measured from the frame line O2 -> O4: u + alpha - beta
        alpha = np.arctan2(ca[1] - c2[1], ca[0] - c2[0])
        beta = np.arctan2(g4[1] - g2[1], g4[0] - g2[0])
        shape = (np.shape(X)[1],)
        return tuple(np.broadcast_to(v, shape).astype(float) for v in (a, b, c, d, alpha - beta))

    def constraints(self, X):
        """Rows >= 0: the motion's dyad margin (closes, one branch, transmission), the
        Grashof type asked, and (without timing) less than a turn from first to last."""
        s = self.spec
        X = np.asarray(X, float)
        if X.ndim == 1:
            return self.constraints(X[:, None])[:, 0]
        a, b, c, d, off = self.lengths(X)
        u = self.angles(X)
        if s.closed:
            lo, hi = np.zeros_like(a), np.full_like(a, TWO_PI)
        else:
            lo, hi = u[0] + off, u[-1] + off
        rows = [_margin(a, b, c, d, lo, hi, s.min_transmission)]
        if s.grashof != "any":
            rows.append(grashof_margin(a, b, c, d))
            # the link that turns fully is the shortest: the crank, or the frame
            if s.grashof == "crank-rocker":
                rows.append((np.minimum.reduce([b, c, d]) - a) / (a + b + c + d))
            else:
                rows.append((np.minimum.reduce([a, b, c]) - d) / (a + b + c + d))
        if s.timing is None:
            rows.append((TWO_PI - np.sum(X[self.nv + 1 :], axis=0)) / TWO_PI)
        return np.vstack(rows)


# -- reading ---------------------------------------------------------------------------------


def read_path(r: Any) -> PathSpec:
    """The ``path:`` section (``r`` is the problem file's section reader)."""
    from mechsolve.model.parse import load
    from mechsolve.model.source import load_file

    r.allow(("mechanism", "point", "targets", "timing", "closed", "grashof",
             "min_transmission", "vary", "optimise"))  # fmt: skip
    file = r.data.get("mechanism")
    if not isinstance(file, str):
        raise r.err("mechanism", "expected the template mechanism file's path")
    base = Path(r.src.file).parent if getattr(r.src, "file", None) else Path(".")
    mpath = Path(file) if Path(file).is_absolute() else base / file
    mech = load(mpath)
    tsrc = load_file(mpath)
    from mechsolve.analyses.synth.chain_gen import ChainBatch

    try:
        names = _roles(mech)
        fourbar = True
    except InputError:
        names, fourbar = {}, False
    point = r.data.get("point")
    links = {lk.name: lk for lk in mech.links} if isinstance(mech.links, list) else mech.links
    if fourbar:
        if not isinstance(point, str) or point not in links[names["coupler"]].points:
            raise r.err("point", f"expected a point of the coupler {names['coupler']!r}: "
                        f"{', '.join(links[names['coupler']].points)}")  # fmt: skip
    else:
        owners = [lk for lk in links.values() if isinstance(point, str) and point in lk.points]
        if not owners:
            raise r.err("point", "expected the name of a point of one of the template's "
                        "moving links")  # fmt: skip
    names["P"] = point
    units = dict(tsrc.data.get("units") or {})
    tg = r.data.get("targets")
    if not isinstance(tg, list):
        raise r.err("targets", "expected a list of points [x, y]")
    targets = []
    for i, p in enumerate(tg):
        if not (isinstance(p, list) and len(p) == 2):
            raise r.err(("targets", i), f"expected [x, y], got {p!r}")
        targets.append([_qr(r, ("targets", i, k), p[k], "length", units) for k in (0, 1)])
    spec = PathSpec(mpath, tsrc.data, units, names, np.array(targets, float), None,
                    bool(r.data.get("closed", False)))  # fmt: skip
    spec.direction = 1.0 if (mech.driver.sense or "ccw") != "cw" else -1.0
    _vary(r, spec, units)
    _timing(r, spec, units)
    _options(r, spec)
    if fourbar:
        _check_reader(spec, mech)
        return spec
    spec.direction = -1.0 if (mech.driver.sense or 1) == -1 else 1.0
    if spec.grashof != "any":
        raise r.err("grashof", "the Grashof type applies to a four-bar template; for this "
                    "template the closure of every dyad over the motion is checked")  # fmt: skip
    try:
        spec.chain = ChainBatch(spec, mech, Geometry(spec))
    except InputError as exc:
        raise r.err("mechanism", f"{file}: {exc.message}") from None
    return spec


def _qr(r, key, value, kind, units):
    try:
        return _q(value, kind, units)
    except (UnitError, KeyError, TypeError) as exc:
        raise r.err(key, str(exc)) from None


def _vary(r, spec: PathSpec, units) -> None:
    from mechsolve.analyses.study.params import kind_at, lookup, parse_keypath

    v = r.data.get("vary")
    if not isinstance(v, dict) or not v:
        raise r.err("vary", "expected the numbers to vary: {key.path: [lowest, highest]}")
    for key, b in v.items():
        try:
            path = parse_keypath(str(key))
            nominal = lookup(spec.data, path)
        except InputError as exc:
            raise r.err(("vary", key), exc.message) from None
        ok = (path[:1] == ("ground",) and len(path) == 3) or (
            len(path) >= 5 and path[0] == "links" and path[2] == "points"
        )
        kind = kind_at(path, nominal)
        if not ok or kind not in ("length", "angle") or isinstance(nominal, (dict, list)):
            raise r.err(("vary", key), "only a ground pivot's coordinate or a link point's "
                        "coordinate, length or angle can vary")  # fmt: skip
        if not (isinstance(b, list) and len(b) == 2):
            raise r.err(("vary", key), f"expected bounds [lowest, highest], got {b!r}")
        lo, hi = (_qr(r, ("vary", key, i), b[i], kind, units) for i in (0, 1))
        if not lo < hi:
            raise r.err(("vary", key), "the lower bound must be below the upper one")
        spec.vary.append(Var(path, str(key), kind, lo, hi, _default_unit(units, kind)))


def _timing(r, spec: PathSpec, units) -> None:
    n = len(spec.targets)
    need = 3 if r.has("timing") else 4
    if n < need:
        raise r.err("targets", f"{n} target point(s): give at least {need} "
                    f"({'with' if r.has('timing') else 'without'} timing)")  # fmt: skip
    if not r.has("timing"):
        return
    t = r.data["timing"]
    if not (isinstance(t, list) and len(t) == n):
        raise r.err("timing", f"expected one crank angle per target ({n})")
    spec.timing = np.array([_qr(r, ("timing", i), e, "angle", units) for i, e in enumerate(t)])


def _options(r, spec: PathSpec) -> None:
    g = r.data.get("grashof", "any")
    if g not in GRASHOF:
        raise r.err("grashof", f"expected one of: {', '.join(GRASHOF)}")
    spec.grashof = g
    if r.has("min_transmission"):
        spec.min_transmission = r.q("min_transmission", "angle")
        if not 0 <= spec.min_transmission < math.pi / 2:
            raise r.err("min_transmission", "expected an angle from 0 to 90 deg (excluded)")
    o = r.data.get("optimise") or {}
    if not isinstance(o, dict):
        raise r.err("optimise", "expected {max_iter, popsize, top}")
    for k, e in o.items():
        if k not in ("max_iter", "popsize", "top"):
            raise r.err(("optimise", k), "unknown key (expected max_iter, popsize, top)")
        if isinstance(e, bool) or not isinstance(e, int) or e < 1:
            raise r.err(("optimise", k), f"expected a whole number >= 1, got {e!r}")
        setattr(spec, k, e)


# -- solving ---------------------------------------------------------------------------------


@dataclass
class PathResult:
    designs: list[Design]
    search: Search | None
    spec: PathSpec
    names: list[str]
    why: str = ""


def _bounds(spec: PathSpec) -> tuple[list[str], list[tuple[float, float]]]:
    names = [v.name for v in spec.vary]
    bounds = [(v.lo, v.hi) for v in spec.vary]
    if spec.timing is None:
        n = len(spec.targets)
        names += ["u1"] + [f"advance{i}" for i in range(2, n + 1)]
        bounds += [(0.0, TWO_PI)] + [(0.0, TWO_PI)] * (n - 1)
    return names, bounds


def _feasible_somewhere(batch: Batch, bounds, seed) -> str:
    """'' if some design within the bounds meets the Grashof type asked, else why not
    (checked on 20 000 Sobol-spaced designs of the bounds: a search would find none)."""
    if batch.spec.grashof == "any":
        return ""
    from scipy.stats import qmc

    lo, hi = np.array(bounds).T
    X = qmc.scale(qmc.Sobol(len(bounds), seed=seed).random(2**14), lo, hi).T
    c = batch.constraints(X)
    if np.any(np.all(c[1:3] > 0, axis=0)):
        return ""
    return (f"the bounds exclude every {batch.spec.grashof} linkage (none among 16384 "
            "designs spread over them): widen the bounds of 'vary'")  # fmt: skip


def solve_path(
    spec: PathSpec,
    *,
    seed: int | None = 0,
    max_time: float | None = None,
    progress: Callable[[int, float], None] | None = None,
) -> PathResult:
    """Differential evolution on design batches, then a least-squares polish."""
    if spec.chain is not None:
        return _solve_chain(spec, seed=seed, max_time=max_time, progress=progress)
    batch = Batch(spec)
    names, bounds = _bounds(spec)
    why = _feasible_somewhere(batch, bounds, seed)
    if why:
        raise InputError(why)
    found = search(batch.objective, batch.constraints, bounds, seed=seed, max_time=max_time,
                   max_iter=spec.max_iter, popsize=spec.popsize, progress=progress,
                   tol=1e-14)  # fmt: skip
    cands = _candidates(found, batch)
    if not found.interrupted:
        # polish the distinct best ones (a local minimum of one is not the others')
        for k, (_, x) in enumerate(distinct(cands, bounds, 2 * spec.top)):
            pols = [_polish(batch, x, bounds)]
            if k < 3:  # the slower constrained polish: the three best distinct starts
                pols.append(_polish_constrained(batch, x, bounds))
            cands += [p for p in pols if p is not None]
    designs = [_design(batch, names, x, f"optimised {i}")
               for i, (f, x) in enumerate(distinct(cands, bounds, spec.top), 1)]  # fmt: skip
    res = PathResult(designs, found, spec, names)
    if not designs:
        res.why = "no design within the bounds met the constraints " + _violated(batch, found)
    return res


def _candidates(found, batch) -> list[tuple[float, np.ndarray]]:
    """The search's best design and every feasible member of its last population, as
    ``(objective, x)``: the starts of the polish."""
    cands: list[tuple[float, np.ndarray]] = []
    if found.x is not None:
        cands.append((found.fun, found.x))
    if len(found.population):
        ok = np.all(batch.constraints(found.population.T) > 0, axis=0)
        for f, x, good in zip(found.energies, found.population, ok):
            if good and np.isfinite(f):
                cands.append((float(f), x))
    return cands


def _solve_chain(spec: PathSpec, *, seed, max_time, progress) -> PathResult:
    """As :func:`solve_path`, the template solved by its group plan over the batch."""
    from mechsolve.analyses.synth.chain_gen import design, polish

    batch = spec.chain
    names, bounds = _bounds(spec)
    found = search(batch.objective, batch.constraints, bounds, seed=seed, max_time=max_time,
                   max_iter=spec.max_iter, popsize=spec.popsize, progress=progress,
                   tol=1e-14)  # fmt: skip
    cands = _candidates(found, batch)
    if not found.interrupted:
        for _, x in distinct(cands, bounds, 2 * spec.top):
            p = polish(batch, x, bounds)
            if p is not None:
                cands.append(p)
    designs = [design(batch, names, x, f"optimised {i}")
               for i, (f, x) in enumerate(distinct(cands, bounds, spec.top), 1)]  # fmt: skip
    res = PathResult(designs, found, spec, names)
    if not designs and len(found.population):
        c = batch.constraints(found.population.T)
        worst = int(np.argmax(np.sum(c <= 0, axis=1)))
        res.why = "no design within the bounds met the constraints " + batch.labels()[worst]
    elif not designs:
        res.why = "no design within the bounds met the constraints"
    return res


def _violated(batch: Batch, found: Search) -> str:
    if not len(found.population):
        return ""
    c = batch.constraints(found.population.T)
    labels = ["(the dyad closes and keeps one branch over the motion, transmission angle)"]
    if batch.spec.grashof != "any":
        labels += [f"(Grashof {batch.spec.grashof})"] * 2
    if batch.spec.timing is None:
        labels.append("(less than a turn from first to last point)")
    worst = int(np.argmax(np.sum(c <= 0, axis=1)))
    return labels[worst]


def _polish(batch: Batch, x0, bounds):
    lo, hi = np.array(bounds).T
    fp, fm = batch.objective_both(np.asarray(x0)[:, None])
    sigma = 1.0 if fp[0] <= fm[0] else -1.0

    def columns(X):
        return np.vstack(batch.residuals(X, sigma))

    r = batch_least_squares(columns, np.asarray(x0, float), lo, hi, max_nfev=500)
    if r is None:
        return None
    X = r.x[:, None]
    if np.all(batch.constraints(X) > 0):
        f = float(batch.objective(X)[0])
        return (f, np.array(r.x))
    return None


def _polish_constrained(batch: Batch, x0, bounds):
    """A local search that keeps the constraints (SLSQP, gradients by central differences,
    every perturbed design of a step in one batch): where the unconstrained polish leaves
    the feasible set (an order, branch or Grashof limit is active at the optimum), this
    one follows the limit. The result is kept only if strictly feasible, stepping back
    towards ``x0`` (feasible) if it ends on a limit."""
    from scipy.optimize import minimize

    lo, hi = np.array(bounds).T
    x0 = np.clip(np.asarray(x0, float), lo, hi)

    def f(x):
        return float(batch.objective(np.asarray(x, float)[:, None])[0])

    def fjac(x):
        h, X, n = fd_columns(np.asarray(x, float), lo, hi)
        v = batch.objective(X)
        return np.where(h > 0, (v[:n] - v[n:]) / np.where(h > 0, 2 * h, 1), 0.0)

    def g(x):
        return batch.constraints(np.asarray(x, float)[:, None])[:, 0]

    def gjac(x):
        h, X, n = fd_columns(np.asarray(x, float), lo, hi)
        c = batch.constraints(X)
        return np.where(h > 0, (c[:, :n] - c[:, n:]) / np.where(h > 0, 2 * h, 1), 0.0)

    if not np.all(g(x0) > 0):
        return None
    try:
        r = minimize(f, x0, jac=fjac, method="SLSQP", bounds=list(zip(lo, hi)),
                     constraints=[{"type": "ineq", "fun": g, "jac": gjac}],
                     options={"maxiter": 500, "ftol": 1e-16})  # fmt: skip
    except (ValueError, np.linalg.LinAlgError):
        return None
    for t in (1.0, 0.9999, 0.999, 0.99, 0.9):
        x = x0 + t * (np.clip(r.x, lo, hi) - x0)
        if np.all(g(x) > 0):
            fx = f(x)
            return (fx, x) if np.isfinite(fx) and fx < f(x0) else None
    return None


def _pt(p) -> tuple[float, float]:
    return float(np.ravel(p[0])[0]), float(np.ravel(p[1])[0])


def _design(batch: Batch, names: list[str], x: np.ndarray, family: str) -> Design:
    spec = batch.spec
    X = np.asarray(x, float)[:, None]
    fp, fm = batch.objective_both(X)
    sigma = 1.0 if fp[0] <= fm[0] else -1.0
    dx, dy = batch.residuals(X, sigma)
    dist = np.hypot(dx[:, 0], dy[:, 0])
    a, b, c, d, off = (float(v[0]) for v in batch.lengths(X))
    g2, g4 = batch.geo.ground(X, spec.names["O2"]), batch.geo.ground(X, spec.names["O4"])
    u = batch.angles(X)[:, 0]
    lo, hi = (0.0, TWO_PI) if spec.closed else (u[0] + off, u[-1] + off)
    mus = [m for m in np.linspace(0, math.pi / 2, 901)
           if _margin(a, b, c, d, lo, hi, m) > 0]  # fmt: skip
    kind = grashof_type(a, b, c, d)
    # the type asked, as the row names it: a margin of rounding is a change point
    asked = {"crank-rocker": "crank-rocker", "double-crank": "double crank"}.get(spec.grashof)
    notes = [] if asked is None or kind.startswith(asked) else [f"not a {spec.grashof}: {kind}"]
    return Design(
        method="path generation",
        family=family,
        lengths={"crank": a, "coupler": b, "rocker": c, "frame": d},
        ground={"O2": _pt(g2), "O4": _pt(g4)},
        grashof=kind,
        valid=not notes,
        notes=notes,
        min_transmission=float(mus[-1]) if mus else 0.0,
        extra={"x": dict(zip(names, map(float, x))), "sigma": sigma,
               "objective": float(np.sum(dist**2)), "distances": dist, "u": u},
    )  # fmt: skip


# -- the written file and its check -----------------------------------------------------------


def path_yaml(d: Design, name: str, spec: PathSpec, digits: int | None = None) -> str:
    """The template with the design's numbers (in the template's units, to ``digits``
    significant digits, every digit for ``None``), started at the first target's crank
    angle, swept to the last (a full turn for a closed path), on the design's branch."""
    import yaml

    def g(x: float) -> str:
        return repr(float(x)) if digits is None else format(float(x), f".{digits}g")

    data = copy.deepcopy(spec.data)
    data.pop("study", None)
    data.pop("variants", None)
    for v in spec.vary:
        node = data
        for k in v.path[:-1]:
            node = node[k]
        val = d.extra["x"][v.name]
        shown = math.degrees(val) if v.kind == "angle" and v.unit == "deg" else val
        if v.kind == "length":
            from mechsolve.base.units import parse_unit

            shown = val / parse_unit(v.unit).factor
        node[v.path[-1]] = f"{g(shown)} {v.unit}"
    u = d.extra["u"]
    n = spec.names
    data["name"] = name
    if spec.chain is not None:
        from mechsolve.analyses.synth.chain_gen import assembly_lines

        data["assembly"] = assembly_lines(spec.chain, d.extra["combo"])
    else:
        side = "left" if d.extra["sigma"] > 0 else "right"
        data["assembly"] = [f"{n['B']} {side} of {n['A']} -> {n['O4']}"]
    drv = dict(data.get("driver") or {})
    drv["start"] = f"{g(math.degrees(float(u[0])))} deg"
    data["driver"] = drv
    travel = TWO_PI if spec.closed else abs(float(u[-1] - u[0]))
    data["sweep"] = {"range": f"{math.degrees(max(travel, 1e-9)):.12g} deg", "step": "1 deg"}
    kind = "four-bar" if spec.chain is None else "linkage"
    body = yaml.safe_dump(data, sort_keys=False, allow_unicode=True)
    angles = [g(math.degrees(float(x))) for x in u]  # as written, and solved so below
    what = "every digit written" if digits is None else f"{digits} significant digits"
    head = [
        f"# {name}: {kind} path generator (mechsolve synth, {d.family})",
        f"# Template {spec.template.name}; point {n['P']} through {len(spec.targets)} targets: "
        + _written_error(body, spec, [math.radians(float(a)) for a in angles])
        + f" (mechsolve's solution of the numbers as written: {what}).",
        "# Crank angles at the targets (deg): " + ", ".join(angles),
    ]
    if spec.chain is None:
        head.append(f"# Grashof: {d.grashof}.")
    return "\n".join(head) + "\n" + body


def _written_error(text: str, spec: PathSpec, u: list[float]) -> str:
    """The sum of squared distances and the largest distance from the targets of the
    coupler point of the mechanism ``text`` (a written file) at its crank angles ``u``
    (rad), in the template's length unit."""
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.model.parse import loads

    res = solve_instants(loads(text), [Instant(x, 1.0, 0.0) for x in u], forces=False)
    p = res.point(spec.names["P"])
    dist = np.hypot(p.x - spec.targets[:, 0], p.y - spec.targets[:, 1])
    if not np.all(np.isfinite(dist)):
        return "the written linkage does not close at every target's crank angle"
    lu = _default_unit(spec.units, "length")
    k = parse_unit(lu).factor
    return (
        f"sum of squared distances {float(np.sum(dist**2)) / k**2:.6e} {lu}^2, largest "
        f"{float(np.max(dist)) / k:.6e} {lu}"
    )


@dataclass
class PathCheck:
    targets: list
    distances: np.ndarray
    in_order: bool
    reached_x: np.ndarray
    reached_y: np.ndarray
    curve_x: np.ndarray
    curve_y: np.ndarray


def verify_path(text: str, d: Design, result: PathResult) -> PathCheck:
    """Solve the written file with mechsolve: the coupler point at the targets' crank
    angles (reached from the start along the driver, on the file's branch) and its curve
    over the sweep."""
    from mechsolve.analyses.instants import Instant, solve_instants
    from mechsolve.model.parse import loads
    from mechsolve.results.run import solve

    spec = result.spec
    mech = loads(text)
    u = d.extra["u"]
    res = solve_instants(mech, [Instant(float(x), 1.0, 0.0) for x in u], forces=False)
    p = res.point(spec.names["P"])
    dist = np.hypot(p.x - spec.targets[:, 0], p.y - spec.targets[:, 1])
    steps = np.diff(u) * spec.direction
    in_order = bool(np.all(steps >= 0) and np.sum(steps) < TWO_PI + 1e-12)
    full = solve(mech)
    c = full.point(spec.names["P"])
    return PathCheck(
        spec.targets.tolist(), dist, in_order and bool(full.ok.all()), p.x, p.y, c.x, c.y
    )


def describe_rows(out: Any) -> list[str]:
    """The designs' table, lengths in the problem's unit ``out.unit``."""
    u, k = out.unit, parse_unit(out.unit).factor
    head = f"  #  design        {f'sum of squares ({u}^2)':<21} {f'largest distance ({u})':<21} "
    if out.check["spec"].chain is not None:
        rows = [head + " min transmission (deg)"]
        for i, d in enumerate(out.designs, 1):
            mark = "*" if d is out.chosen else " "
            rows.append(
                f" {mark}{i:<2} {d.family:<13} {d.extra['objective'] / k**2:<21.6e} "
                f"{float(np.max(d.extra['distances'])) / k:<21.6e} "
                f"{math.degrees(d.min_transmission):.4f}"
            )
        return rows
    rows = [head + f" crank      coupler    rocker     frame ({u})  Grashof"]
    for i, d in enumerate(out.designs, 1):
        L = {n: v / k for n, v in d.lengths.items()}
        mark = "*" if d is out.chosen else " "
        rows.append(
            f" {mark}{i:<2} {d.family:<13} {d.extra['objective'] / k**2:<21.6e} "
            f"{float(np.max(d.extra['distances'])) / k:<21.6e} {L['crank']:<10.6f} "
            f"{L['coupler']:<10.6f} {L['rocker']:<10.6f} {L['frame']:<10.6f} {d.grashof}"
            + ("" if d.valid else "  INVALID: " + "; ".join(d.notes))
        )
    return rows
