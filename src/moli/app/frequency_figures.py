"""Report figures in frequency: the gain of each channel and the singular values of the
frequency response, beside the record's spectral estimate (matplotlib, Agg canvas)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..data.display import frequency_label
from ..data.iodata import IOData
from ..models.statespace import StateSpaceModel
from ..validation.frequency import EmpiricalResponse, empirical_frequency_response
from .figures import BAND_CONFIDENCE, channel_grid, new_figure

__all__ = ["bode_magnitude", "singular_values", "MAX_DRAWN_FREQUENCIES", "DECADES"]

# The Bode plots span three decades below the Nyquist frequency.
DECADES = 3
# A spectral estimate of a long record has tens of thousands of evenly spaced frequencies,
# nine in ten of them in the top decade of a log axis: at most this many, spread evenly
# over the log axis, are drawn as dots (the panel is some 250 pixels wide).
MAX_DRAWN_FREQUENCIES = 600


def _spectral_estimate(data: IOData | EmpiricalResponse | None, nperseg: int | None) -> EmpiricalResponse | None:
    """The spectral estimate of a record (or the one given), at frequencies spread over a
    log axis: at most :data:`MAX_DRAWN_FREQUENCIES` of them, each a frequency of the estimate."""
    if data is None:
        return None
    empirical = data if isinstance(data, EmpiricalResponse) else empirical_frequency_response(data, nperseg=nperseg)
    omega = empirical.omega
    positive = omega[omega > 0]
    if len(positive) <= MAX_DRAWN_FREQUENCIES:
        return empirical
    grid = np.geomspace(positive[0], positive[-1], MAX_DRAWN_FREQUENCIES)
    keep = np.unique(np.searchsorted(omega, grid).clip(0, len(omega) - 1))
    return EmpiricalResponse(omega[keep], empirical.response[keep])


def bode_magnitude(model: StateSpaceModel, data: IOData | EmpiricalResponse | None = None, nperseg: int | None = None,
                   points: int = 200) -> Figure:
    """Gain of every input-output pair against frequency (a p-by-m grid), on log axes.

    The model's :meth:`~moli.StateSpaceModel.frequency_response` ``|H|`` as a line, from
    three decades below the Nyquist frequency ``pi / Ts`` up to it; a model with a
    covariance (``cov_factor``) gets its pointwise 95 % bands
    (:meth:`~moli.StateSpaceModel.magnitude_bands`, Gauss) shaded; with ``data``, the
    spectral estimate :func:`moli.empirical_frequency_response` as dots.

    Parameters
    ----------
    model : StateSpaceModel
    data : IOData or EmpiricalResponse, optional
        A record of the same channels (raw or centred), or its spectral estimate.
    nperseg : int, optional
        Welch segment length of the empirical estimate of ``data``.
    points : int, default 200
        Log-spaced frequencies of the model's line.

    Returns
    -------
    matplotlib.figure.Figure
    """
    nyquist = np.pi / model.Ts
    omega = np.logspace(np.log10(nyquist) - DECADES, np.log10(nyquist), points)
    gain = np.abs(model.frequency_response(omega))
    bands = None if model.cov_factor is None else model.magnitude_bands(omega, BAND_CONFIDENCE)
    empirical = _spectral_estimate(data, nperseg)
    fig, axes = channel_grid(model, "|H| to", frequency_label(model.info.get("time_unit")))
    for i in range(model.p):
        for j in range(model.m):
            ax = axes[i, j]
            if bands is not None:
                # a Gauss band's lower edge clipped at zero has no place on a log axis
                lower = np.where(bands[0][:, i, j] > 0, bands[0][:, i, j], np.nan)
                ax.fill_between(omega, lower, bands[1][:, i, j], color="C0", alpha=0.2, linewidth=0)
            ax.loglog(omega, gain[:, i, j], color="C0", linewidth=1.2, label="model")
            if empirical is not None:
                ax.loglog(empirical.omega, np.abs(empirical.response[:, i, j]), ".", color="0.4",
                          markersize=3, label="spectral estimate")
            ax.grid(alpha=0.3, which="both")
    if empirical is not None:
        fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="upper left", fontsize=8, ncols=2)
    return fig


def singular_values(model: StateSpaceModel, data: IOData | EmpiricalResponse | None = None,
                    nperseg: int | None = None, points: int = 200) -> Figure:
    """Singular values of the frequency response against frequency: the MIMO gain envelope.

    The largest and smallest gain over all input directions at each frequency, from
    three decades below the Nyquist frequency up to it, as lines; with ``data``, the
    singular values of :func:`moli.empirical_frequency_response` as dots.

    Parameters
    ----------
    model : StateSpaceModel
    data : IOData or EmpiricalResponse, optional
        A record of the same channels (raw or centred), or its spectral estimate.
    nperseg : int, optional
        Welch segment length of the empirical estimate of ``data``.
    points : int, default 200

    Returns
    -------
    matplotlib.figure.Figure
    """
    nyquist = np.pi / model.Ts
    omega = np.logspace(np.log10(nyquist) - DECADES, np.log10(nyquist), points)
    sv = np.linalg.svd(model.frequency_response(omega), compute_uv=False)       # (F, min(p, m))
    fig = new_figure(5.5, 3.4)
    ax = fig.subplots()
    ax.loglog(omega, sv, color="C0", linewidth=1.2)
    ax.lines[0].set_label("model")
    empirical = _spectral_estimate(data, nperseg)
    if empirical is not None:
        keep = empirical.omega > 0
        points_sv = np.linalg.svd(empirical.response[keep], compute_uv=False)
        ax.loglog(empirical.omega[keep], points_sv, ".", color="0.4", markersize=3)
        ax.lines[sv.shape[1]].set_label("spectral estimate")
        ax.legend(fontsize=8)
    ax.set(xlabel=frequency_label(model.info.get("time_unit")), ylabel="singular values of H")
    ax.grid(alpha=0.3, which="both")
    return fig
