"""Every exit code of ``mechsolve``, for each of its causes, through a real process.

0 success, and a run completed with warnings (unassemblable positions; values not
determined at singular positions; a failed check), which also prints a ``warning:`` line on
stderr; 2 input error (the file, the command line, an output folder that cannot be
written, a mechanism that cannot be assembled); 4 a bug; 5 a design check failed
(``tests/test_issue24_exits.py``, which runs every command); 130 interrupted
(SIGTERM: ``tests/test_cli.py::test_sigterm_leaves_no_partial_file``; Ctrl-C here).
No cause may print a traceback. An exception that escapes the input layer without being
an input error is a bug (4), and a genuine input error is never one.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from mechsolve.cli.main import main

from conftest import MECH

BAD_INPUTS = Path(__file__).parent / "bad_inputs"
ROOT = Path(__file__).resolve().parent.parent


def mechsolve(*args: str, script: str | None = None, timeout: float = 180):
    """Run the command line in a new Python process (or ``script``, a wrapper that calls
    it after injecting a fault); no traceback may reach the user."""
    cmd = [sys.executable, "-m", "mechsolve"] if script is None else [sys.executable, script]
    env = {k: v for k, v in os.environ.items() if k != "MECHSOLVE_DEBUG"}
    # a script in a temporary folder imports this checkout, not an installed copy
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    p = subprocess.run(cmd + list(args), capture_output=True, text=True, timeout=timeout, env=env)
    assert "Traceback" not in p.stdout + p.stderr, p.stderr
    return p


def write(tmp_path: Path, name: str, text: str) -> str:
    f = tmp_path / name
    f.write_text(text)
    return str(f)


def fourbar(a: float, b: float, c: float, d: float, extra: str = "") -> str:
    return f"""
ground: {{O2: [0, 0], O4: [{d}, 0]}}
links:
  crank: {{points: {{O2: [0, 0], A: [{a}, 0]}}}}
  coupler: {{points: {{A: [0, 0], B: [{b}, 0]}}}}
  rocker: {{points: {{O4: [0, 0], B: [{c}, 0]}}}}
