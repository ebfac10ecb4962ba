"""Quantities with units, as textbooks write them: ``"110 mm"``, ``"25 deg"``, ``"1.06 rpm"``.

Everything inside mechsolve is SI (m, kg, s, N, rad). A value in a mechanism file may be
a plain number or a string ``"<number> <unit>"``. A plain number is SI, except lengths and
angles, which use the file's ``units.length`` (default m) and ``units.angle`` (default deg).

Dimensions are vectors of exponents over (length, mass, time, angle). Angle is kept as a
dimension of its own so that ``"110 mm"`` given for an angle is caught; a value without
an angle where one is expected (``"2 1/s"`` for an angular speed) is read as radians.

US customary units are exact: in, ft, yd, lbm, lbf, slug (lbf s^2/ft), blob (lbf s^2/in),
kip, psi, ksi. ``lb`` is read as a pound-mass where that gives the expected dimension and
as a pound-force otherwise, as textbooks print it: ``"50 lb"`` is a force where a force
is expected, ``"2 lb"`` a mass where a mass is, and ``"0.3 lb in s^2"`` (lbf s^2 in) a
moment of inertia.
"""

from __future__ import annotations

import math
import re
import unicodedata
from dataclasses import dataclass

Dim = tuple[int, int, int, int]  # exponents of length, mass, time, angle

_DIMS: dict[str, Dim] = {
    "dimensionless": (0, 0, 0, 0),
    "length": (1, 0, 0, 0),
    "mass": (0, 1, 0, 0),
    "time": (0, 0, 1, 0),
    "angle": (0, 0, 0, 1),
    "speed": (1, 0, -1, 0),
    "acceleration": (1, 0, -2, 0),
    "angular speed": (0, 0, -1, 1),
    "angular acceleration": (0, 0, -2, 1),
    "force": (1, 1, -2, 0),
    "torque": (2, 1, -2, 0),
    "moment of inertia": (2, 1, 0, 0),
    "stiffness": (0, 1, -2, 0),
    "damping": (0, 1, -1, 0),
    "rotational damping": (2, 1, -1, -1),
    "density per length": (-1, 1, 0, 0),
}

# the avoirdupois pound (exact, 1959) and the pound-force under standard gravity
_LB = 0.45359237  # kg
_LBF = _LB * 9.80665  # N

