"""Time stamps a record carries as given: checked once, then kept through every operation.

A record may hold the time of each sample (jitter and gaps included) beside its
nominal period ``Ts``. Segments are separate experiments, so the stamps need only
increase within each segment and may restart at a segment's first sample. These
helpers work on plain arrays and start tuples, so :class:`moli.data.IOData` can use
them without importing anything back.
"""

from __future__ import annotations

import warnings
from typing import Sequence

import numpy as np

from ..errors import DataError, IrregularSamplingWarning
from .arguments import real_array
from .timing import TIME_TOLERANCE

__all__ = ["UNSTATED_PERIOD", "check_times", "median_step", "irregular_steps", "warn_uneven", "joined_times"]


class _UnstatedPeriod(float):
    """The default ``Ts`` of a record, 1.0, told apart from a 1.0 the caller gave: with time
    stamps and no stated period, the period comes from the stamps."""

    def __repr__(self) -> str:
        return "1.0"


UNSTATED_PERIOD = _UnstatedPeriod(1.0)


def _kind(values: object) -> str:
    try:
        return np.asarray(values).dtype.kind
    except ValueError:  # ragged nested lists: real_array says so
        return ""


def _inside(N: int, starts: tuple[int, ...]) -> np.ndarray:
    """Which of the N - 1 steps between samples lie inside a segment (a segment's stamps may
    restart at its first sample)."""
    inside = np.ones(max(N - 1, 0), bool)
    inside[[s - 1 for s in starts if s > 0]] = False
    return inside


def check_times(times: object, N: int, starts: tuple[int, ...]) -> np.ndarray:
    """``times`` as a read-only float copy of shape (N,), strictly increasing in each segment.

    ``starts`` are the first samples of the segments. Raises :class:`DataError` naming
    the first sample that is not finite or does not follow its predecessor.
    """
    if _kind(times) in ("m", "M"):   # numpy would turn them into nanoseconds silently
        raise DataError("times must be numbers (e.g. seconds since the first sample), got "
                        f"{np.asarray(times).dtype} values; convert them first, e.g. (t - t[0]) / np.timedelta64(1, 's')")
    stamps = real_array("times", times, finite=False)
    if stamps.shape != (N,):
        raise DataError(f"times must have shape ({N},), one stamp per sample of y and u, "
                        f"got shape {stamps.shape}")
    bad = np.flatnonzero(~np.isfinite(stamps))
    if bad.size:
        k = int(bad[0])
        raise DataError(f"times must be finite: sample {k} has time {stamps[k]:g}")
    backwards = np.flatnonzero(_inside(N, starts) & ~(np.diff(stamps) > 0))
    if backwards.size:
        k = int(backwards[0]) + 1
        raise DataError(
            f"times must increase strictly within each segment: sample {k} has time {stamps[k]:g} "
            f"after {stamps[k - 1]:g} at sample {k - 1}; sort the samples by time, remove "
            "repeated ones, or start a new segment there (segment_starts)"
        )
    stamps.flags.writeable = False
    return stamps


def _steps_inside(times: np.ndarray, starts: tuple[int, ...]) -> np.ndarray:
    """The steps between consecutive stamps of the same segment."""
    return np.diff(times)[_inside(times.size, starts)]


def median_step(times: np.ndarray, starts: tuple[int, ...]) -> float:
    """The median step between consecutive stamps of the same segment: the nominal period."""
    steps = _steps_inside(times, starts)
    if not steps.size:
        raise DataError("times give no step within a segment (every segment has one sample); "
                        "state the sampling period with Ts=")
    return float(np.median(steps))


def irregular_steps(times: np.ndarray, starts: tuple[int, ...], Ts: float) -> int:
    """How many steps within segments differ from ``Ts`` by more than the readers' tolerance."""
    return int(np.count_nonzero(np.abs(_steps_inside(times, starts) - Ts) > TIME_TOLERANCE * Ts))


def warn_uneven(times: np.ndarray | None, starts: tuple[int, ...], Ts: float, stacklevel: int) -> None:
    """Warn where a sampled-time model is to take stamps that step unevenly as evenly spaced."""
    count = 0 if times is None else irregular_steps(times, starts, Ts)
    if count:
        warnings.warn(IrregularSamplingWarning(
            f"{count} step{'s' * (count > 1)} of the record's time stamps differ from Ts = {Ts:g}, and a "
            "sampled-time model takes its samples as evenly spaced; for a record sampled unevenly identify "
            "in continuous time (time='continuous', moli fit --continuous)"), stacklevel=stacklevel + 1)


def joined_times(stamps: Sequence[np.ndarray | None]) -> np.ndarray | None:
    """The stamps of records joined end to end: all of them, or None when none has any.

    Raises :class:`DataError` naming the first record that differs from record 0 when
    only some have stamps.
    """
    given = [s is not None for s in stamps]
    if all(given):
        return np.concatenate(stamps)  # type: ignore[arg-type]
    if any(given):
        odd = given.index(not given[0])
        has = "has" if given[odd] else "has no"
        other = "has" if given[0] else "has no"
        raise DataError(f"merge: record {odd} {has} time stamps and record 0 {other}; give every "
                        "record its stamps (times=) or none")
    return None