joints: {{O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}}
driver: {{joint: O2, speed: 1 rad/s, start: 0 deg}}
{extra}
"""


# --- 0 ----------------------------------------------------------------------------------


def test_0_clean_run(tmp_path):
    p = mechsolve("run", str(MECH / "fourbar.yaml"), "-o", str(tmp_path), "--no-plots")
    assert p.returncode == 0, p.stderr
    assert p.stderr == "" and "181 of 181 positions solved" in p.stdout


# --- 0 with warnings (issue 24: one rule, no 1) -------------------------------------------


def test_0_warned_unassemblable_positions(tmp_path):
    # |A O4| reaches a + d = 1.6 > b + c = 1.1 around 180 deg: no closure there
    f = write(
        tmp_path, "nongrashof.yaml", fourbar(0.6, 0.6, 0.5, 1.0, "assembly: [B left of A -> O4]")
    )
    p = mechsolve("run", f, "-o", str(tmp_path / "o"), "--no-plots")
    assert p.returncode == 0 and "warning: " in p.stderr, p.stdout + p.stderr
    assert "unassemblable at" in p.stdout
    rows = (tmp_path / "o" / "results.csv").read_text().splitlines()
    assert len(rows) == 1 + 361 and any("unassemblable: " in r for r in rows)


def test_0_warned_values_undetermined_at_singular_positions(tmp_path):
    # a four-bar driven by its rocker exactly to the rocker's limit position: there the
    # crank's and the coupler's rates grow without bound and are left blank
    import math

    a, b, c, d = 0.3, 1.1, 0.8, 1.0
    lim = math.degrees(math.acos(((a + b) ** 2 - d * d - c * c) / (2 * d * c)))
    text = (
        fourbar(a, b, c, d, "")
        .replace("joint: O2", "joint: O4")
        .replace("start: 0 deg", f"direction: cw, start: {lim + 30!r} deg")
    )
    text += "sweep: {range: 30 deg, steps: 30}\n"
    p = mechsolve("run", write(tmp_path, "lim.yaml", text), "-o", str(tmp_path), "--no-plots")
    assert p.returncode == 0 and "warning: " in p.stderr, p.stdout + p.stderr
    assert "are not determined (left blank)" in p.stdout


def test_0_warned_forces_indeterminate_at_singular_positions(tmp_path):
    # the same parallelogram in closed form with a mass: its reactions at the collinear
    # positions are indeterminate
    text = fourbar(1, 3, 1, 3, "assembly: {sketch: {B: [3.8, 0.6]}}")
    text = text.replace("A: [1, 0]}}", "A: [1, 0]}, mass: 1 kg, uniform_bar: [O2, A]}")
    p = mechsolve("run", write(tmp_path, "par.yaml", text), "-o", str(tmp_path), "--no-plots")
    assert p.returncode == 0 and "warning: " in p.stderr, p.stdout + p.stderr
    assert "forces indeterminate at" in p.stdout


def test_0_warned_failed_check_dead_zone_stepped_over(tmp_path):
    # b + c falls short of a + d by 5e-5 m around 180 deg: the 10 deg step jumps over it
    text = fourbar(0.8, 1.2, 0.79995, 1.2, "sweep: {range: 350 deg, step: 10 deg}")
    text = text.replace("start: 0 deg", "start: 5 deg") + "assembly: [B left of A -> O4]\n"
    p = mechsolve("run", write(tmp_path, "dz.yaml", text), "-o", str(tmp_path), "--no-plots")
    assert p.returncode == 0 and "warning: " in p.stderr, p.stdout + p.stderr
    assert "warning:" in p.stdout and "dead zone" in p.stdout


def test_0_warned_failed_check_power_balance(tmp_path):
    """No correct model breaks the power balance (it is there to catch a wrong force
    analysis), so the fault is injected: a driving torque off by 1 %."""
    script = write(
        tmp_path,
        "inject.py",
        "import sys\n"
        "import mechsolve.core.kinetostatics as f\n"
        "p = f.ForceResult.power_input\n"
        "f.ForceResult.power_input = property(lambda self: 1.01 * p.fget(self))\n"
        "from mechsolve.cli.main import main\n"
        "sys.exit(main())\n",
    )
    args = ("run", str(MECH / "fourbar.yaml"), "-o", str(tmp_path), "--no-plots")
    p = mechsolve(*args, script=script)
    assert p.returncode == 0 and "warning: " in p.stderr, p.stdout + p.stderr
    assert "warning: the power balance residual reaches" in p.stdout
    # and a streamed run checks it too (it used to exit 0)
    env_script = write(
        tmp_path,
        "inject_stream.py",
        "import os\nos.environ['MECHSOLVE_STREAM_ABOVE'] = '100'\n" + Path(script).read_text(),
    )
    p = mechsolve(*args, script=env_script)
    assert p.returncode == 0 and "warning: " in p.stderr, p.stdout + p.stderr
    assert "streamed in" in p.stdout and "power balance residual reaches" in p.stdout


# --- 2 ----------------------------------------------------------------------------------


def test_2_file_error_names_file_line_and_key(tmp_path):
    text = (MECH / "fourbar.yaml").read_text().replace("speed:", "sped:", 1)
    f = write(tmp_path, "typo.yaml", text)
    p = mechsolve("run", f, "-o", str(tmp_path / "o"))
    assert p.returncode == 2, p.stdout + p.stderr
    assert re.search(r"typo\.yaml:\d+: driver\.sped: ", p.stderr), p.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["run", "--frobnicate"], "No such option"),
        (["run", "{f}", "--method", "magic"], "Invalid value for '--method'"),
        (["run", "{f}", "--step", "5 kg"], "--step '5 kg'"),
        (["run", "{f}", "--variant", "nope"], "nope"),
        (["run", "{d}/missing.yaml"], "no such file"),
        (["launch"], "No such command"),
    ],
)
def test_2_bad_command_line(tmp_path, args, fragment):
    f = str(MECH / "fourbar.yaml")
    args = [a.format(f=f, d=tmp_path) for a in args] + ["-o", str(tmp_path / "o")]
    p = mechsolve(*args)
    assert p.returncode == 2, p.stdout + p.stderr
    assert fragment in p.stderr


def _unwritable(tmp_path: Path) -> dict[str, tuple[str, str]]:
    """Output folders that cannot be written, even by root: -o value -> expected text."""
    afile = tmp_path / "afile"
    afile.write_text("x")
    cases = {
        "/proc/mechsolve-out": ("/proc/mechsolve-out", "No such file or directory"),
        "under-a-file": (str(afile / "sub" / "out"), f"{afile} is a file, not a folder"),
        "a-file": (str(afile), "is a file"),
    }
    if Path("/sys").is_dir():
        cases["/sys"] = ("/sys/mechsolve-out", "not permitted")
    return cases


@pytest.mark.parametrize("case", ["/proc/mechsolve-out", "under-a-file", "a-file", "/sys"])
def test_2_output_folder_cannot_be_written(tmp_path, case):
    cases = _unwritable(tmp_path)
    if case not in cases:
        pytest.skip("no /sys here")
    outdir, why = cases[case]
    p = mechsolve("run", str(MECH / "fourbar.yaml"), "-o", outdir, "--no-plots")
    assert p.returncode == 2, p.stdout + p.stderr
    assert why in p.stderr and "bug" not in p.stderr


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0,
    reason="root writes into a read-only folder anyway (covered by /proc and /sys)",
)
def test_2_read_only_output_folder(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        p = mechsolve("run", str(MECH / "fourbar.yaml"), "-o", str(ro), "--no-plots")
    finally:
        ro.chmod(0o755)
    assert p.returncode == 2, p.stdout + p.stderr
    assert "the output folder cannot be written: Permission denied" in p.stderr
    assert list(ro.iterdir()) == []


def test_2_before_solving(tmp_path):
    """The folder is checked before the sweep is solved: a long run fails at once."""
    t0 = time.monotonic()
    p = mechsolve(
        "run", str(MECH / "fourbar.yaml"), "--step", "0.0001 deg", "-o", "/proc/mechsolve-out"
    )
    assert p.returncode == 2 and time.monotonic() - t0 < 20


def test_2_check_draw_cannot_be_written():
    p = mechsolve("check", str(MECH / "fourbar.yaml"), "--draw", "/proc/mechsolve.png")
    assert p.returncode == 2, p.stdout + p.stderr
    assert "--draw /proc/mechsolve.png: cannot write it" in p.stderr


# --- 2: cannot be assembled (issue 24: no 3) ---------------------------------------------


def test_2_cannot_assemble(tmp_path):
    # b + c = 0.5 < d - a = 0.8: the loop never closes
    f = write(tmp_path, "short.yaml", fourbar(0.2, 0.25, 0.25, 1.0))
    p = mechsolve("run", f, "-o", str(tmp_path / "o"))
    assert p.returncode == 2, p.stdout + p.stderr
    assert p.stderr.startswith("error: ") and "bug" not in p.stderr
    assert not (tmp_path / "o" / "results.csv").exists()
    p = mechsolve("check", f)
    assert p.returncode == 2, p.stdout + p.stderr


# --- 4 ----------------------------------------------------------------------------------

INJECT_BUG = """\
import sys
import mechsolve.model.parse as parse

