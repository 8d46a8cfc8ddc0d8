"""The process pool of :mod:`flagellum.parallel`: ordered results, single-threaded BLAS in
the workers, errors reach the caller, the worker count and the in-process pool."""

import math
import os

import pytest

from flagellum import parallel


def test_pmap_returns_results_in_item_order_whatever_the_submission_order():
    items = [4.0, 1.0, 9.0, 16.0, 25.0]
    assert parallel.pmap(math.sqrt, items, 2) == [2.0, 1.0, 3.0, 4.0, 5.0]
    # cost: submitted largest first, still returned in item order
    assert parallel.pmap(math.sqrt, items, 2, cost=lambda x: x) == [2.0, 1.0, 3.0, 4.0, 5.0]
    assert parallel.pmap(math.sqrt, items, 1) == [2.0, 1.0, 3.0, 4.0, 5.0]  # serial
    assert parallel.pmap(math.sqrt, [], 2) == []


def test_workers_run_single_threaded_blas_and_the_parent_environment_is_restored(monkeypatch):
    for name in parallel.BLAS_THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("MKL_NUM_THREADS", "3")  # a caller's own setting is kept
    with parallel.process_pool(2) as (submit, as_completed):
        futures = [submit(os.getenv, name) for name in parallel.BLAS_THREAD_VARIABLES]
        seen = [f.result() for f in futures]
        assert len(list(as_completed(futures))) == 3
    assert seen == ["1", "1", "3"]
    assert "OPENBLAS_NUM_THREADS" not in os.environ and "OMP_NUM_THREADS" not in os.environ
    assert os.environ["MKL_NUM_THREADS"] == "3"


def test_a_task_error_reaches_the_caller():
    with pytest.raises(ValueError, match="math domain error"):
        parallel.pmap(math.sqrt, [1.0, -1.0, 4.0], 2)
    with parallel.process_pool(1) as (submit, _):
        fut = submit(math.sqrt, -1.0)
        assert isinstance(fut.exception(), ValueError)


def test_serial_pool_delivers_results_and_errors_through_futures():
    with parallel.serial_pool() as (submit, as_completed):
        ok, bad = submit(math.sqrt, 9.0), submit(math.sqrt, -1.0)
        assert set(as_completed([ok, bad])) == {ok, bad}
    assert ok.result() == 3.0 and isinstance(bad.exception(), ValueError)


def test_default_workers(monkeypatch):
    monkeypatch.delenv(parallel.WORKERS_VARIABLE, raising=False)
    n = os.cpu_count() or 1
    assert parallel.default_workers() == n and parallel.default_workers(2) == min(2, n)
    monkeypatch.setenv(parallel.WORKERS_VARIABLE, "5")
    assert parallel.default_workers(2) == 5
    monkeypatch.setenv(parallel.WORKERS_VARIABLE, "many")  # not a number: ignored
    assert parallel.default_workers(1) == 1


def test_shared_pool_reuses_its_workers_and_gives_the_same_results():
    """Inside shared_pool every pmap call runs on the same worker processes (the pids of two
    calls are one set of two), with the results of a pool per call; errors still reach the
    caller and the pool stays usable after one."""
    items = [4.0, 1.0, 9.0, 16.0, 25.0]
    with parallel.shared_pool(2):
        assert parallel.pmap(math.sqrt, items, 2, cost=lambda x: x) == [2.0, 1.0, 3.0, 4.0, 5.0]
        pids = set()
        for _ in range(3):
            pids |= set(parallel.pmap(_pid_after_a_while, [0.2, 0.2, 0.2, 0.2], 2))
        with pytest.raises(ValueError, match="math domain error"):
            parallel.pmap(math.sqrt, [1.0, -1.0], 2)
        assert parallel.pmap(math.sqrt, items, 2) == [2.0, 1.0, 3.0, 4.0, 5.0]
        with parallel.shared_pool(2):  # nested: the same pool
            pids |= set(parallel.pmap(_pid_after_a_while, [0.2, 0.2], 2))
    assert len(pids) == 2 and os.getpid() not in pids
    assert not parallel._SHARED
    # outside the block a pool per call: new processes
    assert not set(parallel.pmap(_pid_after_a_while, [0.2, 0.2], 2)) & pids


def _pid_after_a_while(seconds: float) -> int:
    import time

    time.sleep(seconds)
    return os.getpid()
