"""Input-to-output dead times from data: where the input coefficients of an ARX model start.

For each output, a multi-input ARX model with an intercept is fitted by least squares,

    y_i[k] = c + sum_{l=1..na} a_l y_i[k-l] + sum_j sum_{t=0..nb-1} b_{ij,t} u_j[k-t] + e[k],

and the dead time of input ``j`` on output ``i`` is read from ``b_{ij,t}``: the first
lag ``t`` that is not shown to be dead, minus the one sample every strictly proper
sampled system takes (docs/diagnostics.md §3). ``B(q)/A(q)`` with ``A`` monic has the
same leading zeros as the impulse response, so the lag is the impulse response's.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.special

from ..data.iodata import IOData, require_one_segment
from ..errors import DataError, DataQualityWarning
from ..numerics.blas_threads import limited_blas

__all__ = ["estimate_delays", "first_response_lags", "DEFAULT_MAX_DELAY"]

DEFAULT_MAX_DELAY = 20
# A coefficient below this fraction of the largest input coefficient of its pair is
# not a response even when its t-ratio is large: on noise-free data every t-ratio is a
# ratio of round-off errors.
RELATIVE_FLOOR = 1e-3
# A lag before a pair's response must be shown below this share of the pair's largest
# coefficient (one-sided, at ``level``) to count as dead time. At 10 dB the dead lags of
# random systems come out below 0.4 of the peak (0.05 to 0.37 measured), while the lag
# before a weak response that starts small lies above 0.7 (moli.example_data, y2 from
# u1: 0.73); a half separates them.
NEGLIGIBLE = 0.5
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


def first_response_lags(
    data: IOData, max_delay: int | None = None, order: int = 10, level: float = 0.01
) -> tuple[np.ndarray, int]:
    """First lag of every pair's response, (p, m) ints; -1 where no response is found.

    Also returns the ``max_delay`` used. Arguments and rule as :func:`estimate_delays`.
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
    # without response up to max_delay + 1 shows one at a single lag
    critical = -scipy.special.ndtri(level / (2 * scanned))  # normal upper quantile
    below = -scipy.special.ndtri(level)                    # one-sided: "surely below"
    first = np.full((p, m), -1)
    for i in range(p):
        y_lags = np.stack([data.y[start - l : N - l, i] for l in range(1, order + 1)], axis=1)
        regressors = np.column_stack([np.ones(rows), y_lags, inputs])
        b, se, wald = _coefficients(regressors, data.y[start:, i], 1 + order, nb)
        b = b[1 + order :].reshape(m, nb)
        se = se[1 + order :].reshape(m, nb)
        peak = np.max(np.abs(b), axis=1, keepdims=True)
        significant = (np.abs(b) > critical * se) & (np.abs(b) > RELATIVE_FLOOR * peak)
        # before its response a pair's coefficients are zero: a lag counts as dead
        # when it is not significant and surely below a share of the pair's peak;
        # a lag the data cannot place either way is taken as part of the response
        dead = ~significant & (np.abs(b) + below * se <= NEGLIGIBLE * peak)
        dead |= np.abs(b) <= RELATIVE_FLOOR * peak          # round-off of noise-free data
        responds = significant.any(axis=1) | (wald[0] > scipy.special.chdtri(wald[1], level))
        live = ~dead[:, :scanned]
        starts = np.where(live.any(axis=1), np.argmax(live, axis=1), -1)
        first[i] = np.where(responds, starts, -1)
    return first, max_delay


