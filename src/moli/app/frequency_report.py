"""The HTML report of a model fitted to a frequency response (``moli fit --frequency``).

Provenance, the selected model and how its order was chosen, the run's warnings, the
modal table, the orders tried, then the figures: per channel pair the data's and the
model's magnitude (with the model's 95 % band and the data's standard deviation where
the data carry a variance) and phase, the data's coherence where given, the error on every
line, and the stabilization
diagram (:mod:`moli.app.stabilization`); last the options.
"""

from __future__ import annotations

import html
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from matplotlib.figure import Figure

from .._version import __version__
from ..data.atomic_files import write_atomic
from ..data.display import report_name
from ..data.files import file_sha256
from ..data.frequency_data import FrequencyData
from ..method.frequency import FrequencyResult
from ..method.frequency.identification import HOLD_OUT_EVERY
from ..models.bands import magnitude_bands
from ..models.modal import modes
from .figure_files import save_figure
from .figures import BAND_CONFIDENCE, channel_grid
from .report import STYLE, embedded_image, facts_table, warnings_section
from .stabilization import DAMPING_TOLERANCE, FREQUENCY_TOLERANCE, MAC_THRESHOLD, stabilization, stabilization_figure

__all__ = ["write_frequency_report", "modal_lines", "drawn_lines", "delays_text", "MAX_DRAWN_LINES"]

# At most this many lines are drawn (evenly spread over the data's): a 2.4-inch panel is some
# 260 pixels wide, so more only slow the drawing; the fit and the tables use every line.
MAX_DRAWN_LINES = 2000
# The lower band edge in dB where it reaches |G| = 0: this far below the model's least gain.
BAND_FLOOR_DB = 40.0


def _with_std(value: float, std: float | None, digits: int) -> str:
    return f"{value:.{digits}f}" + ("" if std is None else f" ± {std:.2g}")


def modal_lines(model: Any) -> list[str]:
    """The modes as console lines: natural frequency in rad/s and Hz, damping ratio, with standard deviations."""
    lines = ["modes (natural frequency, damping ratio; ± one standard deviation):"]
    for k, mode in enumerate(modes(model), 1):
        hz_std = None if mode.natural_frequency_std is None else mode.natural_frequency_std / (2 * np.pi)
        lines.append(f"  {k}: {_with_std(mode.natural_frequency, mode.natural_frequency_std, 4)} rad/s  "
                     f"{_with_std(mode.frequency_hz, hz_std, 4)} Hz  zeta {_with_std(mode.damping, mode.damping_std, 4)}"
                     + ("" if mode.oscillatory else "  (real pole)"))
    return lines


def delays_text(model: Any) -> str:
    """The model's input delays by input name, in time units (continuous) or samples, and what the search
    estimated before the held-out lines judged each (``delays="auto"``)."""
    unit = "samples" if getattr(model, "Ts", None) is not None else "time units"
    shown = ", ".join(f"{name} {delay:.6g}" for name, delay in zip(model.input_names, model.input_delays))
    estimated = model.info.get("delays_estimated")
    return f"{shown} ({unit})" + ("" if estimated is None else
                                  f"; estimated before the held-out test: {', '.join(f'{d:.6g}' for d in estimated)}")


def _shape_entry(mode: Any, output: int) -> str:
    """One output's shape entry, magnitude and phase, with their standard deviations where the model has them."""
    value = mode.shape[output]
    # whole degrees as an int: round-off never prints "-0"
    degrees = round(float(np.degrees(np.angle(value))))
    if mode.shape_magnitude_std is None or mode.shape_magnitude_std[output] == 0:
        return f"{abs(value):.3f} ∠ {degrees}°"
    return (f"{abs(value):.3f} ± {mode.shape_magnitude_std[output]:.2g} ∠ {degrees}° "
            f"± {np.degrees(mode.shape_phase_std[output]):.2g}°")


def _modal_table(model: Any) -> str:
    outputs = "".join(f"<th>shape {html.escape(report_name(name))}</th>" for name in model.output_names)
    head = "<th>mode</th><th>natural frequency (rad/s)</th><th>(Hz)</th><th>damping ratio</th>" + outputs
    rows = []
    for k, mode in enumerate(modes(model), 1):
        hz_std = None if mode.natural_frequency_std is None else mode.natural_frequency_std / (2 * np.pi)
        shape = "".join(f"<td>{_shape_entry(mode, output)}</td>" for output in range(mode.shape.size))
        rows.append(f"<tr><td>{k}{'' if mode.oscillatory else ' (real)'}</td>"
                    f"<td>{_with_std(mode.natural_frequency, mode.natural_frequency_std, 4)}</td>"
                    f"<td>{_with_std(mode.frequency_hz, hz_std, 4)}</td>"
                    f"<td>{_with_std(mode.damping, mode.damping_std, 5)}</td>{shape}</tr>")
    return f"<div class='wide'><table><tr>{head}</tr>{''.join(rows)}</table></div>"


