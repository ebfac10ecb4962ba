"""Read a mechanism file safely and remember the line of every key.

YAML is composed with PyYAML's safe loader into a node tree; no Python object is
ever constructed from a tag. The tree is converted to plain dicts, lists and scalars
while the line of every key is recorded, so that a later check can say
``crane.yaml:23: links.crank.points.A: ...``.

Guards: files over :data:`MAX_BYTES`, more than :data:`MAX_NODES` values once aliases
are expanded (the "billion laughs" alias bomb), nesting deeper than :data:`MAX_DEPTH`,
duplicate keys and non-standard tags are all refused with a clear message.
"""

from __future__ import annotations

import copy
import math
import os
import re
import select
import stat
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import yaml

from mechsolve.base.errors import InputError
from mechsolve.joints.registry import KINDS

_STD = "tag:yaml.org,2002:"


class _Loader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """libyaml's parser when PyYAML has it (about 10x faster on a large file), else
    Python's; either only composes nodes: nothing in a file is ever constructed as an
    object.

    Plain scalars are resolved by YAML 1.2's core schema, as the schema's editors (the
    YAML language server) read them, not by PyYAML's YAML 1.1 rules: ``050`` is fifty
    (1.1: octal 40), ``1:45`` and ``1_000`` are text (1.1: 105 and 1000), ``1e3`` is a
    number (1.1: text), ``yes``/``on`` are text. See :data:`YAML12_INT` and
    :data:`YAML12_FLOAT`.
    """

    yaml_implicit_resolvers: dict = {}


_LOADER = _Loader

# YAML 1.2 core schema (https://yaml.org/spec/1.2.2/#1032-tag-resolution)
YAML12_INT = re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$")
YAML12_FLOAT = re.compile(
    r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
    r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"
)
for _tag, _regexp, _first in (
    ("bool", r"^(?:true|True|TRUE|false|False|FALSE)$", "tTfF"),
    ("int", YAML12_INT.pattern, "-+0123456789"),
    ("float", YAML12_FLOAT.pattern, "-+.0123456789"),
    ("null", r"^(?:~|null|Null|NULL|)$", ["~", "n", "N", ""]),
    ("merge", r"^(?:<<)$", "<"),  # not read, but refused by name (see _Converter)
):
    _Loader.add_implicit_resolver(_STD + _tag, re.compile(_regexp), list(_first))

MAX_BYTES = 1_000_000
MAX_NODES = 100_000  # values once aliases are expanded (a 1000-loop chain has 32 000)
MAX_EVENTS = 150_000  # parser events in the text itself (that chain has 60 000)
MAX_DEPTH = 64
PIPE_WAIT = 5.0  # seconds a pipe or a device may stay silent before it is refused

KeyPath = tuple[Any, ...]


def format_keypath(path: Iterable[Any]) -> str:
    """Render a key path as ``links.crank.points[0]`` (very deep ones shortened)."""
    path = list(path)
    if len(path) > 12:
        return format_keypath(path[:4]) + "..." + format_keypath(path[-2:])
    out = ""
    for k in path:
        if isinstance(k, int):
            out += f"[{k}]"
        else:
            out += ("." if out else "") + str(k)
    return out


