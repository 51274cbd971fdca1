"""The paired test of two models on the same validation samples.

Two models' mean VAFs differ by a sum over samples of the differences of their squared
errors, and the sum's standard error comes from contiguous batch sums of those
differences (batch means), which keeps the serial correlation of simulation errors
within each batch. That holds while the batches are long against the differences'
correlation time: on a short record under coloured noise, ten batches of a few samples
each are correlated with one another, their spread understates the error, and the test
declares one of two equally good models better far more often than its level
(benchmarks/paired_test_size.py). The batches are therefore made at least
:data:`BATCH_TIMES` correlation times long, at most :data:`PAIRED_BATCHES` and at least
:data:`MIN_BATCHES` of them (fewer only on a record of fewer samples), and the threshold of
``z`` standard errors is taken at the one-sided level Student's t gives it with ten batches,
whatever their number.
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.special

__all__ = ["PAIRED_BATCHES", "MIN_BATCHES", "BATCH_TIMES", "error_shares", "paired_difference",
           "correlation_time"]

# Batches where the errors' correlation allows: enough for a standard error, each long enough
# (tens of samples on short records) to hold the errors' serial correlation.
PAIRED_BATCHES = 10
# Fewest batches: two degrees of freedom for the standard error.
MIN_BATCHES = 3
# Batch length in correlation times: batch sums of an AR(1) series of pole a this long are
# correlated by a / (5 (1 + a)^2), at most 0.05, with their neighbours.
BATCH_TIMES = 5
# Sokal's window for the integrated correlation time: the sum runs to the first lag that is at
# least this many times the time summed so far (the standard choice; 5-10 in the literature).
WINDOW_TIMES = 5


def error_shares(y: np.ndarray, yhat: np.ndarray) -> np.ndarray:
    """Each sample's squared error of ``yhat``, in points; inf where not finite.

    Summed over the samples: the mean over the outputs of ``100 |e_j|^2 / |y_j - mean(y_j)|^2``.
    """
    scale = 100.0 / (y.shape[1] * np.maximum(np.sum((y - y.mean(axis=0)) ** 2, axis=0), 1e-300))
    with np.errstate(all="ignore"):
        shares = ((y - yhat) ** 2) @ scale
    return np.nan_to_num(shares, nan=np.inf, posinf=np.inf)


def correlation_time(series: np.ndarray) -> float:
    """Integrated correlation time ``1 + 2 sum_k rho_k`` of a series, in samples (at least 1).

    The autocorrelations come from one FFT; the sum is windowed as Sokal's: it stops at
    the first lag ``M >= WINDOW_TIMES * tau(M)``, where the estimated ``rho_k`` are still
    mostly correlation rather than noise. White noise gives about 1, an AR(1) series of
    pole ``a`` about ``(1 + a) / (1 - a)``.
    """
    series = np.asarray(series, float)
    if np.ptp(series) == 0:                     # a constant: nothing correlated (np.mean may round)
        return 1.0
    x = series - np.mean(series)
    largest = np.max(np.abs(x))
    if largest > 1e150:       # squares would overflow (the shares of a constant output); rho is scale-free
        x = x / largest
    n = x.size
    spectrum = np.fft.rfft(x, 2 * n)
    covariance = np.fft.irfft(spectrum * spectrum.conj(), 2 * n)[:n]
    taus = 1.0 + 2.0 * np.cumsum(covariance[1:] / covariance[0])
    # the sum over every lag of a mean-removed series' autocovariances is zero, so the window
    # closes at the last lag at the latest (and the estimate stays below n / WINDOW_TIMES: on a
    # short record it runs low, and MIN_BATCHES bounds what that costs)
    tau = taus[np.argmax(np.arange(1, n) >= WINDOW_TIMES * taus)]
    return float(min(max(tau, 1.0), n))


def paired_difference(shares: np.ndarray, reference: np.ndarray, z: float) -> tuple[float, float]:
    """Points of mean VAF by which ``shares`` lose to ``reference``, and the margin ``z`` makes.

    The margin is ``z`` batch standard errors with :data:`PAIRED_BATCHES` batches; with
    fewer (a short record whose differences are correlated over many samples) it is the
    threshold of the same one-sided t level at their degrees of freedom. A loss above the
    margin is significant, one below it is not.
    """
    # a diverging model: an infinite loss and no spread (inf - inf where both diverge); the shares of
    # a constant output, scaled by its zero variance's floor, square to infinity: no spread either
    with np.errstate(invalid="ignore", over="ignore"):
        differences = shares - reference
        count = PAIRED_BATCHES
        if np.all(np.isfinite(differences)):
            tau = correlation_time(differences)
            count = int(min(PAIRED_BATCHES, max(MIN_BATCHES, differences.size // (BATCH_TIMES * tau))))
        sums = np.array([np.sum(part) for part in np.array_split(differences, min(count, differences.size))])
        worse = float(sums.sum())
        spread = float(np.sqrt(len(sums) / max(len(sums) - 1, 1) * np.sum((sums - worse / len(sums)) ** 2)))
    return worse, _threshold(float(z), len(sums)) * spread


@functools.lru_cache(maxsize=None)
def _threshold(z: float, batches: int) -> float:
    """``z`` where there are :data:`PAIRED_BATCHES` batches; else the t quantile of the same tail."""
    if batches == PAIRED_BATCHES or batches < 2:
        return z
    # scipy.special's t distribution: scipy.stats costs an identification half a second to import
    tail = scipy.special.stdtr(PAIRED_BATCHES - 1, -z)
    return float(-scipy.special.stdtrit(batches - 1, tail))
