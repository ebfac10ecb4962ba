"""Requirements: named checks on the figures of a run (the ``requirements:`` section).

A requirement is a comparison of a figure of the run with a limit, written in the
expression language of conditions (:mod:`mechsolve.model.expr`) with the reductions that turn a
quantity over the sweep into one number::

    requirements:
      torque: max(abs(input.torque)) <= 300 kN m
      transmission: min(transmission_angle.B) >= 40 deg
      quick return: time_ratio(ram) >= 1.4       # or ram.time_ratio
      closes: full turn                          # every position of a full turn assembles
      power balance: max(abs(power.residual)) <= 1e-6 W

What a requirement may read (SI values, whatever unit the CSV shows):

* every column of ``results.csv`` by its name (``K.y``, ``input.torque``, ``jib.angle``,
  ``power.residual``, ``O1(ground->crank).F`` written ``O1.F`` when the joint joins two
  links only);
* ``transmission_angle.X``: the transmission angle of loop ``X`` at each position; its
  ``min()`` is the exact minimum between samples (the one the summary prints);
* ``<link>.swing``, ``<link>.time_ratio`` (a rocker), ``<slider>.stroke``,
  ``<slider>.time_ratio``: the limit positions' figures; ``cycle.work``: the driver's work
  over the sweep (J).

Reductions: ``max(q)``, ``min(q)``, ``range(q)`` (max − min): the extremes over the sweep
the plots are drawn from, each located between its neighbouring samples (see
:class:`_Reducer`), the verdict saying where; ``mean(q)``, ``rms(q)`` over the file's
samples, ``at(q, u)`` (q at the driver value u, solved there; cubic between the samples
of a motion law of time); ``abs`` and the
other functions act position by position. Positions that did not solve are left out of a
reduction; a figure that is not determined (no solved position) fails its requirement and
says so.

What is compared must be of one kind (:func:`mechsolve.model.expr.dimension_of`), and the
figures of limit positions must name what they belong to (:func:`check_names`): both are
checked as the file is read, so that a slip is an input error at its line before anything
is solved, never a verdict.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from mechsolve.base.errors import InputError
from mechsolve.base.units import UnitError, parse_unit
from mechsolve.core import evaluate as core
from mechsolve.core.solution import gap_sides
from mechsolve.model.expr import (
    Binary,
    BoolOp,
    Call,
    Chain,
    Compare,
    ExprError,
    Expression,
    Not,
    Num,
    Ref,
    Unary,
    bottom_up,
    dimension_of,
    walk,
)
from mechsolve.model.requirement import (
    _ANGLE,
    _LENGTH,
    FULL_TURN,
    Requirement,
    _rewrite,
    figure_dim,
    parse_requirement,
)
from mechsolve.results.run import for_plots

if TYPE_CHECKING:  # (what a requirement is belongs to the model: model/requirement.py)
    from mechsolve.model import Mechanism
    from mechsolve.results.results import Results

__all__ = [
    "Requirement",
    "Verdict",
    "check_requirements",
    "evaluate_figure",
    "junit_xml",
    "located_extreme",
    "parse_requirement",
    "verdict_table",
]


@dataclass
class Verdict:
    """A requirement checked on a run."""

    name: str
    text: str
    value: float  # the measured figure, SI
    limit: float | None
    unit: str  # the unit the value and the limit are shown in
    passed: bool
    message: str


class _Exact(np.ndarray):
    """Transmission angles over the sweep, with their exact minimum between samples
    (the attribute is lost by arithmetic: only ``min(transmission_angle.X)`` uses it)."""

    exact_min: float | None = None
    exact_u: float | None = None


class _Unknown(KeyError):
    pass


@functools.lru_cache(maxsize=64)
def _factor(unit: str) -> float:
    """The factor to SI of a column's unit (1 for one that is not a unit, such as "-")."""
    try:
        return parse_unit(unit).factor if unit else 1.0
    except UnitError:
        return 1.0


