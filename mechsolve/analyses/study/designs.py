"""A study: the file, its parameters, and the designs (one set of values each).

The study comes from the file's ``study:`` section and/or ``-p`` options::

    study:
      design: grid              # grid (default), one-at-a-time, random, latin-hypercube
      samples: 50               # designs of a random or Latin-hypercube study
      seed: 1                   # the random designs are the same every time
      parameters:
        ground.O1[0]: 2.6..3.1 m:6
        links.coupler.points.B[0]: 2.7, 2.78, 2.86
      figures: [range(K.y)]     # extra figures of each design (the requirements' language)
      best: min range(K.y)      # the best design, written as a runnable file

A design is the file with the parameters' values written in; it is validated exactly as
the file is (:func:`mechsolve.model.parse.from_source`), so an invalid design is a row
with the parser's message.
"""

from __future__ import annotations

import copy
import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mechsolve.analyses.study.params import Parameter, make_parameter, parse_option
from mechsolve.base.errors import InputError
from mechsolve.base.keyspec import whole
from mechsolve.base.units import OutputUnits
from mechsolve.model.parse import from_source
from mechsolve.model.source import Source

DESIGNS = {
    "grid": "grid",
    "one-at-a-time": "one-at-a-time",
    "oat": "one-at-a-time",
    "random": "random",
    "latin-hypercube": "latin-hypercube",
    "lhs": "latin-hypercube",
}
STUDY_KEYS = ("design", "samples", "seed", "parameters", "figures", "best")
MAX_DESIGNS = 1_000_000
DEFAULT_SAMPLES = 50


@dataclass
class Study:
    """What ``mechsolve sweep`` solves.

    Attributes
    ----------
    source
        The file (its variant applied, without its ``study`` section).
    params
        The varied parameters.
    design
        ``grid``, ``one-at-a-time``, ``random`` or ``latin-hypercube``.
    designs
        One mapping per design: parameter index -> value (in the parameter's unit);
        a parameter missing from a design keeps the file's value (one-at-a-time).
    figures
        Extra figures (expressions of the requirements' language) per design.
    best
        ``("min" | "max", expression)`` or None.
    step
        A sweep step (SI) replacing the file's, or None.
    """

    source: Source
    params: list[Parameter]
    design: str = "grid"
    samples: int | None = None
    seed: int = 0
    designs: list[dict[int, float]] = field(default_factory=list)
    figures: list[str] = field(default_factory=list)
    best: tuple[str, str] | None = None
    step: float | None = None
    method: str | None = None
    variant: str | None = None
    units: OutputUnits | None = None  # the units of the table and the designs' CSVs

    def __getstate__(self) -> dict:
        # without the design family cached by a process (analyses.study.execute): each
        # process that solves designs parses the file once for itself
        state = dict(self.__dict__)
        state.pop("_family", None)
        return state

    @property
    def file(self) -> str:
        return self.source.file or "mechanism"

    def __len__(self) -> int:
        return len(self.designs)

    def values(self, k: int) -> list[float]:
        """Every parameter's value in design ``k`` (the file's value where not varied)."""
        d = self.designs[k]
        return [d.get(i, p.nominal) for i, p in enumerate(self.params)]

    def source_of(self, k: int) -> Source:
        """The file of design ``k`` (lines kept, so that a message names them)."""
        data = copy.deepcopy(self.source.data)
        for i, x in self.designs[k].items():
            p = self.params[i]
            node = data
            for key in p.path[:-1]:
                node = node[key]
            node[p.path[-1]] = p.yaml_value(x)
        out = copy.copy(self.source)
        out.data = data
        return out

    def mechanism(self, k: int):
        """The validated mechanism of design ``k`` (raises InputError if invalid)."""

        return from_source(self.source_of(k))

    def describe(self, k: int) -> str:
        return ", ".join(
            f"{p.name} = {x:.6g}{' ' + p.unit if p.unit else ''}"
            for p, x in zip(self.params, self.values(k))
        )


