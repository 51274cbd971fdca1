"""The first step of :func:`moli.identify`: the call's options, the hold-out, and the records the
search runs on (loop method, segments, operating point, filter grid, pole bound, input delays).

Every check of the call runs here, before any work: a record or option the search cannot
use is refused with the argument's name, never found out halfway through the path.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ...data.arguments import check_channel_order, check_validation_length
from ...data.iodata import IOData, longest_segment
from ...data.quality import screen
from ...data.stamps import warn_uneven
from ...errors import DataError, OptionError
from ...validation.comparison import same_period
from ...validation.feedback import FeedbackCheck
from ..closed_loop.loop_method import feedback_found, loop_method, warn_feedback
from ..closed_loop.reference_projection import FirstStage, ReferenceProjection, two_stage_records, without_reference
from ..least_squares.estimation import check_sample_count
from ..options.identify_options import IdentifyOptions
from ..refinement.levenberg_marquardt import MAX_RADIUS
from ..refinement.refined_steps import RefinedSteps
from ..search.long_records import search_window
from ..structure.filters import check_candidates
from ..tuning.barycenter import default_omega
from .records import check_reach, check_scales, input_delays, long_segments, shifted_inputs, short_segments

__all__ = ["Prepared", "call_options", "check_hooks", "split_records", "prepare", "HOLDOUT_FRACTION",
           "AUTO_RADIUS_SPAN"]

# Share of the record held out for the order rule when no validation data are given.
HOLDOUT_FRACTION = 0.3
# "auto" stability bound: a mode whose time constant exceeds a tenth of the estimation
# record (radius exp(-10/N)) cannot be told from drift in that record.
AUTO_RADIUS_SPAN = 10.0


@dataclass(frozen=True)
class Prepared:
    """The records and settings the search, the refinements and the covariance run on.

    ``estimation`` and ``validation`` are the records as the result reports them (centred,
    short segments out, inputs projected where the two-stage method runs); ``fitted`` and
    ``scored`` are the same with the inputs shifted by ``delays``, and ``searched`` is
    ``fitted`` or, for a long record, its search window (docs/method.md §15).
    """

    options: IdentifyOptions
    loop: str
    estimation: IOData
    validation: IOData
    fitted: IOData
    scored: IOData
    searched: IOData
    grid: np.ndarray
    radius: float | None
    delays: tuple[int, ...]
    projection: ReferenceProjection | None
    first_stage: FirstStage | None
    feedback: FeedbackCheck | None

    @property
    def bound(self) -> float:
        """The pole radius bound of every refinement step."""
        return MAX_RADIUS if self.radius is None else min(self.radius, MAX_RADIUS)

    def refinements(self) -> RefinedSteps:
        """The refinements every phase after the path shares: on the search's records, with the
        options' ridges, initial state and steps, within :attr:`bound`."""
        ridges = self.options.refine_ridge
        return RefinedSteps(self.searched, self.scored, ridges if isinstance(ridges, tuple) else (ridges,),
                            x0=self.options.x0, max_radius=self.bound, iterations=self.options.refine_iterations)

    @property
    def long_record(self) -> bool:
        """Whether the search ran on a window of the estimation record."""
        return self.searched is not self.fitted


def call_options(options: IdentifyOptions | None, overrides: dict[str, Any]) -> IdentifyOptions:
    """The options of one call: ``options`` (or a named preset) with ``overrides`` applied."""
    preset = overrides.pop("preset", None)
    if options is not None and not isinstance(options, IdentifyOptions):
        raise OptionError(f"options must be an IdentifyOptions, got {type(options).__name__}")
    if preset is not None:
        if options is not None:
            raise OptionError("give either options or preset, not both")
        return IdentifyOptions.preset(preset, **overrides)
    return (options or IdentifyOptions()).replace(**overrides)


def check_hooks(data: object, progress: Callable[..., None] | None, phase: Callable[[str], None] | None) -> None:
    """``data`` must be an :class:`IOData`, and each hook given a callable."""
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    for name, hook, argument in (("progress", progress, "a PathStep"), ("phase", phase, "a phase's name")):
        if hook is not None and not callable(hook):
            raise OptionError(f"{name} must be a callable taking {argument}, got {type(hook).__name__}")