# symbol -> (factor to SI, dimension)
_UNITS: dict[str, tuple[float, Dim]] = {
    # length
    "m": (1.0, (1, 0, 0, 0)),
    "mm": (1e-3, (1, 0, 0, 0)),
    "cm": (1e-2, (1, 0, 0, 0)),
    "dm": (1e-1, (1, 0, 0, 0)),
    "km": (1e3, (1, 0, 0, 0)),
    "um": (1e-6, (1, 0, 0, 0)),
    # US customary, exact by definition (1959): 1 in = 0.0254 m, 1 ft = 0.3048 m
    "in": (0.0254, (1, 0, 0, 0)),
    "inch": (0.0254, (1, 0, 0, 0)),
    "ft": (0.3048, (1, 0, 0, 0)),
    "yd": (0.9144, (1, 0, 0, 0)),
    # mass
    "kg": (1.0, (0, 1, 0, 0)),
    "g": (1e-3, (0, 1, 0, 0)),
    "t": (1e3, (0, 1, 0, 0)),
    "lbm": (_LB, (0, 1, 0, 0)),  # "lb" is lbm or lbf, see parse_quantity
    "slug": (_LBF / 0.3048, (0, 1, 0, 0)),  # lbf s^2/ft
    "blob": (_LBF / 0.0254, (0, 1, 0, 0)),  # lbf s^2/in (Norton's unit)
    # time
    "s": (1.0, (0, 0, 1, 0)),
    "ms": (1e-3, (0, 0, 1, 0)),
    "sec": (1.0, (0, 0, 1, 0)),
    "min": (60.0, (0, 0, 1, 0)),
    "h": (3600.0, (0, 0, 1, 0)),
    # angle
    "rad": (1.0, (0, 0, 0, 1)),
    "deg": (math.pi / 180.0, (0, 0, 0, 1)),
    "°": (math.pi / 180.0, (0, 0, 0, 1)),
    "rev": (2.0 * math.pi, (0, 0, 0, 1)),
    "r": (2.0 * math.pi, (0, 0, 0, 1)),
    "turn": (2.0 * math.pi, (0, 0, 0, 1)),
    # rotational speed
    "rpm": (2.0 * math.pi / 60.0, (0, 0, -1, 1)),
    # force, torque, energy, power, pressure
    "N": (1.0, (1, 1, -2, 0)),
    "kN": (1e3, (1, 1, -2, 0)),
    "MN": (1e6, (1, 1, -2, 0)),
    "kgf": (9.80665, (1, 1, -2, 0)),
    "lbf": (_LBF, (1, 1, -2, 0)),
    "kip": (1e3 * _LBF, (1, 1, -2, 0)),
    "Nm": (1.0, (2, 1, -2, 0)),
    "kNm": (1e3, (2, 1, -2, 0)),
    "J": (1.0, (2, 1, -2, 0)),
    "kJ": (1e3, (2, 1, -2, 0)),
    "W": (1.0, (2, 1, -3, 0)),
    "kW": (1e3, (2, 1, -3, 0)),
    "Pa": (1.0, (-1, 1, -2, 0)),
    "kPa": (1e3, (-1, 1, -2, 0)),
    "MPa": (1e6, (-1, 1, -2, 0)),
    "bar": (1e5, (-1, 1, -2, 0)),
    "psi": (_LBF / 0.0254**2, (-1, 1, -2, 0)),
    "ksi": (1e3 * _LBF / 0.0254**2, (-1, 1, -2, 0)),
}

# The largest magnitude (SI) a value of each kind may have. Far beyond any mechanism, and
# small enough that no later formula overflows: with lengths to 1e6 m, angular speeds to
# 1e6 rad/s and masses to 1e9 kg, accelerations stay below 1e18 m/s^2, inertia forces
# below 1e27 N and powers below 1e40 W, squares of them far inside the float range.
LIMITS: dict[str, float] = {
    "dimensionless": 1e12,
    "length": 1e6,
    "mass": 1e9,
    "time": 1e9,
    "angle": 1e6,
    "speed": 1e6,
    "acceleration": 1e6,
    "angular speed": 1e6,
    "angular acceleration": 1e12,
    "force": 1e12,
    "torque": 1e15,
    "moment of inertia": 1e21,
    "stiffness": 1e12,
    "damping": 1e12,
    "rotational damping": 1e15,
    "density per length": 1e9,
}

# how the limits are written in messages
_SI = {
    "length": "m",
    "mass": "kg",
    "time": "s",
    "angle": "rad",
    "speed": "m/s",
    "acceleration": "m/s^2",
    "angular speed": "rad/s",
    "angular acceleration": "rad/s^2",
    "force": "N",
    "torque": "N m",
    "moment of inertia": "kg m^2",
    "stiffness": "N/m",
    "damping": "N s/m",
    "rotational damping": "N m s/rad",
    "density per length": "kg/m",
}

# a unit's exponent: m^4 (second moment of area) is the largest any mechanism needs
MAX_EXPONENT = 6

# A number as a quantity's text starts: ASCII digits only, as the JSON Schema's editors
# (ECMAScript regular expressions, where \d is [0-9]) read it; Python's \d would take any
# script's digits. The schema's patterns are built from these two.
NUMBER_PATTERN = r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?"
SPACE_PATTERN = r"[ \t\r\n\u00a0\u3000]"  # and the no-break and ideographic spaces
_NUMBER = NUMBER_PATTERN
_QUANTITY_RE = re.compile(rf"^{SPACE_PATTERN}*({_NUMBER}){SPACE_PATTERN}*(.*?)\s*$")
_FACTOR_RE = re.compile(r"^([A-Za-zµ°]+)(?:(?:\^|\*\*)([-+]?[0-9]+))?$")


