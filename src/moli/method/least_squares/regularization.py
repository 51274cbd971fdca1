"""Ridge least squares with the weight chosen by generalized cross-validation."""

from __future__ import annotations

import numpy as np

__all__ = ["REGULARIZATIONS", "ridge_gcv"]

# "none": plain least squares (the paper); "gcv": ridge, weight by GCV per problem.
REGULARIZATIONS = ("none", "gcv")

# Ridge weights tried, relative to the largest squared singular value of the
# column-scaled problem: from no shrinkage at all to heavy shrinkage.
RELATIVE_WEIGHTS = np.concatenate([[0.0], np.logspace(-12, -1, 23)])


def ridge_gcv(small: np.ndarray, rhs: np.ndarray, rows: int) -> np.ndarray:
    """Ridge solutions of reduced least-squares problems, weight by GCV, per problem.

    ``small`` (R, k, q) and ``rhs`` (R, k) are problems reduced by a triangular factor
    of the full ``rows``-row regression, so residual norms are the full ones. The
    columns are scaled to unit norm before shrinking (the weight then acts alike on
    every regressor); GCV(lambda) = rows RSS / (rows - df)^2.
    """
    count, _, q = small.shape
    norms = np.sqrt(np.einsum("rkq,rkq->rq", small, small))
    norms[norms == 0] = 1.0
    scaled = small / norms[:, None, :]
    U, s, Vt = np.linalg.svd(scaled, full_matrices=False)
    beta = np.einsum("rkq,rk->rq", U, rhs)
    outside = np.einsum("rk,rk->r", rhs, rhs) - np.einsum("rq,rq->r", beta, beta)
    s2 = s * s
    lam = RELATIVE_WEIGHTS[None, :] * s2[:, :1]                        # (R, L)
    with np.errstate(divide="ignore", invalid="ignore"):
        shrink = s2[:, None, :] / (s2[:, None, :] + lam[:, :, None])  # (R, L, q)
        shrink = np.where(s2[:, None, :] > 0, shrink, 0.0)
        rss = np.maximum(outside, 0.0)[:, None] + np.einsum("rlq,rq->rl", (1 - shrink) ** 2, beta * beta)
        df = shrink.sum(axis=2)
        gcv = rows * rss / np.maximum(rows - df, 1.0) ** 2
    best = np.argmin(np.where(np.isfinite(gcv), gcv, np.inf), axis=1)
    f = shrink[np.arange(count), best]
    with np.errstate(divide="ignore", invalid="ignore"):
        coef = np.where(s > 0, f * beta / s, 0.0)
    theta = np.einsum("rqk,rk->rq", Vt.transpose(0, 2, 1), coef)
    return theta / norms
