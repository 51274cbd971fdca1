"""Local worker processes that moli starts, watches, times and ends itself.

A process pool hides which worker runs which call, so it can neither end the one call
that runs too long nor promise that its workers die with the process that started
them. :func:`worker_processes` keeps each worker on a pipe of its own and hands it one
call at a time, so that

- a call that runs longer than its timeout is ended by killing its worker (whatever it
  is doing, native code included); a fresh worker takes the next call;
- a call whose worker dies (killed, out of memory, a crash) is run once more, on another
  worker (a fresh one replaces the dead); a second death fails that call alone;
- every worker watches the process that started it and ends itself within
  :data:`PARENT_POLL_SECONDS` once that process is gone, however it ended
  (``kill -9`` included): no worker outlives the run.

Each worker is a fresh interpreter (no lock or thread state inherited from the caller,
and, on POSIX, no re-run of the caller's main script), so ``function`` and the
arguments' classes must be importable by their module paths.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import multiprocessing.connection
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass
from multiprocessing.reduction import ForkingPickler
from typing import Any, Callable, Iterator, Sequence

from ..errors import MoliError

__all__ = ["worker_processes", "serve_socket", "RecordTimeoutError", "LostWorkerError", "PARENT_POLL_SECONDS"]

Done = Iterator[tuple[int, Any, "BaseException | None"]]
# How often a worker checks that the process that started it is alive: the longest a
# worker outlives it.
PARENT_POLL_SECONDS = 0.25
# Seconds a worker asked to stop may take before it is killed.
STOP_GRACE_SECONDS = 5.0


class RecordTimeoutError(MoliError):
    """A call ran longer than its timeout; its worker process was ended."""


class LostWorkerError(RuntimeError):
    """A call's worker process died (killed, out of memory, crashed) on its first try and its retry."""


def _watch_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(PARENT_POLL_SECONDS)
    os._exit(1)  # the starter is gone (a reparented worker has another parent): nobody wants the result


def _serve(connection: multiprocessing.connection.Connection, parent: int) -> None:
    """A worker's life: run each ``(index, function, args)`` received, send back the outcome."""
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True, name="moli-parent-watch").start()
    with contextlib.suppress(EOFError, OSError):  # the pipe closed: the starter is gone or done with us
        while (task := connection.recv()) is not None:
            index, function, args = task
            connection.send((index, "started", None))  # the call's time runs from here, not from the start-up
            try:
                outcome: tuple[str, Any] = ("value", function(*args))
            except Exception as exc:  # the call's own error travels back as its result
                outcome = ("error", exc)
            try:
                message = ForkingPickler.dumps((index, *outcome))
            except Exception as exc:  # an outcome that cannot be pickled
                message = ForkingPickler.dumps((index, "error", RuntimeError(
                    f"its result could not be sent back: {type(exc).__name__}: {exc}")))
            connection.send_bytes(message)


@dataclass
class _Worker:
    process: Any  # a subprocess.Popen, or a multiprocessing Process where there is no fork
    connection: multiprocessing.connection.Connection
    index: int | None = None
    started: float | None = None  # when the worker said it began its call

    def end(self) -> None:
        """Kill the process (a no-op when it has ended) and wait for it."""
        self.process.kill()
        self.process.wait() if isinstance(self.process, subprocess.Popen) else self.process.join()
        self.connection.close()


def serve_socket(fd: int, parent: int) -> None:
    """A worker started by :func:`_start_worker` on POSIX: serve on the socket ``fd``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the starter's to handle: it ends the workers
    _serve(multiprocessing.connection.Connection(fd), parent)


def _start_worker() -> _Worker:
    """A fresh interpreter serving calls: its own session on POSIX, so that Ctrl-C in a
    terminal reaches the starter alone, and never a re-run of the caller's main script."""
    if os.name != "posix":  # no inheritable socket: multiprocessing's spawn (which imports __main__)
        context = multiprocessing.get_context("spawn")
        ours, theirs = context.Pipe()
        process: Any = context.Process(target=_serve, args=(theirs, os.getpid()), daemon=True)
        process.start()
        theirs.close()
        return _Worker(process, ours)
    mine, theirs_socket = socket.socketpair()
    code = (f"import sys; sys.path[:0] = {sys.path!r}; from moli.fleets.local_workers import serve_socket; "
            f"serve_socket({theirs_socket.fileno()}, {os.getpid()})")
    process = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.DEVNULL,
                               pass_fds=[theirs_socket.fileno()], start_new_session=True)
    theirs_socket.close()
    return _Worker(process, multiprocessing.connection.Connection(mine.detach()))


