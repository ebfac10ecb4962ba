"""Issue 29, item 1: the documentation site builds with warnings as errors, its file
reference lists exactly the keys the parser accepts, and every example in it runs.

The examples: a fenced block's language says what it is. ``bash`` blocks are run (in a
temporary folder that holds the example mechanisms, one folder per page, in the page's
order, so that a later block reads what an earlier one wrote); ``python`` blocks are run
the same way; ``yaml`` blocks must be valid YAML; ``console`` (a command that must not
run here, such as ``pip install``, or a command shown with its output) and ``text``
(output, a layout) are shown only. Any other language, or none, is refused, so that no
example is left unchecked by accident. A block right after the line
``<!-- file: NAME -->`` is written to the file NAME first, for the examples that follow.
"""

from __future__ import annotations

import copy
import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from mechsolve.analyses.schema import reference
from mechsolve.base.errors import InputError
from mechsolve.model import parse
from mechsolve.model.source import load_text

from conftest import ROOT

DOCS = ROOT / "docs"
RUN = {"bash", "python"}
SHOWN = {"console", "text", "yaml"}
FENCE = re.compile(r"^(?P<indent>[ \t]*)(?P<fence>`{3,}|~{3,})(?P<lang>[^\s`]*)")
FILE = re.compile(r"^<!-- file: (?P<name>[\w.-]+) -->$")


def pages() -> list[Path]:
    return sorted(DOCS.rglob("*.md"))


def blocks(path: Path) -> list[tuple[int, str, str, str | None]]:
    """The fenced blocks of a page: (line, language, text, the file it is written to or
    None), in order."""
    out = []
    lines = path.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if m:
            indent, fence = len(m["indent"]), m["fence"]
            body, j = [], i + 1
            while j < len(lines) and not lines[j].strip().startswith(fence):
                body.append(lines[j][indent:])
                j += 1
            assert j < len(lines), f"{path}:{i + 1}: the block is not closed"
            named = FILE.match(lines[i - 1]) if i else None
            out.append((i + 1, m["lang"], "\n".join(body) + "\n", named and named["name"]))
            i = j
        i += 1
    return out


def _env() -> dict[str, str]:
    """A child's environment: this checkout's package first, the interpreter's scripts
    (``mechsolve``) on the PATH, no display, no debug tracebacks."""
    env = {k: v for k, v in os.environ.items() if k != "MECHSOLVE_DEBUG"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env["MPLBACKEND"] = "Agg"
    env["NO_MKDOCS_2_WARNING"] = "1"
    return env


# --- the site -------------------------------------------------------------------------


def test_readme_test_command_installs_the_docs_group():
    """CI runs README's test command (.ci/run): it installs the docs group, so that the
    build below is never skipped there."""
    cmd = next(
        ln for ln in (ROOT / "README.md").read_text().splitlines() if "python -m pytest" in ln
    )
    extras = re.search(r"\[([^\]]+)\]", cmd)
    assert extras and {"test", "docs"} <= set(extras.group(1).split(",")), cmd
    groups = (ROOT / "pyproject.toml").read_text()
    assert re.search(r"^docs = \[", groups, re.M)


@pytest.mark.slow
def test_site_builds_with_warnings_as_errors(tmp_path):
    if importlib.util.find_spec("mkdocs") is None:
        if os.environ.get("CI", "").lower() not in ("", "0", "false", "no"):
            pytest.fail('CI must install the docs group: pip install -e ".[test,docs]"')
        pytest.skip('the docs group is not installed (pip install -e ".[docs]")')
    site = tmp_path / "site"
    p = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml")]
        + ["-d", str(site)],
        capture_output=True,
        text=True,
        timeout=600,
        env=_env(),
        cwd=ROOT,
    )
    assert p.returncode == 0, p.stderr[-4000:]
    assert "WARNING" not in p.stderr, p.stderr[-4000:]
    # the generated pages have their generated parts
    keys_page = (site / "reference" / "file" / "index.html").read_text()
    for key in ("cam_contact", "uniform_bar", "pitch_line", "requirements", "time_step"):
        assert f"<code>{key}</code>" in keys_page, key
    commands = (site / "reference" / "commands" / "index.html").read_text()
    from mechsolve.cli.main import main

    for name in main.commands:
        assert f"mechsolve {name}" in commands, name
    assert "Sentinel" not in commands  # click's own help text: its defaults, not UNSET
    api = (site / "reference" / "api" / "index.html").read_text()
    for name in ("load", "solve", "check", "solve_designs", "transmission_angles"):
        assert re.search(rf"id=\"[\w.]*\b{name}\"", api), name
    bench = (site / "benchmarks" / "index.html").read_text()
    assert "work-precision.png" in bench and (site / "benchmarks" / "work-precision.png").exists()


