"""The report's figures placed from their texts: every text inside the figure, none over
another axes or another text, and the axes filling the figure."""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.text import Text

import moli
from moli.app import figures, frequency_figures
from moli.app.figure_files import DPI, save_figure
from moli.app.figure_layout import GridLayout
from moli.app.figure_ticks import in_view
from moli.validation.comparison import compare
from moli.validation.residuals import residual_analysis

# Antialiasing and the extents' rounding to whole pixels: boxes that touch may share a pixel.
TOUCH = 1.0


def _model(p: int, m: int, names: bool = False) -> moli.StateSpaceModel:
    rng = np.random.default_rng(p * 10 + m)
    n = p + 1
    A = np.diag(np.linspace(0.3, 0.9, n))
    B, C = rng.normal(size=(n, m)), rng.normal(size=(p, n)) * 10.0 ** rng.integers(-3, 3, size=(p, 1))
    kwargs = {}
    if names:   # long channel names: wide titles and labels
        kwargs = {"input_names": [f"valve {j} position (% open)" for j in range(m)],
                  "output_names": [f"reactor {i} (deg C)" for i in range(p)]}
    return moli.StateSpaceModel(A, B, C, np.zeros((p, m)), **kwargs)


def _record(model: moli.StateSpaceModel, N: int) -> moli.IOData:
    u = np.random.default_rng(1).normal(size=(N, model.m))
    y = model.simulate(u) + 0.1 * np.random.default_rng(2).normal(size=(N, model.p))
    return moli.IOData(y, u, input_names=model.input_names, output_names=model.output_names)


def _shown_tick_labels(axis) -> list[Text]:
    """The major tick labels the axis draws: those of ticks in its view."""
    locs = np.asarray(axis.get_majorticklocs(), dtype=float)
    shown = set(in_view(axis, locs).tolist())
    return [tick.label1 for tick in axis.get_major_ticks(len(locs)) if tick.get_loc() in shown]


def _texts(fig: Figure) -> list[tuple[object, Text]]:
    """Every text drawn, with the axes it belongs to (None for the figure's own)."""
    drawn = []
    for ax in fig.axes:
        owned = [*_shown_tick_labels(ax.xaxis), *_shown_tick_labels(ax.yaxis), ax.xaxis.label, ax.yaxis.label,
                 ax.xaxis.get_offset_text(), ax.yaxis.get_offset_text(),
                 *(child for child in ax.get_children() if isinstance(child, Text) and child not in ax.texts)]
        drawn += [(ax, text) for text in owned]
    drawn += [(None, text) for text in fig.texts]
    return [(owner, text) for owner, text in drawn if text.get_visible() and text.get_text().strip()]


def _tick_texts(ax) -> list[Text]:
    return [*ax.get_xticklabels(), *ax.get_yticklabels(), ax.xaxis.get_offset_text(), ax.yaxis.get_offset_text()]


def _overlap(a, b) -> bool:
    return min(a.x1, b.x1) - max(a.x0, b.x0) > TOUCH and min(a.y1, b.y1) - max(a.y0, b.y0) > TOUCH


def _scaled_model() -> moli.StateSpaceModel:
    """One output, three inputs, gains near 1e-5: each axes has an offset text under its title."""
    model = _model(1, 3, names=True)
    return moli.StateSpaceModel(model.A, model.B, 1e-5 * model.C / np.abs(model.C).max(), model.D,
                                input_names=model.input_names, output_names=model.output_names)


def _rotated_end_labels() -> Figure:
    """Stacked axes sharing x, y tick labels at both ends of each, x tick labels turned upright."""
    fig = figures.new_figure(4.0, 4.0)
    t = np.linspace(0.0, 1.0, 50)
    for ax in fig.subplots(3, 1, sharex=True):
        ax.plot(1e4 + 1e3 * t, t)
        ax.set_ylim(0.0, 1.0)
        ax.set_yticks([0.0, 0.5, 1.0])
        ax.tick_params(axis="x", labelrotation=90)
    return fig


def _figures() -> dict[str, Figure]:
    siso, grid, wide = _model(1, 1), _model(3, 3), _model(2, 4, names=True)
    record = _record(grid, 600)
    long_record = _record(siso, 6000)
    wide_record = _record(wide, 600)
    made = {
        "steps 1x1": figures.step_responses(siso, 40),
        "steps 3x3": figures.step_responses(grid, 40),
        "steps 2x4, long names": figures.step_responses(wide, 40),
        "magnitude 3x3 with spectrum": frequency_figures.bode_magnitude(grid, record, points=40),
        "magnitude 2x4, long names": frequency_figures.bode_magnitude(wide, points=40),
        "validation 3 outputs": figures.measured_vs_simulated(record, compare(grid, record)),
        "validation long record": figures.measured_vs_simulated(long_record, compare(siso, long_record)),
        "residuals 3x3": figures.residual_correlations(residual_analysis(grid, record, lags=10)),
        "residuals 2x4, long names": figures.residual_correlations(residual_analysis(wide, wide_record, lags=10)),
        "steps 1x3, gains 1e-5 under titles": figures.step_responses(_scaled_model(), 40),
        "rotated labels, labels at the axes' ends": _rotated_end_labels(),
        "poles": figures.poles(grid),
        "singular values": frequency_figures.singular_values(grid, record, points=40),
    }
    assert list(made) == FIGURES
    return made


