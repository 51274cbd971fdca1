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
parts as separate rows. Lines are taken :data:`LINE_CHUNK` at a time, and only the
triangular factor of ``[J | r]`` (size x size) is kept: memory does not grow with the lines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...numerics.triangular import fold
from .modal_form import ModalLayout, split

__all__ = ["FitProblem", "LINE_CHUNK", "response", "cost", "factor", "score_spread"]

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
    F, p, m, n, c = P.shape[0], layout.p, layout.m, layout.n, layout.pairs
    pair_P, pair_Q = P[:, :, :2 * c].reshape(F, p, c, 2), Q[:, :2 * c].reshape(F, c, 2, m)
    parts = [
        np.einsum("fpck,fckm->fpmc", pair_P, pair_Q),
        np.einsum("fpc,fcm->fpmc", pair_P[..., 0], pair_Q[:, :, 1]) - np.einsum(
            "fpc,fcm->fpmc", pair_P[..., 1], pair_Q[:, :, 0]),
        np.einsum("fpr,frm->fpmr", P[:, :, 2 * c:], Q[:, 2 * c:]),
        np.einsum("fpk,jl->fpjkl", P, np.eye(m)).reshape(F, p, m, n * m),
        np.einsum("ai,fkm->famik", np.eye(p), Q).reshape(F, p, m, p * n),
    ]
    if layout.feedthrough:
        unit = (np.eye(p)[:, None, :, None] * np.eye(m)[None, :, None, :]).reshape(p, m, p * m)
        parts.append(np.broadcast_to(unit, (F, p, m, p * m)))
    return np.concatenate(parts, axis=3)


def _weighted(layout: ModalLayout, theta: np.ndarray, problem: FitProblem, part: slice) -> tuple[np.ndarray, ...]:
    P, Q, model = _resolvent_products(layout, theta, problem.points[part])
    weights = problem.weights[part]
    return _jacobian(layout, P, Q) * weights[..., None], weights * (model - problem.G[part])


def factor(layout: ModalLayout, theta: np.ndarray, problem: FitProblem) -> tuple[np.ndarray, np.ndarray, float]:
    """``R`` and ``q`` with ``|J d + r|^2 = |R d + q|^2 + const`` (one pass), and the cost ``|r|^2``."""
    triangle, total = None, 0.0
    for start in problem.chunks():
        jacobian, residual = _weighted(layout, theta, problem, slice(start, start + LINE_CHUNK))
        rows = np.concatenate([jacobian.reshape(-1, layout.size), residual.reshape(-1, 1)], axis=1)
        triangle = fold(triangle, np.concatenate([rows.real, rows.imag]).T, 16)
        total += float(np.sum(np.abs(residual) ** 2))
    size = layout.size
    R = np.zeros((size, size))
    q = np.zeros(size)
    kept = min(triangle.shape[0], size)
    R[:kept] = triangle[:kept, :size]
    q[:kept] = triangle[:kept, size]
    return R, q, total


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