# --- the file reference against the parser --------------------------------------------


def listed() -> dict[str, list[str]]:
    """The keys the generated file reference lists, by section title, in its order."""
    out: dict[str, list[str]] = {}
    title = None
    for line in reference.markdown().splitlines():
        m = re.match(r"^## (.+?) \{#[\w-]+\}$", line)
        if m:
            title = m.group(1)
            out[title] = []
        elif title and (k := re.match(r"^\| `([^`]+)` \|", line)):
            out[title].append(k.group(1))
    return out


def _allowed(message: str) -> list[str]:
    m = re.search(r"(?:allowed|sections are): (.*)$", message)
    assert m, message
    return m.group(1).split(", ")


def parser_keys(text: str, read=parse.loads) -> list[str]:
    """The keys a reader accepts where ``text`` puts the bogus key ``zzz``: the list its
    message gives."""
    with pytest.raises(InputError) as exc:
        read(text)
    assert "'zzz'" in exc.value.message, exc.value.message
    return _allowed(exc.value.message)


def _set(data: dict, path: tuple, value) -> dict:
    d = data
    for k in path[:-1]:
        d = d[k]
    if value is None:
        del d[path[-1]]
    else:
        d[path[-1]] = value
    return data


def test_file_reference_lists_exactly_the_keys_the_parser_accepts():
    """Every mapping of the format: the keys the page lists are the keys the parser's
    message lists when a bogus key is put there (the probes of tests/test_schema.py, which
    reach every section the mechanism parser reads), in the same order."""
    from test_schema import PROBES, base

    page = listed()
    for title, changes in PROBES.items():
        data = base()
        for path, value in changes:
            _set(data, path, copy.deepcopy(value))
        accepted = parser_keys(json.dumps(data))
        if title == "pin":  # a pin is a joint with fewer keys
            assert set(accepted) < set(page["joint"])
        else:
            assert page[title] == accepted, title


CAM = (ROOT / "mechanisms" / "shaper-cam.yaml").read_text()


def _cam(change) -> str:
    data = yaml.safe_load(CAM)
    data.pop("variants")
    change(data["cam"])
    return json.dumps(data)


def test_file_reference_lists_the_cam_the_study_and_the_torque_problem_keys():
    """The sections other readers read: the cam (mechsolve cam), the study (mechsolve
    sweep) and the torque problem (mechsolve flywheel without links)."""
    from mechsolve.analyses.cam.model import from_source
    from mechsolve.analyses.study.designs import STUDY_KEYS
    from mechsolve.model.read_machine import read_torque_problem

    page = listed()

    def cam(text: str):
        return from_source(load_text(text, "cam.yaml"))

    probes = {
        "cam": lambda c: c.update(zzz=1),
        "follower": lambda c: c["follower"].update(zzz=1),
        "allowable pressure angle": lambda c: c["allowable_pressure_angle"].update(zzz=1),
    }
    for title, change in probes.items():
        assert page[title] == parser_keys(_cam(change), cam), title
    # a segment's keys depend on its kind (a dwell has no lift): each kind's, together
    segment = set()
    for i in range(4):  # rise, dwell, return, dwell
        segment |= set(parser_keys(_cam(lambda c, i=i: c["motion"][i].update(zzz=1)), cam))
    translating = {  # a translating follower's rise has a lift, not a swing
        "units": {"length": "mm", "angle": "deg"},
        "cam": {
            "follower": {"type": "translating roller", "roller_radius": 10},
            "base_radius": 40,
            "rotation": "ccw",
            "speed": "60 rpm",
            "law": "cycloidal",
            "motion": [{"rise": 180, "lift": 20, "zzz": 1}, {"return": 180}],
        },
    }
    segment |= set(parser_keys(json.dumps(translating), cam))
    assert set(page["cam segment"]) == segment
    # the study's reader names its keys in its message in its own words: its constant
    assert page["study"] == list(STUDY_KEYS)

    def torque(text: str):
        return read_torque_problem(load_text(text, "torque.yaml"))

    problem = {"torque": {"table": [[0, 1], [180, 2], [360, 1]]}, "speed": "60 rpm"}
    assert page["torque problem"] == parser_keys(json.dumps({**problem, "zzz": 1}), torque)
    curve = {**problem, "torque": {**problem["torque"], "zzz": 1}}
    assert page["torque curve"] == parser_keys(json.dumps(curve), torque)


