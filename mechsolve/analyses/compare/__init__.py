"""``mechsolve compare``: several schemes of one machine side by side (seed 001, chapter 2:
the shaper's three schemes of the main motion, judged before one is chosen).

:func:`compare` solves each scheme over one turn of its crank and computes the same
figures for each (:mod:`.figures` defines them), :mod:`.table` prints them side by side
and writes them as a tidy CSV (one row per scheme, every column with its unit), and
:mod:`.plots` overlays the outputs' curves, one line per scheme.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from mechsolve.analyses.compare.figures import (
    STEP,
    Output,
    SchemeFigures,
    check_comparable,
    parse_scheme,
    resolve_output,
    scheme_figures,
)
from mechsolve.analyses.compare.table import comparison_text, write_csv
from mechsolve.base.errors import InputError
from mechsolve.base.units import OutputUnits
from mechsolve.model.parse import load, variants

__all__ = [
    "STEP",
    "Comparison",
    "Output",
    "SchemeFigures",
    "compare",
    "expand_schemes",
    "parse_middle",
    "parse_scheme",
    "resolve_output",
]


@dataclass
class Comparison:
    """The figures of every scheme, in the order given."""

    schemes: list[SchemeFigures]
    delta: float
    middle: float

    @property
    def check_failed(self) -> bool:
        """A requirement of some scheme failed (exit 5)."""
        return any(s.failed for s in self.schemes)

    def text(self, units: OutputUnits | None = None) -> str:
        """The figures side by side, each with its unit (what the command prints), in
        ``units`` (None: the SI text)."""
        return comparison_text(self, units)

    def to_csv(self, path: str | Path, units: OutputUnits | None = None) -> Path:
        """The tidy table (one row per scheme) in ``units`` (default SI), written
        atomically; returns the path."""
        return write_csv(self, Path(path), units)

    def write_plots(
        self, outdir: str | Path, fmt: str = "png", units: OutputUnits | None = None
    ) -> list[Path]:
        """The overlaid curves (velocity, displacement, driving torque) in ``units``
        (None: the SI figures), written atomically into ``outdir``; returns the files
        written."""
        from mechsolve.analyses.compare.plots import write_plots

        return write_plots(self, Path(outdir), fmt, units)


def parse_middle(text: str | float) -> float:
    """The part of the working stroke for the uniformity, in per cent (``80``, ``80%``)
    as a fraction. Raises :class:`InputError` for anything but (0, 100] %."""
    raw = str(text).strip().removesuffix("%").strip()
    try:
        value = float(raw) / 100
    except ValueError:
        raise InputError(f"--middle {text!r}: expected a percentage such as 80 or 80%") from None
    if not (math.isfinite(value) and 0 < value <= 1):
        raise InputError(f"--middle {text!r}: the part of the working stroke is in (0, 100] %")
    return value


def expand_schemes(
    items: Sequence[str | Path | tuple[str | Path, str | None]], all_variants: bool = False
) -> list[tuple[Path, str | None]]:
    """The schemes as (file, variant): ``FILE``, ``FILE@VARIANT`` or a pair; with
    ``all_variants``, each file stands for itself and each of its variants."""
    out: list[tuple[Path, str | None]] = []
    for item in items:
        file, variant = (Path(item[0]), item[1]) if isinstance(item, tuple) else parse_scheme(item)
        if all_variants and variant is None:
            if not file.exists():
                raise InputError(f"{file}: no such file")
            out.append((file, None))
            out += [(file, v) for v in variants(file)]
        else:
            out.append((file, variant))
    return out


def _checked_schemes(schemes, outputs, delta: float, middle: float, all_variants: bool):
    """The (file, variant) pairs and each one's output, after the checks of the options:
    at least one scheme, ``middle`` and ``delta`` in range, one output or one per scheme,
    no scheme (and output) given twice."""
    pairs = expand_schemes(schemes, all_variants)
    if not pairs:
        raise InputError("compare: give at least one scheme (a mechanism file)")
    if not (0 < middle <= 1):
        raise InputError(
            f"--middle {middle * 100:g} %: the part of the working stroke is above 0 and at "
            "most 100 %"
        )
    if not (0 < delta < 1):
        raise InputError(f"--delta {delta!r}: the coefficient of fluctuation is between 0 and 1")
    outs = list(outputs or [])
    if len(outs) not in (0, 1, len(pairs)):
        raise InputError(
            f"--output is given {len(outs)} times for {len(pairs)} schemes: give it once "
            "(the same output for all) or once per scheme, in their order"
        )
    specs = [outs[k] if len(outs) > 1 else (outs[0] if outs else None) for k in range(len(pairs))]
    seen = set()
    for (file, variant), spec in zip(pairs, specs):
        key = (str(file.resolve()), variant, spec)
        if key in seen:
            what = f"{file}@{variant}" if variant else str(file)
            raise InputError(f"{what}: the same scheme (and output) is given twice")
        seen.add(key)
    return pairs, specs


def _names(mechs, pairs, specs) -> list[str]:
    """Each scheme's name, told apart by its file or its output where two would be one."""
    names = [m.name + (f" ({v})" if v else "") for m, (_, v) in zip(mechs, pairs)]
    if len(set(names)) < len(names):  # two files of one name: tell them apart
        if len({f.resolve() for f, _ in pairs}) > 1:
            names = [n + f" [{f.name}]" for n, (f, _) in zip(names, pairs)]
    if len(set(names)) < len(names):  # one scheme, two outputs
        names = [n + (f" [{spec}]" if spec else "") for n, spec in zip(names, specs)]
    return names


