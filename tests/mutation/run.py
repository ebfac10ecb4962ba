"""Mutation testing of the suite (not run by CI): a seeded sample of cosmic-ray's mutants.

usage::

    pip install cosmic-ray
    git worktree add /tmp/mut HEAD          # never in a tree others use: it edits sources
    cd /tmp/mut && cosmic-ray init tests/mutation/cr.toml session.sqlite
    python tests/mutation/run.py /tmp/mut out.jsonl --db session.sqlite

Each sampled mutant (10 per entry of ``SEL``, a module or a package, seed
``"11:<entry>"``; the bitwise and shift replacements left out, since on floats they raise
TypeError wherever they run) is applied with cosmic-ray's ``use_mutation`` (which restores
the file) and tested with only its entry's test files (``-x``, a timeout); one JSON line
per mutant goes to ``out.jsonl``. ``--only cam/,synth/`` runs the entries that contain
one of these strings, ``--per N`` samples N per entry, ``--timeout S`` bounds each
mutant's test run (a timed-out run counts as killed: the mutant made the tests hang).
"""

from __future__ import annotations

import json
import os
import random
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

SEED, PER_MODULE = 11, 10
SKIP_OPS = ("BitOr", "BitAnd", "BitXor", "LShift", "RShift")
SEL = {
    "mechsolve/groups/closed.py": [
        "tests/test_closed_form.py",
        "tests/test_seed_tables.py",
        "tests/test_moving_guides.py",
        "tests/test_branches.py",
        "tests/test_hard_cases.py",
    ],
    "mechsolve/solvers/forces.py": [
        "tests/test_forces.py",
        "tests/test_force_elements.py",
        "tests/test_moving_guides.py",
    ],
    # the loads and the work per cycle, split from forces.py (issue 24)
    "mechsolve/solvers/loads.py": [
        "tests/test_forces.py",
        "tests/test_force_elements.py",
        "tests/test_issue23_study.py",
    ],
    "mechsolve/solvers/work.py": ["tests/test_force_elements.py", "tests/test_issue23_study.py"],
    "mechsolve/results.py": [
        "tests/test_design_figures.py",
        "tests/test_api.py",
        "tests/test_cli.py",
    ],
    "mechsolve/limits.py": [
        "tests/test_design_figures.py",
        "tests/test_api.py",
        "tests/test_cli.py",
    ],
    "mechsolve/writers/csv.py": [
        "tests/test_csv_values.py",
        "tests/test_cli.py",
        "tests/test_stream.py",
    ],
    # issue 23: the design tools, the dynamics and the studies (packages are sampled as
    # one entry: 10 mutants over all their modules)
    "mechsolve/cam/": [
        "tests/test_cam_laws.py",
        "tests/test_cam_profile.py",
        "tests/test_cam_design.py",
        "tests/test_cam_cli.py",
        "tests/test_issue23_faults.py",
    ],
    "mechsolve/synth/": [
        "tests/test_synth.py",
        "tests/test_synth_cli.py",
        "tests/test_issue23_faults.py",
    ],
    "mechsolve/dynamics": ["tests/test_dynamics.py"],
    "mechsolve/flywheel.py": ["tests/test_dynamics.py", "tests/test_issue23_faults.py"],
    "mechsolve/requirements.py": [
        "tests/test_requirements.py",
        "tests/test_study.py",
        "tests/test_study_cli.py",
        "tests/test_issue23_faults.py",
    ],
    "mechsolve/study/": [
        "tests/test_study.py",
        "tests/test_study_cli.py",
        "tests/test_study_exec.py",
        "tests/test_issue23_faults.py",
    ],
    "mechsolve/polygons": ["tests/test_polygons.py", "tests/test_issue23_faults.py"],
}
EXTRA = ["tests/test_mutants.py"]
TIMEOUT = 600  # s per mutant


def _entry(path: str) -> str | None:
    """The entry of ``SEL`` a module belongs to (itself, or the package it is in)."""
    for key in SEL:
        if path == key or (key.endswith("/") and path.startswith(key)):
            return key
    return None


def sample(db: str, per: int = PER_MODULE, only: list[str] | None = None) -> list[tuple]:
    """The seeded sample of mutation specs (module, operator, occurrence, position), each
    with the entry of ``SEL`` it was drawn for."""
    c = sqlite3.connect(db)
    rows = c.execute(
        "select module_path, operator_name, occurrence, start_pos_row, start_pos_col,"
        " end_pos_row, end_pos_col from mutation_specs"
    ).fetchall()
    out = []
    for key in SEL:
        if only and not any(o in key for o in only):
            continue
        cand = sorted(r for r in rows if _entry(r[0]) == key and not r[1].endswith(SKIP_OPS))
        pick = random.Random(f"{SEED}:{key}").sample(cand, min(per, len(cand)))
        out += [(key, *r) for r in sorted(pick, key=lambda r: (r[0], r[3], r[4], r[1]))]
    return out


def _option(name: str, default: str | None) -> str | None:
    return sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default


def main() -> None:
    import cosmic_ray.plugins
    from cosmic_ray.mutating import use_mutation

    wt, outp = sys.argv[1], sys.argv[2]
    db = _option("--db", "session.sqlite")
    per = int(_option("--per", str(PER_MODULE)))
    only = _option("--only", None)
    timeout = float(_option("--timeout", str(TIMEOUT)))
    env = dict(os.environ, PYTHONPATH=wt, PYTHONDONTWRITEBYTECODE="1")
    done = set()
    if Path(outp).exists():
        done = {json.loads(ln)["id"] for ln in open(outp)}
    for key, mod, op, occ, r0, c0, _, _ in sample(db, per, only.split(",") if only else None):
        mid = f"{mod}:{r0}:{c0}:{op}:{occ}"
        if mid in done:
            continue
        tests = [t for t in EXTRA + SEL[key] if (Path(wt) / t).exists()]
        cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests]
        operator = cosmic_ray.plugins.get_operator(op)()
        t0 = time.time()
        with use_mutation(Path(wt) / mod, operator, occ) as (orig, mutated):
            if mutated is None:
                res, rc = "no-mutation", None
            else:
                try:
                    p = subprocess.run(
                        cmd, cwd=wt, env=env, capture_output=True, text=True, timeout=timeout
                    )
                    rc = p.returncode
                    res = "survived" if rc == 0 else "killed"
                except subprocess.TimeoutExpired:
                    res, rc = "killed-timeout", None
            line = mutated.splitlines()[r0 - 1].strip() if mutated else ""
            rec = dict(
                id=mid,
                entry=key,
                module=mod,
                op=op,
                result=res,
                rc=rc,
                secs=round(time.time() - t0, 1),
                orig_line=orig.splitlines()[r0 - 1].strip(),
                mut_line=line,
            )
        with open(outp, "a") as f:
            f.write(json.dumps(rec) + "\n")
        print(rec["id"], res, rec["secs"], flush=True)


if __name__ == "__main__":
    main()
