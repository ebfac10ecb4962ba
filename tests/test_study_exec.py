"""mechsolve sweep's executors: the same study gives the same table in this process, on
the process pool and on Dask; a scheduler that does not answer is a clear message; an
interrupted study keeps the rows already finished."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest

from mechsolve.analyses.study import execute as ex
from mechsolve.analyses.study.designs import make_study
from mechsolve.analyses.study.table import columns, write_csv
from mechsolve.base.errors import InputError
from mechsolve.model.source import load_file

FOURBAR = Path(__file__).parent / "data" / "study_fourbar.yaml"


def small_study():
    # 6 designs of the file's grid, and one more value of d that cannot close (a row)
    return make_study(load_file(FOURBAR), ["ground.O4[0]=80, 87.5, 300 mm"])


def same(rows_a, rows_b, rel: float = 0.0) -> bool:
    """The same rows: every value equal (to ``rel`` relative for numbers, when given)."""
    if len(rows_a) != len(rows_b):
        return False
    for a, b in zip(rows_a, rows_b):
        if a.keys() != b.keys():
            return False
        for k in a:
            x, y = a[k], b[k]
            if isinstance(x, float) and math.isnan(x) and isinstance(y, float) and math.isnan(y):
                continue
            if rel and isinstance(x, float) and isinstance(y, float):
                if abs(x - y) <= rel * max(abs(x), abs(y)):
                    continue
            if x != y:
                return False
    return True


@pytest.fixture(scope="module")
def local_rows():
    # chunks of two designs, as the pool's and Dask's below: each chunk is solved as one
    # batch, and the same chunks give the same table to the last digit
    st = small_study()
    out = ex.execute(st, jobs=1, chunk=2)
    assert not out.interrupted and len(out.rows) == 9
    assert sum(r["status"] == "ok" for r in out.rows) == 6
    return out.rows


def test_pool_gives_the_same_table(local_rows, tmp_path):
    st = small_study()
    out = ex.execute(st, jobs=2, chunk=2)
    assert out.executor == "a pool of 2 processes"
    assert same(out.rows, local_rows)
    a = write_csv(st, local_rows, tmp_path / "a.csv").read_text()
    b = write_csv(st, out.rows, tmp_path / "b.csv").read_text()
    assert a == b


def test_dask_local_cluster_gives_the_same_table(local_rows):
    pytest.importorskip("dask.distributed", reason="dask is optional: pip install mechsolve[dask]")
    st = small_study()
    out = ex.execute(st, dask=True, jobs=2, dask_processes=False, chunk=2)
    assert out.executor.startswith("a Dask local cluster")
    assert same(out.rows, local_rows)


def test_scheduler_that_does_not_answer():
    pytest.importorskip("dask.distributed", reason="dask is optional: pip install mechsolve[dask]")
    t0 = time.monotonic()
    with pytest.raises(InputError) as exc:
        ex.execute(small_study(), scheduler="tcp://127.0.0.1:9")
    took = time.monotonic() - t0
    assert "no Dask scheduler answers" in str(exc.value)
    assert "tcp://127.0.0.1:9" in str(exc.value)
    assert took < ex.SCHEDULER_TIMEOUT + 5


def test_default_chunks_do_not_depend_on_the_workers():
    for n in (5, 9, 100, 1000):
        assert ex.chunks(n, 1) == ex.chunks(n, 2) == ex.chunks(n, 8)


def test_rows_of_separate_solves_equal_the_batched_to_rounding(local_rows):
    st = small_study()
    alone = [ex.solve_design(st, k) for k in range(len(st))]
    assert same(alone, local_rows, rel=1e-12)


def test_interrupt_keeps_the_finished_rows(local_rows):
    st = small_study()
    seen = []

    def progress(n):
        seen.append(n)
        if len(seen) == 2:
            raise KeyboardInterrupt

    out = ex.execute(st, jobs=1, chunk=2, progress=progress)
    assert out.interrupted
    assert [r["design [-]"] for r in out.rows] == [0, 1, 2, 3]
    assert same(out.rows, local_rows[:4])


def test_interrupt_of_the_pool_keeps_the_finished_rows(local_rows):
    st = small_study()
    calls = []

    def progress(n):
        calls.append(n)
        raise KeyboardInterrupt

    out = ex.execute(st, jobs=2, chunk=1, progress=progress)
    assert out.interrupted and 1 <= len(out.rows) < 9
    for r in out.rows:  # each finished row is the design's row (solved alone: to rounding)
        assert same([r], [local_rows[r["design [-]"]]], rel=1e-12)


def test_chunks_cover_every_design_once():
    for n in (1, 7, 100, 1001):
        for w in (1, 2, 16):
            cs = ex.chunks(n, w)
            assert sorted(i for c in cs for i in c) == list(range(n))
            assert max(len(c) for c in cs) <= 32


def test_columns_are_in_a_fixed_order(local_rows):
    st = small_study()
    assert columns(st, list(reversed(local_rows))) == columns(st, local_rows)