def test_every_section_of_the_reference_is_checked_against_a_reader():
    from test_schema import PROBES

    checked = set(PROBES) - {"pin"} | {
        "cam", "follower", "cam segment", "allowable pressure angle", "study",
        "torque problem", "torque curve",
    }  # fmt: skip
    assert set(listed()) == checked


# --- the examples ---------------------------------------------------------------------


def test_every_fenced_block_says_whether_it_runs():
    """No block without a language, and none in a language the examples test ignores."""
    for page in pages():
        for line, lang, _, _ in blocks(page):
            assert lang in RUN | SHOWN, (
                f"{page.relative_to(ROOT)}:{line}: a ```{lang} block: write ```bash or "
                "```python for an example that runs, ```console or ```text for one shown only"
            )


def test_every_yaml_block_is_yaml():
    for page in pages():
        for line, lang, text, _ in blocks(page):
            if lang == "yaml":
                try:
                    yaml.safe_load(text)
                except yaml.YAMLError as exc:
                    pytest.fail(f"{page.relative_to(ROOT)}:{line}: {exc}")


RUNNABLE = [p for p in pages() if any(lang in RUN for _, lang, _, _ in blocks(p))]


@pytest.mark.slow
@pytest.mark.parametrize("page", RUNNABLE, ids=lambda p: str(p.relative_to(DOCS)))
def test_examples_of_a_page_run(page, tmp_path):
    """Each example of the page, in a folder with the example mechanisms: exit 0."""
    (tmp_path / "mechanisms").symlink_to(ROOT / "mechanisms", target_is_directory=True)
    for line, lang, text, name in blocks(page):
        if name:
            (tmp_path / name).write_text(text, encoding="utf-8")
        if lang == "bash":
            cmd = ["bash", "-euo", "pipefail", "-c", text]
        elif lang == "python":
            cmd = [sys.executable, "-c", text]
        else:
            continue
        p = subprocess.run(
            cmd, cwd=tmp_path, capture_output=True, text=True, timeout=600, env=_env()
        )
        assert p.returncode == 0, (
            f"{page.relative_to(ROOT)}:{line}: exit {p.returncode}\n{text}\n{p.stderr[-3000:]}"
        )
        assert "Traceback" not in p.stderr, p.stderr


# --- README, the front page -----------------------------------------------------------

HISTORY = re.compile(r"\b[Ss]eed 00\d|\b[Ii]ssue \d+|\bthe issue\b")


def test_readme_is_a_front_page():
    """Under 150 lines: what it is, the two commands first, one picture, links that lead
    somewhere; nothing of the project's history a user cannot see."""
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) < 150
    first = text.split("```", 2)[1].splitlines()[1:]
    assert first[0] == "pip install . && mechsolve run mechanisms/crane.yaml"
    assert first[1].startswith("pip install ") and first[1].endswith("python -m pytest")
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert len(images) == 1 and (ROOT / images[0]).is_file()
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text):
        if not target.startswith(("http://", "https://")):
            assert (ROOT / target).exists(), target
    assert not HISTORY.search(text), HISTORY.search(text)


def test_the_pages_say_nothing_of_the_projects_history():
    for page in pages():
        m = HISTORY.search(page.read_text(encoding="utf-8"))
        assert not m, f"{page.relative_to(ROOT)}: {m and m.group(0)!r}"


# --- exit codes in each command's help --------------------------------------------------


