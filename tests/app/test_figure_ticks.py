"""Ticks trimmed to the view, minor ticks as lines, labels placed only where they show:
the same pixels from fewer tick objects."""

from __future__ import annotations

import io

import numpy as np
import pytest

import moli
from matplotlib.collections import LineCollection
from matplotlib.ticker import LogFormatterSciNotation, NullLocator

from moli.app import figures, frequency_figures
from moli.app.figure_files import DPI, save_figure
from moli.app.figure_ticks import (PlainLogFormatter, plain_log_labels, trim_ticks, unlabelled_minor_ticks_as_lines,
                                   unplaced_empty_labels)


def _model() -> moli.StateSpaceModel:
    """Two inputs, two outputs: shared axes in a grid, small enough to draw quickly."""
    A = np.array([[0.9, 0.1], [0.0, 0.5]])
    return moli.StateSpaceModel(A, np.eye(2), np.array([[1.0, 0.0], [0.3, 1.0]]), np.zeros((2, 2)))


def _pixels(fig) -> bytes:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="rgba", dpi=60)
    return buffer.getvalue()


def _in_view(axis, locs: np.ndarray) -> np.ndarray:
    low, high = sorted(axis.get_view_interval())
    return locs[(locs >= low * (1 - 1e-9)) & (locs <= high * (1 + 1e-9))] if axis.get_scale() == "log" else \
        locs[(locs >= low - 1e-9 * (high - low)) & (locs <= high + 1e-9 * (high - low))]


@pytest.mark.parametrize("draw", [
    lambda model: frequency_figures.bode_magnitude(model, points=40),  # shared log axes, minor ticks
    lambda model: frequency_figures.singular_values(model, points=40),  # one log-log axes, a legend
])
def test_trimmed_ticks_draw_the_same_pixels(draw):
    model = _model()
    plain, trimmed = draw(model), draw(model)
    trim_ticks(trimmed)
    assert _pixels(plain) == _pixels(trimmed)


def test_a_saved_report_figure_holds_ticks_only_in_its_view(tmp_path):
    fig = frequency_figures.bode_magnitude(_model())
    save_figure(fig, tmp_path / "magnitude.png")
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for locs, ticks in ((axis.get_majorticklocs(), axis.majorTicks),
                                (axis.get_minorticklocs(), axis.minorTicks)):
                # the locator's own answer reaches a decade beyond the view on log axes
                assert len(_in_view(axis, locs)) == len(locs)
                # the axis builds one tick per location (and one, unused, where there is none)
                assert len(ticks) == max(1, len(locs))


def _rgb(png: bytes) -> np.ndarray:
    from PIL import Image
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def _saved_by_matplotlib(fig) -> bytes:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


@pytest.mark.parametrize("draw", [
    lambda model: frequency_figures.bode_magnitude(model, points=40),
    lambda model: figures.step_responses(model, 30),   # linear axes, labels on the outer ones only
])
def test_a_saved_figure_draws_what_savefig_draws(tmp_path, draw):
    """The figure is drawn once on its canvas instead of savefig's two passes; the minor
    ticks of wide log axes become lines and empty labels are not placed. The picture is the
    same: matplotlib's own savefig of the same figure, with the same tick locations and label
    texts, is the truth."""
    model = _model()
    reference = draw(model)
    trim_ticks(reference)
    plain_log_labels(reference)
    expected = _rgb(_saved_by_matplotlib(reference))
    saved = _rgb(save_figure(draw(model), tmp_path / "figure.png"))
    assert saved.shape == expected.shape
    differ = np.abs(saved - expected).max(axis=2)
    # the lines replacing the minor ticks are antialiased along other pixel boundaries than
    # the ticks' own lines: a few pixels of their edges move by a shade; no pixel changes
    # from line to background (a difference of more than a third of the range)
    assert (differ > 0).mean() < 1e-3
    assert differ.max() < 85


def test_minor_ticks_that_carry_labels_stay_ticks():
    """An axis spanning less than a decade labels some minor ticks (2×10⁰, 3×10⁰, ...):
    those stay ticks with their labels; a wide axis's unlabelled ones become lines."""
    fig = figures.new_figure(4, 3)
    ax = fig.subplots()
    ax.loglog([1e-2, 1e2], [2.0, 6.0])
    ax.set_xlim(1e-2, 1e2)
    unlabelled_minor_ticks_as_lines(fig)
    assert isinstance(ax.xaxis.get_minor_locator(), NullLocator)
    assert not isinstance(ax.yaxis.get_minor_locator(), NullLocator)
    assert any(ax.yaxis.get_minor_formatter().format_ticks(ax.yaxis.get_minorticklocs()))
    # the x axis's minor grid is off here: its ticks' marks (bottom side) are the one line added
    added = list(ax.lines)[1:]
    # 8 minor ticks per decade over the 4 decades of the view, none beyond it (its locator's
    # answer reaches a decade further on each side, where the axis would draw nothing)
    assert len(added) == 1 and len(added[0].get_xdata()) == 8 * 4
    assert not [artist for artist in ax.get_children() if isinstance(artist, LineCollection)]
    unlabelled_minor_ticks_as_lines(fig)   # a second call adds nothing
    assert len(ax.lines) == 2


def test_empty_labels_are_not_placed_and_named_ones_are():
    fig, axes = figures.channel_grid(_model(), "to", "time")
    unplaced_empty_labels(fig)
    for ax in axes.flat:
        for axis in (ax.xaxis, ax.yaxis):
            assert axis._autolabelpos == bool(axis.label.get_text())


@pytest.mark.parametrize("value, mathtext, plain", [
    (1e-2, r"$\mathdefault{10^{-2}}$", "0.01"),
    (1e3, r"$\mathdefault{10^{3}}$", "1000"),
    (3.0, r"$\mathdefault{3\times10^{0}}$", "3"),
    (40.0, r"$\mathdefault{4\times10^{1}}$", "40"),
    (2e-5, r"$\mathdefault{2\times10^{-5}}$", "2×10⁻⁵"),
    (1e5, r"$\mathdefault{10^{5}}$", "10⁵"),
])
def test_plain_log_labels_read_as_matplotlib_mathtext(value, mathtext, plain):
    fig = figures.new_figure(4, 3)
    ax = fig.subplots()
    ax.loglog([value / 3, value * 3], [1, 2])
    ax.set_xlim(value / 3, value * 3)      # under a decade: the minor ticks are labelled too
    formatter = ax.xaxis.get_major_formatter() if np.isclose(np.log10(value) % 1, 0) else ax.xaxis.get_minor_formatter()
    formatter.set_locs([value])
    assert formatter(value) == mathtext     # what the plain text stands for
    plain_log_labels(fig)
    wrapped = ax.xaxis.get_major_formatter() if np.isclose(np.log10(value) % 1, 0) else ax.xaxis.get_minor_formatter()
    assert isinstance(wrapped, PlainLogFormatter)
    wrapped.set_locs([value])
    assert wrapped(value) == plain


def test_plain_log_labels_keep_what_they_cannot_read():
    class Odd(LogFormatterSciNotation):
        def __call__(self, x, pos=None):
            return r"$\mathdefault{\alpha_{1}}$"
    assert PlainLogFormatter(Odd())(10.0) == r"$\mathdefault{\alpha_{1}}$"
