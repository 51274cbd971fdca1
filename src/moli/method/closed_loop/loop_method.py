"""Which method a record's loop calls for, what the feedback check found, and the record of both.

Open-loop output error unless told otherwise: the two-stage method where references are
named, the direct method where ``closed_loop="direct"`` (docs/closed_loop.md). The
feedback check runs on the estimation record and warns (``ClosedLoopWarning``) where an
open-loop model is about to be fitted to a record that looks closed-loop.
"""

from __future__ import annotations

import warnings

from ...data.iodata import IOData, longest_segment
from ...errors import ClosedLoopWarning, OptionError
from ...validation.feedback import feedback_check, usable_lags
from ..options.identify_options import IdentifyOptions
from .reference_projection import ReferenceProjection

__all__ = ["loop_method", "feedback_found", "loop_record", "FEEDBACK_SAMPLES"]

# Samples of the estimation record the feedback check looks at.
FEEDBACK_SAMPLES = 3000


def loop_method(options: IdentifyOptions) -> tuple[str, IdentifyOptions]:
    """The loop method ("open", "two-stage" or "direct") and the options it runs with.

    The two-stage method selects its order by the paired rule unless told otherwise
    (docs/closed_loop.md §4); the direct method estimates no feedthrough, since a
    controller that reads ``y[k]`` to make ``u[k]`` would let a feedthrough carry ``y[k]``
    into its own prediction.

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
    loop = options.closed_loop or ("two-stage" if options.reference else "open")
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


def feedback_found(estimation: IOData, lag_zero: bool, warn: bool, stacklevel: int = 2) -> str | None:
    """:func:`moli.feedback_check`'s summary where it flags the record (None where it does not,
    or the record is too short to tell); a :class:`ClosedLoopWarning` too when ``warn``
    (``stacklevel`` counted from the caller, as for :func:`warnings.warn`)."""
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
            stacklevel=stacklevel + 1,
        )
    return check.summary() if check.detected else None


def loop_record(loop: str, projection: ReferenceProjection | None, feedback: str | None) -> dict[str, object]:
    """``info["closed_loop"]``: the method and why it was used."""
    if loop == "two-stage":
        why = "references named: each input replaced by the part of it they explain (docs/closed_loop.md)"
    elif loop == "direct":
        why = "asked for: the model and its noise model estimated jointly by prediction error"
    else:
        why = ("identified as if open-loop, though " + feedback) if feedback else "no feedback detected"
    return {"method": loop, "why": why, "feedback": feedback} | (projection.to_dict() if projection is not None else {})
