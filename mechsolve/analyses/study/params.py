"""Study parameters: numbers of a mechanism file named by their key path, and the values
they take.

A parameter is written ``KEYPATH=VALUES`` on the command line (``-p``) or as
``KEYPATH: VALUES`` in the file's ``study.parameters``. The key path walks the file's
YAML: ``links.crank.points.A[0]``, ``ground.O1[1]``, ``links.jib.mass``,
``links.jib.points.C.length``, ``driver.speed``. VALUES is one of

===============================  ====================================================
``20 mm, 25 mm, 30 mm``          a list (a unit at the end serves the bare numbers:
                                 ``20, 25, 30 mm``); a YAML list works too
``20..30 mm:5``                  a range with a count: 5 values, both ends included
``uniform(20, 30 mm)``           a distribution, for random and Latin-hypercube
``normal(25 mm, 0.5 mm)``        studies (mean, standard deviation)
===============================  ====================================================

A bare number has the unit the file's number has (``units.length`` for a coordinate).
A value of the wrong kind (``20 kg`` for a coordinate) is refused before anything is
solved.
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass, field
from typing import Any

from mechsolve.base.errors import InputError
from mechsolve.base.keyspec import whole
from mechsolve.base.units import (
    UnitError,
    dim_name,
    parse_quantity,
    parse_unit,
    read_number,
    split_number,
)

KeyPath = tuple[Any, ...]

# the kind of quantity at a key path ("*" any name), for numbers written without a unit
KINDS: list[tuple[KeyPath, str]] = [
    (("ground", "*"), "length"),
    (("links", "*", "points", "*"), "length"),
    (("links", "*", "points", "*", "length"), "length"),
    (("links", "*", "points", "*", "angle"), "angle"),
    (("links", "*", "points", "*", "x"), "length"),
    (("links", "*", "points", "*", "y"), "length"),
    (("links", "*", "mass"), "mass"),
    (("links", "*", "weight"), "force"),
    (("links", "*", "inertia"), "moment of inertia"),
    (("links", "*", "com"), "length"),
    (("joints", "*", "line", "offset"), "length"),
    (("joints", "*", "line", "angle"), "angle"),
    (("joints", "*", "angle"), "angle"),
    (("driver", "start"), "angle"),
    (("sweep", "range"), "angle"),
    (("sweep", "to"), "angle"),
    (("sweep", "step"), "angle"),
    (("loads", "*", "force"), "force"),
    (("loads", "*", "torque"), "torque"),
    (("loads", "*", "stiffness"), "stiffness"),
    (("loads", "*", "damping"), "damping"),
    (("motor", "stall"), "torque"),
    (("flywheel", "inertia"), "moment of inertia"),
    (("gravity",), "acceleration"),
]

SI_UNIT = {
    "dimensionless": "",
    "length": "m",
    "mass": "kg",
    "time": "s",
    "angle": "deg",
    "speed": "m/s",
    "acceleration": "m/s^2",
    "angular speed": "rad/s",
    "angular acceleration": "rad/s^2",
    "force": "N",
    "torque": "N*m",
    "moment of inertia": "kg*m^2",
    "stiffness": "N/m",
    "damping": "N*s/m",
    "rotational damping": "N*m*s/rad",
    "density per length": "kg/m",
}

# a comma between two digits: a decimal comma (1,5) or a list written without spaces?
_DIGIT_COMMA_RE = re.compile(r"[0-9],[0-9]")
# a whole number written with thousands grouped by commas (1,000,000 or 20,250,300 mm)
_THOUSANDS_LIST_RE = re.compile(r"^\s*([+-]?[1-9][0-9]{0,2}(?:,[0-9]{3})+)(?![0-9.,])")
_DIST_RE = re.compile(r"^\s*(uniform|normal)\s*\((.*)\)\s*$", re.IGNORECASE)


def parse_keypath(text: str) -> KeyPath:
    """``links.crank.points.A[0]`` -> ``("links", "crank", "points", "A", 0)``."""
    out: list[Any] = []
    text = text.strip()
    if not text:
        raise InputError("a parameter needs a key path, e.g. links.crank.points.A[0]")
    for part in text.split("."):
        m = re.fullmatch(r"([^\[\]]*)((?:\[\s*-?\d+\s*\])*)", part.strip())
        if m is None or (not m.group(1) and not out):
            raise InputError(
                f"cannot read the key path {text!r}: write names joined by dots and list "
                "indexes in brackets, e.g. links.crank.points.A[0]"
            )
        if m.group(1):
            out.append(m.group(1))
        out += [int(i) for i in re.findall(r"-?\d+", m.group(2))]
    return tuple(out)


def format_keypath(path: KeyPath) -> str:
    out = ""
    for k in path:
        out += f"[{k}]" if isinstance(k, int) else ("." if out else "") + str(k)
    return out


def _children(node: Any) -> list[str]:
    if isinstance(node, dict):
        return [str(k) for k in node]
    if isinstance(node, list):
        return [f"[{i}]" for i in range(len(node))]
    return []


def _all_paths(data: Any, prefix: KeyPath = (), depth: int = 0) -> list[str]:
    """Every number's key path in the document (for a suggestion)."""
    if depth > 8:
        return []
    out = []
    if isinstance(data, dict):
        for k, v in data.items():
            if k in ("variants", "study", "requirements"):
                continue
            out += _all_paths(v, prefix + (k,), depth + 1)
    elif isinstance(data, list):
        for i, v in enumerate(data):
            out += _all_paths(v, prefix + (i,), depth + 1)
    elif prefix:
        out.append(format_keypath(prefix))
    return out


