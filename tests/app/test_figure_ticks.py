"""Ticks trimmed to the view: the same pixels from fewer tick objects."""

from __future__ import annotations

import io

import numpy as np
import pytest

import moli
from moli.app import figures
from moli.app.figure_ticks import trim_ticks


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
    lambda model: figures.bode_magnitude(model, points=40),  # shared log axes, minor ticks
    lambda model: figures.singular_values(model, points=40),  # one log-log axes, a legend
])
def test_trimmed_ticks_draw_the_same_pixels(draw):
    model = _model()
    plain, trimmed = draw(model), draw(model)
    trim_ticks(trimmed)
    assert _pixels(plain) == _pixels(trimmed)


def test_a_saved_report_figure_holds_ticks_only_in_its_view(tmp_path):
    fig = figures.bode_magnitude(_model())
    figures.save_figure(fig, tmp_path / "magnitude.png")
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for locs, ticks in ((axis.get_majorticklocs(), axis.majorTicks),
                                (axis.get_minorticklocs(), axis.minorTicks)):
                # the locator's own answer reaches a decade beyond the view on log axes
                assert len(_in_view(axis, locs)) == len(locs)
                # the axis builds one tick per location (and one, unused, where there is none)
                assert len(ticks) == max(1, len(locs))
