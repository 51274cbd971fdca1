"""The ``moli`` console script: its exit codes, and Ctrl-C as one line at any moment.

Exit codes (docs/cli.md): 0 the run is complete, 2 bad input, 3 a model was written from a
partial run, 130 interrupted with nothing written. This module imports nothing heavy, so that
Ctrl-C while the command's libraries load (most of a second on a cold start) is one line too.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import sys
import threading
from types import FrameType
from typing import Any

__all__ = ["COMPLETE", "USAGE_ERROR", "PARTIAL", "INTERRUPTED", "InterruptHold", "stop_interrupts", "interrupted",
           "is_interrupt", "main"]

COMPLETE = 0
USAGE_ERROR = 2
PARTIAL = 3
INTERRUPTED = 130  # 128 + SIGINT: what shells report for a command that Ctrl-C ended
INTERRUPTED_LINE = "moli: interrupted"
# set by main(): the process is the console script's, whose Ctrl-C handling this module may change
# for good; a command run from Python (click's test runner, a notebook) leaves its host's alone
_owns_process = False


def is_interrupt(exc: BaseException) -> bool:
    """Whether ``exc`` is Ctrl-C or was raised because of it.

    Ctrl-C inside a C extension's initialization (matplotlib's font module on a cold start)
    surfaces as ``ImportError: initialization failed`` raised from the KeyboardInterrupt.

    Examples
    --------
    >>> try:
    ...     try:
    ...         raise KeyboardInterrupt
    ...     except KeyboardInterrupt as cut:
    ...         raise ImportError("initialization failed") from cut
    ... except ImportError as exc:
    ...     is_interrupt(exc)
    True
    >>> is_interrupt(ValueError())
    False
    """
    seen: set[int] = set()
    link: BaseException | None = exc
    while link is not None and id(link) not in seen:     # a chain may loop back on itself
        if isinstance(link, KeyboardInterrupt):
            return True
        seen.add(id(link))
        link = link.__cause__ or link.__context__
    return False


def _in_main_thread() -> bool:
    """Signal handlers can be set only there (a command run from another thread keeps Python's)."""
    return threading.current_thread() is threading.main_thread()


class InterruptHold:
    """Ctrl-C noted instead of raised, from :meth:`start` to :meth:`release`.

    It brackets the writing of a finished result, so that Ctrl-C cannot lose it half way; the
    caller acts on the Ctrl-C (:meth:`release` says whether one came) once the result is safe.
    Outside the main thread both do nothing. As a context manager, it is released on leaving.

    Examples
    --------
    >>> hold = InterruptHold()
    >>> hold.start()
    >>> hold.release()
    False
    """

    def __init__(self) -> None:
        self.received = False
        self._previous: Any = None
        self._held = False

    def __enter__(self) -> InterruptHold:
        return self

    def __exit__(self, *exc: object) -> None:
        """Released on the way out, whatever ended the block (held or not)."""
        self.release()

    def start(self) -> None:
        """Note Ctrl-C from now on instead of raising KeyboardInterrupt."""
        if _in_main_thread() and not self._held:
            self._previous = signal.signal(signal.SIGINT, self._note)
            self._held = True

    def release(self) -> bool:
        """Restore the handler that was in place; whether Ctrl-C came while held."""
        if self._held:
            # None: a handler set outside Python, which cannot be put back; Python's own instead
            signal.signal(signal.SIGINT, signal.default_int_handler if self._previous is None else self._previous)
            self._held = False
        return self.received

    def _note(self, signum: int, frame: FrameType | None) -> None:
        self.received = True


def stop_interrupts() -> None:
    """Ignore further Ctrl-C in the console script: the command is ending with its message and
    exit code, and a second Ctrl-C while it says so would print a traceback instead."""
    if _owns_process and _in_main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def interrupted(written: str | None = None) -> int:
    """End a command on Ctrl-C: further Ctrl-C ignored, one line on stderr; the exit code.

    Parameters
    ----------
    written : str, optional
        The model file the command had written (shown as given): the run was partial (3), else
        nothing was written (130).

    Returns
    -------
    int
    """
    stop_interrupts()
    print(INTERRUPTED_LINE if written is None else f"{INTERRUPTED_LINE} after writing {written}", file=sys.stderr)
    return INTERRUPTED if written is None else PARTIAL


def _flush_standard_streams() -> None:
    """Before ``os._exit``, which would drop what they still buffer."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            stream.flush()


def _end_at_once_on_interrupt(status: int) -> None:
    """From here the run's work and exit code are settled: Ctrl-C while the interpreter shuts
    down (its exit handlers, worker threads) ends the process at once with that code."""
    _flush_standard_streams()

    def end(signum: int, frame: FrameType | None) -> None:
        os.write(2, f"{INTERRUPTED_LINE}\n".encode())
        os._exit(status)

    if _in_main_thread():
        signal.signal(signal.SIGINT, end)


def _redeliver_lost_interrupts(previous: Any) -> Any:
    """A ``sys.unraisablehook`` that sends Ctrl-C again when Python had to drop it.

    Ctrl-C that lands inside a finalizer or weakref callback (the import system's module-lock
    callbacks, most of all) cannot propagate: Python prints it as "Exception ignored" with a
    traceback and the run goes on as if no Ctrl-C had come. A thread raises SIGINT again once the
    hook has returned: raised while the hook runs, the KeyboardInterrupt would be dropped the same
    way. The thread is not a daemon, so the interpreter joins it before it shuts down instead of
    tearing itself down under a thread still running. Every other unraisable exception goes to
    ``previous``.
    """

    def hook(unraisable: Any) -> None:
        if not (isinstance(unraisable.exc_value, BaseException) and is_interrupt(unraisable.exc_value)):
            previous(unraisable)
            return
        returned = threading.Event()

        def send_again() -> None:
            returned.wait()
            signal.raise_signal(signal.SIGINT)

        try:
            threading.Thread(target=send_again, name="moli-ctrl-c", daemon=False).start()
        except RuntimeError:    # the interpreter is shutting down: the run's exit code is settled
            pass
        finally:
            returned.set()

    return hook


def main() -> None:
    """Entry point of the ``moli`` console script and of ``python -m moli``."""
    global _owns_process
    _owns_process = True
    # registered first, so run last of the exit handlers: Ctrl-C after them, while the interpreter
    # restores the default handler and exits, would end the process by the signal instead of the code
    atexit.register(stop_interrupts)
    sys.unraisablehook = _redeliver_lost_interrupts(sys.unraisablehook)
    code: Any = COMPLETE
    try:
        from .cli import main as run_command   # click, numpy, scipy: most of a second on a cold start

        run_command()
    except SystemExit as ended:
        code = ended.code
    except BaseException as exc:               # Ctrl-C while the libraries load, before any command runs
        if not is_interrupt(exc):
            raise
        # no command ran and nothing was written, and the interpreter's shutdown after a library's
        # import was cut short can crash it (a fatal "PyThreadState_Get" error, 3 runs in 900
        # with Ctrl-C 0.3-0.7 s in): it is skipped
        code = interrupted()
        _flush_standard_streams()
        os._exit(code)
    _end_at_once_on_interrupt(code if isinstance(code, int) else int(code is not None))
    sys.exit(code)
