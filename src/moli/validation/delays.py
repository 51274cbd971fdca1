"""Input-to-output dead times from data: the first significant coefficient of an ARX model.

For each output, a multi-input ARX model with an intercept is fitted by least squares,

    y_i[k] = c + sum_{l=1..na} a_l y_i[k-l] + sum_j sum_{t=0..nb-1} b_{ij,t} u_j[k-t] + e[k],

and the dead time of input ``j`` on output ``i`` is read from ``b_{ij,t}``: the first
lag ``t`` whose coefficient is significant, minus the one sample every strictly proper
sampled system takes (docs/diagnostics.md §3). ``B(q)/A(q)`` with ``A`` monic has the
same leading zeros as the impulse response, so the lag is the impulse response's.
"""

from __future__ import annotations

import numpy as np
import scipy.special

from ..data.iodata import IOData, require_one_segment
from ..errors import DataError

__all__ = ["estimate_delays", "first_significant_lags", "DEFAULT_MAX_DELAY"]

DEFAULT_MAX_DELAY = 20
# A coefficient below this fraction of the largest input coefficient of its pair is
# not a response even when its t-ratio is large: on noise-free data every t-ratio is a
# ratio of round-off errors.
RELATIVE_FLOOR = 1e-3
# Fewer rows than this many times the parameters leave the standard errors too rough.
ROWS_PER_PARAMETER = 2


def _integer(name: str, value: object, low: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < low:
        raise DataError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def _parameters(max_delay: int, order: int, m: int) -> int:
    return 1 + order + m * (max_delay + 1 + order)


def _rows(N: int, max_delay: int, order: int) -> int:
    return N - (max_delay + order)


def first_significant_lags(
    data: IOData, max_delay: int | None = None, order: int = 10, level: float = 0.01
) -> tuple[np.ndarray, int]:
    """First significant lag of every pair, (p, m) ints, -1 where none up to ``max_delay + 1``.

    Also returns the ``max_delay`` used. Arguments as :func:`estimate_delays`.
    """
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    require_one_segment(data, "the delay estimate (lagged regressions)")
    order = _integer("order", order, 1)
    if isinstance(level, bool) or not isinstance(level, (int, float)) or not 0 < level < 1:
        raise DataError(f"level must be a number in (0, 1), got {level!r}")
    N, p, m = data.N, data.p, data.m

    def feasible(d: int) -> bool:
        return _rows(N, d, order) >= ROWS_PER_PARAMETER * _parameters(d, order, m)

    if max_delay is None:
        max_delay = next((d for d in range(DEFAULT_MAX_DELAY, -1, -1) if feasible(d)), 0)
    max_delay = _integer("max_delay", max_delay, 0)
    if not feasible(max_delay):
        raise DataError(
            f"{N} samples are too few for max_delay = {max_delay} and order = {order} "
            f"({_parameters(max_delay, order, m)} ARX parameters per output need "
            f"{ROWS_PER_PARAMETER} rows each): lower them or give a longer record"
        )
    nb = max_delay + 1 + order
    start = nb - 1                                     # the largest lag, nb - 1 >= order
    rows = N - start
    u_lags = np.stack([data.u[start - t : N - t] for t in range(nb)], axis=2)   # (rows, m, nb)
    inputs = u_lags.reshape(rows, m * nb)
    scanned = max_delay + 2                             # lags 0 .. max_delay + 1
    # Bonferroni over the lags scanned: ``level`` bounds the chance that a pair
    # without response up to max_delay + 1 shows one
    critical = -scipy.special.ndtri(level / (2 * scanned))  # normal upper quantile
    first = np.full((p, m), -1)
    for i in range(p):
        y_lags = np.stack([data.y[start - l : N - l, i] for l in range(1, order + 1)], axis=1)
        regressors = np.column_stack([np.ones(rows), y_lags, inputs])
        b, se = _coefficients(regressors, data.y[start:, i])
        b = b[1 + order :].reshape(m, nb)
        se = se[1 + order :].reshape(m, nb)
        peak = np.max(np.abs(b), axis=1, keepdims=True)
        significant = (np.abs(b) > critical * se) & (np.abs(b) > RELATIVE_FLOOR * peak)
        significant = significant[:, :scanned]
        found = significant.any(axis=1)
        first[i, found] = np.argmax(significant[found], axis=1)
    return first, max_delay


def _coefficients(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares coefficients and their standard errors, by the SVD of the scaled columns.

    Directions below round-off are dropped (minimum-norm solution): on noise-free
    data an ARX model of too high an order is exactly rank deficient.
    """
    norms = np.linalg.norm(X, axis=0)
    norms[norms == 0] = 1.0
    U, s, Vt = np.linalg.svd(X / norms, full_matrices=False)
    keep = s > np.finfo(float).eps * max(X.shape) * s[0]
    U, s, Vt = U[:, keep], s[keep], Vt[keep]
    theta = Vt.T @ ((U.T @ y) / s)
    residual = y - (X / norms) @ theta
    sigma = np.sqrt(residual @ residual / max(X.shape[0] - s.size, 1))
    se = sigma * np.sqrt(np.sum((Vt / s[:, None]) ** 2, axis=0))
    return theta / norms, se / norms


def estimate_delays(
    data: IOData, max_delay: int | None = None, *, order: int = 10, level: float = 0.01
) -> np.ndarray:
    """Dead time of every input-output pair, in samples, from an ARX estimate.

    For each output ``i`` a multi-input ARX model (own past outputs to lag
    ``order``, every input at lags 0 to ``max_delay + order``, an intercept) is fitted
    by least squares. Input coefficient ``b_t`` counts as significant when
    ``|b_t| > z se(b_t)`` (``z`` the two-sided normal quantile at ``level`` divided
    by the ``max_delay + 2`` lags scanned) and ``|b_t|`` is at least 1e-3 of the
    pair's largest coefficient. The dead time is the first significant lag minus
    one: a sampled system without dead time responds one sample late (zero if the
    first significant lag is 0, a direct feedthrough).

    Parameters
    ----------
    data : IOData
        Open-loop record (an offset is fitted, means need not be removed).
    max_delay : int, optional
        Largest dead time looked for; default 20, or less when the record is too
        short for 20 (each output's regression needs twice as many rows as it has
        parameters).
    order : int, default 10
        Number of past outputs in each regression (at least the order of the
        system's dynamics for exact results; more only costs variance).
    level : float, default 0.01
        Chance that a pair whose response starts after ``max_delay + 1`` samples is
        given a shorter dead time, on white-noise-like data.

    Returns
    -------
    ndarray of int, shape (p, m)
        Entry ``[i, j]``: samples of dead time from input ``j`` to output ``i``
        (the ARX "nk" minus one). A pair with no significant coefficient up to lag
        ``max_delay + 1`` gets ``max_delay``: its dead time is at least that.

    Examples
    --------
    >>> import numpy as np, moli
    >>> plant = moli.StateSpaceModel([[0.8]], [[1.0]], [[1.0]]).with_input_delays([3])
    >>> u = np.random.default_rng(0).standard_normal(500)
    >>> moli.estimate_delays(moli.IOData(plant.simulate(u), u), max_delay=8)
    array([[3]])
    """
    first, used = first_significant_lags(data, max_delay, order, level)
    return np.where(first < 0, used, np.maximum(first - 1, 0))