class RunContext:
    """What a requirement reads from a run (see the module's docstring); ``figures``:
    also the limit positions, exact transmission minima and the work (not needed for
    the few positions an extreme is located with)."""

    def __init__(
        self, results: Results, figures: bool = True, of: RunContext | None = None
    ) -> None:
        self.res = results
        self.values: dict[str, Any] = {}
        self.units: dict[str, str] = {}
        joints: dict[str, list[str]] = {}
        for c in results.columns():
            self.values[c.name] = np.asarray(c.values, float) * _factor(c.unit)
            self.units[c.name] = c.unit
            head, _, attr = c.name.rpartition(".")
            if "(" in head:
                joints.setdefault(f"{head.split('(')[0]}.{attr}", []).append(c.name)
        for alias, cols in joints.items():
            if len(cols) == 1 and alias not in self.values:
                self.values[alias] = self.values[cols[0]]
                self.units[alias] = self.units[cols[0]]
        self._figures(figures)
        if of is not None:  # the run's own figures (a swing, the work), one number each
            for key, v in of.values.items():
                if key not in self.values and np.ndim(v) == 0:
                    self.values[key], self.units[key] = v, of.units[key]

    def _figures(self, figures: bool) -> None:
        res = self.res
        sol = res.solution
        plan = res.analysis.plan
        exact = {t.group: t for t in res.transmission_angles()} if figures else {}
        for gi, g in enumerate(plan):
            if g.n_modes != 2 or not sol.indicator.size:
                continue
            key = g.label.split()[1] if g.label.startswith("loop ") else g.label
            mu = np.arcsin(np.clip(np.where(sol.ok, sol.indicator[gi], np.nan), 0.0, 1.0))
            arr = mu.view(_Exact)
            if g.label in exact:
                arr.exact_min, arr.exact_u = exact[g.label].angle, exact[g.label].u
            self.values[f"transmission_angle.{key}"] = arr
            self.units[f"transmission_angle.{key}"] = "deg"
        if not figures:
            return
        for lp in res.limit_positions():
            kind = "stroke" if lp.travels else "swing"
            self.values[f"{lp.name}.{kind}"] = lp.high - lp.low
            self.units[f"{lp.name}.{kind}"] = "m" if lp.travels else "deg"
            if lp.time_ratio is not None:
                self.values[f"{lp.name}.time_ratio"] = lp.time_ratio
                self.units[f"{lp.name}.time_ratio"] = ""
        if res.forces is not None:
            self.values["cycle.work"] = res.work()
            self.units["cycle.work"] = "J"

    def quantity(self, name: str, attr: str) -> Any:
        key = f"{name}.{attr}"
        if key not in self.values:
            mech = self.res.mechanism
            links = {lk.name for lk in mech.links}
            joints = {j.name for j in mech.joints}
            if (attr in ("swing", "time_ratio") and name in links) or (
                attr in ("stroke", "time_ratio") and name in joints
            ):
                # a figure the run does not reach (a rocker that turns, or a sweep that
                # ends before its limit positions): not determined, so it fails
                return math.nan
            raise _Unknown(key)
        return self.values[key]

    def point_xy(self, name: str):
        return self.quantity(name, "x"), self.quantity(name, "y")

    def ref_dim(self, ref: Ref) -> tuple[int, int, int, int] | None:
        """The dimension of a figure from the unit of its column (``None`` if unknown)."""
        unit = self.units.get(f"{ref.name}.{ref.attr}")
        if unit is None:
            return figure_dim(ref, self.res.linear)
        try:
            return parse_unit("" if unit == "-" else unit).dim
        except UnitError:
            return None

    def unknown(self, key: str) -> str:
        near = difflib.get_close_matches(key, list(self.values), n=3, cutoff=0.6)
        hint = f" (did you mean {', '.join(near)}?)" if near else ""
        return (
            f"the run has no quantity {key!r}{hint}; requirements read the columns of "
            "results.csv (K.y, input.torque, power.residual...), transmission_angle.<loop>, "
            "<rocker>.swing, <rocker>.time_ratio, <slider>.stroke and cycle.work"
        )

    def at(self, q: Any, where: Any) -> float:
        """``q`` at the driver value ``where``: cubic between the samples."""
        from scipy.interpolate import CubicSpline

        u = np.asarray(self.res.u, float)
        q = np.broadcast_to(np.asarray(q, float), u.shape)
        w = float(np.asarray(where, float).ravel()[0])
        good = np.isfinite(q) & np.isfinite(u)
        if good.sum() < 2 or not (u[good].min() <= w <= u[good].max()):
            return math.nan
        x, y = u[good], q[good]
        order = np.argsort(x)
        x, y = x[order], y[order]
        keep = np.r_[True, np.diff(x) > 0]
        x, y = x[keep], y[keep]
        if len(x) < 4:
            return float(np.interp(w, x, y))
        return float(CubicSpline(x, y)(w))


def _finite(q: Any) -> np.ndarray:
    q = np.atleast_1d(np.asarray(q, float))
    return q[np.isfinite(q)]


def _evaluate(tree, ctx: RunContext) -> Any:
    """A tree without reductions, position by position."""
    e = Expression._derived(tree, "", ())
    with np.errstate(all="ignore"):
        return e.evaluate(ctx, {"at": ctx.at})


