"""The HTML report of a continuous-time identification (``moli fit --continuous``).

The sections of the sampled report where they make sense: provenance, the run's
warnings, the poles in the plant's own units (time constants, natural frequencies,
damping), the static gains with their intervals, the greedy path, the validation
scores and record beside the model's simulation on its own time stamps, the step
responses and the gain against frequency with their bands, the residual analysis and
the options.
"""

from __future__ import annotations

import html
from datetime import datetime, timezone
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from . import figures
from .._version import __version__
from ..data.atomic_files import write_atomic
from ..data.display import angular_unit, figure_label, report_name, time_label
from ..data.files import file_sha256
from ..data.iodata import longest_segment
from ..method.continuous.estimation import simulate_stamped, stamped_record, warm_up_rows
from ..method.continuous.identification import ContinuousResult
from ..method.continuous.search import WARM_UP
from ..models.bands import magnitude_bands
from ..validation.comparison import compare
from .report import STYLE, drawn_residuals, embedded_figures, facts_table, residual_section, warnings_section

__all__ = ["write_continuous_report"]

# Frequencies of the gain figure: this factor below the slowest pole and above the fastest.
FREQUENCY_MARGIN = 30.0
# The step responses run to this many of the slowest pole's time constants (e^-6: settled
# to 0.25 % of the step), drawn at this many points.
SETTLING_TIME_CONSTANTS = 6.0
STEP_POINTS = 200


