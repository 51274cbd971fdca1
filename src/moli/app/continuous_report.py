"""The HTML report of a continuous-time identification (``moli fit --continuous``).

The poles in the plant's own units (time constants, natural frequencies, damping),
the static gains with their intervals, the greedy path, the validation record beside
the model's simulation on its own time stamps, and the gain against frequency with
its band.
"""

from __future__ import annotations

import html
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from . import figures
from .figure_files import save_figure
from .._version import __version__
from ..data.atomic_files import write_atomic
from ..data.display import figure_label, report_name
from ..data.files import file_sha256
from ..method.continuous.estimation import simulate_stamped, stamped_record, warm_up_rows
from ..method.continuous.identification import ContinuousResult
from ..method.continuous.search import WARM_UP
from ..models.bands import magnitude_bands
from .report import STYLE, embedded_image, facts_table

__all__ = ["write_continuous_report"]

# Frequencies of the gain figure: this factor below the slowest pole and above the fastest.
FREQUENCY_MARGIN = 30.0


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
    axes[-1].set_xlabel("time")
    return fig


def _gain_figure(result: ContinuousResult) -> Figure:
    model = result.model
    speeds = np.abs(model.poles())
    omega = np.geomspace(max(speeds.min(), 1e-12) / FREQUENCY_MARGIN, speeds.max() * FREQUENCY_MARGIN, 200)
    gain = np.abs(model.frequency_response(omega))
    lower, upper = magnitude_bands(model, omega) if model.cov_factor is not None else (gain, gain)
    fig, axes = figures.channel_grid(model, "gain", "rad per time unit")
    for i in range(model.p):
        for j in range(model.m):
            ax = axes[i, j]
            ax.fill_between(omega, lower[:, i, j], upper[:, i, j], color="C0", alpha=0.25, lw=0)
            ax.loglog(omega, gain[:, i, j], color="C0")
    return fig


def write_continuous_report(result: ContinuousResult, directory: str | Path,
                            data_file: str | Path | None = None) -> Path:
    """Write ``report.html`` and its figures (PNG) for a continuous-time identification.

    Parameters
    ----------
    result : ContinuousResult
    directory : str or Path
        Created if missing.
    data_file : str or Path, optional
        The file the record was read from: the report gives its name and SHA-256.

    Returns
    -------
    Path
        The HTML file.
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    step, model = result.selected, result.model
    provenance = {"input": str(data_file) if data_file is not None else "not recorded"}
    if data_file is not None:
        provenance["SHA-256 of the input file"] = file_sha256(data_file)
    provenance |= {"moli version": __version__,
                   "written (UTC)": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S")}
    facts = {"indices": str(list(step.indices)), "order n": str(step.order),
             "filter (wc, zeta)": f"{step.eta[0]:.4g} rad per time unit, {step.eta[1]:.3f}",
             "input between samples": {"zoh": "held", "foh": "linear"}[result.options.input_hold],
             "selected by": f"{result.selection} ({result.validation_source})"}
    drawn = {
        "validation": (_validation_figure(result), "Validation record (grey) and the model's simulation "
                       "on the same time stamps. Each segment's initial state is fitted on its "
                       f"first {WARM_UP:.0%} (shaded), and the VAF counts the rest."),
        "magnitude": (_gain_figure(result), "Gain of each channel against frequency, shaded: pointwise "
                      "95 % confidence band of the estimate."),
    }
    shown = "".join(
        f"<figure>{embedded_image(save_figure(fig, out / f'{name}.png'), name)}"
        f"<figcaption class='note'>{caption}</figcaption></figure>" for name, (fig, caption) in drawn.items())
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
<h3>Poles (rad per time unit)</h3><ul>{poles}</ul>
<h3>Static gains with their 95 % intervals</h3>{_gain_table(result)}
{"" if result.covariance_note is None else f"<p>No covariance, so no intervals or bands: {html.escape(result.covariance_note)}</p>"}
<h2>Greedy structure path</h2>
<p class="note">J: the criterion on the estimation record. VAF: validation record, percent.</p>
{_path_table(result)}
<h2>Figures</h2>{shown}
</body></html>
"""
    target = out / "report.html"
    write_atomic(target, page)
    return target
