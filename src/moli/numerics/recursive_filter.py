"""Recursive (IIR) filtering of many signals at once, without ``scipy.signal``.

:func:`recursive_filter` computes what ``scipy.signal.lfilter(b, a, x, axis, zi)`` does
for the filters moli uses: real, with a denominator of low degree. ``scipy.signal`` costs
0.6-0.9 s of CPU to import (``scipy.stats`` and SciPy's docstring machinery come with it),
which a fresh process would pay on its first identification; the filters here need only
``scipy.linalg.lapack``, which the regression loads anyway.

The recursion ``y[t] + a_1 y[t-1] + ... + a_d y[t-d] = v[t]`` over ``N`` samples is a
forward substitution with the unit lower-triangular banded Toeplitz matrix of ``a``: one
LAPACK ``dtbtrs`` solves it for every signal at once, as the same loop over the samples
``lfilter`` runs (the sums come in another order, so results agree to rounding).
``v`` is the numerator applied to the input, plus the initial state.

State convention (``lfilter``'s transposed direct form II, ``a`` scaled to ``a_0 = 1``,
``b`` and ``a`` padded with zeros to ``d + 1`` coefficients): unrolled over the first
samples, the state ``zi`` adds ``zi[t]`` to ``v[t]`` for ``t < d``; after the last sample
the state is ``zf[i] = zi[N + i] (where N + i < d) + sum_{j = i+1 .. min(d, N + i)}
(b_j x[N + i - j] - a_j y[N + i - j])``, what the next call continues from.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg.lapack

__all__ = ["recursive_filter"]


def recursive_filter(
    b: np.ndarray | list[float], a: np.ndarray | list[float], x: np.ndarray, axis: int = -1,
    zi: np.ndarray | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Filter ``x`` along ``axis`` by ``b(q^-1) / a(q^-1)``, as ``scipy.signal.lfilter`` does.

    Parameters
    ----------
    b : array_like, shape (nb,)
        Numerator coefficients.
    a : array_like, shape (na,)
        Denominator coefficients, ``a[0] != 0``.
    x : ndarray
        Real signals; samples along ``axis``.
    axis : int
        The time axis of ``x``.
    zi : ndarray or None
        Initial state, the shape of ``x`` with ``axis`` of length ``max(na, nb) - 1``
        (``lfilter``'s layout); None for rest.

    Returns
    -------
    y : ndarray
        The filtered signals, the shape of ``x`` (not necessarily C-contiguous).
    zf : ndarray
        Only when ``zi`` is given: the final state, the shape of ``zi``.
    """
    b, a = _coefficients(b, a)
    d = a.size - 1
    x = np.asarray(x, dtype=float)
    last = axis in (-1, x.ndim - 1)
    moved = x if last else np.moveaxis(x, axis, -1)
    shape, N = moved.shape, moved.shape[-1]
    signals = moved.reshape(math.prod(shape[:-1]), N)
    # v, one signal per row (C order: the columns of a Fortran right-hand side, no copy)
    v = np.array(signals, order="C") if b[0] == 1.0 else np.multiply(signals, b[0], order="C")
    for k in range(1, min(d, N - 1) + 1):
        if b[k]:
            v[:, k:] += b[k] * signals[:, :-k]
    if zi is not None:
        zi = np.asarray(zi, dtype=float)
        state = (zi if last else np.moveaxis(zi, axis, -1)).reshape(signals.shape[0], d)
        v[:, : min(d, N)] += state[:, :N]
    if d and N and v.shape[0]:
        band = np.repeat(a[None], N, axis=0).T     # Fortran order; row k: the k-th subdiagonal, a_k
        y = scipy.linalg.lapack.dtbtrs(band, v.T, uplo="L", diag="U", overwrite_b=1)[0].T
    else:
        y = v
    filtered = y.reshape(shape) if last else np.moveaxis(y.reshape(shape), -1, axis)
    if zi is None:
        return filtered
    zf = _final_state(b, a, signals, y, state).reshape(*shape[:-1], d)
    return filtered, zf if last else np.moveaxis(zf, -1, axis)


def _coefficients(b: np.ndarray | list[float], a: np.ndarray | list[float]) -> tuple[np.ndarray, np.ndarray]:
    """``b`` and ``a`` scaled to ``a[0] = 1`` and padded with zeros to one length."""
    b, a = np.asarray(b, dtype=float), np.asarray(a, dtype=float)
    if a[0] != 1.0:
        b, a = b / a[0], a / a[0]
    if a.size == b.size:
        return b, a
    both = np.zeros((2, max(a.size, b.size)))
    both[0, : b.size], both[1, : a.size] = b, a
    return both[0], both[1]


def _final_state(b: np.ndarray, a: np.ndarray, x: np.ndarray, y: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """The state after the last sample (module docstring), one signal per row."""
    d, N = a.size - 1, x.shape[1]
    tail = min(d, N)
    # coefficient j = i + 1 + m of the sample N - 1 - m for state entry i (zero past d)
    index = np.arange(d)[:, None] + 1 + np.arange(tail)[None, :]
    b_of, a_of = np.pad(b, (0, d))[index], np.pad(a, (0, d))[index]
    recent_x, recent_y = x[:, N - tail :][:, ::-1], y[:, N - tail :][:, ::-1]
    zf = recent_x @ b_of.T - recent_y @ a_of.T
    zf[:, : d - tail] += zi[:, N:]      # state entries the samples have not reached yet
    return zf