@contextlib.contextmanager
def worker_processes(function: Callable[..., Any], calls: Sequence[tuple[Any, ...]], workers: int,
                     timeout: float | None = None) -> Iterator[Done]:
    """Run ``function(*args)`` for every ``args`` of ``calls`` on ``workers`` processes.

    Parameters
    ----------
    function : callable
        A module-level function (pickled by reference).
    calls : sequence of tuples
    workers : int
        Processes at once (at most one per call).
    timeout : float, optional
        Seconds one call may run; a call over it is ended with its worker and fails
        with :class:`RecordTimeoutError`.

    Yields
    ------
    iterator of (int, object, BaseException or None)
        Per call, in completion order: its position, its value, and its error (its own
        exception, a timeout, a lost worker) or None. Leaving the block ends every
        worker still running.
    """
    pending = deque(range(len(calls)))
    lost_once: set[int] = set()
    team: list[_Worker] = []

    def outcome(worker: _Worker) -> tuple[int, Any, BaseException | None] | None:
        """The finished call's triple; None for the worker's word that it began, or when it died
        first (then its call is queued again)."""
        index = worker.index
        assert index is not None
        try:
            _, kind, value = worker.connection.recv()
        except (EOFError, OSError):  # the worker died before it could answer
            worker.end()
            team.remove(worker)
            if index in lost_once:
                return index, None, LostWorkerError(
                    "its worker process died twice (killed, out of memory or crashed), "
                    f"exit code {_exit_code(worker.process)}")
            lost_once.add(index)
            pending.appendleft(index)
            return None
        except Exception as exc:  # an answer this process cannot unpickle; the worker goes on
            kind, value = "error", exc
        if kind == "started":
            worker.started = time.monotonic()
            return None
        worker.index = None
        return (index, None, value) if kind == "error" else (index, value, None)

    def done() -> Done:
        while pending or any(worker.index is not None for worker in team):
            running = sum(worker.index is not None for worker in team)
            while len(team) < min(workers, len(pending) + running):
                team.append(_start_worker())
            for worker in team:
                if worker.index is None and pending:
                    worker.index, worker.started = pending.popleft(), None
                    with contextlib.suppress(OSError):  # a worker that died idle: its pipe's end shows it below
                        worker.connection.send((worker.index, function, calls[worker.index]))
            busy = [worker for worker in team if worker.index is not None]
            deadlines = [w.started + timeout for w in busy if timeout is not None and w.started is not None]
            wait = max(0.0, min(deadlines) - time.monotonic()) if deadlines else None
            ready = multiprocessing.connection.wait([w.connection for w in busy], wait)
            for worker in busy:
                if worker.connection in ready:  # an answer, or the end of the pipe of a worker that died
                    finished = outcome(worker)
                    if finished is not None:
                        yield finished
                elif timeout is not None and worker.started is not None \
                        and time.monotonic() - worker.started >= timeout:
                    index = worker.index
                    worker.end()
                    team.remove(worker)
                    yield index, None, RecordTimeoutError(
                        f"ran longer than the {timeout:g} s allowed; its worker process was ended")

    try:
        yield done()
    finally:
        _stop(team)


def _exit_code(process: Any) -> int | None:
    return process.returncode if isinstance(process, subprocess.Popen) else process.exitcode


def _stop(team: list[_Worker]) -> None:
    """Idle workers are asked to stop, busy ones killed; none is left running."""
    for worker in team:
        if worker.index is None:
            with contextlib.suppress(OSError, ValueError):
                worker.connection.send(None)
        else:
            worker.process.kill()
    deadline = time.monotonic() + STOP_GRACE_SECONDS
    for worker in team:
        with contextlib.suppress(subprocess.TimeoutExpired):
            if isinstance(worker.process, subprocess.Popen):
                worker.process.wait(max(0.0, deadline - time.monotonic()))
            else:
                worker.process.join(max(0.0, deadline - time.monotonic()))
        worker.end()