class Source:
    """Plain data from a mechanism file, with the line of each key.

    Attributes
    ----------
    data
        The document as dicts, lists, str, int, float, bool and None.
    file
        The file name used in messages (``None`` for a model built in code).
    text
        The file's text as read (``None`` for a model built in code or a variant), for
        tools that edit the file and keep its comments.
    """

    def __init__(
        self,
        data: Any,
        lines: dict[KeyPath, int] | None = None,
        file: str | None = None,
        display: dict[KeyPath, KeyPath] | None = None,
    ) -> None:
        self.data = data
        self.file = file
        self.text: str | None = None
        self._lines = lines or {}
        self._display = display or {}
        # mappings a variant merged into: the variant's key path there (an error about
        # the merged mapping as a whole, "give only one of range, to", points at it)
        self._merged: dict[KeyPath, KeyPath] = {}

    def line(self, path: KeyPath) -> int | None:
        """The line of ``path``, or of its nearest parent that has one."""
        path = tuple(path)
        while path:
            if path in self._lines:
                return self._lines[path]
            path = path[:-1]
        return None

    def error(self, path: KeyPath, message: str) -> InputError:
        """An :class:`InputError` that names this file, the key path and its line."""
        path = tuple(path)
        if path in self._merged and self._merged[path] in self._lines:
            src = self._merged[path]
            return InputError(
                message, file=self.file, keypath=format_keypath(src), line=self._lines[src]
            )
        shown = path
        probe = path
        while probe:
            if probe in self._display:
                shown = self._display[probe] + path[len(probe) :]
                break
            probe = probe[:-1]
        return InputError(
            message, file=self.file, keypath=format_keypath(shown) or None, line=self.line(path)
        )

    # -- variants -------------------------------------------------------------------
    def with_variant(self, name: str) -> Source:
        """Return a new source with ``variants.<name>`` merged over the base document.

        Mappings merge key by key; any other value replaces; ``null`` deletes a key. A key
        of a group of mutually exclusive keys (:data:`EXCLUSIVE`: ``sweep`` ``range``,
        ``to`` and ``duration``; ``step``, ``steps`` and ``time_step``...) drops the base's
        other keys of its group.
        """
        variants = self.data.get("variants") if isinstance(self.data, dict) else None
        if not isinstance(variants, dict) or name not in variants:
            known = ", ".join(sorted(variants)) if isinstance(variants, dict) else "none"
            raise self.error(("variants",), f"no variant named {name!r} (variants: {known})")
        over = variants[name]
        if not isinstance(over, dict):
            raise self.error(("variants", name), "a variant must be a mapping of keys to override")
        data = copy.deepcopy(self.data)
        del data["variants"]
        lines = dict(self._lines)
        display = dict(self._display)
        prefix = ("variants", name)
        merged: dict[KeyPath, KeyPath] = {}
        self._merge(data, over, (), prefix, lines, display, merged)
        out = Source(data, lines, self.file, display)
        out._merged = merged
        return out

    def _merge(
        self, base: dict, over: dict, path: KeyPath, prefix: KeyPath, lines, display, merged
    ) -> None:
        # a key the variant sets replaces the base's keys that exclude it ("steps" drops
        # the base's "step"), so that no variant has to write "step: null"
        for group in exclusive_groups(path):
            setting = [k for k in group if over.get(k) is not None]
            if setting:
                for k in group:
                    if k not in over:
                        base.pop(k, None)
        for key, value in over.items():
            here = path + (key,)
            src = prefix + here
            if value is None:
                base.pop(key, None)
                continue
            if isinstance(value, dict) and isinstance(base.get(key), dict):
                merged[here] = src
                self._merge(base[key], value, here, prefix, lines, display, merged)
                continue
            base[key] = copy.deepcopy(value)
            # lines and display of everything below the replaced key come from the variant
            for p in [p for p in lines if p[: len(here)] == here]:
                del lines[p]
            for p, ln in self._lines.items():
                if p[: len(src)] == src:
                    lines[here + p[len(src) :]] = ln
            display[here] = src


# Keys of one mapping that exclude each other: where a variant sets one of a group, the
# base file's others are dropped. "*" stands for any name (a link, a joint, a load).
EXCLUSIVE: dict[KeyPath, tuple[tuple[str, ...], ...]] = {
    ("sweep",): (("range", "to", "duration"), ("step", "steps", "time_step")),
    ("driver",): (("speed", "motion"),),
    ("driver", "motion"): (("accelerate", "segments", "table", "law"),),
    ("links", "*"): (("mass", "weight"),),
    ("joints", "*"): (tuple(KINDS),),
    ("joints", "*", "line"): (("through", "offset"),),
    ("loads", "*"): (("force", "torque", "spring", "damper", "drag"),),
}


def exclusive_groups(path: KeyPath) -> tuple[tuple[str, ...], ...]:
    """The groups of mutually exclusive keys of the mapping at ``path`` (see
    :data:`EXCLUSIVE`)."""
    for pattern, groups in EXCLUSIVE.items():
        if len(pattern) == len(path) and all(p in ("*", k) for p, k in zip(pattern, path)):
            return groups
    return ()