def _rebuild(n: Any, kids: list[Any]) -> Any:
    """Node ``n`` with its operands replaced."""
    if isinstance(n, (Unary, Not)):
        return dataclasses.replace(n, arg=kids[0])
    if isinstance(n, Binary):
        return dataclasses.replace(n, left=kids[0], right=kids[1])
    if isinstance(n, (Chain, Compare)):
        return dataclasses.replace(n, operands=tuple(kids))
    if isinstance(n, (Call, BoolOp)):
        return dataclasses.replace(n, args=tuple(kids))
    return n


class _Reducer:
    """Reduces a run to its figures. ``max``, ``min`` and ``range`` are taken over the
    sweep the plots are drawn from (:func:`mechsolve.api.for_plots`: 1 degree or finer,
    with the exact driver values of the limit positions, of the switching of loads and
    of a cam program's joins) and each extreme is then located between its neighbouring
    samples: the quantity is evaluated on a grid between them, solved there, and the
    grid narrowed around its best point down to 1e-8 of the driver coordinate (a value
    the quantity takes, so never beyond the true extreme). Next to a range where the
    mechanism cannot close, the interval reaches the located edge of that range (where
    a loop stops closing: a toggle, its transmission angle 0, where a driving torque
    through it grows without bound). At a singular position the sweep closes through
    (a change point) a quantity not determined there is probed towards it and, where it
    grows without bound (the reactions), is unbounded. A sweep that does not close at its
    ends is located on its own samples (for the plots' sweep is then the run's). With a
    motion law of time the extremes are the samples' and say so;
    ``mean`` and ``rms`` read the file's samples; ``at(q, u)`` is q solved at u.

    The points' ranges of the summary are located otherwise, by Newton's method on a
    coordinate's rates (:mod:`mechsolve.results.ranges`, whose docstring says why the two
    locators are not one)."""

    def __init__(self, results: Results) -> None:
        self.res = results
        self.ctx = RunContext(results)
        self.fine = self._fine_sweep(results)
        # per position only: the figures (limit positions, exact minima) are the run's
        self.fctx = None
        if self.fine is not None:
            self.fctx = RunContext(self.fine, figures=False, of=self.ctx)
        self.notes: list[str] = []
        self.jumps = False  # whether the last quantity's ends differ (see extreme)

    @classmethod
    def of(cls, results: Results) -> _Reducer:
        """The reducer of a run, made once per run (its fine sweep and contexts kept on
        the run: a study reads several figures of each design)."""
        red = getattr(results, "_requirements_reducer", None)
        if red is None or red.res is not results:
            red = cls(results)
            try:
                results._requirements_reducer = red
            except AttributeError:
                pass
        red.notes = []
        return red

    @staticmethod
    def _fine_sweep(res: Results) -> Results | None:

        if res.mechanism.driver.motion is None and len(res.u) > 1 and np.any(res.ok):
            return for_plots(res.mechanism, res)  # the run itself if its ends do not close
        return None

    # -- evaluation -------------------------------------------------------------------
    def value(self, tree) -> Any:
        """The value of a tree: each reduction replaced by its figure, bottom-up."""

        def figure(n, kids: list[Any]) -> Any:
            node = _rebuild(n, kids) if kids else n
            if isinstance(node, Call) and node.func in REDUCE and len(node.args) == 1:
                return Num(self.reduce(node.func, node.args[0]))
            if isinstance(node, Call) and node.func == "at" and self.fine is not None:
                return Num(self.at(node.args[0], _scalar(_evaluate(node.args[1], self.ctx), "u")))
            return node

        return _evaluate(bottom_up(tree, figure), self.ctx)

    def at(self, arg, x: float) -> float:
        """``arg`` at the driver value ``x``, solved there (next to the nearest solved
        sample of the sweep); not determined outside the sweep or where it does not
        close. (Without a fine sweep ``at`` is cubic between the samples, see
        :meth:`RunContext.at`.)"""
        fine = self.fine
        u = np.asarray(fine.u, float)
        good = np.flatnonzero(fine.ok)
        tol = 1e-12 * (fine.analysis.scale if fine.analysis.linear else 1.0)
        if not good.size or not (u[good].min() - tol <= x <= u[good].max() + tol):
            return math.nan
        k = int(good[np.argmin(np.abs(u[good] - x))])
        return float(self._values(arg, np.array([x]), k)[0])

    def reduce(self, func: str, arg) -> float:
        if func in ("mean", "rms"):
            v = _finite(_evaluate(arg, self.ctx))
            if v.size > 1:
                self.notes.append(f"{func} over the {v.size} samples")
            if not v.size:
                return math.nan
            return float(v.mean() if func == "mean" else np.sqrt(np.mean(v * v)))
        if func == "range":
            hi, u_hi = self.extreme(arg, +1)
            lo, u_lo = self.extreme(arg, -1)
            if self.fine is None and u_hi is not None:
                self.notes.append(f"range of the {self._samples()} samples, not located")
            else:
                self._where("max", u_hi, "largest", hi)
                self._where("min", u_lo, "smallest", lo)
            return hi - lo
        sense = +1 if func == "max" else -1
        v, u = self.extreme(arg, sense)
        self._where(func, u, "largest" if sense > 0 else "smallest", v)
        return v

    def _samples(self) -> int:
        return int(np.count_nonzero(self.res.ok))

    def _where(self, func: str, u: float | None, word: str, value: float = 0.0) -> None:
        """Note where an extreme ``value`` is (``u``: None for a figure that is one
        number)."""
        if u is None:
            return
        if self.fine is None:
            self.notes.append(f"{func} the {word} of the {self._samples()} samples, not located")
        elif math.isfinite(u) and math.isinf(value) and self._at_sample(u):
            self.notes.append(
                f"{func} grows without bound towards the singular position at "
                f"{self.res.format_u(u)}"
            )
        elif math.isfinite(u) and math.isinf(value):
            self.notes.append(
                f"{func} towards {self.res.format_u(u)}, where the mechanism stops closing"
            )
        elif math.isfinite(u):
            self.notes.append(f"{func} {self._place(u)}")

    def _at_sample(self, u: float) -> bool:
        """Whether ``u`` is a solved sample of the plots' sweep (a singular position the
        sweep closes through, not the edge of a range where it cannot close)."""
        fine = self.fine
        hit = np.flatnonzero(np.asarray(fine.u, float) == u)
        return bool(hit.size and np.asarray(fine.ok, bool)[hit].any())

    def _place(self, u: float) -> str:
        """Where an extreme at the driver value ``u`` is, in words. Where the quantity
        jumps where a full turn closes (a change point: its ends differ), an extreme at
        an end is that end's (the end of the turn is 360°, not its start again) and, at
        a singular position where the rates and efforts are their limits along the
        motion, said to be that limit (the value from the other side differs)."""
        fine = self.fine
        n = len(fine.u)
        at = self.res.format_u(u)
        if not (self.jumps and u in (float(fine.u[0]), float(fine.u[-1]))):
            return f"at {at}"
        k = 0 if u == float(fine.u[0]) else n - 1
        if k == n - 1:  # the end of a full turn: 360°, not its start again
            at = fine.describe_u(k).split(" (")[0]
        limits = set(fine.solution.rates_by_limit)
        if fine.forces is not None:
            limits |= set(fine.forces.effort_by_limit)
        if k in limits:
            return f"as its limit along the motion towards {at}, a singular position"
        return f"at {at}"

    def extreme(self, arg, sense: int) -> tuple[float, float | None]:
        """(the largest (sense +1) or smallest value of ``arg`` over the run, the driver
        value where it is; ``None`` for a figure that is one number already)."""
        ctx = self.fctx if self.fctx is not None else self.ctx
        q = _evaluate(arg, ctx)
        arr = np.asarray(q, float)
        if arr.size == 1:
            return float(arr.ravel()[0]), None
        s = sense * np.where(np.isfinite(arr), arr, np.nan)
        if not np.any(np.isfinite(s)):
            return math.nan, math.nan
        k = int(np.nanargmax(s))
        best, where = float(s[k]), float(ctx.res.u[k])
        # a full turn whose ends differ: the quantity jumps where the turn closes (a
        # change point), its value at either end is the limit from that end's side
        self.jumps = bool(
            ctx.res.is_full_cycle() and arr.size > 1 and not np.isclose(arr[0], arr[-1])
        )
        if self.fine is not None:
            best, where = self._locate(arg, sense, k, best, where)
        if sense < 0:  # transmission angles: the exact minimum the run located
            exact = _evaluate(arg, self.ctx)
            ex = getattr(exact, "exact_min", None)
            if ex is not None and -ex > best:
                best, where = -ex, float(getattr(exact, "exact_u", where))
        return sense * best, where

    def _locate(self, arg, sense: int, k: int, best: float, where: float):
        fine = self.fine
        u, ok, n = np.asarray(fine.u, float), fine.ok, len(fine.u)
        gaps = {e.after for e in fine.solution.events if e.kind == "dead zone"}
        lo = u[k - 1] if k > 0 and ok[k - 1] and k - 1 not in gaps else _edge(fine, k, -1)
        hi = u[k + 1] if k < n - 1 and ok[k + 1] and k not in gaps else _edge(fine, k, +1)
        sides = [(lo, hi, k)]
        if fine.is_full_cycle():  # the last sample is the first: its neighbours too
            if k == 0 and ok[n - 2] and n - 2 not in gaps:
                sides.append((u[n - 2], u[n - 1], n - 1))
            if k == n - 1 and ok[1] and 0 not in gaps:
                sides.append((u[0], u[1], 0))
        scale = fine.analysis.scale if fine.analysis.linear else 1.0
        edges = [
            e
            for e, j in ((sides[0][0], k - 1), (sides[0][1], k + 1))
            if not 0 <= j < n or not ok[j]
        ]
        for lo, hi, near in sides:
            best, where = self._narrow(arg, sense, lo, hi, near, best, where)
        for e in edges:
            if e != u[k] and abs(where - e) <= _TOL * scale and self._unbounded(arg, sense, k, e):
                return math.inf, e
        for near, e, away in gap_sides(fine.solution):  # up to each edge of a range not closing
            best, where = self._towards_edge(arg, sense, (near, away), e, best, where)
            if math.isinf(best):
                return best, where
        for near, j in self._singular_sides(arg):  # a toggle or change point it closes through
            if self._grows_towards(arg, sense, near, j):
                return math.inf, float(u[j])
        return best, where

    def _singular_sides(self, arg) -> list[tuple[int, int]]:
        """``(near, j)``: each solved sample ``j`` where ``arg`` is not determined (a
        singular position the sweep closes through or ends at: a change point, a
        toggle, where the reactions are indeterminate) with a neighbour ``near`` where
        it is; over a full turn the first and last samples are neighbours through the
        turn's end (the change point at 0° is reached from 359° towards 360°)."""
        fine = self.fine
        v = np.asarray(_evaluate(arg, self.fctx), float)
        ok, n = np.asarray(fine.ok, bool), len(fine.u)
        if v.shape != ok.shape:
            return []
        known = ok & np.isfinite(v)
        cycle = fine.is_full_cycle()
        out = []
        for j in np.flatnonzero(ok & ~np.isfinite(v)):
            near = [j - 1, j + 1]
            if cycle and j in (0, n - 1):
                near = [1, n - 2]
            out += [(int(k), int(j)) for k in near if 0 <= k < n and known[k]]
        return out

    def _grows_towards(self, arg, sense: int, near: int, j: int) -> bool:
        """Whether ``sense * arg`` grows without bound from sample ``near`` towards the
        singular sample ``j``: solved at 1e-2 ... 1e-8 of the driver coordinate from it
        (as close as it is determined: the reactions are left blank within rounding of
        the singular pose), the growth over the last three decades does not die out: each
        step at least twice the one before (a force the pose cannot carry grows as 1/d,
        its steps tenfold; a rate or effort with a limit along the motion settles, its
        steps shrinking tenfold)."""
        fine = self.fine
        u = np.asarray(fine.u, float)
        scale = fine.analysis.scale if fine.analysis.linear else 1.0
        edge = float(u[j])
        if fine.is_full_cycle() and j in (0, len(u) - 1) and abs(near - j) > 1:
            edge = float(u[-1] if j == 0 else u[0])  # through the turn's end
        away = 1.0 if float(u[near]) > edge else -1.0
        d = np.logspace(-2, -8, 7) * scale
        v = sense * self._values(arg, edge + away * d, near)
        bad = np.flatnonzero(~np.isfinite(v))
        v = v[: bad[0]] if bad.size else v  # as close as it is determined
        if v.size < 3 or d[v.size - 1] > 1e-4 * scale:
            return False
        steps = np.diff(v[-4:])  # over the last three decades determined (or two)
        return bool(np.all(steps > 0.0) and np.all(steps[1:] > 2.0 * steps[:-1]))

    def _narrow(self, arg, sense: int, lo: float, hi: float, near: int, best, where):
        """The best of ``sense * arg`` between ``lo`` and ``hi`` (solved next to sample
        ``near``) and where it is, if better than ``best``: a grid narrowed around its
        best point down to :data:`_TOL`."""
        fine = self.fine
        scale = fine.analysis.scale if fine.analysis.linear else 1.0
        anchor = min(max(float(fine.u[near]), min(lo, hi)), max(lo, hi))
        for _ in range(40):
            if not abs(hi - lo) > _TOL * scale:
                break
            x = np.linspace(lo, hi, _GRID)
            closed = np.ones(_GRID, bool)
            vals = sense * self._values(arg, x, near, closed)
            # only the motion from the anchor: past a point that does not close (a dead
            # zone to rounding at a change point) the solve may be on the other branch
            vals = _joined(vals, closed, int(np.argmin(np.abs(x - anchor))))
            if not np.any(np.isfinite(vals)):
                break
            j = int(np.nanargmax(vals))
            anchor = float(x[j])
            if vals[j] > best:
                best, where = float(vals[j]), float(x[j])
            lo, hi = x[max(j - 1, 0)], x[min(j + 1, _GRID - 1)]
        return best, where

    def _towards_edge(self, arg, sense: int, side: tuple[int, int], edge: float, best, where):
        """``(best, where)`` with the interval from solved sample ``k`` to the ``edge``
        of a range where the mechanism cannot close searched too (an extreme next to a
        dead zone between two samples lies there, not at a sample): ``(inf, edge)``
        where ``arg`` grows without bound towards the edge. A sample at the edge itself
        (the plots' sweep has one) is searched from the sample before it (``side``: ``k``
        and the step of the index away from the range)."""
        fine = self.fine
        k, away = side
        u, ok = np.asarray(fine.u, float), fine.ok
        scale = fine.analysis.scale if fine.analysis.linear else 1.0
        if abs(u[k] - edge) <= _TOL * scale:
            k = k + away
            if not (0 <= k < len(u) and ok[k]):
                return best, where
        if self._unbounded(arg, sense, k, edge):
            return math.inf, edge
        return self._narrow(arg, sense, float(u[k]), edge, k, best, where)

    def _unbounded(self, arg, sense: int, k: int, edge: float) -> bool:
        """Whether ``arg`` grows without bound (in the direction ``sense``) towards the
        ``edge`` of a range where the mechanism cannot close, beside sample ``k``: its
        growth over the last decades of the distance from the edge (1e-4, 1e-6, 1e-8 of the
        driver coordinate) does not die out, as a rate through a toggle (like 1/sqrt(d))
        does, while a position (like sqrt(d)) or a smooth quantity settles."""
        fine = self.fine
        scale = fine.analysis.scale if fine.analysis.linear else 1.0
        away = 1.0 if float(fine.u[k]) > edge else -1.0
        d = np.array([1e-4, 1e-6, 1e-8]) * scale
        if not np.all(d < abs(float(fine.u[k]) - edge)):
            return False
        v = sense * self._values(arg, edge + away * d, k)
        if not np.all(np.isfinite(v)):
            return False
        return bool(v[2] - v[1] > 2.0 * (v[1] - v[0]) > 0.0)

    def _values(self, arg, x: np.ndarray, near: int, closed: np.ndarray | None = None):
        """``arg`` at driver values ``x``, solved next to sample ``near`` of the sweep
        (``closed``, if given, is set to where the mechanism closes)."""

        fine = self.fine
        an = fine.analysis
        one = fine.solved_near(x, near)
        f = None
        if fine.forces is not None:
            f = core.forces(an, one, fine.forces.stroke_extremes)
        with np.errstate(all="ignore"):
            # a run of the same kind as the fine sweep (the results are not imported
            # here: the model's parser imports this module)
            q = _evaluate(arg, RunContext(type(fine)(an, one, f), figures=False, of=self.ctx))
        out = np.broadcast_to(np.asarray(q, float), x.shape).copy()
        out[~np.asarray(one.ok, bool)] = np.nan
        if closed is not None:
            closed[:] = np.asarray(one.ok, bool)
        return out