class UnitError(ValueError):
    """A quantity could not be read or has the wrong dimension."""


@dataclass(frozen=True)
class Unit:
    """A parsed unit: multiply a number by ``factor`` to get SI."""

    factor: float
    dim: Dim


def dimension(kind: str) -> Dim:
    """Return the dimension vector of a named kind of quantity (``"length"``...)."""
    return _DIMS[kind]


def dim_name(dim: Dim) -> str:
    """Name a dimension vector in words, for messages."""
    for name, d in _DIMS.items():
        if d == dim:
            return name
    parts = []
    for sym, e in zip(("m", "kg", "s", "rad"), dim):
        if e:
            parts.append(sym if e == 1 else f"{sym}^{e}")
    return " ".join(parts) or "dimensionless"


_HYPHEN_RE = re.compile(r"(?<=[A-Za-z])-(?=[A-Za-z])")
_LB_RE = re.compile(r"(?<![A-Za-z])lb(?![A-Za-z])")
_SUPERSCRIPT_RE = re.compile("⁻?[⁰¹²³⁴⁵⁶⁷⁸⁹]+")
_SUPERSCRIPTS = str.maketrans("⁻⁰¹²³⁴⁵⁶⁷⁸⁹", "-0123456789")


def parse_unit(text: str, pound: str = "lbm") -> Unit:
    """Parse a unit expression such as ``"m/s^2"``, ``"kg m^2"``, ``"N*m"``, ``"r/min"``.

    Products may be written with spaces, ``*``, ``·`` or, between letters, ``-``
    (``"lb-in"``); exponents with ``^``, ``**`` or superscripts (``"s²"``). ``lb``
    stands for ``pound`` (``"lbm"`` or ``"lbf"``).
    """
    text = text.strip().replace("·", " ").replace("µ", "u")
    text = _HYPHEN_RE.sub(" ", text)
    text = _SUPERSCRIPT_RE.sub(lambda m: "^" + m.group().translate(_SUPERSCRIPTS), text)
    if text in ("", "1", "-"):
        return Unit(1.0, (0, 0, 0, 0))
    factor = 1.0
    dim = [0, 0, 0, 0]
    parts = text.split("/")
    for i, part in enumerate(parts):
        sign = 1 if i == 0 else -1
        tokens = [tok for tok in re.split(r"[\s*]+", part.strip()) if tok]
        if not tokens:
            if i == 0 and len(parts) > 1:  # "1/s" written as "/s"
                continue
            raise UnitError(f"cannot read unit {text!r}")
        for tok in tokens:
            if tok == "1" and i == 0:
                continue
            m = _FACTOR_RE.match(tok)
            sym = m.group(1) if m else ""
            if sym == "lb":
                sym = pound
            if sym not in _UNITS:
                known = ", ".join(sorted([*_UNITS, "lb"]))
                raise UnitError(f"unknown unit {tok!r} in {text!r} (known units: {known})")
            f, d = _UNITS[sym]
            exp = sign * int(m.group(2) or 1)
            if abs(exp) > MAX_EXPONENT:
                raise UnitError(
                    f"the exponent in {tok!r} of {text!r} is beyond {MAX_EXPONENT}: "
                    "no quantity of a mechanism has such a unit"
                )
            factor *= f**exp
            for k in range(4):
                dim[k] += d[k] * exp
    return Unit(factor, tuple(dim))  # type: ignore[arg-type]


_EXAMPLE = {
    "dimensionless": "0.5",
    "length": "110 mm",
    "mass": "2.5 kg",
    "time": "0.5 s",
    "angle": "25 deg",
    "speed": "0.3 m/s",
    "acceleration": "9.81 m/s^2",
    "angular speed": "1.06 rpm",
    "angular acceleration": "2 rad/s^2",
    "force": "50 kN",
    "torque": "12 N*m",
    "moment of inertia": "0.02 kg*m^2",
    "stiffness": "500 N/m",
    "damping": "15 N*s/m",
    "rotational damping": "0.1 N*m*s/rad",
    "density per length": "2 kg/m",
}


