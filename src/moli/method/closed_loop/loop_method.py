"""Which method a record's loop calls for, what the feedback check found, and the record of both.

The two-stage method where references are named, the direct method where
``closed_loop="direct"``, or where no reference is named and the feedback check finds an
input that the outputs reproduce exactly (a controller's output: feedback beyond doubt);
open-loop output error otherwise (docs/closed_loop.md). The feedback check runs on the
estimation record and warns (``ClosedLoopWarning``) where an open-loop model is about to
be fitted to a record that looks closed-loop, where the default turned to the direct
method, and where it cannot tell.
"""

from __future__ import annotations

import warnings

from ...data.iodata import IOData, longest_segment
from ...errors import ClosedLoopWarning, OptionError
from ...validation.feedback import FeedbackCheck, checked_feedback, usable_lags
from ..options.identify_options import IdentifyOptions
from .reference_projection import ReferenceProjection

__all__ = ["loop_method", "feedback_found", "warn_feedback", "loop_record", "FEEDBACK_SAMPLES", "FEEDBACK_LEVEL"]

# Samples of the estimation record the feedback check looks at.
FEEDBACK_SAMPLES = 3000
# The check's false-alarm level (moli.feedback_check's default).
FEEDBACK_LEVEL = 0.01


def loop_method(options: IdentifyOptions, feedback: FeedbackCheck | None = None) -> tuple[str, IdentifyOptions]:
    """The loop method ("open", "two-stage" or "direct") and the options it runs with.

    With no method asked for and no reference named, the direct method where ``feedback``
    found a controller's output (:attr:`FeedbackCheck.exact`) and no feedthrough is asked
    for, else the open-loop one. The two-stage method selects its order by the paired
    rule unless told otherwise (docs/closed_loop.md §4); the direct method estimates no
    feedthrough, since a controller that reads ``y[k]`` to make ``u[k]`` would let a
    feedthrough carry ``y[k]`` into its own prediction.

    Raises
    ------
    OptionError
        ``closed_loop="direct"`` with ``feedthrough=True``.

    Examples
    --------
    >>> loop_method(IdentifyOptions(reference=("r1",)))[0]
    'two-stage'
    >>> loop_method(IdentifyOptions(closed_loop="direct"))[1].feedthrough
    False
    """
    found = feedback is not None and bool(feedback.exact) and options.feedthrough is not True
    loop = options.closed_loop or ("two-stage" if options.reference else "direct" if found else "open")
    if loop == "two-stage" and options.order_rule is None:
        # the two-stage method's order: the paired rule (docs/closed_loop.md §4); the direct
        # method keeps the best order, whose extra states its noise model may need
        options = options.replace(order_rule="paired")
    if loop == "direct":
        if options.feedthrough is True:
            raise OptionError("closed_loop='direct' needs a delay in the loop: a model with feedthrough=True "
                              "would predict each output from the input its controller made of it; use the "
                              "two-stage method (reference=[...]) for a plant with direct feedthrough")
        options = options.replace(feedthrough=False)
    return loop, options


def feedback_found(estimation: IOData, lag_zero: bool) -> FeedbackCheck | None:
    """:func:`moli.feedback_check` of the estimation record, without its warning (None where
    the record is too short to tell)."""
    # the first FEEDBACK_SAMPLES samples: a loop that shows in no fewer is too weak to
    # matter, and the check's cost stays bounded while the search's grows with N
    # lagged regressions run through time: of a record with gaps, the longest stretch
    record = longest_segment(estimation)[:FEEDBACK_SAMPLES]
    lags = usable_lags(record.N, record.p, record.m)
    if lags == 0:  # too short to tell
        return None
    return checked_feedback(record, lags, FEEDBACK_LEVEL, lag_zero)


def warn_feedback(loop: str, feedback: FeedbackCheck | None, asked: str | None, stacklevel: int = 2) -> None:
    """A :class:`ClosedLoopWarning` where the record looks closed-loop and is identified as if
    open, where the default turned to the direct method, or where the check cannot tell
    (``asked``: the method the options ask for; ``stacklevel`` counted from the caller)."""
    if feedback is None or loop == "two-stage":
        return
    if loop == "direct" and asked is None:
        message = (f"the estimation data are closed-loop: {feedback.summary()}. Identified by the direct method "
                   "(the model and its noise model jointly, docs/closed_loop.md), since an output-error model "
                   "fitted to closed-loop data is biased. Name the logged set-points with reference=[...] for the "
                   "two-stage method, or pass closed_loop='open' to fit it as if open-loop")
    elif loop == "open" and feedback.detected:
        message = (f"the estimation data look closed-loop: {feedback.summary()}. An output-error model "
                   "fitted to closed-loop data is biased unless the output noise is white. Name the logged "
                   "set-points with reference=[...] (the two-stage method), identify with closed_loop='direct' "
                   "(the noise modelled jointly), or excite the loop from outside. A plant with direct "
                   "feedthrough looks the same at lag 0: pass feedthrough=True if yours has one")
    elif loop == "open" and (why := feedback.cannot_tell()) is not None:
        message = why
    else:
        return
    warnings.warn(message, ClosedLoopWarning, stacklevel=stacklevel + 1)


def loop_record(loop: str, projection: ReferenceProjection | None, feedback: FeedbackCheck | None,
                asked: str | None = None) -> dict[str, object]:
    """``info["closed_loop"]``: the method, why it was used, and the feedback check's verdict
    where it found feedback or could not tell (``asked``: the method the options ask for)."""
    said = None if feedback is None or not (feedback.detected or feedback.undecided) else feedback.summary()
    if loop == "two-stage":
        why = "references named: each input replaced by the part of it they explain (docs/closed_loop.md)"
    elif loop == "direct" and asked is None:
        why = (f"{said}, and no reference named: the model and its noise model estimated jointly by "
               "prediction error (closed_loop='open' fits it as if open-loop)")
    elif loop == "direct":
        why = "asked for: the model and its noise model estimated jointly by prediction error"
    else:
        why = ("identified as if open-loop, though " + said) if said else "no feedback detected"
    return {"method": loop, "why": why, "feedback": said, "chosen": "asked" if asked else "default"} | (
        projection.to_dict() if projection is not None else {})
