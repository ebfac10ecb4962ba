"""The JSON Schema of the mechanism file (issue 16, editor support).

Checked against the parser, not against itself: every example the parser reads is valid,
every known-bad file the parser refuses is refused by the schema too (at the same key),
and the keys the schema allows in each mapping are the keys the parser's own "unknown
key" message lists there.
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import jsonschema  # the test group installs it (pyproject: test)
import pytest
from click.testing import CliRunner

from mechsolve.analyses.schema import build as gen
from mechsolve.base.errors import InputError
from mechsolve.cli.commands.schema import schema as schema_command
from mechsolve.model import keys, parse
from mechsolve.model.source import load_file, load_text

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = ROOT / "mechsolve" / "analyses" / "schema" / "mechanism.schema.json"
EXAMPLES = sorted(
    p
    for p in [*ROOT.glob("mechanisms/*.yaml"), *ROOT.glob("mechanisms/studies/*.yaml")]
    if "links" in load_file(p).data or "cam" in load_file(p).data
)


@pytest.fixture(scope="module")
def schema() -> dict:
    return json.loads(SHIPPED.read_text("utf-8"))


@pytest.fixture(scope="module")
def validator(schema):
    return jsonschema.Draft7Validator(schema)


def test_the_shipped_schema_is_the_generated_one():
    assert SHIPPED.read_text("utf-8") == gen.text(), "run: python scripts/make_schema.py"


def test_the_schema_is_a_valid_draft_07_schema(schema):
    assert schema["$schema"] == "http://json-schema.org/draft-07/schema#"
    jsonschema.Draft7Validator.check_schema(schema)


def test_the_examples_are_found():
    names = {p.name for p in EXAMPLES}
    assert {"crane.yaml", "crane-zh.yaml", "shaper.yaml", "shaper-cam.yaml"} <= names
    assert "fourbar-study.yaml" in names
    assert not any(p.parent.name == "synth" for p in EXAMPLES)  # another format


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_every_example_and_each_of_its_variants_is_valid(path, validator):
    src = load_file(path)
    errors = [f"{list(e.absolute_path)}: {e.message}" for e in validator.iter_errors(src.data)]
    assert not errors, errors
    for name in src.data.get("variants") or {}:
        merged = src.with_variant(name).data
        errors = [f"{list(e.absolute_path)}: {e.message}" for e in validator.iter_errors(merged)]
        assert not errors, (name, errors)
        if "links" in merged:  # the parser agrees that the file is good
            parse.from_source(src, name)


BASE = """
name: slider-crank
units: {length: mm, angle: deg}
ground: {O: [0, 0]}
links:
  crank: {points: {O: [0, 0], A: [50, 0]}, mass: 1 kg, com: A}
  rod: {points: {A: [0, 0], C: [200, 0]}}
  piston: {points: {C: [0, 0]}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cylinder: {slider: [ground, piston], point: C, line: {through: [0, 10], angle: 0}}
driver: {joint: O, speed: 60 rpm, start: 0 deg}
sweep: {range: 360 deg, step: 30 deg}
"""


def base() -> dict:
    return load_text(BASE).data


def test_the_base_file_is_good(validator):
    assert not list(validator.iter_errors(base()))
    parse.from_source(load_text(BASE))


def _set(data: dict, path: tuple, value) -> dict:
    node = data
    for k in path[:-1]:
        node = node.setdefault(k, {})
    if value is None:
        node.pop(path[-1], None)
    else:
        node[path[-1]] = value
    return data


# A known-bad file: changes to the base file, the key path the parser names, and the
# key path where the schema's complaint sits (the mapping that holds the mistake).
BAD = {
    "unknown top-level key": ([(("linkz",), {"crank": {}})], ("linkz",), ()),
    "unknown key in a link": ([(("links", "rod", "lenght"), 200)], ("links", "rod", "lenght"),
                              ("links", "rod")),
    "driver without joint": ([(("driver",), {"speed": "60 rpm"})], ("driver",), ("driver",)),
    "a list where a mass is expected": ([(("links", "crank", "mass"), [1, 2])],
                                        ("links", "crank", "mass"), ("links", "crank", "mass")),
    "a mapping where a step is expected": ([(("sweep", "step"), {"deg": 5})], ("sweep", "step"),
                                           ("sweep", "step")),
    "a quantity without a number": ([(("links", "crank", "mass"), "heavy")],
                                    ("links", "crank", "mass"), ("links", "crank", "mass")),
    "a load of two kinds": ([(("loads",), {"L": {"force": "1 N", "torque": "1 N m", "at": "C",
                                                 "on": "piston"}})], ("loads", "L"),
                            ("loads", "L")),
    "a key that does not apply to the load's kind": (
        [(("loads",), {"L": {"torque": "1 N m", "on": "rod", "at": "C"}})],
        ("loads", "L", "at"), ("loads", "L")),
    "a link name with a hyphen": ([(("links", "crank-1"), {"points": {"B": [0, 0]}})],
                                  ("links", "crank-1"), ("links",)),
    "a slider's guide line of one point": ([(("joints", "cylinder", "line"), ["C"])],
                                           ("joints", "cylinder", "line"),
                                           ("joints", "cylinder", "line")),
    "an unknown solver method": ([(("solver",), {"method": "magic"})], ("solver", "method"),
                                 ("solver", "method")),
    "a tolerance that is not a number": ([(("solver",), {"tolerance": "small"})],
                                         ("solver", "tolerance"), ("solver", "tolerance")),
    "a flywheel without inertia": ([(("flywheel",), {"on": "crank"})], ("flywheel",),
                                   ("flywheel",)),
    "a motor's stall without slope": ([(("motor",), {"stall": "50 N m"})], ("motor",),
                                      ("motor",)),
    "a variant's unknown key": ([(("variants",), {"v": {"driver": {"jiont": "O"}}})],
                                None, ("variants", "v", "driver")),
    "no links": ([(("links",), None)], (), ()),
}  # fmt: skip


@pytest.mark.parametrize("case", list(BAD), ids=lambda c: c.replace(" ", "-"))
def test_known_bad_files_fail_the_schema_where_the_parser_fails(case, validator):
    changes, parser_path, schema_path = BAD[case]
    data = base()
    for path, value in changes:
        _set(data, path, value)
    errors = list(validator.iter_errors(data))
    assert errors, f"the schema accepts a file with {case}"
    # the most specific complaint (jsonschema's relevance) sits at the mistake's mapping
    best = jsonschema.exceptions.best_match(errors)
    where = tuple(best.absolute_path)
    assert where[: len(schema_path)] == schema_path, (where, best.message)
    # the parser refuses it too, at that key (for a variant: when the variant is applied)
    text = json.dumps(data)  # JSON is YAML
    with pytest.raises(InputError) as exc:
        if parser_path is None:
            parse.loads(text, variant="v")
        else:
            parse.loads(text)
    if parser_path:
        assert exc.value.keypath == ".".join(map(str, parser_path)), str(exc.value)


# --- the schema's keys are the parser's keys ------------------------------------------

SLIDER_DRIVER = {"joint": "cylinder", "speed": "1 m/s", "start": "200 mm"}

# Where each mapping of the format sits in a file built on the base file: the changes
# that place it there with the bogus key 'zzz', and the definition of the schema that
# describes it. The parser's message "unknown key 'zzz' ...; allowed: a, b" lists the keys
# it accepts there.
PROBES = {
    "mechanism file": [(("zzz",), 1)],
    "units": [(("units", "zzz"), 1)],
    "link": [(("links", "rod", "zzz"), 1)],
    "point": [(("links", "rod", "points", "P"), {"length": 1, "angle": 0, "zzz": 1})],
    "joint": [(("joints", "A"), {"revolute": ["crank", "rod"], "zzz": 1})],
    "pin": [(("joints", "A"), {"revolute": ["crank", "rod", "piston"], "zzz": 1})],
    "guide line": [(("joints", "cylinder", "line"), {"through": [0, 10], "zzz": 1})],
    "joint friction": [(("joints", "cylinder", "friction"), {"coefficient": 0.1, "zzz": 1})],
    "driver": [(("driver", "zzz"), 1)],
    "limit start": [(("driver", "start"), {"limit": "C.x", "at": "max", "zzz": 1})],
    "motion": [(("driver", "speed"), None), (("driver", "motion"), {"law": "t", "zzz": 1})],
    "segment": [(("driver", "speed"), None),
                (("driver", "motion"), {"segments": [{"run": "1 s", "zzz": 1}]})],
    "sweep": [(("sweep", "zzz"), 1)],
    "assembly": [(("assembly",), {"conditions": ["C.x > A.x"], "zzz": 1})],
    "outputs": [(("outputs",), {"zzz": 1})],
    "solver": [(("solver",), {"zzz": 1})],
    "gravity": [(("gravity",), {"g": 9.81, "zzz": 1})],
    "load": [(("loads",), {"L": {"force": "1 N", "at": "C", "on": "piston", "zzz": 1}})],
    "motor": [(("motor",), {"zzz": 1})],
    "flywheel": [(("flywheel",), {"zzz": 1})],
    "simulate": [(("simulate",), {"zzz": 1})],
    "instant": [(("instants",), [{"theta": 0, "omega": 1, "zzz": 1}])],
    "linear instant": [(("driver",), SLIDER_DRIVER), (("sweep",), {"range": "50 mm"}),
                       (("instants",), [{"s": 200, "v": 1, "zzz": 1}])],
}  # fmt: skip


def _allowed(message: str) -> list[str]:
    m = re.search(r"(?:allowed|sections are): (.*)$", message)
    assert m, message
    return m.group(1).split(", ")


def _definition(schema: dict, title: str) -> dict:
    if title == "mechanism file":
        return schema
    if title == "pin":  # a pin's mapping is a joint's with fewer keys
        return schema["definitions"]["joint"]
    return schema["definitions"][gen.slug(title)]


@pytest.mark.parametrize("title", list(PROBES))
def test_each_mapping_allows_exactly_the_keys_the_parser_allows(title, schema, validator):
    data = base()
    for path, value in PROBES[title]:
        _set(data, path, copy.deepcopy(value))
    with pytest.raises(InputError) as exc:
        parse.loads(json.dumps(data))
    assert "'zzz'" in exc.value.message, exc.value.message
    parser_keys = _allowed(exc.value.message)
    props = list(_definition(schema, title)["properties"])
    if title == "pin":
        assert set(parser_keys) < set(props)
    else:
        assert parser_keys == props  # the same keys, in the same order

    # and the schema refuses the bogus key at that mapping (inside an alternative, for
    # a mapping that may also be written otherwise)
    def every(errors):
        for e in errors:
            yield e
            yield from every(e.context or ())

    assert any(
        e.validator == "additionalProperties" and "'zzz'" in e.message
        for e in every(validator.iter_errors(data))
    )


def test_every_declared_section_of_the_parser_is_probed():
    own = {s.title for s in keys.SECTIONS.values()} - {
        "study", "cam", "follower", "cam segment", "allowable pressure angle"  # other readers
    }  # fmt: skip
    assert own <= set(PROBES)


def test_the_required_keys_are_the_parsers(schema):
    # each key the schema requires, left out of a good file, makes the parser complain
    # that the mapping needs it
    for path, key in [
        (("driver",), "joint"),
        (("flywheel",), "on"),
        (("flywheel",), "inertia"),
        (("simulate",), "duration"),
        (("gravity",), "g"),
    ]:
        good = {
            "driver": {"joint": "O", "speed": "1 rad/s"},
            "flywheel": {"on": "crank", "inertia": "1 kg m^2"},
            "simulate": {"duration": "1 s"},
            "gravity": {"g": "9.81 m/s^2"},
        }[path[0]]
        data = _set(base(), path, {k: v for k, v in good.items() if k != key})
        if path[0] in ("flywheel", "simulate"):
            data["motor"] = {"stall": "5 N m", "slope": "1 N m s"}
        with pytest.raises(InputError, match=f"needs the key '{key}'"):
            parse.loads(json.dumps(data))
        section = _definition(schema, {"driver": "driver"}.get(path[0], path[0]))
        assert key in section["required"]


def test_the_cam_and_study_sections_are_their_readers_keys(schema):
    from mechsolve.analyses.cam.model import CAM_KEYS, FOLLOWER_KEYS
    from mechsolve.analyses.study.designs import STUDY_KEYS

    defs = schema["definitions"]
    assert set(defs["cam"]["properties"]) == set(CAM_KEYS)
    assert set(defs["follower"]["properties"]) == set(FOLLOWER_KEYS)
    assert set(defs["study"]["properties"]) == set(STUDY_KEYS)


def test_a_name_in_any_script_is_a_name_and_punctuation_is_not(validator):
    for good in ("曲柄", "кривошип", "_a1", "O1", "象鼻梁2"):
        data = base()
        data["links"][good] = {"points": {"Z": [0, 0]}}
        assert not list(validator.iter_errors(data)), good
    for bad in ("1a", "a-b", "a b", "a.b", "a/b"):
        data = base()
        data["links"][bad] = {"points": {"Z": [0, 0]}}
        assert list(validator.iter_errors(data)), bad


def test_every_key_has_a_description(schema):
    def walk(node, where):
        if isinstance(node, dict):
            for k, v in (node.get("properties") or {}).items():
                assert v.get("description"), where + (k,)
            for k, v in node.items():
                walk(v, where + (k,))
        elif isinstance(node, list):
            for i, v in enumerate(node):
                walk(v, where + (i,))

    walk(schema, ())


# --- the command ------------------------------------------------------------------------


def test_the_command_prints_the_shipped_schema():
    res = CliRunner().invoke(schema_command, [])
    assert res.exit_code == 0, res.output
    assert res.output == SHIPPED.read_text("utf-8")


def test_the_command_writes_a_file_and_names_its_own(tmp_path):
    out = tmp_path / "mechanism.schema.json"
    res = CliRunner().invoke(schema_command, ["-o", str(out)])
    assert res.exit_code == 0, res.output
    assert json.loads(out.read_text("utf-8")) == json.loads(SHIPPED.read_text("utf-8"))
    res = CliRunner().invoke(schema_command, ["--path"])
    assert res.exit_code == 0
    assert Path(res.output.strip()).read_text("utf-8") == SHIPPED.read_text("utf-8")


def test_the_command_says_when_it_cannot_write(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    res = CliRunner().invoke(schema_command, ["-o", str(blocker / "schema.json")])
    assert res.exit_code == 2
    assert "cannot write" in res.output and "Traceback" not in res.output
