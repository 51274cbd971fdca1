"""The report's regularized impulse and step responses (docs/regularization.md): the impulse
response of the estimation record with a kernel prior per input-output pair, drawn per pair with
its pointwise 95 % posterior bands, and the hyperparameters the marginal likelihood chose.

No model order is involved: the section shows what the record says of the responses whatever
the model, so a model whose step response leaves the bands is worth a second look.
"""

from __future__ import annotations

import html
from typing import Sequence

from matplotlib.figure import Figure

from ..data.display import figure_label, report_name, time_label
from ..data.iodata import IOData
from ..errors import DataError
from ..method.kernel.impulse import ImpulseResponse, impulse_response
from .figures import BAND_CONFIDENCE, PANEL_HEIGHT, new_figure

__all__ = ["IMPULSE_FIGURES", "regularized_fit", "regularized_responses", "impulse_figures", "impulse_section"]

# The section's figures, by file name (without .png).
IMPULSE_FIGURES = ("regularized_impulse", "regularized_step")


def regularized_fit(record: IOData) -> ImpulseResponse | str:
    """:func:`moli.impulse_response` of ``record`` (TC prior, length from the data), or why the
    record gives none (the refusal's message: an input that never changes, too few rows)."""
    try:
        return impulse_response(record)
    except DataError as exc:
        return str(exc)


def regularized_responses(fit: ImpulseResponse, step: bool = False) -> Figure:
    """The impulse (or, with ``step``, the step) responses of every input-output pair (a p-by-m
    grid: inputs in the column titles, outputs on the rows), their pointwise 95 % bands shaded.

    Parameters
    ----------
    fit : ImpulseResponse
    step : bool, default False

    Returns
    -------
    matplotlib.figure.Figure
    """
    n, p, m = fit.coefficients.shape
    fig = new_figure(2.4 * m + 0.6, PANEL_HEIGHT * p + 0.4)
    axes = fig.subplots(p, m, sharex=True, squeeze=False)
    lower, upper = fit.bands(BAND_CONFIDENCE, step=step)
    values = fit.step() if step else fit.coefficients
    t = fit.lags * fit.Ts
    for i, name in enumerate(fit.input_names):
        axes[0, i].set_title(f"from {figure_label(name)}", fontsize=9)
        axes[-1, i].set_xlabel(time_label(fit.time_unit, "lag"))
    for j, name in enumerate(fit.output_names):
        axes[j, 0].set_ylabel(f"{'step' if step else 'impulse'} to {figure_label(name)}")
        for i in range(m):
            ax = axes[j, i]
            ax.fill_between(t, lower[:, j, i], upper[:, j, i], step="post" if step else None, color="C0",
                            alpha=0.2, linewidth=0)
            if step:
                ax.plot(t, values[:, j, i], color="C0", linewidth=1.2, drawstyle="steps-post")
            else:
                ax.plot(t, values[:, j, i], "o-", color="C0", linewidth=0.8, markersize=2)
            ax.axhline(0.0, color="0.8", linewidth=0.8)
            ax.grid(alpha=0.3)
    return fig


def impulse_figures(fit: ImpulseResponse | str) -> dict[str, tuple[Figure, str]]:
    """The section's figures by file name, each with its caption; none where ``fit`` is a refusal."""
    if isinstance(fit, str):
        return {}
    shaded = (f"shaded: pointwise {BAND_CONFIDENCE:.0%} posterior band (where the response has died out, "
              "the prior, not the data, sets its width).")
    return {
        IMPULSE_FIGURES[0]: (regularized_responses(fit), "Regularized impulse response from each input to "
                             f"each output, lags {fit.lags[0]}-{fit.lags[-1]}; " + shaded),
        IMPULSE_FIGURES[1]: (regularized_responses(fit, step=True), "Step responses of the same estimate "
                             "(the impulse response summed over lags); " + shaded),
    }


def _hyperparameter_table(fit: ImpulseResponse) -> str:
    head = "<th></th>" + "".join(f"<th>{html.escape(report_name(u))}</th>" for u in fit.input_names) \
        + "<th>noise variance</th>"
    rows = "".join(
        f"<tr><th scope='row'>{html.escape(report_name(y))}</th>"
        + "".join("<td>" + ", ".join(f"{html.escape(key)} = {value:.4g}" for key, value in pair.items()) + "</td>"
                  for pair in fit.hyperparameters[j])
        + f"<td>{fit.noise_variance[j]:.4g}</td></tr>" for j, y in enumerate(fit.output_names))
    return f"<div class='wide'><table><tr>{head}</tr>{rows}</table></div>"


def impulse_section(fit: ImpulseResponse | str, figures_html: Sequence[str], samples: int) -> str:
    """The section's HTML: what was estimated and how, the hyperparameters, the figures.

    Parameters
    ----------
    fit : ImpulseResponse or str
        The estimate, or why the record gives none (:func:`regularized_fit`).
    figures_html : sequence of str
        The embedded figures of :func:`impulse_figures`, in its order.
    samples : int
        Samples of the record it was estimated from.

    Returns
    -------
    str
    """
    heading = "<h2>Regularized impulse and step responses</h2>"
    if isinstance(fit, str):
        return f"{heading}<p class='note'>The estimation record gives none: {html.escape(fit)}.</p>"
    prior = f"a {fit.kernel} kernel prior" if fit.kernel != "none" else "no prior (least squares)"
    table = _hyperparameter_table(fit) if fit.kernel != "none" else ""
    return f"""{heading}
<p class="note">The impulse response of the estimation record ({samples} samples, {len(fit.lags)} lags per
input-output pair) by regularized least squares, whatever the model's order: {prior} on each pair, whose
hyperparameters (scale c, decay per sample &lambda;{', correlation &rho;' if fit.kernel == "DC" else ''}) and each
output's noise variance maximize the marginal likelihood (moli.impulse_response, docs/regularization.md).</p>
{table}
{''.join(figures_html)}
"""
