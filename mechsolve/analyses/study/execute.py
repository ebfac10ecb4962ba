"""Solve the designs of a study: in this process, on a local process pool, or on Dask.

Designs go out in chunks (a few tens at most), so that what each task costs to send and
to start is small beside the solving; every executor runs the same function on the same
designs, so the table does not depend on which one ran it. Rows come back as chunks
finish; Ctrl-C stops the study and keeps the rows already finished. A design's results
file that cannot be written (``--keep-results`` on a full disk) stops the study the same
way (:class:`ResultsNotWritten`): the rows solved are kept, the error is the file's.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import threading
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mechsolve.analyses.batch import solve_parsed
from mechsolve.analyses.study.designs import Study
from mechsolve.analyses.study.family import DesignFamily, solve_family
from mechsolve.analyses.study.figures import Row, design_row
from mechsolve.base.atomic import WriteFailed
from mechsolve.base.errors import AssemblyError, InputError, MechsolveError
from mechsolve.results.requirements import check_requirements, evaluate_figure
from mechsolve.results.run import solve as solve_sweep

# solve a study's designs as a design family where its parameters allow (False: parse
# every design, as before it; the benchmark's comparison)
FAMILY = True
SCHEDULER_TIMEOUT = 3.0  # seconds: a Dask scheduler that does not answer by then is reported


class ResultsNotWritten(WriteFailed):
    """A design's results file could not be written (a full disk, a quota, permissions):
    the study stops. ``rows`` are the rows finished before it in its chunk, that design's
    included (it was solved: its figures are right, only its file is missing)."""

    def __init__(self, path: str | os.PathLike, cause: OSError, rows=()) -> None:
        super().__init__(path, cause)
        self.rows = list(rows)

    def __reduce__(self):  # through a process pool or Dask, with its rows
        return (type(self), (self.filename, OSError(self.errno, self.strerror), self.rows))


def results_kept(rows: list[Row]) -> int:
    """How many of ``rows`` had their results file written (``--keep-results``): those
    solved (with their counts of positions) whose file did not fail."""
    return sum(
        "positions [-]" in r and not str(r.get("status", "")).startswith("failed") for r in rows
    )


def status_of(row: Row, res=None) -> str:
    """``ok``, or why the design's figures are blank: where it does not assemble (the
    first run of positions where a loop cannot close, with ``res``)."""
    n, solved = row.get("positions [-]"), row.get("solved [-]")
    if n is None:
        return "ok"
    zones = [
        e for e in getattr(getattr(res, "solution", None), "events", ()) if e.kind == "dead zone"
    ]
    if solved == n and zones:  # every sample closes, the motion between two does not
        e, fu = zones[0], res.analysis.format_u
        span = f"between {fu(e.edge_in)} and {fu(e.edge_out)}"
        if not (math.isfinite(e.edge_in) and math.isfinite(e.edge_out)):
            span = f"near {fu(e.u)}"
        return (
            f"not assemblable {span} ({e.group} cannot close there, a range between two "
            "samples): figures not computed"
        )
    if solved == n:
        return "ok"
    if solved == 0:
        return "not assemblable at any position"
    where = ""
    fails = getattr(res, "failures", None) if res is not None else None
    if fails:
        f = fails[0]
        an = res.analysis
        span = (
            an.format_u(f.u_first)
            if f.first == f.last
            else f"{an.format_u(f.u_first)} to {an.format_u(f.u_last)}"
        )
        more = f" and {len(fails) - 1} more run(s)" if len(fails) > 1 else ""
        where = f" ({f.group} does not close at {span}{more})"
    return f"not assemblable at {n - solved} of {n} positions{where}: figures not computed"


_DESIGN_FILE = re.compile(r"design-([0-9]{5,})\.csv")


def design_files(results_dir: str | Path) -> dict[str, tuple[int, int, int]]:
    """The designs' results files in ``results_dir`` (``design-00007.csv``): name ->
    (inode, size, modification time in ns). A file written again has a new inode (the
    atomic writer moves a new file onto the name), so two listings tell the files
    written in between (:func:`written_since`)."""
    out: dict[str, tuple[int, int, int]] = {}
    try:
        with os.scandir(results_dir) as it:
            for e in it:
                if _DESIGN_FILE.fullmatch(e.name):
                    try:
                        st = e.stat(follow_symlinks=False)
                    except OSError:
                        continue
                    out[e.name] = (st.st_ino, st.st_size, st.st_mtime_ns)
    except OSError:
        pass
    return out


def written_since(results_dir: str | Path, before: dict[str, tuple[int, int, int]]) -> list[Path]:
    """The designs' results files of ``results_dir`` written since it held ``before``
    (:func:`design_files`): those of the workers of a pool or a Dask cluster, whose
    writes this process did not make (the output folder's record lists them)."""
    now = design_files(results_dir)
    return [Path(results_dir) / n for n in sorted(now) if before.get(n) != now[n]]


def rowless(rows: list[Row], files: list[Path]) -> list[Path]:
    """Those of the designs' results ``files`` whose design has no row in ``rows``: the
    designs a worker finished after the study stopped (a full disk, Ctrl-C), before it
    was ended. Their results are whole; only their rows are missing."""
    have = {r.get("design [-]") for r in rows}
    out = []
    for p in files:
        m = _DESIGN_FILE.fullmatch(p.name)
        if m is not None and int(m.group(1)) not in have:
            out.append(p)
    return out


def _head(study: Study, k: int) -> Row:
    row: Row = {"design [-]": k}
    for p, x in zip(study.params, study.values(k)):
        row[p.header] = x
    return row


def _fill(study: Study, row: Row, mech, solved, results_dir: str | None) -> Row:
    """Complete design ``row``: solve it (``solved()`` gives its Results, or raises what
    ``mechsolve.solve`` raises) and add its figures, or say why there are none."""
    import numpy as np

    figures = list(study.figures)
    if study.best is not None and study.best[1] not in figures:
        figures.append(study.best[1])
    k = row["design [-]"]
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = solved()
            fig = design_row(res, mech, figures)
    except AssemblyError as exc:
        row["status"] = f"not assemblable: {exc}"
        row["assembles [-]"] = False
        return row
    except MechsolveError as exc:
        row["status"] = f"failed: {exc}"
        return row
    except Exception as exc:  # noqa: BLE001 - one design's bug must not end the study
        row["status"] = f"internal error: {type(exc).__name__}: {exc}"
        return row
    row["status"] = status_of(fig, res)
    row.update(fig)
    if results_dir is not None:
        _keep_results(res, Path(results_dir) / f"design-{k:05d}.csv", study, row)
    return row


def _keep_results(res, path: Path, study: Study, row: Row) -> None:
    """Write a solved design's results to ``path``; a file the system refuses (a full
    disk) stops the study (:class:`ResultsNotWritten`, carrying ``row``)."""
    import numpy as np

    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res.to_csv(path, study.units)
    except WriteFailed as exc:
        raise ResultsNotWritten(exc.filename, exc.cause, [row]) from None
    except Exception as exc:  # noqa: BLE001 - one design's bug must not end the study
        row["status"] = f"failed: its results were not written: {type(exc).__name__}: {exc}"


def _in_order(indices: list[int], one: Callable[[int], Row]) -> list[Row]:
    """``[one(k) for k in indices]``; a :class:`ResultsNotWritten` carries the rows
    finished before it too."""
    rows: list[Row] = []
    for k in indices:
        try:
            rows.append(one(k))
        except ResultsNotWritten as exc:
            raise ResultsNotWritten(exc.filename, exc.cause, rows + exc.rows) from None
    return rows


def solve_design(study: Study, k: int, results_dir: str | None = None) -> Row:
    """One design's row: its parameters, a status, and its figures (see
    :mod:`mechsolve.analyses.study.figures`). An invalid design or one that cannot be solved is a
    row that says why; nothing is raised but KeyboardInterrupt."""

    row = _head(study, k)
    try:
        mech = study.mechanism(k)
    except InputError as exc:
        row["status"] = f"invalid: {exc}"
        return row
    return _fill(
        study,
        row,
        mech,
        lambda: solve_sweep(mech, step=study.step, method=study.method),
        results_dir,
    )


def precheck(study: Study, nominal) -> None:
    """Solve the file as it is once and read the study's figures and the requirements
    there, so that a figure naming something the run does not have is one input error
    before the study starts, not a message in every row. Nothing is checked when the
    file's own design cannot be solved."""
    import numpy as np

    figures = list(study.figures)
    if study.best is not None:
        figures.append(study.best[1])
    if not figures and not getattr(nominal, "requirements", None):
        return
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = solve_sweep(nominal, step=study.step, method=study.method)
    except MechsolveError:
        return
    if not res.ok.any():
        return
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for text in figures:
            try:
                evaluate_figure(text, nominal, res)
            except InputError as exc:
                what = "--best" if study.best is not None and text == study.best[1] else "figure"
                raise InputError(f"{what} {exc.message}") from None
        check_requirements(nominal, res)


def _rows_acceleration(study: Study, mech, results_dir: str | None) -> bool | None:
    """False when the rows read no acceleration, so that a batch need not compute them:
    no extra figure, no ``--best``, no requirement, no results written (the design
    figures are positions, rates and transmission angles; the force analysis computes
    the accelerations it needs whatever this says). None otherwise: the file's outputs."""
    if results_dir is not None or study.figures or study.best is not None:
        return None
    if getattr(mech, "requirements", None):
        return None
    return False


def solve_chunk(study: Study, indices: list[int], results_dir: str | None = None) -> list[Row]:
    """The rows of designs ``indices``, as :func:`solve_design` gives them; the valid
    designs are solved as one batch (:func:`mechsolve.analyses.batch.solve_designs`, the same
    results as separate solves), then each row's figures come from its own results.

    When the study's parameters are numbers the analysis reads as they are (see
    :mod:`mechsolve.analyses.study.family`), the designs are not parsed: the batch stacks the
    file's numbers with the designs' values, and a design the parser would refuse is
    parsed on its own for its message. The rows are the same."""
    try:
        fam = study_family(study, indices)
    except Exception:  # noqa: BLE001 - then every design is parsed, as before the family
        fam = None
    if fam is not None:
        return _family_chunk(study, fam, indices, results_dir)
    import numpy as np

    heads: dict[int, Row] = {}
    mechs: dict = {}
    for k in indices:
        heads[k] = _head(study, k)
        try:
            mechs[k] = study.mechanism(k)
        except InputError as exc:
            heads[k]["status"] = f"invalid: {exc}"
    if len(mechs) < 2:
        return _in_order(indices, lambda k: solve_design(study, k, results_dir))
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            batch = solve_parsed(  # (parsed and validated just above: not checked again)
                list(mechs.values()),
                step=study.step,
                method=study.method,
                acceleration=_rows_acceleration(study, next(iter(mechs.values())), results_dir),
            )
    except Exception:  # noqa: BLE001 - then each design is solved on its own, as always
        return _in_order(indices, lambda k: solve_design(study, k, results_dir))
    slot = {k: j for j, k in enumerate(mechs)}

    def one(k: int) -> Row:
        if k not in mechs:  # invalid: its row says why
            return heads[k]
        return _fill(study, heads[k], mechs[k], lambda: batch.results(slot[k]), results_dir)

    return _in_order(indices, one)


def study_family(study: Study, indices: list[int]) -> DesignFamily | None:
    """The designs ``indices`` of ``study`` as a design family, or None when its
    parameters need each design parsed (:attr:`DesignFamily.why_not`). The file is
    parsed once per study and process."""
    if not FAMILY:
        return None
    cache = study.__dict__.get("_family")
    if cache is None:
        import numpy as np

        whole = DesignFamily(study.source, study.params, np.zeros((0, len(study.params))))
        whole.prepare()
        cache = study.__dict__["_family"] = whole
    if cache.why_not is not None:
        return None
    import numpy as np

    n = len(study.params)
    table = np.zeros((len(indices), n))
    given = np.zeros((len(indices), n), bool)
    for j, k in enumerate(indices):
        for i, x in study.designs[k].items():
            table[j, i] = x
            given[j, i] = True
    return cache.with_values(table, None if given.all() else given)


def _family_chunk(
    study: Study, fam: DesignFamily, indices: list[int], results_dir: str | None
) -> list[Row]:
    """:func:`solve_chunk` on a design family: the same rows, no design parsed but those
    the parser might refuse."""
    import numpy as np

    fam.prepare()
    heads = {k: _head(study, k) for k in indices}
    for j, exc in fam.invalid.items():
        heads[indices[j]]["status"] = f"invalid: {exc}"
    valid = [j for j in range(len(indices)) if j not in fam.invalid]
    if len(valid) < 2:
        return _in_order(indices, lambda k: solve_design(study, k, results_dir))
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            batch = solve_family(
                fam,
                step=study.step,
                method=study.method,
                acceleration=_rows_acceleration(study, fam.mechanism(valid[0]), results_dir),
            )
    except Exception:  # noqa: BLE001 - then each design is solved on its own, as always
        return _in_order(indices, lambda k: solve_design(study, k, results_dir))
    slot = {k: j for j, k in enumerate(indices)}

    def one(k: int) -> Row:
        j = slot[k]
        if j in fam.invalid:  # its row says why
            return heads[k]
        return _fill(study, heads[k], fam.mechanism(j), lambda: batch.results(j), results_dir)

    return _in_order(indices, one)


class Estimate:
    """What a study will cost, from its first chunk of designs solved and timed here.
    ``unwritten``: the error that stopped the study in that chunk, if one did (see
    :class:`ResultsNotWritten`; ``rows`` are then those finished)."""

    unwritten: ResultsNotWritten | None = None

    def __init__(self, rows: list[Row], seconds: float, n: int, workers: int) -> None:
        self.rows = rows
        self.timed = len(rows)
        self.per_design = seconds / max(len(rows), 1)  # s, as solved in chunks
        self.n = n
        self.workers = max(1, workers)
        # the table's rows stay in memory until it is written: their size, measured
        self.row_bytes = sum(_row_size(r) for r in rows) / max(len(rows), 1)

    @property
    def seconds(self) -> float:
        """The estimated time for the designs not timed yet (s)."""
        return (self.n - self.timed) * self.per_design / self.workers

    @property
    def memory(self) -> float:
        """The estimated memory of the table's rows (bytes)."""
        return self.n * self.row_bytes

    def text(self, where: str) -> str:
        return (
            f"about {duration_text(self.seconds)} on {where} "
            f"({self.per_design * 1e3:.3g} ms a design, timed on the first {self.timed}) "
            f"and about {bytes_text(self.memory)} of memory for the table's rows"
        )


def _row_size(row: Row) -> int:
    import sys

    return sys.getsizeof(row) + sum(sys.getsizeof(k) + sys.getsizeof(v) for k, v in row.items())


def duration_text(seconds: float) -> str:
    """``42 s``, ``3.5 min``, ``2.1 h``, ``3.2 days``."""
    if seconds < 90:
        return f"{seconds:.2g} s" if seconds < 10 else f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.2g} min"
    if seconds < 172800:
        return f"{seconds / 3600:.2g} h"
    return f"{seconds / 86400:.3g} days"


