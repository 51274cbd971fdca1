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

from ..covariance import long_run_covariance
from ..estimation import _observer_form
from ..regression import _quotient_map
from ..structure import Indices
from .estimation import StampedRecord, model_part, observer_rows
from .filters import unit_divisors

__all__ = ["covariance_factor"]

# Relative step of the central differences: the map is a polynomial of degree two in
# the parameters, so the truncation error is zero and round-off sets the step.
DIFFERENCE_STEP = 1e-6


def regressor_map(quotient: np.ndarray, c: int, p: int, j: int) -> np.ndarray:
    """``T`` with output ``j``'s regressors ``= [xi, y] T`` (see :func:`_small_problems`)."""
    nbar, l = quotient.shape
    T = np.zeros((c * nbar + p, c * l + j))
    for r in range(c):
        T[r * nbar : (r + 1) * nbar, r * l : (r + 1) * l] = quotient
    T[c * nbar : c * nbar + j, c * l :] = np.eye(j)
    return T


def covariance_factor(record: StampedRecord, eta: np.ndarray, indices: Indices, s: float,
                      thetas: list[np.ndarray], linear_inputs: bool) -> np.ndarray:
    """``F`` with ``cov(vec[A, B, C, D]) = F F'`` for the model fitted with filter ``eta``."""
    wc, zeta = float(eta[0]), float(eta[1])
    alpha, *divisors = unit_divisors(zeta, indices, s)
    p, m, nbar = len(indices), record.m, alpha.size - 1
    channels = p + m + 1 + len(record.times)
    segments = observer_rows(record, wc, alpha, linear_inputs, skip=nbar)
    rows = np.concatenate(segments)
    breaks = np.cumsum([len(part) for part in segments])[:-1]
    scores, factors = [], []
    for j, (alpha_j, theta) in enumerate(zip(divisors, thetas)):
        regressors = rows @ regressor_map(_quotient_map(alpha, alpha_j), channels, p, j)
        residual = rows[:, channels * nbar + j] - regressors @ theta
        scores.append(regressors * residual[:, None])
        factors.append(scipy.linalg.qr(regressors, mode="r", check_finite=False)[0][: regressors.shape[1]])
    meat, _ = long_run_covariance(np.concatenate(scores, axis=1), tuple(breaks))
    values, vectors = np.linalg.eigh(meat)
    root = vectors * np.sqrt(np.clip(values, 0.0, None))              # meat = root root'
    parts = np.split(root, np.cumsum([t.size for t in thetas])[:-1], axis=0)
    # (R'R)^-1 root by two triangular solves per output
    spread = np.concatenate([
        scipy.linalg.solve_triangular(r, scipy.linalg.solve_triangular(r, part, trans="T"))
        for r, part in zip(factors, parts)
    ])
    # the transients' parameters are nuisances: only the model's rows go on
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
    A, B, C, _ = _observer_form(np.split(moved, bounds, axis=1), [divisors] * len(moved), indices, m)
    p = C.shape[1]
    vectors = np.concatenate([wc * A.reshape(len(moved), -1), wc * B.reshape(len(moved), -1),
                              C.reshape(len(moved), -1), np.zeros((len(moved), p * m))], axis=1)
    half = flat.size
    return ((vectors[:half] - vectors[half:]) / (2 * steps[:, None])).T
