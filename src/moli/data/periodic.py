"""frequency_response: the FRF of periodic (multisine) records, averaged over periods, with each line's variance.

Each record holds ``P`` periods of ``N_p`` samples. The first ``transient`` periods are
dropped (the system's response to the start has not died out in them); the DFT of each
remaining period gives ``U_r(k)`` and ``Y_r(k)``, and their means over the periods
``U(k)``, ``Y(k)``. With ``m`` inputs, ``m`` records (experiments) whose inputs are
independent at each excited line give ``G(k) = Y(k) U(k)^-1``, ``Y`` of shape (p, m)
and ``U`` of shape (m, m), one column per record. The periods' spread gives the
variance of each mean, ``var Y_ie(k) = sum_r |Y_r - Y|^2 / (P (P - 1))``, and with noise
on the outputs alone (the inputs are known exactly, as a generator's) and independent
between records, ``var G_ij(k) = sum_e var Y_ie(k) |U^-1(k)_ej|^2``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import DataError
from .arguments import integer
from .frequency_data import FrequencyData
from .iodata import IOData

__all__ = ["frequency_response", "EXCITED"]

# A line is excited when the smallest singular value of its input spectra U(k) is at least
# this fraction of the largest over the lines: a multisine's unexcited lines hold round-off
# (1e-13 of its amplitude and below), its excited ones a comparable amplitude each.
EXCITED = 1e-6
# Noise-free records spread only by round-off: each line's variance is kept at least this
# fraction of |G|^2 (a relative error of 1e-8), so that weights stay finite.
FLOOR = 1e-16


def _records(data: IOData | Sequence[IOData]) -> list[IOData]:
    records = [data] if isinstance(data, IOData) else list(data) if isinstance(data, (list, tuple)) else None
    if not records or not all(isinstance(r, IOData) for r in records):
        raise DataError(f"data must be an IOData or a list of IOData (one record per input), got {type(data).__name__}")
    first = records[0]
    if len(records) != first.m:
        raise DataError(f"{first.m} inputs need {first.m} records whose inputs are independent at each excited line "
                        f"(one experiment per input), got {len(records)}")
    for number, record in enumerate(records):
        if (record.p, record.m, record.N) != (first.p, first.m, first.N) or record.Ts != first.Ts:
            raise DataError(f"record {number} has {record.p} outputs, {record.m} inputs, {record.N} samples and "
                            f"Ts = {record.Ts:g}; record 0 has {first.p}, {first.m}, {first.N} and Ts = {first.Ts:g}")
        if record.n_segments != 1:
            raise DataError(f"record {number} has {record.n_segments} segments: periods must follow each other")
        if not (np.all(np.isfinite(record.y)) and np.all(np.isfinite(record.u))):
            raise DataError(f"record {number} has missing (NaN) samples: periodic averaging needs every sample")
    return records


def frequency_response(data: IOData | Sequence[IOData], periods: int, *, transient: int = 1) -> FrequencyData:
    """The frequency response of periodic records at their excited lines, with each line's variance.

    Parameters
    ----------
    data : IOData or list of IOData
        One record per input (a single record for one input), each holding ``periods``
        whole periods of the same excitation length, sampled every ``Ts``.
    periods : int
        Periods in each record (its length must be a multiple of it).
    transient : int, default 1
        Leading periods dropped as the transient; at least two periods must remain for
        the variance.

    Returns
    -------
    FrequencyData
        Discrete time (``Ts`` of the records), at the lines ``2 pi k / (N_p Ts)`` (up to
        Nyquist) where every input is excited, with the variance of each line's mean
        from the periods' spread, and the records' channel names.

    Raises
    ------
    DataError
        Records that do not match one another, a length that is not a multiple of
        ``periods``, fewer than two periods after the transient, missing samples, or no
        excited line.

    Examples
    --------
    >>> import numpy as np, moli
    >>> k = np.arange(64)
    >>> u = np.cos(2 * np.pi * 3 * k / 16)             # period 16, line 3
    >>> y = 0.5 * np.roll(u, 1)                        # y[t] = 0.5 u[t - 1]
    >>> frf = frequency_response(moli.IOData(y, u), 4, transient=1)
    >>> frf.F, bool(np.isclose(frf.G[0, 0, 0], 0.5 * np.exp(-2j * np.pi * 3 / 16)))
    (1, True)
    """
    records = _records(data)
    P = integer("periods", periods, low=1)
    drop = integer("transient", transient, low=0)
    N, Ts = records[0].N, records[0].Ts
    if N % P:
        raise DataError(f"the records hold {N} samples, not a whole number of {P} periods")
    if P - drop < 2:
        raise DataError(f"{P} periods less {drop} transient leave {P - drop}; the variance needs at least two")
    length = N // P
    # (records, periods, lines, channels): each period's DFT, the transient dropped
    Y = np.stack([np.fft.rfft(r.y[drop * length:].reshape(P - drop, length, r.p), axis=1) for r in records])
    U = np.stack([np.fft.rfft(r.u[drop * length:].reshape(P - drop, length, r.m), axis=1) for r in records])
    Ymean, Umean = Y.mean(axis=1), U.mean(axis=1)             # (records e, lines, channels)
    inputs = Umean.transpose(1, 2, 0)                         # (lines, m, e)
    singular = np.linalg.svd(inputs, compute_uv=False)
    excited = singular[:, -1] >= EXCITED * singular[:, 0].max() if singular[:, 0].max() > 0 else []
    lines = np.flatnonzero(excited)
    if lines.size == 0:
        raise DataError("no line of the records is excited by every input: periodic averaging needs "
                        "inputs that repeat each period (multisines)")
    inverse = np.linalg.inv(inputs[lines])                    # (lines, e, m)
    G = Ymean[:, lines].transpose(1, 2, 0) @ inverse          # (lines, p, m)
    spread = np.sum(np.abs(Y - Ymean[:, None]) ** 2, axis=1) / ((P - drop) * (P - drop - 1))   # (e, lines, p)
    variance = np.einsum("elp,lej->lpj", spread[:, lines], np.abs(inverse) ** 2)
    omega = 2 * np.pi * lines / (length * Ts)
    variance = np.maximum(variance, FLOOR * np.abs(G) ** 2 + np.finfo(float).tiny)
    return FrequencyData(omega, G, unit="rad/s", Ts=Ts, variance=variance,
                         output_names=records[0].output_names, input_names=records[0].input_names)
