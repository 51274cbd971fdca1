"""Report figures drawn with matplotlib on the Agg canvas (no display needed).

Each function returns a :class:`matplotlib.figure.Figure` that is not registered with
pyplot, so drawing many reports never accumulates open windows or memory.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..data.display import figure_label, period_text, time_label
from ..data.iodata import IOData
from ..models.pole_bands import pole_support
from ..models.statespace import StateSpaceModel
from ..method.search.greedy_path import PathStep
from ..validation.comparison import Comparison
from ..validation.residuals import ResidualAnalysis
from .figure_layout import GridLayout

__all__ = [
    "vaf_by_order", "measured_vs_simulated", "poles", "step_responses", "settling_samples",
    "envelope", "residual_correlations", "new_figure", "channel_grid", "PANEL_HEIGHT", "BAND_CONFIDENCE",
]

PANEL_HEIGHT = 1.9  # inches per row of axes
# Confidence of the bands drawn around responses of models that carry a covariance.
BAND_CONFIDENCE = 0.95
# A time series of more samples than this is drawn as the band between the least and
# the largest sample of ENVELOPE_BINS bins: a 7.5-inch panel at 110 dpi is about 800
# pixels wide, so more points only slow the drawing and blot the line.
MAX_DRAWN_SAMPLES = 4000
ENVELOPE_BINS = 1000
# A long record's figure shows its last samples beside the envelope, each drawn.
DETAIL_SAMPLES = 500


def new_figure(width: float, height: float) -> Figure:
    """An empty figure on the Agg canvas whose grid of axes :class:`GridLayout` places."""
    fig = Figure(figsize=(width, height), layout=GridLayout())
    FigureCanvasAgg(fig)
    return fig


def channel_grid(model: StateSpaceModel, ylabel: str, xlabel: str) -> tuple[Figure, np.ndarray]:
    """A p-by-m grid of axes, one per channel: inputs in the column titles, outputs on the rows."""
    fig = new_figure(2.4 * model.m + 0.6, PANEL_HEIGHT * model.p + 0.4)
    axes = fig.subplots(model.p, model.m, sharex=True, squeeze=False)
    for j, name in enumerate(model.input_names):
        axes[0, j].set_title(f"from {figure_label(name)}", fontsize=9)
        axes[-1, j].set_xlabel(xlabel)
    for i, name in enumerate(model.output_names):
        axes[i, 0].set_ylabel(f"{ylabel} {figure_label(name)}")
    return fig, axes


def envelope(t: np.ndarray, values: np.ndarray, bins: int = ENVELOPE_BINS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The least and largest sample of each of ``bins`` runs of consecutive samples.

    Drawn as a step band (``fill_between(edges, low, high, step="post")``) it covers
    every sample: bin ``b`` spans ``edges[b]`` to ``edges[b + 1]``, the times of its first
    sample and of the next bin's (the record's last time for the last bin).

    Parameters
    ----------
    t : ndarray, shape (N,)
        Increasing times of the samples.
    values : ndarray, shape (N,)
    bins : int, default 1000
        At most this many bins (fewer for a shorter record), of sizes differing by at most one.

    Returns
    -------
    edges, low, high : ndarray, shape (bins + 1,)
        ``low`` and ``high`` repeat their last value at the closing edge.

    Examples
    --------
    >>> edges, low, high = envelope(np.arange(6.0), np.array([0.0, 5, 1, 2, 9, 3]), bins=2)
    >>> edges.tolist(), low.tolist(), high.tolist()
    ([0.0, 3.0, 5.0], [0.0, 2.0, 2.0], [5.0, 9.0, 9.0])
    """
    values = np.asarray(values, dtype=float)
    bins = min(bins, len(values))
    starts = np.linspace(0, len(values), bins + 1).astype(int)[:-1]
    low = np.minimum.reduceat(values, starts)
    high = np.maximum.reduceat(values, starts)
    edges = np.append(np.asarray(t, dtype=float)[starts], t[-1])
    return edges, np.append(low, low[-1]), np.append(high, high[-1])


def _trace(ax: object, t: np.ndarray, values: np.ndarray, color: str, label: str,
           filled: bool) -> None:
    """A time series as a line, or when it is long as its min-max envelope: a filled band,
    or its two edges as lines so that a band drawn under it still shows."""
    if len(values) <= MAX_DRAWN_SAMPLES:
        ax.plot(t, values, color=color, linewidth=1.0, label=label)  # type: ignore[attr-defined]
        return
    edges, low, high = envelope(t, values)
    label = f"{label}, min and max of {len(values) / (len(edges) - 1):.0f} samples"
    if filled:
        ax.fill_between(edges, low, high, step="post", color=color, alpha=0.45,  # type: ignore[attr-defined]
                        linewidth=0, label=label)
    else:
        ax.plot(edges, low, color=color, linewidth=0.7, drawstyle="steps-post", label=label)  # type: ignore[attr-defined]
        ax.plot(edges, high, color=color, linewidth=0.7, drawstyle="steps-post")  # type: ignore[attr-defined]