def bytes_text(b: float) -> str:
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if b >= size:
            return f"{b / size:.3g} {unit}"
    return f"{b:.0f} B"


def time_first_chunk(
    study: Study, workers: int, chunk: int | None = None, results_dir: str | Path | None = None
) -> Estimate:
    """Solve the study's first chunk of designs here, timed, for :class:`Estimate`; its
    rows are kept (``execute(first=...)`` does not solve them again)."""
    n = len(study)
    todo = chunks(n, 1, chunk)
    if not todo:
        return Estimate([], 0.0, 0, workers)
    rd = None if results_dir is None else str(results_dir)
    t0 = time.perf_counter()
    try:
        rows = solve_chunk(study, todo[0], rd)
    except ResultsNotWritten as exc:
        est = Estimate(exc.rows, time.perf_counter() - t0, n, workers)
        est.unwritten = exc
        return est
    return Estimate(rows, time.perf_counter() - t0, n, workers)


# the study of a pool worker: sent once, when the worker starts
_WORKER_STUDY: Study | None = None


def _init_worker(study: Study) -> None:
    import signal

    global _WORKER_STUDY
    _WORKER_STUDY = study
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the main process's to handle
    # and SIGTERM (the main process's pool.terminate) ends a worker at once, without the
    # KeyboardInterrupt and traceback of the handler a forked worker inherits
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _pool_chunk(indices: list[int], results_dir: str | None) -> list[Row]:
    assert _WORKER_STUDY is not None
    return solve_chunk(_WORKER_STUDY, indices, results_dir)


