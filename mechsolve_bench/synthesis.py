"""The ``synthesis`` case of ``mechsolve bench``: path generation on the 18 points of a
closed curve with prescribed timing (Kunjur & Krishnamurty 1997; the problem file is a
copy of mechanisms/synth/path-18-points.yaml), solved by ``mechsolve synth``'s
differential evolution (each generation one batch of the closed form) and least-squares
polish, for a few seeds.

Each row gives the whole synthesis' wall time, the sum of squared distances reached
(m^2), the generations and designs evaluated (batches times the population), and the
time at which the search's best first came within 1 % of that run's final objective (the
whole time when only the final polish got there). The peer, pyslvs's
differential evolution, is timed on the same case when it can be imported; otherwise the
case says why. No published best objective is quoted: none was at hand to check.
"""

from __future__ import annotations

import tempfile
import time
from importlib import resources
from pathlib import Path

FILES = ("path-18-points.yaml", "fourbar-free.yaml")


def _problem(folder: Path) -> Path:
    data = resources.files("mechsolve_bench") / "data"
    for name in FILES:
        (folder / name).write_text((data / name).read_text(encoding="utf-8"), encoding="utf-8")
    return folder / FILES[0]


def _one(problem: Path, seed: int, max_iter: int | None):
    """Solve once; the row's figures: seconds, objective, generations, designs evaluated
    (batches times the population) and the time to within 1 % of the final objective."""
    import yaml

    from mechsolve.analyses.synth.problem import solve_problem

    if max_iter is not None:
        data = yaml.safe_load(problem.read_text())
        data["path"]["optimise"]["max_iter"] = max_iter
        problem = problem.with_name(f"budget-{max_iter}.yaml")
        problem.write_text(yaml.safe_dump(data, sort_keys=False))
    marks: list[tuple[float, float]] = []
    t0 = time.perf_counter()

    def progress(generation: int, best: float) -> None:
        marks.append((time.perf_counter() - t0, best))

    out = solve_problem(problem, seed=seed, progress=progress)
    seconds = time.perf_counter() - t0
    found = out.check["search"]
    f = float(out.chosen.extra["objective"])
    reach = next((t for t, b in marks if b <= 1.01 * f), seconds)
    designs = found.evaluations * len(found.population)
    return seconds, f, found.generations, designs, reach


def _peer_line() -> str:
    try:
        import pyslvs  # noqa: F401
    except ImportError:
        return (
            "peer pyslvs: not importable here (when this case was written, PyPI had pyslvs "
            "22.7.0 as a source distribution only, no wheel for Python 3.11, and its Cython "
            "sources failed to "
            "compile with the current Cython: pyslvs/bfgs.pyx, 'Too many members for const "
            "Point &'): no peer timing in this run, and no published evaluation count of "
            "its differential evolution on this case was at hand to compare with"
        )
    return (
        "peer pyslvs: importable, but this case does not pose the 18-point problem in "
        "pyslvs's own terms yet: no peer timing in this run"
    )


def case_synthesis(quick: bool):
    """The ``synthesis`` case (a :class:`mechsolve_bench.Case`)."""
    from mechsolve_bench import Case, Row

    case = Case(
        "synthesis",
        "path generation, 18 points on a closed curve with timing (Kunjur & Krishnamurty)",
    )
    seeds = (1,) if quick else (1, 2, 3)
    budget = 100 if quick else None
    with tempfile.TemporaryDirectory() as tmp:
        problem = _problem(Path(tmp))
        for seed in seeds:
            secs, f, gens, evals, reach = _one(problem, seed, budget)
            case.rows.append(
                Row(
                    f"mechsolve synth, seed {seed}" + (f", {budget} generations" if budget else ""),
                    secs,
                    {},
                    f"sum of squares {f:.6e} m^2; {gens} generations, {evals} designs evaluated; "
                    f"within 1 % of it after {reach:.2f} s",
                )
            )
    case.lines = [_peer_line()]
    return case
