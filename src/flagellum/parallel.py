"""Process pools for independent tasks: one policy for sweeps, bifurcation probes, the
figures of ``flagellum reproduce`` and the grids of the buckling theory.

Workers are *spawn*-started (a fresh interpreter: no forked Numba, BLAS or HDF5 state),
run single-threaded BLAS (``OPENBLAS/OMP/MKL_NUM_THREADS=1`` unless the caller set them:
the parallelism is over tasks, and threads per worker would oversubscribe the cores), and
end themselves when the parent process dies (a killed sweep leaves no orphans behind).

Two interfaces:

* :func:`pmap` — ``[fun(x) for x in items]`` in order (serial for one worker or one item);
  inside :func:`shared_pool` all its calls share one pool;
* :func:`process_pool`, :func:`serial_pool`, :func:`dask_pool` — context managers that
  yield ``(submit, as_completed)`` with the :mod:`concurrent.futures` meaning, for callers
  that handle each result as it arrives (the sweep writes its file after every point).

Tasks and their arguments must be picklable: module-level functions, plain data.
"""

from __future__ import annotations

import concurrent.futures
import logging
import multiprocessing
import os
import threading
import time
from contextlib import contextmanager
from typing import Any, Callable, Iterable

from .errors import ParameterError

#: environment variables that make the BLAS libraries of a worker single-threaded
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
#: environment variable that overrides the default number of workers
WORKERS_VARIABLE = "FLAGELLUM_WORKERS"


#: most worker processes a command starts: far more than the cores of any one machine; a
#: larger count (a typo, 10**23) would try to start them all
MAX_WORKERS = 1024


def check_workers(name: str, n) -> int | None:
    """``n`` (None: the default) checked as a count of worker processes in [1, MAX_WORKERS]."""
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_WORKERS):
        raise ParameterError(name, n, f"an integer in [1, {MAX_WORKERS}]")
    return n


def check_scheduler(address: str | None) -> str | None:
    """``address`` (None: no scheduler) checked as a dask scheduler address
    ``[protocol://]host:port`` before anything is started or written."""
    import re

    if address is not None and not re.fullmatch(
            r"(?:(?:tcp|tls|ucx|ws|wss)://)?(?:[A-Za-z0-9_.-]+|\[[0-9A-Fa-f:.]+\]):\d{1,5}", address):
        raise ParameterError("scheduler", address, "a dask scheduler address protocol://host:port, "
                                                   "e.g. tcp://127.0.0.1:8786")
    return address


def default_workers(at_most: int | None = None) -> int:
    """Worker processes when the caller gives none: ``FLAGELLUM_WORKERS`` if it is a positive
    integer, else the CPU count capped at ``at_most``."""
    env = os.environ.get(WORKERS_VARIABLE)
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            pass
    n = os.cpu_count() or 1
    return max(1, n if at_most is None else min(at_most, n))


def _exit_with_parent(parent: int) -> None:
    """Pool initializer: end the worker when its parent process dies (e.g. killed)."""

    def watch():
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


@contextmanager
def process_pool(workers: int):
    """Yield ``(submit, as_completed)`` of a pool of ``workers`` spawn-started processes with
    single-threaded BLAS that end with the parent. Leaving the block waits for the tasks;
    an exception in the block cancels the pending ones."""
    threads = {k: "1" for k in BLAS_THREAD_VARIABLES if k not in os.environ}
    os.environ.update(threads)  # read by BLAS at import in the spawned workers
    pool = concurrent.futures.ProcessPoolExecutor(
        workers, mp_context=multiprocessing.get_context("spawn"),
        initializer=_exit_with_parent, initargs=(os.getpid(),))
    ok = False
    try:
        yield pool.submit, concurrent.futures.as_completed
        ok = True
    finally:
        pool.shutdown(wait=ok, cancel_futures=True)
        for k in threads:
            os.environ.pop(k, None)