def chunks(n: int, workers: int, size: int | None = None) -> list[list[int]]:
    """Design indices in chunks: at least sixteen chunks where there are designs enough,
    between 1 and 32 designs each (the progress bar moves, the overhead per design stays
    small, two workers share the work). The chunks do not depend on ``workers``: a chunk
    is solved as one batch, and the same chunks give the same table to the last digit,
    whichever executor runs them."""
    if size is None:
        size = max(1, min(32, math.ceil(n / 16)))
    return [list(range(i, min(i + size, n))) for i in range(0, n, size)]


def cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


class Outcome:
    """The rows of a study, in design order, whether it was interrupted, and the error
    that stopped it (``unwritten``: a design's results file not written), if any."""

    def __init__(
        self,
        rows: list[Row],
        total: int,
        interrupted: bool,
        executor: str,
        unwritten: ResultsNotWritten | None = None,
    ) -> None:
        self.rows = sorted(rows, key=lambda r: r["design [-]"])
        self.total = total
        self.interrupted = interrupted
        self.executor = executor
        self.unwritten = unwritten
        # designs' results files of designs without a row (see rowless): named by the CLI
        self.late: list[Path] = []


def execute(
    study: Study,
    *,
    jobs: int | None = None,
    dask: bool = False,
    scheduler: str | None = None,
    dask_processes: bool = True,
    chunk: int | None = None,
    progress: Callable[[int], Any] | None = None,
    results_dir: str | Path | None = None,
    first: list[Row] | None = None,
) -> Outcome:
    """Solve every design of ``study``.

    Parameters
    ----------
    jobs
        Workers: processes of the local pool (default: all cores; 1 solves in this
        process), or Dask workers of ``dask``'s local cluster.
    dask, scheduler
        Run on a Dask local cluster, or on the scheduler at ``tcp://host:port``.
    chunk
        Designs per task (default: see :func:`chunks`).
    progress
        Called with the number of designs each finished chunk holds.
    results_dir
        Write each design's results CSV there (``design-00007.csv``).
    first
        The rows of the first chunk, already solved (:func:`time_first_chunk`): the
        other chunks are solved.
    """
    n = len(study)
    rd = None if results_dir is None else str(results_dir)
    todo_chunks = chunks(n, 1, chunk)
    done: list[Row] = []
    if first is not None and todo_chunks:
        assert [r["design [-]"] for r in first] == todo_chunks[0], "not the first chunk"
        done, todo_chunks = list(first), todo_chunks[1:]
    if scheduler is not None or dask:
        return _run_dask(study, jobs, scheduler, dask_processes, todo_chunks, done, progress, rd)
    workers = min(jobs or cpu_count(), max(n, 1))
    rows: list[Row] = list(done)
    if not todo_chunks:
        return Outcome(rows, n, False, "this process")
    if workers <= 1:
        return _run_here(study, todo_chunks, rows, n, progress, rd)
    return _run_pool(study, workers, todo_chunks, rows, n, progress, rd)