def _joined(vals: np.ndarray, closed: np.ndarray, c: int) -> np.ndarray:
    """``vals`` with NaN at the grid points not joined to point ``c`` by points where
    the mechanism closes (``closed``) and the value is determined."""
    keep = closed & np.isfinite(vals)
    gaps = np.flatnonzero(~keep)
    before, after = gaps[gaps < c], gaps[gaps > c]
    if before.size:
        keep[: before[-1]] = False
    if after.size:
        keep[after[0] :] = False
    return np.where(keep, vals, np.nan)


def _edge(res: Results, k: int, side: int) -> float:
    """The driver value where the motion from solved sample ``k`` meets a range of the
    sweep in which the mechanism cannot close, before (``side`` -1) or after (+1) it in
    the sweep's order: the range's located edge, else ``u[k]`` itself."""
    x = math.nan
    for f in res.solution.failures:
        if side > 0 and f.first == k + 1:
            x = f.edge_in
        elif side < 0 and f.last == k - 1:
            x = f.edge_out
    return float(x) if math.isfinite(x) else float(res.u[k])


_GRID = 65  # points of each narrowing of an extreme's interval (32 times narrower each)
# width (rad, or of the mechanism's size) at which an extreme is located: its value is
# then off by 0.5 |q''| 1e-16 at a smooth extreme, |q'| 1e-8 at a kink
_TOL = 1e-8
REDUCE = ("max", "min", "range", "mean", "rms")