def parse_best(text: Any, where: str) -> tuple[str, str]:
    """``"min range(K.y)"`` -> ("min", "range(K.y)")."""
    if not isinstance(text, str) or not text.strip():
        raise InputError(
            f"{where}: write 'min EXPRESSION' or 'max EXPRESSION', e.g. 'min range(K.y)'"
        )
    sense, _, expr = text.strip().partition(" ")
    if sense.lower() not in ("min", "max") or not expr.strip():
        raise InputError(
            f"{where} {text!r}: start with min or max, then the figure, e.g. 'min range(K.y)' "
            "or 'max min(transmission_angle.B)'"
        )
    return sense.lower(), expr.strip()


def _section(src: Source) -> dict:
    sec = src.data.get("study")
    if sec is None:
        return {}
    if not isinstance(sec, dict):
        raise src.error(("study",), "'study' must be a mapping with keys such as 'parameters'")
    for key in sec:
        if key not in STUDY_KEYS:
            from mechsolve.model.validate import suggest

            raise src.error(
                ("study", key),
                f"unknown key {key!r} in 'study'"
                + suggest(str(key), list(STUDY_KEYS))
                + f"; allowed: {', '.join(STUDY_KEYS)}",
            )
    return sec


def make_study(
    src: Source,
    options: list[str] = (),
    *,
    variant: str | None = None,
    design: str | None = None,
    samples: int | None = None,
    seed: int | None = None,
    best: str | None = None,
    figures: list[str] = (),
) -> Study:
    """Read the study of a parsed file and the command line's ``-p`` options (which add
    parameters, or replace the file's of the same key path) and list its designs."""
    sec = _section(src)
    if variant is not None:
        src = src.with_variant(variant)
    data = dict(src.data)
    data.pop("study", None)
    base = copy.copy(src)
    base.data = data
    params = _parameters(src, sec, data, options)
    mode = _design_mode(src, sec, design, params)
    n = _whole_setting(src, sec, "samples", samples, 1, "the number of samples")
    if n is not None and (mode in ("grid", "one-at-a-time") or n > MAX_DESIGNS):
        msg = (
            f"{n} samples: at most {MAX_DESIGNS}"
            if n > MAX_DESIGNS
            else f"a {mode} study takes every value; samples are for random ones"
        )
        if samples is None:
            raise src.error(("study", "samples"), msg)
        raise InputError(f"--samples {samples}: {msg}")
    sd = _whole_setting(src, sec, "seed", seed, 0, "the seed")
    sd = 0 if sd is None else sd
    bst = _best(src, sec, best)
    figs = _figures(src, sec, figures)
    study = Study(base, params, mode, n, sd, figures=figs, best=bst, variant=variant)
    study.designs = list_designs(study)
    return study


def _whole_setting(src: Source, sec: dict, key: str, given, least: int, what: str):
    """The whole number ``study.KEY`` (``given``: the command line's, which replaces it),
    ``least`` or more, or None when neither gives one. ``10.0`` is 10, as for every
    whole-number setting of the file and as the JSON Schema's ``integer`` reads it; a
    fraction, text or a number under ``least`` is refused where it was written."""
    n = whole(given if given is not None else sec.get(key))
    if n is None or (isinstance(n, int) and not isinstance(n, bool) and n >= least):
        return n
    msg = f"{what} must be a whole number of {least} or more, got {n!r}"
    if given is None:
        raise src.error(("study", key), msg)
    raise InputError(f"--{key}: {msg}")


def _parameters(src: Source, sec: dict, data: dict, options) -> list:
    """The parameters of the file's study section, then the ``-p`` options (one of the
    same key path replaces the file's); at least one, none given twice."""
    units = data.get("units") if isinstance(data.get("units"), dict) else {}
    given: dict[str, tuple[Any, tuple]] = {}
    raw = sec.get("parameters", {})
    if raw is not None and not isinstance(raw, dict):
        raise src.error(("study", "parameters"), "'parameters' maps key paths to values")
    for key, value in (raw or {}).items():
        given[str(key)] = (value, ("study", "parameters", key))
    said = {key: f"study.parameters.{key}" for key in given}  # where each was given
    for opt in options:
        key, value = parse_option(opt)
        if key in given and given[key][1] == ():  # (one of the file's: replaced)
            raise InputError(f"{said[key]} and -p {opt!r} both vary {key}: give it once")
        given[key] = (value, ())
        said[key] = f"-p {opt!r}"
    params = []
    for key, (value, where) in given.items():
        try:
            params.append(make_parameter(data, key, value, units))
        except InputError as exc:
            if where:
                raise src.error(where, exc.message) from None
            raise InputError(f"{said[key]}: {exc.message}") from None
    first: dict[str, str] = {}
    for key, p in zip(given, params):
        if p.name in first:
            raise InputError(
                f"the parameter {p.name} is given twice, as {first[p.name]} and "
                f"{said[key]}: give it once"
            )
        first[p.name] = said[key]
    if not params:
        raise InputError(
            f"{src.file}: nothing to vary: give parameters with -p KEYPATH=VALUES "
            '(e.g. -p "links.crank.points.A[0]=20..30 mm:5") or in the file\'s study section'
        )
    return params


