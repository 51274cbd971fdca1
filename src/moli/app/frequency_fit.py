"""``moli fit FILE --frequency``: a model fitted to a measured frequency response, its file, summary and report.

The command is ``moli fit`` with one more flag rather than a command of its own: the
channels, the orders, the options file and the outputs are named as for a record
(``--inputs force --outputs disp,accel`` picks the ``disp/force`` and ``accel/force``
columns). The flags that only a time record has (``--validation``, ``--seed``,
``--continuous``, ``--preset`` of the time-domain search, the reading flags of time
columns, ...) are refused by name before any work: the held-out lines are the validation,
and the file (with ``--ts`` for a sampled system) says the time base.
"""

from __future__ import annotations

import sys
import warnings
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable

import click
from click.core import ParameterSource
from tqdm import tqdm

from ..data.display import console_text
from ..data.files import file_sha256
from ..data.frequency_data import FrequencyData
from ..data.frequency_files import read_frequency_data
from ..errors import DataError, FrequencyConventionWarning, OptionError
from ..method.frequency import FrequencyResult, FrequencyStep
from ..method.frequency.identification import HOLD_OUT_EVERY
from ..method.identification import identify
from ..method.options import IdentifyOptions
from ..models.continuous import ContinuousModel
from .console import InterruptHold
from .frequency_report import delays_text, modal_lines, write_frequency_report
from .outputs import fit_outputs, run_folder, save_held
from .progress import Phases
from .reading import RunWarnings, names

__all__ = ["fit_frequency", "FREQUENCY_FLAGS", "selected_channels", "summary"]

# The parameters of ``moli fit`` that a frequency-response fit reads; any other flag given is refused.
FREQUENCY_FLAGS = ("data_files", "inputs", "outputs", "ts", "options_file", "nmax", "order", "model_path",
                   "report_dir", "force", "frequency", "delimiter", "averages")
# --delimiter's words, as the time-record readers take them
DELIMITER_WORDS = {"tab": "\t", "whitespace": r"\s+"}


def _refused_flags(ctx: click.Context) -> None:
    given = [param.opts[0] for param in ctx.command.params if param.name not in FREQUENCY_FLAGS
             and ctx.get_parameter_source(param.name) not in (ParameterSource.DEFAULT, None)]
    if given:
        raise OptionError(f"{', '.join(given)} {'does' if len(given) == 1 else 'do'} not apply to --frequency: "
                          "a frequency response is no time record (its order is judged on held-out lines, one in "
                          f"{HOLD_OUT_EVERY}; the file and --ts say its time base); leave "
                          f"{'it' if len(given) == 1 else 'them'} out")


def selected_channels(data: FrequencyData, inputs: list[str] | None, outputs: list[str] | None,
                      source: str) -> FrequencyData:
    """The pairs of the named outputs and inputs, in the order named (all of a side not named).

    Raises
    ------
    DataError
        A name that is not one of the file's channels, or named twice.
    """
    picked = []
    for flag, wanted, found in (("--outputs", outputs, data.output_names), ("--inputs", inputs, data.input_names)):
        wanted = list(found) if wanted is None else wanted
        unknown = [name for name in wanted if name not in found]
        if unknown or len(set(wanted)) != len(wanted) or not wanted:
            problem = f"no channel {', '.join(unknown)}" if unknown else "each channel once, at least one"
            raise DataError(f"{flag} {','.join(wanted)}: {problem} in {source}, whose pair columns name "
                            f"{'outputs' if flag == '--outputs' else 'inputs'} {', '.join(found)}")
        picked.append([found.index(name) for name in wanted])
    return data.pairs(slice(None), *picked)


def summary(result: FrequencyResult) -> str:
    """What the console prints of a fit: the order chosen and how, the model, its modes."""
    step, model = result.selected, result.model
    orders = f"orders {result.path[0].order}-{result.path[-1].order}"
    how = ("the fixed order (--order)" if result.options.order is not None
           else f"the paired rule on the held-out lines (one in {HOLD_OUT_EVERY}) among {orders}")
    kind = "continuous-time" if isinstance(model, ContinuousModel) else f"sampled (Ts = {model.Ts:g})"
    covariance = ("with covariance" if result.covariance_note is None
                  else f"no covariance: {result.covariance_note}")
    lines = [f"order {step.order} selected by {how}; held-out mean VAF {step.mean_vaf:.2f} %",
             f"{kind} model, {model.n} states, {'stable' if model.is_stable() else 'UNSTABLE'}, "
             f"{'refined on every line' if model.info['refined'] else 'not refined'}, "
             f"{covariance}; {result.seconds:.1f} s",
             *([f"input delays: {delays_text(model)}"] if any(model.input_delays) else []), *modal_lines(model)]
    return "\n".join(lines)


