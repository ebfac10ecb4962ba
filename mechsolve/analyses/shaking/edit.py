"""The balanced file by editing the original text: its comments, order and layout kept.

Each counterweight adds a point to its link's ``points`` and an entry to its
``point_masses`` (the mapping is created when the link has none). An entry goes into a
flow mapping (``{O: [0, 0], A: [50, 0]}``) before its closing brace, into a block
mapping on a new line after its last entry, at its keys' indentation. The edited text
is read back and must give exactly the data the counterweights call for; otherwise (an
alias, a layout this does not handle) there is no edit and the caller writes the data
out afresh.
"""

from __future__ import annotations

from typing import Any

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from mechsolve.base.errors import InputError
from mechsolve.model.source import load_text


def with_counterweights(text: str, entries: list[tuple[str, str, str, str]], want: Any):
    """``text`` with the counterweights ``entries`` (link, point name, ``[x, y]`` text,
    mass text) added, or None if the edit cannot be made exactly (``want``: the data
    the edited text must give)."""
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return None
    links = _get(root, "links")
    edits: list[tuple[int, str]] = []
    for link, point, xy, mass in entries:
        node = _get(links, link)
        pts = _get(node, "points")
        if not isinstance(node, MappingNode) or not isinstance(pts, MappingNode):
            return None
        pm = _get(node, "point_masses")
        new = [_entry(text, pts, point, xy)]
        if pm is None:
            new.append(_entry(text, node, "point_masses", f"{{{point}: {mass}}}"))
        elif isinstance(pm, MappingNode):
            new.append(_entry(text, pm, point, mass))
        else:
            return None
        if any(e is None for e in new):
            return None
        edits += new  # type: ignore[arg-type]
    out = text
    for index, piece in sorted(edits, key=lambda e: e[0], reverse=True):
        out = out[:index] + piece + out[index:]
    try:
        if load_text(out).data != want:
            return None
    except InputError:
        return None
    return out


def _get(node: Node | None, key: str) -> Node | None:
    if not isinstance(node, MappingNode):
        return None
    for k, v in node.value:
        if isinstance(k, ScalarNode) and k.value == key:
            return v
    return None


def _last_leaf(node: Node) -> Node:
    """The last node written of a block collection (where its text ends)."""
    while isinstance(node, (MappingNode, SequenceNode)) and not node.flow_style and node.value:
        last = node.value[-1]
        node = last[1] if isinstance(node, MappingNode) else last
    return node


def _entry(text: str, mapping: MappingNode, key: str, value: str) -> tuple[int, str] | None:
    """Where and what to insert to add ``key: value`` to ``mapping``."""
    if mapping.flow_style:
        end = mapping.end_mark.index - 1
        if end < 0 or text[end] != "}":
            return None
        if not mapping.value:
            return end, f"{key}: {value}"
        return mapping.value[-1][1].end_mark.index, f", {key}: {value}"
    if not mapping.value:
        return None
    column = mapping.value[0][0].start_mark.column
    leaf = _last_leaf(mapping.value[-1][1])
    eol = text.find("\n", leaf.end_mark.index)
    line = f"{' ' * column}{key}: {value}"
    if eol < 0:
        return len(text), "\n" + line + "\n"
    return eol + 1, line + "\n"