def _scalar(node: yaml.ScalarNode) -> Any:
    tag = node.tag
    if tag == _STD + "str":
        return node.value
    if tag == _STD + "int":
        return _int12(node.value)
    if tag == _STD + "float":
        return _float12(node.value)
    if tag == _STD + "bool":
        # YAML 1.1 reads yes/no/on/off as booleans; a name like "on" is meant as text
        if node.value.lower() in ("true", "false"):
            return node.value.lower() == "true"
        return node.value
    if tag == _STD + "null":
        return None
    if tag in (_STD + "timestamp", _STD + "binary"):
        return node.value  # YAML's other standard scalars: keep the text
    # anything else, in YAML's own namespace too (!!python/name:os.system, !!python/object,
    # !!set...), is not a standard type of a mechanism file: refused, never read as text
    raise ValueError(_refused(tag))


def _int12(text: str) -> int | str:
    """A YAML 1.2 integer: decimal (leading zeros too: ``050`` is 50), ``0o17`` octal or
    ``0x1F`` hexadecimal. With an explicit ``!!int`` tag any other text is refused."""
    if len(text) > 400:  # Python refuses to convert over 4300 digits; no key needs 400
        raise ValueError(f"{text[:20]}... is too large a number")
    if not YAML12_INT.match(text):
        raise ValueError(f"{text!r} is not a number (an integer is written as 50, 0o62, 0x32)")
    if text.startswith(("0o", "0x")):
        return int(text[2:], 8 if text[1] == "o" else 16)
    return int(text, 10)


def _float12(text: str) -> float:
    """A YAML 1.2 float: ``0.05``, ``5e-2``, ``.5``, ``.inf``, ``.nan``."""
    if not YAML12_FLOAT.match(text) and not YAML12_INT.match(text):
        raise ValueError(f"{text!r} is not a number (a float is written as 0.05 or 5e-2)")
    low = text.lower()
    if low.endswith(".inf"):
        return -math.inf if low.startswith("-") else math.inf
    if low == ".nan":
        return math.nan
    if text.startswith(("0o", "0x")):
        return float(_int12(text))
    return float(text)


def _refused(tag: str) -> str:
    """Why ``tag`` is refused, with the tag as the file spells it (``!!python/...``)."""
    shown = "!!" + tag[len(_STD) :] if tag.startswith(_STD) else tag
    return (
        f"the tag {shown!r} is not allowed in a mechanism file (it takes plain values, "
        "and of YAML's tags only !!str, !!int, !!float, !!bool, !!null, !!seq and !!map)"
    )


class _Converter:
    def __init__(self, file: str | None) -> None:
        self.file = file
        self.count = 0
        self.lines: dict[KeyPath, int] = {}

    def fail(self, node: yaml.Node, path: KeyPath, message: str) -> InputError:
        return InputError(
            message,
            file=self.file,
            keypath=format_keypath(path) or None,
            line=node.start_mark.line + 1,
        )

    def convert(self, node: yaml.Node, path: KeyPath) -> Any:
        self.count += 1
        if self.count > MAX_NODES:
            raise self.fail(
                node,
                path,
                f"the document expands to more than {MAX_NODES} values "
                "(an alias bomb or a file far larger than any mechanism)",
            )
        if len(path) > MAX_DEPTH:
            raise self.fail(node, path, f"nesting deeper than {MAX_DEPTH} levels")
        if isinstance(node, yaml.ScalarNode):
            try:
                return _scalar(node)
            except ValueError as exc:
                raise self.fail(node, path, str(exc)) from None
        if node.tag not in (_STD + "seq", _STD + "map"):
            raise self.fail(node, path, _refused(node.tag))
        if isinstance(node, yaml.SequenceNode):
            out = []
            for i, item in enumerate(node.value):
                self.lines[path + (i,)] = item.start_mark.line + 1
                out.append(self.convert(item, path + (i,)))
            return out
        assert isinstance(node, yaml.MappingNode)
        result: dict[str, Any] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                raise self.fail(key_node, path, "a key must be a plain name, not a list or mapping")
            if key_node.tag == _STD + "merge":
                raise self.fail(
                    key_node, path, "YAML merge keys ('<<') are not supported; use 'variants'"
                )
            key = key_node.value
            here = path + (key,)
            if key in result:
                raise self.fail(key_node, here, f"the key {key!r} appears twice")
            self.lines[here] = key_node.start_mark.line + 1
            result[key] = self.convert(value_node, here)
        return result


