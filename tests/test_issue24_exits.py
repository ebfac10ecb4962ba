"""Issue 24, section 4: one exit-code rule for every command, run in real processes.

0 done (a partial result too, with a ``warning:`` line on stderr), 2 bad input (the file,
the command line, a mechanism that cannot be assembled where it must be, an output that
cannot be written), 4 internal error, 5 a design check failed (requirements in run,
report and sweep; a cam's allowances; a flywheel whose check misses its delta), 130
interrupted. No command may exit 1 or 3, and none may print a traceback. The expected
code of each case follows from the rule and the input alone (a file whose requirement is
28.88 deg >= 30 deg must fail it: the four-bar's closed-form transmission angle; a loop
with b + c < d - a cannot close), never from an earlier run.
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

from conftest import MECH

ROOT = Path(__file__).resolve().parent.parent
DATA = Path(__file__).parent / "data"
STUDY = DATA / "study_fourbar.yaml"  # requirements: transmission >= 25 deg, swing >= 55 deg


def _env() -> dict[str, str]:
    """The environment of a child: no MECHSOLVE_DEBUG, and this checkout's package first
    (a script run from a temporary folder would otherwise import an installed copy)."""
    env = {k: v for k, v in os.environ.items() if k != "MECHSOLVE_DEBUG"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


def mechsolve(*args, script: str | None = None, timeout: float = 300):
    """The command line in a new Python process (or ``script``, which injects a fault
    first); no traceback may reach the user, whatever the code."""
    cmd = [sys.executable, "-m", "mechsolve"] if script is None else [sys.executable, script]
    p = subprocess.run(
        cmd + [str(a) for a in args], capture_output=True, text=True, timeout=timeout, env=_env()
    )
    assert "Traceback" not in p.stdout + p.stderr, p.stderr
    return p


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


def write(tmp_path: Path, name: str, text: str) -> Path:
    f = tmp_path / name
    f.write_text(text)
    return f


@pytest.fixture
def short(tmp_path) -> Path:
    """b + c = 0.5 m < d - a = 0.8 m: the loop closes nowhere."""
    return write(tmp_path, "short.yaml", fourbar(0.2, 0.25, 0.25, 1.0))


@pytest.fixture
def nongrashof(tmp_path) -> Path:
    """a + d = 1.6 m > b + c = 1.1 m: no closure around 180 deg (a partial sweep)."""
    return write(tmp_path, "ng.yaml", fourbar(0.6, 0.6, 0.5, 1.0, "assembly: [B left of A -> O4]"))


# --- run ---------------------------------------------------------------------------------


def test_run_0_2_5(tmp_path, short, nongrashof):
    assert (
        mechsolve("run", MECH / "fourbar.yaml", "-o", tmp_path / "a", "--no-plots").returncode == 0
    )
    # cannot be assembled at the start: bad input (2), naming the driver angle and the loop
    p = mechsolve("run", short, "-o", tmp_path / "b", "--no-plots")
    assert p.returncode == 2, p.stdout + p.stderr
    assert re.search(r"cannot assemble at driver angle 0°: loop B .* cannot close", p.stderr)
    assert "|AO4| = 0.8 m > 0.25 m + 0.25 m" in p.stderr
    assert not (tmp_path / "b" / "results.csv").exists()
    # a bad file: 2
    bad = write(tmp_path, "bad.yaml", fourbar(0.2, 0.25, 0.25, 1.0).replace("O4: [1.0", "O4: [x"))
    assert mechsolve("run", bad, "-o", tmp_path / "c").returncode == 2
    # the seed's requirement: min transmission angle 28.88 deg (closed form) >= 30 deg fails
    p = mechsolve("run", MECH / "studies" / "fourbar-study.yaml", "-o", tmp_path / "d", "-q")
    assert p.returncode == 5, p.stdout + p.stderr
    assert "FAIL  transmission" in p.stdout


def test_run_partial_result_is_0_with_a_warning_even_quiet(tmp_path, nongrashof):
    """Positions that cannot close are a finding of the run: done (0), the rows written,
    and one warning on stderr that -q does not hide."""
    p = mechsolve("run", nongrashof, "-o", tmp_path / "o", "--no-plots", "-q")
    assert p.returncode == 0, p.stdout + p.stderr
    assert p.stdout == ""
    assert p.stderr.startswith("warning: the results are incomplete")
    rows = (tmp_path / "o" / "results.csv").read_text().splitlines()
    assert any("unassemblable: " in r for r in rows)


def test_run_4_injected_bug(tmp_path):
    script = write(
        tmp_path,
        "bug.py",
        "import sys\nimport mechsolve.model.parse as parse\n"
        "def read_ground(*a, **k):\n    raise ValueError('injected')\n"
        "parse.read_ground = read_ground\nfrom mechsolve.cli.main import main\nsys.exit(main())\n",
    )
    for cmd in (
        ["run", MECH / "fourbar.yaml", "-o", tmp_path / "o"],
        ["check", MECH / "fourbar.yaml"],
    ):
        p = mechsolve(*cmd, script=str(script))
        assert p.returncode == 4, p.stdout + p.stderr
        assert "internal error: ValueError: injected" in p.stderr


# --- check, polygons, animate, schema, synth ---------------------------------------------


def test_check_0_2(short):
    assert mechsolve("check", MECH / "fourbar.yaml").returncode == 0
    p = mechsolve("check", short)
    assert p.returncode == 2 and "cannot assemble at driver angle 0°" in p.stderr


def test_polygons_0_2(tmp_path, short):
    p = mechsolve("polygons", MECH / "fourbar.yaml", "--at", "3", "-o", tmp_path / "a")
    assert p.returncode == 0, p.stderr
    assert mechsolve("polygons", short, "--at", "3", "-o", tmp_path / "b").returncode == 2


def test_animate_0_2_and_a_partial_animation_is_0(tmp_path, nongrashof):
    out = tmp_path / "a.gif"
    p = mechsolve("animate", MECH / "fourbar.yaml", "-o", out, "--frames", "4", "--size", "64x64")
    assert p.returncode == 0, p.stderr
    p = mechsolve("animate", nongrashof, "-o", tmp_path / "b.gif", "--frames", "8", "-q")
    assert p.returncode == 0, p.stderr
    assert p.stderr.startswith("warning: the mechanism cannot close in")
    assert mechsolve("animate", MECH / "fourbar.yaml", "-o", tmp_path / "x.avi").returncode == 2


def test_bench_2():
    """A case bench does not have is a mistake on the command line (its 0 is in
    tests/test_bench.py, which runs the cases)."""
    p = mechsolve("bench", "--case", "no-such-case")
    assert p.returncode == 2 and "no-such-case" in p.stderr


def test_schema_and_synth_0_2(tmp_path):
    assert mechsolve("schema", "-o", tmp_path / "s.json").returncode == 0
    assert mechsolve("schema", "-o", tmp_path / "no" / "s.json").returncode == 2
    synth = ROOT / "mechanisms" / "synth" / "crane-crank-rocker.yaml"
    assert mechsolve("synth", synth, "-q").returncode == 0
    assert mechsolve("synth", synth, "--pick", "smallest", "--solution", "1").returncode == 2


# --- simulate, flywheel ------------------------------------------------------------------

NON_GRASHOF_MOTOR = """
ground: {O2: [0, 0], O4: [1.0, 0]}
links:
  crank: {points: {O2: [0, 0], A: [0.6, 0]}, mass: 1 kg, uniform_bar: [O2, A]}
  coupler: {points: {A: [0, 0], B: [0.6, 0]}, mass: 1 kg, uniform_bar: [A, B]}
  rocker: {points: {O4: [0, 0], B: [0.5, 0]}, mass: 1 kg, uniform_bar: [O4, B]}
