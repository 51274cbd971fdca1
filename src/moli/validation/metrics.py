"""Fit measures. All compare measured outputs with *simulated* ones.

* ``vaf``: variance accounted for, per output, percent, clipped at 0:
  ``max(1 - var(y - yhat) / var(y), 0) * 100``.
* ``cost_j``: the paper's criterion ``J = mean_i min(var(y_i - yhat_i) / var(y_i), 1)``
  (0 is perfect, 1 is no better than the mean).
* ``nrmse_fit``: ``100 (1 - ||y - yhat|| / ||y - mean(y)||)`` per output (can be negative).
"""

from __future__ import annotations

import numpy as np

from ..data.arguments import real_array
from ..errors import DataError

__all__ = ["error_ratio", "vaf", "cost_j", "nrmse_fit"]


def _pair(y: object, yhat: object) -> tuple[np.ndarray, np.ndarray]:
    # a simulation may diverge (inf scores as no fit); the measurement must be finite
    a = np.array(real_array("y", y), ndmin=1)
    b = np.array(real_array("yhat", yhat, finite=False), ndmin=1)
    if a.ndim == 1:
        a = a[:, None]
    if b.ndim == 1:
        b = b[:, None]
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] == 0:
        raise DataError(f"y and yhat must have the same shape (N, p) with p >= 1, got {a.shape} and {b.shape}")
    if a.shape[0] < 2:
        raise DataError("need at least two samples to compare signals")
    return a, b


def error_ratio(y: object, yhat: object) -> np.ndarray:
    """``var(y - yhat) / var(y)`` per output; inf where the simulation is not finite."""
    a, b = _pair(y, yhat)
    with np.errstate(all="ignore"):
        ratio = np.var(a - b, axis=0) / np.var(a, axis=0)
    return np.where(np.isfinite(ratio), ratio, np.inf)


def vaf(y: object, yhat: object) -> np.ndarray:
    """Variance accounted for, per output, in percent, clipped at 0.

    Parameters
    ----------
    y, yhat : array_like, shape (N, p) or (N,)
        Measured and simulated outputs.

    Returns
    -------
    ndarray, shape (p,)

    Examples
    --------
    >>> vaf([1.0, 2.0, 3.0, 4.0], [1.0, 2.0, 3.0, 4.0])
    array([100.])
    """
    return np.maximum(1.0 - error_ratio(y, yhat), 0.0) * 100.0


def cost_j(y: object, yhat: object) -> float:
    """The paper's criterion ``J``: mean over outputs of ``min(var(e)/var(y), 1)``.

    Examples
    --------
    >>> cost_j([[1.0], [2.0], [3.0]], [[1.0], [2.0], [3.0]])
    0.0
    """
    return float(np.mean(np.minimum(error_ratio(y, yhat), 1.0)))


def nrmse_fit(y: object, yhat: object) -> np.ndarray:
    """Normalized root-mean-square fit per output, percent (100 is perfect).

    Examples
    --------
    >>> nrmse_fit([0.0, 2.0], [0.0, 2.0])
    array([100.])
    """
    a, b = _pair(y, yhat)
    with np.errstate(all="ignore"):
        fit = 1.0 - np.linalg.norm(a - b, axis=0) / np.linalg.norm(a - a.mean(axis=0), axis=0)
    return np.where(np.isfinite(fit), fit, -np.inf) * 100.0
