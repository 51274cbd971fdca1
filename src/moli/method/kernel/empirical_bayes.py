"""Empirical Bayes for one output: the kernels' hyperparameters and the noise variance that
maximize the marginal likelihood, and the posterior of the impulse response they give.

With ``y = Phi g + e``, ``g ~ N(0, K)`` and ``e ~ N(0, sigma^2 I)``, the marginal likelihood
of ``y`` needs ``Sigma = sigma^2 I + Phi K Phi^T`` (``N x N``). From ``R`` of ``[Phi | y]``
(``R1``, ``r2``, ``r3``, :mod:`.fir_rows`) and a square root ``K = L L^T``, the QR of the
``2d x (d + 1)`` matrix ``[[R1 L, r2], [sigma I, 0]]`` gives ``[[Q1, q2], [0, q3]]`` with
(Chen and Ljung 2013)

- ``y^T Sigma^-1 y = (r3^2 + q3^2) / sigma^2``,
- ``log det Sigma = (N - d) log sigma^2 + 2 sum log |diag Q1|``,
- the posterior mean ``L Q1^-1 q2`` and covariance ``sigma^2 L Q1^-1 Q1^-T L^T``,

so one evaluation costs one QR of ``d + 1`` columns, never an ``N x N`` matrix.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ...numerics.triangular import tall_factor
from .fir_rows import FirFactor
from .kernels import ARTANH_BOUND, LOGIT_BOUND, hyperparameter_count, kernel_root

__all__ = ["OutputFit", "fit_output", "neg_log_likelihood", "posterior"]

# Decays per sample and shares of the output's variance left to the noise tried before the search
# (every pair of them, each at its best overall scale): the best of them starts it.
START_DECAYS = (0.3, 0.6, 0.8, 0.9, 0.95, 0.98)
START_NOISE_SHARES = (0.5, 0.2, 0.05, 0.01)
# log c and log sigma^2 are searched within this many nepers of their start.
LOG_RANGE = 25.0
# The search ends when a step lowers -2 log p(y) by less than this share of it: 1e-12 of values
# of order N is far below the 1 that separates hyperparameters worth telling apart.
FTOL = 1e-12
# Quasi-Newton iterations at most (the fits measured converge in 10-40).
MAX_ITERATIONS = 100


@dataclass(frozen=True)
class OutputFit:
    """One output's estimate: the coefficients (input-major), a covariance factor ``F``
    (``cov = F F^T``), the noise variance and each input's kernel coordinates."""

    coefficients: np.ndarray
    cov_factor: np.ndarray
    noise_variance: float
    coordinates: tuple[np.ndarray, ...]
    neg_log_likelihood: float


def _root(kind: str, lags: np.ndarray, coordinates: list[np.ndarray]) -> np.ndarray:
    """The block-diagonal square root of the prior of every input's coefficients."""
    roots = [kernel_root(kind, lags, z) for z in coordinates]
    size = lags.size
    L = np.zeros((size * len(roots), size * len(roots)))
    for i, root in enumerate(roots):
        L[i * size:(i + 1) * size, i * size:(i + 1) * size] = root
    return L


def _posterior_factor(factor: FirFactor, j: int, L: np.ndarray, sigma: float) -> np.ndarray:
    d = L.shape[0]
    stacked = np.zeros((2 * d, d + 1))
    stacked[:d, :d] = factor.R1 @ L
    stacked[:d, d] = factor.r2[:, j]
    stacked[d:, :d] = sigma * np.eye(d)
    return tall_factor(stacked)[: d + 1]


def neg_log_likelihood(factor: FirFactor, j: int, L: np.ndarray, sigma2: float) -> float:
    """``-2 log p(y_j)`` up to a constant, for the prior square root ``L`` and noise variance ``sigma2``."""
    quadratic, log_det = _likelihood_terms(factor, j, L, sigma2)
    return quadratic + log_det


def _likelihood_terms(factor: FirFactor, j: int, L: np.ndarray, sigma2: float) -> tuple[float, float]:
    """``y^T Sigma^-1 y`` and ``log det Sigma`` (both inf where ``Sigma`` is singular)."""
    d = L.shape[0]
    Q = _posterior_factor(factor, j, L, np.sqrt(sigma2))
    diagonal = np.abs(np.diag(Q)[:d])
    if np.any(diagonal == 0) or not np.isfinite(Q).all():
        return np.inf, np.inf
    return (float((factor.r3[j] ** 2 + Q[d, d] ** 2) / sigma2),
            float((factor.rows - d) * np.log(sigma2) + 2.0 * np.sum(np.log(diagonal))))


def _split(kind: str, m: int, x: np.ndarray) -> tuple[list[np.ndarray], float]:
    size = hyperparameter_count(kind)
    return [x[i * size:(i + 1) * size] for i in range(m)], float(np.exp(x[-1]))


