"""A report figure written to its file: drawn once, with fewer tick objects.

``savefig`` draws a figure that has a layout engine twice (once to place it, with rendering
off, once to paint it), and the ticks cost the same in both; a PNG is drawn here once on the
figure's Agg canvas, after :mod:`moli.app.figure_ticks` has cut the tick objects to those
that show (docs/performance.md, "The report's figures drawn once").
"""

from __future__ import annotations

import io
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.image import imsave

from ..data.atomic_files import write_atomic
from ..errors import MoliError
from .figure_ticks import plain_log_labels, trim_ticks, unlabelled_minor_ticks_as_lines, unplaced_empty_labels

__all__ = ["DPI", "save_figure", "check_figure_suffix"]

DPI = 110  # a 7.5-inch figure some 800 pixels wide


def check_figure_suffix(path: Path, what: str) -> None:
    """Refuse, before any work, a figure file whose suffix names no format matplotlib writes."""
    formats = FigureCanvasAgg.get_supported_filetypes()
    if path.suffix and path.suffix[1:].lower() not in formats:
        raise MoliError(f"{what}: {path.name} names no figure format moli writes; give one of "
                        f"{', '.join('.' + name for name in sorted(formats))}")


def save_figure(fig: Figure, path: Path) -> bytes:
    """Write ``fig`` whole or not at all (:func:`moli.data.atomic_files.write_atomic`); its bytes.

    The format follows the suffix of ``path`` (PNG without one). A PNG of a figure on an Agg
    canvas is drawn once, on that canvas; any other file goes through ``savefig``.
    """
    trim_ticks(fig)
    unlabelled_minor_ticks_as_lines(fig)
    unplaced_empty_labels(fig)
    plain_log_labels(fig)
    buffer = io.BytesIO()
    fmt = path.suffix[1:].lower() or "png"
    if fmt == "png" and isinstance(fig.canvas, FigureCanvasAgg):
        dpi = fig.dpi
        fig.set_dpi(DPI)
        try:
            fig.canvas.draw()
            imsave(buffer, fig.canvas.buffer_rgba(), format="png", origin="upper", dpi=DPI)
        finally:
            fig.set_dpi(dpi)
    else:
        fig.savefig(buffer, format=fmt, dpi=DPI)
    write_atomic(path, buffer.getvalue())
    return buffer.getvalue()
