"""The one-call entry point: structure search, filter tuning, estimation, order rule."""

from __future__ import annotations

import time
import warnings
from dataclasses import replace
from functools import partial
from typing import Any, Callable

import numpy as np

from ..data.iodata import IOData, longest_segment
from ..data.quality import screen
from ..errors import ClosedLoopWarning, DataError, OptionError
from ..models.statespace import StateSpaceModel
from ..validation.comparison import compare, same_period
from ..validation.feedback import feedback_check, usable_lags
from .least_squares.estimation import check_sample_count
from .pipeline.interruption import post_path_phases
from .search.long_records import reestimate, search_window
from .pipeline.records import check_reach, check_scales, input_delays, long_segments, shifted_inputs, short_segments
from .uncertainty.noise_model import estimate_noise_model
from .options.identify_options import IdentifyOptions
from .closed_loop.reference_projection import ReferenceProjection, two_stage_records, without_reference
from .refinement.prediction_error import prediction_error_refine
from .refinement.levenberg_marquardt import MAX_RADIUS, refine_each
from .uncertainty.refined_covariance import is_refined
from .result import IdentificationResult
from .selection.order_rules import (clearly_better, generic_candidate, generic_orders_below, polished_if_clearly_better, select_order,
                          select_order_paired, select_order_refined, siblings)
from .search.greedy_path import PathStep, StructureSearch, greedy_path
from .selection.checks import warn_if_at_bound, warn_if_short_selection
from .tuning.barycenter import default_omega
from .uncertainty.matrix_covariance import estimate_covariance
from .continuous.identification import ContinuousResult, identify_continuous

__all__ = ["IdentificationResult", "identify"]

# Share of the record held out for the order rule when no validation data are given.
HOLDOUT_FRACTION = 0.3
# "auto" stability bound: a mode whose time constant exceeds a tenth of the estimation
# record (radius exp(-10/N)) cannot be told from drift in that record.
AUTO_RADIUS_SPAN = 10.0
# Samples of the estimation record the feedback check looks at.
FEEDBACK_SAMPLES = 3000


