"""The FIR regression of a record, reduced to its triangular factor.

Output ``j`` at sample ``t`` is regressed on ``u_i(t - k)`` for every input ``i`` and lag
``k`` in ``lags``; rows start once every lag of the segment is inside it, so each segment
(experiment, or stretch between gaps) gives its own rows and no sample crosses a gap. Only
the ``R`` of ``[Phi | Y]`` is kept, built from row blocks: memory is one block, whatever
the record's length.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...data.iodata import IOData
from ...numerics.triangular import streamed_factor

__all__ = ["FirFactor", "fir_factor", "fir_rows"]

# Rows of one block of the regression: (rows x m n) doubles stay a few megabytes.
BLOCK_ROWS = 2048


@dataclass(frozen=True)
class FirFactor:
    """``R`` of ``[Phi | Y]`` split as the marginal likelihood uses it.

    Attributes
    ----------
    R1 : ndarray, shape (d, d)
        The regressors' factor (``Phi^T Phi = R1^T R1``), ``d = m * len(lags)``, columns input-major.
    r2 : ndarray, shape (d, p)
        ``R1^-T Phi^T Y``: each output's projection on the regressors.
    r3 : ndarray, shape (p,)
        Each output's residual norm after its least squares.
    rows : int
        Rows of the regression.
    """

    R1: np.ndarray
    r2: np.ndarray
    r3: np.ndarray
    rows: int


def fir_rows(data: IOData, lags: np.ndarray) -> int:
    """Rows of the FIR regression of ``data`` at ``lags``: those of each segment longer than the largest lag.

    >>> import numpy as np
    >>> fir_rows(IOData(np.zeros(100), np.zeros(100)), np.arange(1, 11))
    90
    """
    top = int(lags[-1])
    return int(sum(max(stop - start - top, 0) for start, stop in data.bounds))


def _blocks(data: IOData, lags: np.ndarray):
    """Transposed row blocks ``[Phi | Y]^T`` of every segment."""
    top, m = int(lags[-1]), data.m
    for start, stop in data.bounds:
        for first in range(start + top, stop, BLOCK_ROWS):
            last = min(first + BLOCK_ROWS, stop)
            rows = np.arange(first, last)
            phi = np.empty((len(rows), m * len(lags)))
            for i in range(m):
                phi[:, i * len(lags):(i + 1) * len(lags)] = data.u[rows[:, None] - lags[None, :], i]
            yield np.concatenate([phi, data.y[first:last]], axis=1).T


def fir_factor(data: IOData, lags: np.ndarray) -> FirFactor:
    """The factor of the FIR regression of ``data`` at ``lags`` (sample lags, increasing).

    Parameters
    ----------
    data : IOData
        A record whose segments each hold more samples than the largest lag (others give no rows).
    lags : ndarray of int

    Returns
    -------
    FirFactor
    """
    d, p = data.m * len(lags), data.p
    R = streamed_factor(_blocks(data, lags))
    square = np.zeros((d + p, d + p))
    square[: R.shape[0]] = R            # fewer rows than columns: the missing rows are zero
    lower = square[d:, d:]
    return FirFactor(R1=square[:d, :d], r2=square[:d, d:], r3=np.sqrt(np.sum(lower ** 2, axis=0)),
                     rows=fir_rows(data, lags))