def _scalar(val: Any, what: str) -> float:
    arr = np.asarray(val, float)
    if arr.size != 1:
        raise ExprError(
            f"{what} gives {arr.size} values, one per position: reduce it to one number "
            "with max(), min(), mean(), rms(), range() or at(q, u)"
        )
    return float(arr.ravel()[0])


def _show(x: float, unit: str) -> str:
    if math.isnan(x):
        return "not determined"
    if math.isinf(x):  # towards a toggle (see _Reducer._unbounded)
        return "unbounded" if x > 0 else "unbounded below"
    if unit:
        return f"{x / parse_unit(unit).factor:.6g} {unit}"
    return f"{x:.6g}"


def _check_dims(expr: Expression, ctx: RunContext) -> Any:
    driver = _LENGTH if ctx.res.linear else _ANGLE
    return expr.dimension(ctx.ref_dim, driver)


def evaluate_figure(text: str, mech: Mechanism, results: Results) -> float:
    """The value (SI) of a figure of a run, e.g. ``"range(K.y)"`` or
    ``"max(abs(input.torque))"`` (extremes located as for requirements); an
    :class:`InputError` for text that does not parse, mixes kinds of quantities or reads
    something the run does not have."""
    red = _Reducer.of(results)
    try:
        e = Expression(_rewrite(text))
        e.text = text
        _check_dims(e, red.ctx)
        return _scalar(red.value(e.tree), repr(text))
    except _Unknown as exc:
        raise InputError(f"{text!r}: {red.ctx.unknown(exc.args[0])}") from None
    except ExprError as exc:
        raise InputError(f"{text!r}: {exc}") from None


