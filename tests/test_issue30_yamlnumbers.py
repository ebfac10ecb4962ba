"""Numbers in a mechanism file are read as YAML 1.2 (and its editors) read them.

PyYAML's defaults are YAML 1.1's: ``050`` is octal (40), ``1:45`` is base 60 (105),
``1_000`` is 1000. An engineer who writes ``050`` means fifty, and the JSON Schema's
editors (YAML 1.2) read fifty too; so a zero-padded number is decimal, ``0o17`` and
``0x1F`` are octal and hexadecimal as YAML 1.2 writes them, and ``1:45`` or ``1_000`` are
not numbers: refused with the file, the key path and the line.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import jsonschema
import pytest
import yaml
from click.testing import CliRunner

from mechsolve.analyses.study.designs import make_study
from mechsolve.base.errors import InputError
from mechsolve.cli.main import main
from mechsolve.model import parse
from mechsolve.model.source import load_text

SLIDER_CRANK = """\
name: sc
units: {{length: mm, angle: deg}}
ground: {{O: [0, 0]}}
links:
  crank: {{points: {{O: [0, 0], A: [{crank}, 0]}}}}
  rod: {{points: {{A: [0, 0], C: [200, 0]}}}}
  piston: {{points: {{C: [0, 0]}}}}
joints:
  O: [ground, crank]
  A: [crank, rod]
  C: [rod, piston]
  cylinder: {{slider: [ground, piston], point: C, line: {{through: [0, 10], angle: 0}}}}
