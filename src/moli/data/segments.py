"""Segment boundaries of a record: where its experiments or the stretches between gaps start.

A record holds one or more segments with the same channels and sampling period,
stored end to end; these helpers keep the tuple of each segment's first sample index
right through the operations on the samples (missing rows, slices, cuts). They work
on plain arrays and start tuples, so :class:`moli.data.IOData` can use them without
importing anything back.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import DataError

__all__ = ["check_starts", "remove_missing_rows", "check_slice", "starts_in_slice", "starts_after_cut",
           "segment_bounds"]


def check_starts(starts: object, N: int) -> tuple[int, ...]:
    """Validate segment starts: increasing integers in ``0..N-1``, the first 0."""
    try:
        values = [int(s) for s in starts]  # type: ignore[union-attr]
        exact = all(int(s) == s for s in starts)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise DataError(f"segment_starts must be a sequence of sample indices, got {starts!r}") from None
    if not exact or not values or values[0] != 0 or any(b <= a for a, b in zip(values, values[1:])) or (
        values[-1] >= N
    ):
        raise DataError(
            f"segment_starts must be increasing sample indices from 0 to {N - 1}, the first 0, "
            f"got {starts!r}"
        )
    return tuple(values)


def remove_missing_rows(
    y: np.ndarray, u: np.ndarray, starts: tuple[int, ...], times: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, tuple[int, ...]]:
    """Drop the samples with a NaN in any channel; where they were, a new segment starts.

    Returns the remaining rows of ``y`` and ``u``, their time stamps (None without
    ``times``) and the starts of their segments. Raises :class:`DataError` when no
    sample is complete.
    """
    missing = np.isnan(y).any(axis=1) | np.isnan(u).any(axis=1)
    if not missing.any():
        return y, u, times, starts
    kept = np.flatnonzero(~missing)
    if kept.size == 0:
        raise DataError(f"every one of the {missing.size} samples has a missing (NaN) value")
    begins = np.zeros(missing.size, bool)
    begins[list(starts)] = True
    begins[1:] |= missing[:-1]              # the sample after a missing one starts a segment
    new_starts = np.flatnonzero(begins[kept])
    return (y[kept], u[kept], None if times is None else times[kept],
            tuple(sorted({0, *new_starts.tolist()})))


def check_slice(index: object, N: int, segments: int, stamped: bool) -> slice:
    """``index`` where it slices a record of ``N`` samples in ``segments`` segments (with time
    stamps where ``stamped``); a :class:`DataError` that says why where it does not."""
    if not isinstance(index, slice):
        raise DataError("IOData is indexed by a slice of samples, e.g. data[0:500]")
    try:
        index.indices(N)
    except (TypeError, ValueError):          # bounds or a step that are no integers, a zero step
        raise DataError(f"IOData is sliced by integers with a non-zero step, e.g. data[0:500], got {index}") from None
    if segments > 1 and index.step not in (None, 1):
        raise DataError(f"a record of {segments} segments is sliced with step 1 only, got {index}")
    if stamped and (index.step or 1) < 0:
        raise DataError(f"a record with time stamps is sliced forwards only (a positive step), got {index}")
    return index


def starts_in_slice(starts: tuple[int, ...], N: int, index: slice) -> tuple[int, ...]:
    """Segment starts of ``samples[index]`` (a slice with step 1), counted from the slice's start."""
    first, stop, _ = index.indices(N)
    return (0, *(s - first for s in starts if first < s < stop))


def starts_after_cut(starts: tuple[int, ...], N: int, start: int, stop: int) -> tuple[int, ...]:
    """Segment starts once samples ``start..stop-1`` are cut out: the two sides become separate segments."""
    width = stop - start
    kept = {s for s in starts if s < start} | {s - width for s in starts if s >= stop}
    if 0 < start and stop < N:
        kept.add(start)
    return tuple(sorted(kept | {0}))


def segment_bounds(starts: Sequence[int], N: int) -> tuple[tuple[int, int], ...]:
    """``(start, stop)`` of each segment."""
    return tuple(zip(starts, (*starts[1:], N)))
