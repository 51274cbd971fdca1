"""The covariance of a continuous-time estimate, propagated to ``A, B, C``.

docs/continuous.md §6. Each output's parameters are a least-squares estimate on the
filtered regressors; their joint covariance is the sandwich
``bread S bread`` with ``bread`` each output's ``(Phi_j' Phi_j)^-1`` (from its
triangular factor, no inverse formed) and ``S`` the Newey-West long-run covariance of
the scores ``Phi_j e_j`` of all outputs together (robust to coloured and correlated
output errors; no lag spans a segment boundary). The map from the parameters to
``A, B, C`` (the observer form) is smooth; its Jacobian is taken by central
differences, and the model carries ``cov_factor`` with
``cov(vec[A, B, C, D]) = cov_factor cov_factor'``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..least_squares.sandwich import check_rank, long_run_covariance, sandwich_root
from ..least_squares.realization import observer_form_matrices
from ..least_squares.shared_factors import quotient_map
from ..structure.indices import Indices
from .estimation import StampedRecord, model_part, observer_rows
from .filters import unit_divisors

__all__ = ["covariance_factor", "regressor_map"]

# Relative step of the central differences: the map is affine in each single parameter
# (A = A_D + D C, C by forward substitution), so the truncation error is zero and
# round-off sets the step.
DIFFERENCE_STEP = 1e-6


def regressor_map(quotient: np.ndarray, c: int, p: int, j: int) -> np.ndarray:
    """``T`` with output ``j``'s regressors ``= [xi, y, 1] T`` (see :func:`reduced_problems`)."""
    nbar, l = quotient.shape
    T = np.zeros((c * nbar + p + 1, c * l + j + 1))
    for r in range(c):
        T[r * nbar : (r + 1) * nbar, r * l : (r + 1) * l] = quotient
    T[c * nbar : c * nbar + j, c * l : c * l + j] = np.eye(j)
    T[-1, -1] = 1.0
    return T


def covariance_factor(record: StampedRecord, eta: np.ndarray, indices: Indices, s: float,
                      thetas: list[np.ndarray], linear_inputs: bool) -> np.ndarray:
    """``F`` with ``cov(vec[A, B, C, D]) = F F'`` for the model fitted with filter ``eta``.

    Parameters
    ----------
    record : StampedRecord
        The estimation record the model was fitted on.
    eta : ndarray, shape (2,)
        Its filter ``(wc, zeta)``.
    indices : tuple of int
    s : float
        Root spacing factor.
    thetas : list of ndarray
        Each output's parameters, the nuisance ones included (:func:`fit_list`).
    linear_inputs : bool

    Returns
    -------
    ndarray, shape (n*n + n*m + p*n + p*m, r)

    Raises
    ------
    DataError
        An output's least-squares problem is rank deficient (an input that does not
        move, say): its parameters, and so their covariance, are not determined.
    """
    wc, zeta = float(eta[0]), float(eta[1])
    alpha, *divisors = unit_divisors(zeta, indices, s)
    p, m, nbar = len(indices), record.m, alpha.size - 1
    channels = p + m + record.with_rows(nbar)
    segments = observer_rows(record, wc, alpha, linear_inputs, skip=nbar)
    rows = np.concatenate(segments)
    breaks = np.cumsum([len(part) for part in segments])[:-1]
    scores, solved = [], []
    for j, (alpha_j, theta) in enumerate(zip(divisors, thetas)):
        regressors = rows @ regressor_map(quotient_map(alpha, alpha_j), channels, p, j)
        residual = rows[:, channels * nbar + j] - regressors @ theta
        norms = np.linalg.norm(regressors, axis=0)
        norms[norms == 0] = 1.0
        scaled = regressors / norms
        factor = scipy.linalg.qr(scaled, mode="r", check_finite=False)[0][: theta.size]
        check_rank(np.abs(np.diagonal(factor)), j)
        scores.append(scaled * residual[:, None])
        # columns back in theta's units, and rows / (N - k) in place of rows / N, as in
        # the discrete covariance (docs/uncertainty.md)
        solved.append((factor, norms / np.sqrt(rows.shape[0] / (rows.shape[0] - theta.size))))
    meat, _ = long_run_covariance(np.concatenate(scores, axis=1), tuple(breaks))
    spread = sandwich_root(meat, solved, np.cumsum([t.size for t in thetas])[:-1]).T   # cov = spread spread'
    # the transients' and the offset's parameters are nuisances: only the model's rows go on
    kept = np.concatenate([offset + model_part(np.arange(theta.size), l, p, m, channels)
                           for offset, theta, l in zip(np.cumsum([0] + [t.size for t in thetas]), thetas, indices)])
    model_thetas = [model_part(theta, l, p, m, channels) for theta, l in zip(thetas, indices)]
    return _jacobian(model_thetas, divisors, indices, m, wc) @ spread[kept]


def _jacobian(thetas: list[np.ndarray], divisors: list[np.ndarray], indices: Indices, m: int,
              wc: float) -> np.ndarray:
    """d vec[A, B, C, D] / d theta by central differences, all perturbations in one batch."""
    flat = np.concatenate(thetas)
    steps = DIFFERENCE_STEP * np.maximum(np.abs(flat), 1.0)
    moved = flat + np.concatenate([np.diag(steps), -np.diag(steps)])
    bounds = np.cumsum([t.size for t in thetas])[:-1]
    A, B, C, _ = observer_form_matrices(np.split(moved, bounds, axis=1), [divisors] * len(moved), indices, m)
    p = C.shape[1]
    vectors = np.concatenate([wc * A.reshape(len(moved), -1), wc * B.reshape(len(moved), -1),
                              C.reshape(len(moved), -1), np.zeros((len(moved), p * m))], axis=1)
    half = flat.size
    return ((vectors[:half] - vectors[half:]) / (2 * steps[:, None])).T