def identify(
    data: IOData,
    validation: IOData | None = None,
    options: IdentifyOptions | None = None,
    *,
    progress: Callable[[PathStep], None] | None = None,
    phase: Callable[[str], None] | None = None,
    **overrides: Any,
) -> IdentificationResult | ContinuousResult:
    """Identify a multivariable state-space model with MOLI-ZOFT.

    Parameters
    ----------
    data : IOData
        Estimation record.
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
        of the default; it cannot be combined with ``options``.

    Returns
    -------
    IdentificationResult
        Or, with ``time="continuous"``, a :class:`ContinuousResult` whose model is a
        :class:`ContinuousModel` (docs/continuous.md).

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
    opts = _options(options, overrides)
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    for name, hook, argument in (("progress", progress, "a PathStep"), ("phase", phase, "a phase's name")):
        if hook is not None and not callable(hook):
            raise OptionError(f"{name} must be a callable taking {argument}, got {type(hook).__name__}")
    check_scales(data, validation)
    if validation is None:
        if data.N * HOLDOUT_FRACTION < 1:
            raise DataError(f"data hold {data.N} sample{'s' if data.N != 1 else ''}: too few to hold out "
                            f"the last {HOLDOUT_FRACTION:.0%} for validation; give a longer record")
        estimation, validation = data.split(1.0 - HOLDOUT_FRACTION)
        source = f"held out: last {HOLDOUT_FRACTION:.0%} of the record"
    else:
        if not isinstance(validation, IOData):
            raise DataError(f"validation must be an IOData, got {type(validation).__name__}")
        if (validation.p, validation.m) != (data.p, data.m):
            raise DataError(
                f"validation has {validation.p} outputs and {validation.m} inputs, "
                f"data have {data.p} and {data.m}"
            )
        if opts.time == "discrete" and not same_period(validation.Ts, data.Ts):
            raise DataError(f"validation is sampled every Ts = {validation.Ts:g}, data every "
                            f"Ts = {data.Ts:g}; both records must share the sampling period")
        estimation, source = data, "given"
    p = data.p
    if opts.order is not None and opts.order < p:
        raise OptionError(f"IdentifyOptions.order must be at least the number of outputs, {p} "
                          f"(the path starts at n = p); got {opts.order}")
    nmax = opts.path_end(p)
    if nmax < p:
        raise OptionError(f"IdentifyOptions.nmax must be at least the number of outputs, {p}; got {nmax}")
    if opts.time == "continuous":
        return identify_continuous(estimation, validation, source, opts, progress, phase)
    if opts.input_hold != "zoh":
        raise OptionError(f"IdentifyOptions.input_hold={opts.input_hold!r} applies in continuous time only "
                          "(time='continuous'): a sampled model takes each input as it is sampled")
    loop = opts.closed_loop or ("two-stage" if opts.reference else "open")
    if loop == "two-stage" and opts.order_rule is None:
        # the two-stage method's order: the paired rule (docs/closed_loop.md §4); the direct
        # method keeps the best order, whose extra states its noise model may need
        opts = opts.replace(order_rule="paired")
    if loop == "direct":
        # a controller that reads y[k] to make u[k] would let a feedthrough carry y[k] into
        # its own prediction: the direct method needs a delay in the loop, the plant's
        if opts.feedthrough is True:
            raise OptionError("closed_loop='direct' needs a delay in the loop: a model with feedthrough=True "
                              "would predict each output from the input its controller made of it; use the "
                              "two-stage method (reference=[...]) for a plant with direct feedthrough")
        opts = opts.replace(feedthrough=False)
    projection = first = None
    if loop == "two-stage":
        if opts.delays != 0:
            raise OptionError("the two-stage method (reference=...) takes no input delays yet: leave delays at 0 "
                              "or use closed_loop='direct'")
        estimation, validation, projection, first = two_stage_records(estimation, validation, opts.reference)
        # the first stage on the samples the search and the refinement keep, for the covariance
        first = first.rows(estimation.bounds, short_segments(estimation, opts.path_end(p), opts.feedthrough
                                                             is not False), opts.search_samples)
    elif opts.reference:        # a method that does not use the references: the plant inputs alone
        estimation, validation = (without_reference(record, opts.reference) for record in (estimation, validation))
    estimation = long_segments(estimation, opts.path_end(data.p), opts.feedthrough is not False)
    if opts.center:
        estimation = estimation.remove_means()
        validation = validation.remove_means(estimation.y_offset, estimation.u_offset)
    grid = default_omega(estimation.Ts, opts.filter_grid) if opts.omega is None else np.array(opts.omega)
    radius = opts.max_radius
    if radius == "auto":
        radius = float(np.exp(-AUTO_RADIUS_SPAN / longest_segment(search_window(estimation, opts.search_samples)).N))
    # "auto" delays come from the search window of a long record (docs/method.md §15)
    delays = input_delays(opts.delays, search_window(estimation, opts.search_samples)
                           if opts.delays == "auto" else estimation)
    check_sample_count(estimation.N - max(delays), (1,) * p, estimation.m, opts.feedthrough is not False)
    check_reach(opts.nmax, opts.order, estimation.N - max(delays), p, estimation.m, opts.feedthrough is not False)
    screen(estimation, nmax, stacklevel=2)
    start = time.perf_counter()
    # a plant told to have feedthrough shows it at lag 0 like feedback: test later lags only
    # (the two-stage method's inputs are projections on the references: nothing to check)
    feedback = None if loop == "two-stage" else _feedback(estimation, lag_zero=opts.feedthrough is not True,
                                                           warn=loop == "open")
    # the path's models are fitted and scored on the shifted inputs, delay-free; the
    # delays are attached once the path is done (the results are the same either way)
    fitted, scored = shifted_inputs(estimation, delays), shifted_inputs(validation, delays)
    searched = search_window(fitted, opts.search_samples)   # fitted itself unless the record is long
    search = StructureSearch(
        searched, scored, grid, opts.tuning, opts.iterations, opts.s, opts.seed, opts.x0,
        opts.criterion_x0, opts.feedthrough, radius, opts.trend_degree, opts.output_filters,
        opts.regularization,
    )
    path: list[PathStep] = []
    interrupted = False

    def record(step: PathStep) -> None:
        path.append(step)
        if progress:
            progress(step)

    with warnings.catch_warnings():
        # unstable candidates are expected while searching; the selected model is checked below
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            greedy_path(search, nmax, record)
        except KeyboardInterrupt:
            if not path:
                raise
            interrupted = True
    bound = MAX_RADIUS if radius is None else min(radius, MAX_RADIUS)

    ridges = opts.refine_ridge if isinstance(opts.refine_ridge, tuple) else (opts.refine_ridge,)

    done: dict[tuple[int, float], tuple[StateSpaceModel, PathStep]] = {}

    def refined(step: PathStep, chosen: tuple[float, ...] = ridges[:1]) -> list[PathStep]:
        """The step refined with each ridge, from its model; each counts the time of all.
        A model refined with a ridge before (the order rule's walk) is not refined again: ``done``
        holds each model beside its id, which is unique only while the model lives."""
        todo = tuple(r for r in chosen if done.get((id(step.model), r), (None,))[0] is not step.model)
        if todo:
            started = time.perf_counter()
            models = [result.model for result in refine_each(step.model, searched, todo, max_radius=bound,
                                                             iterations=opts.refine_iterations)]
            vafs = [compare(model, scored, opts.x0).vaf for model in models]
            seconds = step.seconds + time.perf_counter() - started
            for ridge, model, vaf in zip(todo, models, vafs):
                done[id(step.model), ridge] = step.model, replace(step, model=model, vaf=vaf, seconds=seconds)
        return [done[id(step.model), r][1] for r in chosen]

    def free(step: PathStep) -> PathStep:
        return refined(step, (0.0,))[0]

    def begin(name: str) -> str:
        if phase:
            phase(name)
        return name

    unrefined, at_bound = list(path), replace(path[-1])    # at_bound: the path's own last least squares
    # Ctrl-C after the path keeps the best complete model so far (moli.method.pipeline.interruption)
    phases = post_path_phases(opts, long_record=searched is not fitted, direct=loop == "direct")
    stage, skipped = phases[0], ()
    try:
        if opts.refine == "path" and not interrupted:
            stage = begin("refinement of the path")
            path[:] = [refined(st)[0] for st in path]
        selected = _fixed_order(path, opts.order, interrupted)
        if selected is None and opts.order_rule == "refined" and not interrupted:
            stage = begin("order rule's refinements")
            selected, chosen = select_order_refined(path, lambda i: [path[i], *siblings(search, path, i)],
                                                    refined, scored, opts.x0, opts.order_errors)
            path[selected] = unrefined[selected] = chosen
    except KeyboardInterrupt:   # the path as it was, and the order rule of an interrupted search
        skipped, selected = tuple(phases[phases.index(stage):]), _fixed_order(path, opts.order, True)
    if selected is None and opts.order_rule in ("paired", "refined"):
        selected = select_order_paired(path, scored, opts.x0, opts.order_errors)
    elif selected is None:
        selected = select_order(path, opts.order_tolerance)
    if not skipped:
        try:
            if searched is not fitted:      # docs/method.md §15: the selected list on the whole record
                stage = begin("re-estimation on the whole record")
                path[selected] = reestimate(unrefined[selected], fitted, scored, opts.s, opts.feedthrough, opts.x0,
                                            opts.regularization)
                path[selected].model.info["search_samples"] = searched.N
                if opts.refine == "path":
                    stage = begin("refinement")
                    path[selected] = refined(path[selected])[0]
            if opts.refine == "selected":
                stage = begin("refinement")
                path[selected] = refined(path[selected])[0]
            elif opts.refine == "guarded":
                stage = begin("refinement")
                # each ridge from the unrefined model: the best on validation stays; then the free
                # refinement of each other list the greedy step compared at this order, where it
                # is better by more than a paired standard error (docs/method.md §12)
                # two-stage: the free output-error estimate is the consistent one (the error
                # G (u - u_hat) + v is coloured, which biases the least squares): kept
                for candidate in refined(path[selected], ridges if first is None else (0.0,)):
                    if first is not None or candidate.mean_vaf > path[selected].mean_vaf:
                        path[selected] = candidate
                for sibling in [] if interrupted else siblings(search, path, selected):
                    for candidate in refined(sibling, ridges[:1]):
                        if clearly_better(candidate, path[selected], scored, opts.x0):
                            path[selected] = candidate
                # the generic list spans almost every system of the order: kept where it fits
                # validation within the order tolerance, then those of the orders below while
                # they fit as well (docs/method.md §12)
                candidate = None if interrupted else generic_candidate(search, path[selected], free, searched,
                                                                       scored, opts.x0, bound)
                if candidate is not None and candidate.mean_vaf >= path[selected].mean_vaf - opts.order_tolerance:
                    path[selected] = candidate
                if not interrupted and opts.order is None and opts.lower_orders:
                    selected = generic_orders_below(search, path, selected, free, searched, scored, opts.x0, bound,
                                                    opts.order_tolerance)
                if not interrupted and opts.polish_selected:
                    path[selected] = polished_if_clearly_better(path[selected], searched, scored, opts.x0, bound)
            if loop == "direct":
                # the noise model of the model so far starts the joint prediction-error estimate
                stage = begin("noise model")
                start_model = _attached(estimate_noise_model, "noise_model", path[selected].model, searched)
                stage = begin("prediction error")
                direct = prediction_error_refine(start_model, searched, max_radius=bound).model
                path[selected] = replace(path[selected], model=direct, vaf=compare(direct, scored, opts.x0).vaf)
            # covariance (of the problem that gave the model: a refined one's on the search window, the
            # least squares' on the whole record) and noise model (search window) of the delay-free
            # model, on the shifted record
            stage = begin("covariance")
            kept = path[selected].model
            path[selected] = replace(path[selected], model=_attached(
                estimate_covariance if first is None else partial(estimate_covariance, first_stage=first),
                "covariance", kept,
                searched if is_refined(kept) or first is not None else fitted))
            if opts.noise_model and loop != "direct":
                stage = begin("noise model")
                path[selected] = replace(path[selected], model=_attached(estimate_noise_model, "noise_model",
                                                                         path[selected].model, searched))
        except KeyboardInterrupt:
            skipped = tuple(phases[phases.index(stage):])
    if skipped:
        path[selected].model.info["interrupted"] = {"skipped": list(skipped)}
    returned = path[selected]               # delay-free, as the search scores it: for the bound warning
    if any(delays):                         # new steps: the search's own (returned, at_bound) stay as they were
        path[:] = [replace(step, model=step.model.with_input_delays(delays)) for step in path]
    model = path[selected].model
    model.info["options"] = opts.to_dict()
    model.info["closed_loop"] = _loop_record(loop, projection, feedback)
    model.warn_if_unstable(stacklevel=2)
    # a fixed order is the caller's choice, not the search running into its bound
    if not interrupted and path[selected].order != opts.order:
        warn_if_at_bound(path, selected, nmax, validation, opts.x0, beyond=None if skipped else (
            search, at_bound, returned, None if opts.refine == "none" else refined, bound))
    warn_if_short_selection(path, scored.N, scored.m, stacklevel=2)
    return IdentificationResult(
        model=model, path=path, selected_index=selected, estimation=estimation,
        validation=validation, validation_source=source, options=opts, nmax=nmax, omega=grid,
        max_radius=radius, seconds=time.perf_counter() - start, interrupted=interrupted or bool(skipped),
        skipped=skipped,
    )


def _attached(estimator: Callable[[StateSpaceModel, IOData], StateSpaceModel], key: str,
              model: StateSpaceModel, record: IOData) -> StateSpaceModel:
    """``estimator(model, record)`` (the covariance or the noise model), or ``model`` with
    the reason in ``info[key]`` when the estimator refuses it (an unstable model, a
    record too short for its least squares)."""
    try:
        return estimator(model, record)
    except DataError as exc:
        model.info[key] = {"method": "none", "reason": str(exc)}
        return model


def _fixed_order(path: list[PathStep], order: int | None, interrupted: bool) -> int | None:
    """Position of the path step of the fixed ``order``; None to apply the order rule.

    An interrupted search keeps the best model of the orders done, like one without a
    fixed order; a complete path that stops short of ``order`` is an error.
    """
    if order is None:
        return None
    found = [i for i, step in enumerate(path) if step.order == order]
    if found:
        return found[0]
    if interrupted:
        return None
    raise DataError(f"IdentifyOptions.order = {order} is not on the greedy path: the record has "
                    f"too few samples for lists beyond n = {path[-1].order}")


def _options(options: IdentifyOptions | None, overrides: dict[str, Any]) -> IdentifyOptions:
    """The options of one call: ``options`` (or a named preset) with ``overrides`` applied."""
    preset = overrides.pop("preset", None)
    if options is not None and not isinstance(options, IdentifyOptions):
        raise OptionError(f"options must be an IdentifyOptions, got {type(options).__name__}")
    if preset is not None:
        if options is not None:
            raise OptionError("give either options or preset, not both")
        return IdentifyOptions.preset(preset, **overrides)
    return (options or IdentifyOptions()).replace(**overrides)


def _feedback(estimation: IOData, lag_zero: bool, warn: bool) -> str | None:
    """:func:`feedback_check`'s summary where it flags the record (None where it does not, or
    the record is too short to tell); a :class:`ClosedLoopWarning` too when ``warn``."""
    # the first FEEDBACK_SAMPLES samples: a loop that shows in no fewer is too weak to
    # matter, and the check's cost stays bounded while the search's grows with N
    # lagged regressions run through time: of a record with gaps, the longest stretch
    record = longest_segment(estimation)[:FEEDBACK_SAMPLES]
    lags = usable_lags(record.N, record.p, record.m)
    if lags == 0:  # too short to tell
        return None
    check = feedback_check(record, lags, lag_zero=lag_zero)
    if check.detected and warn:
        warnings.warn(
            f"the estimation data look closed-loop: {check.summary()}. An output-error model "
            "fitted to closed-loop data is biased unless the output noise is white. Name the logged "
            "set-points with reference=[...] (the two-stage method), identify with closed_loop='direct' "
            "(the noise modelled jointly), or excite the loop from outside. A plant with direct "
            "feedthrough looks the same at lag 0: pass feedthrough=True if yours has one",
            ClosedLoopWarning,
            stacklevel=3,
        )
    return check.summary() if check.detected else None


def _loop_record(loop: str, projection: ReferenceProjection | None, feedback: str | None) -> dict[str, object]:
    """``info["closed_loop"]``: the method and why it was used."""
    if loop == "two-stage":
        why = "references named: each input replaced by the part of it they explain (docs/closed_loop.md)"
    elif loop == "direct":
        why = "asked for: the model and its noise model estimated jointly by prediction error"
    else:
        why = ("identified as if open-loop, though " + feedback) if feedback else "no feedback detected"
    return {"method": loop, "why": why, "feedback": feedback} | (projection.to_dict() if projection is not None else {})
