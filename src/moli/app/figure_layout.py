"""A grid of axes placed from the sizes of its texts, measured without building tick objects.

matplotlib's constrained layout finds each axes' decorations by asking it for its tight
bounding box, which builds, updates and measures every tick of the axes, twice per draw
(its two passes), before the draw builds and measures them again to paint them: on the
report's grids of channels the layout cost 40 % of the figures' drawing (docs/performance.md,
"The report's figures placed from their texts"). The report's figures are regular grids
whose decorations are known: tick labels, axis labels, titles, a figure title and legends
above the grid. :class:`GridLayout` measures those texts alone (a tick label is laid out
from its string, not from a tick) and sets the grid's margins and gaps so that each fits.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib import rcParams
from matplotlib.axes import Axes
from matplotlib.axis import Axis
from matplotlib.figure import Figure
from matplotlib.layout_engine import LayoutEngine
from matplotlib.text import Text

from .figure_ticks import in_view

__all__ = ["GridLayout"]

PAD_POINTS = 4.0       # between a text and the figure's edge, and between neighbours' decorations
PASSES = 2             # as constrained layout's: the second measures the ticks of the places the first set


def _points(renderer: Any, value: float) -> float:
    return float(renderer.points_to_pixels(value))


def _text_size(renderer: Any, text: Text) -> tuple[float, float]:
    """Width and height in pixels of ``text`` as drawn (zero when empty or hidden)."""
    if not text.get_visible() or not text.get_text():
        return 0.0, 0.0
    box = text.get_window_extent(renderer)
    return box.width, box.height


def _tick_labels(fig: Figure, renderer: Any, axis: Axis, side: str) -> tuple[float, float, float]:
    """Width and height of the widest and tallest tick label of ``axis`` on ``side`` (its
    extent across the axis, then along it; minor ticks' labels too, as a log axis spanning
    less than a decade has), and the tick's length and pad before it; zeros when that side
    carries no labels.

    The labels' style (shown or not, font, rotation, pad) is read from the axis's first
    major tick, which the draw builds anyway; the strings come from its locators and
    formatters, trimmed to the view.
    """
    tick = axis.get_major_ticks(1)[0]
    label = tick.label1 if side in ("bottom", "left") else tick.label2
    if not label.get_visible():
        return 0.0, 0.0, 0.0
    labels = set()
    for locs, formatter in ((axis.get_majorticklocs(), axis.get_major_formatter()),
                            (axis.get_minorticklocs(), axis.get_minor_formatter())):
        labels.update(formatter.format_ticks(in_view(axis, np.asarray(locs, dtype=float))))
    labels.discard("")
    if not labels:
        return 0.0, 0.0, 0.0
    across = along = 0.0
    for text in labels:
        box = Text(text=text, fontproperties=label.get_fontproperties(), rotation=label.get_rotation(),
                   figure=fig).get_window_extent(renderer)
        width, height = (box.height, box.width) if axis is axis.axes.xaxis else (box.width, box.height)
        across, along = max(across, width), max(along, height)
    return across, along, _points(renderer, tick.get_tick_padding() + tick.get_pad())


def _offset(fig: Figure, renderer: Any, axis: Axis) -> float:
    """Height of the axis's offset or multiplier text (``1e-3``) with its pad, zero when it
    shows none."""
    offset = axis.get_major_formatter().get_offset()
    if not offset or not axis.offsetText.get_visible():
        return 0.0
    text = Text(text=offset, fontproperties=axis.offsetText.get_fontproperties(), figure=fig)
    return _text_size(renderer, text)[1] + _points(renderer, axis.OFFSETTEXTPAD)


def _decorations(fig: Figure, renderer: Any, ax: Axes) -> dict[str, float]:
    """Pixels each side of ``ax`` needs for its texts: tick labels, axis labels, titles."""
    across, along, before = _tick_labels(fig, renderer, ax.yaxis, "left")
    x_across, x_along, x_before = _tick_labels(fig, renderer, ax.xaxis, "bottom")
    ylabel = _text_size(renderer, ax.yaxis.label)[0]
    # a tick label at an end of its axis reaches past the end by half its extent along the axis
    left = max(across + before + (ylabel + _points(renderer, ax.yaxis.labelpad) if ylabel else 0.0), x_along / 2)
    xlabel = _text_size(renderer, ax.xaxis.label)[1]
    bottom = max(x_across + x_before + (xlabel + _points(renderer, ax.xaxis.labelpad) if xlabel else 0.0)
                 + _offset(fig, renderer, ax.xaxis), along / 2)
    title = max((_text_size(renderer, t)[1] for t in _titles(ax)), default=0.0)
    # matplotlib lifts the titles above the y axis's offset text where it has one
    top = max((title + _points(renderer, rcParams["axes.titlepad"]) if title else 0.0)
              + _offset(fig, renderer, ax.yaxis), along / 2)
    return {"left": left, "bottom": bottom, "top": top, "right": x_along / 2}


def _titles(ax: Axes) -> list[Text]:
    """The axes' titles (left, centre, right) that have text: its texts that are not
    annotations or texts placed in it."""
    shown = {ax.get_title(loc) for loc in ("left", "center", "right")} - {""}
    return [child for child in ax.get_children() if isinstance(child, Text) and child.get_text() in shown
            and child not in ax.texts]


class GridLayout(LayoutEngine):
    """Margins and gaps of a figure's one grid of axes set from the sizes of its texts.

    Above the grid: the figure's title (a figure text in its upper half) and its legends
    (placed at the top left, one under the other). It places what the report's figures
    have: tick labels and axis labels on the left and at the bottom, offset texts, titles
    no wider than their column. A figure whose axes do not all lie on one grid keeps its
    positions.
    """

    _adjust_compatible = False
    _colorbar_gridspec = False

    def execute(self, fig: Figure) -> None:
        specs = [ax.get_subplotspec() for ax in fig.axes]
        if not specs or any(spec is None for spec in specs) or \
                len({id(spec.get_gridspec()) for spec in specs}) != 1:
            return
        # the tick locators choose their ticks by the axes' length, so the ticks measured in
        # matplotlib's default places can differ from those of the new ones: measured again there
        for _ in range(PASSES):
            _place(fig, specs)


def _place(fig: Figure, specs: list[Any]) -> None:
    """Set the margins and gaps of the grid of ``specs`` from the texts as they are now."""
    grid = specs[0].get_gridspec()
    rows, cols = grid.get_geometry()
    # the canvas's own renderer, whichever backend is drawing (a PDF or SVG file's too): what
    # matplotlib's own layout engines use
    renderer = fig._get_renderer()
    width, height = fig.bbox.width, fig.bbox.height
    pad = _points(renderer, PAD_POINTS)
    need = {side: np.zeros((rows, cols)) for side in ("left", "bottom", "top", "right")}
    for ax, spec in zip(fig.axes, specs):
        for side, value in _decorations(fig, renderer, ax).items():
            at = (spec.rowspan.stop - 1 if side == "bottom" else spec.rowspan.start,
                  spec.colspan.stop - 1 if side == "right" else spec.colspan.start)
            need[side][at] = max(need[side][at], value)
    above = pad
    for text in (t for t in fig.texts if t.get_position()[1] > 0.5):   # the figure's title
        text.set_y(1.0 - above / height)
        text.set_verticalalignment("top")
        above += _text_size(renderer, text)[1] + pad
    for legend in fig.legends:             # each made with loc="upper left"
        legend.set_bbox_to_anchor((0.0, 1.0 - (above - pad) / height), transform=fig.transFigure)
        # the legend stands its border pad below the anchor
        above += legend.get_window_extent(renderer).height + _points(renderer, legend.borderaxespad
                                                                     * legend.prop.get_size_in_points()) + pad
    left = need["left"][:, 0].max() + pad
    right = need["right"][:, -1].max() + pad
    bottom = need["bottom"][-1].max() + pad
    top = need["top"][0].max() + above
    gap_w = max((need["left"][:, j].max() + need["right"][:, j - 1].max() for j in range(1, cols)),
                default=0.0) + pad
    gap_h = max((need["bottom"][i - 1].max() + need["top"][i].max() for i in range(1, rows)),
                default=0.0) + pad
    cell_w = (width - left - right - (cols - 1) * gap_w) / cols
    cell_h = (height - bottom - top - (rows - 1) * gap_h) / rows
    if cell_w <= 0 or cell_h <= 0:         # texts larger than the figure: the places stay
        return
    grid.update(left=left / width, right=1 - right / width, bottom=bottom / height, top=1 - top / height,
                wspace=gap_w / cell_w, hspace=gap_h / cell_h)
    for ax, spec in zip(fig.axes, specs):  # each axes takes its cell's new place
        ax.set_subplotspec(spec)
