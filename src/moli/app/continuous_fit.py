"""``moli fit --continuous``: the continuous-time identification of a record, its model and report."""

from __future__ import annotations

from pathlib import Path

import click

from ..data.iodata import IOData
from ..method.options import IdentifyOptions
from .console import InterruptHold
from .continuous_report import write_continuous_report
from .outputs import save_held
from .progress import Phases
from .reading import RunWarnings
from .search_run import held_out_search

__all__ = ["fit_continuous"]


def fit_continuous(data: IOData, fraction: float, options: IdentifyOptions, noted: RunWarnings,
                   model_path: Path, report_dir: Path | None, data_file: Path | None, *,
                   hold: InterruptHold) -> int:
    """Identify in continuous time on all but the last ``fraction`` of ``data``; save and report.

    ``hold`` starts as the search returns and ends once the model is written. Returns the exit
    code: 0 (the continuous search has no partial results).
    """
    result = held_out_search(data, fraction, options, noted, hold=hold)
    click.echo(result.summary())
    save_held(result.model, model_path, hold)
    if report_dir is not None:
        with Phases() as phases:
            phases("report")
            report = write_continuous_report(result, report_dir, data_file)
        click.echo(f"report written to {report}")
    return 0