def split_records(data: IOData, validation: IOData | None, options: IdentifyOptions) -> tuple[IOData, IOData, str]:
    """The estimation and validation records and where the validation came from (the last
    :data:`HOLDOUT_FRACTION` of ``data`` when none is given); the orders asked for checked
    against the number of outputs."""
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
        check_channel_order(data, validation, "data", "validation")
        check_validation_length(validation)
        if options.time == "discrete" and not same_period(validation.Ts, data.Ts):
            raise DataError(f"validation is sampled every Ts = {validation.Ts:g}, data every "
                            f"Ts = {data.Ts:g}; both records must share the sampling period")
        estimation, source = data, "given"
    p = data.p
    if options.order is not None and options.order < p:
        raise OptionError(f"IdentifyOptions.order must be at least the number of outputs, {p} "
                          f"(the path starts at n = p); got {options.order}")
    if options.path_end(p) < p:
        raise OptionError(f"IdentifyOptions.nmax must be at least the number of outputs, {p}; "
                          f"got {options.path_end(p)}")
    return estimation, validation, source


def prepare(estimation: IOData, validation: IOData, options: IdentifyOptions) -> Prepared:
    """The records of a sampled-time identification as the search and what follows it use them.

    Warnings (data quality, closed loop) point at the caller of :func:`moli.identify`.
    """
    if options.input_hold != "zoh":
        raise OptionError(f"IdentifyOptions.input_hold={options.input_hold!r} applies in continuous time only "
                          "(time='continuous'): a sampled model takes each input as it is sampled")
    loop, options = loop_method(options)
    p, nmax = estimation.p, options.path_end(estimation.p)
    grid = default_omega(estimation.Ts, options.filter_grid) if options.omega is None else np.array(options.omega)
    check_candidates(grid, estimation.Ts)
    projection = first = feedback = None
    if loop == "two-stage":
        if options.delays != 0:
            raise OptionError("the two-stage method (reference=...) takes no input delays yet: leave delays at 0 "
                              "or use closed_loop='direct'")
        estimation, validation, projection, first = two_stage_records(estimation, validation, options.reference)
        # the first stage on the samples the search and the refinement keep, for the covariance
        first = first.rows(estimation.bounds, short_segments(estimation, nmax, options.feedthrough is not False),
                           options.search_samples)
    else:
        if options.reference:      # a method that does not use the references: the plant inputs alone
            estimation, validation = (without_reference(record, options.reference)
                                      for record in (estimation, validation))
        # a plant told to have feedthrough shows it at lag 0 like feedback: test later lags only
        # (the two-stage method's inputs are projections on the references: nothing to check).
        # Checked before the segments and the centring (the check's intercept and its longest
        # stretch make them no difference): a controller found turns the default to the
        # direct method, whose options (no feedthrough) the segments depend on
        feedback = feedback_found(estimation, lag_zero=options.feedthrough is not True)
        loop, options = loop_method(options, feedback)
    feedthrough = options.feedthrough is not False
    estimation = long_segments(estimation, nmax, feedthrough)
    if options.center:
        estimation = estimation.remove_means()
        validation = validation.remove_means(estimation.y_offset, estimation.u_offset)
    radius = options.max_radius
    if radius == "auto":
        radius = float(np.exp(-AUTO_RADIUS_SPAN / longest_segment(search_window(estimation, options.search_samples)).N))
    # "auto" delays come from the search window of a long record (docs/method.md §15)
    delays = input_delays(options.delays, search_window(estimation, options.search_samples)
                          if options.delays == "auto" else estimation)
    check_sample_count(estimation.N - max(delays), (1,) * p, estimation.m, feedthrough)
    check_reach(options.nmax, options.order, estimation.N - max(delays), p, estimation.m, feedthrough)
    screen(estimation, nmax, stacklevel=3)
    for record in (estimation, validation):
        warn_uneven(record.times, record.segment_starts, record.Ts, stacklevel=3)
    warn_feedback(loop, feedback, options.closed_loop, stacklevel=3)
    # the path's models are fitted and scored on the shifted inputs, delay-free; the
    # delays are attached once the path is done (the results are the same either way)
    fitted, scored = shifted_inputs(estimation, delays), shifted_inputs(validation, delays)
    return Prepared(options=options, loop=loop, estimation=estimation, validation=validation, fitted=fitted,
                    scored=scored, searched=search_window(fitted, options.search_samples), grid=grid, radius=radius,
                    delays=delays, projection=projection, first_stage=first, feedback=feedback)
