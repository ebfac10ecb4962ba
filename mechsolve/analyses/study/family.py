"""A design family: one parsed mechanism and the values its designs give some of its numbers.

A design study writes each design's values into a copy of the file and parses it
(:meth:`mechsolve.analyses.study.designs.Study.mechanism`, about a millisecond a design),
and the batch then reads every parsed design back (its structure checked against the
first one's, its numbers gathered: some hundred Python objects a design). When the
varied numbers are numbers the analysis reads as they are, neither is needed: the file
is parsed once, and each design's stacked numbers (:func:`mechsolve.analyses.batch._split`'s
order) are the base's with the varied columns replaced by the values, converted to SI by
the parser's own function on the text the study would write (the same bits).

Supported key paths (a family whose parameters are all of these, on a mechanism without
sliders, takes the fast path):

* ``ground.P[i]``: a ground point's coordinate written ``[x, y]``;
* ``links.L.points.P[i]``: a link's point written ``[x, y]``, when no other point of the
  link is placed from it (``from``, ``ref``), its centre of mass does not name it, the
  link has no ``point_masses`` and the driver's angle is not measured from it. A
  ``uniform_bar`` through it gets its centre and inertia computed per design by the
  parser's formulas.

Anything else (a polar point's length or angle, a mass, a load, the sweep, a number that
places other points) parses every design, as before. The checks the parser makes on the
values (a finite number within range, the joint points of a link distinct, the inertia's
range) are made per design over arrays; a design that fails one, or comes within a hair
of failing, is parsed on its own, so that a refused design has the parser's message.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from mechsolve.analyses.batch import DesignBatch, _split, number_index, solve_stacked
from mechsolve.analyses.study.params import (
    Parameter,
    format_keypath,
    kind_at,
    lookup,
    parse_keypath,
)
from mechsolve.base.errors import InputError, MechsolveError
from mechsolve.base.units import LIMITS, UnitError, parse_quantity, parse_unit
from mechsolve.core.sweep import Analysis
from mechsolve.model import Mechanism
from mechsolve.model.parse import from_source
from mechsolve.model.source import Source

__all__ = ["DesignFamily", "design_family", "solve_family"]

# a design whose joint points come within this factor of the parser's coincidence test
# (distance <= 1e-9 scale) is parsed on its own: numpy's hypot and math.dist may differ
# in the last bit
_MARGIN = 4.0


def _source_of(source: Source, params: list[Parameter], values: dict[int, float]) -> Source:
    """The file of one design (:meth:`Study.source_of`: the same text written)."""
    data = copy.deepcopy(source.data)
    for i, x in values.items():
        p = params[i]
        node = data
        for key in p.path[:-1]:
            node = node[key]
        node[p.path[-1]] = p.yaml_value(x)
    out = copy.copy(source)
    out.data = data
    return out


class _Mechanisms(Sequence):
    """The designs of a family as a sequence of mechanisms, each built when asked for."""

    def __init__(self, fam: DesignFamily) -> None:
        self.fam = fam

    def __len__(self) -> int:
        return len(self.fam)

    def __getitem__(self, k):  # type: ignore[override]
        if isinstance(k, slice):
            return [self.fam.mechanism(j) for j in range(len(self))[k]]
        return self.fam.mechanism(k)


class DesignFamily:
    """Designs of one mechanism file that differ in the values of some of its numbers.

    Parameters
    ----------
    source
        The file (its variant applied).
    params
        The varied numbers: key paths and the units their values are in.
    table
        The values, shape (designs, parameters), each in its parameter's unit.
    given
        Which values a design gives, same shape (a design keeps the file's number where
        False: a one-at-a-time study); None: all.
    base
        The file parsed (:func:`mechsolve.model.parse.from_source`), if already done.

    Attributes
    ----------
    why_not
        Why the designs are parsed one by one (a parameter the family does not support),
        or None.
    """

    def __init__(
        self,
        source: Source,
        params: Sequence[Parameter],
        table: np.ndarray,
        given: np.ndarray | None = None,
        base: Mechanism | InputError | None = None,
        cache: dict | None = None,
    ) -> None:
        self.source = source
        self.params = list(params)
        self.table = np.asarray(table, float).reshape(-1, len(self.params))
        self.given = given
        self._base = base
        self._cache = {} if cache is None else cache  # (parameter, value bits) -> SI
        self._ready = False
        self.why_not: str | None = None
        self._parsed: dict[int, Mechanism] = {}
        self.invalid: dict[int, InputError] = {}
        self._made: dict[int, Mechanism] = {}
        self.rows: np.ndarray | None = None

    def __len__(self) -> int:
        return self.table.shape[0]

    # -- the designs one by one (the fallback) ----------------------------------------------
    def values(self, k: int) -> dict[int, float]:
        """Design ``k``'s values by parameter (those it gives)."""
        row = self.table[k]
        if self.given is None:
            return {i: float(x) for i, x in enumerate(row)}
        return {i: float(x) for i, x in enumerate(row) if self.given[k, i]}

    def source_of(self, k: int) -> Source:
        """The file of design ``k``, as a study writes it."""
        return _source_of(self.source, self.params, self.values(k))

    def parse(self, k: int) -> Mechanism:
        """Design ``k`` parsed and validated from its file (raises its InputError)."""
        return from_source(self.source_of(k))

    @property
    def base(self) -> Mechanism | None:
        """The file parsed as it is, or None when the parser refuses it."""
        if self._base is None:
            try:
                self._base = from_source(self.source)
            except InputError as exc:
                self._base = exc
        return None if isinstance(self._base, InputError) else self._base

    # -- the family's numbers ---------------------------------------------------------------
    def prepare(self) -> DesignFamily:
        """Decide whether the family's numbers can be stacked without parsing the
        designs (:attr:`why_not`), and stack them: :attr:`rows` (designs, numbers),
        :attr:`invalid` (designs the parser refuses, with its error)."""
        if self._ready:
            return self
        self._ready = True
        base = self.base
        lay = None if base is None else self._layout()
        self.why_not = "the file itself is refused" if lay is None else lay.why_not
        nd = len(self)
        if self.why_not is not None or not nd:
            return self
        X = np.empty((nd, lay.row.size))
        X[...] = lay.row
        flagged = np.zeros(nd, bool)
        for i, p in enumerate(self.params):
            col_of = lay.cols[i]
            vals = self.table[:, i]
            if self.given is None:  # every design gives it (rows: all of them)
                rows, sel = slice(None), vals
            else:
                rows = np.flatnonzero(self.given[:, i])
                if not rows.size:
                    continue
                sel = vals[rows]
            si, bad = self._converted(p, np.ascontiguousarray(sel).view(np.int64), lay)
            X[rows, col_of] = si
            if bad is not None:
                if isinstance(rows, slice):
                    flagged |= bad
                else:
                    flagged[rows[bad]] = True
        _bars(lay, X)
        flagged |= _refused(lay, X)
        self.rows = X
        for k in np.flatnonzero(flagged):  # parsed on their own: the parser decides
            k = int(k)
            try:
                self._parsed[k] = self.parse(k)
            except InputError as exc:
                self.invalid[k] = exc
        return self

    def _converted(self, p: Parameter, bits: np.ndarray, lay: _Layout):
        """The values (their bits, int64) of parameter ``p`` in SI: each distinct value
        converted once per study by the parser's own function, on the text a study writes
        (``self._cache``), and which of them the parser refuses (None: none; a refused
        one is 0.0 here). Where every value was converted before, they are looked up in
        a sorted table of those conversions instead (:data:`_TABLE` entries at most)."""
        key = ("table", p.name, p.unit)
        table = self._cache.get(key)
        if table is not None:
            known, si = table
            at = np.searchsorted(known, bits)
            np.minimum(at, known.size - 1, out=at)
            if (known[at] == bits).all():
                out = si[at]
                bad = np.isnan(out)
                if not bad.any():
                    return out, None
                out[bad] = 0.0
                return out, bad
        uniq, inv = np.unique(bits, return_inverse=True)
        si = np.empty(uniq.size)
        for u, b in enumerate(uniq.tolist()):
            got = self._cache.get((p.name, p.unit, b))
            if got is None:
                x = float(np.int64(b).view(np.float64))
                try:
                    got = parse_quantity(p.yaml_value(x), "length", lay.length_unit)
                except (UnitError, ValueError, TypeError):
                    got = math.nan
                self._cache[p.name, p.unit, b] = got
            si[u] = got
        if table is None or table[0].size + uniq.size <= _TABLE:  # the table, merged
            if table is not None:
                uniq, first = np.unique(np.concatenate([table[0], uniq]), return_index=True)
                si = np.concatenate([table[1], si])[first]
                si_inv = si[np.searchsorted(uniq, bits)]
            else:
                si_inv = si[inv]
            self._cache[key] = (uniq, si)
        else:
            si_inv = si[inv]
        bad = np.isnan(si_inv)
        if not bad.any():
            return si_inv, None
        si_inv[bad] = 0.0
        return si_inv, bad

    def _analysis(self, method: str | None) -> Analysis | None:
        """The analysis of the file as it is (method ``method``), made once per study
        (:meth:`with_values` shares it): the structure every design of the family has
        (:func:`mechsolve.analyses.batch._reference`); None where it cannot be made."""
        key = ("analysis", method)
        if key not in self._cache:
            try:
                self._cache[key] = Analysis(self.base, method)
            except MechsolveError:
                self._cache[key] = None
        return self._cache[key]

    def _layout(self) -> _Layout:
        """What the family's numbers are made of, the same for every family of this file
        and parameters (:meth:`with_values` shares it, with the values' conversions)."""
        lay = self._cache.get(_LAYOUT)
        if lay is None:
            lay = self._cache[_LAYOUT] = _Layout(self)
        return lay

    # -- a design -----------------------------------------------------------------------------
    def mechanism(self, k: int) -> Mechanism:
        """Design ``k``'s mechanism: the parsed one where it was parsed, else the base
        with the design's numbers (equal to the parsed one; its ``source`` is the base
        file's). Raises the parser's error for a refused design."""
        self.prepare()
        if k in self.invalid:
            raise self.invalid[k]
        got = self._parsed.get(k) or self._made.get(k)
        if got is not None:
            return got
        if self.why_not is not None:
            got = self._parsed[k] = self.parse(k)
            return got
        got = self._made[k] = _with_row(self.base, self.rows[k])
        return got

    def mechanisms(self) -> Sequence[Mechanism]:
        """The designs, each built when asked for."""
        return _Mechanisms(self)

    def with_values(self, table: np.ndarray, given: np.ndarray | None = None) -> DesignFamily:
        """The family of the same file and parameters with other designs (the base parsed
        once for both, the values' conversions shared)."""
        self.base  # noqa: B018 - parsed once for both
        return DesignFamily(self.source, self.params, table, given, self._base, self._cache)


