"""A self-contained HTML report of one identification, with its figures as PNG files.

The report says where it came from (input file and its SHA-256, options, moli
version, date), what the scores mean, and stays readable with many outputs: the path
table numbers the outputs and lists their names under it.
"""

from __future__ import annotations

import base64
import html
from datetime import datetime, timezone
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from . import figures, frequency_figures
from .figure_files import save_figure
from .impulse_section import IMPULSE_FIGURES, impulse_figures, impulse_section, regularized_fit
from .._version import __version__
from ..data.atomic_files import write_atomic
from ..data.display import period_text, report_name
from ..data.files import file_sha256
from ..data.iodata import IOData, longest_segment
from ..errors import DataError
from ..method.identification import IdentificationResult
from ..method.search.greedy_path import PathStep
from ..models.pole_bands import pole_support
from ..models.protocol import LinearModel
from ..validation.comparison import compare
from ..validation.frequency import EmpiricalResponse, empirical_frequency_response
from ..validation.residuals import SAMPLES_PER_LAG, ResidualAnalysis, residual_analysis

__all__ = ["path_table", "validation_caption", "warnings_section", "write_report"]

STYLE = """
body { font-family: sans-serif; max-width: 60em; margin: 2em auto; color: #222; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { padding: 0.2em 0.6em; text-align: right; border-bottom: 1px solid #ddd; }
th[scope="row"], td.text { text-align: left; }
.wide { overflow-x: auto; }
tr.selected { background: #fde7c7; font-weight: bold; }
img { max-width: 100%; }
.note { color: #555; font-size: 0.9em; }
"""


def embedded_image(png: bytes, alt: str) -> str:
    encoded = base64.b64encode(png).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{encoded}">'


