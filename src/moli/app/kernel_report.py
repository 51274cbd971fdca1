"""The HTML report of the kernel methods (``moli fit --method kernel`` or ``kernel-arx``, docs/regularization.md).

The sections of the MOLI report where they make sense: provenance, the selected model, the
run's warnings, every order's realization (or truncation) with its validation VAF, the validation
record beside the model's simulation, the poles, the step and gain responses with their bands,
the regularized impulse and step responses (for ``kernel`` those the model realizes; for
``kernel-arx`` the record's, as every report has them) with the hyperparameters that chose them,
the residual analysis and the options.
"""

from __future__ import annotations

import html
from datetime import datetime, timezone
from pathlib import Path
from typing import Sequence

import numpy as np

from . import figures, frequency_figures
from .impulse_section import IMPULSE_FIGURES, impulse_figures, impulse_section, regularized_fit
from .._version import __version__
from ..data.atomic_files import write_atomic
from ..data.display import period_text, report_name
from ..data.files import file_sha256
from ..data.iodata import longest_segment
from ..method.kernel.arx_model import KernelArxResult
from ..method.kernel.kernel_model import KernelResult
from ..method.pipeline.routes import KERNEL_READS
from ..validation.comparison import compare
from .report import STYLE, drawn_residuals, embedded_figures, facts_table, residual_section, warnings_section

__all__ = ["write_kernel_report"]


def _path_table(result: KernelResult | KernelArxResult) -> str:
    """Every order's realization: validation VAF per output, its mean, stability; the selected one highlighted."""
    names = result.estimation.output_names
    head = "".join(f"<th>{html.escape(h)}</th>" for h in
                   ["n", *(f"VAF {report_name(name)}" for name in names), "mean VAF", "stable"])
    rows = []
    for i, step in enumerate(result.path):
        cells = [str(step.order), *(f"{v:.2f}" for v in step.vaf), f"{step.mean_vaf:.2f}",
                 "yes" if step.stable else "no"]
        mark = ' class="selected"' if i == result.selected_index else ""
        rows.append(f"<tr{mark}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return f"<div class='wide'><table><tr>{head}</tr>{''.join(rows)}</table></div>"


def write_kernel_report(result: KernelResult | KernelArxResult, directory: str | Path,
                        data_file: str | Path | None = None, *, warnings: Sequence[str] = ()) -> Path:
    """Write ``report.html`` and its figures (PNG) for a kernel method's identification.

    Parameters
    ----------
    result : KernelResult or KernelArxResult
    directory : str or Path
        Created if missing.
    data_file : str or Path, optional
        The file the record was read from: the report gives its name and SHA-256.
    warnings : sequence of str, optional
        Every warning the run raised, listed in the Warnings section.

    Returns
    -------
    Path
        The HTML file.

    Examples
    --------
    >>> import moli, tempfile
    >>> result = moli.identify(moli.example_data(N=300, seed=1), method="kernel", nmax=4)
    >>> write_kernel_report(result, tempfile.mkdtemp()).name
    'report.html'
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    model, validation = result.model, result.validation
    if isinstance(result, KernelResult):
        fit = result.impulse
        method = f"realization of the regularized impulse response ({fit.kernel} prior, {len(fit.lags)} lags)"
        steps, posterior = "realization of the impulse response below", "the impulse response's posterior"
    else:
        fit = regularized_fit(result.estimation)
        method = (f"balanced reduction of the regularized ARX model ({result.arx.kernel} prior, {result.arx.lags} "
                  "lags per channel)")
        steps, posterior = "balanced truncation of the regularized ARX model", "the ARX model's posterior"
    options = model.info.get("options", {})
    x0 = options.get("x0", "zero")
    recorded = model.info.get("data", {})
    provenance = {"input": str(data_file) if data_file is not None else recorded.get("source", "not recorded")}
    if data_file is not None:
        provenance["SHA-256 of the input file"] = file_sha256(data_file)
    if "sha256" in recorded:
        provenance["SHA-256 of the estimation samples"] = recorded["sha256"]
    provenance |= {"moli version": __version__,
                   "written (UTC)": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S")}
    radius = float(np.max(np.abs(model.poles()), initial=0.0))
    facts = {"method": method,
             "order n": str(model.n), "outputs": ", ".join(map(report_name, model.output_names)),
             "inputs": ", ".join(map(report_name, model.input_names)),
             "Ts": period_text(model.Ts, model.info.get("time_unit")),
             "largest pole modulus": f"{radius:.4f} ({'stable' if model.is_stable() else 'UNSTABLE'})",
             "selected by": f"the lowest order within one paired standard error of the best validation error, on "
                            f"{validation.N} validation samples ({result.validation_source})"}
    comparison = compare(model, validation, x0)
    bands = (f", shaded: pointwise {figures.BAND_CONFIDENCE:.0%} confidence band of the estimate "
             f"({posterior} pushed through the model)." if model.cov_factor is not None
             else ".")
    drawn = {
        "validation": (figures.measured_vs_simulated(validation, comparison),
                       "Measured and simulated outputs on the validation record "
                       f"({html.escape(result.validation_source)}), with each output's VAF and fit; simulation "
                       f"from the {x0} initial state."),
        "poles": (figures.poles(model), "Poles of the selected model and the unit circle."),
        "step_responses": (figures.step_responses(model, figures.settling_samples(model, result.estimation.N)),
                           "Unit-step responses of the model from each input to each output (deviations)" + bands),
        "magnitude": (frequency_figures.bode_magnitude(model), "Gain of each channel against frequency, up to "
                      "the Nyquist frequency" + bands),
        **impulse_figures(fit),
    }
    analysis = drawn_residuals(model, longest_segment(validation), drawn)
    shown = embedded_figures(drawn, out)
    residuals = "" if analysis is None else residual_section(analysis, shown.pop("residuals"))
    regularized = impulse_section(fit, [shown.pop(name) for name in IMPULSE_FIGURES], result.estimation.N)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>moli kernel identification</title>
<style>{STYLE}</style></head><body>
<h1>moli kernel identification</h1>
<p class="note">Estimation {result.estimation.N} samples, validation {validation.N} samples
({html.escape(result.validation_source)}). docs/regularization.md says what the method assumes.</p>
{facts_table(provenance)}
<h2>Selected model</h2>{facts_table(facts)}
{warnings_section(warnings)}
<h2>Realizations</h2>
<p class="note">Each order's {steps}, simulated on the
validation record from the {x0} initial state. VAF: percent, 100 is perfect, clipped at 0.</p>
{_path_table(result)}
<h2>Figures</h2>{"".join(shown.values())}
{regularized}
{residuals}
<h2>Options</h2>
<p class="note">The options the kernel methods read (the model records every option in info["options"]).</p>
{facts_table({name: str(value) for name, value in options.items() if name in KERNEL_READS})}
</body></html>
"""
    target = out / "report.html"
    write_atomic(target, page)
    return target
