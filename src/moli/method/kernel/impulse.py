"""``moli.impulse_response``: a MIMO impulse response with a kernel prior, for short records.

Every input-output pair gets its own kernel (:mod:`.kernels`); each output's kernels and
noise variance maximize that output's marginal likelihood (:mod:`.empirical_bayes`), and the
posterior gives the estimate and its covariance: bands on the impulse and step responses
that the least squares of a short record, at the same length, cannot give (docs/regularization.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...data.arguments import flag, integer
from ...data.iodata import IOData
from ...errors import DataError, OptionError
from ..least_squares.estimation import COND_LIMIT
from .empirical_bayes import OutputFit, fit_output
from .fir_rows import fir_factor, fir_rows
from .kernels import KERNELS, decay_of, named_hyperparameters
from ...numerics.blas_threads import limited_blas

__all__ = ["ImpulseResponse", "impulse_response"]

# The length chosen from the data starts here and doubles while the fitted kernels still
# expect more than DECAY_LEFT of the response (prior standard deviation against lag 1) at
# its end, as long as the record keeps ROWS_PER_COEFFICIENT rows per coefficient of an output.
START_LENGTH = 20
DECAY_LEFT = 0.01
# Coefficients per output the chosen length stops at: each likelihood evaluation costs a QR of
# twice as many rows by one more column, and at 640 (four inputs, 160 lags) one fit took minutes.
MAX_COEFFICIENTS = 200
ROWS_PER_COEFFICIENT = 0.5
MAX_DOUBLINGS = 4


@dataclass(frozen=True)
class ImpulseResponse:
    """An estimated impulse response with its posterior covariance.

    Attributes
    ----------
    coefficients : ndarray, shape (n, p, m)
        ``g[k, j, i]``: output ``j``'s response at lag ``lags[k]`` to a unit impulse of input ``i``.
    lags : ndarray, shape (n,)
        Sample lags (from 1, or from 0 with ``feedthrough=True``).
    cov_factors : tuple of ndarray
        Output ``j``'s covariance factor ``F_j`` over its coefficients, input-major
        (``cov = F_j F_j^T``, shape (m n, m n)).
    noise_variance : ndarray, shape (p,)
    kernel : str
    hyperparameters : tuple of tuple of dict
        ``hyperparameters[j][i]``: the kernel's ``c``, ``lambda`` (and ``rho``) of pair (j, i).
    Ts : float
    output_names, input_names : tuple of str
    time_unit : str or None
    """

    coefficients: np.ndarray
    lags: np.ndarray
    cov_factors: tuple[np.ndarray, ...]
    noise_variance: np.ndarray
    kernel: str
    hyperparameters: tuple[tuple[dict[str, float], ...], ...]
    Ts: float
    output_names: tuple[str, ...]
    input_names: tuple[str, ...]
    time_unit: str | None = None

    def step(self) -> np.ndarray:
        """The step responses at ``lags``, shape (n, p, m): cumulative sums of the impulse response."""
        return np.cumsum(self.coefficients, axis=0)

    def bands(self, confidence: float = 0.95, step: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Pointwise ``confidence`` bands of the impulse (or, with ``step``, the step) responses.

        Returns
        -------
        lower, upper : ndarray, shape (n, p, m)
        """
        if isinstance(confidence, bool) or not isinstance(confidence, (int, float)) or not 0 < confidence < 1:
            raise OptionError(f"confidence must be a number strictly between 0 and 1, got {confidence!r}")
        import scipy.special  # only when bands are asked for

        n, p, m = self.coefficients.shape
        # the step response is the impulse response summed over lags: the same sum of each input's block
        summed = np.tril(np.ones((n, n))) if step else np.eye(n)
        sd = np.empty((n, p, m))
        for j, factor in enumerate(self.cov_factors):
            for i in range(m):
                sd[:, j, i] = np.linalg.norm(summed @ factor[i * n:(i + 1) * n], axis=1)
        z = float(scipy.special.ndtri(0.5 + confidence / 2))
        centre = self.step() if step else self.coefficients
        return centre - z * sd, centre + z * sd


def check_kernel_arguments(data: object, kernel: object, center: object) -> None:
    """What every kernel estimate checks first: an IOData, a known kernel, ``center`` a flag."""
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    if kernel not in KERNELS:
        raise OptionError(f"kernel must be one of {KERNELS}, got {kernel!r}")
    flag("center", center, error=OptionError)


def centred_record(data: IOData, center: bool) -> IOData:
    """The record a kernel estimate fits (its deviations from the means where ``center``); an
    input that never changes is refused, as nothing of its response is in the record."""
    record = data.remove_means() if center else data
    still = [name for name, spread in zip(record.input_names, np.ptp(record.u, axis=0)) if spread == 0]
    if still:
        raise DataError(f"input {', '.join(still)} never changes: the record says nothing of its response; "
                        "leave it out of the inputs")
    return record