class _Open:
    """A collection open in the event stream, and where in it the parser is."""

    __slots__ = ("is_map", "index", "key", "expect_key", "here")

    def __init__(self, is_map: bool) -> None:
        self.is_map = is_map
        self.index = 0
        self.key: Any = None
        self.expect_key = True
        self.here: Any = None  # the path component of the node being read in it


def _check_events(text: str, file: str | None) -> None:
    """Count the parser's events and the nesting depth as the text is parsed.

    Raise :class:`InputError` as soon as the file holds more than :data:`MAX_EVENTS`
    events or nests deeper than :data:`MAX_DEPTH`, naming the key path and the line. The
    parser is lazy, so a hostile file is refused after reading only its beginning.
    """
    stack: list[_Open] = []
    try:
        _walk_events(text, file, stack)
    except yaml.MarkedYAMLError as exc:
        # libyaml 0.2.6 (PyYAML 6.0.4's wheels) refuses nesting beyond 1000 flow levels
        # itself, while scanning ahead of the events that reach us
        if "nesting depth" not in str(exc.problem) or exc.problem_mark is None:
            raise
        raise InputError(
            f"nesting deeper than {MAX_DEPTH} levels",
            file=file,
            # the collection being scanned has no entry read yet (its ``here`` is None)
            keypath=format_keypath(f.here for f in stack if f.here is not None) or None,
            line=exc.problem_mark.line + 1,
        ) from None


def _walk_events(text: str, file: str | None, stack: list[_Open]) -> None:
    node_events = (yaml.ScalarEvent, yaml.AliasEvent, yaml.CollectionStartEvent)
    nodes = 0
    for n, ev in enumerate(yaml.parse(text, Loader=_LOADER)):
        if n > MAX_EVENTS:
            raise InputError(
                f"the file holds more than {MAX_EVENTS} YAML items; no mechanism needs "
                "that many (is this the right file?)",
                file=file,
            )
        if isinstance(ev, yaml.CollectionEndEvent):
            stack.pop()
            continue
        if not isinstance(ev, node_events):
            continue
        nodes += 1
        if nodes > MAX_NODES:  # before aliases expand: composing them all would be slow
            raise InputError(
                f"the document holds more than {MAX_NODES} values (a file far larger than "
                "any mechanism)",
                file=file,
                line=ev.start_mark.line + 1,
            )
        is_key = False
        if stack:
            top = stack[-1]
            if not top.is_map:
                top.here = top.index
                top.index += 1
            elif top.expect_key:
                top.key = ev.value if isinstance(ev, yaml.ScalarEvent) else "?"
                top.expect_key = False
                is_key = True
            else:
                top.here = top.key
                top.expect_key = True
        if len(stack) > MAX_DEPTH and not is_key:
            raise InputError(
                f"nesting deeper than {MAX_DEPTH} levels",
                file=file,
                keypath=format_keypath(f.here for f in stack) or None,
                line=ev.start_mark.line + 1,
            )
        if isinstance(ev, yaml.CollectionStartEvent):
            stack.append(_Open(isinstance(ev, yaml.MappingStartEvent)))


def load_text(text: str, file: str | None = None) -> Source:
    """Parse YAML text into a :class:`Source`; raise :class:`InputError` on any problem."""
    if len(text) > MAX_BYTES:
        raise InputError(
            f"the file is {len(text)} characters long; a mechanism file is limited to "
            f"{MAX_BYTES} (is this the right file?)",
            file=file,
        )
    try:
        # walk the parser's events first (cheap, and it stops early): a file with more
        # values than any mechanism, or nested deeper than any, is refused before Python
        # builds a node for each (composing 20 000 nested brackets takes seconds)
        _check_events(text, file)
        nodes = list(yaml.compose_all(text, Loader=_LOADER))
    except yaml.MarkedYAMLError as exc:
        # the context ("while parsing a flow sequence", at the '[' left open) is usually
        # where the mistake is; the problem is where the parser noticed it
        ctx, mark = exc.context_mark, exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else None
        problem = exc.problem or exc.context or "invalid YAML"
        if exc.context and ctx is not None and mark is not None and ctx.line != mark.line:
            problem += f" at line {mark.line + 1} ({exc.context} that starts at line {ctx.line + 1}"
            if ctx.column is not None:
                problem += f", column {ctx.column + 1}"
            problem += ")"
            line = ctx.line + 1
        raise InputError(f"invalid YAML: {problem}", file=file, line=line) from None
    except yaml.YAMLError as exc:
        raise InputError(f"invalid YAML: {exc}", file=file) from None
    except RecursionError:
        raise InputError("invalid YAML: nesting too deep", file=file) from None
    nodes = [n for n in nodes if n is not None]
    if not nodes:
        raise InputError("the file is empty: a mechanism file is a YAML mapping", file=file)
    if len(nodes) > 1:
        raise InputError(
            "the file holds several YAML documents ('---'); put one mechanism per file",
            file=file,
            line=nodes[1].start_mark.line + 1,
        )
    conv = _Converter(file)
    try:
        data = conv.convert(nodes[0], ())
    except RecursionError:
        raise InputError("invalid YAML: nesting too deep", file=file) from None
    if not isinstance(data, dict):
        kind = "a list" if isinstance(data, list) else f"a single value ({data!r})"
        raise InputError(
            f"the file holds {kind}; a mechanism file must be a mapping with keys such as "
            "'ground', 'links', 'joints' and 'driver'",
            file=file,
            line=1,
        )
    src = Source(data, conv.lines, file)
    src.text = text
    return src


