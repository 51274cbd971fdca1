"""A MIMO ARX model with a kernel prior on each of its polynomials, for short records.

Output ``j`` is

``y_j(t) = sum_i sum_k a_ji(k) y_i(t - k) + sum_l sum_k b_jl(k) u_l(t - k) + e_j(t)``,

``k = 1..n`` (the inputs' ``k = 0..n-1`` where output ``j`` has a direct feedthrough). Each polynomial
``a_ji`` and ``b_jl`` gets a kernel prior (:mod:`.kernels`), independent of the others; on
channels scaled to unit variance, output ``j``'s ``a`` polynomials share one kernel and its
``b`` polynomials another, which with its noise variance maximize its marginal likelihood
(:mod:`.arx_evidence`, one QR per evaluation), and the posterior gives the
coefficients and their covariance (docs/regularization.md). A slow mode that an impulse
response needs hundreds of coefficients for is a few coefficients of ``a_jj``.

With a feedthrough the inputs' prior is put on lags ``0..n-1`` as if they were ``1..n``:
a shift of the lags only rescales these kernels' ``c`` (by ``lambda`` for TC and DC,
``lambda^3`` for SS), so the prior is the same family. Both regressions have the same rows
(from lag ``n`` of each segment), so their marginal likelihoods are of the same data: with
``feedthrough="auto"`` each output takes the one its data find more likely.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...data.arguments import flag, integer
from ...data.iodata import IOData
from ...errors import DataError, OptionError
from ..least_squares.estimation import COND_LIMIT
from .arx_rows import arx_factor, arx_rows
from .fir_rows import FirFactor
from .arx_evidence import fit_arx_output
from .impulse import MAX_COEFFICIENTS, ROWS_PER_COEFFICIENT, centred_record, check_kernel_arguments
from .kernels import named_hyperparameters

__all__ = ["RegularizedArx", "regularized_arx", "arx_state_space", "default_lags"]

# Lags per channel when none are given (arxRegul's generous fixed order), fewer where the
# record or the cost asks: at most MAX_COEFFICIENTS per output (each likelihood evaluation is a
# QR of twice as many rows by one more column) and at least ROWS_PER_COEFFICIENT regression
# rows per coefficient (the prior carries the rest), the impulse response's limits.
DEFAULT_LAGS = 30


@dataclass(frozen=True)
class RegularizedArx:
    """A regularized ARX model and its posterior.

    Attributes
    ----------
    outputs : ndarray, shape (n, p, p)
        ``outputs[k - 1, j, i] = a_ji(k)``: output ``j``'s coefficient of ``y_i(t - k)``.
    inputs : ndarray, shape (n + 1, p, m)
        ``inputs[k, j, l] = b_jl(k)``, lags 0..n: zero at lag 0 for an output without a
        feedthrough, zero at lag n for one with it.
    cov_factors : tuple of ndarray
        Output ``j``'s covariance factor over its ``(p + m) n`` coefficients, block by block
        (outputs' polynomials, then inputs'), ``cov = F_j F_j^T``.
    noise_variance : ndarray, shape (p,)
    kernel : str
    hyperparameters : tuple of tuple of dict
        ``hyperparameters[j]``: output ``j``'s kernel of the output polynomials, then of the input
        polynomials (``c`` for channels scaled to unit variance); empty for ``kernel="none"``.
    feedthrough : tuple of bool
        Whether each output has a direct feedthrough (its inputs' lags are ``0..n-1``).
    """

    outputs: np.ndarray
    inputs: np.ndarray
    cov_factors: tuple[np.ndarray, ...]
    noise_variance: np.ndarray
    kernel: str
    hyperparameters: tuple[tuple[dict[str, float], ...], ...]
    feedthrough: tuple[bool, ...]

    @property
    def lags(self) -> int:
        """Lags per channel."""
        return self.outputs.shape[0]

    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The simulator's ``A, B, C, D`` (:func:`arx_state_space`)."""
        return arx_state_space(self.outputs, self.inputs)

    def moved(self, j: int, direction: np.ndarray) -> "RegularizedArx":
        """This model with output ``j``'s coefficients moved by ``direction`` (block by block, as
        its covariance factor's columns)."""
        n, p = self.outputs.shape[:2]
        blocks = direction.reshape(-1, n)
        outputs, inputs = self.outputs.copy(), self.inputs.copy()
        outputs[:, j, :] += blocks[:p].T
        first = 0 if self.feedthrough[j] else 1
        inputs[first:first + n, j, :] += blocks[p:].T
        return RegularizedArx(outputs, inputs, self.cov_factors, self.noise_variance, self.kernel,
                              self.hyperparameters, self.feedthrough)


def arx_state_space(outputs: np.ndarray, inputs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The ARX simulator in block observer form, ``p n`` states.

    With ``A_k = outputs[k - 1]`` (lags 1..n), ``B_k = inputs[k]`` (lags 0..n) and ``D = B_0``:
    ``y(t) = x_1(t) + D u(t)`` and ``x_k(t + 1) = A_k y(t) + x_(k+1)(t) + B_k u(t)``.

    Examples
    --------
    >>> A, B, C, D = arx_state_space(np.array([[[0.5]]]), np.array([[[0.0]], [[2.0]]]))
    >>> A.tolist(), B.tolist(), C.tolist(), D.tolist()      # y(t) = 0.5 y(t-1) + 2 u(t-1)
    ([[0.5]], [[2.0]], [[1.0]], [[0.0]])
    """
    n, p = outputs.shape[:2]
    m = inputs.shape[2]
    D = inputs[0]
    A = np.zeros((p * n, p * n))
    A[:, :p] = outputs.reshape(n * p, p)
    A[: p * (n - 1), p:] = np.eye(p * (n - 1))
    B = (inputs[1:] + outputs @ D).reshape(n * p, m)
    C = np.zeros((p, p * n))
    C[:, :p] = np.eye(p)
    return A, B, C, D.copy()


def default_lags(record: IOData) -> int:
    """Lags per channel when none are given: :data:`DEFAULT_LAGS`, fewer where the coefficients
    per output would pass :data:`MAX_COEFFICIENTS` or the record give less than
    :data:`ROWS_PER_COEFFICIENT` rows for each (at least 1)."""
    channels = record.p + record.m
    lags = max(1, min(DEFAULT_LAGS, MAX_COEFFICIENTS // channels))
    while lags > 1 and arx_rows(record, lags) < ROWS_PER_COEFFICIENT * channels * lags:
        lags -= 1
    return lags


def regularized_arx(data: IOData, kernel: str = "TC", lags: int | None = None, *,
                    feedthrough: bool | str = "auto", center: bool = True) -> RegularizedArx:
    """A MIMO ARX model by regularized least squares, a kernel prior on each polynomial (empirical Bayes).

    Parameters
    ----------
    data : IOData
        The record; each segment gives its own rows (no lag reaches across a gap).
    kernel : {"TC", "DC", "SS", "none"}, default "TC"
        The prior of every polynomial; "none": plain least squares.
    lags : int, optional
        Lags per channel; default :func:`default_lags` (30, fewer on short records or many channels).
    feedthrough : {True, False, "auto"}, default "auto"
        The inputs act at lag 0 too (a direct feedthrough ``D``); "auto": per output, where
        its marginal likelihood is higher with it (``kernel="none"``: never).
    center : bool, default True
        Remove the record's means first (the model of deviations from the operating point).

    Returns
    -------
    RegularizedArx

    Raises
    ------
    OptionError
        An unknown kernel or feedthrough, or lags that are not a positive integer.
    DataError
        ``data`` is not an IOData; an input that never changes; lags beyond the longest segment;
        least squares (``kernel="none"``) with too few rows or an ill-conditioned regression.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> u, e, y = rng.standard_normal(300), 0.05 * rng.standard_normal(300), np.zeros(300)
    >>> for t in range(1, 300):       # an ARX system: the noise enters the recursion
    ...     y[t] = 0.8 * y[t - 1] + u[t - 1] + e[t]
    >>> fit = regularized_arx(moli.IOData(y, u), lags=10)
    >>> bool(abs(fit.outputs[0, 0, 0] - 0.8) < 0.05 and abs(fit.inputs[1, 0, 0] - 1.0) < 0.05)
    True
    """
    check_kernel_arguments(data, kernel, center)
    if lags is not None:
        lags = integer("lags", lags, error=OptionError, low=1)
    if not (isinstance(feedthrough, str) and feedthrough == "auto"):
        try:
            feedthrough = flag("feedthrough", feedthrough, error=OptionError)
        except OptionError:
            raise OptionError(f"feedthrough must be True, False or 'auto', got {feedthrough!r}") from None
    record = centred_record(data, center)
    longest = max(stop - start for start, stop in record.bounds)
    if lags is not None and lags >= longest:
        raise DataError(f"lags = {lags} reach beyond the longest segment ({longest} samples): give fewer lags")
    n = default_lags(record) if lags is None else lags
    p, m, d = record.p, record.m, (record.p + record.m) * n
    rows = arx_rows(record, n)
    if kernel == "none" and rows <= d:
        raise DataError(f"the record gives {rows} rows for {d} coefficients per output ({n} lags of {p} outputs "
                        f"and {m} inputs): least squares needs more rows than coefficients; use a kernel or fewer lags")
    # the regression on unit-variance channels (scaling R's columns keeps it triangular), so that one
    # kernel fits every polynomial of a kind; every block's prior on lags 1..n
    spread = np.concatenate([np.std(record.y, axis=0), np.std(record.u, axis=0)])
    spread[spread == 0] = 1.0                        # a constant output: nothing to scale
    regressors, outputs = np.repeat(1.0 / spread, n), 1.0 / spread[:p]
    automatic = isinstance(feedthrough, str)
    tried = [False, True] if automatic and kernel != "none" else [not automatic and bool(feedthrough)]
    candidates = []
    for direct in tried:
        factor = arx_factor(record, n, direct)
        if kernel == "none":
            _check_conditioning(factor, n)
        scaled = FirFactor(factor.R1 * regressors, factor.r2 * outputs, factor.r3 * outputs, factor.rows)
        candidates.append([fit_arx_output(scaled, j, kernel, np.arange(1, n + 1), (p, m)) for j in range(p)])
    # per output, the structure of the higher marginal likelihood (the first where there is one)
    chosen = [min(range(len(tried)), key=lambda c: candidates[c][j].neg_log_likelihood) for j in range(p)]
    fits = [candidates[c][j] for j, c in enumerate(chosen)]
    direct = tuple(tried[c] for c in chosen)
    # back to the channels' units: theta_j = diag(regressors) theta'_j / outputs_j
    back = [regressors / outputs[j] for j in range(p)]
    blocks = np.stack([(b * f.coefficients).reshape(p + m, n) for b, f in zip(back, fits)])   # (p, p + m, n)
    inputs = np.zeros((n + 1, p, m))
    for j in range(p):
        first = 0 if direct[j] else 1
        inputs[first:first + n, j] = blocks[j, p:].T
    return RegularizedArx(
        outputs=blocks[:, :p].transpose(2, 0, 1).copy(), inputs=inputs,
        cov_factors=tuple(b[:, None] * f.cov_factor for b, f in zip(back, fits)),
        noise_variance=np.array([f.noise_variance / outputs[j] ** 2 for j, f in enumerate(fits)]),
        kernel=kernel, hyperparameters=tuple(tuple(named_hyperparameters(kernel, z) for z in f.coordinates)
                                             for f in fits),
        feedthrough=direct)


def _check_conditioning(factor: FirFactor, lags: int) -> None:
    """Least squares has no prior to bound what the data cannot: an ill-conditioned regression is refused."""
    with np.errstate(all="ignore"):
        condition = np.linalg.cond(factor.R1)
    if not condition < COND_LIMIT:
        raise DataError(f"the ARX least squares of {lags} lags is ill-conditioned (condition number {condition:.3g}: "
                        "the signals do not excite every lag, or move together); use a kernel or fewer lags")
