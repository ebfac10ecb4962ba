"""The reader of a mechanism file's plain data: typed values with their key path and
line (see :mod:`mechsolve.model.parse`)."""

from __future__ import annotations

from typing import Any

from mechsolve.base.errors import InputError
from mechsolve.base.units import UnitError, parse_quantity
from mechsolve.model import NAME_RE
from mechsolve.model.expr import ExprError, Expression
from mechsolve.model.source import KeyPath, Source
from mechsolve.model.validate import suggest


class Reader:
    """Reads values out of a :class:`Source` with unit conversion and located errors."""

    def __init__(self, source: Source) -> None:
        self.src = source
        self.length_unit = "m"
        self.angle_unit = "deg"

    def fail(self, path: KeyPath, message: str) -> InputError:
        return self.src.error(path, message)

    def mapping(
        self,
        value: Any,
        path: KeyPath,
        allowed: tuple[str, ...],
        what: str,
        required: tuple[str, ...] = (),
    ) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(path, f"{what} must be a mapping (key: value), got {_kind(value)}")
        for key in value:
            if key not in allowed:
                raise self.fail(
                    path + (key,),
                    f"unknown key {key!r} in {what}"
                    + suggest(key, list(allowed))
                    + f"; allowed: {', '.join(allowed)}",
                )
        for key in required:
            if key not in value:
                raise self.fail(path, f"{what} needs the key {key!r}")
        return value

    def quantity(self, value: Any, path: KeyPath, kind: str) -> float:
        default = {"length": self.length_unit, "angle": self.angle_unit}.get(kind)
        try:
            return parse_quantity(value, kind, default)
        except UnitError as exc:
            raise self.fail(path, str(exc)) from None

    def positive(self, value: Any, path: KeyPath, kind: str, allow_zero: bool = False) -> float:
        x = self.quantity(value, path, kind)
        if x < 0 or (x == 0 and not allow_zero):
            raise self.fail(
                path, f"must be {'zero or ' if allow_zero else ''}positive, got {value!r}"
            )
        return x

    def xy(self, value: Any, path: KeyPath) -> tuple[float, float]:
        if isinstance(value, str) and "," in value:  # "(1, 2) mm" or "1, 2"
            text = value.strip()
            unit = ""
            if ")" in text:
                text, unit = text.rsplit(")", 1)
                text = text.lstrip("(")
            parts = [
                p.strip() + (" " + unit.strip() if unit.strip() else "") for p in text.split(",")
            ]
            value = parts
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(path, f"expected coordinates [x, y], got {_kind(value)}")
        return (
            self.quantity(value[0], path + (0,), "length"),
            self.quantity(value[1], path + (1,), "length"),
        )

    def ident(self, name: str, path: KeyPath, what: str) -> str:
        """A name of a point, link or joint: an identifier (checked as soon as it is read)."""
        if not NAME_RE.match(name):
            raise self.fail(
                path,
                f"{what} name {name!r} must start with a letter or '_' and contain only "
                "letters, digits and '_'",
            )
        return name

    def name(self, value: Any, path: KeyPath, what: str) -> str:
        if not isinstance(value, str):
            raise self.fail(path, f"expected the name of a {what}, got {_kind(value)}")
        return value

    def names(
        self,
        value: Any,
        path: KeyPath,
        what: str,
        count: int | None = None,
        least: int | None = None,
    ) -> list[str]:
        """A list of names: exactly ``count`` of them, or at least ``least``."""
        short = least is not None and isinstance(value, list) and len(value) < least
        if not isinstance(value, list) or (count is not None and len(value) != count) or short:
            n = f"{count} " if count else f"{least} or more " if least else ""
            raise self.fail(path, f"expected a list of {n}{what} names, got {_kind(value)}")
        return [self.name(v, path + (i,), what) for i, v in enumerate(value)]

    def expression(self, value: Any, path: KeyPath) -> Expression:
        try:
            e = Expression(value)
        except ExprError as exc:
            raise self.fail(path, f"cannot read the condition: {exc}") from None
        if e.reductions():
            raise self.fail(
                path,
                f"{e.reductions()[0]}() reduces a whole run to one number: it belongs in "
                "'requirements', not in a condition that holds position by position",
            )
        return e

    def flag(self, value: Any, path: KeyPath) -> bool:
        if not isinstance(value, bool):
            raise self.fail(path, f"expected true or false, got {_kind(value)}")
        return value


def _kind(value: Any) -> str:
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if value is None:
        return "nothing (null)"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
