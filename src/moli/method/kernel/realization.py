"""A state-space model from an impulse response: the Ho-Kalman realization of its Hankel matrix,
and the covariance of the matrices it gives.

The Markov parameters ``M_k = C A^(k-1) B`` fill the block Hankel matrix ``H[i, j] = M_(i+j+1)``;
its SVD ``H = U S V^T`` cut at order ``n`` gives the observability matrix ``O = U_n S_n^(1/2)``
and the controllability matrix ``S_n^(1/2) V_n^T``: ``C`` is the first block row of ``O``,
``B`` the first block column of the other, and ``A`` the least-squares shift ``O_up A = O_down``
(a balanced realization: Kung 1978). The covariance of ``vec[A, B, C, D]`` is the impulse
response's posterior pushed through this map to first order, each direction of the posterior
realized again in the nominal model's state basis (the realization is unique only up to it).
"""

from __future__ import annotations

import numpy as np

__all__ = ["hankel_realization", "realization_covariance", "hankel_blocks"]

# Relative size of the perturbation along one direction of the posterior (central differences:
# the error is of its square, 1e-10, far below the directions' own size).
STEP = 1e-5


def hankel_blocks(count: int) -> tuple[int, int]:
    """Block rows and columns of the Hankel matrix of ``count`` Markov parameters (``rows + cols - 1 <= count``)."""
    rows = (count + 1) // 2
    return rows, count + 1 - rows


def _hankel(markov: np.ndarray) -> np.ndarray:
    count, p, m = markov.shape
    rows, cols = hankel_blocks(count)
    H = np.empty((rows * p, cols * m))
    for i in range(rows):
        for j in range(cols):
            H[i * p:(i + 1) * p, j * m:(j + 1) * m] = markov[i + j]
    return H


def hankel_realization(markov: np.ndarray, order: int,
                       basis: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``A, B, C`` of order ``order`` realizing the Markov parameters ``markov[k] = M_(k+1)``, shape (count, p, m).

    With ``basis`` (a nominal realization's observability matrix), the state coordinates are
    those that bring this realization's observability matrix closest to it.

    Examples
    --------
    >>> a, b, c = 0.5, 2.0, 3.0
    >>> A, B, C = hankel_realization(np.array([[[c * a ** k * b]] for k in range(6)]), 1)
    >>> round(float(A[0, 0]), 12), round(float((C @ B)[0, 0]), 12)
    (0.5, 6.0)
    """
    p, m = markov.shape[1:]
    U, s, Vt = np.linalg.svd(_hankel(markov), full_matrices=False)
    root = np.sqrt(s[:order])
    O, R = U[:, :order] * root, root[:, None] * Vt[:order]
    if basis is not None:
        T = np.linalg.lstsq(O, basis, rcond=None)[0]          # O T ~ basis
        O, R = O @ T, np.linalg.solve(T, R)
    A = np.linalg.lstsq(O[:-p], O[p:], rcond=None)[0]
    return A, R[:, :m], O[:p]


def realization_covariance(markov: np.ndarray, order: int, directions: list[np.ndarray],
                           feedthrough: bool) -> np.ndarray:
    """``F`` with ``cov(vec[A, B, C, D]) = F F^T`` for the realization of ``markov`` at ``order``.

    Parameters
    ----------
    markov : ndarray, shape (count, p, m)
        The impulse response at lags 1..count (the posterior mean).
    order : int
    directions : list of ndarray
        Independent directions of the impulse response's uncertainty, each shaped as
        ``markov`` plus the lag-0 row first when ``feedthrough``, i.e. (count + feedthrough, p, m).
    feedthrough : bool
        Whether a lag 0 (``D``) was estimated.
    """
    p, m = markov.shape[1:]
    basis = np.linalg.svd(_hankel(markov), full_matrices=False)
    O = basis[0][:, :order] * np.sqrt(basis[1][:order])
    columns = []
    for direction in directions:
        scale = STEP * max(float(np.max(np.abs(markov))), 1e-300) / max(float(np.max(np.abs(direction))), 1e-300)
        moved = []
        for sign in (1.0, -1.0):
            shifted = markov + sign * scale * direction[int(feedthrough):]
            A, B, C = hankel_realization(shifted, order, O)
            D = sign * scale * direction[0] if feedthrough else np.zeros((p, m))
            moved.append(np.concatenate([A.ravel(), B.ravel(), C.ravel(), D.ravel()]))
        columns.append((moved[0] - moved[1]) / (2.0 * scale))
    return np.column_stack(columns)
