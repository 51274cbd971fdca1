"""Long records in row blocks: filtered regressors and their triangular factor, in bounded memory.

A least-squares problem of docs/method.md §3 has one row per sample ``k`` and, per
channel, the delays ``base[k - L + t]``, ``t < L``, of one filtered signal
``base = lfilter(1, a, z)`` (``L`` the filter's degree). On a long record the rows are
produced block by block, the filter state carried from one block to the next
(``lfilter``'s ``zi``), and each block is folded into the triangular factor ``R`` by a
QR of ``[R; block]``: the ``R`` of all rows so far. Memory is one block and ``R``,
whatever the record's length.

A record may consist of several segments ``(start, stop)``: each is filtered from
rest, and its rows start ``skip`` samples after its start, so that no row reaches
across a boundary.
"""

from __future__ import annotations

from typing import Iterable, Iterator, Sequence

import numpy as np
import scipy.linalg.lapack

__all__ = ["BLOCK_ROWS", "WHOLE_ROWS", "lagged_blocks", "fold", "streamed_factor", "tall_factor", "column_norms"]

# Rows per block: a block of a few dozen columns is then a few MB, small enough to stay
# near the cache and to bound memory, large enough that the per-block Python work is
# negligible.
BLOCK_ROWS = 8192
# Records of at most this many rows are solved whole, as they always were (so their
# results are the same to the last bit); longer ones in row blocks.
WHOLE_ROWS = 2**15
# LAPACK dgeqrt's block size (see moli.method.regression.QR_BLOCK).
QR_BLOCK = 8
# The tall factors (the refinement's Jacobian, the noise model's regression, the
# estimate's problems: records times outputs, tens to a hundred columns) are dgeqrt's
# with blocks of 16 (np.linalg.qr's dgeqrf took 3-4 times as long on 1500 x 84 to
# 8000 x 100), factored whole up to WHOLE_TALL_ROWS rows and beyond that folded in
# blocks of TALL_BLOCK_ROWS, whose [R; block] stays in cache (on 98304 x 60 to 100 the
# whole factor took 1.6-2.3 times as long, np.linalg.qr 7-8 times).
TALL_QR_BLOCK = 16
WHOLE_TALL_ROWS = 8192
TALL_BLOCK_ROWS = 2048


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
    from scipy.signal import lfilter  # slow to import: only when filtering

    c = signals.shape[0]
    L = a.size - 1
    for start, stop in segments:
        state = np.zeros((c, L))
        done = start                      # samples filtered so far in this segment
        kept = np.zeros((c, 0))           # the last filtered samples, those the next rows reach
        for k0 in range(start + skip, stop, block_rows):
            k1 = min(k0 + block_rows, stop)
            if L:
                fresh, state = lfilter([1.0], a, signals[:, done:k1], axis=-1, zi=state)
            else:
                fresh = signals[:, done:k1]
            window = np.concatenate([kept, fresh], axis=1)[:, -(k1 - k0 + L):]   # base[k0 - L : k1]
            done, kept = k1, window[:, window.shape[1] - L :]
            s_r, s_k = window.strides
            yield k0, k1, np.lib.stride_tricks.as_strided(
                window, (c, L, k1 - k0), (s_r, s_k, s_k), writeable=False)


def fold(r: np.ndarray | None, block: np.ndarray, qr_block: int = QR_BLOCK) -> np.ndarray:
    """Triangular factor of ``[R; X_b]``: ``R`` (or None) and the next rows ``X_b``, given as ``block = X_b^T``.

    Returns ``R'`` of shape (min(rows, cols), cols) with ``R'^T R' = R^T R + X_b^T X_b``
    (rows' signs as LAPACK leaves them); ``qr_block`` is dgeqrt's block size.
    """
    cols = block.shape[0]
    k = 0 if r is None else r.shape[0]
    # stored column by column: dgeqrt factors [R; block] in place
    stacked = np.empty((cols, k + block.shape[1]))
    if k:
        stacked[:, :k] = r.T
    stacked[:, k:] = block
    rows = stacked.shape[1]
    factored = scipy.linalg.lapack.dgeqrt(max(min(qr_block, rows, cols), 1), stacked.T, overwrite_a=True)[0]
    return np.triu(factored[: min(rows, cols)])


def streamed_factor(blocks: Iterable[np.ndarray], qr_block: int = QR_BLOCK) -> np.ndarray:
    """Triangular factor of a tall matrix given as transposed row blocks (:func:`fold`, in turn)."""
    r = None
    for block in blocks:
        r = fold(r, block, qr_block)
    return r


def tall_factor(matrix: np.ndarray) -> np.ndarray:
    """Triangular factor of a tall matrix: ``np.linalg.qr(matrix, mode="r")`` to round-off.

    Both are Householder factorizations, so the rows' signs agree. Matrices of at most
    :data:`WHOLE_TALL_ROWS` rows are factored whole, taller ones folded in blocks of
    :data:`TALL_BLOCK_ROWS` rows, without a copy of the whole matrix.
    """
    rows, cols = matrix.shape
    if min(rows, cols) == 0:
        return np.zeros((min(rows, cols), cols))
    if rows <= WHOLE_TALL_ROWS:
        # the input is left alone: LAPACK factors a column-ordered copy
        factored = scipy.linalg.lapack.dgeqrt(min(TALL_QR_BLOCK, rows, cols), matrix)[0]
        return np.triu(factored[: min(rows, cols)])
    return streamed_factor((matrix[i : i + TALL_BLOCK_ROWS].T for i in range(0, rows, TALL_BLOCK_ROWS)),
                           TALL_QR_BLOCK)


def column_norms(matrix: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(matrix, axis=0)``, by row blocks beyond :data:`WHOLE_TALL_ROWS` rows.

    Short matrices get numpy's norm as they always did; taller ones are summed block by
    block, without the squared copy of the whole matrix.
    """
    if matrix.shape[0] <= WHOLE_TALL_ROWS:
        return np.linalg.norm(matrix, axis=0)
    total = np.zeros(matrix.shape[1])
    for i in range(0, matrix.shape[0], BLOCK_ROWS):
        block = matrix[i : i + BLOCK_ROWS]
        total += np.einsum("ij,ij->j", block, block)
    return np.sqrt(total)

