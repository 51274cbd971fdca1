"""Exact propagation of ``x' = F x + G v`` between time stamps (docs/continuous.md §2).

Between two stamps the driving signal ``v`` is either held (zero-order hold: the value
at the interval's start) or linear (first-order hold: the straight line through the
two samples). Under that assumption the state at the next stamp is exact:

    x_{k+1} = Phi_k x_k + Gamma0_k v_k + Gamma1_k (v_{k+1} - v_k)   (linear channels)

with ``Phi = exp(F h)``, ``Gamma0 = int_0^h exp(F s) ds G`` and
``Gamma1 = (1/h) int_0^h exp(F (h - s)) s ds G``, all read from one matrix exponential
of a block matrix. The recursion is then summed by doubling (Hillis-Steele): log2(N)
passes of whole-array products instead of N Python steps, with products of the
stable maps only, so nothing grows.

Regular stamps share one map. Irregular stamps use ``F``'s eigenvectors when they are
well conditioned (each mode is then a scalar recursion with closed-form maps), and a
matrix exponential per interval otherwise.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["interval_maps", "propagate", "is_regular"]

# Steps equal to this share of their median are one step: stamps k * T written in
# floating point differ from it by a few ulps of t_k, far below this.
REGULAR_SPREAD = 1e-9
# Eigenvectors better conditioned than this give the modal maps (their round-off
# grows with the condition: about 1e-10 relative here); beyond it (repeated or
# clustered poles, filters of degree 9 and more) the per-interval matrix exponential
# is used.
MODAL_CONDITION = 1e6
# The doubling stops once the map's products are below round-off of the sums.
NEGLIGIBLE = 1e-18
# |x| below this: phi_2(x) = (e^x - 1 - x) / x^2 by its series (the closed form
# cancels there).
SERIES_BELOW = 1e-3


def is_regular(steps: np.ndarray) -> bool:
    """Whether every step equals the median within :data:`REGULAR_SPREAD` of it."""
    if steps.size == 0:
        return True
    median = float(np.median(steps))
    return bool(np.max(np.abs(steps - median)) <= REGULAR_SPREAD * median)


def interval_maps(F: np.ndarray, G: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``Phi, Gamma0, Gamma1`` of each step length in ``h`` (shape (K,)): (K, n, n), (K, n, m), (K, n, m)."""
    n, m = G.shape
    block = np.zeros((h.size, n + 2 * m, n + 2 * m))
    block[:, :n, :n] = F
    block[:, :n, n : n + m] = G
    block[:, n : n + m, n + m :] = np.eye(m)
    exponential = scipy.linalg.expm(block * h[:, None, None])
    return (exponential[:, :n, :n], exponential[:, :n, n : n + m],
            exponential[:, :n, n + m :] / h[:, None, None])


def propagate(F: np.ndarray, G: np.ndarray, times: np.ndarray, signal: np.ndarray,
              linear: np.ndarray, start: np.ndarray | None = None) -> np.ndarray:
    """States at every stamp of ``x' = F x + G v``, from ``start`` (zero) at the first stamp.

    Parameters
    ----------
    F : ndarray, shape (n, n)
    G : ndarray, shape (n, m)
    times : ndarray, shape (N,)
        Strictly increasing stamps (one segment).
    signal : ndarray, shape (N, m, c)
        ``c`` independent driving signals (the columns share ``F`` and ``G``).
    linear : ndarray of bool, shape (m, c)
        Which entries are linear between samples; the others are held.
    start : ndarray, shape (n, c), optional
        State of each column at the first stamp; zero by default.

    Returns
    -------
    ndarray, shape (N, n, c)
    """
    N, m, c = signal.shape
    n = F.shape[0]
    first = np.zeros((n, c)) if start is None else np.asarray(start, dtype=float).reshape(n, c)
    out = np.zeros((N, n, c))
    if n == 0:
        return out
    out[0] = first
    if N < 2:
        return out
    # the start enters the sums as the drive of a step before the first stamp
    steps = np.diff(times)
    slope = np.where(linear, np.diff(signal, axis=0), 0.0)                       # (K, m, c)
    if is_regular(steps):
        Phi, gamma0, gamma1 = (part[0] for part in interval_maps(F, G, np.array([np.median(steps)])))
        drive = np.einsum("nm,kmc->nkc", gamma0, signal[:-1]) + np.einsum("nm,kmc->nkc", gamma1, slope)
        return _sum_constant(Phi, np.concatenate([first[:, None], drive], axis=1)).transpose(1, 0, 2)
    values, vectors = np.linalg.eig(F)
    if np.linalg.cond(vectors) <= MODAL_CONDITION:
        return _modal(values, vectors, G, steps, signal[:-1], slope, first=first)
    Phi, gamma0, gamma1 = interval_maps(F, G, steps)
    drive = gamma0 @ signal[:-1] + gamma1 @ slope                                 # (K, n, c)
    return _sum_varying(np.concatenate([np.zeros((1, n, n)), Phi]), np.concatenate([first[None], drive]))


