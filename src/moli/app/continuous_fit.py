"""``moli fit --continuous``: the continuous-time identification of a record, its model and report."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import click

from ..data.files import file_sha256, fingerprint
from ..data.iodata import IOData
from ..method.continuous import ContinuousResult
from ..method.options import IdentifyOptions
from .console import InterruptHold
from .continuous_report import write_continuous_report
from .outputs import save_held
from .progress import Phases
from .reading import RunWarnings
from .search_run import held_out_search

__all__ = ["fit_continuous", "recorded_model"]


def recorded_model(result: ContinuousResult, facts: dict[str, Any] | None = None) -> ContinuousResult:
    """``result`` with its model carrying ``facts`` (the data's source, ...) beside what
    :func:`moli.identify` recorded on it (the options, ``time`` among them, and the selected
    order's validation VAF)."""
    result.model = replace(result.model, info={**result.model.info, **(facts or {})})
    return result


def fit_continuous(data: IOData, fraction: float, options: IdentifyOptions, noted: RunWarnings, *,
                   model_path: Path, report_dir: Path | None, data_files: tuple[Path, ...],
                   facts: dict[str, Any], hold: InterruptHold) -> int:
    """Identify in continuous time on all but the last ``fraction`` of ``data``; save and report.

    The model file's ``info`` holds what a sampled model's does: the options, the run's
    warnings, and the data (fingerprint of the estimation part, sample counts, the input
    files' SHA-256, ``facts``). ``hold`` starts as the search returns and ends once the model
    is written. Returns the exit code: 0 (the continuous search has no partial results).
    """
    estimation, validation = data.split(1.0 - fraction)       # the records as read, for the fingerprint
    result = held_out_search(data, fraction, options, noted, hold=hold)
    hashes = [file_sha256(path) for path in data_files]
    recorded_model(result, {"data": {
        "sha256": fingerprint(estimation), "N": estimation.N, "validation_N": validation.N,
        "validation_fraction": fraction, "validation_source": result.validation_source,
        "file_sha256": hashes[0] if len(hashes) == 1 else hashes, **facts}})
    click.echo(result.summary())
    result.model.info["warnings"] = list(noted.messages)
    save_held(result.model, model_path, hold)
    if report_dir is not None:
        with Phases() as phases:
            phases("report")
            report = write_continuous_report(result, report_dir, data_files[0] if len(data_files) == 1 else None,
                                             warnings=noted.messages)
        click.echo(f"report written to {report}")
    return 0
