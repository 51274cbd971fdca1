"""A self-contained HTML report of one identification, with its figures as PNG files."""

from __future__ import annotations

import base64
import html
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from . import figures
from .._version import __version__
from ..method.identification import IdentificationResult
from ..method.search import PathStep
from ..validation.comparison import compare
from ..validation.residuals import SAMPLES_PER_LAG, ResidualAnalysis, residual_analysis

__all__ = ["path_table", "write_report"]

STYLE = """
body { font-family: sans-serif; max-width: 60em; margin: 2em auto; color: #222; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { padding: 0.2em 0.6em; text-align: right; border-bottom: 1px solid #ddd; }
tr.selected { background: #fde7c7; font-weight: bold; }
img { max-width: 100%; }
.note { color: #555; font-size: 0.9em; }
"""


def _save(fig: Figure, path: Path) -> bytes:
    fig.savefig(path, dpi=110)
    return path.read_bytes()


def _image(png: bytes, alt: str) -> str:
    encoded = base64.b64encode(png).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{encoded}">'


def path_table(result: IdentificationResult) -> str:
    """The greedy path as an HTML table, the selected row highlighted.

    Parameters
    ----------
    result : IdentificationResult

    Returns
    -------
    str
    """
    names = result.estimation.output_names
    head = "".join(f"<th>{html.escape(h)}</th>" for h in
                   ["n", "indices", "J", *(f"VAF {nm}" for nm in names), "mean VAF", "wc",
                    "zeta", "stable", "seconds"])
    rows = []
    for i, st in enumerate(result.path):
        cells = [str(st.order), html.escape(str(list(st.indices))), f"{st.J:.4f}",
                 *(f"{v:.2f}" for v in st.vaf), f"{st.mean_vaf:.2f}", f"{st.eta[0]:.4g}",
                 f"{st.eta[1]:.3f}", "yes" if st.stable else "no", f"{st.seconds:.2f}"]
        mark = ' class="selected"' if i == result.selected_index else ""
        rows.append(f"<tr{mark}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(rows)}</table>"


def _model_facts(result: IdentificationResult) -> str:
    model = result.model
    radius = float(np.max(np.abs(model.poles()), initial=0.0))
    facts = {
        "indices": str(list(model.indices or ())),
        "order n": str(model.n),
        "outputs": ", ".join(model.output_names),
        "inputs": ", ".join(model.input_names),
        "Ts": f"{model.Ts:g}",
        "filter (wc, zeta)": f"{model.info.get('wc', float('nan')):.4g}, "
                             f"{model.info.get('zeta', float('nan')):.3f}",
        "largest pole modulus": f"{radius:.4f} ({'stable' if model.is_stable() else 'UNSTABLE'})",
    }
    return "<table>" + "".join(
        f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in facts.items()
    ) + "</table>"


def residual_section(analysis: ResidualAnalysis, figure_html: str) -> str:
    """The residual-analysis section: what was tested, one verdict per output, the figure.

    Parameters
    ----------
    analysis : ResidualAnalysis
    figure_html : str
        The embedded figure of :meth:`ResidualAnalysis.plot`.

    Returns
    -------
    str
    """
    kind = ("one-step prediction errors (the model's noise model)" if analysis.horizon == 1 else
            "simulation errors (the model has no noise model)" if analysis.horizon is None else
            f"{analysis.horizon}-step prediction errors")
    verdicts = "".join(f"<li>{html.escape(v)}</li>" for v in analysis.verdicts)
    return f"""<h2>Residual analysis</h2>
<p class="note">Residuals on the validation record: {kind}. Whiteness: Ljung-Box test over lags
1-{analysis.lags}; independence: chi-square test of the correlation with each prewhitened
input at lags 0-{analysis.lags}. A test fails below p = {1 - analysis.confidence:.2g}.</p>
<ul>{verdicts}</ul>
{figure_html}
"""


def write_report(
    result: IdentificationResult,
    directory: str | Path,
    tried: Sequence[PathStep] = (),
    title: str = "moli identification report",
) -> Path:
    """Write ``report.html`` and its figures (PNG) into ``directory``.

    The HTML embeds the images, so the one file can be mailed or archived; the PNG
    files next to it are for slides and documents.

    Parameters
    ----------
    result : IdentificationResult
    directory : str or Path
        Created if missing; existing report files in it are overwritten.
    tried : sequence of PathStep, optional
        Lists fitted besides the greedy path (e.g. :func:`moli.method.search.exhaustive`),
        drawn as dots on the VAF-against-order figure.
    title : str
        Heading of the report.

    Returns
    -------
    Path
        The HTML file.

    Examples
    --------
    >>> import moli, tempfile
    >>> result = moli.identify(moli.example_data(N=300), nmax=4)
    >>> write_report(result, tempfile.mkdtemp()).name
    'report.html'
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    model, validation = result.model, result.validation
    comparison = compare(model, validation, result.options.x0)
    bands = (f", shaded: pointwise {figures.BAND_CONFIDENCE:.0%} confidence band of the estimate "
             "(docs/uncertainty.md)." if model.cov_factor is not None else ".")
    drawn = {
        "vaf_by_order": (figures.vaf_by_order(result.path, tried, result.selected_index),
                         "Mean validation VAF against the order: the greedy path"
                         + (" and every other list fitted (grey)." if tried else ".")),
        "validation": (figures.measured_vs_simulated(validation, comparison),
                       f"Measured and simulated outputs on the validation record "
                       f"({html.escape(result.validation_source)}); simulation from "
                       f"{result.options.x0} initial state, offsets removed."),
        "poles": (figures.poles(model), "Poles of the selected model and the unit circle."),
        "step_responses": (figures.step_responses(model, figures.settling_samples(model)),
                           "Unit-step responses from each input to each output (deviations)" + bands),
        "magnitude": (figures.magnitude_responses(model),
                      "Gain of each channel against frequency, up to the Nyquist frequency" + bands),
    }
    # at most the default 25 lags, fewer on a short validation record
    lags = min(25, validation.N // SAMPLES_PER_LAG - 1)
    analysis = residual_analysis(model, validation, lags=lags) if lags >= 1 else None
    if analysis is not None:
        drawn["residuals"] = (analysis.plot(), f"Residual correlations on the validation record "
                              f"with their {analysis.confidence:.0%} bands: autocorrelation, then "
                              "the cross-correlation with each input (positive lags: past inputs).")
    figures_html = {}
    for name, (fig, caption) in drawn.items():
        png = _save(fig, out / f"{name}.png")
        figures_html[name] = (f"<figure>{_image(png, name)}<figcaption class='note'>{caption}"
                              "</figcaption></figure>")
    residuals = "" if analysis is None else residual_section(analysis, figures_html.pop("residuals"))
    interrupted = ("<p><b>The search was interrupted; the path below is partial.</b></p>"
                   if result.interrupted else "")
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{STYLE}</style></head><body>
<h1>{html.escape(title)}</h1>
<p class="note">moli {__version__}; estimation {result.estimation.N} samples, validation
{validation.N} samples ({html.escape(result.validation_source)}); total {result.seconds:.1f} s.</p>
{interrupted}
<h2>Selected model</h2>{_model_facts(result)}
<h2>Greedy structure path</h2>
<p class="note">J: criterion on the estimation record; VAF: validation record, simulation,
percent. Selected: lowest order within {result.options.order_tolerance:g} point of the best
mean VAF.</p>
{path_table(result)}
<h2>Figures</h2>
{''.join(figures_html.values())}
{residuals}</body></html>
"""
    target = out / "report.html"
    target.write_text(page, encoding="utf-8")
    return target