def _run_here(
    study: Study,
    todo_chunks: list[list[int]],
    rows: list[Row],
    n: int,
    progress: Callable[[int], Any] | None,
    rd: str | None,
) -> Outcome:
    """Solve the chunks in this process, adding their rows to ``rows`` (Ctrl-C keeps
    those finished)."""
    try:
        for idx in todo_chunks:
            rows += solve_chunk(study, idx, rd)
            if progress is not None:
                progress(len(idx))
    except KeyboardInterrupt:
        return Outcome(rows, n, True, "this process")
    except ResultsNotWritten as exc:
        return Outcome(rows + exc.rows, n, False, "this process", exc)
    return Outcome(rows, n, False, "this process")


def _run_pool(
    study: Study,
    workers: int,
    todo_chunks: list[list[int]],
    rows: list[Row],
    n: int,
    progress: Callable[[int], Any] | None,
    rd: str | None,
) -> Outcome:
    """Solve the chunks on a pool of ``workers`` processes, adding their rows to ``rows``
    as they finish (Ctrl-C ends the workers at once and keeps the rows finished)."""
    import multiprocessing

    # a multiprocessing pool, not concurrent.futures: on Ctrl-C its workers are ended at
    # once (terminate), where an executor's shutdown lets every chunk already handed out
    # run to its end (a minute or more of a large study) before the process can exit
    pool = multiprocessing.get_context().Pool(workers, _init_worker, (study,))
    interrupted = False
    unwritten = None
    try:
        todo = [(idx, rd) for idx in todo_chunks]
        for got in pool.imap_unordered(_pool_chunk_args, todo):
            rows += got
            if progress is not None:
                progress(len(got))
        pool.close()
    except KeyboardInterrupt:
        interrupted = True
    except ResultsNotWritten as exc:  # the disk is full: the other workers are ended
        rows += exc.rows
        unwritten = exc
    except BaseException:
        pool.terminate()
        pool.join()
        raise
    try:
        if interrupted or unwritten is not None:
            with _ctrl_c_held():  # pressed again: the workers are being ended already
                _end_pool(pool, rd)
        else:
            pool.join()
    except KeyboardInterrupt:  # Ctrl-C while the workers end: the rows are kept
        interrupted = True
        with _ctrl_c_held():
            _end_pool(pool, rd)
    return Outcome(rows, n, interrupted, f"a pool of {workers} processes", unwritten)