def lookup(data: Any, path: KeyPath) -> Any:
    """The value at ``path`` in the document; an :class:`InputError` with a suggestion
    (the closest key there, or the closest full key path) when it does not exist."""
    node = data
    for depth, key in enumerate(path):
        here = format_keypath(path[:depth])
        ok = (isinstance(node, dict) and key in node) or (
            isinstance(node, list) and isinstance(key, int) and -len(node) <= key < len(node)
        )
        if not ok:
            name = format_keypath(path)
            shown = f"[{key}]" if isinstance(key, int) else str(key)
            choices = _children(node)
            close = difflib.get_close_matches(shown, choices, n=1, cutoff=0.6)
            if close:
                fixed = path[:depth] + (int(close[0][1:-1]) if close[0][0] == "[" else close[0],)
                hint = f" (did you mean {format_keypath(fixed + path[depth + 1 :])}?)"
            else:
                whole = difflib.get_close_matches(name, _all_paths(data), n=1, cutoff=0.6)
                hint = f" (did you mean {whole[0]}?)" if whole else ""
            where = f"under {here}" if here else "at the top of the file"
            listing = f"; there: {', '.join(choices[:12])}" if choices else ""
            raise InputError(f"parameter {name}: the file has no {shown!r} {where}{hint}{listing}")
        node = node[key]
    return node


def kind_at(path: KeyPath, nominal: Any) -> str | None:
    """The kind of quantity at a key path: from the unit the file writes there, else from
    where it is (:data:`KINDS`), else None (not known: the parser checks each design)."""
    if isinstance(nominal, str):
        try:
            unit = split_number(nominal)[1]
            if unit:
                return dim_name(parse_unit(unit).dim)
        except UnitError:
            pass
    names = tuple(k for k in path if not isinstance(k, int))
    for pattern, kind in KINDS:
        if len(pattern) == len(names) and all(p in ("*", k) for p, k in zip(pattern, names)):
            return kind
    return None


@dataclass
class Parameter:
    """A number of the file that a study varies.

    Attributes
    ----------
    path, name
        Its key path, as a tuple and as written.
    kind
        The kind of quantity (``"length"``...), None when not known.
    unit
        The unit its values are given and tabulated in ('' for a bare number of a kind
        not known).
    spec
        ``"list"`` (lists and ranges), ``"uniform"`` or ``"normal"``.
    values
        The values of a list or range (in ``unit``), or the distribution's two numbers.
    nominal
        The file's value in ``unit`` (NaN when it cannot be read as one).
    """

    path: KeyPath
    name: str
    kind: str | None
    unit: str
    spec: str
    values: list[float]
    nominal: float = math.nan
    default_unit: str | None = None
    text: str = ""
    notes: list[str] = field(default_factory=list)

    @property
    def header(self) -> str:
        return f"{self.name} [{self.unit or '-'}]"

    def yaml_value(self, x: float) -> Any:
        """What the file holds for value ``x`` (in ``unit``): text with the unit."""
        x = float(x)
        if self.unit:
            return f"{x:.12g} {self.unit}"
        return x

    def si(self, x: float) -> float:
        if self.unit:
            return x * parse_unit(self.unit).factor
        return x

    @property
    def is_random(self) -> bool:
        return self.spec in ("uniform", "normal")


def _split_items(text: str) -> list[str]:
    return [p for p in (s.strip() for s in text.split(",")) if p]


