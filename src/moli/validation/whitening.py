"""Autoregressive whitening: the innovations of a multichannel AR model chosen by AIC.

Used to pre-estimate the innovations behind a noise model (docs/noise_model.md §2) and
to prewhiten inputs before testing residual-input independence (§4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DataError
from ..numerics.triangular import tall_factor

__all__ = ["ARFit", "fit_ar"]


@dataclass(frozen=True)
class ARFit:
    """A multichannel AR model ``x[t] = sum_{i=1}^{order} Γ_i x[t-i] + ε[t]`` fitted by least squares.

    Attributes
    ----------
    order : int
        Chosen order (0: the signal is taken as white).
    start : int
        First sample of ``residuals``: every order was compared on the samples
        ``start, ..., N-1`` (``start`` is the largest order tried).
    residuals : ndarray, shape (N - start, c)
        The innovations ``ε[start:]``.
    """

    order: int
    start: int
    residuals: np.ndarray


def fit_ar(x: np.ndarray, max_order: int) -> ARFit:
    """Fit AR models of orders 0 to ``max_order`` to ``x`` and keep the one of least AIC.

    One QR factor of ``[x[t-1], ..., x[t-max_order] | x[t]]`` serves every order: the
    residual sums of squares of the nested fits are the trailing blocks of its
    triangular factor. AIC is ``rows * log det(Σ_order) + 2 order c^2``.

    Parameters
    ----------
    x : ndarray, shape (N, c)
        Needs ``N - max_order >= (max_order + 1) c``.
    max_order : int
        Largest order tried, >= 0.

    Returns
    -------
    ARFit

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> e = np.random.default_rng(0).standard_normal(2000)
    >>> fit = fit_ar(lfilter([1.0], [1.0, -0.8], e)[:, None], 10)
    >>> fit.order >= 1, bool(np.std(fit.residuals - e[10:, None]) < 0.05)
    (True, True)
    """
    N, c = x.shape
    h = max_order
    if isinstance(h, bool) or not isinstance(h, (int, np.integer)) or h < 0 or N - h < (h + 1) * c:
        raise DataError(f"max_order must be an integer from 0 to the largest with N - max_order >= "
                        f"(max_order + 1) c (N = {N}, c = {c}), got {max_order!r}")
    # unit-scaled channels keep the triangular factor well balanced; AR fits with full
    # coefficient matrices are equivariant to channel scaling, so nothing else changes
    scale = np.std(x, axis=0)
    scale[scale == 0.0] = 1.0
    z = x / scale
    rows = N - h
    # lags 1..h then the target, so that each order's regressors are a leading block
    columns = np.concatenate([z[h - i : N - i] for i in range(1, h + 1)] + [z[h:]], axis=1)
    R = tall_factor(columns)
    tail = R[:, h * c :]
    best, best_aic = 0, np.inf
    for order in range(h + 1):
        block = tail[order * c : (h + 1) * c]
        sign, logdet = np.linalg.slogdet(block.T @ block / rows)
        if sign <= 0:  # an exact fit: no higher order can do better
            best = order
            break
        aic = rows * logdet + 2 * order * c * c
        if aic < best_aic:
            best, best_aic = order, aic
    residuals = z[h:]
    if best:
        theta, *_ = np.linalg.lstsq(R[: best * c, : best * c], tail[: best * c], rcond=None)
        residuals = residuals - columns[:, : best * c] @ theta
    return ARFit(order=best, start=h, residuals=residuals * scale)
