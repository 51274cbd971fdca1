"""Outliers: isolated samples far from their neighbours (spikes, logger glitches).

The rule compares each sample with the median of the ``WINDOW`` = 7 samples centred
on it, in units of the channel's standard deviation:

    z[k] = |x[k] - median(x[k-3 .. k+3])| / std(x),    an outlier when z[k] > threshold.

Why the deviation from a running median: a median filter keeps steps (the edges of a
test signal, a set-point change), so only a sample that disagrees with its neighbours
on *both* sides stands out, at its own sample; the first difference would flag every
step and smear each spike over two samples. The window of 7 ignores up to 3
consecutive bad samples when taking the median.

Why the channel's standard deviation as the unit, not the spread of the deviations (a
Hampel filter's MAD of ``r``): a plant's output is not white noise. Its fast transients
and lightly damped bursts make the deviations heavy-tailed, and a MAD-scaled rule flags
hundreds of clean samples on the DaISy records and on the built-in example plant. Against
the channel's spread, the largest ``z`` of those records is 3.3 (destill, an input), of
white Gaussian noise 5.1 in 4e5 samples. The price: outliers numerous and large enough
to inflate the standard deviation (say 5 % of the samples at 10 standard deviations)
hide each other; a lower threshold finds them.

Designed inputs (fewer than ``LEVELS`` distinct values: binary, multi-level) are not
screened: their pulses are intended, however short. Found outliers are only reported;
:func:`remove_outliers` replaces them, on request, by linear interpolation between the
nearest clean samples of the same channel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import DataError
from .arguments import real_number
from .iodata import IOData

__all__ = ["OUTLIER_THRESHOLD", "OutlierReport", "flag_outliers", "remove_outliers"]

WINDOW = 7
# In standard deviations of the channel. White Gaussian noise has z near 5 once in 4e5
# samples (its deviation from the median of 7 has a variance about 0.93 of the noise's);
# 6 leaves a margin, and the measured DaISy records stay below 3.5.
OUTLIER_THRESHOLD = 6.0
# Channels with fewer distinct values are designed (binary, multi-level) signals.
LEVELS = 16


@dataclass(frozen=True)
class OutlierReport:
    """What :func:`flag_outliers` found.

    Attributes
    ----------
    channels : tuple of str
        Output names, then input names (the columns of ``mask``).
    mask : ndarray of bool, shape (N, p + m)
        True at each outlier sample; outputs first, then inputs.
    threshold : float
        Standard deviations of its channel a sample's deviation had to exceed.
    screened : tuple of bool
        False for the channels not screened (designed inputs, too short records).
    """

    channels: tuple[str, ...]
    mask: np.ndarray
    threshold: float
    screened: tuple[bool, ...]

    @property
    def counts(self) -> dict[str, int]:
        """Number of outliers per channel that has any."""
        return {name: int(n) for name, n in zip(self.channels, self.mask.sum(axis=0)) if n}

    @property
    def first(self) -> dict[str, int]:
        """First outlier sample (index from 0) per channel that has any."""
        return {name: int(np.argmax(col)) for name, col in zip(self.channels, self.mask.T) if col.any()}

    def __bool__(self) -> bool:
        return bool(self.mask.any())


def _check(data: object, threshold: object) -> float:
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    return real_number("threshold", threshold, low=0.0, low_open=True)


def _scores(x: np.ndarray) -> np.ndarray:
    """``z`` of every sample of one channel (0 where the channel is constant)."""
    half = WINDOW // 2
    # reflection (not repetition) at the ends, so a spike at sample 0 is not its own neighbour
    windows = np.lib.stride_tricks.sliding_window_view(np.pad(x, half, mode="reflect"), WINDOW)
    scale = np.std(x)
    return np.abs(x - np.partition(windows, half, axis=1)[:, half]) / scale if scale > 0 else np.zeros_like(x)


def flag_outliers(data: IOData, threshold: float = OUTLIER_THRESHOLD) -> OutlierReport:
    """Find isolated samples far from their neighbours, per channel (see the module's rule).

    Parameters
    ----------
    data : IOData
    threshold : float, default 6
        Deviation from the running median of 7 samples, in standard deviations of the
        channel, above which a sample is an outlier.

    Returns
    -------
    OutlierReport
        ``mask`` (N, p + m), per-channel ``counts`` and ``first`` sample. Nothing is
        changed: see :func:`remove_outliers`.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> y = rng.standard_normal(500); y[123] += 20.0
    >>> report = flag_outliers(IOData(y, rng.standard_normal(500)))
    >>> report.counts, report.first
    ({'y1': 1}, {'y1': 123})
    """
    threshold = _check(data, threshold)
    columns = np.concatenate([data.y, data.u], axis=1)
    usable = np.isfinite(columns)
    names = data.output_names + data.input_names
    mask = np.zeros(columns.shape, dtype=bool)
    screened = []
    for j, column in enumerate(columns.T):
        x = column[usable[:, j]]
        designed = j >= data.p and np.unique(x).size < LEVELS
        ok = x.size > WINDOW and not designed
        screened.append(ok)
        if ok:
            mask[np.flatnonzero(usable[:, j]), j] = _scores(x) > threshold
    return OutlierReport(names, mask, threshold, tuple(screened))


def remove_outliers(data: IOData, threshold: float = OUTLIER_THRESHOLD) -> IOData:
    """A copy of ``data`` with every outlier replaced by linear interpolation.

    Each outlier sample takes the value on the straight line between the nearest clean
    samples of its channel before and after it (the nearest clean sample at either end
    of the record). Clean samples, ``Ts``, names, offsets, segments and time stamps are
    unchanged.

    Parameters
    ----------
    data : IOData
    threshold : float, default 6
        As in :func:`flag_outliers`.

    Returns
    -------
    IOData

    Examples
    --------
    >>> y = np.sin(0.05 * np.arange(200)); y[50] = 30.0
    >>> cleaned = remove_outliers(IOData(y, np.cos(0.07 * np.arange(200))))
    >>> bool(abs(cleaned.y[50, 0] - np.sin(2.5)) < 1e-3)
    True
    """
    mask = flag_outliers(data, threshold).mask
    columns = np.concatenate([data.y, data.u], axis=1)
    k = np.arange(data.N)
    for j in np.flatnonzero(mask.any(axis=0)):
        clean = ~mask[:, j] & np.isfinite(columns[:, j])
        columns[mask[:, j], j] = np.interp(k[mask[:, j]], k[clean], columns[clean, j])
    cleaned = IOData(columns[:, : data.p], columns[:, data.p:], data.Ts, data.output_names, data.input_names,
                     segment_starts=data.segment_starts, times=data.times, time_unit=data.time_unit)
    cleaned.y_offset, cleaned.u_offset = data.y_offset.copy(), data.u_offset.copy()
    return cleaned