joints: {O2: [ground, crank], A: [crank, coupler], B: [coupler, rocker], O4: [ground, rocker]}
assembly: ["B left of A -> O4"]
driver: {joint: O2, start: 0 deg}
gravity: off
motor: {stall: 5 N m, slope: 0 N m s}
simulate: {duration: 2 s, step: 0.01 s, method: rk4, from: rest}
"""


def test_simulate_0_2_and_stopped_early_is_0(tmp_path):
    p = mechsolve("simulate", MECH / "motor-linkage.yaml", "-o", tmp_path / "a", "--no-plots")
    assert p.returncode == 0, p.stderr
    # the motion reaches 82.82 deg, where the loop stops closing (cos = 0.125): done, warned
    f = write(tmp_path, "ng.yaml", NON_GRASHOF_MOTOR)
    p = mechsolve("simulate", f, "-o", tmp_path / "b", "--no-plots", "-q")
    assert p.returncode == 0, p.stderr
    assert p.stderr.startswith("warning: the motion stopped early, at t = ")
    p = mechsolve("simulate", MECH / "fourbar.yaml", "-o", tmp_path / "c")  # no motor
    assert p.returncode == 2, p.stderr


def test_flywheel_0_2_5(tmp_path):
    seed = MECH / "motor-linkage.yaml"
    p = mechsolve("flywheel", seed, "--delta", "0.05", "-o", tmp_path / "a")
    assert p.returncode == 0, p.stdout + p.stderr
    assert mechsolve("flywheel", seed, "--delta", "two", "-o", tmp_path / "b").returncode == 2
    # a stiff motor (3000 N m s) with the same steady speed damps the fluctuation itself:
    # the energy method's flywheel, checked by simulation, misses the delta asked for
    slope = 3000
    text = seed.read_text().replace(
        "motor: {stall: 50 N m, slope: 1.25 N m s}",
        f"motor: {{stall: {0.9611 + slope * 39.2304:.6f} N m, slope: {slope} N m s}}",
    )
    p = mechsolve(
        "flywheel", write(tmp_path, "stiff.yaml", text), "--delta", "0.05", "-o", tmp_path / "c"
    )
    assert p.returncode == 5, p.stdout + p.stderr
    assert "misses the asked delta" in p.stdout


# --- cam ---------------------------------------------------------------------------------


def test_cam_0_2_5(tmp_path):
    seed = ROOT / "mechanisms" / "shaper-cam.yaml"
    # the seed's rise exceeds the common data set's 40 deg pressure-angle allowance
    p = mechsolve("cam", seed, "-o", tmp_path / "a", "--no-plots", "--no-dxf")
    assert p.returncode == 5, p.stdout + p.stderr
    assert "THE DESIGN FAILS" in p.stdout
    p = mechsolve(
        "cam", seed, "-o", tmp_path / "b", "--no-plots", "--no-dxf", "--variant", "as-seed"
    )
    assert p.returncode == 0, p.stdout + p.stderr
    p = mechsolve("cam", seed, "-o", tmp_path / "c", "--variant", "no-such")
    assert p.returncode == 2, p.stdout + p.stderr


# --- report ------------------------------------------------------------------------------


def test_report_0_5_for_requirements_and_for_a_cam(tmp_path):
    args = ("--frames", "2", "-q")
    p = mechsolve("report", MECH / "fourbar.yaml", "-o", tmp_path / "a.html", *args)
    assert p.returncode == 0, p.stderr
    p = mechsolve(
        "report", MECH / "studies" / "fourbar-study.yaml", "-o", tmp_path / "b.html", *args
    )
    assert p.returncode == 5, p.stderr
    assert (tmp_path / "b.html").stat().st_size > 0  # written all the same
    # a cam that exceeds its allowance is a failed design check in the report too
    p = mechsolve(
        "report", ROOT / "mechanisms" / "shaper-cam.yaml", "-o", tmp_path / "c.html", *args
    )
    assert p.returncode == 5, p.stderr
    p = mechsolve("report", MECH / "fourbar.yaml", "-o", tmp_path / "no" / "d.html", *args)
    assert p.returncode == 2, p.stderr


# --- sweep -------------------------------------------------------------------------------


def test_sweep_0_2_5(tmp_path):
    """5 when the file has requirements and no design meets them all (a study's job is to
    find designs); 0 when one does, even if others fail or are invalid (warned)."""
    common = ("-j", "1", "--no-plots", "-q", "--step", "10 deg")
    p = mechsolve("sweep", STUDY, "-o", tmp_path / "a", *common)
    assert p.returncode == 0, p.stderr
    strict = write(
        tmp_path,
        "strict.yaml",
        STUDY.read_text().replace("rocker.swing >= 55 deg", "rocker.swing >= 120 deg"),
    )
    p = mechsolve("sweep", strict, "-o", tmp_path / "b", *common)
    assert p.returncode == 5, p.stderr
    p = mechsolve(
        "sweep", STUDY, "-o", tmp_path / "c", *common, "-p", "links.coupler.mass=0.2, -1 kg"
    )
    assert p.returncode == 0, p.stderr
    assert p.stderr.startswith("warning: ") and "their rows say why" in p.stderr
    p = mechsolve("sweep", STUDY, "-o", tmp_path / "d", *common, "-p", "no.such=1, 2")
    assert p.returncode == 2, p.stderr


# --- 130 ---------------------------------------------------------------------------------


def _interrupt(args: list, ready) -> subprocess.CompletedProcess:
    p = subprocess.Popen(
        [sys.executable, "-m", "mechsolve", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 90
    while not ready() and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.05)
    assert p.poll() is None, "the command ended before it could be interrupted"
    time.sleep(0.3)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    return subprocess.CompletedProcess(p.args, p.returncode, out, err)


def test_simulate_130(tmp_path):
    text = (MECH / "motor-linkage.yaml").read_text()
    text = text.replace("duration: 2.2 s, step: 0.002 s", "duration: 200 s, step: 0.001 s")
    f = write(tmp_path, "long.yaml", text)
    out = tmp_path / "o"
    p = _interrupt(["simulate", f, "-o", out, "--max-steps", "300000"], out.exists)
    assert p.returncode == 130, p.stderr
    assert "interrupted" in p.stderr and "Traceback" not in p.stderr + p.stdout
    assert not list(out.glob("*.csv"))


def test_animate_130(tmp_path):
    out = tmp_path / "a.gif"
    marker = tmp_path / "started"
    # the frames are solved after the file is loaded: the marker file says it has been
    script = write(
        tmp_path,
        "go.py",
        "import sys, pathlib\nimport mechsolve.report.animate as a\nf = a.solve_frames\n"
        f"def s(*x, **k):\n    pathlib.Path({str(marker)!r}).touch()\n    return f(*x, **k)\n"
        "a.solve_frames = s\nfrom mechsolve.cli.main import main\nsys.exit(main())\n",
    )
    p = subprocess.Popen(
        [sys.executable, str(script), "animate", str(MECH / "fourbar.yaml"), "-o", str(out),
         "--frames", "20000"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    deadline = time.monotonic() + 90
    while not marker.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)
    assert p.poll() is None, "animate ended before it could be interrupted"
    p.send_signal(signal.SIGINT)
    stdout, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err + stdout
    assert not out.exists()


def test_help_states_the_rule_once():
    """`mechsolve --help` lists the codes; a command's --help points at them in one line."""
    p = mechsolve("--help")
    assert p.returncode == 0
    for code in ("0 ", "2 ", "4 ", "5 ", "130", "141"):
        assert re.search(rf"^\s+{code}", p.stdout, re.M), code
    assert not re.search(r"^\s+[13]\s", p.stdout, re.M)
    for cmd in ("run", "cam", "sweep", "report", "flywheel", "simulate", "check", "animate"):
        q = mechsolve(cmd, "--help")
        tail = q.stdout[q.stdout.index("Exit codes") :]
        assert len(tail.strip().splitlines()) <= 4, (cmd, tail)
        # only the commands that check a design can fail one (issue 29: no code a command
        # cannot give; tests/test_issue29_docs.py checks every command)
        can_fail = cmd not in ("simulate", "check", "animate")
        assert ("5 a design check failed" in " ".join(tail.split())) == can_fail, cmd


