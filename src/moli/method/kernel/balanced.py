"""Balanced truncation of a discrete-time model: the projection that keeps its states of largest
Hankel singular value, the unstable ones kept whole.

scipy has no model reduction, and python-control's ``balred`` needs slycot (not a moli
dependency), so the square-root method is written out here (Moore 1981; Laub et al. 1987):
the Gramians ``P = A P A^T + B B^T`` and ``Q = A^T Q A + C^T C`` of the stable part, square
roots ``P = S S^T`` and ``Q = R R^T``, the SVD ``R^T S = U Sigma V^T``, and the projection
``x = S V_r Sigma_r^(-1/2) z``, ``z = Sigma_r^(-1/2) U_r^T R^T x``. An unstable part (no Gramian)
is split off first by an ordered real Schur form and a Sylvester equation, and kept as it is,
as MATLAB's ``balred`` does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .kernels import square_root

__all__ = ["Balancing", "balancing"]

# Stable states whose Hankel singular value is below this share of the largest are dropped
# from the balancing: they are numerically unobservable or unreachable, and their projection
# (Sigma^(-1/2)) would amplify round-off.
HSV_FLOOR = 1e-12


@dataclass(frozen=True)
class Balancing:
    """The balanced coordinates of a model: ``x = right @ z`` and ``z = left.T @ x``.

    Attributes
    ----------
    right, left : ndarray, shape (states, kept)
        Columns: the balanced stable states by decreasing Hankel singular value, then the
        unstable states; ``left.T @ right = I``.
    hankel_singular_values : ndarray
        Of the stable part, the states kept.
    unstable : int
        States of the unstable part (eigenvalues of modulus 1 or more).
    """

    right: np.ndarray
    left: np.ndarray
    hankel_singular_values: np.ndarray
    unstable: int

    @property
    def largest_order(self) -> int:
        """The most states a truncation can keep."""
        return self.right.shape[1]

    def projection(self, order: int) -> tuple[np.ndarray, np.ndarray]:
        """``V, W`` of the truncation to ``order`` states (at least :attr:`unstable`):
        the reduced model is ``W^T A V, W^T B, C V, D``."""
        if not self.unstable <= order <= self.largest_order:
            raise ValueError(f"order {order} outside {self.unstable}..{self.largest_order}")
        stable = len(self.hankel_singular_values)
        keep = np.r_[np.arange(order - self.unstable), np.arange(stable, stable + self.unstable)]
        return self.right[:, keep], self.left[:, keep]


def balancing(A: np.ndarray, B: np.ndarray, C: np.ndarray) -> Balancing:
    """The balanced coordinates of ``x[k+1] = A x[k] + B u[k]``, ``y[k] = C x[k]``.

    Examples
    --------
    Two states, one of them unobservable: a single state carries the whole response.

    >>> A, B, C = np.diag([0.5, 0.2]), np.ones((2, 1)), np.array([[1.0, 0.0]])
    >>> b = balancing(A, B, C)
    >>> b.largest_order, b.unstable
    (1, 0)
    >>> V, W = b.projection(1)
    >>> round(float((W.T @ A @ V)[0, 0]), 12)
    0.5
    """
    states = A.shape[0]
    T, Z, stable = scipy.linalg.schur(A, output="real", sort="iuc")
    # decouple the unstable part: [[I, -X], [0, I]] T [[I, X], [0, I]] is block diagonal
    X = scipy.linalg.solve_sylvester(T[:stable, :stable], -T[stable:, stable:], -T[:stable, stable:]) \
        if stable < states else np.zeros((stable, 0))
    right = Z.copy()
    right[:, stable:] += Z[:, :stable] @ X
    left = Z.copy()
    left[:, :stable] -= Z[:, stable:] @ X.T
    As, Bs, Cs = T[:stable, :stable], (left.T @ B)[:stable], (C @ right)[:, :stable]
    S = square_root(scipy.linalg.solve_discrete_lyapunov(As, Bs @ Bs.T))
    R = square_root(scipy.linalg.solve_discrete_lyapunov(As.T, Cs.T @ Cs))
    U, sigma, Vt = np.linalg.svd(R.T @ S)
    kept = int(np.sum(sigma > HSV_FLOOR * sigma[0])) if sigma.size and sigma[0] > 0 else 0
    root = 1.0 / np.sqrt(sigma[:kept])
    stable_right = right[:, :stable] @ (S @ Vt[:kept].T * root)
    stable_left = left[:, :stable] @ (R @ U[:, :kept] * root)
    return Balancing(np.concatenate([stable_right, right[:, stable:]], axis=1),
                     np.concatenate([stable_left, left[:, stable:]], axis=1), sigma[:kept], states - stable)
