"""``moli fit --continuous``: the continuous-time identification of a record, its model and report."""

from __future__ import annotations

from pathlib import Path

import click

from ..data.iodata import IOData
from ..method.options import IdentifyOptions
from .continuous_report import write_continuous_report
from .progress import Phases
from .reading import RunWarnings
from .search_run import held_out_search

__all__ = ["fit_continuous"]


def fit_continuous(data: IOData, fraction: float, options: IdentifyOptions, noted: RunWarnings,
                   model_path: Path, report_dir: Path | None, data_file: Path | None) -> None:
    """Identify in continuous time on all but the last ``fraction`` of ``data``; save and report."""
    result = held_out_search(data, fraction, options, noted)
    click.echo(result.summary())
    model_path.parent.mkdir(parents=True, exist_ok=True)
    result.model.save(model_path)
    click.echo(f"model written to {model_path}")
    if report_dir is not None:
        with Phases() as phases:
            phases("report")
            report = write_continuous_report(result, report_dir, data_file)
        click.echo(f"report written to {report}")
