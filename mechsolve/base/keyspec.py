"""The vocabulary of key declarations: what one value of a file may be (:class:`Kind`),
one key (:class:`Key`) and one mapping (:class:`Section`).

The model declares the file's keys with it (:mod:`mechsolve.model.keys`), the joint kinds
declare their own (:mod:`mechsolve.joints`), and the schema's builder turns the
declarations into the JSON Schema.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Kind:
    """What one value may be.

    ``tag`` is one of ``quantity`` (``arg``: the dimension), ``xy``, ``text``, ``name``
    (``arg``: point, link or joint), ``names`` (``arg``: what; ``count``: exact length;
    ``low``: the least length),
    ``condition``, ``expression`` (``arg``: its variables), ``flag``, ``number``,
    ``integer``, ``choice`` (``arg``: the values), ``const`` (``arg``: the value),
    ``null``, ``any``, ``list`` (``arg``: the items' kind; ``count``: the least length),
    ``pair`` (``arg``: the two items' kinds), ``map`` (``arg``: the values' kind;
    ``names``: what the keys name, or ``None`` for free text), ``section`` (``arg``: a
    section's id) and ``either`` (``arg``: alternative kinds).
    """

    tag: str
    arg: Any = None
    count: int | None = None
    names: str | None = None
    low: float | None = None
    high: float | None = None
    doc: str = ""


def quantity(dim: str) -> Kind:
    return Kind("quantity", dim)


XY = Kind("xy")
TEXT = Kind("text")
CONDITION = Kind("condition")
FLAG = Kind("flag")
NULL = Kind("null")
ANY = Kind("any")


def name(what: str) -> Kind:
    return Kind("name", what)


def names(what: str, count: int | None = None, least: int | None = None) -> Kind:
    """A list of names: exactly ``count`` of them, or at least ``least``."""
    return Kind("names", what, count=count, low=least)


def expression(*variables: str) -> Kind:
    return Kind("expression", variables)


def number(low: float | None = None, high: float | None = None) -> Kind:
    return Kind("number", low=low, high=high)


def integer(low: int | None = None, high: int | None = None) -> Kind:
    return Kind("integer", low=low, high=high)


def whole(value: Any) -> Any:
    """``value`` as an ``int`` where it is a float with no fraction (``10.0``): a JSON
    Schema integer, as the editors read it; anything else unchanged, for the caller to
    check."""
    if isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
        return int(value)
    return value


def choice(*values: str) -> Kind:
    return Kind("choice", tuple(values))


def const(value: Any) -> Kind:
    return Kind("const", value)


def list_of(item: Kind, least: int | None = None) -> Kind:
    return Kind("list", item, count=least)


def pair(first: Kind, second: Kind) -> Kind:
    return Kind("pair", (first, second))


def map_of(value: Kind, keys: str | None = None) -> Kind:
    """A mapping of names (of ``keys``: point, link, joint...; ``None``: any text) to
    values of kind ``value``."""
    return Kind("map", value, names=keys)


def section(sid: str) -> Kind:
    return Kind("section", sid)


def either(*kinds: Kind, doc: str = "") -> Kind:
    return Kind("either", tuple(kinds), doc=doc)


@dataclass(frozen=True)
class Key:
    """One key of a section: its kind, a one-line description, whether it is required."""

    kind: Kind
    doc: str
    required: bool = False


@dataclass(frozen=True)
class Section:
    """One mapping of the file format.

    Parameters
    ----------
    title
        A short title (the schema's ``title``).
    doc
        One line on what the mapping is.
    keys
        The keys in the order the parser lists them in its messages.
    one_of
        Keys of which exactly one must be given (a load's kind, a joint's kind...).
    needs
        Keys that need other keys (``stall`` needs ``slope``).
    kinds
        For each key of ``one_of``, the keys that apply with it (a force load has
        ``at``, a torque load has not); the keys of no kind (``when``) apply to all.
    """

    title: str
    doc: str
    keys: dict[str, Key]
    one_of: tuple[str, ...] = ()
    needs: dict[str, tuple[str, ...]] = field(default_factory=dict)
    kinds: dict[str, set[str]] = field(default_factory=dict)

    @property
    def allowed(self) -> tuple[str, ...]:
        """The keys the parser accepts, in its order."""
        return tuple(self.keys)

    @property
    def required(self) -> tuple[str, ...]:
        """The keys that must be given, in the parser's order."""
        return tuple(k for k, v in self.keys.items() if v.required)

    def only(self, *keys: str, title: str | None = None) -> Section:
        """The same section restricted to ``keys`` (in that order)."""
        return Section(
            title or self.title,
            self.doc,
            {k: self.keys[k] for k in keys},
            tuple(k for k in self.one_of if k in keys),
            {k: v for k, v in self.needs.items() if k in keys},
        )


def K(kind: Kind, doc: str, required: bool = False) -> Key:  # noqa: N802 (a short constructor)
    return Key(kind, doc, required)


ANGLE = quantity("angle")
LENGTH = quantity("length")
DESCRIPTION = K(TEXT, "Free text about this item (ignored by the solver).")

# A joint's friction (a revolute's or a slider's ``friction:``): shared by the joint kinds
# that can have it, so that the schema and the unknown-key suggestions know its keys.
JOINT_FRICTION = Section(
    "joint friction",
    "Friction in a joint: Coulomb's law (a revolute's friction circle rho = f r, a slider's "
    "friction angle atan f) and optionally a viscous part.",
    {
        "coefficient": K(number(0), "The Coulomb friction coefficient f (zero or positive)."),
        "journal radius": K(
            LENGTH, "A revolute's journal (pin) radius r: the friction circle is rho = f r."
        ),
        "viscous": K(
            either(quantity("rotational damping"), quantity("damping")),
            "A viscous part: a revolute's torque per relative angular speed (N m s/rad), "
            "a slider's force per sliding speed (N s/m).",
        ),
        "description": DESCRIPTION,
    },
)