def _fitted(data: FrequencyData, options: IdentifyOptions, noted: RunWarnings, hold: InterruptHold) -> FrequencyResult:
    """identify on ``data`` behind a bar over the orders; ``hold`` starts as it returns."""
    bar = tqdm(total=options.path_end(data.p) if options.order is None else 1, desc="orders", unit="order",
               file=sys.stderr, delay=0.5)

    def progress(step: FrequencyStep) -> None:
        bar.set_postfix_str(f"n={step.order} held-out VAF {step.mean_vaf:.1f}%", refresh=False)
        bar.update()

    with warnings.catch_warnings(record=True) as caught, Phases() as phases:

        def phase(name: str) -> None:
            bar.close()         # the full bar stays above the phases after the orders
            phases(name)

        warnings.simplefilter("always")
        try:
            result = identify(data, None, options, progress=progress, phase=phase)
            hold.start()
        finally:
            bar.close()
    noted.add(caught)
    return result


def fit_frequency(ctx: click.Context, options_from_flags: Callable[..., IdentifyOptions]) -> int:
    """Run ``moli fit FILE --frequency`` on the parsed flags of ``ctx``; the exit code.

    The model file's ``info`` holds the options, the data (the file, its SHA-256, the lines,
    the channels, the time base) and the run's warnings, as ``moli fit`` writes them for a
    record; the report goes where ``--report`` (or the run's folder) says.
    """
    _refused_flags(ctx)
    flags: dict[str, Any] = ctx.params
    files: tuple[Path, ...] = flags["data_files"]
    if len(files) != 1:
        raise DataError(f"--frequency reads one frequency-response file, got {len(files)}")
    path = files[0]
    options = options_from_flags(flags["options_file"], None, nmax=flags["nmax"], order=flags["order"])
    read = [path, *([flags["options_file"]] if flags["options_file"] is not None else [])]
    model_path, report_dir = fit_outputs(flags["model_path"], flags["report_dir"], run_folder("fit", [path.stem]),
                                         flags["force"], read)
    noted = RunWarnings()
    delimiter = flags["delimiter"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", FrequencyConventionWarning)
        data = read_frequency_data(path, Ts=flags["ts"], sep=DELIMITER_WORDS.get(delimiter, delimiter),
                                   averages=flags["averages"])
    noted.add([w for w in caught if issubclass(w.category, FrequencyConventionWarning)])
    data = selected_channels(data, names(flags["inputs"]), names(flags["outputs"]), str(path))
    click.echo(f"{console_text(str(path))}: {data!r}")
    with InterruptHold() as hold:     # from the fit's return to the model on disk, Ctrl-C waits
        result = _fitted(data, options, noted, hold)
        # the time base the file gave, so that --options model.json reruns in it
        used = result.options.replace(time="discrete" if data.Ts is not None else "continuous")
        facts = {"options": used.to_dict(), "warnings": list(noted.messages),
                 "data": {"source": str(path), "file_sha256": file_sha256(path), "lines": data.F,
                          "omega_range": [float(data.omega[0]), float(data.omega[-1])], "Ts": data.Ts,
                          "outputs": list(data.output_names), "inputs": list(data.input_names),
                          "held_out_lines": int(result.held_out.size)}}
        model = result.model
        if isinstance(model, ContinuousModel):
            result.model = replace(model, info={**model.info, **facts})
        else:
            model.info.update(facts)
        click.echo(summary(result))
        save_held(result.model, model_path, hold)
    if report_dir is not None:
        with Phases() as phases:
            phases("report")
            report = write_frequency_report(result, data, report_dir, path, warnings=noted.messages)
        click.echo(f"report written to {report}")
    return 0