@contextmanager
def serial_pool():
    """Yield ``(submit, as_completed)`` that run each task at once in this process (for one
    worker: no process start-up, and results identical to a pool's)."""

    def submit(fn, arg):
        fut = concurrent.futures.Future()
        try:
            fut.set_result(fn(arg))
        except Exception as exc:  # noqa: BLE001 - delivered through the future, as a pool does
            fut.set_exception(exc)
        return fut

    yield submit, concurrent.futures.as_completed


@contextmanager
def dask_pool(scheduler: str | None, dask_local: int | None):
    """Yield ``(submit, as_completed)`` of a ``dask.distributed`` client: at the scheduler
    address ``scheduler``, or on a local cluster of ``dask_local`` single-threaded processes."""
    where = scheduler if scheduler is not None else f"dask-local {dask_local}"
    try:
        import distributed
    except ImportError:
        raise ParameterError("scheduler", where, "usable: install dask[distributed] "
                                                 "(pip install 'flagellum[dist]')") from None
    cluster = client = None
    try:
        if dask_local is not None:
            cluster = distributed.LocalCluster(n_workers=dask_local, threads_per_worker=1,
                                               processes=True, host="127.0.0.1",
                                               dashboard_address=None, silence_logs=logging.ERROR)
        try:
            client = distributed.Client(cluster if cluster is not None else scheduler, timeout=15)
        except (OSError, TimeoutError, ValueError, AssertionError) as exc:
            detail = " ".join(f"{type(exc).__name__}: {exc}".split())[:500]
            raise ParameterError("scheduler", where, f"a reachable dask scheduler ({detail})") from None
        yield (lambda fn, arg: client.submit(fn, arg, pure=False)), distributed.as_completed
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


#: pools kept open by :func:`shared_pool`, by number of workers
_SHARED: dict[int, concurrent.futures.Executor] = {}


@contextmanager
def shared_pool(workers: int):
    """Within the block, every :func:`pmap` with ``workers`` workers submits to one pool of
    :func:`process_pool` instead of starting its own: a command that calls :func:`pmap`
    many times (``flagellum reproduce all``) starts its workers, their imports and Numba
    cache loads once. Tasks and results are the same as with a pool per call. Nested use
    with the same count reuses the outer pool; one worker is serial anyway."""
    if workers <= 1 or workers in _SHARED:
        yield
        return
    with process_pool(workers) as (submit, _):
        _SHARED[workers] = submit
        try:
            yield
        finally:
            del _SHARED[workers]


def pmap(fun: Callable[[Any], Any], items: Iterable, workers: int | None = None, *,
         cost: Callable[[Any], float] | None = None) -> list:
    """``[fun(x) for x in items]`` on :func:`process_pool` (serial for one worker or one
    item; ``workers`` defaults to :func:`default_workers`). With ``cost`` (an estimate per
    item) the most expensive items are submitted first, so that the workers finish together.
    The first exception of a task is raised here."""
    items = list(items)
    workers = default_workers() if workers is None else workers
    if workers <= 1 or len(items) <= 1:
        return [fun(x) for x in items]
    order = range(len(items)) if cost is None else \
        sorted(range(len(items)), key=lambda k: -float(cost(items[k])))
    out = [None] * len(items)
    if workers in _SHARED:
        futures = {k: _SHARED[workers](fun, items[k]) for k in order}
        try:
            for k, fut in futures.items():
                out[k] = fut.result()
        except BaseException:  # as leaving process_pool with an error: drop the pending tasks
            for fut in futures.values():
                fut.cancel()
            raise
        return out
    with process_pool(min(workers, len(items))) as (submit, _):
        futures = {k: submit(fun, items[k]) for k in order}
        for k, fut in futures.items():
            out[k] = fut.result()
    return out


__all__ = ["BLAS_THREAD_VARIABLES", "WORKERS_VARIABLE", "default_workers", "dask_pool", "pmap",
           "process_pool", "serial_pool", "shared_pool"]