def compare(
    schemes: Sequence[str | Path | tuple[str | Path, str | None]],
    *,
    outputs: Sequence[str] | None = None,
    delta: float = 1 / 40,
    middle: float = 0.8,
    method: str | None = None,
    all_variants: bool = False,
) -> Comparison:
    """Solve each scheme over one turn of its crank and compute its figures.

    Parameters
    ----------
    schemes
        Mechanism files: ``"A.yaml"``, ``"A.yaml@variant"`` or ``(path, variant)``.
    outputs
        The output of each scheme (:func:`resolve_output`): one for all, or one per
        scheme in order; default: each file's first output point or slider.
    delta
        The coefficient of speed fluctuation the flywheel is sized for.
    middle
        The fraction of the working stroke, centred, over which the velocity's
        uniformity is measured (0 < middle <= 1).
    method
        The position solver (``auto``, ``newton``, ``split-newton``).
    all_variants
        Each file stands for itself and for each of its variants.

    Raises
    ------
    InputError
        A missing or wrong file, a scheme that is not a crank turning fully at a constant
        speed, schemes at different speeds, an output the file does not have.
    """
    pairs, specs = _checked_schemes(schemes, outputs, delta, middle, all_variants)
    mechs = [load(f, v) for f, v in pairs]
    names = _names(mechs, pairs, specs)
    speeds = [check_comparable(m, n) for m, n in zip(mechs, names)]
    if any(abs(s - speeds[0]) > 1e-9 * speeds[0] for s in speeds):
        listed = ", ".join(f"{n} {s * 30 / math.pi:.6g} rpm" for n, s in zip(names, speeds))
        raise InputError(
            f"the schemes' cranks turn at different speeds ({listed}): their velocities, "
            "torques and flywheels do not compare; give them the same driver speed (a "
            "variant can set it)"
        )
    for m, spec in zip(mechs, specs):  # every output named before anything is solved
        resolve_output(m, spec)
    figs = []
    for (f, v), m, n, spec in zip(pairs, mechs, names, specs):
        figs.append(
            scheme_figures(
                m,
                name=n,
                file=str(f),
                variant=v,
                output=spec,
                delta=delta,
                middle=middle,
                method=method,
            )
        )
    return Comparison(figs, delta, middle)
