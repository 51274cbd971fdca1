"""The weighted FRF error of a modal-form model and its analytic Jacobian, one pass over the lines.

With ``R(s) = (s I - A)^-1`` block diagonal (a pair's block ``[[a, b], [-b, a]]``,
``a = (s - sigma) / d``, ``b = omega / d``, ``d = (s - sigma)^2 + omega^2``; a real pole's
``1 / (s - lambda)``), the model's response is ``G(s) = C R(s) B + D`` and, with
``P = C R`` and ``Q = R B``,

- ``dG / d sigma_i = P_i Q_i`` (the pair's two columns of ``P`` and rows of ``Q``),
- ``dG / d omega_i = P_i J Q_i``, ``J = [[0, 1], [-1, 0]]``, ``dG / d lambda_i = P_i Q_i``,
- ``dG / d B_kj`` = column ``j`` of ``P``'s column ``k``; ``dG / d C_ik`` = row ``i`` of
  ``Q``'s row ``k``; ``dG / d D_ij`` = ``e_i e_j'``.

The residual of line ``k`` is ``w_k * (G(s_k) - G_k)`` entry by entry, real and imaginary
parts as separate rows. Lines are taken :data:`LINE_CHUNK` at a time, and only ``J^T J``
and ``J^T r`` (size x size) are kept: memory does not grow with the lines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .modal_form import ModalLayout, split

__all__ = ["FitProblem", "LINE_CHUNK", "response", "cost", "normal_equations", "score_spread", "weighted_jacobian"]

# Lines per pass block: the (chunk, p, m, size) complex Jacobian stays at a few megabytes.
LINE_CHUNK = 256


@dataclass(frozen=True)
class FitProblem:
    """Points ``s_k`` (``1j omega`` scaled, or ``exp(1j omega Ts)``), data ``G`` (F, p, m) and weights (F, p, m)."""

    points: np.ndarray
    G: np.ndarray
    weights: np.ndarray

    def chunks(self) -> range:
        return range(0, self.points.size, LINE_CHUNK)


def _resolvent_products(layout: ModalLayout, theta: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, ...]:
    """``P = C R(s)`` (F, p, n), ``Q = R(s) B`` (F, n, m) and ``G(s)`` (F, p, m)."""
    sigma, omega, lam, B, C, D = split(layout, theta)
    c = layout.pairs
    shifted = s[:, None] - sigma[None, :]
    denominator = shifted**2 + omega[None, :] ** 2
    a, b = shifted / denominator, omega[None, :] / denominator                                   # (F, c)
    real = 1.0 / (s[:, None] - lam[None, :])                                                      # (F, r)
    B0, B1, Br = B[0:2 * c:2], B[1:2 * c:2], B[2 * c:]
    C0, C1, Cr = C[:, 0:2 * c:2], C[:, 1:2 * c:2], C[:, 2 * c:]
    Q = np.empty((s.size, layout.n, layout.m), dtype=complex)
    Q[:, 0:2 * c:2] = a[:, :, None] * B0 + b[:, :, None] * B1
    Q[:, 1:2 * c:2] = -b[:, :, None] * B0 + a[:, :, None] * B1
    Q[:, 2 * c:] = real[:, :, None] * Br
    P = np.empty((s.size, layout.p, layout.n), dtype=complex)
    P[:, :, 0:2 * c:2] = C0 * a[:, None, :] - C1 * b[:, None, :]
    P[:, :, 1:2 * c:2] = C0 * b[:, None, :] + C1 * a[:, None, :]
    P[:, :, 2 * c:] = Cr * real[:, None, :]
    return P, Q, C @ Q + D


def response(layout: ModalLayout, theta: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``G(s)`` at every point, shape (F, p, m)."""
    out = np.empty((points.size, layout.p, layout.m), dtype=complex)
    for start in range(0, points.size, LINE_CHUNK):
        out[start:start + LINE_CHUNK] = _resolvent_products(layout, theta, points[start:start + LINE_CHUNK])[2]
    return out


def cost(layout: ModalLayout, theta: np.ndarray, problem: FitProblem) -> float:
    """``sum_k |w_k (G(s_k) - G_k)|^2``; inf where the model is not finite on the lines."""
    total = 0.0
    for start in problem.chunks():
        part = slice(start, start + LINE_CHUNK)
        model = _resolvent_products(layout, theta, problem.points[part])[2]
        total += float(np.sum(np.abs(problem.weights[part] * (model - problem.G[part])) ** 2))
    return total if np.isfinite(total) else np.inf


