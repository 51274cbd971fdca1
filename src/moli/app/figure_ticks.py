"""Ticks made only where they show: the same figure from fewer matplotlib tick objects.

matplotlib's log locators return ticks a decade or more beyond the view on each side (the
minor one eight per decade), and an axis builds a tick (two marks, a grid line, two
labels) for every one of them, then updates each of them for every layout pass and draw:
on the report's grids of log axes those unseen ticks are a third of all. A locator trimmed
to the view gives the same ticks on the canvas (the axis draws only those in its view) at
the cost of the ones drawn.

Of the ticks left, the minor ticks of a log axis spanning a decade or more are most, and
they carry no label there: each is two marks and a grid line. Drawn instead as one line of
markers per side and one collection of grid lines per axis, in the ticks' own styles, they
give the same pixels (to antialiasing) at a fraction of the cost.

An axis places its label below (or beside) its tick labels, measuring them again for every
layout pass and draw; in a grid of channels most axes have no label to place.

A log axis labels its ticks in mathtext (``10^{-2}`` set as a formula), which is parsed and
laid out glyph by glyph; the same label in plain text with Unicode superscripts reads the
same and is set as one string.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np
from matplotlib.axis import Axis
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import Formatter, LogFormatterSciNotation, Locator, NullLocator

__all__ = ["InViewLocator", "PlainLogFormatter", "in_view", "plain_log_labels", "trim_ticks",
           "unlabelled_minor_ticks_as_lines", "unplaced_empty_labels"]

# The labels a log axis's formatter sets in mathtext: "$\mathdefault{10^{-2}}$",
# "$\mathdefault{2\times10^{0}}$", "$\mathdefault{0.5}$". Anything else is kept as it is.
MATHTEXT_LABEL = re.compile(r"\$\\mathdefault\{(.*)\}\$")
SUPERSCRIPT = re.compile(r"\^\{([-0-9]+)\}")
PLAIN_REST = re.compile(r"[-0-9.]*")
SUPERSCRIPT_CHARACTERS = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")
# Log-axis labels in this range are written as plain numbers (at most four characters from
# 0.001 up to 9000); beyond it as powers of ten, shorter there than the digits.
PLAIN_LOW, PLAIN_HIGH = 1e-3, 1e4

# A tick this close to the view's end, as a share of the view's width on the axis's scale,
# is kept: matplotlib draws ticks that round-off puts just outside the view.
EDGE_SHARE = 1e-6


def in_view(axis: Axis, locs: np.ndarray) -> np.ndarray:
    """The tick locations ``locs`` of ``axis`` that lie in its view (those it draws)."""
    scale = axis.get_transform()
    low, high = np.sort(scale.transform(np.asarray(axis.get_view_interval(), dtype=float)))
    edge = EDGE_SHARE * (high - low)
    with np.errstate(divide="ignore", invalid="ignore"):   # a log axis's ticks at or below 0
        where = scale.transform(locs) if locs.size else locs
    return locs[(where >= low - edge) & (where <= high + edge)]


class InViewLocator(Locator):
    """The ticks of ``locator`` that lie in the axis's view (its other answers unchanged)."""

    def __init__(self, locator: Locator) -> None:
        self.locator = locator

    def set_axis(self, axis: Any) -> None:
        super().set_axis(axis)
        self.locator.set_axis(axis)

    def __call__(self) -> np.ndarray:
        return in_view(self.axis, np.asarray(self.locator(), dtype=float))

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