def test_each_command_help_names_only_the_codes_it_can_give():
    """The rule is listed once, in `mechsolve --help`; a command's help points at it in
    one line, naming 5 (a design check failed) only where the command can end with it
    (its module ends with finish(check_failed=...) or returns that code)."""
    import inspect

    from click.testing import CliRunner

    from mechsolve.cli.main import main

    full = CliRunner().invoke(main, ["--help"]).output
    assert re.search(r"^\s+5\s+a design check failed", full, re.M)
    for name, cmd in main.commands.items():
        source = inspect.getsource(sys.modules[cmd.callback.__module__])
        can_fail = "check_failed=" in source or "EXIT_CHECK_FAILED" in source
        out = CliRunner().invoke(main, [name, "--help"]).output
        tail = out[out.index("Exit codes") :]
        assert len(tail.strip().splitlines()) <= 4, (name, tail)
        assert ("5 a design check failed" in " ".join(tail.split())) == can_fail, name
        assert not re.search(r"^\s+(0|2|4|5|130|141)\s{2,}", out, re.M), name  # no table
    schema = CliRunner().invoke(main, ["schema", "--help"]).output
    assert "Exit codes: 0 done, 2 bad input, 4 internal error, 130 interrupted" in " ".join(
        schema.split()
    )


# --- CI prints the fast tier's time -------------------------------------------------------

STUB = """#!/usr/bin/env bash
# a stand-in for {name}: log the call; python's pytest exits with the codes the test sets
echo "{name} $*" >> "$STUB_LOG"
if [ "{name}" = python3 ] && [ "$1" = -m ] && [ "$2" = venv ]; then
  mkdir -p "$3/bin"
  printf 'PATH="%s:$PATH"\\n' "$STUB_VENV_BIN" > "$3/bin/activate"
fi
if [ "{name}" = python ] && [ "$1 $2" = "-m pytest" ]; then
  case " $* " in
    *" not slow "*) exit "$FAST_RC" ;;
    *) exit "$FULL_RC" ;;
  esac
fi
exit 0
"""


def _stubs(where: Path, *names: str) -> None:
    where.mkdir()
    for name in names:
        (where / name).write_text(STUB.format(name=name))
        (where / name).chmod(0o755)


@pytest.mark.parametrize("fast_rc, full_rc", [(0, 0), (1, 0), (0, 1), (1, 3)])
def test_ci_times_the_fast_tier_then_runs_readme_test_command(tmp_path, fast_rc, full_rc):
    """.ci/run (with stand-ins for Python, pip and apt-get that log their calls): the fast
    tier runs first under `time` and its time is printed, then exactly README's test
    command; the exit status is that command's, whatever the fast tier gave."""
    repo = tmp_path / "repo"
    (repo / ".ci").mkdir(parents=True)
    (repo / ".ci" / "run").write_text((ROOT / ".ci" / "run").read_text())
    readme = '# x\n\n```sh\npip install .\npip install ".[test,docs]" && python -m pytest\n```\n'
    (repo / "README.md").write_text(readme)
    _stubs(tmp_path / "bin", "python3", "apt-get")
    _stubs(tmp_path / "venv-bin", "python", "pip")
    log = tmp_path / "log"
    env = {
        "PATH": os.pathsep.join([str(tmp_path / "bin"), os.environ["PATH"]]),
        "STUB_LOG": str(log),
        "STUB_VENV_BIN": str(tmp_path / "venv-bin"),
        "FAST_RC": str(fast_rc),
        "FULL_RC": str(full_rc),
        "HOME": str(tmp_path),
    }
    p = subprocess.run(
        ["bash", str(repo / ".ci" / "run")], capture_output=True, text=True, env=env, timeout=60
    )
    assert p.returncode == full_rc, p.stdout + p.stderr
    assert re.search(r'fast tier \(pytest -m "not slow"\): \d+\.\d+ s wall', p.stderr), p.stderr
    assert f"fast tier: exit code {fast_rc}" in p.stdout
    calls = [c for c in log.read_text().splitlines() if c.startswith(("python ", "pip "))]
    tests = [c for c in calls if c.startswith("python -m pytest")]
    assert tests == ["python -m pytest -m not slow -q -p no:cacheprovider", "python -m pytest"]
    # README's command ran whole, after the fast tier: its install, then its tests
    assert calls[-2:] == ["pip install .[test,docs]", "python -m pytest"]
    assert calls.index(tests[0]) < len(calls) - 2


@pytest.mark.slow
def test_readme_python_example_runs(tmp_path):
    (tmp_path / "mechanisms").symlink_to(ROOT / "mechanisms", target_is_directory=True)
    found = [text for _, lang, text, _ in blocks(ROOT / "README.md") if lang == "python"]
    assert found
    for text in found:
        p = subprocess.run(
            [sys.executable, "-c", text], cwd=tmp_path, capture_output=True, text=True,
            timeout=300, env=_env(),
        )  # fmt: skip
        assert p.returncode == 0, p.stderr[-3000:]