_LAYOUT = "layout"  # the key of a family's _Layout in its cache (the others are tuples)
_TABLE = 1 << 16  # a parameter's converted values kept in a sorted table, at most


class _Layout:
    """Where a family's numbers go, and what of them is checked: made once per file and
    parameters (the cache :meth:`DesignFamily.with_values` shares).

    Attributes
    ----------
    why_not
        :func:`_unsupported`'s answer.
    row
        The file's stacked numbers (:func:`_split`'s order); ``cols``: each parameter's
        column among them; ``length_unit``: the unit of a plain length in the file.
    bars
        Per ``uniform_bar`` through a varied point: its four coordinates' columns, which
        of the four a parameter writes, the link's mass, and the columns of its centre
        and inertia where the parser computes them (else None).
    checks
        The columns :func:`_refused` reads (see there), as index arrays.
    """

    def __init__(self, fam: DesignFamily) -> None:
        base = fam.base
        self.why_not = _unsupported(fam)
        if self.why_not is not None:
            return
        index = number_index(base)
        self.row = np.array(_split(base)[1], float)
        self.length_unit = _length_unit(fam.source)
        self.cols = [_column(p, index) for p in fam.params]
        written = set(self.cols)
        links = fam.source.data.get("links") or {}
        varied = {(p.path[1], p.path[3]) for p in fam.params if p.path[0] == "links"}
        self.bars = []
        for lk in base.links:
            m = links.get(lk.name)
            ends = m.get("uniform_bar") if isinstance(m, dict) else None
            if not ends or not any((lk.name, e) in varied for e in ends):
                continue
            cols = [index["point", lk.name, e, i] for e in ends for i in (0, 1)]
            com = None if "com" in m else (index["com", lk.name, 0], index["com", lk.name, 1])
            inertia = None if "inertia" in m else index["inertia", lk.name]
            moved = [j for j, c in enumerate(cols) if c in written]
            self.bars.append((cols, moved, lk.mass, com, inertia))
        changed = {p.path[1] for p in fam.params if p.path[0] == "links"}
        self.checks = _checks(base, changed, index, written)


