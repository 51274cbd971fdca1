"""One BLAS thread inside moli's computations, the caller's setting restored after.

moli's arithmetic is thousands of small factorizations and products (hundreds of rows by tens
of columns, long records folded in blocks of 2048 rows), too small for a multi-threaded BLAS
to share out. Between two such calls OpenBLAS's idle threads go to sleep, and waking them
costs more than the call itself: with the default thread count of a 2-core machine, idle
otherwise, the likelihood's QR factors of ``moli.impulse_response`` on the built-in example
took 4 ms each instead of 0.15 ms, and the call 10.3 s instead of 0.79 s (docs/performance.md,
"BLAS threads"). Every public computation of moli therefore runs with BLAS limited to one
thread (threadpoolctl), which is also how the benchmarks run, so a user gets the arithmetic
the benchmarks measured. ``MOLI_BLAS_THREADS`` sets another limit (a positive integer), or
``keep`` leaves the process's BLAS threads as they are.

The limit is process-wide while it holds (OpenBLAS's pool is shared by every thread): it is set
by the first of concurrent moli calls to enter and restored by the last to leave, whichever
threads those are. Each public function holds it around its body, not by a decorator, so that
its warnings still point at its caller.
"""

from __future__ import annotations

import contextlib
import os
import threading
from typing import Any, Iterator

from ..errors import OptionError

__all__ = ["ENVIRONMENT_VARIABLE", "MAX_THREADS", "blas_thread_limit", "limited_blas"]

ENVIRONMENT_VARIABLE = "MOLI_BLAS_THREADS"
KEEP = "keep"
# More threads than any machine moli runs on has cores; larger numbers overflow the C int that
# OpenBLAS takes (2**31 became 3 threads) or fail in ctypes, so they are refused by name.
MAX_THREADS = 1024

_lock = threading.Lock()
_depth = 0
_limiter: Any = None
_controller: Any = None


def blas_thread_limit() -> int | None:
    """The BLAS thread limit of moli's computations: ``$MOLI_BLAS_THREADS``, 1 when unset, None for ``keep``.

    Raises
    ------
    OptionError
        The variable holds something else than an integer from 1 to :data:`MAX_THREADS` or ``keep``.
    """
    text = os.environ.get(ENVIRONMENT_VARIABLE, "1").strip()
    if text.lower() == KEEP:
        return None
    if not (text.isascii() and text.isdigit()) or not 1 <= int(text) <= MAX_THREADS:
        raise OptionError(f"the environment variable {ENVIRONMENT_VARIABLE} must be an integer from 1 to "
                          f"{MAX_THREADS} (BLAS threads inside moli's computations) or {KEEP!r} (leave BLAS "
                          f"as it is), got {text!r}")
    return int(text)


def _threadpool_controller() -> Any:
    """threadpoolctl's view of the BLAS libraries loaded, built once, with numpy's and scipy's loaded
    (each wheel carries its own OpenBLAS; a library loaded after it is built would go unlimited)."""
    global _controller
    if _controller is None:
        import scipy.linalg  # noqa: F401
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    return _controller


def _take_openblas_pool() -> None:
    """Let this thread set OpenBLAS's shared pool.

    threadpoolctl 3.8 and later let one thread at a time set it, the first to try, until that
    thread lets go, and ignore the others without a word. moli counts its calls across threads, so
    the thread that enters first or leaves last must be able to set the pool whichever thread set
    it before (earlier versions have no such owner).
    """
    import threadpoolctl

    release = getattr(getattr(threadpoolctl, "OpenBLASController", None), "clear_controlling_thread", None)
    if release is not None:
        release(force=True)


@contextlib.contextmanager
def limited_blas() -> Iterator[None]:
    """BLAS limited to :func:`blas_thread_limit` threads while the block runs (nested blocks: the outermost decides)."""
    global _depth, _limiter
    limit = blas_thread_limit()
    with _lock:
        if _depth == 0 and limit is not None:
            controller = _threadpool_controller()
            _take_openblas_pool()
            _limiter = controller.limit(limits=limit, user_api="blas")
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0 and _limiter is not None:
                _take_openblas_pool()
                _limiter.restore_original_limits()
                _take_openblas_pool()            # and let go of it
                _limiter = None


def _forget_after_fork() -> None:
    """A child forked while another thread held the lock, or inside a moli call, starts afresh."""
    global _lock, _depth, _limiter
    _lock, _depth, _limiter = threading.Lock(), 0, None


if hasattr(os, "register_at_fork"):      # POSIX
    os.register_at_fork(after_in_child=_forget_after_fork)
