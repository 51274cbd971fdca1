"""Ticks made only where they show: the same figure from fewer matplotlib tick objects.

matplotlib's log locators return ticks a decade or more beyond the view on each side (the
minor one eight per decade), and an axis builds a tick (two marks, a grid line, two
labels) for every one of them, then updates each of them for every layout pass and draw:
on the report's grids of log axes those unseen ticks are a third of all. A locator trimmed
to the view gives the same ticks on the canvas (the axis draws only those in its view) at
the cost of the ones drawn.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import Locator

__all__ = ["InViewLocator", "trim_ticks"]

# A tick this close to the view's end, as a share of the view's width on the axis's scale,
# is kept: matplotlib draws ticks that round-off puts just outside the view.
EDGE_SHARE = 1e-6


class InViewLocator(Locator):
    """The ticks of ``locator`` that lie in the axis's view (its other answers unchanged)."""

    def __init__(self, locator: Locator) -> None:
        self.locator = locator

    def set_axis(self, axis: Any) -> None:
        super().set_axis(axis)
        self.locator.set_axis(axis)

    def __call__(self) -> np.ndarray:
        locs = np.asarray(self.locator(), dtype=float)
        scale = self.axis.get_transform()
        low, high = np.sort(scale.transform(np.asarray(self.axis.get_view_interval(), dtype=float)))
        edge = EDGE_SHARE * (high - low)
        with np.errstate(divide="ignore", invalid="ignore"):   # a log axis's ticks at or below 0
            where = scale.transform(locs) if locs.size else locs
        return locs[(where >= low - edge) & (where <= high + edge)]

    def tick_values(self, vmin: float, vmax: float) -> Any:
        return self.locator.tick_values(vmin, vmax)

    def nonsingular(self, v0: float, v1: float) -> tuple[float, float]:
        return self.locator.nonsingular(v0, v1)

    def view_limits(self, vmin: float, vmax: float) -> tuple[float, float]:
        return self.locator.view_limits(vmin, vmax)


def trim_ticks(fig: Figure) -> None:
    """Give every log axis of ``fig`` locators trimmed to its view; call after the plotting
    (setting a scale replaces an axis's locators). A linear axis's locator reaches one tick
    beyond each end at most: trimming it costs what it saves."""
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() != "log":
                continue
            for ticker in (axis.major, axis.minor):   # shared axes share their tickers
                if not isinstance(ticker.locator, InViewLocator):
                    trimmed = InViewLocator(ticker.locator)
                    trimmed.set_axis(axis)
                    ticker.locator = trimmed
