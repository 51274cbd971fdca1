"""Empirical frequency response: Welch spectral analysis of an input-output record.

``H(w) = S_yu(w) S_uu(w)^-1`` per frequency, from cross-spectra averaged over
Hann-windowed, half-overlapping segments (docs/diagnostics.md §1). Independent of any
model, it is the reference a model's :meth:`~moli.StateSpaceModel.frequency_response`
is checked against.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..data.frequency_data import FrequencyData
from ..data.iodata import IOData, require_one_segment
from ..errors import DataError
from ..models.frequency import check_omega
from ..numerics.blas_threads import limited_blas

__all__ = ["EmpiricalResponse", "empirical_frequency_response", "spectral_frequency_data"]

# S_uu is treated as singular (response NaN) beyond this condition number: the
# inputs then carry no independent power at that frequency.
MAX_CONDITION = 1e10


class EmpiricalResponse(NamedTuple):
    """Frequencies and response of :func:`empirical_frequency_response` (unpacks as a pair)."""

    omega: np.ndarray
    """Frequencies, rad per time unit, shape (F,)."""
    response: np.ndarray
    """Complex response, shape (F, p, m): entry ``[f, i, j]`` from input ``j`` to output ``i``."""


def default_segment(N: int, m: int) -> int:
    """Segment length: about N / 8 rounded down to a power of two (at least 16), so that
    Welch averages some 15 half-overlapping segments, and never fewer than ``4 m``."""
    length = max(16, 2 ** int(np.floor(np.log2(max(N / 8, 1.0)))))
    while length > 16 and 2 * N // length - 1 < 4 * m:
        length //= 2
    return min(length, N)


def empirical_frequency_response(
    data: IOData, omega: object | None = None, nperseg: int | None = None
) -> EmpiricalResponse:
    """Spectral-analysis estimate of the frequency response from inputs to outputs.

    Each channel is cut into segments of ``nperseg`` samples overlapping by half,
    each segment's mean removed and a Hann window applied; the cross-spectra
    ``S_yu`` (p, m) and ``S_uu`` (m, m) are averaged over the segments, and
    ``H = S_yu S_uu^-1`` is solved per frequency (for several inputs this separates
    their contributions even when the inputs are correlated, as long as ``S_uu`` is
    invertible).

    Parameters
    ----------
    data : IOData
        The record (means need not be removed: each segment's mean is).
    omega : array_like, optional
        Frequencies in rad per time unit of ``data.Ts``; default the segment's DFT
        frequencies ``2 pi k / (nperseg Ts)``, ``k = 1 .. nperseg / 2`` (zero
        frequency left out: removing segment means empties it).
    nperseg : int, optional
        Segment length: resolution ``2 pi / (nperseg Ts)``, variance about inversely
        proportional to the number of segments ``2 N / nperseg - 1``. Default about
        ``N / 8`` (a power of two, at least 16).

    Returns
    -------
    EmpiricalResponse
        ``(omega, response)``; response has shape (F, p, m), NaN at frequencies
        where the inputs have no power (``S_uu`` singular).

    Raises
    ------
    DataError
        ``data`` not an IOData, ``nperseg`` not an integer from 8 to N, or too few
        segments (fewer than the number of inputs) to invert ``S_uu``.

    Examples
    --------
    >>> import numpy as np, moli
    >>> model = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]])
    >>> u = np.random.default_rng(0).standard_normal(4000)
    >>> omega, H = moli.empirical_frequency_response(moli.IOData(model.simulate(u), u), omega=[0.5])
    >>> exact = model.frequency_response([0.5])
    >>> bool(abs(H[0, 0, 0] - exact[0, 0, 0]) < 0.05 * abs(exact[0, 0, 0]))
    True
    """
    with limited_blas():
        omega_, response, _, _ = _welch(data, omega, nperseg)
        return EmpiricalResponse(omega_, response)


def spectral_frequency_data(data: IOData, nperseg: int | None = None) -> FrequencyData:
    """The spectral estimate of :func:`empirical_frequency_response` as :class:`moli.FrequencyData`,
    with each line's variance, for identification from an arbitrary (not periodic) record.

    With the noise on the outputs and ``K`` Hann-windowed segments overlapping by half, the
    estimate's error is ``S_vu S_uu^-1``; its variance per entry is
    ``var G_ij = S_vv,ii [S_uu^-1]_jj / K_eff`` (Bendat and Piersol), with the noise spectrum
    ``S_vv = (S_yy - G S_uu G^H) K_eff / (K_eff - m)`` and Welch's equivalent number of
    segments ``K_eff = K / (1 + 2 rho^2 (K - 1) / K)``, ``rho`` the window's overlap correlation
    (1/6 for Hann at half overlap). Lines where the inputs have no power are left out. The
    coherence of each output is the share of its spectrum the inputs explain,
    ``gamma_i^2 = (G S_uu G^H)_ii / S_yy,ii`` (with one input the ordinary coherence
    ``|S_yu|^2 / (S_yy S_uu)``; with several, the multiple coherence of the output, given on
    each of its pairs).

    Parameters
    ----------
    data : IOData
        One record without gaps (means need not be removed).
    nperseg : int, optional
        As for :func:`empirical_frequency_response`.

    Returns
    -------
    FrequencyData
        Discrete time (``data.Ts``), at the segment's DFT frequencies, with its variance
        and coherence.

    Examples
    --------
    >>> import numpy as np, moli
    >>> model = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]])
    >>> u = np.random.default_rng(0).standard_normal(4000)
    >>> y = model.simulate(u) + 0.1 * np.random.default_rng(1).standard_normal((4000, 1))
    >>> frf = moli.spectral_frequency_data(moli.IOData(y, u))
    >>> frf.variance.shape == frf.G.shape
    True
    """
    with limited_blas():
        omega, response, variance, coherence = _welch(data, None, nperseg)
        kept = np.all(np.isfinite(response), axis=(1, 2)) & np.all(variance > 0, axis=(1, 2))
        if not kept.any():
            raise DataError("the inputs have no power at any frequency of the spectral estimate")
        return FrequencyData(omega[kept], response[kept], unit="rad/s", Ts=data.Ts, variance=variance[kept],
                             output_names=data.output_names, input_names=data.input_names,
                             coherence=np.clip(coherence[kept], 0.0, 1.0))


def _welch(data: IOData, omega: object | None,
           nperseg: int | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Frequencies, the H1 estimate, its variance per entry and each output's coherence on its pairs
    (NaN where ``S_uu`` is singular)."""
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    require_one_segment(data, "empirical_frequency_response (Welch spectra)")
    N, p, m = data.N, data.p, data.m
    if N < 8:
        raise DataError(f"data must have at least 8 samples (one segment of 8), got {N}")
    if nperseg is None:
        length = default_segment(N, m)
    elif isinstance(nperseg, (bool, np.bool_)) or not isinstance(nperseg, (int, np.integer)) \
            or not 8 <= nperseg <= N:
        raise DataError(f"nperseg must be an integer from 8 to the record length {N}, got {nperseg!r}")
    else:
        length = int(nperseg)
    step = length // 2
    count = (N - length) // step + 1
    if count < m:
        raise DataError(
            f"{count} segments of {length} samples cannot separate {m} inputs: "
            f"give a shorter nperseg (at most {2 * N // (m + 1)}) or a longer record"
        )
    # the periodic Hann window (scipy.signal.get_window("hann"), whose import is slow)
    window = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(length) / length)
    z = np.concatenate([data.y, data.u], axis=1)
    segments = np.lib.stride_tricks.sliding_window_view(z, length, axis=0)[::step]  # (K, p+m, L)
    segments = (segments - segments.mean(axis=2, keepdims=True)) * window
    if omega is None:
        w = 2 * np.pi * np.arange(1, length // 2 + 1) / (length * data.Ts)
        spectra = np.fft.rfft(segments, axis=2)[:, :, 1:]                 # (K, p+m, F)
    else:
        w = check_omega(omega)
        # the segments' DTFT at the requested frequencies (any grid, not only DFT bins)
        kernel = np.exp(-1j * np.outer(np.arange(length), w * data.Ts))  # (L, F)
        spectra = segments @ kernel
    # cross-spectra S[f, a, b] = mean over segments of Z_a conj(Z_b); the window's
    # scaling is common to S_yu and S_uu and cancels in H
    S = np.einsum("kaf,kbf->fab", spectra, spectra[:, p:].conj()) / count      # (F, p+m, m)
    S_yu, S_uu = S[:, :p], S[:, p:]
    response = np.full((w.size, p, m), np.nan, dtype=complex)
    usable = np.linalg.cond(S_uu) < MAX_CONDITION
    # H S_uu = S_yu, solved as S_uu^T H^T = S_yu^T: no inverse is formed
    solved = np.linalg.solve(S_uu[usable].transpose(0, 2, 1), S_yu[usable].transpose(0, 2, 1))
    response[usable] = solved.transpose(0, 2, 1)
    # Welch's equivalent number of segments: neighbours share the window's overlap, correlation rho
    rho = float(window[step:] @ window[:-step] / (window @ window)) if step > 0 else 0.0
    effective = count / (1.0 + 2.0 * rho ** 2 * (count - 1) / count)
    variance, coherence = np.full((w.size, p, m), np.nan), np.full((w.size, p, m), np.nan)
    G = response[usable]
    S_yy = np.real(np.einsum("kif,kif->fi", spectra[:, :p], spectra[:, :p].conj()))[usable] / count
    explained = np.real(np.einsum("fii->fi", G @ S_uu[usable] @ G.conj().transpose(0, 2, 1)))
    with np.errstate(divide="ignore", invalid="ignore"):        # an output without power has no coherence
        coherence[usable] = (explained / S_yy)[:, :, None]
    if effective > m:
        noise = np.maximum(S_yy - explained, 0.0) * effective / (effective - m)
        # diag(S_uu^-1) per line, by a solve with the identity (S_uu is m x m and well conditioned here)
        inverse = np.real(np.einsum("fjj->fj", np.linalg.solve(S_uu[usable], np.eye(m)[None])))
        variance[usable] = noise[:, :, None] * inverse[:, None, :] / effective
    return w, response, variance, coherence