def _checks(base: Mechanism, changed: set, index: dict, written: set) -> dict[str, Any]:
    """The columns :func:`_refused` reads, for the links whose points a parameter moves:
    per link, the coordinates of its points a parameter writes (``links``: x columns,
    y columns, and the largest distance from the origin among its other points, the
    file's, or -inf); the pairs of a link's joint points (``ax``, ``ay``, ``bx``,
    ``by``; their link ``link``), the inertias and the centres' coordinates."""
    row = np.array(_split(base)[1], float)
    links, link, inertia, com = [], [], [], []
    ends: dict[str, list[int]] = {k: [] for k in ("ax", "ay", "bx", "by")}
    for lk in base.links:
        if lk.name not in changed:
            continue
        xy = [(index["point", lk.name, p, 0], index["point", lk.name, p, 1]) for p in lk.points]
        moved = [(x, y) for x, y in xy if x in written or y in written]
        fixed = [float(np.hypot(row[x], row[y])) for x, y in xy if (x, y) not in moved]
        far = max(fixed, default=-math.inf)  # (max is exact: as over the whole row)
        links.append(([x for x, _ in moved], [y for _, y in moved], far))
        used = sorted({j.point for j in base.joints if lk.name in j.links and j.point in lk.points})
        for a in range(len(used)):
            for b in range(a + 1, len(used)):
                for key, p, i in (("ax", a, 0), ("ay", a, 1), ("bx", b, 0), ("by", b, 1)):
                    ends[key].append(index["point", lk.name, used[p], i])
                link.append(len(links) - 1)
        if ("inertia", lk.name) in index:
            inertia.append(index["inertia", lk.name])
        if ("com", lk.name, 0) in index:
            com += [index["com", lk.name, 0], index["com", lk.name, 1]]
    out = {k: np.array(v, np.intp) for k, v in ends.items()}
    out |= {"link": np.array(link, np.intp), "inertia": inertia, "com": com, "links": links}
    return out


