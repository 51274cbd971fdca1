"""Where the independent calls of a fleet run: here, local processes, Dask, any executor.

:func:`run_calls` hides the backends behind one loop over ``(index, value, error)``
triples in completion order. Dask, joblib and Ray are imported only when asked for,
so ``import moli`` stays light and the core needs none of them.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import os
from typing import Any, Callable, Iterator, Sequence

from ..errors import OptionError

__all__ = ["usable_cpus", "run_calls"]

Done = Iterator[tuple[int, Any, "BaseException | None"]]


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
) -> Iterator[tuple[str, Done]]:
    """Run ``function(*args)`` for every ``args`` of ``calls``.

    Parameters
    ----------
    function : callable
        A module-level function (it is pickled by reference to reach the workers).
    calls : sequence of tuples
        The arguments of each call.
    executor : None, str, dask.distributed.Client or concurrent.futures.Executor
        None: ``n_jobs`` local processes (joblib's loky when installed, else
        ``concurrent.futures``; this process when ``n_jobs`` is 1); a string: that
        joblib backend (``"ray"`` registers Ray's first); a Client or an Executor:
        its workers.
    n_jobs : int or None
        Local processes or joblib workers; default :func:`usable_cpus`.

    Yields
    ------
    description : str
        Where the calls run, e.g. ``"loky, 2 processes"``.
    done : iterator of (int, object, BaseException or None)
        Per call, in completion order: its position, its value, and the error that
        kept the backend from returning it (a lost worker, say), or None.

    Raises
    ------
    OptionError
        An executor of another kind, an unknown joblib backend, a bad ``n_jobs``,
        or ``n_jobs`` given with a Client or an Executor (before any call runs).
    """
    if n_jobs is not None and (isinstance(n_jobs, bool) or not isinstance(n_jobs, int) or n_jobs < 1):
        raise OptionError(f"n_jobs must be a positive integer or None, got {n_jobs!r}")
    brings_workers = _is_dask_client(executor) or isinstance(executor, concurrent.futures.Executor)
    if brings_workers and n_jobs is not None:
        raise OptionError("n_jobs sets local workers; a Client or an Executor brings its own: leave n_jobs out")
    if executor is not None and not brings_workers and not isinstance(executor, str):
        raise OptionError("executor must be None, a dask.distributed.Client, a concurrent.futures.Executor "
                          f"or the name of a joblib backend, got {type(executor).__name__}")
    workers = max(1, min(n_jobs or usable_cpus(), len(calls)))
    if _is_dask_client(executor):
        from distributed import as_completed

        address = getattr(getattr(executor, "scheduler", None), "address", "?")
        with _futures(executor.submit, calls, function, as_completed, pure=False) as done:
            yield f"dask, {address}", done
    elif isinstance(executor, concurrent.futures.Executor):
        with _futures(executor.submit, calls, function, concurrent.futures.as_completed) as done:
            yield type(executor).__name__, done
    elif isinstance(executor, str):
        with _joblib(executor, workers, function, calls) as done:
            yield f"joblib {executor}, {workers} workers", done
    elif workers == 1:
        yield "this process", ((i, function(*args), None) for i, args in enumerate(calls))
    else:
        try:
            import joblib  # noqa: F401  (loky reuses its workers from one fleet to the next)
        except ImportError:
            with concurrent.futures.ProcessPoolExecutor(workers) as pool:
                with _futures(pool.submit, calls, function, concurrent.futures.as_completed) as done:
                    yield f"{workers} processes", done
        else:
            with _joblib("loky", workers, function, calls) as done:
                yield f"loky, {workers} processes", done


@contextlib.contextmanager
def _futures(submit: Callable[..., Any], calls: Sequence[tuple[Any, ...]], function: Callable[..., Any],
             as_completed: Callable[[Any], Any], **options: Any) -> Iterator[Done]:
    """One future per call; the ones still pending are cancelled when the loop stops early."""
    futures = {submit(function, *args, **options): i for i, args in enumerate(calls)}

    def done() -> Done:
        for future in as_completed(list(futures)):
            try:
                yield futures[future], future.result(), None
            except Exception as exc:  # the backend lost this call; the others go on
                yield futures[future], None, exc

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