def located_extreme(text: str, results: Results, largest: bool = True) -> tuple[float, float]:
    """The largest (or smallest) value over a run of a quantity such as
    ``"abs(input.torque)"`` and the driver value where it is, located between samples as
    for requirements (``max()``, ``min()``), for any report that prints a peak;
    ``(nan, nan)`` where nothing is determined. An :class:`InputError` for text that
    does not read the run."""
    red = _Reducer.of(results)
    try:
        e = Expression(_rewrite(text))
        e.text = text
        _check_dims(e, red.ctx)
        value, where = red.extreme(e.tree, +1 if largest else -1)
    except _Unknown as exc:
        raise InputError(f"{text!r}: {red.ctx.unknown(exc.args[0])}") from None
    except ExprError as exc:
        raise InputError(f"{text!r}: {exc}") from None
    return value, (math.nan if where is None else where)


def _closes(r: Requirement, results: Results) -> Verdict:
    """The verdict of ``full turn``: every position solved over a full turn, and no
    dead zone stepped over between two samples (the loop cannot close there, so the
    crank does not turn fully even though every sample closes)."""
    n = len(results.u)
    solved = int(np.count_nonzero(results.ok))
    zones = [e for e in results.solution.events if e.kind == "dead zone"]
    full = bool(results.is_full_cycle()) and solved == n and not zones
    if full:
        msg = f"assembles over the whole turn ({solved} of {n} positions): pass"
    elif zones:
        e = zones[0]
        fu = results.format_u
        span = (
            f"between {fu(e.edge_in)} and {fu(e.edge_out)}"
            if math.isfinite(e.edge_in) and math.isfinite(e.edge_out)
            else f"near {fu(e.u)}"
        )
        more = f" (and {len(zones) - 1} more such range(s))" if len(zones) > 1 else ""
        k = min(e.after + 1, n - 1)
        msg = (
            f"{e.group} cannot close {span}{more} (a range the sweep steps over, between "
            f"its samples at {fu(float(results.u[e.after]))} and {fu(float(results.u[k]))})"
            ": the crank does not turn fully: FAIL"
        )
    else:
        msg = (
            f"assembles at {solved} of {n} positions"
            + ("" if results.is_full_cycle() else "; the sweep is not a full turn")
            + ": FAIL"
        )
    return Verdict(r.name, r.text, float(solved), float(n), "", full, msg)