def vaf_by_order(path: Sequence[PathStep], tried: Sequence[PathStep] = (), selected: int | None = None) -> Figure:
    """Mean validation VAF against the order, like Fig. 2 of the MOLI-ZOFT paper.

    Parameters
    ----------
    path : sequence of PathStep
        The greedy path (one step per order), drawn as a line.
    tried : sequence of PathStep, optional
        Every other list fitted (greedy candidates or an exhaustive search), drawn as dots.
    selected : int, optional
        Position in ``path`` of the selected model, circled.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure(6.4, 3.6)
    ax = fig.add_subplot()
    if tried:
        ax.plot([st.order for st in tried], [st.mean_vaf for st in tried], "o", color="0.65",
                markersize=4, label="other lists fitted")
    orders = [st.order for st in path]
    ax.plot(orders, [st.mean_vaf for st in path], "o-", color="C0", label="greedy path")
    for st in path:
        # labels sit above the ring that marks the selected model, not under it
        ax.annotate(",".join(map(str, st.indices)), (st.order, st.mean_vaf), fontsize=7,
                    textcoords="offset points", xytext=(0, 10), ha="center")
    if selected is not None:
        st = path[selected]
        ax.plot(st.order, st.mean_vaf, "o", markersize=14, markerfacecolor="none",
                markeredgecolor="C3", markeredgewidth=2, label=f"selected (n = {st.order})")
    ax.set_xticks(range(min(orders), max(orders) + 1))
    scores = [st.mean_vaf for st in [*path, *tried]]
    ax.set_ylim(max(min(scores) - 1.0, 0.0), min(max(scores) + 1.0, 100.5))
    ax.set_xlabel("order n")
    ax.set_ylabel("mean validation VAF (%)")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    return fig


def measured_vs_simulated(data: IOData, comparison: Comparison) -> Figure:
    """Measured and simulated outputs, one panel per output (like the paper's Fig. 7).

    A record longer than :data:`MAX_DRAWN_SAMPLES` is drawn as bands from the least to
    the largest sample of each of :data:`ENVELOPE_BINS` bins (:func:`envelope`): the
    measured output filled, the simulated one as its two edges; beside it, the last
    :data:`DETAIL_SAMPLES` samples as lines. So the figure of 10^6 samples stays
    readable and quick to write.

    Parameters
    ----------
    data : IOData
        The record the model was simulated on; dotted lines mark where its segments start.
    comparison : Comparison
        Result of :func:`moli.compare` on ``data``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    long = data.N > MAX_DRAWN_SAMPLES
    fig = new_figure(10.0 if long else 7.5, PANEL_HEIGHT * data.p + 0.4)
    grid = fig.subplots(data.p, 2 if long else 1, sharex="col", squeeze=False,
                        width_ratios=[3, 1] if long else None)
    axes = grid[:, 0]
    t = data.time()
    for i, ax in enumerate(axes):
        _trace(ax, t, data.y[:, i], "0.2", "measured", filled=True)
        _trace(ax, t, comparison.yhat[:, i], "C1", "simulated", filled=False)
        for start in data.segment_starts[1:]:   # each segment is simulated from its own start
            ax.axvline(t[start], color="0.5", linewidth=0.8, linestyle=":")
        if long:  # the record's last samples as they are, where single responses show
            tail = slice(data.N - DETAIL_SAMPLES, None)
            grid[i, 1].plot(t[tail], data.y[tail, i], color="0.2", linewidth=1.0)
            grid[i, 1].plot(t[tail], comparison.yhat[tail, i], color="C1", linewidth=1.0)
            grid[i, 1].grid(alpha=0.3)
        ax.set_ylabel(figure_label(data.output_names[i]))
        ax.set_title(f"VAF {comparison.vaf[i]:.1f} %, fit {comparison.fit[i]:.1f} %",
                     fontsize=9, loc="right")
        ax.grid(alpha=0.3)
    if long:
        grid[0, 1].set_title(f"last {DETAIL_SAMPLES} samples", fontsize=9, loc="right")
        grid[-1, 1].set_xlabel(time_label(data.time_unit))
    # above the axes (GridLayout puts it there): inside, it hides the first output's start-up transient
    fig.legend(*axes[0].get_legend_handles_labels(), loc="upper left", fontsize=8, ncols=2)
    axes[-1].set_xlabel(time_label(data.time_unit, "time from the start of the record"))
    return fig


def poles(model: StateSpaceModel) -> Figure:
    """Poles of the model in the complex plane with the unit circle.

    Parameters
    ----------
    model : StateSpaceModel

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure(4.2, 4.2)
    ax = fig.add_subplot()
    angle = np.linspace(0.0, 2.0 * np.pi, 400)
    ax.plot(np.cos(angle), np.sin(angle), color="0.5", linewidth=1.0)
    z = model.poles()
    inside = np.abs(z) < 1.0
    ax.plot(z.real[inside], z.imag[inside], "x", color="C0", markersize=8, mew=1.5, label="stable")
    if not inside.all():
        ax.plot(z.real[~inside], z.imag[~inside], "x", color="C3", markersize=8, mew=1.5,
                label="on or outside the circle")
    reach = max(1.1, float(np.max(np.abs(z), initial=0.0)) * 1.1)
    ax.set_xlim(-reach, reach)
    ax.set_ylim(-reach, reach)
    ax.set_aspect("equal")
    ax.axhline(0.0, color="0.8", linewidth=0.8)
    ax.axvline(0.0, color="0.8", linewidth=0.8)
    ax.set_xlabel("real")
    ax.set_ylabel("imaginary")
    ax.set_title(f"poles (n = {model.n}, Ts = {period_text(model.Ts, model.info.get('time_unit'))})", fontsize=10)
    ax.legend(loc="upper left", fontsize=8)
    return fig


def step_responses(model: StateSpaceModel, samples: int) -> Figure:
    """Unit-step responses from every input to every output (a p-by-m grid).

    A model with a covariance (``model.cov_factor``) gets its pointwise 95 % bands
    (:meth:`StateSpaceModel.step_bands`, Gauss approximation) shaded.

    Parameters
    ----------
    model : StateSpaceModel
    samples : int
        Length of each response.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, axes = channel_grid(model, "to", time_label(model.info.get("time_unit")))
    t = np.arange(samples) * model.Ts
    bands = None if model.cov_factor is None else model.step_bands(samples, BAND_CONFIDENCE)
    for j in range(model.m):
        u = np.zeros((samples, model.m))
        u[:, j] = 1.0
        y = model.simulate(u)
        for i in range(model.p):
            ax = axes[i, j]
            if bands is not None:
                ax.fill_between(t, bands[0][:, i, j], bands[1][:, i, j], step="post", color="C0",
                                alpha=0.2, linewidth=0)
            ax.plot(t, y[:, i], color="C0", linewidth=1.2, drawstyle="steps-post")
            ax.axhline(0.0, color="0.8", linewidth=0.8)
            ax.grid(alpha=0.3)
    return fig


def residual_correlations(analysis: ResidualAnalysis) -> Figure:
    """:meth:`ResidualAnalysis.plot <moli.validation.residuals.ResidualAnalysis.plot>`'s figure,
    its grid placed as the other report figures' (:class:`GridLayout`)."""
    fig = analysis.plot()
    fig.set_layout_engine(GridLayout())
    return fig


def settling_samples(model: StateSpaceModel, record_samples: int | None = None, cap: int = 2000) -> int:
    """A step-response length that shows the slowest pole the record supports settle (5 time constants).

    A pole the data cannot tell from the unit circle, or slower than the record
    (:func:`moli.models.pole_bands.pole_support`), would stretch the plot to its own settling and
    squeeze the dynamics the record does show into its first percent: it sets no length.

    Parameters
    ----------
    model : StateSpaceModel
    record_samples : int, optional
        Samples of the estimation record.
    cap : int, default 2000
        Upper bound, reached by a supported pole close to the unit circle.

    Returns
    -------
    int
        ``cap`` for an unstable model: its plot shows it diverge.

    Examples
    --------
    >>> settling_samples(StateSpaceModel([[0.5]], [[1.0]], [[1.0]]))
    20
    >>> settling_samples(StateSpaceModel(np.diag([0.999, 0.9]), [[1.0], [1.0]], [[1.0, 1.0]]), 500)
    48
    """
    if not model.is_stable():
        return cap
    supported = [s.time_constant for s in pole_support(model, record_samples) if s.supported]
    slowest = max(supported, default=0.0)
    return int(min(cap, max(20, np.ceil(5.0 * slowest))))
