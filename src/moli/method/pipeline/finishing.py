"""The last steps of :func:`moli.identify`: the chosen model refined, re-estimated on the whole of
a long record, estimated jointly with its noise by the direct method, and given its covariance
and noise model; then the record of how it was made (docs/method.md §12, §15, docs/closed_loop.md).

Ctrl-C during one of these phases keeps the best complete model before it
(:mod:`moli.method.pipeline.interruption`).
"""

from __future__ import annotations

from dataclasses import replace
from functools import partial
from typing import Callable

from ...data.iodata import IOData
from ...errors import DataError
from ...models.statespace import StateSpaceModel
from ...validation.comparison import compare
from ..closed_loop.loop_method import loop_record
from ..refinement.levenberg_marquardt import is_refined
from ..refinement.prediction_error import prediction_error_refine
from ..refinement.refined_steps import RefinedSteps
from ..search.greedy_path import StructureSearch
from ..search.long_records import reestimate
from ..selection.guarded import PathSelection, guarded_refinement
from ..uncertainty.matrix_covariance import estimate_covariance
from ..uncertainty.noise_model import estimate_noise_model
from ..search.greedy_path import PathStep
from ..selection.checks import warn_if_at_bound, warn_if_no_better_than_mean, warn_if_short_selection
from .interruption import SELECTION_CHECKS, Phases
from .preparation import Prepared

__all__ = ["refine_and_finish", "record_of_making", "checked_selection", "attached"]


def refine_and_finish(selection: PathSelection, search: StructureSearch, refined: RefinedSteps, prepared: Prepared,
                      phases: Phases, *, interrupted: bool) -> None:
    """The chosen model's phases after the order rule, in place on ``selection``; those Ctrl-C
    stops are recorded in ``phases``."""
    options, searched = prepared.options, prepared.searched
    try:
        if prepared.long_record:      # docs/method.md §15: the selected list on the whole record
            phases.begin("re-estimation on the whole record")
            selection.keep(reestimate(selection.unrefined[selection.index], prepared.fitted, prepared.scored, options.s,
                                      options.feedthrough, options.x0, regularization=options.regularization))
            selection.step.model.info["search_samples"] = searched.N
            if options.refine == "path":
                phases.begin("refinement")
                selection.keep(refined(selection.step)[0])
        if options.refine == "selected":
            phases.begin("refinement")
            selection.keep(refined(selection.step)[0])
        elif options.refine == "guarded":
            phases.begin("refinement")
            guarded_refinement(selection, search, refined, options, interrupted=interrupted,
                               two_stage=prepared.first_stage is not None)
        if prepared.loop == "direct":
            # the noise model of the model so far starts the joint prediction-error estimate
            phases.begin("noise model")
            start_model = attached(estimate_noise_model, "noise_model", selection.step.model, searched)
            phases.begin("prediction error")
            direct = prediction_error_refine(start_model, searched, max_radius=prepared.bound).model
            selection.keep(replace(selection.step, model=direct, vaf=compare(direct, prepared.scored, options.x0).vaf))
        # covariance (of the problem that gave the model: a refined one's on the search window, the
        # least squares' on the whole record) and noise model (search window) of the delay-free
        # model, on the shifted record
        phases.begin("covariance")
        kept, first = selection.step.model, prepared.first_stage
        covariance = estimate_covariance if first is None else partial(estimate_covariance, first_stage=first)
        on = searched if is_refined(kept) or first is not None else prepared.fitted
        selection.keep(replace(selection.step, model=attached(covariance, "covariance", kept, on)))
        if options.noise_model and prepared.loop != "direct":
            phases.begin("noise model")
            selection.keep(replace(selection.step, model=attached(estimate_noise_model, "noise_model",
                                                                   selection.step.model, searched)))
    except KeyboardInterrupt:
        phases.cut()


def record_of_making(selection: PathSelection, prepared: Prepared, skipped: tuple[str, ...]) -> StateSpaceModel:
    """The model returned: the chosen one with the input delays attached (to every path step,
    as new steps) and ``info`` saying what made it (options, loop method, phases skipped)."""
    if skipped:
        selection.step.model.info["interrupted"] = {"skipped": list(skipped)}
    if any(prepared.delays):        # new steps: the search's own (returned, at_bound) stay as they were
        selection.path[:] = [replace(step, model=step.model.with_input_delays(prepared.delays))
                             for step in selection.path]
    model = selection.step.model
    model.info["options"] = prepared.options.to_dict()
    if prepared.estimation.time_unit is not None:     # the unit of Ts, for axes and tables
        model.info["time_unit"] = prepared.estimation.time_unit
    model.info["closed_loop"] = loop_record(prepared.loop, prepared.projection, prepared.feedback,
                                            prepared.options.closed_loop)
    return model


def checked_selection(selection: PathSelection, search: StructureSearch, refined: RefinedSteps, prepared: Prepared,
                      *, returned: PathStep, nmax: int, interrupted: bool, skipped: tuple[str, ...]) -> tuple[str, ...]:
    """The warnings about the model returned (unstable, an order at the search's bound, a short
    validation record, no output fitted better than its mean), pointing at the caller of
    :func:`moli.identify`; the phases skipped, with :data:`SELECTION_CHECKS` added where Ctrl-C
    stopped the checks (the model, complete, is kept).

    ``returned`` is the chosen step as the search scores it, without input delays.
    """
    options, model = prepared.options, selection.step.model
    try:
        model.warn_if_unstable(stacklevel=3)
        # a fixed order is the caller's choice, not the search running into its bound
        if not interrupted and selection.step.order != options.order:
            beyond = None if skipped else (search, selection.at_bound, returned,
                                           None if options.refine == "none" else refined)
            warn_if_at_bound(selection.path, selection.index, nmax, prepared.validation, options.x0, beyond=beyond,
                             stacklevel=3)
        warn_if_short_selection(selection.path, prepared.scored.N, prepared.scored.m, stacklevel=3)
        warn_if_no_better_than_mean(returned.model, prepared.scored, options.x0, stacklevel=3)
    except KeyboardInterrupt:       # the model is complete: Ctrl-C during its checks skips them alone
        skipped += (SELECTION_CHECKS,)
        model.info["interrupted"] = {"skipped": list(skipped)}
    return skipped


def attached(estimator: Callable[[StateSpaceModel, IOData], StateSpaceModel], key: str,
              model: StateSpaceModel, record: IOData) -> StateSpaceModel:
    """``estimator(model, record)`` (the covariance or the noise model), or ``model`` with
    the reason in ``info[key]`` when the estimator refuses it (an unstable model, a
    record too short for its least squares)."""
    try:
        return estimator(model, record)
    except DataError as exc:
        model.info[key] = {"method": "none", "reason": str(exc)}
        return model