assembly: [C.x > A.x]
driver: {{joint: O, speed: {speed}, start: 0 deg}}
sweep: {{range: 360 deg, step: 10 deg}}
"""


def _mech(crank: str = "50", speed: str = "1 rad/s"):
    return parse.loads(SLIDER_CRANK.format(crank=crank, speed=speed), file="sc.yaml")


def _crank_mm(crank: str) -> float:
    return _mech(crank).links[0].points["A"][0] * 1e3


@pytest.mark.parametrize(
    "written, meant",
    [
        ("050", 50),  # YAML 1.1: octal 40
        ("025", 25),  # 21
        ("060", 60),  # 48
        ("087", 87),  # not octal, so 87 already: the rule is now the same for every digit
        ("+050", 50),
        ("0050.5", 50.5),
        ("50", 50),
        ("5e1", 50),  # YAML 1.2 reads an exponent without a dot as a number too
        ("0o62", 0o62),  # YAML 1.2 octal: 50
        ("0x32", 0x32),  # YAML 1.2 hexadecimal: 50
        ('"050 mm"', 50),
        ('"0.05 m"', 50),
    ],
)
def test_a_coordinate_is_read_by_its_decimal_meaning(written, meant):
    assert _crank_mm(written) == pytest.approx(meant, rel=1e-12)


def test_a_zero_padded_speed_is_decimal():
    # a plain number of angular speed is rad/s
    assert _mech(speed="0100").driver.speed == pytest.approx(100.0)


@pytest.mark.parametrize(
    "written, shown",
    [("1:45", "1:45"), ("1:0:0", "1:0:0"), ("1_000", "1_000"), ('"1:45 mm"', "1:45 mm")],
)
def test_base_60_and_underscored_numbers_are_refused_where_they_are(written, shown):
    with pytest.raises(InputError) as info:
        _mech(written)
    err = info.value
    text = str(err)
    assert err.file == "sc.yaml" and err.line == 5, text
    assert err.keypath == "links.crank.points.A[0]", text
    assert shown in text and "not a number" in text, text


def test_a_speed_in_base_60_is_refused():
    with pytest.raises(InputError) as info:
        _mech(speed="1:30")
    assert info.value.line == 14 and info.value.keypath == "driver.speed"
    assert "not a number" in str(info.value)


def test_the_plain_scalars_follow_yaml_1_2_core():
    data = load_text(
        "a: 050\nb: 0o17\nc: 0x1F\nd: 1:45\ne: 1_000\nf: 1e3\ng: .5\nh: -.inf\n"
        "i: 0b101\nj: 1.5e-3\nk: +12\nl: yes\nm: ~\nn: 2001-12-14\no: 007.50\n"
    ).data
    assert data == {
        "a": 50,
        "b": 15,
        "c": 31,
        "d": "1:45",
        "e": "1_000",
        "f": 1000.0,
        "g": 0.5,
        "h": -math.inf,
        "i": "0b101",
        "j": 0.0015,
        "k": 12,
        "l": "yes",
        "m": None,
        "n": "2001-12-14",
        "o": 7.5,
    }
    assert type(data["a"]) is int and type(data["f"]) is float


def test_simulate_settings_and_study_parameters_read_decimal():
    text = SLIDER_CRANK.format(crank="50", speed="10 rad/s") + (
        "simulate: {duration: 02, step: 0.001, revolutions: 010}\n"
        "study:\n  parameters:\n    links.rod.points.C[0]: [0190, 0210]\n"
    )
    mech = parse.loads(text, file="sc.yaml")
    assert mech.simulation.duration == 2.0 and mech.simulation.revolutions == 10.0
    study = make_study(load_text(text), ["links.crank.points.A[0]=040, 060"])
    values = {p.name: (p.values, p.unit) for p in study.params}
    assert values["links.rod.points.C[0]"] == ([190.0, 210.0], "mm")  # not 190, 136
    assert values["links.crank.points.A[0]"] == ([40.0, 60.0], "mm")


def _stroke_hand(r: float, l: float = 200.0, e: float = 10.0) -> float:
    """The stroke of an offset slider-crank (Norton 2-17): the extreme slider positions
    are where crank and rod are in line."""
    return math.sqrt((l + r) ** 2 - e**2) - math.sqrt((l - r) ** 2 - e**2)


def test_run_reports_the_stroke_of_a_fifty_mm_crank(tmp_path):
    f = tmp_path / "sc.yaml"
    f.write_text(SLIDER_CRANK.format(crank="050", speed="1500 rpm"), "utf-8")
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(tmp_path / "out"), "--no-plots"])
    assert r.exit_code == 0, r.output
    m = re.search(r"\(stroke ([0-9.]+) mm\)", r.output)
    assert m, r.output
    assert float(m.group(1)) == pytest.approx(_stroke_hand(50.0), abs=1e-3)
    assert abs(_stroke_hand(50.0) - _stroke_hand(40.0)) > 19  # 040 would be far off


def test_check_refuses_a_base_60_coordinate_with_its_line(tmp_path):
    f = tmp_path / "sc.yaml"
    f.write_text(SLIDER_CRANK.format(crank="1:45", speed="1500 rpm"), "utf-8")
    r = CliRunner().invoke(main, ["check", str(f)])
    assert r.exit_code == 2, r.output
    assert "sc.yaml:5" in r.output and "links.crank.points.A[0]" in r.output, r.output
    assert "Traceback" not in r.output


# --- the schema and the parser agree (item 8 of review 17) ------------------------------

SCHEMA_FILE = (
    Path(__file__).resolve().parent.parent / "mechsolve/analyses/schema/mechanism.schema.json"
)


@pytest.fixture(scope="module")
def validator():
    return jsonschema.Draft7Validator(json.loads(SCHEMA_FILE.read_text("utf-8")))


def _patterns(node) -> list[str]:
    if isinstance(node, dict):
        out = [node["pattern"]] if isinstance(node.get("pattern"), str) else []
        return out + [p for v in node.values() for p in _patterns(v)]
    if isinstance(node, list):
        return [p for v in node for p in _patterns(v)]
    return []


def _escapes(pattern: str) -> set[str]:
    """The backslash escapes of a regular expression (``\\\\`` skipped as a pair)."""
    out, i = set(), 0
    while i < len(pattern):
        if pattern[i] == "\\" and i + 1 < len(pattern):
            out.add(pattern[i + 1])
            i += 2
        else:
            i += 1
    return out


def test_the_schemas_patterns_mean_the_same_in_python_and_ecmascript():
    # \d, \w, \b are ASCII in an editor's ECMAScript regex and Unicode in Python's re
    # (jsonschema); \s differs too (\x1c-\x1f, \x85, \ufeff): none may appear
    patterns = _patterns(json.loads(SCHEMA_FILE.read_text("utf-8")))
    assert len(patterns) > 10
    for p in patterns:
        bad = _escapes(p) & set("dDwWsSbB")
        assert not bad, (p, bad)
        re.compile(p)
        # what is left is the same in both: \t \r \n, \xNN, \uNNNN, escaped punctuation
        assert _escapes(p) <= set("trnxu.-^$*+?()[]{}|/\\"), p


def _data(**changes) -> dict:
    data = load_text(SLIDER_CRANK.format(crank="50", speed="1500 rpm")).data
    for path, value in changes.items():
        node = data
        keys = path.split("__")
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = value
    return data


def _schema_errors(validator, data) -> list[str]:
    return [e.message for e in validator.iter_errors(data)]


def _parser_error(data) -> str:
    text = yaml.safe_dump(data, allow_unicode=True, sort_keys=False)
    with pytest.raises(InputError) as info:
        parse.loads(text, file="sc.yaml")
    return str(info.value)


@pytest.mark.parametrize(
    "changes, said",
    [
        ({"driver__speed": "１５００ rpm"}, "write '1500 rpm'"),  # full-width digits
        ({"ground__O": ["０", 0]}, "write '0'"),
        ({"driver__speed": "1,5 rpm"}, "a decimal comma is not read; write '1.5 rpm'"),
        ({"driver__speed": "1_500 rpm"}, "grouped with '_' are not read; write '1500 rpm'"),
        ({"driver__speed": "1:30 rpm"}, "'a:b' values"),
        ({"units__length": None}, "expected the unit of plain lengths, e.g. mm"),
        ({"joints__O": ["ground"]}, "expected a list of 2 or more link names, got a list of 1"),
        ({"joints__O": []}, "expected a list of 2 or more link names, got a list of 0"),
        ({"solver": {"tolerance": "1_0e-9"}}, "solver.tolerance"),
    ],
)
def test_what_the_schema_refuses_the_parser_refuses_saying_why(validator, changes, said):
    data = _data(**changes)
    assert _schema_errors(validator, data), changes
    message = _parser_error(data)
    assert said in message, message
    assert "None" not in message and "unknown unit" not in message, message


def test_a_whole_number_written_with_a_point_is_a_whole_number(validator):
    # a JSON Schema integer, as the editors read it: 10.0 is 10
    data = _data(sweep={"range": "360 deg", "steps": 10.0})
    assert not _schema_errors(validator, data)
    mech = parse.loads(yaml.safe_dump(data, sort_keys=False), file="sc.yaml")
    assert mech.sweep.step == pytest.approx(2 * math.pi / 10)
    data = _data(sweep={"range": "360 deg", "steps": 10.5})
    assert _schema_errors(validator, data)
    assert "whole number" in _parser_error(data)


def test_no_break_and_ideographic_spaces_around_a_number_are_read_by_both(validator):
    data = _data(driver__speed="\u30001500\u00a0rpm")
    assert not _schema_errors(validator, data)
    assert parse.loads(yaml.safe_dump(data, allow_unicode=True), file="sc.yaml").driver.speed == (
        pytest.approx(1500 * 2 * math.pi / 60)
    )


# --- a run into a used folder leaves none of the earlier run's files (item 7) -----------

WITH_G = SLIDER_CRANK.format(crank="50", speed="1500 rpm").replace(
    "C: [200, 0]}}", "C: [200, 0], G: [60, 0]}, mass: 0.9 kg, com: G, inertia: 0.0045 kg m^2}"
)
INSTANTS = "instants:\n  - {theta: 30 deg, omega: 10 rad/s, alpha: 0}\n"


def _run(folder, text, *extra):
    f = folder / "m.yaml"
    f.write_text(text, "utf-8")
    r = CliRunner().invoke(main, ["run", str(f), "-o", str(folder / "out"), *extra])
    return r


def _wrote(output: str) -> set[str]:
    m = re.search(r"wrote \d+ file\(s\) to [^:]*: (.*)", output)
    assert m, output
    return set(m.group(1).split(", "))


def _listing(out) -> set[str]:
    return {p.name for p in out.iterdir()} - {".mechsolve-outputs.json"}


def test_a_run_names_what_the_last_run_wrote_and_it_does_not(tmp_path):
    assert WITH_G != SLIDER_CRANK.format(crank="50", speed="1500 rpm")
    out = tmp_path / "out"
    r = _run(tmp_path, WITH_G + INSTANTS)
    assert r.exit_code == 0, r.output
    first = _wrote(r.output)
    assert {"point_G.png", "torque.png", "reactions.png"} <= first
    assert _listing(out) == first | {"instants.csv"}
    mine = out / "notes.txt"  # a file of the user's: never touched
    mine.write_text("mine", "utf-8")
    # the same model without G, its masses and its instants
    r = _run(tmp_path, SLIDER_CRANK.format(crank="50", speed="1500 rpm"))
    assert r.exit_code == 0, r.output
    second = _wrote(r.output)
    gone = sorted((first | {"instants.csv"}) - second)
    assert {"point_G.png", "torque.png", "reactions.png", "instants.csv"} <= set(gone)
    assert f"{len(gone)} file(s) in {out}/ are from an earlier run, not from this one" in r.output
    assert ", ".join(gone) in r.output
    # nothing is removed: they may be results still needed
    assert _listing(out) == second | set(gone) | {"notes.txt"}
    assert mine.read_text("utf-8") == "mine" and "notes.txt" not in r.output
    # named again by the next run, until they are gone or written again
    (out / "torque.png").unlink()
    r = _run(tmp_path, SLIDER_CRANK.format(crank="50", speed="1500 rpm"))
    assert r.exit_code == 0, r.output
    rest = [g for g in gone if g != "torque.png"]
    assert f"{len(rest)} file(s) in {out}/ are from an earlier run" in r.output
    assert ", ".join(rest) in r.output


def test_a_file_changed_since_mechsolve_wrote_it_is_left_and_named(tmp_path):
    out = tmp_path / "out"
    r = _run(tmp_path, WITH_G, "--no-plots")
    assert r.exit_code == 0, r.output
    r = _run(tmp_path, WITH_G)  # the plots too
    assert r.exit_code == 0, r.output
    (out / "point_G.png").write_bytes(b"the user's own picture")
    r = _run(tmp_path, SLIDER_CRANK.format(crank="50", speed="1500 rpm"))
    assert r.exit_code == 0, r.output
    assert "1 file(s) in" in r.output and "were changed since" in r.output, r.output
    m = re.search(r"were changed since it wrote them \(kept, no longer in its record\): (.*)",
                  r.output)  # fmt: skip
    assert m and m.group(1).strip() == "point_G.png"
    assert (out / "point_G.png").read_bytes() == b"the user's own picture"
    assert (out / "torque.png").exists()
    r = _run(tmp_path, SLIDER_CRANK.format(crank="50", speed="1500 rpm"))
    assert "changed since" not in r.output  # named once: no longer mechsolve's


def test_run_at_leaves_the_sweeps_files_and_a_failed_run_names_nothing(tmp_path):
    out = tmp_path / "out"
    r = _run(tmp_path, WITH_G)
    assert r.exit_code == 0, r.output
    files = _listing(out)
    r = _run(tmp_path, WITH_G, "--at", "theta=30 deg")
    assert r.exit_code == 0, r.output
    assert _listing(out) == files | {"instants.csv"}
    # a run that fails after writing (a requirement on an unknown quantity) names nothing
    bad = SLIDER_CRANK.format(crank="50", speed="1500 rpm") + (
        "requirements:\n  r: stroke(cylinderx) > 90 mm\n"
    )
    r = _run(tmp_path, bad)
    assert r.exit_code == 2, r.output
    assert "from an earlier run" not in r.output
    assert {"point_G.png", "torque.png"} <= _listing(out)
    # the next complete run names both runs' leftovers, not the --at run's instants.csv
    r = _run(tmp_path, SLIDER_CRANK.format(crank="50", speed="1500 rpm"))
    assert r.exit_code == 0, r.output
    named = re.search(r"from this one \(kept; delete them if they are not needed\): (.*)",
                      r.output).group(1).split(", ")  # fmt: skip
    assert set(named) == _listing(out) - _wrote(r.output) - {"instants.csv"}
    assert {"point_G.png", "torque.png"} <= set(named)


def test_simulate_follows_the_same_rule(tmp_path):
    f = tmp_path / "m.yaml"
    f.write_text(
        WITH_G + "motor: {stall: 50 N m, slope: 1 N m s}\n"
        "simulate: {duration: 0.05 s, step: 0.001 s}\n",
        "utf-8",
    )
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(out)])
    assert r.exit_code == 0, r.output
    plots = _wrote(r.output) - {"simulation.csv"}
    assert plots
    r = CliRunner().invoke(main, ["simulate", str(f), "-o", str(out), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert _listing(out) == {"simulation.csv"} | plots  # kept: the last plots made
    assert f"{len(plots)} file(s) in {out}/ are from an earlier simulate" in r.output


def test_the_record_never_names_a_file_outside_the_folder(tmp_path):
    from mechsolve.base.manifest import NAME, record

    out = tmp_path / "out"
    out.mkdir()
    outside = tmp_path / "keep.txt"
    outside.write_text("x", "utf-8")
    st = outside.stat()
    (out / NAME).write_text(
        json.dumps(
            {
                "format": 1,
                "commands": {
                    "run": {
                        "files": {
                            "../keep.txt": [st.st_size, st.st_mtime_ns],
                            str(outside): [st.st_size, st.st_mtime_ns],
                        }
                    }
                },
            }
        ),
        "utf-8",
    )
    (out / "results.csv").write_text("new", "utf-8")
    (out / "old.csv").write_text("old", "utf-8")
    st = (out / "old.csv").stat()
    data = json.loads((out / NAME).read_text("utf-8"))
    data["commands"]["run"]["files"]["old.csv"] = [st.st_size, st.st_mtime_ns]
    (out / NAME).write_text(json.dumps(data), "utf-8")
    done = record(out, "run", [out / "results.csv"], complete=True)
    assert done.earlier == ["old.csv"] and (out / "old.csv").exists()  # the check works
    assert outside.exists()  # and the names outside the folder were not even read


def test_the_number_to_write_is_suggested_only_where_it_is_certain():
    from mechsolve.base.units import UnitError, parse_quantity

    with pytest.raises(UnitError, match=r"write '1500 rpm'"):
        parse_quantity("1_500 rpm", "angular speed")
    with pytest.raises(UnitError) as info:  # -p rebuilds "1.0 _000": no "1.0000" guess
        parse_quantity("1.0 _000", "length")
    assert "grouped with '_'" in str(info.value) and "write" not in str(info.value)


@pytest.mark.parametrize(
    "condition, said",
    [
        ("C.x > １５０ mm", "is not ASCII 0-9"),
        ("C.x > 1_500 mm", "digits grouped with '_' are not read"),
        ("C.x > 1:30 mm", "'a:b' values (base 60) are not read"),
    ],
)
def test_an_assembly_condition_reads_numbers_as_the_values_do(condition, said):
    text = SLIDER_CRANK.format(crank="50", speed="1500 rpm").replace(
        "assembly: [C.x > A.x]", f"assembly: [{condition}]"
    )
    with pytest.raises(InputError) as info:
        parse.loads(text, file="sc.yaml")
    assert said in str(info.value) and info.value.keypath == "assembly[0]", str(info.value)


def test_a_zero_padded_number_in_a_condition_is_decimal():
    from mechsolve.model.expr import Expression

    # 0100 mm is 0.1 m, not octal 64 mm
    assert Expression("0100 mm + 1 mm").evaluate_at({}) == pytest.approx(0.101)
    assert Expression("angle * 0100", variables=("angle",)).evaluate_at({"angle": 1.0}) == 100


def test_a_commands_input_and_kept_results_are_never_removed(tmp_path):
    """The review's cases: `shaking --balance` writes a balanced design into the folder,
    the next `shaking` of that design into the same folder reads it (its input: neither
    removed nor named); the plots of a run with plots survive a run with --no-plots."""
    import shutil

    src = Path(__file__).resolve().parents[1] / "mechanisms" / "fourbar.yaml"
    f = tmp_path / "fourbar.yaml"
    shutil.copy(src, f)
    sh = tmp_path / "sh"
    r = CliRunner().invoke(main, ["shaking", str(f), "--balance", "-o", str(sh), "--no-plots"])
    assert r.exit_code == 0, r.output
    balanced = sorted(sh.glob("*balanced*.yaml"))
    assert balanced, _listing(sh)
    text = balanced[0].read_text("utf-8")
    r = CliRunner().invoke(main, ["shaking", str(balanced[0]), "-o", str(sh), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert balanced[0].read_text("utf-8") == text  # the input is still there, unchanged
    assert balanced[0].name not in r.output
    r = CliRunner().invoke(main, ["shaking", str(f), "-o", str(sh), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert balanced[0].exists()