def _jacobian(layout: ModalLayout, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``dG / d theta`` on a block of lines, shape (F, p, m, size), complex."""
    F, p, m, n, c, r = P.shape[0], layout.p, layout.m, layout.n, layout.pairs, layout.reals
    out = np.zeros((F, p, m, layout.size), dtype=complex)
    pair_P, pair_Q = P[:, :, :2 * c].reshape(F, p, c, 2), Q[:, :2 * c].reshape(F, c, 2, m)
    out[..., :c] = np.einsum("fpck,fckm->fpmc", pair_P, pair_Q)
    first, second = pair_P[..., 0][:, :, None], pair_P[..., 1][:, :, None]                      # (F, p, 1, c)
    upper, lower = pair_Q[:, :, 0].transpose(0, 2, 1)[:, None], pair_Q[:, :, 1].transpose(0, 2, 1)[:, None]
    out[..., c:2 * c] = first * lower - second * upper                                        # P_i J Q_i
    out[..., 2 * c:2 * c + r] = P[:, :, None, 2 * c:] * Q[:, 2 * c:].transpose(0, 2, 1)[:, None]
    start = layout.poles
    for j in range(m):                      # B[k, j] moves column j by P's column k
        out[:, :, j, start + j: start + n * m: m] = P
    start += n * m
    for i in range(p):                      # C[i, k] moves row i by Q's row k
        out[:, i, :, start + i * n: start + (i + 1) * n] = Q.transpose(0, 2, 1)
    if layout.feedthrough:
        start += p * n
        for i in range(p):
            for j in range(m):
                out[:, i, j, start + i * m + j] = 1.0
    return out


def _weighted(layout: ModalLayout, theta: np.ndarray, problem: FitProblem, part: slice) -> tuple[np.ndarray, ...]:
    P, Q, model = _resolvent_products(layout, theta, problem.points[part])
    weights = problem.weights[part]
    return _jacobian(layout, P, Q) * weights[..., None], weights * (model - problem.G[part])


def normal_equations(layout: ModalLayout, theta: np.ndarray,
                     problem: FitProblem) -> tuple[np.ndarray, np.ndarray, float]:
    """``J^T J``, ``J^T r`` (real and imaginary rows together) and the cost ``|r|^2``, in one pass over the lines.

    The size x size products are all that is kept; a step's accuracy needs no more, as the
    residual of the fit, not the step's round-off, sets the estimate (the steps continue
    until the cost stops falling).
    """
    curvature, gradient, total = np.zeros((layout.size, layout.size)), np.zeros(layout.size), 0.0
    for start in problem.chunks():
        jacobian, residual = _weighted(layout, theta, problem, slice(start, start + LINE_CHUNK))
        rows = jacobian.reshape(-1, layout.size)
        stacked = np.concatenate([rows.real, rows.imag])
        curvature += stacked.T @ stacked
        flat = residual.ravel()
        gradient += stacked.T @ np.concatenate([flat.real, flat.imag])
        total += float(np.sum(np.abs(residual) ** 2))
    return curvature, gradient, total


def score_spread(layout: ModalLayout, theta: np.ndarray, problem: FitProblem) -> np.ndarray:
    """``sum_k s_k s_k^T`` of the lines' scores ``s_k = J_k^T r_k`` (the sandwich's meat), shape (size, size).

    The lines' errors are independent of one another (each line its own DFT bin or
    measurement), so no lag of the scores enters; their spread, not ``sigma^2 J^T J``, also
    holds where the given variances are off by a factor or a model error remains.
    """
    meat = np.zeros((layout.size, layout.size))
    for start in problem.chunks():
        jacobian, residual = _weighted(layout, theta, problem, slice(start, start + LINE_CHUNK))
        scores = np.einsum("fpmt,fpm->ft", jacobian.real, residual.real) + np.einsum(
            "fpmt,fpm->ft", jacobian.imag, residual.imag)
        meat += scores.T @ scores
    return meat


def weighted_jacobian(layout: ModalLayout, theta: np.ndarray, problem: FitProblem,
                      part: slice) -> tuple[np.ndarray, np.ndarray]:
    """The weighted Jacobian (lines, p, m, size), complex, and residual (lines, p, m) on the lines ``part``,
    for fits that add parameters of their own (:mod:`moli.method.frequency.delays`)."""
    return _weighted(layout, theta, problem, part)