def check_requirements(mech: Mechanism, results: Results) -> list[Verdict]:
    """Check every requirement of ``mech`` on ``results`` (``[]`` when there are none).
    A requirement that reads something the run does not have, or mixes kinds of
    quantities, is an input error located at its line."""
    reqs: list[Requirement] = getattr(mech, "requirements", []) or []
    if not reqs:
        return []
    red = _Reducer.of(results) if any(r.expr is not None for r in reqs) else None
    out = []
    for r in reqs:
        if r.expr is None or red is None:
            out.append(_closes(r, results))
            continue
        tree = r.expr.tree
        red.notes = []
        try:
            _check_dims(r.expr, red.ctx)
            reads = [any(isinstance(n, Ref) for n in walk(t)) for t in tree.operands]
            k = reads.index(True)
            fig_dim = dimension_of_side(tree.operands[k], red.ctx)
            value = _scalar(red.value(tree.operands[k]), "the figure")
            limit = _scalar(red.value(tree.operands[1 - k]), "the limit")
        except _Unknown as exc:
            raise mech.error(("requirements", r.name), red.ctx.unknown(exc.args[0])) from None
        except ExprError as exc:
            raise mech.error(("requirements", r.name), str(exc)) from None
        unit = r.unit or _unit_for(tree.operands[k], red.ctx, fig_dim)
        left, right = (value, limit) if k == 0 else (limit, value)
        ok = bool(
            not math.isnan(value)
            and Expression._derived(Compare(tree.ops, (Num(left), Num(right))), "", ()).evaluate(
                red.ctx
            )
        )
        figure = re.split(r"<=|>=|==|!=|<|>", r.text)[k].strip()
        notes = ""
        if red.notes and not math.isnan(value):
            said = list(red.notes)
            if len(said) == 1 and said[0].split(" ", 1)[0] in ("max", "min"):
                said = [said[0].split(" ", 1)[1]]  # one extreme: "at driver angle ..."
            notes = f" ({'; '.join(said)})"
        shown = f"{figure} = {_show(value, unit)}{notes} {tree.ops[0]} {_show(limit, unit)}"
        if k == 1:
            shown = f"{_show(limit, unit)} {tree.ops[0]} {figure} = {_show(value, unit)}{notes}"
        out.append(
            Verdict(
                r.name, r.text, value, limit, unit, ok, f"{shown}: " + ("pass" if ok else "FAIL")
            )
        )
    return out


