"""Triangular factors of tall matrices: Householder QR, R only, in cache-sized row blocks.

Every least-squares problem of moli over a record (the regressions of the method, the
refinement's Jacobian, the noise model, the residual tests) needs only the ``R`` of a
QR factorization of ``[X | y]``: ``|X v - y| = |R [v; -1]|``. LAPACK's ``dgeqrt`` factors
it; a tall matrix is folded in blocks of rows, the ``R`` of ``[R; next block]`` being the
``R`` of all rows so far, so that the work stays in cache and memory is one block.
"""

from __future__ import annotations

from typing import Iterable

import numpy as np
import scipy.linalg.lapack

__all__ = ["QR_BLOCK", "TALL_QR_BLOCK", "WHOLE_TALL_ROWS", "TALL_BLOCK_ROWS", "fold", "streamed_factor",
           "tall_factor", "column_norms"]

# Block size of the QR of the filtered data of a search: the record-long matrices have a
# few dozen columns, too few for LAPACK's blocked dgeqrf (which then applies one
# reflector at a time); dgeqrt in blocks of 8 took 17-44 % less time on 433 x 30 to 645 x 90
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
    for i in range(0, matrix.shape[0], TALL_BLOCK_ROWS):
        block = matrix[i : i + TALL_BLOCK_ROWS]
        total += np.einsum("ij,ij->j", block, block)
    return np.sqrt(total)

