"""What :func:`moli.identify` does to its records before the search: short segments out, inputs delayed."""

from __future__ import annotations

import warnings

import numpy as np

from ...data.iodata import IOData, longest_segment, merge
from ...data.quality import check_scale
from ...errors import DataError, DataQualityWarning, OptionError
from ...models.delays import shift_inputs
from ...validation.delays import first_response_lags
from ..least_squares.estimation import check_sample_count
from ..structure.rows import largest_order
from ..structure.indices import Indices

__all__ = ["long_segments", "shifted_inputs", "input_delays", "check_scales", "check_reach"]


def check_scales(*records: IOData | None) -> None:
    """Each record's channels must lie within what double precision identifies from
    (:func:`moli.data.quality.check_scale`); None and other types are checked elsewhere."""
    for record in records:
        if isinstance(record, IOData):
            check_scale(record)


def check_reach(nmax: int | None, order: int | None, N: int, p: int, m: int, feedthrough: bool) -> None:
    """An nmax or order asked for must be within what N samples can estimate (before the search)."""
    reach = largest_order(N, p, m, feedthrough)
    for name, value in (("nmax", nmax), ("order", order)):
        if value is not None and value > reach:
            raise DataError(
                f"IdentifyOptions.{name} = {value} (moli fit --{name}) is beyond what {N} samples of "
                f"{p} outputs and {m} inputs can estimate: the largest order is {reach}; lower it "
                "or give a longer record")


def long_segments(data: IOData, nmax: int, feedthrough: bool) -> IOData:
    """``data`` without the segments too short for the search's largest list, which warn.

    A record of one segment is returned as it is (the search skips the lists it is too
    short for). Of several, a segment that cannot hold every list up to ``nmax`` on its
    own is dropped with a :class:`DataQualityWarning`; none left is a :class:`DataError`.
    """
    short = short_segments(data, nmax, feedthrough)
    if not short:
        return data
    largest = _largest_list(data.p, nmax)
    kept = [segment for i, segment in enumerate(data.segments) if i not in short]
    lengths = ", ".join(f"{i} ({data.bounds[i][1] - data.bounds[i][0]} samples)" for i in short)
    if not kept:
        raise DataError(f"every segment of the estimation record is too short for the list "
                        f"{list(largest)} (order {sum(largest)}): segments {lengths}")
    warnings.warn(f"estimation segments {lengths} are too short for the list {list(largest)} "
                  f"(order {sum(largest)}) and were left out", DataQualityWarning, stacklevel=3)
    return merge(kept)


def _largest_list(p: int, nmax: int) -> Indices:
    """The list of degree nmax needing most samples: its whole excess on the last output."""
    return (1,) * (p - 1) + (max(nmax, p) - p + 1,)


def short_segments(data: IOData, nmax: int, feedthrough: bool) -> list[int]:
    """Positions of the segments :func:`long_segments` leaves out (none of a one-segment record)."""
    if data.n_segments == 1:
        return []
    largest = _largest_list(data.p, nmax)
    short = []
    for i, (start, stop) in enumerate(data.bounds):
        try:
            check_sample_count(stop - start, largest, data.m, feedthrough)
        except DataError:
            short.append(i)
    return short


def shifted_inputs(data: IOData, delays: tuple[int, ...]) -> IOData:
    """``data`` with input ``j`` delayed by ``delays[j]`` samples (zero, i.e. the operating
    point, before the record), as the model's simulation shifts it."""
    if not any(delays):
        return data
    u = np.concatenate([shift_inputs(data.u[a:b], delays) for a, b in data.bounds])  # zero at each segment's start
    shifted = IOData(data.y, u, data.Ts, data.output_names, data.input_names, segment_starts=data.segment_starts)
    shifted.y_offset, shifted.u_offset = data.y_offset.copy(), data.u_offset.copy()
    return shifted


def input_delays(delays: int | tuple[int, ...] | str, estimation: IOData) -> tuple[int, ...]:
    """``IdentifyOptions.delays`` for this record: one int per input, checked or estimated."""
    m = estimation.m
    if delays == "auto":
        # lagged regressions run through time: on the longest continuous stretch
        first, _ = first_response_lags(longest_segment(estimation))
        # per input, the earliest response over the outputs; an input that no output
        # answers within the lags looked at gets no delay (nothing supports one)
        return tuple(
            max(int(np.min(col[col >= 0])) - 1, 0) if np.any(col >= 0) else 0 for col in first.T
        )
    values = (delays,) * m if isinstance(delays, int) else tuple(delays)
    if len(values) != m:
        raise OptionError(f"IdentifyOptions.delays has {len(values)} entries for {m} inputs")
    if max(values) >= estimation.N:
        raise OptionError(
            f"IdentifyOptions.delays must be shorter than the estimation record ({estimation.N} "
            f"samples), got {list(values)}"
        )
    return values
