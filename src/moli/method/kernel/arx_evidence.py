"""Empirical Bayes for one output of an ARX model: one kernel shared by its output polynomials,
one by its input polynomials, and the noise variance, by the marginal likelihood.

The regression's channels are scaled to unit variance first (:func:`.arx.regularized_arx`), so
that one scale ``c`` fits every polynomial of a kind: two kernels and a noise variance are five
hyperparameters (TC) whatever the number of channels, where a kernel per polynomial would be
``2 (p + m) + 1``, each a numerical derivative of the likelihood more per step of the search.
The likelihood and the posterior are :mod:`.empirical_bayes`'s (one QR per evaluation).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from .empirical_bayes import (FTOL, LOG_RANGE, MAX_ITERATIONS, START_DECAYS, OutputFit, fit_output,
                              neg_log_likelihood, posterior)
from .fir_rows import FirFactor
from .kernels import ARTANH_BOUND, LOGIT_BOUND, hyperparameter_count, kernel_root

__all__ = ["fit_arx_output"]


def _root(kind: str, lags: np.ndarray, x: np.ndarray, blocks: tuple[int, int]) -> np.ndarray:
    """The block-diagonal prior square root: ``blocks[0]`` output polynomials sharing the first
    kernel of ``x``, then ``blocks[1]`` input polynomials sharing the second."""
    size = hyperparameter_count(kind)
    roots = [kernel_root(kind, lags, x[i * size:(i + 1) * size]) for i in range(2)]
    return scipy.linalg.block_diag(*([roots[0]] * blocks[0] + [roots[1]] * blocks[1]))


def _objective(x: np.ndarray, factor: FirFactor, j: int, kind: str, lags: np.ndarray, blocks: tuple[int, int]) -> float:
    with np.errstate(all="ignore"):
        return neg_log_likelihood(factor, j, _root(kind, lags, x, blocks), float(np.exp(x[-1])))


def fit_arx_output(factor: FirFactor, j: int, kind: str, lags: np.ndarray, blocks: tuple[int, int]) -> OutputFit:
    """Output ``j``'s marginal-likelihood estimate of a scaled ARX regression (or its least squares
    with ``kind = "none"``).

    Parameters
    ----------
    factor : FirFactor
        Of the regression on unit-variance channels, ``blocks[0] + blocks[1]`` blocks of ``len(lags)`` columns.
    j : int
    kind : {"TC", "DC", "SS", "none"}
    lags : ndarray of int
        The lags the kernels are evaluated at (each block's).
    blocks : (int, int)
        Output and input polynomials (p and m).

    Returns
    -------
    OutputFit
        ``coordinates``: the output polynomials' kernel, then the input polynomials'.
    """
    if kind == "none":
        return fit_output(factor, j, kind, lags, np.ones(sum(blocks)))
    # noise at half the output's variance, each kind's polynomials a quarter of it
    total = (np.sum(factor.r2[:, j] ** 2) + factor.r3[j] ** 2) / max(factor.rows, 1)
    total = total if total > 0 else 1.0
    size = hyperparameter_count(kind)
    best = None
    for decay in START_DECAYS:
        z = np.zeros(size)
        z[1] = np.log(decay / (1.0 - decay))
        starts = []
        for count in blocks:
            z[0] = np.log(0.25 * total * (1.0 - decay) / max(count, 1))
            starts.append(z.copy())
        x = np.concatenate([*starts, [np.log(0.5 * total)]])
        value = _objective(x, factor, j, kind, lags, blocks)
        if best is None or value < best[1]:
            best = (x, value)
    x0 = best[0]
    bounds = []
    for i in range(2):
        bounds += [(x0[i * size] - LOG_RANGE, x0[i * size] + LOG_RANGE), LOGIT_BOUND] + \
                  ([ARTANH_BOUND] if kind == "DC" else [])
    bounds.append((x0[-1] - LOG_RANGE, x0[-1] + LOG_RANGE))
    from scipy import optimize  # 0.1 s to import: only when a kernel's hyperparameters are searched

    low, high = np.array(bounds).T
    # unbounded search, coordinates clipped inside the objective, as empirical_bayes.fit_output's
    found = optimize.minimize(lambda x: _objective(np.clip(x, low, high), factor, j, kind, lags, blocks), x0,
                              method="L-BFGS-B", options={"ftol": FTOL, "maxiter": MAX_ITERATIONS})
    x = np.clip(found.x, low, high) if found.fun <= best[1] else x0
    sigma2 = float(np.exp(x[-1]))
    coefficients, cov_factor = posterior(factor, j, _root(kind, lags, x, blocks), sigma2)
    return OutputFit(coefficients, cov_factor, sigma2, (x[:size], x[size:2 * size]), float(min(found.fun, best[1])))