def _pool_chunk_args(args: tuple[list[int], str | None]) -> list[Row]:
    return _pool_chunk(*args)


def _end_pool(pool, rd: str | None = None) -> None:
    """End the workers of an interrupted pool now: they are computing chunks whose rows
    are not wanted any more. ``terminate`` sends each SIGTERM (which ends a worker at
    once: see :func:`_init_worker`) and waits for them. A worker ended while it wrote a
    design's results leaves the atomic writer's temporary (never a part-written result):
    those of the results folder ``rd`` are removed."""
    pool.terminate()
    pool.join()
    if rd is not None:
        for tmp in Path(rd).glob(".design-*.part"):
            tmp.unlink(missing_ok=True)


def connect(scheduler: str, timeout: float = SCHEDULER_TIMEOUT):
    """A Dask client of the scheduler at ``scheduler``; an :class:`InputError` naming it
    when it does not answer within ``timeout`` seconds."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise InputError(
            '--scheduler needs Dask: pip install "mechsolve[dask]" (dask[distributed])'
        ) from None
    t0 = time.monotonic()
    try:
        return Client(scheduler, timeout=timeout)
    except (OSError, TimeoutError) as exc:
        waited = time.monotonic() - t0
        raise InputError(
            f"--scheduler {scheduler}: no Dask scheduler answers there (gave up after "
            f"{waited:.1f} s: {type(exc).__name__}: {exc}). Is it running (dask scheduler) "
            "and is the address tcp://HOST:PORT?"
        ) from None
    except ValueError as exc:
        raise InputError(f"--scheduler {scheduler}: {exc}") from None


@contextlib.contextmanager
def _ctrl_c_held():
    """Ignore Ctrl-C for a moment: while a Dask local cluster starts its worker processes
    (they inherit SIGINT ignored, so a Ctrl-C at the terminal, sent to the whole process
    group, does not raise KeyboardInterrupt in each of them and print its traceback, and
    a cluster half started is not left for Dask's exit handler to fail on; a Ctrl-C
    during the start, a few seconds, is not seen: press it again once the designs are
    running), and while workers are ended or a cluster closed after a Ctrl-C."""
    import signal

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _run_dask(study, jobs, scheduler, processes, todo_chunks, done, progress, rd) -> Outcome:
    n = len(study)
    cluster = client = None
    rows: list[Row] = list(done)
    interrupted = False
    unwritten = None
    futures: list = []
    if scheduler is None:
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:
            raise InputError(
                '--dask needs Dask: pip install "mechsolve[dask]" (dask[distributed])'
            ) from None
    try:
        # Ctrl-C is held while the cluster starts and the designs are handed out (see
        # _ctrl_c_held): it stops the study while the designs are being solved
        with _ctrl_c_held():
            if scheduler is not None:
                client = connect(scheduler)
                where = f"the Dask scheduler at {scheduler}"
            else:
                workers = jobs or cpu_count()
                where = f"a Dask local cluster of {workers} workers"
                cluster = LocalCluster(
                    n_workers=workers,
                    threads_per_worker=1,
                    processes=processes,
                    dashboard_address=None,
                    silence_logs=50,
                )
                client = Client(cluster)
            from dask.distributed import as_completed

            shared = client.scatter(study, broadcast=True)
            futures = [
                client.submit(solve_chunk, shared, idx, rd, pure=False) for idx in todo_chunks
            ]
        for fut in as_completed(futures):
            got = fut.result()
            rows += got
            if progress is not None:
                progress(len(got))
    except KeyboardInterrupt:
        interrupted = True
    except ResultsNotWritten as exc:  # the disk is full: the other chunks are cancelled
        rows += exc.rows
        unwritten = exc
    finally:
        # a Ctrl-C pressed again while the cluster closes would leave it half closed for
        # Dask's exit handler to fail on (with tracebacks): the close is not interrupted
        with _ctrl_c_held():
            if (interrupted or unwritten is not None) and client is not None and futures:
                client.cancel(futures)
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
    executor = where if client is not None else "Dask"
    return Outcome(rows, n, interrupted, executor, unwritten)


__all__ = [
    "Estimate",
    "Outcome",
    "ResultsNotWritten",
    "chunks",
    "connect",
    "cpu_count",
    "design_files",
    "execute",
    "precheck",
    "results_kept",
    "rowless",
    "solve_chunk",
    "solve_design",
    "status_of",
    "study_family",
    "time_first_chunk",
    "written_since",
]