def _minor_lines(axis: Axis, locs: np.ndarray) -> list[Line2D | LineCollection]:
    """The marks and grid lines of ``axis``'s minor ticks at ``locs``, in one artist each."""
    ax = axis.axes
    horizontal = axis is ax.xaxis
    transform = ax.get_xaxis_transform() if horizontal else ax.get_yaxis_transform()

    def at(across: float) -> tuple[np.ndarray, np.ndarray]:
        fixed = np.full(len(locs), across)
        return (locs, fixed) if horizontal else (fixed, locs)

    tick = axis.get_minor_ticks(1)[0]
    lines: list[Line2D | LineCollection] = []
    for mark, across in ((tick.tick1line, 0.0), (tick.tick2line, 1.0)):
        if mark.get_visible():
            lines.append(Line2D(*at(across), transform=transform, linestyle="none", marker=mark.get_marker(),
                                markersize=mark.get_markersize(), markeredgewidth=mark.get_markeredgewidth(),
                                color=mark.get_markeredgecolor(), zorder=axis.get_zorder(), clip_on=False))
    grid = tick.gridline
    if grid.get_visible():
        segments = np.stack([np.column_stack(at(0.0)), np.column_stack(at(1.0))], axis=1)
        lines.append(LineCollection(segments, transform=transform, colors=[grid.get_color()], alpha=grid.get_alpha(),
                                    linewidths=grid.get_linewidth(), linestyles=grid.get_linestyle(),
                                    zorder=axis.get_zorder()))
    return lines


def unlabelled_minor_ticks_as_lines(fig: Figure) -> None:
    """Draw the minor ticks of every log axis of ``fig`` whose minor ticks carry no label
    (its view spans a decade or more) as lines added to its axes, and remove the ticks.

    Call after the plotting, once the views are final: the lines stay where the ticks were.
    Shared axes share their locators, so every axis's ticks are read before any is removed.
    """
    done: list[tuple[Axis, list[Line2D | LineCollection]]] = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() != "log" or isinstance(axis.get_minor_locator(), NullLocator):
                continue
            locs = in_view(axis, np.asarray(axis.get_minorticklocs(), dtype=float))
            if locs.size and not any(axis.get_minor_formatter().format_ticks(locs)):
                done.append((axis, _minor_lines(axis, locs)))
    for axis, lines in done:
        for line in lines:
            axis.axes.add_artist(line)
        axis.set_minor_locator(NullLocator())


def unplaced_empty_labels(fig: Figure) -> None:
    """Fix the place of every empty axis label of ``fig``, so that no layout pass or draw
    measures the axis's tick labels to place it. An empty label draws nothing and the
    layout ignores it (its extent has no width), wherever it is."""
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if not axis.label.get_text():
                axis.set_label_coords(0.5, 0.5)


class PlainLogFormatter(Formatter):
    """The labels of ``formatter`` (a log axis's), mathtext turned into plain text: a value from
    :data:`PLAIN_LOW` up to :data:`PLAIN_HIGH` as a plain number (``0.01``, ``6``, ``40``), one
    beyond as a power (``10⁻⁵``, ``2×10⁻⁵``). Which ticks get a label is the formatter's choice.

    ``6×10⁰ 4×10⁰ 3×10⁰`` on an axis spanning less than a decade read as clutter where ``6 4 3``
    read at a glance."""

    def __init__(self, formatter: Formatter) -> None:
        self.formatter = formatter

    def set_axis(self, axis: Any) -> None:
        super().set_axis(axis)
        self.formatter.set_axis(axis)

    def set_locs(self, locs: Any) -> None:
        super().set_locs(locs)
        self.formatter.set_locs(locs)

    def __call__(self, x: float, pos: int | None = None) -> str:
        label = self.formatter(x, pos)
        match = MATHTEXT_LABEL.fullmatch(label)
        if match is None or not PLAIN_REST.fullmatch(SUPERSCRIPT.sub("", match.group(1)).replace("\\times", "")):
            return label
        if PLAIN_LOW <= abs(x) < PLAIN_HIGH:
            return f"{x:.4g}".replace("-", "−")
        body = SUPERSCRIPT.sub(lambda power: power.group(1).translate(SUPERSCRIPT_CHARACTERS), match.group(1))
        return body.replace("\\times", "×").replace("-", "−")


def plain_log_labels(fig: Figure) -> None:
    """Give every log axis of ``fig`` whose labels come from matplotlib's scientific-notation
    formatter the same labels in plain text (:class:`PlainLogFormatter`)."""
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() != "log":
                continue
            for ticker in (axis.major, axis.minor):   # shared axes share their tickers
                if isinstance(ticker.formatter, LogFormatterSciNotation):
                    plain = PlainLogFormatter(ticker.formatter)
                    plain.set_axis(axis)
                    ticker.formatter = plain
