"""The one-call entry point, as the chain of its steps (docs/method.md).

prepare (:mod:`.pipeline.preparation`: the call's options, the hold-out, the records the
search runs on) → path (:mod:`.search`) → order (:mod:`.pipeline.order_choice`) → refine
and finish (:mod:`.pipeline.finishing`: the guarded refinement, the long-record
re-estimate, the direct method, the covariance and the noise model).
"""

from __future__ import annotations

import time
from typing import Any, Callable

from ..data import FrequencyData, IOData
from .options import IdentifyOptions, options_section
from .pipeline.finishing import checked_selection, record_of_making, refine_and_finish
from .pipeline.interruption import Phases, post_path_phases
from .pipeline.order_choice import choose_order
from .pipeline.routes import HandedOver, frequency_route, handed_over
from .pipeline.preparation import call_options, check_hooks, prepare, split_records
from .result import IdentificationResult
from .search.greedy_path import PathStep, StructureSearch, path_until_interrupted
from ..numerics.blas_threads import limited_blas

__all__ = ["IdentificationResult", "identify"]


def identify(
    data: IOData | FrequencyData,
    validation: IOData | None = None,
    options: IdentifyOptions | None = None,
    *,
    progress: Callable[[PathStep], None] | None = None,
    phase: Callable[[str], None] | None = None,
    **overrides: Any,
) -> IdentificationResult | HandedOver:
    """Identify a multivariable state-space model with MOLI-ZOFT.

    Parameters
    ----------
    data : IOData or FrequencyData
        Estimation record, or a measured frequency response (docs/frequency.md).
    validation : IOData, optional
        Validation record, used only by the order rule. When omitted, the last
        30 % of ``data`` is held out for it (``result.validation_source`` says so).
    options : IdentifyOptions, optional
        Every choice of the identification; default ``IdentifyOptions()``, the defaults
        chosen on the generalization benchmark (docs/accuracy.md).
    progress : callable, optional
        Called with each :class:`PathStep` as the path grows.
    phase : callable, optional
        Called with the name of each phase after the path as it starts ("refinement",
        "covariance", "noise model", ...: the names ``IdentificationResult.skipped`` uses),
        so that a caller can show the work that follows the path.
    **overrides
        Fields of :class:`IdentifyOptions` changed for this call:
        ``identify(est, val, nmax=12)`` is ``identify(est, val, IdentifyOptions(nmax=12))``.
        ``preset="paper"`` (or "bounded", "improved", "fast", "default") starts from that preset instead
        of the default; it cannot be combined with ``options``. Every field, with its default, is
        listed under Other Parameters.

    Returns
    -------
    IdentificationResult
        Or, with ``time="continuous"``, a :class:`ContinuousResult` whose model is a
        :class:`ContinuousModel` (docs/continuous.md); from :class:`FrequencyData`, a
        :class:`FrequencyResult` (docs/frequency.md); with ``method="kernel"``, a
        :class:`KernelResult`, with ``method="kernel-arx"`` a :class:`KernelArxResult`
        (docs/regularization.md).

    Raises
    ------
    OptionError
        An unknown or invalid option (before any work); the message names it.
    DataError
        Records that are not :class:`IOData`, or whose channels do not match; a channel
        above 1e150 or below 1e-150 in magnitude; an ``nmax`` or ``order`` beyond what
        the record's samples can estimate (all before the search).

    Examples
    --------
    >>> import moli
    >>> est, val = moli.example_data(N=600, seed=1).split(400)
    >>> result = moli.identify(est, val, nmax=6)
    >>> result.selected.order <= 6
    True
    >>> paper = moli.identify(est, val, moli.IdentifyOptions.paper(nmax=6))
    >>> paper.options.feedthrough
    False
    """
    with limited_blas():
        options = call_options(options, overrides)
        from_frequencies = frequency_route(data, validation, options, progress, phase)
        if from_frequencies is not None:
            return from_frequencies
        check_hooks(data, progress, phase)
        estimation, validation, source = split_records(data, validation, options)
        nmax = options.path_end(data.p)
        handed = handed_over(estimation, validation, source, options, progress, phase)
        if handed is not None:       # continuous time, or the kernel method
            return handed
        start = time.perf_counter()
        prepared = prepare(estimation, validation, options)
        options = prepared.options
        search = StructureSearch.from_options(prepared.searched, prepared.scored, prepared.grid, options,
                                              prepared.radius)
        # a fixed order is reached whatever the fit on the way
        path, interrupted = path_until_interrupted(search, nmax, progress, margin=options.order_tolerance,
                                                   patience=options.path_patience if options.order is None else None)
        refined = prepared.refinements()
        # Ctrl-C after the path keeps the best complete model so far (moli.method.pipeline.interruption)
        phases = Phases(post_path_phases(options, long_record=prepared.long_record, direct=prepared.loop == "direct"),
                        phase)
        selection = choose_order(path, search, refined, options, phases, interrupted=interrupted)
        if not phases.skipped:
            refine_and_finish(selection, search, refined, prepared, phases, interrupted=interrupted)
        returned = selection.step               # delay-free, as the search scores it: for the bound warning
        model = record_of_making(selection, prepared, phases.skipped)
        skipped = checked_selection(selection, search, refined, prepared, returned=returned, nmax=nmax,
                                    interrupted=interrupted, skipped=phases.skipped)
        return IdentificationResult(
            model=model, path=selection.path, selected_index=selection.index, estimation=prepared.estimation,
            validation=prepared.validation, validation_source=source, options=options, nmax=nmax, omega=prepared.grid,
            max_radius=prepared.radius, seconds=time.perf_counter() - start,
            interrupted=interrupted or bool(skipped), skipped=skipped,
        )


if identify.__doc__:        # None under python -OO
    # every option with its default, generated from IdentifyOptions so that the help cannot drift
    identify.__doc__ = identify.__doc__.replace("    Returns\n    -------\n", options_section() + "    Returns\n    -------\n", 1)