def _list_items(text: str, where: str) -> list[str]:
    """The items of a list of values, split at its commas.

    ``1,5`` (one comma between digits, no space) is refused: a decimal comma, which the
    file's numbers refuse, or two values? So is ``1,000,000`` (digits grouped by
    thousands, or three values?). Two or more commas otherwise make a list
    (``20,25,30``): no number has two decimal commas."""
    m = _DIGIT_COMMA_RE.search(text)
    if m is not None and text.count(",") == 1:
        i = m.start() + 1  # the comma
        point, apart = text[:i] + "." + text[i + 1 :], text[:i] + ", " + text[i + 1 :]
        raise InputError(
            f"{where}: {text!r} has a comma between digits: a decimal comma is not read; "
            f"write {point!r}, or {apart!r} for a list of values"
        )
    g = _THOUSANDS_LIST_RE.match(text)
    if g is not None:
        grouped = g.group(1).replace(",", "") + text[g.end(1) :]
        apart = ", ".join(_split_items(text))
        raise InputError(
            f"{where}: {text!r} may be digits grouped by thousands, which are not read, or "
            f"a list of values: write {grouped!r}, or {apart!r} for a list"
        )
    return _split_items(text)


def _number_unit(item: Any, where: str) -> tuple[float, str]:
    """A value's number and unit text, read as the file's numbers are
    (:func:`mechsolve.base.units.split_number`)."""
    if isinstance(item, bool) or item is None:
        raise InputError(f"{where}: expected a number, got {item!r}")
    if isinstance(item, (int, float)):
        return float(item), ""
    try:
        return split_number(str(item), "a number with a unit")
    except UnitError as exc:
        raise InputError(f"{where}: {exc}") from None


def _count(count: str, text: str, where: str) -> int:
    """The count of values of the range ``text`` (``5``, or ``5.0``: a whole number
    read as the file's are)."""
    try:
        n = whole(read_number(count))
    except UnitError as exc:
        raise InputError(f"{where}: the count of the range {text!r}: {exc}") from None
    if not isinstance(n, int):
        raise InputError(f"{where}: the count {count!r} of {text!r} is not a whole number")
    if n < 1:
        raise InputError(f"{where}: the range {text!r} has {n} values: give a count of 1 or more")
    return n


class _Units:
    """Converts the numbers of one parameter to one unit, checking their kind."""

    def __init__(self, name: str, kind: str | None, default: str | None) -> None:
        self.name, self.kind, self.default = name, kind, default
        self.unit: str | None = None

    def convert(self, x: float, unit: str, written: str) -> float:
        unit = unit or self.default or ""
        if self.kind is not None:
            try:
                si = parse_quantity(f"{x!r} {unit}" if unit else x, self.kind)
            except UnitError as exc:
                raise InputError(
                    f"parameter {self.name}: {written!r}: {exc} (the file's value there is "
                    f"{'an' if self.kind[0] in 'aeiou' else 'a'} {self.kind})"
                ) from None
        else:
            try:
                si = x * parse_unit(unit).factor if unit else x
            except UnitError as exc:
                raise InputError(f"parameter {self.name}: {written!r}: {exc}") from None
        if self.unit is None:
            self.unit = unit
            return x
        if unit == self.unit:
            return x
        if self.kind is None and parse_unit(unit).dim != parse_unit(self.unit or "1").dim:
            raise InputError(
                f"parameter {self.name}: {written!r} is not in a unit of the same kind as "
                f"{self.unit!r}"
            )
        return si / (parse_unit(self.unit).factor if self.unit else 1.0)


def parse_values(name: str, value: Any, kind: str | None, default: str | None):
    """Read VALUES (see the module's docstring): (spec, values, unit)."""
    conv = _Units(name, kind, default)
    if isinstance(value, list):
        if not value:
            raise InputError(f"parameter {name}: the list of values is empty")
        nums = [_number_unit(v, f"parameter {name}") for v in value]
        return "list", [conv.convert(x, u, str(v)) for (x, u), v in zip(nums, value)], conv.unit
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return "list", [conv.convert(float(value), "", str(value))], conv.unit
    if not isinstance(value, str) or not value.strip():
        raise InputError(
            f"parameter {name}: expected values such as '20, 25, 30 mm', '20..30 mm:5', "
            f"'uniform(20, 30 mm)' or 'normal(25 mm, 0.5 mm)', got {value!r}"
        )
    text = value.strip()
    m = _DIST_RE.match(text)
    if m:
        dist = m.group(1).lower()
        items = _split_items(m.group(2))
        if len(items) != 2:
            what = "low, high" if dist == "uniform" else "mean, standard deviation"
            raise InputError(f"parameter {name}: {dist}(...) takes two numbers: {what}")
        nums = [_number_unit(v, f"parameter {name}") for v in items]
        last = nums[-1][1]
        nums = [(x, u or last) for x, u in nums]
        vals = [conv.convert(x, u, text) for x, u in nums]
        if dist == "uniform" and not vals[1] > vals[0]:
            raise InputError(f"parameter {name}: {text!r}: the high end must exceed the low end")
        if dist == "normal" and not vals[1] > 0:
            raise InputError(f"parameter {name}: {text!r}: the standard deviation must be positive")
        return dist, vals, conv.unit
    if ".." in text:
        return _range(name, text, conv)
    items = _list_items(text, f"parameter {name}")
    nums = [_number_unit(v, f"parameter {name}") for v in items]
    last = nums[-1][1]
    nums = [(x, u or last) for x, u in nums]
    return "list", [conv.convert(x, u, it) for (x, u), it in zip(nums, items)], conv.unit