def _bars(lay: _Layout, X: np.ndarray) -> None:
    """The centre and inertia of each ``uniform_bar`` through a varied point, by the
    parser's formulas (:func:`mechsolve.model.read_geometry.read_mass`) in Python floats,
    once per distinct bar."""
    for cols, moved, mass, com, inertia in lay.bars:
        uniq, inv = _distinct_rows(X[:, cols], moved)
        if com is not None:  # (the same sums and halves as in Python floats, per distinct row)
            X[:, com[0]] = ((uniq[:, 0] + uniq[:, 2]) / 2)[inv]
            X[:, com[1]] = ((uniq[:, 1] + uniq[:, 3]) / 2)[inv]
        if inertia is not None:  # (Python's ** 2, libm's pow: not always x * x, as the parser)
            inertias = [
                mass * ((x1 - x0) ** 2 + (y1 - y0) ** 2) / 12.0 for x0, y0, x1, y1 in uniq.tolist()
            ]
            X[:, inertia] = np.array(inertias, float)[inv]


def _distinct_rows(A: np.ndarray, moved: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The distinct rows of ``A`` (equal values alike, as ``np.unique(A, axis=0)`` takes
    them) and each row's index among them: each column's distinct values numbered, the
    numbers combined into one integer per row (``np.unique`` over rows of floats sorts
    them as records, some fifty times slower for a study's thousand designs). Only the
    columns ``moved`` may differ from row to row (the others hold the file's number in
    every row); one of them that does not differ numbers every row 0, as it did."""
    varies = [A[:, j] for j in moved]
    if len(varies) == 1:  # its distinct values number the rows (as the key below would)
        _, first, inv = np.unique(varies[0], return_index=True, return_inverse=True)
        return A[first], np.ravel(inv)
    key = np.zeros(A.shape[0], np.int64)
    for col in varies:
        vals, code = np.unique(col, return_inverse=True)
        key = key * vals.size + np.ravel(code)
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    return A[first], np.ravel(inv)


def _length_unit(source: Source) -> str:
    """The unit of a plain length in the file (:class:`mechsolve.model.reader.Reader`)."""
    units = source.data.get("units")
    if isinstance(units, dict) and "length" in units:
        return str(units["length"])
    return "m"


def _column(p: Parameter, index: dict) -> int:
    path = p.path
    i = path[-1] % 2
    if path[0] == "ground":
        return index["ground", path[1], i]
    return index["point", path[1], path[3], i]


def _unsupported(fam: DesignFamily) -> str | None:
    """Why the family's designs must be parsed one by one, or None."""
    base = fam.base
    data = fam.source.data
    if any(j.geometry() for j in base.joints):
        return "the mechanism has a joint with numbers of its own (a slider's line)"
    line = set()
    d = base.driver
    if d is not None and d.line is not None:
        line = {(base.joint(d.joint).b, p) for p in d.line}
    for p in fam.params:
        path = p.path
        xy = len(path) >= 2 and isinstance(path[-1], int) and path[-1] in (-2, -1, 0, 1)
        if xy and len(path) == 3 and path[0] == "ground":
            node = lookup(data, path[:2])
            if not isinstance(node, list) or len(node) != 2 or path[1] not in base.ground:
                return f"{p.name} is not a coordinate written [x, y]"
            if ("ground", path[1]) in line:
                return f"the driver's angle is measured from {path[1]}"
            continue
        if not (xy and len(path) == 5 and path[0] == "links" and path[2] == "points"):
            return f"{p.name} is not a point's coordinate"
        name, point = path[1], path[3]
        node = lookup(data, path[:4])
        if not isinstance(node, list) or len(node) != 2:
            return f"{p.name} is not a coordinate written [x, y]"
        link = data["links"][name]
        if "point_masses" in link:
            return f"link {name} has point masses"
        if link.get("com") == point:
            return f"the centre of mass of link {name} is its point {point}"
        for q, v in link["points"].items():
            if isinstance(v, dict) and (v.get("from") == point or point in (v.get("ref") or ())):
                return f"point {q} of link {name} is placed from {point}"
        if (name, point) in line:
            return f"the driver's angle is measured from {point}"
    return None


def _refused(lay: _Layout, X: np.ndarray) -> np.ndarray:
    """The designs the parser might refuse for their values (checked over arrays, with a
    margin: these are parsed on their own). Each value was converted by the parser's own
    function (a refused one is flagged there); here the link's joint points that must
    be distinct, and the range of a bar's inertia and centre (:func:`_checks`' columns:
    a point no parameter moves has the file's distance from the origin in every design)."""
    c = lay.checks
    nd = X.shape[0]
    out = np.zeros(nd, bool)
    if c["links"]:  # each link's scale: its points' largest distance from the origin
        scale = np.empty((nd, len(c["links"])))
        for j, (xs, ys, far) in enumerate(c["links"]):
            r = np.hypot(X[:, xs], X[:, ys]).max(axis=1) if xs else np.full(nd, far)
            np.maximum(r, far, out=r)
            np.maximum(1e-9, r, out=scale[:, j])
        if c["link"].size:
            d = np.hypot(X[:, c["ax"]] - X[:, c["bx"]], X[:, c["ay"]] - X[:, c["by"]])
            out |= ~(d > _MARGIN * 1e-9 * scale[:, c["link"]]).all(axis=1)
    if c["inertia"]:
        v = X[:, c["inertia"]]
        out |= ~((v >= 0) & (v <= LIMITS["moment of inertia"])).all(axis=1)
    if c["com"]:
        out |= ~(np.abs(X[:, c["com"]]) <= LIMITS["length"]).all(axis=1)
    return out


def _with_row(base: Mechanism, row: np.ndarray) -> Mechanism:
    """``base`` with the numbers ``row`` (:func:`_split`'s order) in its ground points and
    links (the numbers after them are the base's: the family varies none of them)."""
    vals = row.tolist()
    out = copy.copy(base)
    out.__dict__.pop("_link_index", None)
    n = 0
    ground = {}
    for p in base.ground:
        ground[p] = (vals[n], vals[n + 1])
        n += 2
    out.ground = ground
    links = []
    for lk in base.links:
        pts = {}
        for p in lk.points:
            pts[p] = (vals[n], vals[n + 1])
            n += 2
        mass = inertia = com = None
        if lk.mass is not None:
            mass = vals[n]
            n += 1
        if lk.inertia is not None:
            inertia = vals[n]
            n += 1
        if lk.com is not None:
            com = (vals[n], vals[n + 1])
            n += 2
        links.append(dataclasses.replace(lk, points=pts, mass=mass, inertia=inertia, com=com))
    out.links = links
    return out


def design_family(
    base: Mechanism | Source,
    values: Mapping[str, Any],
    units: Mapping[str, str] | None = None,
) -> DesignFamily:
    """The designs that give the numbers at ``values``' key paths the values listed.

    Parameters
    ----------
    base
        The mechanism as parsed from its file (``mechsolve.load``: its ``source``), or
        the parsed file (:class:`mechsolve.model.source.Source`).
    values
        Key path (``"links.crank.points.A[0]"``, ``"ground.O4[1]"``) -> one value per
        design; every array the same length.
    units
        The unit of each key path's values (default: the unit a bare number has there
        in the file, ``units.length``). A design's number is what the file holds with
        the value written in it (``"26.5 mm"``): converted as the parser converts it.

    Returns
    -------
    DesignFamily
        For :func:`solve_family`.
    """
    if isinstance(base, Mechanism):
        if base.source is None:
            raise InputError("a design family needs a mechanism read from a file")
        src, parsed = base.source, base
    else:
        src, parsed = base, None
    data = src.data
    file_units = data.get("units") if isinstance(data.get("units"), dict) else {}
    units = dict(units or {})
    params, cols = [], []
    n = None
    for key, vals in values.items():
        path = parse_keypath(key)
        nominal = lookup(data, path)
        name = format_keypath(path)
        kind = kind_at(path, nominal)
        default = {"length": file_units.get("length", "m"), "angle": file_units.get("angle", "deg")}
        unit = units.pop(key, None) or default.get(kind or "", "")
        if unit:
            try:
                parse_unit(unit)
            except UnitError as exc:
                raise InputError(f"parameter {name}: {exc}") from None
        col = np.asarray(vals, float).ravel()
        if n is not None and col.size != n:
            raise InputError(f"parameter {name}: {col.size} values where the others have {n}")
        n = col.size
        params.append(
            Parameter(path, name, kind, unit, "list", [], default_unit=default.get(kind or ""))
        )
        cols.append(col)
    if units:
        raise InputError(f"units given for {', '.join(units)}, which has no values")
    if not params:
        raise InputError("a design family needs at least one key path with values")
    return DesignFamily(src, params, np.column_stack(cols), None, parsed)


def solve_family(
    family: DesignFamily,
    *,
    step: float | None = None,
    method: str | None = None,
    forces: bool | None = None,
    acceleration: bool | None = None,
) -> DesignBatch:
    """Solve every design of a family as one batch (:func:`mechsolve.analyses.batch.solve_designs`),
    without parsing the designs where the family's parameters allow it (see the module's
    docstring); otherwise each design is parsed from its file, as a study does.

    Parameters
    ----------
    family
        The designs (:func:`design_family`, or a study's).
    step, method, forces, acceleration
        As for :func:`mechsolve.analyses.batch.solve_designs`.

    Returns
    -------
    DesignBatch
        ``results(k)`` gives design ``k``'s Results, the same as parsing and solving it
        one by one; a design the parser refuses raises the parser's error there
        (:attr:`DesignFamily.invalid` lists them).
    """
    family.prepare()
    nd = len(family)
    if family.why_not is not None:  # every design parsed, as a study always did
        for k in range(nd):
            try:
                family._parsed[k] = family.parse(k)
            except InputError as exc:
                family.invalid[k] = exc
    mechs = family.mechanisms()
    out = DesignBatch(mechs, np.zeros(0), np.zeros(nd, bool), _auto_forces=forces is None)
    alone: dict[int, str] = {}
    for k, exc in family.invalid.items():
        out._separate[k] = exc
        alone[k] = "the parser refuses it"
    if len(alone) == nd:
        for k in alone:
            out.why[k] = alone[k]
        return out
    valid = [k for k in range(nd) if k not in alone] if alone else list(range(nd))
    if forces is not None:
        want_forces = forces
    elif family.why_not is None:  # masses and loads are the base's in every design
        want_forces = mechs[valid[0]].needs_forces
    else:
        want_forces = any(mechs[k].needs_forces for k in valid)
    rows = like = None
    if family.why_not is None:  # (the file's analysis: the designs' structure, once)
        rows, like = family.rows, family._analysis(method)
    todo = (want_forces, step, method, forces, acceleration, like)
    return solve_stacked(out, rows, alone, *todo)