def impulse_response(data: IOData, kernel: str = "TC", length: int | None = None, *,
                     feedthrough: bool = False, center: bool = True) -> ImpulseResponse:
    """A MIMO impulse response by regularized least squares (empirical Bayes).

    Parameters
    ----------
    data : IOData
        The record; each segment gives its own rows (no lag reaches across a gap).
    kernel : {"TC", "DC", "SS", "none"}, default "TC"
        The prior of every input-output pair; "none": plain least squares (no prior).
    length : int, optional
        Coefficients per pair. None: from 20, doubled while the fitted kernels still expect
        more than 1 % of the response (prior standard deviation against lag 1) at the end,
        up to half a row per coefficient of an output, 200 coefficients per output and four
        doublings; "none" takes the length the TC kernel finds.
    feedthrough : bool, default False
        Also estimate lag 0 (a direct feedthrough).
    center : bool, default True
        Remove the record's means first (the response of deviations from the operating point).

    Returns
    -------
    ImpulseResponse

    Raises
    ------
    OptionError
        An unknown kernel, or a length that is not a positive integer.
    DataError
        ``data`` is not an IOData; an input that never changes; a length beyond the longest
        segment or too few rows for it (least squares needs more rows than coefficients per
        output, and a condition number below 1e10).

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(200)
    >>> y = np.convolve(u, np.r_[0.0, 0.8 ** np.arange(40)])[:200] + 0.1 * rng.standard_normal(200)
    >>> fit = moli.method.impulse_response(moli.IOData(y, u), length=30)     # g(k) = 0.8^(k-1)
    >>> bool(np.max(np.abs(fit.coefficients[:, 0, 0] - 0.8 ** np.arange(30))) < 0.1)
    True
    """
    with limited_blas():
        check_kernel_arguments(data, kernel, center)
        if length is not None:
            length = integer("length", length, error=OptionError, low=1)
        first = 0 if flag("feedthrough", feedthrough, error=OptionError) else 1
        record = centred_record(data, center)
        longest = max(stop - start for start, stop in record.bounds)
        if length is not None and length >= longest:
            raise DataError(f"length = {length} lags reach beyond the longest segment ({longest} samples): "
                            "give a shorter length")
        chosen = None
        if length is None:
            length, chosen = _chosen_length(record, "TC" if kernel == "none" else kernel, first)
        lags = np.arange(first, first + length)
        rows, per_output = fir_rows(record, lags), record.m * length
        if rows < 1 or (kernel == "none" and rows <= per_output):
            raise DataError(f"the record gives {rows} rows for {length} lags of {record.m} inputs "
                            f"({per_output} coefficients per output): "
                            + ("least squares needs more rows than coefficients; use a kernel or a shorter length"
                               if kernel == "none" else "give a longer record or a shorter length"))
        # the length's search fitted this kernel at the length it chose: its fits are the estimate
        fits = chosen if chosen is not None and kernel != "none" else _fits(record, lags, kernel)
        n, m = length, record.m
        return ImpulseResponse(
            coefficients=np.stack([f.coefficients.reshape(m, n).T for f in fits], axis=1),
            lags=lags, cov_factors=tuple(f.cov_factor for f in fits),
            noise_variance=np.array([f.noise_variance for f in fits]), kernel=kernel,
            hyperparameters=tuple(tuple(named_hyperparameters(kernel, z) for z in f.coordinates) for f in fits),
            Ts=record.Ts, output_names=record.output_names, input_names=record.input_names,
            time_unit=record.time_unit)


def _fits(record: IOData, lags: np.ndarray, kernel: str) -> list[OutputFit]:
    """Each output's fit; the least squares refused where its factor is ill-conditioned."""
    factor = fir_factor(record, lags)
    if kernel == "none":
        with np.errstate(all="ignore"):
            condition = np.linalg.cond(factor.R1)
        if not condition < COND_LIMIT:      # a prior would bound what the data cannot: least squares has none
            raise DataError(f"the FIR least squares of {len(lags)} lags is ill-conditioned (condition number "
                            f"{condition:.3g}: the inputs do not excite every lag, or move together); use a "
                            "kernel or a shorter length")
    scales = np.var(record.u, axis=0)
    return [fit_output(factor, j, kernel, lags, scales) for j in range(record.p)]


def _chosen_length(record: IOData, kernel: str, first: int) -> tuple[int, list[OutputFit] | None]:
    """:data:`START_LENGTH` lags, doubled while the fitted kernels expect more of the response; and
    the fits at that length (None where the last doubling was not fitted)."""
    longest = max(stop - start for start, stop in record.bounds)
    length = max(1, min(START_LENGTH, longest // 2))
    for _ in range(MAX_DOUBLINGS):
        lags = np.arange(first, first + length)
        fits = _fits(record, lags, kernel)
        left = max(decay_of(kernel, z, int(lags[-1])) for fit in fits for z in fit.coordinates)
        longer = 2 * length
        enough_rows = fir_rows(record, np.arange(first, first + longer)) >= ROWS_PER_COEFFICIENT * record.m * longer
        if left <= DECAY_LEFT or not enough_rows or longer > longest // 2 or record.m * longer > MAX_COEFFICIENTS:
            return length, fits
        length = longer
    return length, None