def _path_table(result: ContinuousResult) -> str:
    head = "".join(f"<th>{h}</th>" for h in ("n", "indices", "J", "mean VAF", "wc", "zeta", "stable"))
    rows = []
    for i, st in enumerate(result.path):
        cells = [str(st.order), html.escape(str(list(st.indices))), f"{st.J:.4f}", f"{st.mean_vaf:.2f}",
                 f"{st.eta[0]:.4g}", f"{st.eta[1]:.3f}", "yes" if st.stable else "no"]
        mark = ' class="selected"' if i == result.selected_index else ""
        rows.append(f"<tr{mark}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return f"<div class='wide'><table><tr>{head}</tr>{''.join(rows)}</table></div>"


def _gain_table(result: ContinuousResult) -> str:
    model = result.model
    if not model.is_stable():
        return "<p>The model is not stable: it has no static gain.</p>"
    gain = model.static_gain()
    if model.cov_factor is None:
        lower = upper = np.full(gain.shape, np.nan)
    else:
        lower, upper = model.static_gain_interval()
    head = "<th></th>" + "".join(f"<th>{html.escape(report_name(u))}</th>" for u in model.input_names)
    rows = "".join(
        f"<tr><th scope='row'>{html.escape(report_name(y))}</th>"
        + "".join(f"<td>{gain[i, j]:.4g} [{lower[i, j]:.4g}, {upper[i, j]:.4g}]</td>" for j in range(model.m))
        + "</tr>" for i, y in enumerate(model.output_names))
    return f"<div class='wide'><table><tr>{head}</tr>{rows}</table></div>"


def _validation_figure(result: ContinuousResult) -> Figure:
    record = stamped_record(result.validation)
    end = result.options.path_end(result.model.p)        # the warm-up the search scored with
    simulated = simulate_stamped(result.model.A, result.model.B, result.model.C, record,
                                 result.options.input_hold == "foh", WARM_UP, states=end)
    fig = figures.new_figure(7.0, figures.PANEL_HEIGHT * result.model.p + 0.4)
    axes = fig.subplots(result.model.p, 1, sharex=True, squeeze=False)[:, 0]
    for k, (t, y, yhat) in enumerate(zip(record.times, record.y, simulated)):
        warm = t[warm_up_rows(t.size, WARM_UP, end, result.model.p) - 1]
        for i, ax in enumerate(axes):
            ax.axvspan(t[0], warm, color="0.92", lw=0)
            ax.plot(t, y[:, i], color="0.5", lw=0.8, label="measured" if k == 0 else None)
            ax.plot(t, yhat[:, i], color="C1", lw=0.9, label="model" if k == 0 else None)
    for ax, name in zip(axes, result.model.output_names):
        ax.set_ylabel(figure_label(name))
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel(time_label(result.model.info.get("time_unit")))
    return fig


def _step_figure(result: ContinuousResult) -> Figure:
    """Unit-step responses of each channel, with their pointwise 95 % bands when the model has a covariance."""
    model = result.model
    decay = np.abs(model.poles().real)
    span = result.estimation.time()[-1] - result.estimation.time()[0]
    # a stable model's slowest time constant sets the horizon; an integrator or an unstable model the record's span
    horizon = SETTLING_TIME_CONSTANTS / decay.min() if model.is_stable() and decay.size and decay.min() > 0 else span
    t = np.linspace(0.0, horizon, STEP_POINTS)
    bands = None if model.cov_factor is None else model.step_bands(t, figures.BAND_CONFIDENCE)
    fig, axes = figures.channel_grid(model, "to", time_label(model.info.get("time_unit")))
    for j in range(model.m):
        step = np.zeros((t.size, model.m))
        step[:, j] = 1.0
        with np.errstate(all="ignore"):
            response = model.simulate_at(step, t)
        for i in range(model.p):
            if bands is not None:
                axes[i, j].fill_between(t, bands[0][:, i, j], bands[1][:, i, j], color="C0", alpha=0.2, lw=0)
            axes[i, j].plot(t, response[:, i], color="C0", lw=1.2)
            axes[i, j].axhline(0.0, color="0.8", lw=0.8)
            axes[i, j].grid(alpha=0.3)
    return fig


def _scores_table(result: ContinuousResult) -> str:
    """Each output's validation VAF as the search scored it, and as ``moli validate`` scores the model."""
    simulated = compare(result.model, result.validation, "zero")
    head = "".join(f"<th>{h}</th>" for h in ("output", "VAF % (search)", "VAF % (from rest)", "fit % (from rest)"))
    rows = "".join(f"<tr><th scope='row'>{html.escape(report_name(name))}</th><td>{result.selected.vaf[i]:.2f}</td>"
                   f"<td>{simulated.vaf[i]:.2f}</td><td>{simulated.fit[i]:.2f}</td></tr>"
                   for i, name in enumerate(result.model.output_names))
    return (f"<div class='wide'><table><tr>{head}</tr>{rows}</table></div><p class='note'>Search: the initial "
            f"state of each segment fitted on its first {WARM_UP:.0%}, the VAF counted on the rest (the order "
            "rule's score). From rest: the simulation from the zero state over the whole validation record, "
            "as moli validate and validate-many score the model.</p>")


def _gain_figure(result: ContinuousResult) -> Figure:
    model = result.model
    speeds = np.abs(model.poles())
    omega = np.geomspace(max(speeds.min(), 1e-12) / FREQUENCY_MARGIN, speeds.max() * FREQUENCY_MARGIN, 200)
    gain = np.abs(model.frequency_response(omega))
    lower, upper = magnitude_bands(model, omega) if model.cov_factor is not None else (gain, gain)
    fig, axes = figures.channel_grid(model, "gain", angular_unit(model.info.get("time_unit")))
    for i in range(model.p):
        for j in range(model.m):
            ax = axes[i, j]
            ax.fill_between(omega, lower[:, i, j], upper[:, i, j], color="C0", alpha=0.25, lw=0)
            ax.loglog(omega, gain[:, i, j], color="C0")
    return fig


def write_continuous_report(result: ContinuousResult, directory: str | Path,
                            data_file: str | Path | None = None, *, warnings: Sequence[str] = ()) -> Path:
    """Write ``report.html`` and its figures (PNG) for a continuous-time identification.

    Parameters
    ----------
    result : ContinuousResult
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
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    step, model = result.selected, result.model
    recorded = model.info.get("data", {})
    provenance = {"input": str(data_file) if data_file is not None else recorded.get("source", "not recorded")}
    if data_file is not None:
        provenance["SHA-256 of the input file"] = file_sha256(data_file)
    if "sha256" in recorded:
        provenance["SHA-256 of the estimation samples"] = recorded["sha256"]
    provenance |= {"moli version": __version__,
                   "written (UTC)": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S")}
    facts = {"indices": str(list(step.indices)), "order n": str(step.order),
             "filter (wc, zeta)": f"{step.eta[0]:.4g} {angular_unit(model.info.get('time_unit'))}, {step.eta[1]:.3f}",
             "input between samples": {"zoh": "held", "foh": "linear"}[result.options.input_hold],
             "stable": "yes" if model.is_stable() else "NO (a pole with a non-negative real part)",
             "selected by": f"{result.selection} ({result.validation_source})"}
    bands = ", shaded: pointwise 95 % confidence band of the estimate." if model.cov_factor is not None else "."
    drawn = {
        "validation": (_validation_figure(result), "Validation record (grey) and the model's simulation "
                       "on the same time stamps. Each segment's initial state is fitted on its "
                       f"first {WARM_UP:.0%} (shaded), and the VAF counts the rest."),
        "step_responses": (_step_figure(result), "Unit-step responses from each input to each output "
                           f"(deviations), to {SETTLING_TIME_CONSTANTS:g} time constants of the slowest pole" + bands),
        "magnitude": (_gain_figure(result), "Gain of each channel against frequency" + bands),
    }
    analysis = drawn_residuals(model, longest_segment(result.validation), drawn)
    shown = embedded_figures(drawn, out)
    residuals = "" if analysis is None else residual_section(analysis, shown.pop("residuals"))
    options = facts_table({name: str(value) for name, value in result.options.to_dict().items()})
    poles = "".join(f"<li>{html.escape(line.strip())}</li>" for line in model.pole_table()[1:]
                    if line.startswith("  "))
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>moli continuous-time identification</title>
<style>{STYLE}</style></head><body>
<h1>moli continuous-time identification</h1>
<p class="note">Estimation {result.estimation.N} samples, validation {result.validation.N} samples;
total {result.seconds:.1f} s. docs/continuous.md says what the method assumes.</p>
{facts_table(provenance)}
<h2>Selected model</h2>{facts_table(facts)}
{warnings_section(warnings)}
<h3>Poles ({angular_unit(model.info.get('time_unit'))}): time constants, natural frequencies and damping</h3><ul>{poles}</ul>
<h3>Static gains with their 95 % intervals</h3>{_gain_table(result)}
{"" if result.covariance_note is None else f"<p>No covariance, so no intervals or bands: {html.escape(result.covariance_note)}</p>"}
<h2>Greedy structure path</h2>
<p class="note">J: the criterion on the estimation record. VAF: validation record, percent.</p>
{_path_table(result)}
<h2>Validation</h2>{_scores_table(result)}
<h2>Figures</h2>{"".join(shown.values())}
{residuals}
<h2>Options</h2>{options}
</body></html>
"""
    target = out / "report.html"
    write_atomic(target, page)
    return target
