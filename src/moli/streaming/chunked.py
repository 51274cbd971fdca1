"""Batch MOLI estimation of records too long for memory, chunk by chunk.

Filter states are carried across chunks and each group of outputs keeps the R
factor of its augmented regression ``[phi, y]``, updated by a QR of
``[R_prev; rows_chunk]`` (:class:`moli.streaming.sqrt_rls.SquareRootRls` with no prior and
no forgetting). ``|Phi theta - y|^2 = |R11 theta - r12|^2 + r22^2`` and ``R11``
has the column norms of ``Phi``, so solving the small triangular problem with
:func:`moli.method.estimation.solve_batch` gives the whole-record least-squares solution
of :func:`moli.estimate` (up to round-off), never forming normal equations.
Memory is constant: a few K x K factors plus one chunk.
"""

from __future__ import annotations

import warnings
from typing import Sequence

import numpy as np

from ..errors import IllConditionedWarning
from ..method.estimation import COND_LIMIT, check_sample_count, realize, solve_batch
from ..models.statespace import StateSpaceModel
from .recursive import FixedFilterEstimator

__all__ = ["ChunkedEstimator"]


class ChunkedEstimator(FixedFilterEstimator):
    """Whole-record batch estimate accumulated over chunks of any sizes.

    Parameters
    ----------
    indices : sequence of int
        Observability indices, one per output.
    alpha : array_like
        Monic, stable filter polynomial of degree ``max(indices)``.
    m : int
        Number of inputs.
    Ts : float, default 1.0
        Sampling period given to the model.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(300)
    >>> y = np.zeros(300)
    >>> for k in range(1, 300):
    ...     y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1]
    >>> est = ChunkedEstimator([1], moli.filter_polynomial(1.0, 1.0, [1]), 1)
    >>> est = est.add(y[:100], u[:100]).add(y[100:], u[100:])
    >>> np.round(est.model().poles().real, 6)
    array([0.8])
    """

    def __init__(self, indices: Sequence[int], alpha: Sequence[float], m: int, Ts: float = 1.0) -> None:
        # no forgetting, unit noise variance and no prior: the plain least-squares factor
        super().__init__(indices, alpha, m, Ts, 1.0, 1.0, np.inf)

    def add(self, y: object, u: object) -> "ChunkedEstimator":
        """Absorb the next chunk of the record.

        Parameters
        ----------
        y : array_like, shape (N, p)
            Outputs, time along axis 0 (1-D accepted when p = 1).
        u : array_like, shape (N, m)
            Inputs, time along axis 0 (1-D accepted when m = 1).

        Returns
        -------
        ChunkedEstimator
            ``self``.
        """
        self._absorb(y, u)
        return self

    def model(self) -> StateSpaceModel:
        """The least-squares model of all samples absorbed so far.

        Warns
        -----
        IllConditionedWarning
            If a least-squares problem is badly conditioned (poor excitation).
        UnstableModelWarning
            If the model has poles on or outside the unit circle.
        """
        check_sample_count(self.samples, self.indices, self.m)
        thetas, worst = [], 1.0
        for count, factor in self._bank.factors():
            theta, cond = solve_batch(factor[:, :count, :count], factor[:, :count, count])
            thetas.append(theta)
            worst = max(worst, float(cond[0]))
        if worst > COND_LIMIT:
            warnings.warn(
                f"least-squares problem for list {list(self.indices)} is badly conditioned "
                f"(condition ~{worst:.2g}): the input may not excite the plant enough, or the "
                "order is too high for the data",
                IllConditionedWarning,
                stacklevel=2,
            )
        model = self._model(*realize(thetas, [self._alphas], self.indices, self.m))
        model.warn_if_unstable(stacklevel=2)
        return model
