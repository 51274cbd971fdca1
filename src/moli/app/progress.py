"""What the command line shows on stderr while it works: a bar per phase.

The structure search has steps (the orders of the greedy path) and gets a bar that
fills; every other long phase (reading a file, the work after the path, the report)
gets a one-step bar that names the phase while it runs and gives its time when done,
so the screen never sits on a full bar while something else runs.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from typing import Any, Callable, Iterator

from tqdm import tqdm

from ..method.options import IdentifyOptions
from ..method.search.greedy_path import ScoredStep

__all__ = ["PathProgress", "Phases", "search_progress", "READING_SHOWN_AFTER"]

# Reading is where bad input is found: a read shorter than this shows no line, so a
# rejected file leaves stderr with its error line alone.
READING_SHOWN_AFTER = 1.0
RUNNING = "{desc} ..."
DONE = "{desc}: {elapsed}"


class PathProgress:
    """Progress bar over the orders of the greedy path.

    The bar appears with the first fitted order, so input rejected before the search
    starts leaves stderr with the error line alone.
    """

    def __init__(self, total: int) -> None:
        self.total = total
        self.bar: tqdm | None = None

    def __call__(self, step: ScoredStep) -> None:
        if self.bar is None:
            self.bar = tqdm(total=self.total, desc="structure search", unit="order", file=sys.stderr)
        self.bar.set_postfix_str(f"n={step.order} {list(step.indices)} VAF {step.mean_vaf:.1f}%", refresh=False)
        self.bar.update()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


class Phases:
    """One line per phase on stderr: ``NAME ...`` while it runs, ``NAME: 00:05`` when done.

    Call the object with a phase's name when the phase starts (it ends the one before;
    :func:`moli.identify` takes it as ``phase=``), or use :meth:`shown_after` for a phase
    whose line waits until it has run a while. Leaving the ``with`` block ends the last.
    """

    def __init__(self) -> None:
        self.bar: tqdm | None = None
        self.timer: threading.Timer | None = None
        self.lock = threading.Lock()
        self.running: object = None   # the running phase's token: a late timer shows nothing

    def __call__(self, name: str) -> None:
        self.shown_after(name, 0.0)

    def shown_after(self, name: str, seconds: float) -> None:
        """Start phase ``name``, its line shown only once it has run ``seconds``."""
        self.done()
        self.running = token = object()
        started = time.time()   # tqdm's clock: a line shown late still counts from here
        if seconds <= 0:
            self._show(name, token, started)
            return
        self.timer = threading.Timer(seconds, self._show, (name, token, started))
        self.timer.daemon = True
        self.timer.start()

    def _show(self, name: str, token: object, started: float) -> None:
        with self.lock:
            if token is self.running:
                self.bar = tqdm(total=1, desc=name, bar_format=RUNNING, file=sys.stderr)
                self.bar.start_t = started

    def done(self) -> None:
        """End the running phase: its line gives its time (nothing if it never showed)."""
        if self.timer is not None:
            self.timer.cancel()
            self.timer = None
        with self.lock:
            self.running = None
            if self.bar is not None:
                self.bar.bar_format, self.bar.n = DONE, 1
                self.bar.close()    # shows the line once more, done
                self.bar = None

    def __enter__(self) -> Phases:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.done()


@contextlib.contextmanager
def search_progress(options: IdentifyOptions, p: int) -> Iterator[tuple[PathProgress, Callable[[str], None]]]:
    """``progress=`` and ``phase=`` for :func:`moli.identify`: the search's bar over the orders
    of the path, closed when the first phase after the path starts, then a line per phase."""
    progress = PathProgress(max(options.path_end(p) - p + 1, 1))
    with Phases() as phases:

        def after_path(name: str) -> None:
            progress.close()        # the full bar stays above the phases that follow it
            phases(name)

        try:
            yield progress, after_path
        finally:
            progress.close()
