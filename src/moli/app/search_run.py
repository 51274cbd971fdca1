"""One identification as the command line runs it: the validation tail split off, the
search behind its progress bar, the warnings kept for the report."""

from __future__ import annotations

import warnings

from ..data.iodata import IOData
from ..errors import DataError
from ..method.continuous import ContinuousResult
from ..method.identification import IdentificationResult, identify
from ..method.options import IdentifyOptions
from .console import InterruptHold
from .progress import search_progress
from .reading import RunWarnings

__all__ = ["held_out_search"]


def held_out_search(data: IOData, fraction: float, options: IdentifyOptions, noted: RunWarnings,
                    last_run: str | None = None, *,
                    hold: InterruptHold | None = None) -> IdentificationResult | ContinuousResult:
    """``identify`` on all but the last ``fraction`` of ``data``, validated on that tail.

    Parameters
    ----------
    data : IOData
    fraction : float
        Share of the record, at its end, held out for the order rule (``--validation``).
    options : IdentifyOptions
    noted : RunWarnings
        Receives every warning of the run.
    last_run : str, optional
        The file the tail comes from when several were merged (said in the result).
    hold : InterruptHold, optional
        Started the moment the search returns: from then on the model is complete, and Ctrl-C
        waits until the caller has written it.

    Returns
    -------
    IdentificationResult or ContinuousResult
    """
    if not 0.0 < fraction < 1.0:
        raise DataError(f"--validation must be a fraction in (0, 1), got {fraction}")
    estimation, validation = data.split(1.0 - fraction)
    with warnings.catch_warnings(record=True) as caught, search_progress(options, data.p) as (progress, phase):
        warnings.simplefilter("always")
        result = identify(estimation, validation, options, progress=progress, phase=phase)
        if hold is not None:
            hold.start()
    noted.add(caught)
    # identify was handed the tail as given validation data: say where it really came from
    result.validation_source = f"held out: last {fraction:.0%} of the record" + (
        f", from {last_run}" if last_run else "")
    return result
