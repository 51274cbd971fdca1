"""The ARX regression of a record, reduced to its triangular factor.

Output ``j`` at sample ``t`` is regressed on ``y_i(t - k)`` for every output ``i`` and
``k = 1..n``, and on ``u_l(t - k)`` for every input ``l`` and ``k = 1..n`` (``0..n-1`` with
a direct feedthrough). Each channel's ``n`` lags form one block of columns, outputs first:
the block a kernel prior is put on. Rows start once every lag of the segment is inside it,
so no regressor reaches across a gap or from one experiment into the next. Only the ``R`` of
``[Phi | Y]`` is kept (:class:`.fir_rows.FirFactor`), built from row blocks.
"""

from __future__ import annotations

import numpy as np

from ...data.iodata import IOData
from ...numerics.triangular import streamed_factor
from .fir_rows import BLOCK_ROWS, FirFactor

__all__ = ["arx_rows", "arx_factor"]


def arx_rows(data: IOData, lags: int) -> int:
    """Rows of the ARX regression of ``data`` with ``lags`` lags per channel: those of each
    segment longer than ``lags``.

    >>> arx_rows(IOData(np.zeros(100), np.zeros(100)), 10)
    90
    """
    return int(sum(max(stop - start - lags, 0) for start, stop in data.bounds))


def _blocks(data: IOData, lags: int, feedthrough: bool):
    """Transposed row blocks ``[Phi | Y]^T`` of every segment."""
    p, m = data.p, data.m
    output_lags = np.arange(1, lags + 1)
    input_lags = output_lags - int(feedthrough)
    for start, stop in data.bounds:
        for first in range(start + lags, stop, BLOCK_ROWS):
            rows = np.arange(first, min(first + BLOCK_ROWS, stop))
            phi = np.empty((len(rows), (p + m) * lags))
            for i in range(p):
                phi[:, i * lags:(i + 1) * lags] = data.y[rows[:, None] - output_lags[None, :], i]
            for i in range(m):
                phi[:, (p + i) * lags:(p + i + 1) * lags] = data.u[rows[:, None] - input_lags[None, :], i]
            yield np.concatenate([phi, data.y[rows]], axis=1).T


def arx_factor(data: IOData, lags: int, feedthrough: bool) -> FirFactor:
    """The factor of the ARX regression of ``data``, ``lags`` lags per channel.

    Parameters
    ----------
    data : IOData
        A record with at least one segment longer than ``lags``.
    lags : int
    feedthrough : bool
        The inputs' lags are ``0..lags-1`` instead of ``1..lags``.

    Returns
    -------
    FirFactor
        ``R1`` over the ``(p + m) * lags`` regressors (outputs' blocks, then inputs'), ``r2``
        and ``r3`` of every output.
    """
    d, p = (data.p + data.m) * lags, data.p
    R = streamed_factor(_blocks(data, lags, feedthrough))
    square = np.zeros((d + p, d + p))
    square[: R.shape[0]] = R            # fewer rows than columns: the missing rows are zero
    lower = square[d:, d:]
    return FirFactor(R1=square[:d, :d], r2=square[:d, d:], r3=np.sqrt(np.sum(lower ** 2, axis=0)),
                     rows=arx_rows(data, lags))