def read_ground(*args, **kwargs):
    raise ValueError("injected: not an input error")

parse.read_ground = read_ground
from mechsolve.cli.main import main
sys.exit(main())
"""


def test_4_bug_in_the_input_layer(tmp_path):
    """A plain exception escaping the parser is a bug: exit 4 and a request to report it,
    without a traceback (unless MECHSOLVE_DEBUG is set)."""
    script = write(tmp_path, "bug.py", INJECT_BUG)
    p = mechsolve("run", str(MECH / "fourbar.yaml"), "-o", str(tmp_path), script=script)
    assert p.returncode == 4, p.stdout + p.stderr
    assert "internal error: ValueError: injected" in p.stderr
    assert "This is a bug in mechsolve" in p.stderr
    env = dict(os.environ, MECHSOLVE_DEBUG="1")
    q = subprocess.run(
        [sys.executable, script, "check", str(MECH / "fourbar.yaml")],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert q.returncode == 4 and "Traceback" in q.stderr and "read_ground" in q.stderr


def test_4_in_process(monkeypatch, tmp_path):
    import mechsolve.model.parse as parse

    def broken(*args, **kwargs):
        raise ValueError("injected")

    monkeypatch.setattr(parse, "read_sweep", broken)
    r = CliRunner().invoke(main, ["check", str(MECH / "fourbar.yaml")])
    assert r.exit_code == 4 and "This is a bug in mechsolve" in r.output


def _mutations() -> list[tuple[str, str]]:
    """The four-bar example with each line in turn deleted, or its value replaced by
    something of the wrong kind: files with genuine mistakes (or none)."""
    lines = (MECH / "fourbar.yaml").read_text().splitlines()
    out = []
    for i, line in enumerate(lines):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        out.append((f"delete line {i + 1}", "\n".join(lines[:i] + lines[i + 1 :])))
        if ":" in line:
            key, _ = line.split(":", 1)
            for bad in ("[]", "-1", "x y z", "{a: 1}"):
                changed = f"{key}: {bad}"
                out.append(
                    (f"line {i + 1} = {bad}", "\n".join(lines[:i] + [changed] + lines[i + 1 :]))
                )
    return out


def test_input_errors_are_never_bugs(tmp_path):
    """Every file of the bad-input corpus, and every mutation of an example, ends in a
    message with exit 0 to 3: an exception the input layer lets through is a failure."""
    files = sorted(BAD_INPUTS.glob("*.yaml"))
    assert len(files) > 20
    texts = [(f.name, f.read_bytes()) for f in files]
    texts += [(name, text.encode()) for name, text in _mutations()]
    bugs = []
    for name, data in texts:
        f = tmp_path / "m.yaml"
        f.write_bytes(data)
        r = CliRunner().invoke(main, ["check", str(f)])
        if r.exit_code not in (0, 1, 2, 3) or "internal error" in r.output:
            bugs.append(f"{name}: exit {r.exit_code}: {r.output.strip()[-300:]}")
    assert not bugs, "\n".join(bugs)


# --- 130 --------------------------------------------------------------------------------


def test_130_ctrl_c_during_a_streamed_run(tmp_path):
    """Ctrl-C (SIGINT) as the SIGTERM test does it (tests/test_cli.py): exit 130, the
    partial CSV removed, no traceback."""
    out = tmp_path / "out"
    p = subprocess.Popen(
        [sys.executable, "-m", "mechsolve", "run", str(MECH / "fourbar.yaml")]
        + ["--step", "0.0002 deg", "--no-plots", "-o", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # a background job may inherit SIGINT ignored; a terminal's Ctrl-C is not
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 60
    while not list(out.glob(".results.csv.*.part")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert list(out.glob(".results.csv.*.part")), "the streamed CSV was never started"
    p.send_signal(signal.SIGINT)
    stdout, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err + stdout
    assert list(out.iterdir()) == []
