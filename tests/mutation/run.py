"""Mutation testing of the suite (not run by CI): a seeded sample of cosmic-ray's mutants.

usage::

    pip install cosmic-ray
    git worktree add /tmp/mut HEAD          # never in a tree others use: it edits sources
    cd /tmp/mut && cosmic-ray init tests/mutation/cr.toml session.sqlite
    python tests/mutation/run.py /tmp/mut out.jsonl --db session.sqlite

Each sampled mutant (10 per module, seed ``"11:<module>"``; the bitwise and shift
replacements left out, since on floats they raise TypeError wherever they run) is applied
with cosmic-ray's ``use_mutation`` (which restores the file) and tested with only its
module's test files (``-x``, a timeout); one JSON line per mutant goes to ``out.jsonl``.
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
}
EXTRA = ["tests/test_mutants.py"]
TIMEOUT = 600  # s per mutant


def sample(db: str) -> list[tuple]:
    """The seeded sample of mutation specs (module, operator, occurrence, position)."""
    c = sqlite3.connect(db)
    rows = c.execute(
        "select module_path, operator_name, occurrence, start_pos_row, start_pos_col,"
        " end_pos_row, end_pos_col from mutation_specs"
    ).fetchall()
    out = []
    for mod in SEL:
        cand = sorted(r for r in rows if r[0] == mod and not r[1].endswith(SKIP_OPS))
        pick = random.Random(f"{SEED}:{mod}").sample(cand, min(PER_MODULE, len(cand)))
        out += sorted(pick, key=lambda r: (r[3], r[4], r[1]))
    return out


def main() -> None:
    import cosmic_ray.plugins
    from cosmic_ray.mutating import use_mutation

    wt, outp = sys.argv[1], sys.argv[2]
    db = sys.argv[sys.argv.index("--db") + 1] if "--db" in sys.argv else "session.sqlite"
    env = dict(os.environ, PYTHONPATH=wt, PYTHONDONTWRITEBYTECODE="1")
    done = set()
    if Path(outp).exists():
        done = {json.loads(ln)["id"] for ln in open(outp)}
    for mod, op, occ, r0, c0, _, _ in sample(db):
        mid = f"{mod}:{r0}:{c0}:{op}:{occ}"
        if mid in done:
            continue
        tests = [t for t in EXTRA + SEL[mod] if (Path(wt) / t).exists()]
        cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests]
        operator = cosmic_ray.plugins.get_operator(op)()
        t0 = time.time()
        with use_mutation(Path(wt) / mod, operator, occ) as (orig, mutated):
            if mutated is None:
                res, rc = "no-mutation", None
            else:
                try:
                    p = subprocess.run(
                        cmd, cwd=wt, env=env, capture_output=True, text=True, timeout=TIMEOUT
                    )
                    rc = p.returncode
                    res = "survived" if rc == 0 else "killed"
                except subprocess.TimeoutExpired:
                    res, rc = "killed-timeout", None
            line = mutated.splitlines()[r0 - 1].strip() if mutated else ""
            rec = dict(
                id=mid,
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
