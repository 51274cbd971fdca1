"""Kernel priors of an impulse response: the covariance of ``g(t_1), ..., g(t_n)`` before the data.

Each kernel says that an impulse response decays exponentially and (for DC and SS) how
smooth it is (Pillonetto and De Nicolao 2010; Chen, Ohlsson and Ljung 2012):

- TC (tuned-correlated): ``K(s, t) = c lambda^max(s, t)``;
- DC (diagonal-correlated): ``K(s, t) = c lambda^((s + t) / 2) rho^|s - t|``;
- SS (stable spline): ``K(s, t) = c (lambda^(s + t + max(s, t)) / 2 - lambda^(3 max(s, t)) / 6)``,

with ``c > 0`` the scale, ``0 < lambda < 1`` the decay per sample and ``|rho| < 1`` the
correlation of neighbouring coefficients. Hyperparameters are searched in unconstrained
coordinates: ``log c``, ``logit lambda`` and ``artanh rho``.
"""

from __future__ import annotations

import numpy as np

from ..options.choices import KERNELS

__all__ = ["KERNELS", "hyperparameter_count", "named_hyperparameters", "kernel_matrix", "square_root",
           "kernel_root", "decay_of"]

# Unconstrained coordinates are kept within these bounds: lambda in (4.5e-5, 1 - 8e-7),
# rho in (-0.9999, 0.9999); beyond them the kernels are numerically the limit cases.
LOGIT_BOUND = (-10.0, 14.0)
ARTANH_BOUND = (-5.0, 5.0)


def hyperparameter_count(kind: str) -> int:
    """Number of hyperparameters of one kernel (the scale included)."""
    return {"TC": 2, "DC": 3, "SS": 2, "none": 0}[kind]


def named_hyperparameters(kind: str, z: np.ndarray) -> dict[str, float]:
    """The kernel's hyperparameters from their unconstrained coordinates ``z``.

    >>> named_hyperparameters("DC", np.array([0.0, 0.0, 0.0]))
    {'c': 1.0, 'lambda': 0.5, 'rho': 0.0}
    """
    if kind == "none":
        return {}
    named = {"c": float(np.exp(z[0])), "lambda": float(1.0 / (1.0 + np.exp(-z[1])))}
    if kind == "DC":
        named["rho"] = float(np.tanh(z[2]))
    return named


def kernel_matrix(kind: str, lags: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The prior covariance of the coefficients at ``lags`` (sample lags, at least 0).

    >>> np.round(kernel_matrix("TC", np.array([1, 2]), np.array([0.0, 0.0])), 3)
    array([[0.5 , 0.25],
           [0.25, 0.25]])
    """
    h = named_hyperparameters(kind, z)
    s, t = np.meshgrid(lags, lags, indexing="ij")
    top = np.maximum(s, t).astype(float)
    lam = h["lambda"]
    if kind == "TC":
        return h["c"] * lam ** top
    if kind == "DC":
        return h["c"] * lam ** ((s + t) / 2.0) * h["rho"] ** np.abs(s - t)
    return h["c"] * (lam ** (s + t + top) / 2.0 - lam ** (3.0 * top) / 6.0)


def square_root(K: np.ndarray) -> np.ndarray:
    """``L`` with ``L L^T = K`` for a symmetric positive semi-definite ``K`` (eigenvalues below
    round-off count as zero: a kernel of fast decay is numerically singular, and a Cholesky
    factor would not exist)."""
    values, vectors = np.linalg.eigh(K)
    return vectors * np.sqrt(np.clip(values, 0.0, None))


def kernel_root(kind: str, lags: np.ndarray, z: np.ndarray) -> np.ndarray:
    """A square root ``L`` (``L L^T = K``) of :func:`kernel_matrix`, in closed form where the kernel has one.

    The marginal likelihood needs some square root of the prior, not a particular one, and
    the search evaluates it hundreds of times per output: an eigendecomposition each time was
    most of a fit's cost. Closed forms:

    - TC at increasing lags ``l_0 < l_1 < ...``: ``g_k = sum_{i >= k} w_i`` with independent
      ``w_i`` of variance ``c (lambda^l_i - lambda^l_{i+1})`` (the last ``c lambda^l_last``) has
      covariance ``c lambda^max(l_s, l_t)``, so ``L[k, i] = sqrt(var w_i)`` for ``i >= k``;
    - DC at consecutive lags: ``diag(sqrt(c) lambda^(l/2))`` times the Cholesky factor of the
      AR(1) correlation ``rho^|s - t|`` (``x_0 = e_0``, ``x_k = rho x_{k-1} + sqrt(1 - rho^2) e_k``).

    Other kernels and lags take :func:`square_root` of the matrix.

    >>> lags, z = np.arange(1, 6), np.array([0.3, 1.2, -0.4])
    >>> L = kernel_root("DC", lags, z)
    >>> bool(np.allclose(L @ L.T, kernel_matrix("DC", lags, z)))
    True
    """
    lags = np.asarray(lags)
    h = named_hyperparameters(kind, z)
    increasing = lags.size > 0 and bool(np.all(np.diff(lags) > 0))
    if kind == "TC" and increasing:
        powers = h["lambda"] ** lags.astype(float)
        variances = h["c"] * (powers - np.append(powers[1:], 0.0))
        return np.triu(np.broadcast_to(np.sqrt(np.clip(variances, 0.0, None)), (lags.size, lags.size)))
    if kind == "DC" and increasing and bool(np.all(np.diff(lags) == 1)):
        rho, d = h["rho"], lags.size
        k = np.arange(d)
        steps = np.subtract.outer(k, k)
        with np.errstate(divide="ignore", invalid="ignore"):
            correlation = np.where(steps >= 0, rho ** np.maximum(steps, 0), 0.0)
        correlation[:, 1:] *= np.sqrt(1.0 - rho * rho)
        return (np.sqrt(h["c"]) * h["lambda"] ** (lags.astype(float) / 2.0))[:, None] * correlation
    return square_root(kernel_matrix(kind, lags, z))


def decay_of(kind: str, z: np.ndarray, lag: int) -> float:
    """The prior standard deviation at ``lag`` relative to lag 1: how much of the response the
    kernel still expects there (``lambda^((lag - 1) / 2)`` for TC and DC, ``lambda^(3 (lag - 1) / 2)``
    for SS)."""
    lam = named_hyperparameters(kind, z)["lambda"]
    return float(lam ** ((3.0 if kind == "SS" else 1.0) * (lag - 1) / 2.0))