def _a(word: str) -> str:
    """``a length``, ``an angle``."""
    return ("an " if word[:1].lower() in "aeiou" else "a ") + word


def _to_float(value: object) -> float:
    try:
        return float(value)  # type: ignore[arg-type]
    except OverflowError:
        raise UnitError(f"{str(value)[:20]}... is too large a number") from None


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def check_range(x: float, kind: str, value: object = None) -> float:
    """Return ``x`` (SI) if it is finite and within :data:`LIMITS` for ``kind``; else
    raise :class:`UnitError` saying so (``value`` is what the user wrote)."""
    shown = _short(x if value is None else value)
    if not math.isfinite(x):
        raise UnitError(f"{shown} is not a finite number")
    limit = LIMITS.get(kind, LIMITS["dimensionless"])
    if abs(x) > limit:
        unit = _SI.get(kind, "")
        raise UnitError(
            f"{shown} is too large a number for {_a(kind)}: mechsolve accepts at most "
            f"{limit:g}{' ' + unit if unit else ''} in magnitude"
        )
    return x


def _finite(x: float, text: object) -> float:
    if not math.isfinite(x):
        raise UnitError(f"{text!r} is not a finite number")
    return x


def parse_quantity(value: object, kind: str, default_unit: str | None = None) -> float:
    """Convert a plain number or a ``"<number> <unit>"`` string to SI.

    Parameters
    ----------
    value
        A number, or a string such as ``"110 mm"``.
    kind
        The kind of quantity expected (a key of the dimension table, e.g. ``"length"``).
    default_unit
        The unit of a plain number; SI when not given.

    Returns
    -------
    float
        The value in SI units (radians for angles).
    """
    want = _DIMS[kind]
    if isinstance(value, bool) or value is None:
        raise UnitError(f"expected {_a(kind)}, got {value!r}")
    if isinstance(value, (int, float)):
        x = _finite(_to_float(value), value)
        if default_unit is not None:
            x *= parse_unit(default_unit).factor
        return check_range(x, kind, value)
    if not isinstance(value, str):
        raise UnitError(
            f"expected {_a(kind)} (a number or a string like '{_EXAMPLE.get(kind, '110 mm')}'), "
            f"got {value!r}"
        )
    number, unit_text = split_number(
        value, f"{_a(kind)}: write a number and a unit, e.g. '{_EXAMPLE.get(kind, '110 mm')}'"
    )
    if unit_text == "":
        unit = parse_unit(default_unit) if default_unit else Unit(1.0, want)
    else:
        unit = parse_unit(unit_text)
        if not _fits(unit.dim, want) and _LB_RE.search(unit_text):
            # textbooks write "lb" for the pound-force too ("50 lb", "lb in s^2")
            alt = parse_unit(unit_text, pound="lbf")
            if _fits(alt.dim, want):
                unit = alt
    dim = unit.dim
    if not _fits(dim, want):
        raise UnitError(f"{value!r} is {_a(dim_name(dim))}, but {_a(kind)} is expected")
    return check_range(number * unit.factor, kind, value)


def split_number(value: str, what: str = "a number") -> tuple[float, str]:
    """The number that starts ``value`` and the text after it (its unit, ``''`` for
    none), read by the rule of the file's numbers, which the command line follows too:
    ASCII digits, a decimal point; ``1:45``, ``1_000``, ``1,5``, a signed ``0x1F`` and
    full-width digits are refused saying why (:class:`UnitError`), as is text that does
    not start with a number (``what``: what was expected, for the message)."""
    odd = _other_digits(value)
    if odd:
        raise UnitError(odd)
    m = _QUANTITY_RE.match(value)
    if not m:
        raise UnitError(f"cannot read {value!r} as {what}")
    odd = _not_a_number(value, m.group(1), m.group(2), m.end(1) == m.start(2))
    if odd:
        raise UnitError(odd)
    return _finite(_to_float(m.group(1)), value), m.group(2)


