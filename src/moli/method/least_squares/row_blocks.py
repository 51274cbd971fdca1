"""Long records in row blocks: the filtered regressors, block by block, in bounded memory.

A least-squares problem of docs/method.md §3 has one row per sample ``k`` and, per
channel, the delays ``base[k - L + t]``, ``t < L``, of one filtered signal
``base = lfilter(1, a, z)`` (``L`` the filter's degree). On a long record the rows are
produced block by block, the filter state carried from one block to the next
(``lfilter``'s ``zi``), and each block is folded into the triangular factor ``R``
(:func:`moli.numerics.triangular.fold`). Memory is one block and ``R``, whatever the
record's length.

A record may consist of several segments ``(start, stop)``: each is filtered from
rest, and its rows start ``skip`` samples after its start, so that no row reaches
across a boundary.
"""

from __future__ import annotations

from typing import Iterator, Sequence

import numpy as np

from ...numerics.recursive_filter import recursive_filter

__all__ = ["BLOCK_ROWS", "WHOLE_ROWS", "lagged_blocks"]

# Rows per block: a block of a few dozen columns is then a few MB, small enough to stay
# near the cache and to bound memory, large enough that the per-block Python work is
# negligible.
BLOCK_ROWS = 8192
# Records of at most this many rows are solved whole, as they always were (so their
# results are the same to the last bit); longer ones in row blocks.
WHOLE_ROWS = 2**15


def lagged_blocks(
    signals: np.ndarray, a: np.ndarray, skip: int, segments: Sequence[tuple[int, int]],
    block_rows: int = BLOCK_ROWS,
) -> Iterator[tuple[int, int, np.ndarray]]:
    """Row blocks of the delays of ``lfilter(1, a, signals)``, segment by segment.

    Parameters
    ----------
    signals : ndarray, shape (c, N)
        Channels along axis 0, samples along axis 1.
    a : ndarray, shape (L + 1,)
        Monic filter denominator.
    skip : int
        Rows of a segment start ``skip >= L`` samples after its start.
    segments : sequence of (start, stop)
    block_rows : int

    Yields
    ------
    k0, k1 : int
        The block's rows are the samples ``k0 .. k1 - 1``.
    lagged : ndarray, shape (c, L, k1 - k0)
        ``lagged[r, t, i] = base[r, k0 + i - L + t]``, base filtered from the segment's
        start at rest (a read-only view, valid until the next block).
    """
    c = signals.shape[0]
    L = a.size - 1
    for start, stop in segments:
        state = np.zeros((c, L))
        done = start                      # samples filtered so far in this segment
        kept = np.zeros((c, 0))           # the last filtered samples, those the next rows reach
        for k0 in range(start + skip, stop, block_rows):
            k1 = min(k0 + block_rows, stop)
            if L:
                fresh, state = recursive_filter([1.0], a, signals[:, done:k1], axis=-1, zi=state)
            else:
                fresh = signals[:, done:k1]
            window = np.concatenate([kept, fresh], axis=1)[:, -(k1 - k0 + L):]   # base[k0 - L : k1]
            done, kept = k1, window[:, window.shape[1] - L :]
            s_r, s_k = window.strides
            yield k0, k1, np.lib.stride_tricks.as_strided(
                window, (c, L, k1 - k0), (s_r, s_k, s_k), writeable=False)
