"""``mechsolve bench --quick`` runs every case, so that the benchmarks cannot rot.

Nothing here asserts a timing: only that each case runs, prints its table and its final
line, that the errors it reports against its references are at rounding level, and that
the optional peers are skipped cleanly when they are not installed.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

CASES = [
    "fourbar-kinematics",
    "crane-kinematics",
    "newton-groups",
    "fourbar-kinetostatics",
    "crane-kinetostatics",
    "startup-dynamics",
    "dynamics-work-precision",
    "chain-growth",
    "positions-growth",
    "stream",
    "startup",
    "study",
    "peers",
]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    png = tmp_path_factory.mktemp("bench") / "wp.png"
    out = subprocess.run(
        [sys.executable, "-m", "mechsolve", "bench", "--quick", "--plot", str(png)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    return out, png


def _section(text: str, name: str) -> str:
    m = re.search(rf"^== {re.escape(name)}:.*?(?=^== |\Z)", text, re.S | re.M)
    assert m, f"no section {name!r} in:\n{text}"
    return m.group(0)


def test_every_case_runs(quick):
    out, png = quick
    assert out.returncode == 0, out.stderr
    assert "Traceback" not in out.stdout + out.stderr
    for name in CASES:
        _section(out.stdout, name)
    assert png.exists() and png.stat().st_size > 10_000


@pytest.mark.parametrize(
    "name, lines",
    [
        ("fourbar-kinematics", ["ratio mechsolve (whole call) / closed form (textbook):"]),
        ("crane-kinematics", ["ratio mechsolve (whole call) / closed form:"]),
        ("fourbar-kinetostatics", ["ratio mechsolve (whole call) / free bodies by hand:"]),
        ("crane-kinetostatics", ["ratio mechsolve (whole call) / free bodies by hand:"]),
        ("startup-dynamics", ["ratio mechsolve simulate / by hand:"]),
        ("dynamics-work-precision", ["fastest to an error under 1e-6:"]),
        ("chain-growth", ["fitted exponent of time against N:"]),
        ("positions-growth", ["fitted exponent of time against the number of positions:"]),
        ("stream", ["peak resident memory:"]),
        ("startup", ["targets:"]),
        ("newton-groups", ["ratio auto / lean by hand (triad):"]),
        (
            "study",
            [
                "pool of 2 / 1 process: speed-up",
                "ratio batch of parsed designs / closed form, with forces:",
                "ratio batch from the study's values / closed form, with forces:",
                "ratio batch from the study's values / closed form, kinematics only:",
                "separate solves / batch:",
            ],
        ),
    ],
)
def test_case_prints_its_final_line(quick, name, lines):
    sec = _section(quick[0].stdout, name)
    for line in lines:
        assert line in sec
        m = re.search(re.escape(line) + r"\s*([0-9.]+)", sec)
        if m:
            assert float(m.group(1)) > 0


@pytest.mark.parametrize(
    "name",
    [
        "fourbar-kinematics",
        "crane-kinematics",
        "fourbar-kinetostatics",
        "crane-kinetostatics",
        "study",
    ],
)
def test_reported_errors_are_at_rounding_level(quick, name):
    """Every error column of the mechsolve rows (and of the second hand-written form)."""
    sec = _section(quick[0].stdout, name)
    errors = []
    for row in sec.splitlines():
        if row.strip().startswith(("mechsolve", "closed form by hand, vector")):
            errors += [float(x) for x in re.findall(r"\d\.\de[+-]\d\d", row)]
    assert errors, sec
    assert max(errors) < 1e-9, sec


def test_streamed_sweep_writes_every_row(quick):
    sec = _section(quick[0].stdout, "stream")
    m = re.search(r"(\d+) rows of (\d+); peak resident memory (\d+) MB", sec)
    assert m, sec
    assert m.group(1) == m.group(2)


def test_missing_peers_are_skipped_cleanly(monkeypatch):
    """Without pylinkage and exudyn (imports made to fail here, so that the test runs
    whether they are installed or not) the peers case says so and skips them."""
    import sys

    import mechsolve_bench as bench

    monkeypatch.setitem(sys.modules, "pylinkage", None)  # import raises ImportError
    monkeypatch.setitem(sys.modules, "exudyn", None)
    case = bench.case_peers(40)
    text = "\n".join(case.lines)
    assert "pylinkage: not installed" in text and "exudyn: not installed" in text


def test_bench_data_is_package_data(tmp_path, monkeypatch):
    """The mechanisms the bench loads come from the package (importlib.resources), not
    from a mechanisms/ folder beside the current directory or the repository."""
    from importlib import resources

    import mechsolve_bench as bench

    data = resources.files("mechsolve_bench") / "data"
    assert {"crane.yaml", "fourbar.yaml"} <= {p.name for p in data.iterdir()}
    monkeypatch.chdir(tmp_path)  # no mechanisms/ here
    mech = bench._crane_mech(36, masses=True)
    assert mech.name and "K" in mech.outputs.points and len(mech.links) >= 3
    src = Path(bench.__file__).read_text()
    assert '"mechanisms"' not in src and "parents[2]" not in src


@pytest.mark.parametrize("name", ["crane.yaml", "fourbar.yaml", "motor-linkage.yaml"])
def test_bench_data_matches_the_examples(name):
    """The bench's copies are the examples of mechanisms/ (update both together)."""
    import mechsolve_bench as bench

    ours = bench.case_file(name).read_text(encoding="utf-8")
    assert ours == (ROOT / "mechanisms" / name).read_text(encoding="utf-8"), (
        f"mechsolve_bench/data/{name} differs from mechanisms/{name}: copy it over"
    )