def _path_table(result: FrequencyResult) -> str:
    head = "".join(f"<th>{h}</th>" for h in ("n", "held-out mean VAF %", "refined", "stable", "estimation cost"))
    rows = []
    for i, step in enumerate(result.path):
        cells = [str(step.order), f"{step.mean_vaf:.4f}", "yes" if step.refined else "no",
                 "yes" if step.stable else "no", f"{step.cost:.4g}"]
        mark = ' class="selected"' if i == result.selected_index else ""
        rows.append(f"<tr{mark}>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return f"<div class='wide'><table><tr>{head}</tr>{''.join(rows)}</table></div>"


def drawn_lines(count: int) -> np.ndarray:
    """Positions of the lines drawn: all of them up to :data:`MAX_DRAWN_LINES`, else that many evenly spread."""
    if count <= MAX_DRAWN_LINES:
        return np.arange(count)
    return np.unique(np.linspace(0, count - 1, MAX_DRAWN_LINES).round().astype(int))


def _decibels(values: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(values)


def _magnitude_figure(model: Any, data: FrequencyData, lines: np.ndarray, fitted: np.ndarray) -> Figure:
    hz = data.hz[lines]
    fig, axes = channel_grid(model, "dB", "frequency (Hz)")
    bands = None if model.cov_factor is None else magnitude_bands(model, data.omega[lines], BAND_CONFIDENCE)
    model_db = _decibels(np.abs(fitted))
    floor = np.min(model_db[np.isfinite(model_db)], initial=0.0) - BAND_FLOOR_DB
    for i in range(model.p):
        for j in range(model.m):
            ax = axes[i, j]
            if bands is not None:
                ax.fill_between(hz, np.maximum(_decibels(bands[0][:, i, j]), floor), _decibels(bands[1][:, i, j]),
                                color="C0", alpha=0.25, lw=0, label="model 95 % band")
            ax.plot(hz, _decibels(np.abs(data.G[lines, i, j])), color="0.7", lw=2.4, label="data")
            if data.variance is not None:
                ax.plot(hz, _decibels(np.sqrt(data.variance[lines, i, j])), color="0.45", lw=0.8, ls=":",
                        label="data std")
            ax.plot(hz, model_db[:, i, j], color="C0", lw=1.1, label="model")
            ax.set_xscale("log")
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    return fig


def _phase_figure(model: Any, data: FrequencyData, lines: np.ndarray, fitted: np.ndarray) -> Figure:
    hz = data.hz[lines]
    fig, axes = channel_grid(model, "phase (deg)", "frequency (Hz)")
    model_phase = np.unwrap(np.angle(fitted), axis=0)
    # the data's phase drawn on the model's branch: no 360-degree jumps where the two agree
    with np.errstate(divide="ignore", invalid="ignore"):
        data_phase = model_phase + np.angle(data.G[lines] / fitted)
    for i in range(model.p):
        for j in range(model.m):
            ax = axes[i, j]
            ax.plot(hz, np.degrees(data_phase[:, i, j]), color="0.7", lw=2.4, label="data")
            ax.plot(hz, np.degrees(model_phase[:, i, j]), color="C0", lw=1.1, label="model")
            ax.set_xscale("log")
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    return fig


def _coherence_figure(model: Any, data: FrequencyData, lines: np.ndarray) -> Figure:
    hz = data.hz[lines]
    fig, axes = channel_grid(model, "coherence", "frequency (Hz)")
    for i in range(model.p):
        for j in range(model.m):
            ax = axes[i, j]
            ax.plot(hz, data.coherence[lines, i, j], color="C2", lw=0.9)
            ax.set_xscale("log")
            ax.set_ylim(-0.02, 1.02)
            ax.grid(alpha=0.3)
    return fig


def _error_figure(model: Any, data: FrequencyData, lines: np.ndarray, fitted: np.ndarray) -> Figure:
    hz = data.hz[lines]
    measured = np.abs(data.G[lines])
    fig, axes = channel_grid(model, "relative error", "frequency (Hz)")
    with np.errstate(divide="ignore", invalid="ignore"):
        error = np.abs(fitted - data.G[lines]) / measured
        noise = None if data.variance is None else np.sqrt(data.variance[lines]) / measured
    for i in range(model.p):
        for j in range(model.m):
            ax = axes[i, j]
            ax.plot(hz, error[:, i, j], color="C3", lw=0.8, label="|G_model - G_data| / |G_data|")
            if noise is not None:
                ax.plot(hz, noise[:, i, j], color="0.15", lw=1.1, ls=":", label="data std / |G_data|", zorder=3)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    return fig


def _provenance(data_file: Path | None, recorded: dict[str, Any]) -> dict[str, str]:
    rows = {"input": str(data_file) if data_file is not None else str(recorded.get("source", "not recorded"))}
    if data_file is not None:
        rows["SHA-256 of the input file"] = file_sha256(data_file)
    return rows | {"moli version": __version__,
                   "written (UTC)": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M:%S")}


def write_frequency_report(result: FrequencyResult, data: FrequencyData, directory: str | Path,
                           data_file: str | Path | None = None, *, warnings: Sequence[str] = ()) -> Path:
    """Write ``report.html`` and its figures (PNG) for a model fitted to frequency data.

    Parameters
    ----------
    result : FrequencyResult
    data : FrequencyData
        The lines the model was fitted to.
    directory : str or Path
        Created if missing.
    data_file : str or Path, optional
        The file the data were read from: the report gives its name and SHA-256.
    warnings : sequence of str, optional
        Every warning the run raised, listed in the Warnings section.

    Returns
    -------
    Path
        The HTML file.
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    model, step = result.model, result.selected
    lines = drawn_lines(data.F)
    fitted = model.frequency_response(data.omega[lines])
    band = "; shaded: the model's pointwise 95 % band" if model.cov_factor is not None else ""
    std = "; dotted: the data's standard deviation per line" if data.variance is not None else ""
    drawn = {
        "magnitude": (_magnitude_figure(model, data, lines, fitted),
                      f"Magnitude of each channel pair, data (grey) and model (blue){band}{std}."),
        "phase": (_phase_figure(model, data, lines, fitted), "Phase of each channel pair, data (grey) and model "
                  "(blue); the data's phase is drawn on the model's branch."),
        "coherence": (None if data.coherence is None else _coherence_figure(model, data, lines),
                      "The data's magnitude-squared coherence on each line: near 1 where the output is the "
                      "input's response, lower where noise, leakage or other inputs share the output."),
        "error": (_error_figure(model, data, lines, fitted), "The model's error on each line relative to the data, "
                  f"|G_model - G_data| / |G_data|{std.replace('; dotted', '; dotted grey')}: "
                  "where the error follows it, the model is as good as the data allow."),
        "stabilization": (stabilization_figure(stabilization(result.path_models), step.order,
                                               (float(data.hz[0]), float(data.hz[-1]))),
                          "Stabilization diagram: the modes of the model of every order tried (fitted on the "
                          "estimation lines), against their natural frequency. A mode is stable against the "
                          "previous order's mode nearest in frequency where the natural frequency moved by at "
                          f"most {FREQUENCY_TOLERANCE:.0%}, the damping ratio by at most {DAMPING_TOLERANCE:.0%}, "
                          f"and the output shapes' MAC is at least {MAC_THRESHOLD} (damping and shape judged only "
                          "where the frequency is stable). Modes outside the measured band are left out."),
    }
    drawn = {name: shown for name, shown in drawn.items() if shown[0] is not None}
    if len(lines) < data.F:
        drawn = {name: (fig, f"{caption} {len(lines)} of the {data.F} lines drawn, evenly spread.")
                 for name, (fig, caption) in drawn.items()}
    shown = "".join(f"<figure>{embedded_image(save_figure(fig, out / f'{name}.png'), name)}"
                    f"<figcaption class='note'>{html.escape(caption)}</figcaption></figure>"
                    for name, (fig, caption) in drawn.items())
    how = ("fixed order (--order)" if result.options.order is not None
           else f"paired rule on the held-out lines (one in {HOLD_OUT_EVERY})")
    facts = {"order n": str(step.order), "selected by": how, "held-out mean VAF": f"{step.mean_vaf:.4f} %",
             "time": "continuous" if data.Ts is None else f"sampled, Ts = {data.Ts:g}",
             "refined on every line": "yes" if model.info.get("refined") else "no",
             "stable": "yes" if model.is_stable() else "NO",
             "covariance": "yes" if result.covariance_note is None else f"none: {result.covariance_note}"}
    if any(model.input_delays) or "delays_estimated" in model.info:
        facts["input delays"] = delays_text(model)
    options = facts_table({name: str(value) for name, value in result.options.to_dict().items()})
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>moli frequency-domain identification</title>
<style>{STYLE}</style></head><body>
<h1>moli frequency-domain identification</h1>
<p class="note">{data.F} lines ({result.held_out.size} held out to choose the order), {data.p} output(s),
{data.m} input(s), {data.hz[0]:.4g}-{data.hz[-1]:.4g} Hz; total {result.seconds:.1f} s. docs/frequency.md says
what the method assumes.</p>
{facts_table(_provenance(None if data_file is None else Path(data_file), model.info.get("data", {})))}
<h2>Selected model</h2>{facts_table(facts)}
{warnings_section(warnings)}
<h3>Modes (± one standard deviation; shapes: each output's share, largest 1, magnitude ∠ phase)</h3>
{_modal_table(model)}
<h2>Orders tried</h2>
<p class="note">Held-out VAF: the weighted fit on the held-out lines, percent. Cost: the weighted squared error
on the estimation lines.</p>
{_path_table(result)}
<h2>Figures</h2>{shown}
<h2>Options</h2>{options}
</body></html>
"""
    target = out / "report.html"
    write_atomic(target, page)
    return target
