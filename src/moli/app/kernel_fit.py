"""``moli fit --method kernel`` (or ``kernel-arx``): the state-space model realizing a record's
regularized impulse response (or reducing its regularized ARX model), its order chosen on the
held-out tail (docs/regularization.md), its model file and report."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from ..data.files import file_sha256, fingerprint
from ..data.iodata import IOData
from ..method.options import IdentifyOptions
from .console import InterruptHold
from .kernel_report import write_kernel_report
from .outputs import save_held
from .progress import Phases
from .reading import RunWarnings
from .search_run import held_out_search

__all__ = ["fit_kernel"]

# The fit shows its line once it has run this long (seconds): a short record's is done before.
SHOWN_AFTER = 1.0


def fit_kernel(data: IOData, fraction: float, options: IdentifyOptions, noted: RunWarnings, *,
               model_path: Path, report_dir: Path | None, data_files: tuple[Path, ...],
               facts: dict[str, Any], hold: InterruptHold) -> int:
    """Identify by a kernel method on all but the last ``fraction`` of ``data``; save and report.

    The model file's ``info`` holds what a MOLI model's does: the options, the run's warnings,
    the kernel and the impulse response's or the ARX model's lags, and the data (fingerprint of the estimation
    part, sample counts, the input files' SHA-256, ``facts``). ``hold`` starts as the fit
    returns and ends once the model is written. Returns the exit code: 0 (the kernel method has
    no partial results).
    """
    estimation, validation = data.split(1.0 - fraction)       # the records as read, for the fingerprint
    with Phases() as phases:
        phases.shown_after("regularized impulse response and its realizations" if options.method == "kernel"
                           else "regularized ARX model and its truncations", SHOWN_AFTER)
        result = held_out_search(data, fraction, options, noted, hold=hold)
    hashes = [file_sha256(path) for path in data_files]
    result.model.info.update({
        "data": {"sha256": fingerprint(estimation), "N": estimation.N, "validation_N": validation.N,
                 "validation_fraction": fraction, "validation_source": result.validation_source,
                 "file_sha256": hashes[0] if len(hashes) == 1 else hashes, **facts},
        "warnings": list(noted.messages)})
    click.echo(result.summary())
    save_held(result.model, model_path, hold)
    if report_dir is not None:
        with Phases() as phases:
            phases("report")
            report = write_kernel_report(result, report_dir, data_files[0] if len(data_files) == 1 else None,
                                         warnings=noted.messages)
        click.echo(f"report written to {report}")
    return 0
