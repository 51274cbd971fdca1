"""Where the independent calls of a fleet run: here, local processes, Dask, any executor.

:func:`run_calls` hides the backends behind one loop over ``(index, value, error)``
triples in completion order. Dask, joblib and Ray are imported only when asked for,
so ``import moli`` stays light and the core needs none of them.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import os
import time
from typing import Any, Callable, Iterable, Iterator, Sequence

from ..errors import MoliError, OptionError
from .dask_workers import quiet_workers
from .local_workers import LostWorkerError, RecordTimeoutError, worker_processes

__all__ = ["usable_cpus", "run_calls", "dask_completed", "NoWorkersError", "LostWorkerError",
           "RecordTimeoutError", "NO_WORKER_TIMEOUT", "MAX_TIMEOUT"]

Done = Iterator[tuple[int, Any, "BaseException | None"]]
# Seconds a Dask cluster may have no worker at all before the calls still pending fail:
# long enough for an autoscaler to bring up a replacement, short enough to end a run.
NO_WORKER_TIMEOUT = 60.0
# The longest per-record timeout: the waits below count milliseconds in 32 bits (2^31 ms is 24.8
# days), and a longer one is no limit at all
MAX_TIMEOUT = 2_000_000.0
# How often the pending Dask futures and the cluster's workers are looked at.
POLL_SECONDS = 0.2


class NoWorkersError(MoliError):
    """A Dask cluster had no worker for longer than the timeout: pending work cannot run."""


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the system has one)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _is_dask_client(executor: Any) -> bool:
    return type(executor).__module__.split(".")[0] == "distributed" and hasattr(executor, "submit")


@contextlib.contextmanager
def run_calls(
    function: Callable[..., Any], calls: Sequence[tuple[Any, ...]], executor: Any, n_jobs: int | None,
    no_worker_timeout: float = NO_WORKER_TIMEOUT, timeout: float | None = None,
) -> Iterator[tuple[str, Done]]:
    """Run ``function(*args)`` for every ``args`` of ``calls``.

    Parameters
    ----------
    function : callable
        A module-level function (it is pickled by reference to reach the workers).
    calls : sequence of tuples
        The arguments of each call.
    executor : None, str, dask.distributed.Client or concurrent.futures.Executor
        None: ``n_jobs`` local processes (:mod:`moli.fleets.local_workers`; this
        process when ``n_jobs`` is 1 and no ``timeout`` is set); a string: that joblib
        backend (``"ray"`` registers Ray's first); a Client or an Executor: its workers.
    n_jobs : int or None
        Local processes or joblib workers; default :func:`usable_cpus`.
    no_worker_timeout : float
        Seconds a Dask cluster may have no worker before its pending calls fail with
        :class:`NoWorkersError`.
    timeout : float, optional
        Seconds one call may run on local processes; a call over it is ended with its
        worker process and fails with :class:`RecordTimeoutError`.

    Yields
    ------
    description : str
        Where the calls run, e.g. ``"2 processes"``.
    done : iterator of (int, object, BaseException or None)
        Per call, in completion order: its position, its value, and the error that
        kept the backend from returning it (a lost worker, a timeout), or None. On
        local processes a call whose worker died is retried once, on another worker,
        so a call that kills its worker fails alone (:class:`LostWorkerError`).

    Raises
    ------
    OptionError
        An executor of another kind, an unknown joblib backend, a bad ``n_jobs``,
        ``n_jobs`` given with a Client or an Executor, or ``timeout`` with anything
        but local processes (before any call runs).
    """
    if n_jobs is not None and (isinstance(n_jobs, bool) or not isinstance(n_jobs, int) or n_jobs < 1):
        raise OptionError(f"n_jobs must be a positive integer or None, got {n_jobs!r}")
    brings_workers = _is_dask_client(executor) or isinstance(executor, concurrent.futures.Executor)
    if brings_workers and n_jobs is not None:
        raise OptionError("n_jobs sets local workers; a Client or an Executor brings its own: leave n_jobs out")
    if executor is not None and not brings_workers and not isinstance(executor, str):
        raise OptionError("executor must be None, a dask.distributed.Client, a concurrent.futures.Executor "
                          f"or the name of a joblib backend, got {type(executor).__name__}")
    if timeout is not None:
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not 0 < timeout <= MAX_TIMEOUT:
            raise OptionError(f"timeout must be a positive number of seconds, at most {MAX_TIMEOUT:.0f} (23 days; "
                              f"leave it out for no limit), got {timeout!r}")
        if executor is not None:
            # a Dask worker's thread or a pool's process cannot be ended for one call alone
            raise OptionError("timeout ends the worker process of a call that runs too long: it needs "
                              "moli's local processes (executor=None), not a Client, an Executor or a "
                              "joblib backend")
    workers = max(1, min(n_jobs or usable_cpus(), len(calls)))
    if _is_dask_client(executor):
        address = getattr(getattr(executor, "scheduler", None), "address", "?")

        def completed(futures: list[Any]) -> Iterator[Any]:
            return dask_completed(executor, futures, no_worker_timeout)

        with quiet_workers(executor):
            # one graph for all the calls: a millisecond less per call in this process than a submit each
            futures = executor.map(function, *zip(*calls), pure=False) if calls else []
            with _futures(futures, completed) as done:
                yield f"dask, {address}", done
    elif isinstance(executor, concurrent.futures.Executor):
        with _futures([executor.submit(function, *args) for args in calls], concurrent.futures.as_completed) as done:
            yield type(executor).__name__, done
    elif isinstance(executor, str):
        with _joblib(executor, workers, function, calls) as done:
            yield f"joblib {executor}, {workers} workers", done
    elif workers == 1 and timeout is None:
        yield "this process", ((i, function(*args), None) for i, args in enumerate(calls))
    else:
        with worker_processes(function, calls, workers, timeout) as done:
            yield f"{workers} process{'es' if workers > 1 else ''}", done


@contextlib.contextmanager
def _futures(submitted: Sequence[Any], as_completed: Callable[[Any], Any]) -> Iterator[Done]:
    """The futures of the calls, in their order; those still pending are cancelled when the loop stops early."""
    futures = {future: i for i, future in enumerate(submitted)}

    def done() -> Done:
        pending = dict(futures)
        try:
            for future in as_completed(list(futures)):
                del pending[future]
                try:
                    yield futures[future], future.result(), None
                except Exception as exc:  # the backend lost this call; the others go on
                    yield futures[future], None, exc
        except NoWorkersError as exc:  # nothing left to run them: each pending call fails
            for index in pending.values():
                yield index, None, exc

    try:
        yield done()
    finally:
        for future in futures:
            future.cancel()


def _indexed(function: Callable[..., Any], index: int, args: tuple[Any, ...]) -> tuple[int, Any]:
    return index, function(*args)


@contextlib.contextmanager
def _joblib(backend: str, workers: int, function: Callable[..., Any],
            calls: Sequence[tuple[Any, ...]]) -> Iterator[Done]:
    try:
        from joblib import Parallel, delayed, parallel_config
    except ImportError:
        raise OptionError(f"executor={backend!r} needs joblib: pip install 'moli[distributed]'") from None
    if backend == "ray":
        try:
            from ray.util.joblib import register_ray
        except ImportError:
            raise OptionError("executor='ray' needs ray: pip install 'ray[default]'") from None
        register_ray()
    try:
        config = parallel_config(backend=backend, n_jobs=workers)
    except ValueError as exc:
        raise OptionError(f"executor: {exc}") from None
    with config:
        try:
            parallel = Parallel(return_as="generator_unordered")
        except ValueError:  # a backend that only returns lists (Ray's): progress at the end
            parallel = Parallel(return_as="list")
        results = parallel(delayed(_indexed)(function, i, args) for i, args in enumerate(calls))
        yield ((index, value, None) for index, value in results)


def dask_completed(client: Any, futures: Iterable[Any], timeout: float = NO_WORKER_TIMEOUT) -> Iterator[Any]:
    """Dask ``futures`` as they complete, failing when the cluster has had no worker for ``timeout`` s.

    Dask waits for a worker forever; a cluster that lost all of its workers would
    hang the caller. Raises :class:`NoWorkersError` naming the scheduler.
    """
    from distributed import as_completed

    # the client's own loop: it need not be the default client of this process
    pending = as_completed(list(futures), loop=getattr(client, "loop", None))
    alone_since: float | None = None
    while not pending.is_empty():
        batch = pending.next_batch(block=False)
        yield from batch
        if batch:
            continue
        if _has_workers(client):
            alone_since = None
        else:
            alone_since = alone_since or time.monotonic()
            if time.monotonic() - alone_since > timeout:
                address = getattr(getattr(client, "scheduler", None), "address", "?")
                raise NoWorkersError(f"the Dask cluster at {address} has had no worker for {timeout:g} s; "
                                     f"{pending.count()} calls could not run: start workers, or run locally")
        time.sleep(POLL_SECONDS)


def _has_workers(client: Any) -> bool:
    try:
        info = client.scheduler_info(n_workers=1)  # lists at most one worker: enough to know
    except TypeError:  # a Dask before the n_workers argument lists them all
        info = client.scheduler_info()
    return bool(info["workers"])