def _coefficients(
    X: np.ndarray, y: np.ndarray, skip: int, block: int
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """Least-squares coefficients, their standard errors, and each input's Wald statistic.

    The columns after the first ``skip`` come in blocks of ``block`` (one per input);
    the Wald statistic of a block tests that all its coefficients are zero, returned
    with its degrees of freedom (the block's rank). Directions below round-off are
    dropped (minimum-norm solution): on noise-free data an ARX model of too high an
    order is exactly rank deficient. The statistics are those of the scaled columns,
    which scaling does not change.
    """
    norms = np.linalg.norm(X, axis=0)
    norms[norms == 0] = 1.0
    U, s, Vt = np.linalg.svd(X / norms, full_matrices=False)
    keep = s > np.finfo(float).eps * max(X.shape) * s[0]
    U, s, Vt = U[:, keep], s[keep], Vt[keep]
    theta = Vt.T @ ((U.T @ y) / s)
    residual = y - (X / norms) @ theta
    sigma = np.sqrt(residual @ residual / max(X.shape[0] - s.size, 1))
    spread = Vt / s[:, None]                            # theta's covariance: sigma^2 spread' spread
    se = sigma * np.sqrt(np.sum(spread ** 2, axis=0))
    inputs = (X.shape[1] - skip) // block
    wald, dof = np.zeros(inputs), np.zeros(inputs, dtype=int)
    for j in range(inputs):
        columns = slice(skip + j * block, skip + (j + 1) * block)
        # theta_b lies in the row space of spread_b, so the statistic is the squared
        # norm of theta_b's coordinates there
        coords, _, rank, _ = np.linalg.lstsq(spread[:, columns].T, theta[columns], rcond=None)
        wald[j], dof[j] = coords @ coords / max(sigma, np.finfo(float).tiny) ** 2, rank
    return theta / norms, se / norms, (wald, dof)


def estimate_delays(
    data: IOData, max_delay: int | None = None, *, order: int = 10, level: float = 0.01
) -> np.ma.MaskedArray:
    """Dead time of every input-output pair, in samples, from an ARX estimate.

    For each output ``i`` a multi-input ARX model (own past outputs to lag
    ``order``, every input at lags 0 to ``max_delay + order``, an intercept) is fitted
    by least squares. A lag before a pair's response is *dead* when its coefficient
    ``b_t`` is not significant (``|b_t| <= z se(b_t)``, ``z`` the two-sided normal
    quantile at ``level`` divided by the ``max_delay + 2`` lags scanned) and is shown
    small: ``|b_t| + z1 se(b_t)`` at most half the pair's largest coefficient (``z1``
    the one-sided quantile at ``level``). The response starts at the first lag that is
    not dead, so a lag the data cannot place either way counts as response: a delay
    too long cannot be undone by a model, one too short costs it states. The dead time
    is that lag minus one: a sampled system without dead time responds one sample late
    (zero if the response starts at lag 0, a direct feedthrough).

    A pair responds when one of its coefficients is significant or when all of them
    together are (a Wald test at ``level``): a response spread over many small
    coefficients is found although none stands out.

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
        Chance, on white-noise-like data, that a pair without response is found to
        respond, and that a dead lag is not recognised as dead.

    Returns
    -------
    numpy.ma.MaskedArray of int, shape (p, m)
        Entry ``[i, j]``: samples of dead time from input ``j`` to output ``i`` (the
        ARX "nk" minus one). Masked where no response was found: the pair shows none,
        or its dead time is longer than ``max_delay``.

    Warns
    -----
    DataQualityWarning
        Naming the pairs in which no response was found.

    Examples
    --------
    >>> import numpy as np, moli
    >>> plant = moli.StateSpaceModel([[0.8]], [[1.0]], [[1.0]]).with_input_delays([3])
    >>> u = np.random.default_rng(0).standard_normal(500)
    >>> moli.estimate_delays(moli.IOData(plant.simulate(u), u), max_delay=8)
    masked_array(data=[[3]],
                 mask=[[False]],
           fill_value=999999)
    """
    with limited_blas():
        first, used = first_response_lags(data, max_delay, order, level)
        none = first < 0
        if none.any():
            pairs = ", ".join(f"{data.input_names[j]} -> {data.output_names[i]}"
                              for i, j in zip(*np.nonzero(none)))
            warnings.warn(
                f"no response found from {pairs} within {used} samples of dead time: those "
                "entries are masked (the input does not move the output measurably, or acts later "
                "than max_delay)", DataQualityWarning, stacklevel=2)
        return np.ma.masked_array(np.maximum(first - 1, 0), mask=none)