def read_number(text: str) -> float:
    """A plain number written as text (a command-line option's), by the rule of
    :func:`split_number`; :class:`UnitError` saying why otherwise (``20 mm``: a unit where
    a plain number is wanted)."""
    x, rest = split_number(text)
    if rest:
        raise UnitError(f"{text!r} is not a plain number (a number without a unit is wanted)")
    return x


_SEXAGESIMAL_RE = re.compile(r"^:[0-9]")
_GROUPED_RE = re.compile(r"^(?:_[0-9]+)+")
_DECIMAL_COMMA_RE = re.compile(r"^,[0-9]")
_THOUSANDS_RE = re.compile(r"^(?:,[0-9]{3})+(?![0-9])")  # 1,500 or 1,000,000
_ONE_COMMA_RE = re.compile(r"^,[0-9]+(?![0-9.,_:])")  # 1,5 as 1.5 (not 1,5.2 nor 1,000,000)
# a base prefix after a 0 read as the number: 0x1F, 0o17, 0b11010 (the rest: a unit)
_BASE_RE = re.compile(r"^([xob])([0-9a-f]+)(?![0-9a-z_.])(.*)$", re.IGNORECASE)


_PLAIN_NUMBER_RE = re.compile(rf"^{SPACE_PATTERN}*{NUMBER_PATTERN}{SPACE_PATTERN}*$")


def plain_float(text: str) -> float:
    """A number written as text (``"1e-6"``, ``" 0.5 "``), read as the JSON Schema's
    pattern reads it: ASCII digits, no ``_`` grouping (Python's ``float`` would take
    ``"1_0"`` and full-width digits). Raises :class:`ValueError` otherwise."""
    if not _PLAIN_NUMBER_RE.match(text):
        raise ValueError(f"{text!r} is not a number")
    return float(text)


def _other_digits(value: str) -> str | None:
    """Why ``value`` is refused if it has digits other than ASCII 0-9 (full-width digits
    from an input method, say); None otherwise."""
    if not any(c.isdecimal() and not c.isascii() for c in value):
        return None
    fixed = "".join(str(unicodedata.decimal(c)) if c.isdecimal() else c for c in value)
    return (
        f"{value!r} has digits other than ASCII 0-9 (full-width digits from an input "
        f"method?), which are not read as a number: write {fixed!r}"
    )


def _not_a_number(value: str, number: str, rest: str, joined: bool = True) -> str | None:
    """Why ``value`` (read as ``number`` then ``rest``) is not a number someone meant,
    where the number runs on in a way no unit starts: ``1:45`` (YAML 1.1's base 60),
    ``1_500`` (grouped digits), ``1,5`` (a decimal comma); None otherwise. The number to
    write instead is given where ``rest`` follows ``number`` directly (``joined``)."""
    if _SEXAGESIMAL_RE.match(rest):
        return (
            f"{value!r} is not a number: 'a:b' values (YAML 1.1's base 60, a time as h:min) "
            "are not read; write one decimal number"
        )
    m = _GROUPED_RE.match(rest)
    if m:
        fixed = number + m.group().replace("_", "") + rest[m.end() :]
        return f"{value!r} is not a number: digits grouped with '_' are not read" + (
            f"; write {fixed!r}" if joined else ""
        )
    if _DECIMAL_COMMA_RE.match(rest):
        return _comma(value, number, rest, joined)
    return _based(value, number, rest) if joined else None


def _comma(value: str, number: str, rest: str, joined: bool) -> str:
    """Why ``value`` (``number`` then ``rest``, a comma and a digit) is refused: a decimal
    comma (``1,5``), digits grouped by thousands (``1,000,000``, ``12,345.6``) or either
    (``1,500``); the numbers to write where ``rest`` follows ``number`` directly."""
    plain = "." not in number and "e" not in number.lower()
    decimal = plain and _ONE_COMMA_RE.match(rest) is not None
    lead = number.lstrip("+-")  # a thousands group leads with 1 to 3 digits, not 0
    g = _THOUSANDS_RE.match(rest) if plain and len(lead) <= 3 and lead[:1] != "0" else None
    write = [number + "." + rest[1:]] if decimal else []
    if g is not None:
        write.append(number + g.group().replace(",", "") + rest[g.end() :])
    if g is None:
        why = "a decimal comma is not read"
    elif decimal:
        why = "a comma is not read (a decimal comma, or digits grouped by thousands?)"
    else:
        why = "digits grouped with ',' are not read"
    shown = " or ".join(repr(w) for w in write)
    return f"{value!r} is not a number: {why}" + (f"; write {shown}" if joined and shown else "")


