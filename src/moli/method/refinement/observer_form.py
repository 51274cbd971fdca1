"""The observer form of a MOLI model: the parameters refinement and the covariance work on.

A model estimated by MOLI is ``A = A_D + D C``, ``C = (I - G)^-1 C_D``, with ``A_D`` and
``C_D`` fixed by its filters and indices (docs/method.md §4); :func:`observer_form`
recovers the free pieces ``D``, ``B``, ``G`` and the feedthrough from its matrices.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ...errors import DataError
from ...models.statespace import StateSpaceModel
from ..least_squares.realization import filter_companion
from ..structure.filters import divisors

__all__ = ["ObserverForm", "observer_form"]


@dataclass
class ObserverForm:
    """The observer-form pieces of a MOLI model.

    ``A = A_D + D C``, ``C = (I - G)^-1 C_D``; ``B`` and the feedthrough ``F`` (zero
    unless the model was estimated with one) are free.
    """

    A_D: np.ndarray
    C_D: np.ndarray
    D: np.ndarray
    B: np.ndarray
    G: np.ndarray
    F: np.ndarray

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C)`` of the model (its feedthrough is ``F``)."""
        p = self.G.shape[0]
        C = np.linalg.solve(np.eye(p) - self.G, self.C_D)
        return self.A_D + self.D @ C, self.B, C


def observer_form(model: StateSpaceModel) -> ObserverForm:
    """Recover ``A_D, C_D, D, B, G`` from a model estimated by MOLI.

    Parameters
    ----------
    model : StateSpaceModel
        Must carry ``indices`` and its filters, ``alpha`` or per-output ``divisors``
        (models from :func:`moli.estimate` or :func:`moli.identify` do).

    Returns
    -------
    ObserverForm
    """
    filters = model.divisors
    if filters is None and model.alpha is not None and model.indices is not None:
        filters = divisors(model.alpha, model.indices)
    if filters is None:
        raise DataError("refinement needs a MOLI model that carries its indices and filter polynomials")
    indices = model.indices
    n, p = model.n, model.p
    A_D = filter_companion([alpha_j[None] for alpha_j in filters], indices)[0]
    C_D = np.zeros((p, n))
    last = np.cumsum(indices) - 1
    C_D[np.arange(p), last] = 1.0
    # C = H C_D with H = (I - G)^-1 unit lower triangular and C_D picking each block's
    # last state, so A - A_D = D C has its only nonzero columns there: D = (A - A_D)[:, last] H^-1.
    # Triangular solves keep this exact whatever the outputs' units (a least-squares
    # fit on C loses the small entries when the outputs' scales differ by many decades).
    H = model.C[:, last]
    H_inv = scipy.linalg.solve_triangular(H, np.eye(p), lower=True, unit_diagonal=True)
    G = np.tril(np.eye(p) - H_inv, -1)
    D = (model.A - A_D)[:, last] @ H_inv
    return ObserverForm(A_D, C_D, D, model.B.copy(), G, model.D.copy())
