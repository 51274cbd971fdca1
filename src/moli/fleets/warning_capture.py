"""Each thread's warnings in its own list, the caller's warning filters restored.

``warnings.catch_warnings`` swaps process-wide state (the filter list and
``showwarning``); entered in several threads at once, one thread's warnings land in
another's list and the last to leave restores a state that is not the caller's (an
``"always"`` filter left behind). :func:`thread_warnings` installs one hook for all
the threads that capture at the same time, routes each warning to the list of the
thread that raised it, and puts the caller's state back when the last thread leaves.
"""

from __future__ import annotations

import contextlib
import threading
import warnings
from typing import Any, Iterator

__all__ = ["thread_warnings"]

_lock = threading.Lock()
_local = threading.local()
_saved: dict[str, Any] = {}
_users = 0


def _route(message: Warning | str, category: type[Warning], filename: str, lineno: int,
           file: Any = None, line: str | None = None) -> None:
    caught = getattr(_local, "caught", None)
    if caught is None:  # a thread that is not capturing: shown as before
        _saved["showwarning"](message, category, filename, lineno, file, line)
    else:
        caught.append(warnings.WarningMessage(message, category, filename, lineno, file, line))


@contextlib.contextmanager
def thread_warnings() -> Iterator[list[warnings.WarningMessage]]:
    """Every warning this thread raises inside the block (all shown: an ``"always"`` filter).

    Yields
    ------
    list of warnings.WarningMessage
        Filled as the block runs; other threads' warnings never enter it.
    """
    global _users
    with _lock:
        if _users == 0:
            _saved.update(filters=warnings.filters[:], showwarning=warnings.showwarning)
            warnings.simplefilter("always")
            warnings.showwarning = _route
        _users += 1
    outer = getattr(_local, "caught", None)
    _local.caught = caught = []
    try:
        yield caught
    finally:
        _local.caught = outer
        with _lock:
            _users -= 1
            if _users == 0:
                warnings.resetwarnings()  # also drops the decisions cached under the "always" filter
                warnings.filters.extend(_saved["filters"])
                warnings.showwarning = _saved["showwarning"]
