"""The regression rows of a record: which samples enter the least squares, and whether they are enough.

A record of several segments (docs/data.md, "Gaps and experiments") restarts the
filters at each segment, so each segment gives its samples from the filter
transient's end on, and no regressor row spans a boundary (docs/method.md §3).
"""

from __future__ import annotations

from itertools import accumulate
from typing import Callable, Sequence

import numpy as np

from ...errors import DataError
from .indices import Indices, generic_indices, parameter_counts

__all__ = ["regression_rows", "row_count", "row_breaks", "samples_needed", "largest_order", "largest_fitting",
           "check_sample_count",
           "check_regression_rows"]


def regression_rows(z: np.ndarray, skip: int, starts: Sequence[int] = (0,)) -> np.ndarray:
    """The samples of ``z`` that are regression rows: each segment's from its sample ``skip`` on.

    ``starts`` holds each segment's first sample; filters restart there, so a segment's
    first ``skip`` samples only charge them (docs/method.md §3, "Segments").
    """
    if len(starts) == 1:
        return z[skip:]
    stops = (*starts[1:], z.shape[0])
    return np.concatenate([z[a + skip : b] for a, b in zip(starts, stops) if b - a > skip] or [z[:0]])


def row_count(bounds: Sequence[tuple[int, int]], skip: int) -> int:
    """How many :func:`regression_rows` a record of segments ``bounds`` has: each one's samples from ``skip`` on."""
    return sum(max(b - a - skip, 0) for a, b in bounds)


def row_breaks(starts: Sequence[int], N: int, skip: int) -> tuple[int, ...]:
    """Where each segment's rows start among the stacked :func:`regression_rows` (after the first)."""
    stops = (*starts[1:], N)
    counts = [b - a - skip for a, b in zip(starts, stops) if b - a > skip]
    return tuple(accumulate(counts))[:-1]


def samples_needed(indices: Indices, m: int, feedthrough: bool = False) -> int:
    """Samples the regression of the list ``indices`` needs: one row more than its largest
    count of unknowns, after the filter transient of ``max(indices)`` samples."""
    return int(parameter_counts(indices, m).max()) + (m if feedthrough else 0) + max(indices) + 1


def largest_order(N: int, p: int, m: int, feedthrough: bool = False) -> int:
    """The largest order whose cheapest list (the balanced one, longer indices first: the
    generic list, :func:`moli.method.structure.indices.generic_indices`) ``N`` samples can estimate;
    ``p - 1`` when none can."""
    return largest_fitting(lambda n: samples_needed(generic_indices(n, p), m, feedthrough) <= N, p)


def largest_fitting(fits: Callable[[int], bool], p: int) -> int:
    """The largest order ``n >= p`` with ``fits(n)``, for a ``fits`` true up to some order and false
    beyond; ``p - 1`` when ``fits(p)`` is false.

    The samples an order needs grow with it: a bound is doubled past the answer, then bisected (a
    long record reaches orders in the hundred thousands, which stepping one by one took seconds to
    find).

    >>> largest_fitting(lambda n: n <= 37, 2), largest_fitting(lambda n: False, 3)
    (37, 2)
    """
    low, high = p - 1, p
    while fits(high):
        low, high = high, 2 * high
    while high - low > 1:
        middle = (low + high) // 2
        low, high = (middle, high) if fits(middle) else (low, middle)
    return low


def check_sample_count(N: int, indices: Indices, m: int, feedthrough: bool = False) -> None:
    """Raise :class:`DataError` unless each output's regression has more rows than unknowns.

    ``feedthrough``: the ``m`` current inputs join every output's regressors.
    """
    need = samples_needed(indices, m, feedthrough)
    if N < need:
        raise DataError(
            f"too few samples: the list {list(indices)} with {m} inputs"
            + (" and a feedthrough" if feedthrough else "")
            + f" needs at least {need} samples ({need - max(indices)} rows after the filter "
            f"transient), got {N}"
        )


def check_regression_rows(
    bounds: Sequence[tuple[int, int]], indices: Indices, m: int, feedthrough: bool = False
) -> None:
    """:func:`check_sample_count` for a record of segments: their rows together must do.

    Each segment gives its samples from ``max(indices)`` on (none when it is shorter);
    one segment is checked exactly as :func:`check_sample_count` checks a record.
    """
    if len(bounds) == 1:
        check_sample_count(bounds[0][1] - bounds[0][0], indices, m, feedthrough)
        return
    skip = max(indices)
    rows = row_count(bounds, skip)
    need = int(parameter_counts(indices, m).max()) + (m if feedthrough else 0) + 1
    if rows < need:
        raise DataError(
            f"too few samples: the list {list(indices)} with {m} inputs"
            + (" and a feedthrough" if feedthrough else "")
            + f" needs at least {need} regression rows, and the {len(bounds)} segments give {rows} "
            f"(each segment's samples after its first {skip}, the filter transient)"
        )