def dimension_of_side(tree, ctx: RunContext) -> Any:
    """The dimension of one side of a requirement, from the run's columns."""
    return dimension_of(tree, ctx.ref_dim, _LENGTH if ctx.res.linear else _ANGLE)


def _unit_for(tree, ctx: RunContext, dim: Any) -> str:
    """The unit to show a figure in when its limit has none: the unit of the one column
    it reads (degrees for angles) if the figure is of that column's kind, else SI."""
    refs = {f"{n.name}.{n.attr}" for n in walk(tree) if isinstance(n, Ref)}
    units = {ctx.units.get(k, "") for k in refs}
    if len(units) == 1:
        (u,) = units
        try:
            if u and parse_unit(u).dim == dim:
                return u
        except UnitError:
            return ""
    return ""


def verdict_table(verdicts: list[Verdict]) -> str:
    """The pass/fail table that ``mechsolve run`` prints."""
    failed = sum(not v.passed for v in verdicts)
    head = f"requirements: {len(verdicts) - failed} of {len(verdicts)} pass" + (
        f", {failed} FAIL" if failed else ""
    )
    width = max(len(v.name) for v in verdicts)
    rows = [f"  {'PASS' if v.passed else 'FAIL'}  {v.name:<{width}}  {v.message}" for v in verdicts]
    return "\n".join([head, *rows])


def junit_xml(verdicts: list[Verdict], suite: str, file: str = "") -> str:
    """A JUnit XML report: one test case per requirement, the measured value and the
    limit in a failure's message."""
    import xml.etree.ElementTree as ET

    failed = sum(not v.passed for v in verdicts)
    ts = ET.Element(
        "testsuite",
        name=f"requirements of {suite}",
        tests=str(len(verdicts)),
        failures=str(failed),
        errors="0",
        skipped="0",
    )
    for v in verdicts:
        tc = ET.SubElement(ts, "testcase", classname=f"mechsolve.{suite}", name=v.name)
        if file:
            tc.set("file", file)
        if not v.passed:
            f = ET.SubElement(tc, "failure", message=v.message, type="RequirementFailed")
            f.text = f"{v.text}\n{v.message}"
        else:
            out = ET.SubElement(tc, "system-out")
            out.text = v.message
    suites = ET.Element("testsuites", tests=str(len(verdicts)), failures=str(failed))
    suites.append(ts)
    ET.indent(suites)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(suites, "unicode") + "\n"


__all__ += ["RunContext", "FULL_TURN"]