def _design_mode(src: Source, sec: dict, design: str | None, params: list) -> str:
    """The kind of design (--design, else the file's; by default random when a parameter
    is a distribution, else a grid), by its canonical name."""
    mode = design or sec.get("design")
    if mode is None:
        mode = "random" if any(p.is_random for p in params) else "grid"
    if mode not in DESIGNS:
        msg = f"unknown design {mode!r}: one of grid, one-at-a-time, random, latin-hypercube"
        if design is None:
            raise src.error(("study", "design"), msg)
        raise InputError(f"--design: {msg}")
    return DESIGNS[mode]


def _best(src: Source, sec: dict, best: str | None):
    """The figure that picks the best design (--best, else the file's), or None."""
    if best is not None:
        return parse_best(best, "--best")
    if sec.get("best") is not None:
        try:
            return parse_best(sec["best"], "best")
        except InputError as exc:
            raise src.error(("study", "best"), exc.message) from None
    return None


def _figures(src: Source, sec: dict, figures) -> list[str]:
    """The extra figures per design: the file's, then the command line's (blank ones
    dropped)."""
    figs = list(figures)
    extra = sec.get("figures", [])
    if isinstance(extra, str):
        extra = [extra]
    if not isinstance(extra, list) or not all(isinstance(f, str) for f in extra):
        raise src.error(("study", "figures"), "'figures' is a list of expressions")
    return [f for f in [*extra, *figs] if f.strip()]


def list_designs(study: Study) -> list[dict[int, float]]:
    """The designs of the study, in a fixed order (the table's)."""
    params, mode = study.params, study.design
    if mode in ("grid", "one-at-a-time"):
        rnd = [p.name for p in params if p.is_random]
        if rnd:
            raise InputError(
                f"{rnd[0]} is a distribution: a {mode} study takes lists and ranges "
                "(use design random or latin-hypercube for distributions)"
            )
        if study.samples is not None:
            raise InputError(
                f"samples: a {mode} study takes every value; samples are for random ones"
            )
    if mode == "grid":
        total = math.prod(len(p.values) for p in params)
        if total > MAX_DESIGNS:
            raise InputError(f"the grid has {total} designs, more than {MAX_DESIGNS}")
        return [dict(enumerate(combo)) for combo in itertools.product(*(p.values for p in params))]
    if mode == "one-at-a-time":
        return [{i: x} for i, p in enumerate(params) for x in p.values]
    n = study.samples or DEFAULT_SAMPLES
    if n > MAX_DESIGNS:
        raise InputError(f"{n} samples: at most {MAX_DESIGNS}")
    rng = np.random.default_rng(study.seed)
    if mode == "latin-hypercube":
        from scipy.stats import qmc

        u = qmc.LatinHypercube(d=len(params), rng=rng).random(n)
    else:
        u = rng.random((n, len(params)))
    cols = []
    for j, p in enumerate(params):
        uj = u[:, j]
        if p.spec == "uniform":
            a, b = p.values
            col = a + (b - a) * uj
        elif p.spec == "normal":
            from scipy.stats import norm

            mean, sd = p.values
            col = mean + sd * norm.ppf(np.clip(uj, 1e-12, 1 - 1e-12))
        else:  # a list or range: each value equally likely
            idx = np.minimum((uj * len(p.values)).astype(int), len(p.values) - 1)
            col = np.asarray(p.values)[idx]
        cols.append([float(f"{x:.12g}") for x in col])
    return [{j: cols[j][k] for j in range(len(params))} for k in range(n)]


__all__ = ["DESIGNS", "Study", "list_designs", "make_study", "parse_best"]