def _read_regular(p: Path) -> bytes:
    with open(p, "rb") as f:
        return f.read(MAX_BYTES + 1)


def _read_stream(p: Path, name: str) -> bytes:
    """Read a pipe (FIFO), a device or the like without ever blocking for good: opening
    a FIFO that nothing writes to blocks until something does, and reading from a
    writer that never writes blocks as long; so it is opened without blocking and each
    wait for data is bounded by :data:`PIPE_WAIT` (a process substitution such as
    ``<(sed ... file.yaml)`` still works). At most ``MAX_BYTES + 1`` bytes are read."""
    fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK)
    try:
        if not hasattr(select, "poll"):  # no poll() on this system: refuse outright
            raise InputError(
                "this is not a regular file (a pipe or a device); give the mechanism file",
                file=name,
            )
        poller = select.poll()
        poller.register(fd, select.POLLIN | select.POLLHUP | select.POLLERR)
        chunks: list[bytes] = []
        total = 0
        while total <= MAX_BYTES:
            if not poller.poll(int(PIPE_WAIT * 1000)):
                what = "a pipe (FIFO)" if stat.S_ISFIFO(os.fstat(fd).st_mode) else "a device"
                said = "stopped sending" if total else "sent nothing"
                raise InputError(
                    f"this is {what}, not a regular file, and it {said} for {PIPE_WAIT:g} s "
                    "(is anything writing to it?); give the mechanism file itself",
                    file=name,
                )
            try:
                got = os.read(fd, min(1 << 16, MAX_BYTES + 1 - total))
            except BlockingIOError:
                continue
            if not got:  # the writer closed it
                break
            chunks.append(got)
            total += len(got)
        return b"".join(chunks)
    finally:
        os.close(fd)


def load_file(path: str | Path) -> Source:
    """Read and parse a mechanism file (a regular file; a pipe or a device is read
    without blocking for longer than :data:`PIPE_WAIT` at a time)."""
    p = Path(path)
    name = str(path)
    try:
        info = p.stat()
    except FileNotFoundError:
        raise InputError("no such file", file=name) from None
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc.strerror}", file=name) from None
    if stat.S_ISDIR(info.st_mode):
        raise InputError("this is a folder, not a mechanism file", file=name)
    regular = stat.S_ISREG(info.st_mode)
    if regular and info.st_size > MAX_BYTES:
        raise InputError(
            f"the file is {info.st_size} bytes; a mechanism file is limited to {MAX_BYTES} "
            "bytes (is this the right file?)",
            file=name,
        )
    # a device or a pipe has no size (/dev/zero never ends): read one byte past the limit
    try:
        raw = _read_regular(p) if regular else _read_stream(p, name)
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc.strerror}", file=name) from None
    if len(raw) > MAX_BYTES:
        raise InputError(
            f"the file is longer than {MAX_BYTES} bytes; a mechanism file is limited to "
            f"{MAX_BYTES} bytes (is this the right file?)",
            file=name,
        )
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"the file is not UTF-8 text (byte {exc.start}); is it a binary file?", file=name
        ) from None
    if "\x00" in text:
        raise InputError("the file contains NUL bytes; is it a binary file?", file=name)
    return load_text(text, name)
