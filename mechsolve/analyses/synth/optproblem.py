"""The optimising sections of a synthesis problem file (``function:``, ``path:``): their
reading, the table of the designs found, the check by mechsolve's own run of the written
file, and the plot of the target against what the written mechanism achieves.

``function:`` (function generation, :mod:`.function_gen`)::

    function:
      y: log(x) / log(10)          # an expression of x (the expression language)
      x: [1, 2]
      input: {start: 45 deg, range: 60 deg}     # the crank's angle over the range of x
      output: {start: 135 deg, range: 90 deg}   # the rocker's angle over the range of y
      frame: 1                     # |O2 O4|
      points: 3                    # Chebyshev-spaced precision points; or at: [x1, x2, x3]
      min_transmission: 30 deg     # optional
      optimise: {samples: 101, max_iter: 300, popsize: 30, top: 5,
                 crank: [lo, hi], coupler: [lo, hi], rocker: [lo, hi],
                 input_start: [lo, hi], output_start: [lo, hi]}   # or false
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from mechsolve.analyses.synth.common import Design
from mechsolve.analyses.synth.writer import Numbers
from mechsolve.base.errors import InputError
from mechsolve.base.units import OutputUnits

__all__ = ["solve_optimised", "confirm_optimised", "describe_optimised", "write_plot"]


def solve_optimised(
    r: Any, method: str, name: str, solution: int | None, digits: int | None = None, **kw
):
    """(designs, chosen, mechanism text, check) of a function or path problem read by
    ``r`` (the problem file's section reader); the text's numbers to ``digits``
    significant digits (every digit for ``None``), its lengths in the problem's unit."""
    if method == "function":
        spec = _function_spec(r)
        from mechsolve.analyses.synth.function_gen import function_yaml, solve_function

        res = solve_function(spec, **kw)
        designs = res.designs
        chosen = _choose(designs, solution, key=lambda d: d.extra["max_error"])
        text = function_yaml(chosen, name, spec, unit=r.length, digits=digits)
        return designs, chosen, text, {"result": res, "spec": spec, "search": res.search}
    from mechsolve.analyses.synth.path_gen import path_yaml, read_path, solve_path

    spec = read_path(r)
    res = solve_path(spec, **kw)
    designs = res.designs
    if not designs:
        why = res.why or "no design met the constraints"
        raise r.err((), f"no linkage found: {why}")
    chosen = _choose(designs, solution, key=lambda d: d.extra["objective"])
    text = path_yaml(chosen, name, spec, digits=digits)
    return designs, chosen, text, {"result": res, "spec": spec, "search": res.search}


def _choose(designs: list[Design], solution: int | None, key) -> Design:
    if solution is not None:
        if not 1 <= solution <= len(designs):
            raise InputError(
                f"--solution {solution}: the problem has {len(designs)} design(s), "
                f"numbered 1 to {len(designs)}"
            )
        d = designs[solution - 1]
        if not d.valid:
            raise InputError(f"--solution {solution} is not valid: {'; '.join(d.notes)}")
        return d
    ok = [d for d in designs if d.valid]
    if not ok:
        why = "; ".join(f"{d.family}: {', '.join(d.notes)}" for d in designs) or "none found"
        raise InputError(f"no valid design ({why})")
    return min(ok, key=key)


# -- reading ------------------------------------------------------------------------------


def _range_of(r, key: str, kinds: str = "number") -> tuple[float, float]:
    v = r.data.get(key)
    if not (isinstance(v, list) and len(v) == 2):
        raise r.err(key, f"expected [first, last], got {v!r}")
    out = []
    for i, e in enumerate(v):
        if kinds == "number":
            if isinstance(e, str):
                try:
                    e = float(e)
                except ValueError:
                    raise r.err((key, i), f"expected a number, got {e!r}") from None
            if isinstance(e, bool) or not isinstance(e, (int, float)) or not math.isfinite(e):
                raise r.err((key, i), f"expected a number, got {e!r}")
            out.append(float(e))
        else:
            out.append(r.q((key, i), kinds, e))
    return out[0], out[1]


def _start_range(r, key: str) -> tuple[float, float]:
    v = r.data.get(key)
    if not (isinstance(v, dict) and set(v) == {"start", "range"}):
        raise r.err(key, "expected {start: angle, range: angle}")
    start = r.q((key, "start"), "angle", v["start"])
    rng = r.q((key, "range"), "angle", v["range"])
    if not 0 < abs(rng) < 2 * math.pi:
        raise r.err((key, "range"), "the range must be non-zero and less than a full turn")
    return start, rng


def _function_spec(r):
    from mechsolve.analyses.synth.function_gen import FunctionSpec
    from mechsolve.model.expr import ExprError
    from mechsolve.model.expr.expression import Expression

    r.allow(("y", "x", "input", "output", "frame", "points", "at", "min_transmission",
             "optimise"))  # fmt: skip
    text = r.data.get("y")
    if not isinstance(text, str):
        raise r.err("y", "expected the function of x as an expression, e.g. 'log(x)'")
    try:
        expr = Expression(text, variables=("x",))
    except ExprError as exc:
        raise r.err("y", str(exc)) from None

    def f(x):
        try:
            return expr.evaluate_at({"x": x})
        except ExprError as exc:
            raise r.err("y", str(exc)) from None

    xr = _range_of(r, "x")
    if xr[0] == xr[1]:
        raise r.err("x", "the range of x must have two different ends")
    phi_s, phi_r = _start_range(r, "input")
    psi_s, psi_r = _start_range(r, "output")
    frame = r.q("frame", "length")
    if not frame > 0:
        raise r.err("frame", "the frame length must be positive")
    at = None
    points = 3
    if r.has("at") and r.has("points"):
        raise r.err("at", "give the precision points' x ('at') or their number ('points')")
    if r.has("at"):
        v = r.data["at"]
        if not isinstance(v, list):
            raise r.err("at", "expected a list of x values")
        at = [float(_num(r, ("at", i), e)) for i, e in enumerate(v)]
        points = len(at)
        lo, hi = sorted(xr)
        for i, x in enumerate(at):
            if not lo <= x <= hi:
                raise r.err(("at", i), f"x = {x:g} is outside the range {lo:g} .. {hi:g}")
    elif r.has("points"):
        points = int(_num(r, "points", r.data["points"], integer=True))
    if points < 3:
        raise r.err(
            "at" if at is not None else "points",
            f"{points} precision point(s): Freudenstein's equation has three unknowns "
            "(K1, K2, K3), give at least 3",
        )
    spec = FunctionSpec(
        f=f, x_range=xr, phi_start=phi_s, phi_range=phi_r, psi_start=psi_s,
        psi_range=psi_r, frame=frame, points=points, at=at, description=f"y = {text}",
    )  # fmt: skip
    if r.has("min_transmission"):
        mu = r.q("min_transmission", "angle")
        if not 0 <= mu < math.pi / 2:
            raise r.err("min_transmission", "expected an angle from 0 to 90 deg (excluded)")
        spec.min_transmission = mu
    _optimise_options(r, spec, lengths=("crank", "coupler", "rocker"),
                      angles=("input_start", "output_start"))  # fmt: skip
    return spec


def _num(r, key, v, integer: bool = False) -> float:
    if isinstance(v, str):
        try:
            v = float(v)
        except ValueError:
            raise r.err(key, f"expected a number, got {v!r}") from None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise r.err(key, f"expected a number, got {v!r}")
    if integer and v != int(v):
        raise r.err(key, f"expected a whole number, got {v!r}")
    return v


def _optimise_options(r, spec, lengths: tuple[str, ...], angles: tuple[str, ...]) -> None:
    """The ``optimise`` mapping (or false) into ``spec``."""
    v = r.data.get("optimise")
    if v is None or v is True:
        return
    if v is False:
        spec.optimise = False
        return
    if not isinstance(v, dict):
        raise r.err("optimise", "expected false or a mapping of options and bounds")
    ints = {"samples": 11, "max_iter": 1, "popsize": 5, "top": 1}
    for k, e in v.items():
        key = ("optimise", k)
        if k in ints:
            n = int(_num(r, key, e, integer=True))
            if n < ints[k]:
                raise r.err(key, f"expected a whole number >= {ints[k]}")
            setattr(spec, k, n)
        elif k in lengths or k in angles:
            kind = "length" if k in lengths else "angle"
            if not (isinstance(e, list) and len(e) == 2):
                raise r.err(key, f"expected bounds [lowest, highest], got {e!r}")
            lo, hi = (r.q(key + (i,), kind, e[i]) for i in (0, 1))
            if not lo < hi:
                raise r.err(key, "the lower bound must be below the upper one")
            spec.bounds[k] = (lo, hi)
        else:
            known = ", ".join([*ints, *lengths, *angles])
            raise r.err(key, f"unknown key (expected one of: {known})")


# -- output -------------------------------------------------------------------------------


def describe_optimised(out: Any) -> str:
    """The designs as a table (best first after the textbook one) and the search."""
    check = out.check
    lines = [f"{out.name}: {out.method} generation, {len(out.designs)} design(s)"]
    found = check.get("search")
    if found is not None:
        lines.append(
            f"  differential evolution: {found.generations} generations, "
            f"{found.evaluations} batches of {len(found.population)} designs, "
            f"{found.seconds:.2f} s (seed {found.seed}); stopped: {found.stopped}"
        )
    if out.method == "function":
        head = f"  #  design                 crank      coupler    rocker     frame ({out.unit})" \
               "  max error (deg)  min transmission (deg)  Grashof"  # fmt: skip
        lines.append(head)
        k = Numbers(out.unit).factor
        for i, d in enumerate(out.designs, 1):
            L = {n: v / k for n, v in d.lengths.items()}
            mark = "*" if d is out.chosen else " "
            bad = "" if d.valid else "  INVALID: " + "; ".join(d.notes)
            ok = math.isfinite(d.extra["max_error"])  # the loop closes over the range
            lines.append(
                f" {mark}{i:<2} {d.family:<22} {L['crank']:<10.6f} {L['coupler']:<10.6f} "
                f"{L['rocker']:<10.6f} {L['frame']:<10.6f} "
                f"{_deg_or_dash(d.extra['max_error'], 6, 16)} "
                f"{_deg_or_dash(d.min_transmission if ok else math.nan, 4, 23)} "
                f"{d.grashof}{bad}"
            )
    else:
        from mechsolve.analyses.synth.path_gen import describe_rows

        lines += describe_rows(out)
    lines.append("  written (*): the valid design with the smallest error (or --solution N)")
    return "\n".join(lines)


def _deg_or_dash(x: float, digits: int, width: int) -> str:
    """An angle (rad) in deg, or '-' where it does not exist (the loop does not close)."""
    text = f"{math.degrees(x):.{digits}f}" if math.isfinite(x) else "-"
    return f"{text:<{width}}"


def confirm_optimised(out: Any) -> str:
    """Solve the written file with mechsolve and report the errors its run gives."""
    if out.method == "function":
        from mechsolve.analyses.synth.function_gen import verify

        ch = verify(out.yaml, out.chosen, out.check["result"])
        out.check["verified"] = ch
        parts = []
        if len(ch.phi_points):
            xs = out.chosen.extra["precision_x"]
            parts.append(
                "error at the precision points "
                + ", ".join(
                    f"x = {x:.6g}: {math.degrees(e):.3e} deg" for x, e in zip(xs, ch.error_points)
                )
            )
        parts.append(
            f"largest error over the range ({len(ch.phi)} positions) "
            f"{math.degrees(float(np.max(np.abs(ch.error)))):.6f} deg"
        )
        return "  mechsolve run of the written file: " + "; ".join(parts)
    from mechsolve.analyses.synth.path_gen import verify_path

    ch = verify_path(out.yaml, out.chosen, out.check["result"])
    out.check["verified"] = ch
    k, u = Numbers(out.unit).factor, out.unit
    return (
        "  mechsolve run of the written file: distance of the coupler point from each "
        "target point "
        + ", ".join(f"{e / k:.3e}" for e in ch.distances)
        + f" {u} (largest {float(np.max(ch.distances)) / k:.3e} {u}); "
        + (
            "precision points reached in order on one branch"
            if ch.in_order
            else "ORDER DEFECT: the points are not reached in order"
        )  # fmt: skip
    )


def write_plot(out: Any, path: Path) -> Path:
    """Target against achieved (by mechsolve's run of the written file), as a PNG."""
    from mechsolve.base.atomic import replacing
    from mechsolve.writers.fonts import pyplot
    from mechsolve.writers.plots import length_axes, pretty_figure

    plt = pyplot()
    if out.method in ("four-positions", "five-positions"):
        from mechsolve.analyses.synth.burmester import plot_curves
        from mechsolve.analyses.synth.burmester5 import plot_five

        fig = plot_curves(plt, out) if out.method == "four-positions" else plot_five(plt, out)
        pretty_figure(fig)
        try:
            with replacing(path, suffix=".png") as tmp:
                fig.savefig(tmp, format="png", dpi=110)
        finally:
            plt.close(fig)
        return path
    ch = out.check.get("verified")
    if ch is None:
        confirm_optimised(out)
        ch = out.check["verified"]
    if out.method == "function":
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        phi = np.degrees(ch.phi)
        ax1.plot(phi, np.degrees(ch.psi_want), label="target psi = f(phi)")
        ax1.plot(phi, np.degrees(ch.psi_want + ch.error), "--", label="achieved (mechsolve run)")
        ax1.set_ylabel("output angle psi (deg)")
        ax1.legend()
        ax2.plot(phi, np.degrees(ch.error))
        ax2.plot(np.degrees(ch.phi_points), np.degrees(ch.error_points), "o",
                 label="precision points")  # fmt: skip
        ax2.set_xlabel("input angle phi (deg)")
        ax2.set_ylabel("structural error (deg)")
        ax2.axhline(0, color="0.6", lw=0.8)
        if len(ch.phi_points):
            ax2.legend()
    else:
        fig, ax1 = plt.subplots(figsize=(7, 6))
        ax1.plot(ch.curve_x, ch.curve_y, "-", color="0.5", label="coupler curve (mechsolve run)")
        tx, ty = np.array(ch.targets).T
        ax1.plot(tx, ty, "o", mfc="none", ms=9, label="target points")
        ax1.plot(ch.reached_x, ch.reached_y, "x", label="reached")
        ax1.set_aspect("equal", adjustable="datalim")
        unit = length_axes(ax1, OutputUnits(length=out.unit))
        ax1.set_xlabel(f"x ({unit})")
        ax1.set_ylabel(f"y ({unit})")
        ax1.legend()
    ax1.set_title(f"{out.name}: {out.chosen.family}")
    fig.tight_layout()
    pretty_figure(fig)
    try:
        with replacing(path, suffix=".png") as tmp:
            fig.savefig(tmp, format="png", dpi=110)
    finally:
        plt.close(fig)
    return path