def fit_output(factor: FirFactor, j: int, kind: str, lags: np.ndarray, scales: np.ndarray) -> OutputFit:
    """Output ``j``'s marginal-likelihood estimate with ``kind`` kernels (one per input), or its
    least squares with ``kind = "none"``.

    Parameters
    ----------
    factor : FirFactor
    j : int
    kind : {"TC", "DC", "SS", "none"}
    lags : ndarray of int
    scales : ndarray, shape (m,)
        Each input's variance, for the start of the kernels' scales.

    Returns
    -------
    OutputFit
    """
    m, d = len(scales), factor.R1.shape[0]
    if kind == "none":
        coefficients = scipy.linalg.solve_triangular(factor.R1, factor.r2[:, j])
        sigma2 = factor.r3[j] ** 2 / (factor.rows - d)
        inverse = scipy.linalg.solve_triangular(factor.R1, np.eye(d))
        return OutputFit(coefficients, np.sqrt(sigma2) * inverse, sigma2, (), np.nan)
    # the output's variance about zero sets the starts: a share of it to the noise, each input's
    # gain scale so that the prior's output variance is the rest
    total = (np.sum(factor.r2[:, j] ** 2) + factor.r3[j] ** 2) / max(factor.rows, 1)
    total = total if total > 0 else 1.0
    size = hyperparameter_count(kind)
    best = None
    for noise, decay in itertools.product(START_NOISE_SHARES, START_DECAYS):
        start = []
        for scale in scales:
            z = np.zeros(size)
            z[0] = np.log((1.0 - noise) * total * (1.0 - decay) / (m * max(scale, 1e-300)))
            z[1] = np.log(decay / (1.0 - decay))
            start.append(z)
        x, value = _scaled_start(np.concatenate([*start, [np.log(noise * total)]]), factor, j, kind, lags)
        if best is None or value < best[1]:
            best = (x, value)
    x0 = best[0]
    bounds = []
    for i in range(m):
        bounds += [(x0[i * size] - LOG_RANGE, x0[i * size] + LOG_RANGE), LOGIT_BOUND] + \
                  ([ARTANH_BOUND] if kind == "DC" else [])
    bounds.append((x0[-1] - LOG_RANGE, x0[-1] + LOG_RANGE))
    from scipy import optimize  # 0.1 s to import: only when a kernel's hyperparameters are searched

    low, high = np.array(bounds).T
    # the search is unbounded and the coordinates clipped inside the objective: L-BFGS-B's
    # projected first step stalled at the start on records where the likelihood falls steeply
    found = optimize.minimize(lambda x: _objective(np.clip(x, low, high), factor, j, kind, lags, m), x0,
                                    method="L-BFGS-B", options={"ftol": FTOL, "maxiter": MAX_ITERATIONS})
    x = np.clip(found.x, low, high) if found.fun <= best[1] else x0
    coordinates, sigma2 = _split(kind, m, x)
    L = _root(kind, lags, coordinates)
    coefficients, cov_factor = posterior(factor, j, L, sigma2)
    return OutputFit(coefficients, cov_factor, sigma2, tuple(coordinates), float(min(found.fun, best[1])))


def posterior(factor: FirFactor, j: int, L: np.ndarray, sigma2: float) -> tuple[np.ndarray, np.ndarray]:
    """Output ``j``'s posterior mean and covariance factor ``F`` (``cov = F F^T``) for the prior
    square root ``L`` and noise variance ``sigma2``."""
    d = L.shape[0]
    Q = _posterior_factor(factor, j, L, np.sqrt(sigma2))
    # posterior mean L Q1^-1 q2 and covariance factor sigma L Q1^-1 (Q1 is upper triangular)
    Q1 = Q[:d, :d]
    coefficients = L @ scipy.linalg.solve_triangular(Q1, Q[:d, d])
    return coefficients, np.sqrt(sigma2) * scipy.linalg.solve_triangular(Q1.T, L.T, lower=True).T


def _scaled_start(x: np.ndarray, factor: FirFactor, j: int, kind: str, lags: np.ndarray) -> tuple[np.ndarray, float]:
    """``x`` with every scale and the noise variance multiplied by the factor that fits the output
    best, and its ``-2 log p(y_j)``: that multiplies ``Sigma`` by ``s``, so ``-2 log p`` is
    ``q / s + N log s`` plus ``log det Sigma``, least at ``s = q / N`` (``q = y^T Sigma^-1 y``). Without
    it the starts are ranked by how well their scale was guessed, and a record whose noise is a
    small share of the output started in the basin where the noise explains everything."""
    size = hyperparameter_count(kind)
    coordinates, sigma2 = _split(kind, (len(x) - 1) // size, x)
    with np.errstate(all="ignore"):
        quadratic, log_det = _likelihood_terms(factor, j, _root(kind, lags, coordinates), sigma2)
    if not (np.isfinite(quadratic) and np.isfinite(log_det) and quadratic > 0):
        return x, np.inf
    scaled = x.copy()
    scaled[0::size] += np.log(quadratic / factor.rows)      # each log c, and log sigma^2 last
    return scaled, factor.rows * (1.0 + np.log(quadratic / factor.rows)) + log_det


def _objective(x: np.ndarray, factor: FirFactor, j: int, kind: str, lags: np.ndarray, m: int) -> float:
    coordinates, sigma2 = _split(kind, m, x)
    with np.errstate(all="ignore"):
        return neg_log_likelihood(factor, j, _root(kind, lags, coordinates), sigma2)