# the figures' names, for the parameters (the figures themselves are built once, by the fixture)
FIGURES = ["steps 1x1", "steps 3x3", "steps 2x4, long names", "magnitude 3x3 with spectrum",
           "magnitude 2x4, long names", "validation 3 outputs", "validation long record", "residuals 3x3",
           "residuals 2x4, long names", "steps 1x3, gains 1e-5 under titles",
           "rotated labels, labels at the axes' ends", "poles", "singular values"]


@pytest.fixture(scope="module")
def drawn(tmp_path_factory) -> dict[str, Figure]:
    out = tmp_path_factory.mktemp("figures")
    made = _figures()
    for name, fig in made.items():
        save_figure(fig, out / f"{name}.png")
        # drawn again as the file was (save_figure puts the figure's own dpi back after), so
        # that every text, offset texts included, is measured where the file has it
        fig.set_dpi(DPI)
        fig.canvas.draw()
    return made


@pytest.mark.parametrize("name", FIGURES)
def test_every_text_is_inside_the_figure_and_clear_of_other_axes_and_texts(drawn, name):
    fig = drawn[name]
    assert isinstance(fig.get_layout_engine(), GridLayout)
    renderer = fig.canvas.get_renderer()
    frame = fig.bbox
    texts = [(owner, text, text.get_window_extent(renderer)) for owner, text in _texts(fig)]
    for owner, text, box in texts:
        assert box.x0 >= frame.x0 - TOUCH and box.x1 <= frame.x1 + TOUCH, (text.get_text(), box, frame)
        assert box.y0 >= frame.y0 - TOUCH and box.y1 <= frame.y1 + TOUCH, (text.get_text(), box, frame)
        for ax in fig.axes:
            if ax is not owner:
                assert not _overlap(box, ax.get_window_extent(renderer)), (text.get_text(), "over another axes")
    for (owner_a, a, box_a), (owner_b, b, box_b) in combinations(texts, 2):
        # an axes' own texts may touch (a tick label and its offset text), its titles may not
        titles = owner_a is owner_b and owner_a is not None and all(t not in _tick_texts(owner_a) for t in (a, b))
        if owner_a is not owner_b or titles:
            assert not _overlap(box_a, box_b), (a.get_text(), b.get_text())
    for legend in fig.legends:
        box = legend.get_window_extent(renderer)
        assert box.y1 <= frame.y1 + TOUCH and box.x0 >= frame.x0 - TOUCH
        for ax in fig.axes:
            assert not _overlap(box, ax.get_window_extent(renderer)), "a legend over the axes"
        for _, text, text_box in texts:
            assert not _overlap(box, text_box), (text.get_text(), "under a legend")


@pytest.mark.parametrize("name", ["steps 3x3", "residuals 3x3", "validation 3 outputs"])
def test_the_axes_fill_the_figure_their_texts_leave(drawn, name):
    # The grid gives its texts what they need and no more: the axes span most of the figure
    # (matplotlib's fixed default margins leave them 0.78 of its width and 0.77 of its height).
    fig = drawn[name]
    renderer = fig.canvas.get_renderer()
    boxes = [ax.get_window_extent(renderer) for ax in fig.axes]
    span_w = (max(b.x1 for b in boxes) - min(b.x0 for b in boxes)) / fig.bbox.width
    span_h = (max(b.y1 for b in boxes) - min(b.y0 for b in boxes)) / fig.bbox.height
    assert span_w > 0.8 and span_h > 0.7


@pytest.mark.parametrize("suffix", ["svg", "pdf"])
def test_a_vector_file_is_placed_as_the_png(tmp_path, suffix):
    # The layout measures its texts with the renderer of whichever backend draws; at the same
    # figure size the margins agree with the PNG's to a few pixels (the backends' text
    # extents differ by their hinting).
    model = _model(2, 2)
    png, vector = figures.step_responses(model, 40), figures.step_responses(model, 40)
    save_figure(png, tmp_path / "steps.png")
    save_figure(vector, tmp_path / f"steps.{suffix}")
    assert (tmp_path / f"steps.{suffix}").stat().st_size > 0
    for a, b in zip(png.axes, vector.axes):
        assert np.allclose(a.get_position().bounds, b.get_position().bounds, atol=0.02)


def test_axes_off_one_grid_keep_their_places():
    fig = Figure(figsize=(4, 3), layout=GridLayout())
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.2, 0.2, 0.5, 0.5))
    ax.plot([0, 1], [0, 1])
    fig.canvas.draw()
    assert np.allclose(ax.get_position().bounds, (0.2, 0.2, 0.5, 0.5))