def test_one_wrapper_no_command_catches_errors_itself():
    """The mapping of errors to codes lives in mechsolve/cli/kit.py alone: no command
    module has a handler for Exception, KeyboardInterrupt or OSError of its own, nor a
    literal exit code, and every command is a clikit.Command."""
    import ast

    import click

    from mechsolve.cli import kit as clikit
    from mechsolve.cli.main import main

    cli = ROOT / "mechsolve" / "cli"
    files = [cli / "main.py", *sorted((cli / "commands").glob("*.py"))]
    for f in files:
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.ExceptHandler):
                names = (
                    {n.id for n in ast.walk(node.type) if isinstance(n, ast.Name)}
                    if node.type
                    else {"*"}
                )
                assert not names & {
                    "Exception",
                    "BaseException",
                    "KeyboardInterrupt",
                    "OSError",
                    "*",
                }, f"{f.name}:{node.lineno}: a handler of its own"
            if isinstance(node, ast.Call) and ast.unparse(node.func) == "sys.exit":
                assert not (node.args and isinstance(node.args[0], ast.Constant)), (
                    f"{f.name}:{node.lineno}: a literal exit code"
                )
    for name, cmd in main.commands.items():
        assert isinstance(cmd, clikit.Command), name
        assert not isinstance(cmd, click.Group), name
