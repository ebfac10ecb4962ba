"""Requirements: named checks on the figures of a run (the ``requirements:`` section).

A requirement is a comparison of a figure of the run with a limit, written in the
expression language of conditions (:mod:`mechsolve.expr`) with the reductions that turn a
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

Reductions: ``min(q)``, ``max(q)``, ``mean(q)`` (over the samples), ``rms(q)``,
``range(q)`` (max − min), ``at(q, u)`` (q at the driver value u, cubic between samples);
``abs`` and the other functions act position by position. Positions that did not solve
are left out of a reduction; a figure that is not determined (no solved position) fails
its requirement and says so.
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from .errors import InputError
from .expr import Compare, ExprError, Expression, Ref, walk
from .units import UnitError, parse_unit

# (the model and the results are not imported: the model's parser imports this module)
Mechanism = Any
Results = Any

__all__ = [
    "Requirement",
    "Verdict",
    "check_requirements",
    "evaluate_figure",
    "junit_xml",
    "parse_requirement",
    "verdict_table",
]

FULL_TURN = "full turn"
_OPS = ("<=", ">=", "==", "!=", "<", ">")


@dataclass
class Requirement:
    """One named requirement as the file gives it."""

    name: str
    text: str
    expr: Expression | None  # None: the assembly requirement ("full turn")
    unit: str = ""  # the unit the limit is written in (for display), "" for SI


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


def _rewrite(text: str) -> str:
    """``time_ratio(ram)`` is the figure ``ram.time_ratio``; likewise swing and stroke."""
    return re.sub(r"\b(time_ratio|swing|stroke)\(\s*([^\W\d]\w*)\s*\)", r"\2.\1", text)


def parse_requirement(name: str, text: Any) -> Requirement:
    """Read one requirement; raises :class:`ExprError` with the reason when it is not a
    comparison of a figure with a limit."""
    if not isinstance(text, str):
        raise ExprError(
            "a requirement is a comparison such as 'max(abs(input.torque)) <= 300 kN m', "
            f"or 'full turn'; got {text!r}"
        )
    if text.strip().lower() in (FULL_TURN, "assembles: full turn", "assembles full turn"):
        return Requirement(name, text, None)
    expr = Expression(_rewrite(text))
    tree = expr.tree
    if not isinstance(tree, Compare) or len(tree.ops) != 1:
        raise ExprError(
            "a requirement compares one figure with a limit, e.g. "
            "'min(transmission_angle.B) >= 40 deg'"
        )
    reads = [any(isinstance(n, Ref) for n in walk(side)) for side in tree.operands]
    if reads.count(True) != 1:
        raise ExprError(
            "one side of the comparison must read the run (e.g. max(K.y)) and the other "
            "be a limit (e.g. 2 m)"
        )
    limit_text = re.split(r"<=|>=|==|!=|<|>", text)[1 if reads[0] else 0]
    return Requirement(name, text, expr, _unit_of(limit_text))


def _unit_of(limit_text: str) -> str:
    m = re.fullmatch(r"\s*[-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?\s*(.*?)\s*", limit_text)
    if not m or not m.group(1):
        return ""
    try:
        parse_unit(m.group(1))
    except UnitError:
        return ""
    return m.group(1)


class _Exact(np.ndarray):
    """Transmission angles over the sweep, with their exact minimum between samples
    (the attribute is lost by arithmetic: only ``min(transmission_angle.X)`` uses it)."""

    exact_min: float | None = None


class _Unknown(KeyError):
    pass


class RunContext:
    """What a requirement reads from a run (see the module's docstring)."""

    def __init__(self, results: Results) -> None:
        self.res = results
        self.values: dict[str, Any] = {}
        self.units: dict[str, str] = {}
        joints: dict[str, list[str]] = {}
        for c in results.columns():
            try:
                factor = parse_unit(c.unit).factor if c.unit else 1.0
            except UnitError:
                factor = 1.0
            self.values[c.name] = np.asarray(c.values, float) * factor
            self.units[c.name] = c.unit
            head, _, attr = c.name.rpartition(".")
            if "(" in head:
                joints.setdefault(f"{head.split('(')[0]}.{attr}", []).append(c.name)
        for alias, cols in joints.items():
            if len(cols) == 1 and alias not in self.values:
                self.values[alias] = self.values[cols[0]]
                self.units[alias] = self.units[cols[0]]
        self._figures()

    def _figures(self) -> None:
        res = self.res
        sol = res.solution
        plan = res.analysis.plan
        exact = {t.group: t.angle for t in res.transmission_angles()}
        for gi, g in enumerate(plan):
            if g.n_modes != 2 or not sol.indicator.size:
                continue
            key = g.label.split()[1] if g.label.startswith("loop ") else g.label
            mu = np.arcsin(np.clip(np.where(sol.ok, sol.indicator[gi], np.nan), 0.0, 1.0))
            arr = mu.view(_Exact)
            arr.exact_min = exact.get(g.label)
            self.values[f"transmission_angle.{key}"] = arr
            self.units[f"transmission_angle.{key}"] = "deg"
        for lp in res.limit_positions():
            kind = "stroke" if lp.kind == "slider" else "swing"
            self.values[f"{lp.name}.{kind}"] = lp.high - lp.low
            self.units[f"{lp.name}.{kind}"] = "m" if lp.kind == "slider" else "deg"
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

    def unknown(self, key: str) -> str:
        near = difflib.get_close_matches(key, list(self.values), n=3, cutoff=0.6)
        hint = f" (did you mean {', '.join(near)}?)" if near else ""
        return (
            f"the run has no quantity {key!r}{hint}; requirements read the columns of "
            "results.csv (K.y, input.torque, power.residual...), transmission_angle.<loop>, "
            "<rocker>.swing, <rocker>.time_ratio, <slider>.stroke and cycle.work"
        )

    def functions(self) -> dict[str, Any]:
        u = np.asarray(self.res.u, float)

        def finite(q):
            q = np.atleast_1d(np.asarray(q, float))
            return q[np.isfinite(q)]

        def reduce(f):
            def g(q):
                v = finite(q)
                return float(f(v)) if v.size else math.nan

            return g

        def minimum(q):
            ex = getattr(q, "exact_min", None)
            v = finite(q)
            best = float(v.min()) if v.size else math.nan
            return min(best, ex) if ex is not None and v.size else best

        def at(q, where):
            from scipy.interpolate import CubicSpline

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

        return {
            "min": minimum,
            "max": reduce(np.max),
            "mean": reduce(np.mean),
            "rms": reduce(lambda v: np.sqrt(np.mean(v * v))),
            "range": reduce(lambda v: v.max() - v.min()),
            "at": at,
        }


def _value(tree, ctx: RunContext) -> Any:
    e = Expression._derived(tree, "", ())
    with np.errstate(all="ignore"):
        return e.evaluate(ctx, ctx.functions())


def _scalar(val: Any, what: str) -> float:
    arr = np.asarray(val, float)
    if arr.size != 1:
        raise ExprError(
            f"{what} gives {arr.size} values, one per position: reduce it to one number "
            "with max(), min(), mean(), rms(), range() or at(q, u)"
        )
    return float(arr.ravel()[0])


def _show(x: float, unit: str) -> str:
    if not math.isfinite(x):
        return "not determined"
    if unit:
        return f"{x / parse_unit(unit).factor:.6g} {unit}"
    return f"{x:.6g}"


def evaluate_figure(text: str, mech: Mechanism, results: Results) -> float:
    """The value (SI) of a figure of a run, e.g. ``"range(K.y)"`` or
    ``"max(abs(input.torque))"``; an :class:`InputError` for text that does not parse or
    reads something the run does not have."""
    ctx = RunContext(results)
    try:
        e = Expression(_rewrite(text))
        return _scalar(_value(e.tree, ctx), repr(text))
    except _Unknown as exc:
        raise InputError(f"{text!r}: {ctx.unknown(exc.args[0])}") from None
    except ExprError as exc:
        raise InputError(f"{text!r}: {exc}") from None


def check_requirements(mech: Mechanism, results: Results) -> list[Verdict]:
    """Check every requirement of ``mech`` on ``results`` (``[]`` when there are none).
    A requirement that reads something the run does not have is an input error located
    at its line."""
    reqs: list[Requirement] = getattr(mech, "requirements", []) or []
    if not reqs:
        return []
    ctx = RunContext(results)
    out = []
    for r in reqs:
        if r.expr is None:
            n = len(results.u)
            solved = int(np.count_nonzero(results.ok))
            full = bool(results.is_full_cycle()) and solved == n
            msg = (
                f"assembles over the whole turn ({solved} of {n} positions): pass"
                if full
                else f"assembles at {solved} of {n} positions"
                + ("" if results.is_full_cycle() else "; the sweep is not a full turn")
                + ": FAIL"
            )
            out.append(Verdict(r.name, r.text, float(solved), float(n), "", full, msg))
            continue
        tree = r.expr.tree
        try:
            sides = [_value(t, ctx) for t in tree.operands]
            reads = [any(isinstance(n, Ref) for n in walk(t)) for t in tree.operands]
            k = reads.index(True)
            value = _scalar(sides[k], "the figure")
            limit = _scalar(sides[1 - k], "the limit")
        except _Unknown as exc:
            raise mech.error(("requirements", r.name), ctx.unknown(exc.args[0])) from None
        except ExprError as exc:
            raise mech.error(("requirements", r.name), str(exc)) from None
        unit = r.unit or _unit_for(tree.operands[k], ctx)
        left, right = (value, limit) if k == 0 else (limit, value)
        ok = bool(
            math.isfinite(value)
            and Expression._derived(Compare(tree.ops, (_num(left), _num(right))), "", ()).evaluate(
                ctx
            )
        )
        figure = re.split(r"<=|>=|==|!=|<|>", r.text)[k].strip()
        shown = f"{figure} = {_show(value, unit)} {tree.ops[0]} {_show(limit, unit)}"
        if k == 1:
            shown = f"{_show(limit, unit)} {tree.ops[0]} {figure} = {_show(value, unit)}"
        out.append(
            Verdict(
                r.name, r.text, value, limit, unit, ok, f"{shown}: " + ("pass" if ok else "FAIL")
            )
        )
    return out


def _num(x: float):
    from .expr import Num

    return Num(x)


def _unit_for(tree, ctx: RunContext) -> str:
    """The unit to show a figure in when its limit has none: the unit of the one column
    it reads (degrees for angles), else SI."""
    refs = {f"{n.name}.{n.attr}" for n in walk(tree) if isinstance(n, Ref)}
    units = {ctx.units.get(k, "") for k in refs}
    if len(units) == 1:
        (u,) = units
        try:
            parse_unit(u)
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