def _range(name: str, text: str, conv: _Units):
    """Read the range ``LOW..HIGH UNIT:COUNT`` (see :func:`parse_values`)."""
    where = f"parameter {name}"
    low, _, high = text.partition("..")
    high, colon, count = high.rpartition(":") if ":" in high else (high, "", "")
    if not colon:
        raise InputError(
            f"{where}: the range {text!r} needs a count of values, e.g. "
            f"'{text}:5' (or use uniform(...) for random designs)"
        )
    if not low.strip() or not high.strip() or ".." in high:
        raise InputError(
            f"{where}: cannot read the range {text!r}: write LOW..HIGH UNIT:COUNT, "
            "e.g. '20..30 mm:5'"
        )
    (lo, ulo), (hi, uhi) = _number_unit(low, where), _number_unit(high, where)
    n = _count(count.strip(), text, where)
    a = conv.convert(lo, ulo or uhi, text)
    b = conv.convert(hi, uhi, text)
    if n == 1:
        if a != b:
            raise InputError(
                f"{where}: {text!r}: a count of 1 needs equal ends (or give a count of 2 or more)"
            )
        return "list", [a], conv.unit
    return "list", [a + (b - a) * k / (n - 1) for k in range(n)], conv.unit


def make_parameter(data: dict, keypath: str, value: Any, units: dict[str, str]) -> Parameter:
    """A parameter of the document ``data`` (after any variant) from its key path and
    VALUES; ``units`` is the file's ``units`` section (defaults of bare numbers)."""
    path = parse_keypath(keypath)
    nominal = lookup(data, path)
    name = format_keypath(path)
    if isinstance(nominal, (dict, list)):
        hint = ""
        if isinstance(nominal, list) and len(nominal) == 2:
            hint = f": vary {name}[0] (x) or {name}[1] (y)"
        elif isinstance(nominal, dict):
            hint = f": vary one of its numbers, e.g. {name}.{next(iter(nominal), '?')}"
        raise InputError(f"parameter {name}: this is not a single number{hint}")
    if isinstance(nominal, bool) or nominal is None:
        raise InputError(f"parameter {name}: the file's value {nominal!r} is not a number")
    kind = kind_at(path, nominal)
    default = {"length": units.get("length", "m"), "angle": units.get("angle", "deg")}.get(
        kind or ""
    )
    if default is None and kind is not None:
        default = SI_UNIT.get(kind, "")
    spec, values, unit = parse_values(name, value, kind, default)
    p = Parameter(path, name, kind, unit or "", spec, values, default_unit=default, text=str(value))
    try:  # the file's value, in the parameter's unit
        if kind is not None:
            si = parse_quantity(nominal, kind, default)
            p.nominal = float(f"{si / (parse_unit(p.unit).factor if p.unit else 1.0):.12g}")
        else:
            p.nominal = float(nominal)
    except (UnitError, ValueError, TypeError):
        pass
    return p


def parse_option(text: str) -> tuple[str, str]:
    """``-p "links.crank.points.A[0]=20..30 mm:5"`` -> (key path, values)."""
    if "=" not in text:
        raise InputError(
            f'-p {text!r}: write KEYPATH=VALUES, e.g. -p "links.crank.points.A[0]=20..30 mm:5"'
        )
    key, _, values = text.partition("=")
    return key.strip(), values.strip()


__all__ = [
    "KINDS",
    "Parameter",
    "format_keypath",
    "kind_at",
    "lookup",
    "make_parameter",
    "parse_keypath",
    "parse_option",
    "parse_values",
]