def _based(value: str, number: str, rest: str) -> str | None:
    """Why ``value``, a number in base 16, 8 or 2 (``-0x1F``, ``0b11010``, ``0x1F mm``),
    is refused, with its decimal value to write; None where it is not one. YAML 1.2 core
    reads ``0x`` and ``0o`` without a sign only, and has no ``0b``."""
    m = _BASE_RE.match(rest)
    if not m or number.lstrip("+-") != "0":
        return None
    try:
        n = int(f"{number}{m.group(1)}{m.group(2)}", 0)
    except ValueError:
        return None
    unit = m.group(3).strip()
    fixed = f"{n} {unit}" if unit else str(n)
    if unit:
        why = "a number in base 16, 8 or 2 is not read before a unit"
    elif m.group(1).lower() == "b":
        why = "binary numbers (0b) are not read (YAML 1.2 has none)"
    else:
        why = (
            "a hexadecimal or octal number with a sign is not read (YAML 1.2 reads "
            "0x1F and 0o17 without one)"
        )
    return f"{value!r} is not a number: {why}; write {fixed!r}"


def _fits(dim: Dim, want: Dim) -> bool:
    """Whether a unit of dimension ``dim`` gives a quantity of dimension ``want``: an
    angle is dimensionless in SI, so "2 1/s" is a valid angular speed in rad/s."""
    return dim == want or (want[3] != 0 and dim[:3] == want[:3] and dim[3] == 0)


def format_unit(kind: str) -> str:
    """The SI unit printed in CSV headers and plot labels for a kind of quantity."""
    return {
        "length": "m",
        "speed": "m/s",
        "acceleration": "m/s^2",
        "angle": "deg",
        "angular speed": "rad/s",
        "angular acceleration": "rad/s^2",
        "time": "s",
        "force": "N",
        "torque": "N*m",
        "mass": "kg",
        "dimensionless": "-",
    }[kind]


# --- the units results are shown in ------------------------------------------------------

# the units the results' columns are computed in (SI, angles in degrees), and their kind
_COLUMN_KINDS: dict[str, str] = {
    "m": "length",
    "m/s": "speed",
    "m/s^2": "acceleration",
    "deg": "angle",
    "rad/s": "angular speed",
    "rad/s^2": "angular acceleration",
    "s": "time",
    "N": "force",
    "N*m": "torque",
    "J": "energy",
    "W": "power",
}

# the keys of a units map and the dimension each must have
_OUTPUT_KEYS: dict[str, Dim] = {
    "length": (1, 0, 0, 0),
    "angle": (0, 0, 0, 1),
    "force": (1, 1, -2, 0),
    "time": (0, 0, 1, 0),
    "torque": (2, 1, -2, 0),
    "energy": (2, 1, -2, 0),
    "power": (2, 1, -3, 0),
}


