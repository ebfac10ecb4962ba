"""The shaking command's inputs and outputs: the moment's point, the counterweights'
radii from the command line, and the files (CSV, plots, the balanced mechanism)."""

from __future__ import annotations

from pathlib import Path

from mechsolve.base.atomic import replacing
from mechsolve.base.errors import InputError
from mechsolve.base.units import UnitError, parse_quantity
from mechsolve.model import GROUND, Mechanism


def parse_about(mech: Mechanism, text: str | None) -> tuple[tuple[float, float], str]:
    """The moment's point from ``--about``: a point of the frame by name, or ``x, y`` in
    the file's length unit (or with units: ``0.1 m, 0``); default the frame's origin."""
    if text is None:
        return (0.0, 0.0), "the frame's origin"
    name = text.strip()
    if name in mech.ground:
        x, y = mech.ground[name]
        return (float(x), float(y)), f"{GROUND} point {name}"
    parts = [p.strip() for p in name.strip("[]()").split(",")]
    if len(parts) != 2:
        raise InputError(
            f"--about {text!r}: give a point of the frame ({', '.join(mech.ground) or 'none'}) "
            f"or its coordinates 'x, y' (in {mech.length_unit} unless given)"
        )
    try:
        xy = [parse_quantity(p, "length", mech.length_unit) for p in parts]
    except UnitError as exc:
        raise InputError(f"--about {text!r}: {exc}") from None
    unit = "" if any(c.isalpha() for c in name) else f" {mech.length_unit}"
    return (xy[0], xy[1]), f"the point ({parts[0]}, {parts[1]}){unit}"


def parse_radii(mech: Mechanism, given: tuple[str, ...]) -> dict[str, float]:
    """``--radius LINK=LENGTH`` (repeatable; a length in the file's unit unless given)."""
    out: dict[str, float] = {}
    for item in given:
        link, sep, value = item.partition("=")
        link = link.strip()
        if not sep or not link:
            raise InputError(f"--radius {item!r}: give LINK=LENGTH, e.g. crank=40")
        if link != GROUND and link not in mech.link_names:
            raise InputError(
                f"--radius {item!r}: no link named {link!r} (links: {', '.join(mech.link_names)})"
            )
        try:
            out[link] = parse_quantity(value.strip(), "length", mech.length_unit)
        except UnitError as exc:
            raise InputError(f"--radius {item!r}: {exc}") from None
    return out


def write_text(path: Path, text: str) -> Path:
    """A text file, written whole or not at all."""
    with replacing(path, suffix=path.suffix) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    return path
