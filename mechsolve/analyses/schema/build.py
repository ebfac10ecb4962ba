"""The JSON Schema of the mechanism file, generated from :mod:`mechsolve.model.keys`.

The schema is JSON Schema draft-07, the draft the YAML language server (VS Code's YAML
extension, and editors that run ``yaml-language-server``) supports fully. It gives
completion and hover help for every key and flags unknown keys, missing required keys and
values of the wrong type. It is looser than the parser where the check needs the rest of
the file (a point name that no link has, a unit of the wrong dimension): the parser's
message says those.

The package ships the generated file (``mechsolve/schema/mechanism.schema.json``,
written by ``scripts/make_schema.py``); ``mechsolve schema`` prints it, and a test checks
that it equals :func:`build`'s output.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from mechsolve.analyses.cam.model import CAM_KEYS, FOLLOWER_KEYS
from mechsolve.analyses.study.designs import DESIGNS, STUDY_KEYS
from mechsolve.base.units import NUMBER_PATTERN, SPACE_PATTERN
from mechsolve.model import keys
from mechsolve.model.keys import Key, Kind, Section

DRAFT = "http://json-schema.org/draft-07/schema#"
SHIPPED = Path(__file__).resolve().parent / "mechanism.schema.json"

# The parser's number (mechsolve.base.units) at the start of a quantity's text, and the
# spaces around it: explicit character classes, never \d, \w or \s, which the editors'
# ECMAScript regular expressions and Python's (jsonschema) read differently.
NUMBER = NUMBER_PATTERN
SPACE = SPACE_PATTERN
# after a quantity's number: not ",5", "_500" or ":45" (refused by the parser as a decimal
# comma, grouped digits and YAML 1.1's base 60)
RUN_ON = r"(?![,_:]?[0-9])"
# A name (mechsolve.model.NAME_RE: a letter of any script or '_', then letters, digits
# and '_'), written so that both ECMA-262 (the editors) and Python (jsonschema) read it
# alike: no ASCII character other than letters, digits and '_' (and no digit first);
# characters outside ASCII are left to the parser.
_PUNCT = r"\x00-\x2f\x3a-\x40\x5b-\x5e\x60\x7b-\x7f"
NAME_PATTERN = rf"^[^{_PUNCT}0-9][^{_PUNCT}]*$"

VARIANT = "variant"  # the definition of a variant: the whole file, every key optional


def slug(title: str) -> str:
    return title.replace(" ", "_")


def _ref(sid: str, partial: bool) -> dict[str, Any]:
    if sid == VARIANT:
        return {"$ref": f"#/definitions/{VARIANT}"}
    return {"$ref": f"#/definitions/{slug(sid)}{'.variant' if partial else ''}"}


def kind_schema(kind: Kind, partial: bool = False) -> dict[str, Any]:
    """The schema of one value; ``partial``: as a variant overrides it (mappings merge,
    ``null`` deletes a key, nothing is required)."""
    tag = kind.tag
    if tag == "quantity":
        return {"$ref": "#/definitions/quantity"}
    if tag == "xy":
        return {"$ref": "#/definitions/coordinates"}
    if tag in ("text", "name", "condition", "expression"):
        return {"type": "string"}
    if tag == "names":
        out: dict[str, Any] = {"type": "array", "items": {"type": "string"}}
        if kind.count is not None:
            out["minItems"] = out["maxItems"] = kind.count
        elif kind.low is not None:
            out["minItems"] = kind.low
        return out
    if tag == "flag":
        return {"type": "boolean"}
    if tag == "number":
        out = {"type": ["number", "string"], "pattern": rf"^{SPACE}*{NUMBER}{SPACE}*$"}
        if kind.low is not None:
            out["exclusiveMinimum"] = kind.low
        if kind.high is not None:
            out["exclusiveMaximum"] = kind.high
        return out
    if tag == "integer":
        out = {"type": "integer"}
        if kind.low is not None:
            out["minimum"] = kind.low
        if kind.high is not None:
            out["maximum"] = kind.high
        return out
    if tag == "choice":
        return {"enum": list(kind.arg)}
    if tag == "const":
        return {"const": kind.arg}
    if tag == "null":
        return {"type": "null"}
    if tag == "any":
        return {}
    if tag == "list":
        out = {"type": "array", "items": kind_schema(kind.arg)}
        if kind.count:
            out["minItems"] = kind.count
        return out
    if tag == "pair":
        return {
            "type": "array",
            "items": [kind_schema(k) for k in kind.arg],
            "minItems": 2,
            "maxItems": 2,
            "additionalItems": False,
        }
    if tag == "map":
        value = kind_schema(kind.arg, partial)
        if partial:
            value = {"anyOf": [value, {"type": "null"}]}
        out = {"type": "object", "additionalProperties": value}
        if kind.names is not None:
            out["propertyNames"] = {"pattern": NAME_PATTERN}
        return out
    if tag == "section":
        return _ref(kind.arg, partial)
    if tag == "either":
        out = {"anyOf": [kind_schema(k, partial) for k in kind.arg]}
        if kind.doc:
            out["description"] = kind.doc
        return out
    raise ValueError(f"unknown kind of value {tag!r}")


def key_schema(key: Key, partial: bool = False) -> dict[str, Any]:
    s = kind_schema(key.kind, partial)
    if partial:
        s = {"anyOf": [s, {"type": "null"}]}
    elif "$ref" in s:  # draft-07 ignores a $ref's siblings: keep the description beside it
        s = {"allOf": [s]}
    return {"description": key.doc, **s}


def section_schema(sec: Section, partial: bool = False, drop: tuple[str, ...] = ()):
    """The schema of one mapping (``partial``: as a variant overrides it)."""
    out: dict[str, Any] = {
        "type": "object",
        "title": sec.title,
        "description": sec.doc,
        "properties": {k: key_schema(v, partial) for k, v in sec.keys.items() if k not in drop},
        "additionalProperties": False,
    }
    if partial:
        return out
    if sec.required:
        out["required"] = list(sec.required)
    if sec.one_of:
        out["oneOf"] = [{"required": [k]} for k in sec.one_of]
    if sec.needs:
        out["dependencies"] = {k: list(v) for k, v in sec.needs.items()}
    if sec.kinds:
        common = [k for k in sec.keys if not any(k in ks for ks in sec.kinds.values())]
        out["allOf"] = [
            {
                "if": {"required": [kind]},
                "then": {
                    "propertyNames": {"enum": [k for k in sec.keys if k in ks or k in common]}
                },
            }
            for kind, ks in sec.kinds.items()
        ]
    return out


def _agree(what: str, declared: tuple[str, ...], read: tuple[str, ...]) -> None:
    if set(declared) != set(read):
        raise RuntimeError(
            f"mechsolve.model.keys describes the keys of {what} as {', '.join(declared)}, but "
            f"its reader accepts {', '.join(read)}: update keys.py"
        )


def check_readers() -> None:
    """The sections other modules read agree with their own key constants."""

    _agree("'cam'", keys.CAM.allowed, CAM_KEYS)
    _agree("'follower'", keys.FOLLOWER.allowed, FOLLOWER_KEYS)
    _agree("'study'", keys.STUDY.allowed, STUDY_KEYS)
    _agree("study.design", keys.STUDY.keys["design"].kind.arg, tuple(DESIGNS))


def build() -> dict[str, Any]:
    """The JSON Schema (a dict) of the mechanism file, from :mod:`mechsolve.model.keys`."""
    check_readers()
    top = keys.TOP
    defs: dict[str, Any] = {
        "quantity": {
            "type": ["number", "string"],
            "pattern": rf"^{SPACE}*{NUMBER}{RUN_ON}",
            "description": "A number in the file's units, or a number and a unit: "
            "'110 mm', '25 deg', '60 rpm', '50 kN', '1.1 kg m^2'.",
        },
        "coordinates": {
            "description": "[x, y] (numbers in the file's length unit, or with units), "
            "or text such as '(20, 30) mm'.",
            "anyOf": [
                {
                    "type": "array",
                    "items": {"$ref": "#/definitions/quantity"},
                    "minItems": 2,
                    "maxItems": 2,
                },
                {"type": "string", "pattern": ","},
            ],
        },
    }
    for sid, sec in keys.SECTIONS.items():
        if sec is top:
            continue
        defs[slug(sid)] = section_schema(sec)
        defs[slug(sid) + ".variant"] = section_schema(sec, partial=True)
    variant = section_schema(top, partial=True, drop=("variants",))
    variant["title"] = "variant"
    variant["description"] = (
        "Overrides of parts of the file: mappings merge key by key, any other value "
        "replaces, null deletes a key."
    )
    defs[VARIANT] = variant
    schema = {"$schema": DRAFT, **section_schema(top)}
    # a mechanism has links and joints; a cam file has a cam instead
    schema["anyOf"] = [{"required": ["links", "joints"]}, {"required": ["cam"]}]
    schema["definitions"] = defs
    return schema


def text() -> str:
    """The schema as the shipped file has it."""
    return json.dumps(build(), indent=2, ensure_ascii=False) + "\n"