@dataclass(frozen=True)
class OutputUnits:
    """The units the results are written and printed in; computed values stay SI.

    ``angle`` is the unit of angles; ``rate_angle`` the angle unit of angular speeds and
    accelerations (``rad`` gives rad/s, ``deg`` deg/s). ``torque`` ``None`` means the
    force unit times the length unit (N*mm for a file in mm). The default is the SI
    output: m, m/s, m/s^2, deg, rad/s, rad/s^2, s, N, N*m, J, W.
    """

    length: str = "m"
    angle: str = "deg"
    rate_angle: str = "rad"
    force: str = "N"
    time: str = "s"
    torque: str | None = None
    energy: str = "J"
    power: str = "W"

    def unit_of(self, kind: str) -> str:
        """The unit (ASCII, as in the CSV headers) of a kind of quantity."""
        L, T, R = self.length, self.time, self.rate_angle
        return {
            "length": L,
            "speed": f"{L}/{T}",
            "acceleration": f"{L}/{T}^2",
            "angle": self.angle,
            "angular speed": f"{R}/{T}",
            "angular acceleration": f"{R}/{T}^2",
            "time": T,
            "force": self.force,
            "torque": self.torque or f"{self.force}*{L}",
            "energy": self.energy,
            "power": self.power,
        }[kind]

    def convert(self, unit: str) -> tuple[float, str]:
        """``(factor, shown unit)`` for values in a column's ``unit`` (one of the SI units
        the results are computed in, ``deg`` for angles): shown value = factor * value.
        A unit of no known kind (``-``) is kept, with factor 1."""
        kind = _COLUMN_KINDS.get(unit)
        if kind is None:
            return 1.0, unit
        target = self.unit_of(kind)
        if target == unit:
            return 1.0, unit
        return parse_unit(unit).factor / parse_unit(target).factor, target

    def show(self, value, unit: str):
        """``(value, shown unit)``: ``value`` (a number or an array, in ``unit``) converted."""
        k, target = self.convert(unit)
        return (value if k == 1.0 else value * k), target

    def text(self, value: float, unit: str, fmt: str = ".6g") -> str:
        """A value in ``unit`` as printed text in the shown unit: ``'110 mm'``, ``'25°'``."""
        v, target = self.show(float(value), unit)
        return f"{format(v, fmt)}{spaced(pretty_unit(target))}"

    @property
    def is_si(self) -> bool:
        return self == SI_OUTPUT


SI_OUTPUT = OutputUnits()


def file_output_units(length_unit: str = "m", angle_unit: str | None = None) -> OutputUnits:
    """The output units of a file whose ``units:`` give ``length_unit`` and ``angle_unit``
    (``None`` when the file does not name one: angles in degrees, their rates in rad/s)."""
    return OutputUnits(
        length=length_unit,
        angle=angle_unit or "deg",
        rate_angle=angle_unit or "rad",
    )


def parse_output_units(text: str, base: OutputUnits = SI_OUTPUT) -> OutputUnits:
    """Read ``--units``: ``SI`` (the SI output), ``file`` (``base``, the file's own units)
    or a map ``length=mm,angle=deg,force=kN`` whose keys replace those of ``base`` (keys:
    length, angle, force, time, torque, energy, power). Raises :class:`UnitError` with
    the reason."""
    t = text.strip()
    if t.upper() == "SI":
        return SI_OUTPUT
    if t.lower() == "file":
        return base
    fields: dict[str, str] = {}
    for part in t.split(","):
        if not part.strip():
            continue
        key, eq, unit = part.partition("=")
        key, unit = key.strip().lower(), unit.strip()
        if not eq or not key or not unit:
            raise UnitError(
                f"cannot read {part.strip()!r}: write SI, file, or KEY=UNIT pairs separated "
                "by commas, e.g. 'length=mm,angle=deg,force=kN'"
            )
        if key not in _OUTPUT_KEYS:
            raise UnitError(f"unknown key {key!r} (keys: {', '.join(_OUTPUT_KEYS)})")
        if key in fields:
            raise UnitError(f"{key!r} is given twice")
        try:
            u = parse_unit(unit)
        except UnitError as exc:
            raise UnitError(f"{key}={unit}: {exc}") from None
        if u.dim != _OUTPUT_KEYS[key]:
            raise UnitError(f"{key}={unit}: {unit!r} is not a unit of {key}")
        fields[key] = unit
    if not fields:
        raise UnitError("no units given: write SI, file, or e.g. 'length=mm,angle=deg'")
    if "angle" in fields:
        fields["rate_angle"] = fields["angle"]
    from dataclasses import replace

    return replace(base, **fields)


