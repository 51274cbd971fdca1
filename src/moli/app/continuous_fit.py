"""``moli fit --continuous``: the continuous-time identification of a record, its model and report."""

from __future__ import annotations

import warnings
from pathlib import Path

import click

from ..data.iodata import IOData
from ..errors import DataError
from ..method.identification import identify
from ..method.options import IdentifyOptions
from .continuous_report import write_continuous_report
from .progress import Phases, search_progress
from .reading import RunWarnings

__all__ = ["fit_continuous"]


def fit_continuous(data: IOData, fraction: float, options: IdentifyOptions, noted: RunWarnings,
                   model_path: Path, report_dir: Path | None, data_file: Path | None) -> None:
    """Identify in continuous time on all but the last ``fraction`` of ``data``; save and report."""
    if not 0.0 < fraction < 1.0:
        raise DataError(f"--validation must be a fraction in (0, 1), got {fraction}")
    estimation, validation = data.split(1.0 - fraction)
    with warnings.catch_warnings(record=True) as caught, search_progress(options, data.p) as (progress, phase):
        warnings.simplefilter("always")
        result = identify(estimation, validation, options, progress=progress, phase=phase)
    noted.add(caught)
    result.validation_source = f"held out: last {fraction:.0%} of the record"
    click.echo(result.summary())
    model_path.parent.mkdir(parents=True, exist_ok=True)
    result.model.save(model_path)
    click.echo(f"model written to {model_path}")
    if report_dir is not None:
        with Phases() as phases:
            phases("report")
            report = write_continuous_report(result, report_dir, data_file)
        click.echo(f"report written to {report}")