def drawn_residuals(model: LinearModel, record: IOData, drawn: dict) -> ResidualAnalysis | None:
    """The residual analysis of ``model`` on ``record`` (at most the default 25 lags, fewer on a
    short record; None where it is too short for one), its figure put into ``drawn``."""
    lags = min(25, record.N // SAMPLES_PER_LAG - 1)
    analysis = residual_analysis(model, record, lags=lags) if lags >= 1 else None
    if analysis is not None:
        drawn["residuals"] = (figures.residual_correlations(analysis),
                              f"Residual correlations on the validation record with their "
                              f"{analysis.confidence:.0%} bands: autocorrelation, then the "
                              "cross-correlation with each input (positive lags: past inputs).")
    return analysis


def embedded_figures(drawn: Mapping[str, tuple], out: Path) -> dict[str, str]:
    """Each ``name: (figure, caption)`` saved as ``out/name.png`` and embedded with its caption."""
    return {name: f"<figure>{embedded_image(save_figure(fig, out / f'{name}.png'), name)}"
                  f"<figcaption class='note'>{caption}</figcaption></figure>" for name, (fig, caption) in drawn.items()}


def facts_table(rows: Mapping[str, str]) -> str:
    """A two-column table of labels and values."""
    return "<table>" + "".join(
        f'<tr><th scope="row">{html.escape(k)}</th><td class="text">{html.escape(v)}</td></tr>'
        for k, v in rows.items()
    ) + "</table>"


def path_table(result: IdentificationResult) -> str:
    """The greedy path as an HTML table, the selected row highlighted.

    Outputs are numbered ``y1, y2, ...`` in the column heads, so the table keeps its
    width whatever the names; a line under it gives each number's name.

    Parameters
    ----------
    result : IdentificationResult

    Returns
    -------
    str
    """
    names = result.estimation.output_names
    head = "".join(f"<th>{html.escape(h)}</th>" for h in
                   ["n", "indices", "J", *(f"VAF y{i + 1}" for i in range(len(names))),
                    "mean VAF", "wc", "zeta", "stable", "seconds"])
    rows = []
    for i, st in enumerate(result.path):
        cells = [str(st.order), html.escape(str(list(st.indices))), f"{st.J:.4f}",
                 *(f"{v:.2f}" for v in st.vaf), f"{st.mean_vaf:.2f}", f"{st.eta[0]:.4g}",
                 f"{st.eta[1]:.3f}", "yes" if st.stable else "no", f"{st.seconds:.2f}"]
        mark = ' class="selected"' if i == result.selected_index else ""
        rows.append(f"<tr{mark}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    # the column heads' numbers named, where the names say more than the numbers ("y1 = y1" says nothing)
    legend = ", ".join(f"y{i + 1} = {html.escape(report_name(name))}" for i, name in enumerate(names)
                       if name != f"y{i + 1}")
    return (f"<div class='wide'><table><tr>{head}</tr>{''.join(rows)}</table></div>"
            + (f"<p class='note'>Outputs: {legend}.</p>" if legend else ""))


def _model_facts(result: IdentificationResult) -> str:
    model = result.model
    radius = float(np.max(np.abs(model.poles()), initial=0.0))
    facts = {
        "indices": str(list(model.indices or ())),
        "order n": str(model.n),
        "outputs": ", ".join(map(report_name, model.output_names)),
        "inputs": ", ".join(map(report_name, model.input_names)),
        "Ts": period_text(model.Ts, model.info.get("time_unit")),
        "filter (wc, zeta)": f"{model.info.get('wc', float('nan')):.4g}, "
                             f"{model.info.get('zeta', float('nan')):.3f}",
        "largest pole modulus": f"{radius:.4f} ({'stable' if model.is_stable() else 'UNSTABLE'})",
        "selected by": f"{result.selection}, on {result.validation.N} validation samples "
                       f"({result.validation_source})",
    }
    # an unstable pole is said above; a stable one the record cannot resolve is named here
    unsupported = [s for s in pole_support(model, result.estimation.N) if not s.supported and abs(s.pole) < 1]
    if unsupported:
        facts["poles the record cannot resolve"] = "; ".join(
            f"{_pole(s.pole)} ({s.reason(result.estimation.N, figures.BAND_CONFIDENCE)})" for s in unsupported)
    if result.loop_method is not None:
        facts["closed loop"] = result.loop_method
    return facts_table(facts)


def _pole(z: complex) -> str:
    """A pole as text: a real one as its value, a complex one with its imaginary part's size."""
    return f"{z.real:.4f}" if z.imag == 0 else f"{z.real:.4f} {'+' if z.imag > 0 else '-'} {abs(z.imag):.4f}j"


def _provenance(result: IdentificationResult, data_file: str | Path | None) -> str:
    """Where the report came from: input, its SHA-256, the record's fingerprint, version, date."""
    recorded = result.model.info.get("data", {})
    rows = {"input": str(data_file) if data_file is not None else recorded.get("source", "not recorded")}
    if data_file is not None:
        rows["SHA-256 of the input file"] = file_sha256(data_file)
    if "sha256" in recorded:
        rows["SHA-256 of the estimation samples"] = recorded["sha256"]
    rows["moli version"] = __version__
    rows["written (UTC)"] = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S")
    return facts_table(rows)


def warnings_section(messages: Sequence[str]) -> str:
    """The warnings of the run, as the console printed them; says so when there were none.

    Parameters
    ----------
    messages : sequence of str

    Returns
    -------
    str
    """
    if not messages:
        return "<h2>Warnings</h2><p class='note'>The run raised no warning.</p>"
    items = "".join(f"<li>{html.escape(message)}</li>" for message in messages)
    return f"<h2>Warnings</h2><p class='note'>Every warning the run raised:</p><ul>{items}</ul>"


def _scores_note(result: IdentificationResult) -> str:
    """What VAF and fit are, and why VAF stops at 0."""
    start = ("the zero initial state" if result.options.x0 == "zero" else
             "a least-squares initial state fitted to the same outputs (so the scores are "
             "a little optimistic)")
    return f"""<p class="note"><b>VAF</b> (variance accounted for) of output <i>i</i>:
100 &middot; (1 &minus; var(y<sub>i</sub> &minus; &ycirc;<sub>i</sub>) / var(y<sub>i</sub>)),
clipped at 0. <b>Fit</b> (normalized root-mean-square): 100 &middot; (1 &minus;
&Vert;y<sub>i</sub> &minus; &ycirc;<sub>i</sub>&Vert; / &Vert;y<sub>i</sub> &minus;
mean(y<sub>i</sub>)&Vert;). Both compare the measured outputs y with a <b>simulation</b>
&ycirc;: the model is driven by the measured inputs alone, from {start}, and never sees
the measured outputs; this is not a one-step-ahead prediction, which scores much higher
on the same model. VAF is clipped at 0 as the MOLI-ZOFT paper defines it: a model no
better than the output's mean scores 0 whatever its error, so one diverging output cannot
drag the mean VAF, and with it the choice of the order, arbitrarily far down. Fit is not
clipped: a negative fit says how bad a bad output is. var removes the mean, so VAF ignores
a constant offset in the error; fit counts it. Scores are percent, 100 is perfect.</p>"""


def _options_table(result: IdentificationResult) -> str:
    options = {name: str(value) for name, value in result.options.to_dict().items()}
    options["nmax"] += f" (path ran to {result.nmax})" if result.options.nmax is None else ""
    return facts_table(options)


def validation_caption(result: IdentificationResult) -> str:
    """Caption of the measured-against-simulated figure: what is drawn, in which units."""
    units = ("deviations from the estimation record's means (the model's operating point), "
             "so the curves need not centre on zero" if result.options.center else
             "the recorded values (IdentifyOptions.center is off: no offsets removed)")
    return (f"Measured and simulated outputs on the validation record "
            f"({html.escape(result.validation_source)}), with each output's VAF and fit (see "
            f"above); simulation from the {result.options.x0} initial state; {units}.")


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
<p class="note">Residuals on the validation record: {kind}; tested {analysis.tested_samples}
(docs/noise_model.md §4). Whiteness: Ljung-Box test over lags 1-{analysis.lags}; independence: chi-square test of the correlation with each prewhitened
input at lags 0-{analysis.lags}. A test fails below p = {1 - analysis.confidence:.2g}: of these
{analysis.tests} tests, a correct model fails at least one on about {analysis.false_alarm_rate:.0%} of records.</p>
<ul>{verdicts}</ul>
{figure_html}
"""


def _spectrum(record: IOData) -> EmpiricalResponse | None:
    """The figures' spectral estimate of ``record``; None when it is too short for one."""
    try:
        return empirical_frequency_response(record)
    except DataError:
        return None


def write_report(
    result: IdentificationResult,
    directory: str | Path,
    tried: Sequence[PathStep] = (),
    title: str = "moli identification report",
    *,
    data_file: str | Path | None = None,
    warnings: Sequence[str] | None = None,
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
        Lists fitted besides the greedy path (e.g. :func:`moli.method.search.greedy_path.exhaustive`),
        drawn as dots on the VAF-against-order figure.
    title : str
        Heading of the report.
    data_file : str or Path, optional
        The file the record was read from: the report gives its name and SHA-256.
        Default: the source recorded in ``result.model.info["data"]``, if any.
    warnings : sequence of str, optional
        Every warning the run raised (reading, screening, the search, the order rule):
        the report lists them under the model. Default: no warnings section.

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
    # spectra and residual correlations run through time: on the longest stretch without a gap
    continuous = longest_segment(validation)
    spectrum = _spectrum(continuous)
    no_spectrum = "" if spectrum is not None else (f" (no spectral estimate: the longest validation stretch, "
                                                   f"{continuous.N} samples, is too short for one)")
    bands = (f", shaded: pointwise {figures.BAND_CONFIDENCE:.0%} confidence band of the estimate "
             "(docs/uncertainty.md)." if model.cov_factor is not None else ".")
    drawn = {
        "vaf_by_order": (figures.vaf_by_order(result.path, tried, result.selected_index),
                         "Mean validation VAF against the order: the greedy path"
                         + (" and every other list fitted (grey)." if tried else ".")),
        "validation": (figures.measured_vs_simulated(validation, comparison),
                       validation_caption(result)),
        "poles": (figures.poles(model), "Poles of the selected model and the unit circle."),
        "step_responses": (figures.step_responses(model, figures.settling_samples(model, result.estimation.N)),
                           "Unit-step responses from each input to each output (deviations)" + bands),
        "magnitude": (frequency_figures.bode_magnitude(model, spectrum),
                      "Gain of each channel against frequency, up to the Nyquist frequency" + no_spectrum
                      + bands),
        "singular_values": (frequency_figures.singular_values(model, spectrum),
                            "Singular values of the frequency response (largest and smallest gain "
                            "over input directions) beside those of the spectral estimate"
                            + (f" (from the longest validation segment, {continuous.N} samples)."
                               if validation.n_segments > 1 else ".") + no_spectrum),
    }
    analysis = drawn_residuals(model, continuous, drawn)
    # what the record says of the responses, whatever the model's order
    impulse = regularized_fit(result.estimation)
    drawn.update(impulse_figures(impulse))
    figures_html = embedded_figures(drawn, out)
    residuals = "" if analysis is None else residual_section(analysis, figures_html.pop("residuals"))
    regularized = impulse_section(impulse, [figures_html.pop(name) for name in IMPULSE_FIGURES
                                            if name in figures_html], result.estimation.N)
    interrupted = (f"<p><b>Interrupted after the path: skipped {html.escape(', '.join(result.skipped))}; "
                   "the model is the best complete one before them.</b></p>" if result.skipped else
                   "<p><b>The search was interrupted; the path below is partial.</b></p>"
                   if result.interrupted else "")
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>{STYLE}</style></head><body>
<h1>{html.escape(title)}</h1>
<p class="note">Estimation {result.estimation.N} samples, validation {validation.N} samples
({html.escape(result.validation_source)}), Ts = {period_text(result.estimation.Ts, result.estimation.time_unit)}; total
{result.seconds:.1f} s.</p>
{_provenance(result, data_file)}
{interrupted}
<h2>Selected model</h2>{_model_facts(result)}
{'' if warnings is None else warnings_section(warnings)}
<h2>How to read the scores</h2>
{_scores_note(result)}
<h2>Greedy structure path</h2>
<p class="note">J: the criterion on the estimation record (0 is perfect). VAF: validation
record, simulation, percent. Selected: {html.escape(result.selection)}.</p>
{path_table(result)}
<h2>Figures</h2>
{''.join(figures_html.values())}
{regularized}
{residuals}
<h2>Identification options</h2>
<p class="note">Every field of IdentifyOptions (docs/method.md); the saved model records
the same in info["options"].</p>
{_options_table(result)}
</body></html>
"""
    target = out / "report.html"
    write_atomic(target, page)
    return target
