"""Dask workers that run a fleet's calls as fast as a plain process does.

A Dask worker wakes its event loop a hundred times a second to sample the running
task's stack (the statistical profiler) and fifty times to time the loop itself (the
tick). Each wake-up takes the interpreter lock from the task: the sampling itself holds
it for 3 to 4 % of an identification's time, and on a machine whose cores all run tasks
each wake-up must also wait for a core, then hand the lock back. :func:`quiet_workers`
stops the sampler and slows the tick on the cluster's workers while a fleet runs, and
puts them back after; :func:`dask_worker_config` is the configuration that does the
same for the whole life of a cluster, and also for what a running worker cannot change
(the sampler of the event loop itself, the allocator's trim threshold).
"""

from __future__ import annotations

import contextlib
import threading
from typing import Any, Iterator

__all__ = ["dask_worker_config", "quiet_workers"]

SAMPLERS = ("profile", "profile-cycle")
# The tick only warns when the loop was blocked for seconds (``distributed.admin.tick.limit``,
# 3 s by default): once a second still sees that.
TICK_MS = 1000.0

# Per worker address, in the worker's process: how many fleets run on it, and the
# callbacks' settings to put back when the last one ends.
_paused: dict[str, tuple[int, dict[str, float | None]]] = {}
_lock = threading.Lock()


def dask_worker_config() -> dict[str, Any]:
    """Dask settings under which a record takes as long on a worker as in one process.

    Set them before the cluster starts (``dask.config.set`` around ``LocalCluster``; the
    Dask configuration file, or ``DASK_*`` variables, of the machines that run
    ``dask worker``). :func:`moli.identify_many` and :func:`moli.estimate_chunks` stop the
    profiler of a cluster started without them while they run, but cannot change the rest.

    Returns
    -------
    dict
        ``distributed.worker.profile.enabled``: False (no statistical profiler, neither
        of the tasks nor of the event loop); ``distributed.admin.tick.interval``: 1 s
        instead of 20 ms; ``distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_``:
        None (glibc's own threshold: with Dask's 65536, every medium-sized array is
        mapped and unmapped, 1.5 to 2 times slower).

    Examples
    --------
    >>> import dask
    >>> from moli.fleets import dask_worker_config
    >>> with dask.config.set(dask_worker_config()):
    ...     dask.config.get("distributed.worker.profile.enabled")
    False
    """
    return {
        "distributed.worker.profile.enabled": False,
        "distributed.admin.tick.interval": f"{TICK_MS:g}ms",
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    }


@contextlib.contextmanager
def quiet_workers(client: Any) -> Iterator[None]:
    """The client's current workers without their profiler and with a slow tick, for a while.

    Settings are put back when the block ends (when the last of several overlapping
    blocks ends). Workers that join meanwhile keep their own settings. Only the speed
    changes: nothing the tasks compute.
    """
    _on_workers(client, _pause)
    try:
        yield
    finally:
        _on_workers(client, _resume)


def _on_workers(client: Any, function: Any) -> None:
    try:
        client.run(function, on_error="ignore")
    except Exception:  # a speed-up only: a worker or a scheduler that cannot be reached changes no result
        pass


def _pause(dask_worker: Any) -> None:
    """On the worker's event loop: stop the sampler and slow the tick, keeping what to restore."""
    callbacks = dask_worker.periodic_callbacks
    with _lock:
        count, saved = _paused.get(dask_worker.address, (0, {}))
        if count == 0:
            saved = {}
            for name in SAMPLERS:
                if name in callbacks and callbacks[name].is_running():
                    callbacks[name].stop()
                    saved[name] = None
            tick = callbacks.get("tick")
            if tick is not None and tick.callback_time < TICK_MS:
                saved["tick"] = tick.callback_time
                tick.callback_time = TICK_MS
        _paused[dask_worker.address] = (count + 1, saved)


def _resume(dask_worker: Any) -> None:
    """On the worker's event loop: undo :func:`_pause` when the last fleet on it ends."""
    callbacks = dask_worker.periodic_callbacks
    with _lock:
        count, saved = _paused.pop(dask_worker.address, (0, {}))
        if count > 1:
            _paused[dask_worker.address] = (count - 1, saved)
            return
        for name, callback_time in saved.items():
            if name not in callbacks:
                continue
            if callback_time is None:
                callbacks[name].start()
            else:
                callbacks[name].callback_time = callback_time