_PRETTY_EXP = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def pretty_unit(unit: str) -> str:
    """A unit as a figure or a printed summary shows it: ``N*m`` → ``N·m``, ``m/s^2`` →
    ``m/s²``, ``deg`` → ``°``, ``deg/s`` → ``°/s``, ``um`` → ``µm``; ``-`` stays."""
    if unit in ("", "-"):
        return unit
    u = re.sub(r"\^(-?\d+)", lambda m: m.group(1).translate(_PRETTY_EXP), unit)
    u = re.sub(r"\s*\*\s*", "·", u)
    u = re.sub(r"(?<![A-Za-z])deg(?![A-Za-z])", "°", u)
    u = re.sub(r"(?<![A-Za-z])um(?![A-Za-z])", "µm", u)
    return u


def spaced(unit: str) -> str:
    """The text after a number for ``unit``: ``' mm'``, but ``'°'`` (no space) for degrees."""
    if not unit or unit == "-":
        return ""
    return unit if unit.startswith("°") and "/" not in unit else " " + unit


_SUBSCRIPT = str.maketrans("aeimnox0123456789", "ₐₑᵢₘₙₒₓ₀₁₂₃₄₅₆₇₈₉")
_GREEK_SUB = re.compile(r"(?<![A-Za-z])(omega|alpha|delta|theta|phi|psi)_(max|min|mean|m|0|1|2)\b")
_GREEK = {"omega": "ω", "alpha": "α", "delta": "δ", "theta": "θ", "phi": "φ", "psi": "ψ"}
_BRACKET = re.compile(r"\[([^\[\]]+)\]")
_UNIT_TOKEN = re.compile(
    r"(?<![\w.])([A-Za-zµ°]+(?:\^-?\d+)?(?:[*/][A-Za-zµ°]+(?:\^-?\d+)?)+|[A-Za-zµ]+\^-?\d+)"
    r"(?![\w(])"
)


def _is_unit(text: str) -> bool:
    try:
        parse_unit(text)
    except UnitError:
        return False
    return True


def pretty_text(text: str) -> str:
    """A figure's or a printed summary's text as a report prints it: units in brackets
    and unit products (``[kg*m^2]``, ``12 N*m``) with ``·`` and superscripts (``kg·m²``,
    ``N·m``), ``omega_max^2`` as ``ωₘₐₓ²``, ``dE_max`` as ``ΔEₘₐₓ``, ``pi^2`` as ``π²``.
    Words that are not units are left as they are; mathtext (``$...$``) is not touched."""
    if "$" in text:
        return text

    def bracket(m: re.Match) -> str:
        inner = m.group(1)
        return f"[{pretty_unit(inner)}]" if _is_unit(inner) else m.group(0)

    def token(m: re.Match) -> str:
        t = m.group(1)
        return pretty_unit(t) if _is_unit(t) else t

    out = _BRACKET.sub(bracket, text)
    out = re.sub(  # "psi (deg)": a unit in parentheses after a word
        r"(?<= )\(([^()]+)\)",
        lambda m: f"({pretty_unit(m[1])})" if _is_unit(m[1]) else m.group(0),
        out,
    )
    out = _UNIT_TOKEN.sub(token, out)
    out = _GREEK_SUB.sub(lambda m: _GREEK[m[1]] + m[2].translate(_SUBSCRIPT), out)
    out = re.sub(r"(?<![A-Za-z_])(omega|alpha)(?=\^)", lambda m: _GREEK[m[1]], out)
    out = re.sub(r"(?<=[A-Z])\((phi|theta|psi)\)", lambda m: f"({_GREEK[m[1]]})", out)
    out = re.sub(r"(?<![A-Za-z])dE_max\b", "ΔEₘₐₓ", out)
    out = re.sub(r"(?<![A-Za-z])pi(?=\^)", "π", out)
    out = re.sub(r"(?<=[\w)ₐₑᵢₘₙₒₓ])\^(-?\d+)\b", lambda m: m[1].translate(_PRETTY_EXP), out)
    return out