def test_installed_package_benchmarks_the_crane(tmp_path):
    """Lay out the package as a wheel or ``pip install .`` would (setuptools' build_py,
    which copies the packages and their declared package data; run on a copy of the
    sources so that the working tree stays clean), then run the crane case from that
    copy, in a folder without mechanisms/: it must not be skipped."""
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    for pkg in ("mechsolve", "mechsolve_bench"):  # the solver and the benchmarks beside it
        shutil.copytree(ROOT / pkg, src / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    site = tmp_path / "site"
    subprocess.run(
        [sys.executable, "-c", "import setuptools; setuptools.setup()", "-q", "build_py"]
        + ["--build-lib", str(site)],
        cwd=src,
        check=True,
        capture_output=True,
        timeout=300,
    )
    assert (site / "mechsolve_bench" / "data" / "crane.yaml").is_file()
    assert not (site / "mechsolve" / "bench").exists()  # the solver package holds no bench
    run_dir = tmp_path / "elsewhere"
    run_dir.mkdir()
    env = dict(os.environ, PYTHONPATH=str(site))
    p = subprocess.run(
        [
            sys.executable,
            "-c",
            "import mechsolve, mechsolve_bench, sys; print(mechsolve.__file__); "
            "print(mechsolve_bench.__file__); "
            "from mechsolve.cli.main import main; sys.exit(main())",
        ]
        + ["bench", "--quick", "--case", "crane-kinematics"],
        capture_output=True,
        text=True,
        cwd=run_dir,
        env=env,
        timeout=600,
    )
    assert p.returncode == 0, p.stderr
    # the installed copies ran, the solver's and the bench's
    assert p.stdout.splitlines()[0].startswith(str(site))
    assert p.stdout.splitlines()[1].startswith(str(site))
    assert "skipped" not in p.stdout
    assert "ratio mechsolve (whole call) / closed form:" in _section(p.stdout, "crane-kinematics")


# --- exudyn's simulation of seed 004's start-up --------------------------------------------

needs_exudyn = pytest.mark.skipif(
    importlib.util.find_spec("exudyn") is None, reason="exudyn is not installed"
)

# seed 004 (problems.md): max omega printed for RK4 at h = 2 ms, and RK4 at h/4 (0.5 ms),
# which is within 0.005 rad/s of the converged value (RK4's error falls as h^4)
SEED004_MAX_OMEGA = 69.3093
SEED004_MAX_OMEGA_FINE = 69.385


@pytest.fixture(scope="module")
def motor_linkage():
    import mechsolve_bench as bench

    return bench.load_case("motor-linkage.yaml")


@needs_exudyn
def test_exudyn_seed004_agrees_on_max_omega(motor_linkage):
    """exudyn's multibody model of the same machine (bodies, joints, motor, damper and
    gravity translated from the YAML model) reaches the seed's max omega up to its
    second-order integrator's error, and that difference shrinks with the step as h^2:
    a model mismatch (a wrong mass, inertia, load or joint) would not shrink."""
    from mechsolve_bench import peers

    coarse = peers.exudyn_seed004(motor_linkage, repeats=1)
    fine = peers.exudyn_seed004(motor_linkage, h=0.0005, repeats=1)
    assert coarse is not None and "error" not in coarse, coarse
    assert fine is not None and "error" not in fine, fine
    assert coarse["steps"] == 1100 and len(coarse["omega"]) == 1101
    # h = 2 ms: generalized-alpha's error is 1.3 % here (RK4's 0.1 %)
    assert coarse["max_omega"] == pytest.approx(SEED004_MAX_OMEGA, rel=0.015)
    # h = 0.5 ms: within 0.15 % of the converged value, and at least 8 times closer than
    # at 2 ms (second order: 16)
    err_coarse = abs(coarse["max_omega"] - SEED004_MAX_OMEGA_FINE)
    err_fine = abs(fine["max_omega"] - SEED004_MAX_OMEGA_FINE)
    assert err_fine < 1.5e-3 * SEED004_MAX_OMEGA_FINE
    assert err_fine < err_coarse / 8
    assert coarse["omega"][0] == 0.0 and coarse["seconds"] > 0


@needs_exudyn
def test_exudyn_seed004_user_function_motor_law(motor_linkage):
    """The motor law M0 - nu0 omega evaluated by a Python load user function at the
    crank's angular velocity gives the same motion as exudyn's compiled torque plus
    rotational damper (and the slider's damper both ways)."""
    from mechsolve_bench import peers

    a = peers.exudyn_seed004(motor_linkage, loads="native", repeats=1)
    b = peers.exudyn_seed004(motor_linkage, loads="user functions", repeats=1)
    assert "error" not in a and "error" not in b, (a, b)
    assert max(abs(a["omega"] - b["omega"])) < 1e-5  # rad/s, Newton's tolerance


@needs_exudyn
def test_exudyn_seed004_reports_errors_as_dicts(motor_linkage):
    import copy

    from mechsolve_bench import peers

    mech = copy.deepcopy(motor_linkage)
    mech.motor.kind = "table"
    out = peers.exudyn_seed004(mech, loads="native", repeats=1)
    assert "linear motor" in out["error"]
    assert "error" in peers.exudyn_seed004(motor_linkage, h=-1.0, repeats=1)


def test_exudyn_seed004_without_exudyn(monkeypatch, motor_linkage):
    from mechsolve_bench import peers

    monkeypatch.setattr(peers, "_import", lambda name: None)
    assert peers.exudyn_seed004(motor_linkage) is None


@needs_exudyn
def test_startup_case_compares_exudyn(quick):
    sec = _section(quick[0].stdout, "startup-dynamics")
    m = re.search(r"ratio exudyn \(h = 2 ms, compiled loads\) / mechsolve simulate: ([0-9.]+)", sec)
    assert m and float(m.group(1)) > 0, sec
    rows = [r for r in sec.splitlines() if r.strip().startswith("exudyn")]
    assert len(rows) == 3, sec
    err = float(re.search(r"\d\.\de[+-]\d\d", rows[0]).group(0))
    assert err < 0.015, sec