@np.errstate(over="ignore", invalid="ignore")   # an unstable map's overflow is reported as inf
def _sum_constant(Phi: np.ndarray, drive: np.ndarray) -> np.ndarray:
    """``x_k = sum_{i <= k} Phi^(k-i) drive_i`` along axis 1 of ``drive`` (n, K, c)."""
    n, K, c = drive.shape
    total = drive.copy()
    power, span = Phi.copy(), 1
    scale = np.max(np.abs(Phi)) if Phi.size else 0.0
    while span < K and np.max(np.abs(power)) > NEGLIGIBLE * max(scale, 1.0):
        if not np.all(np.isfinite(power)):
            # an unstable map overflowed: the states it reaches are not finite
            total[:, span:] = np.inf
            break
        reach = (power @ total[:, : K - span].reshape(n, -1)).reshape(n, K - span, c)
        total[:, span:] += reach
        power = power @ power
        span *= 2
    return total


def _sum_varying(Phi: np.ndarray, drive: np.ndarray) -> np.ndarray:
    """``x_k = Phi_k x_(k-1) + drive_k``, ``x_(-1) = 0``: (K, n, n), (K, n, c) -> (K, n, c)."""
    K = drive.shape[0]
    total, carry, span = drive.copy(), Phi.copy(), 1
    while span < K:
        total[span:] += carry[span:] @ total[:-span]
        carry[span:] = carry[span:] @ carry[:-span]
        span *= 2
    return total


def _phi_functions(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``phi_1 = (e^x - 1)/x`` and ``phi_2 = (e^x - 1 - x)/x^2``, accurate near 0."""
    small = np.abs(x) < SERIES_BELOW
    safe = np.where(small, 1.0, x)
    phi1 = np.where(small, 1 + x / 2 + x**2 / 6 + x**3 / 24, np.expm1(safe) / safe)
    phi2 = np.where(small, 0.5 + x / 6 + x**2 / 24 + x**3 / 120, (np.expm1(safe) - safe) / safe**2)
    return phi1, phi2


def _modal(values: np.ndarray, vectors: np.ndarray, G: np.ndarray, steps: np.ndarray,
           held: np.ndarray, slope: np.ndarray, *, first: np.ndarray) -> np.ndarray:
    """The varying recursion in ``F``'s eigenvector coordinates: each mode a scalar one."""
    x = values[:, None] * steps[None, :]                                            # (n, K)
    phi1, phi2 = _phi_functions(x)
    inputs = np.linalg.solve(vectors, G.astype(complex))                            # (n, m)
    drive = (steps * phi1)[:, :, None] * np.einsum("nm,kmc->nkc", inputs, held) \
        + (steps * phi2)[:, :, None] * np.einsum("nm,kmc->nkc", inputs, slope)      # (n, K, c)
    initial = np.linalg.solve(vectors, first.astype(complex))[:, None]              # (n, 1, c)
    total = np.concatenate([initial, drive], axis=1)
    carry = np.concatenate([np.zeros((values.size, 1), complex), np.exp(x)], axis=1)
    span, K = 1, total.shape[1]
    while span < K:
        total[:, span:] += carry[:, span:, None] * total[:, :-span]
        carry[:, span:] = carry[:, span:] * carry[:, :-span]
        span *= 2
    return np.real(np.einsum("in,nkc->kic", vectors, total))
