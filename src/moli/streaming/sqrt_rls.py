"""Recursive least squares in square-root information form, batched.

Each problem of the batch keeps an upper-triangular factor ``F`` (K x K) of its
augmented data ``[phi, targets]``: ``F^T F`` equals the weighted sum of
``row row^T`` plus the prior ``I / p0``. New rows are absorbed by a QR of
``[sqrt(lambda^b) F; W rows]``, so the estimate is exactly the Kalman-form RLS
(``P_0 = p0 I``, ``theta_0 = 0``, noise variance ``R2``, forgetting ``lambda``):

    P_k^{-1} = lambda P_{k-1}^{-1} + (1 - lambda) I / p0 + phi_k phi_k^T / R2.

The term ``(1 - lambda) I / p0`` (stabilised forgetting) makes the information
decay toward the prior instead of zero, so ``P`` stays below ``p0 I`` when the
data stop exciting some direction; with ``lambda = 1`` it vanishes.

Why this form: ``P = F11^{-1} F11^{-T}`` is symmetric positive definite by
construction, with no subtraction that could lose definiteness over millions
of steps, and a block of ``b`` rows costs one QR that is exactly equal to ``b``
sequential updates. Because the leading columns of a triangular factor are the
factor of the leading columns, one factor of ``[phi, y_1, ..., y_p]`` serves every
output: output ``j`` regresses column ``c + j`` on the ``c + j`` columns before it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SquareRootRls"]

# Rows absorbed per QR: large enough to amortise the per-call overhead, small
# enough that the stacked (K + BLOCK) x K arrays stay in cache.
BLOCK = 512


class SquareRootRls:
    """Batch of exponentially weighted least-squares problems, updated by QR.

    Parameters
    ----------
    batch : int
        Number of independent problems ``G``.
    size : int
        Columns ``K`` of the augmented rows (regressors then targets).
    forgetting : float, default 1.0
        Forgetting factor ``lambda`` in (0, 1].
    noise_variance : float, default 1.0
        Output noise variance ``R2`` of the Kalman form.
    p0 : float, default 1e6
        Prior covariance ``P_0 = p0 I``; ``inf`` gives plain least squares.

    Examples
    --------
    >>> rls = SquareRootRls(1, 2, p0=np.inf)
    >>> rls.update(np.array([[[1.0, 2.0], [2.0, 4.0]]]))
    >>> F = rls.factor[0]   # y = 2 phi: the slope is F[0, 1] / F[0, 0]
    >>> float(round(F[0, 1] / F[0, 0], 12))
    2.0
    """

    def __init__(
        self, batch: int, size: int, *, forgetting: float = 1.0, noise_variance: float = 1.0,
        p0: float = 1e6,
    ) -> None:
        self.forgetting = float(forgetting)
        self._row_scale = 1.0 / np.sqrt(noise_variance)
        self._prior = 0.0 if np.isinf(p0) else 1.0 / np.sqrt(p0)
        self.factor = np.broadcast_to(self._prior * np.eye(size), (batch, size, size)).copy()

    def update(self, rows: np.ndarray) -> None:
        """Absorb rows, oldest first.

        Parameters
        ----------
        rows : ndarray, shape (G, N, K)
        """
        G, N, K = rows.shape
        lam = self.forgetting
        for start in range(0, N, BLOCK):
            block = rows[:, start : start + BLOCK]
            b = block.shape[1]
            # b sequential steps weight row i by lam^(b-1-i) and the old information
            # by lam^b; the prior floor adds (1 - lam^b) I / p0 (nothing when lam = 1).
            weights = lam ** (0.5 * np.arange(b - 1, -1, -1)) * self._row_scale
            parts = [self.factor * lam ** (0.5 * b), block * weights[:, None]]
            if lam < 1.0 and self._prior:
                floor = np.sqrt(1.0 - lam**b) * self._prior * np.eye(K)
                parts.append(np.broadcast_to(floor, (G, K, K)))
            self.factor = np.linalg.qr(np.concatenate(parts, axis=1), mode="r")
