"""The file reference of the documentation, generated from :mod:`mechsolve.model.keys`.

The same declarations give the parser its allowed and required keys and the JSON Schema
(:mod:`mechsolve.analyses.schema.build`), so the page cannot drift from what the parser
accepts. The documentation's build (``scripts/docs_hooks.py``) writes it as
``reference/file.md``; ``python -m mechsolve.analyses.schema.reference`` prints it.

Each mapping of the format is one section of the page: its one-line description, then a
table of its keys in the parser's order (the order its messages list them), each with the
kind of value it takes, whether it is required and its description.
"""

from __future__ import annotations

from mechsolve.analyses.schema.build import check_readers
from mechsolve.model import keys
from mechsolve.model.keys import Kind, Section

# the mappings of the format, in the order a reader meets them in a file
ORDER = (
    "mechanism file",
    "units",
    "link",
    "point",
    "joint",
    "joint friction",
    "guide line",
    "driver",
    "limit start",
    "motion",
    "segment",
    "sweep",
    "assembly",
    "outputs",
    "solver",
    "gravity",
    "load",
    "motor",
    "flywheel",
    "simulate",
    "instant",
    "linear instant",
    "study",
    "cam",
    "follower",
    "cam segment",
    "allowable pressure angle",
)
# a flywheel problem stated by its torque curve (mechsolve flywheel FILE without links)
TORQUE = (keys.TORQUE_PROBLEM, keys.TORQUE_CURVE)


def anchor(title: str) -> str:
    """The HTML id of a section's heading."""
    return title.replace(" ", "-")


def sections() -> list[Section]:
    """Every mapping of the file format, the mechanism file first; the torque problem's last.

    Raises ``RuntimeError`` when a section of :data:`mechsolve.model.keys.SECTIONS` is not
    placed in :data:`ORDER` (a new section must be given its place on the page)."""
    missing = set(keys.SECTIONS) - set(ORDER)
    if missing:
        raise RuntimeError(f"reference.ORDER does not place {', '.join(sorted(missing))}")
    return [keys.SECTIONS[t] for t in ORDER] + list(TORQUE)


def describe(kind: Kind) -> str:
    """The kind of one value in words (Markdown), with links to the sections it refers to."""
    tag, arg = kind.tag, kind.arg
    if tag == "quantity":
        return f"{arg}"
    if tag == "xy":
        return "coordinates [x, y]"
    if tag in ("text", "condition"):
        return kind.doc or tag
    if tag == "name":
        return f"name of a {arg}"
    if tag == "names":
        n = f"{kind.count} " if kind.count else ""
        return f"list of {n}{arg} names"
    if tag == "expression":
        return f"expression of {', '.join(arg)}" if arg else "expression"
    if tag == "flag":
        return "true or false"
    if tag in ("number", "integer"):
        bounds = []
        if kind.low is not None:
            bounds.append(f"> {kind.low:g}" if tag == "number" else f"≥ {kind.low}")
        if kind.high is not None:
            bounds.append(f"< {kind.high:g}" if tag == "number" else f"≤ {kind.high}")
        return tag + (f" ({', '.join(bounds)})" if bounds else "")
    if tag == "choice":
        return " | ".join(f"`{v}`" for v in arg)
    if tag == "const":
        return f"`{str(arg).lower() if isinstance(arg, bool) else arg}`"
    if tag == "null":
        return "`null`"
    if tag == "any":
        return "any value"
    if tag == "list":
        least = f" (at least {kind.count})" if kind.count else ""
        return f"list{least} of {describe(arg)}"
    if tag == "pair":
        return f"[{describe(arg[0])}, {describe(arg[1])}]"
    if tag == "map":
        what = f"{kind.names} name" if kind.names else "name"
        return f"mapping of {what} → {describe(arg)}"
    if tag == "section":
        if arg == "variant":  # the whole file again, every key optional (null deletes one)
            return "[overrides of the file's keys](#mechanism-file)"
        return f"[{arg}](#{anchor(arg)})"
    if tag == "either":
        return " or ".join(describe(k) for k in arg)
    raise ValueError(f"unknown kind of value {tag!r}")


def _cell(text: str) -> str:
    return " ".join(text.replace("|", "\\|").split())


def section_text(sec: Section) -> str:
    """One mapping: heading, description, notes on its alternatives, table of its keys."""
    lines = [f"## {sec.title} {{#{anchor(sec.title)}}}", "", sec.doc, ""]
    if sec.one_of:
        lines += [
            "Exactly one of " + ", ".join(f"`{k}`" for k in sec.one_of) + " is given.",
            "",
        ]
    for kind, ks in sec.kinds.items():
        only = [k for k in sec.keys if k in ks and k != kind]
        lines += [f"With `{kind}`: " + ", ".join(f"`{k}`" for k in only) + ".", ""]
    for key, needed in sec.needs.items():
        lines += [f"`{key}` needs " + ", ".join(f"`{k}`" for k in needed) + ".", ""]
    lines += ["| key | value | required | description |", "|---|---|---|---|"]
    for k, v in sec.keys.items():
        req = "yes" if v.required else ""
        lines.append(f"| `{k}` | {_cell(describe(v.kind))} | {req} | {_cell(v.doc)} |")
    return "\n".join(lines) + "\n"


def markdown(title: str | None = "The mechanism file") -> str:
    """The tables of every mapping (Markdown), under a page title unless ``title`` is None
    (the documentation's page has its own)."""
    check_readers()
    head = f"# {title}\n\n" if title else ""
    body = [
        "Every key the parser accepts, generated from the same key table as the JSON Schema "
        "and the parser's own checks. Quantities are a number in the file's units or a "
        "number with a unit (`110 mm`, `25 deg`, `60 rpm`, `50 kN`, `1.1 kg m^2`).\n"
    ]
    secs = sections()
    body += [section_text(s) for s in secs[: -len(TORQUE)]]
    body.append(
        "## The torque problem file\n\n"
        "`mechsolve flywheel FILE` also reads a file without links: a flywheel problem "
        "stated by its torque curve.\n"
    )
    body += [section_text(s) for s in secs[-len(TORQUE) :]]
    return head + "\n".join(body)


if __name__ == "__main__":  # pragma: no cover
    print(markdown(), end="")
