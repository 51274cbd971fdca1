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
parts as separate rows. ``G_ij`` depends on the poles, ``B[:, j]``, ``C[i, :]`` and ``D[i, j]``
only, so its rows are formed on those columns alone (:func:`entry_parameters`). Lines are
taken :data:`LINE_CHUNK` at a time, and only ``J^T J`` and ``J^T r`` (size x size) are kept:
memory does not grow with the lines.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from .modal_form import ModalLayout, split

__all__ = ["FitProblem", "LINE_CHUNK", "response", "cost", "entry_parameters", "normal_equations", "score_spread",
           "weighted_jacobian"]

# Lines per pass block: the (chunk, p, m, poles) pole derivatives and an entry's (chunk, 3 n + 1) rows
# stay within a few megabytes.
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


def _pole_derivatives(layout: ModalLayout, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``dG / d(sigma, omega, lambda)`` on a block of lines, shape (F, p, m, poles), complex."""
    F, c = P.shape[0], layout.pairs
    out = np.empty((F, layout.p, layout.m, layout.poles), dtype=complex)
    first, second = P[:, :, None, 0:2 * c:2], P[:, :, None, 1:2 * c:2]                          # (F, p, 1, c)
    upper = Q[:, 0:2 * c:2].transpose(0, 2, 1)[:, None]                                          # (F, 1, m, c)
    lower = Q[:, 1:2 * c:2].transpose(0, 2, 1)[:, None]
    out[..., :c] = first * upper + second * lower                                              # P_i Q_i
    out[..., c:2 * c] = first * lower - second * upper                                         # P_i J Q_i
    out[..., 2 * c:] = P[:, :, None, 2 * c:] * Q[:, 2 * c:].transpose(0, 2, 1)[:, None]
    return out


def entry_parameters(layout: ModalLayout) -> list[tuple[int, int, np.ndarray]]:
    """``(i, j, columns)`` per output ``i`` and input ``j``: the entries of theta that move ``G_ij``.

    They are the poles, ``B[:, j]``, ``C[i, :]`` and ``D[i, j]``, ``3 n + 1`` of the
    ``n (1 + m + p) + p m``; the Jacobian's other entries in ``G_ij``'s rows are zero.
    """
    n, p, m, poles = layout.n, layout.p, layout.m, layout.poles
    out = []
    for i in range(p):
        for j in range(m):
            columns = [np.arange(poles), poles + m * np.arange(n) + j, poles + n * m + i * n + np.arange(n)]
            if layout.feedthrough:
                columns.append(np.array([poles + n * m + p * n + i * m + j]))
            out.append((i, j, np.concatenate(columns)))
    return out


def _entry_columns(layout: ModalLayout, P: np.ndarray, Q: np.ndarray) -> Iterator[tuple[int, int, np.ndarray, np.ndarray]]:
    """Per output/input entry on a block of lines: ``(i, j, columns, dG_ij / d theta[columns])``, complex, unweighted."""
    poles = _pole_derivatives(layout, P, Q)
    lines = P.shape[0]
    for i, j, columns in entry_parameters(layout):
        block = np.empty((lines, columns.size), dtype=complex)
        block[:, :layout.poles] = poles[:, i, j]
        block[:, layout.poles:layout.poles + layout.n] = P[:, i]
        block[:, layout.poles + layout.n:layout.poles + 2 * layout.n] = Q[:, :, j]
        if layout.feedthrough:
            block[:, -1] = 1.0
        yield i, j, columns, block


def _entry_blocks(layout: ModalLayout, theta: np.ndarray, problem: FitProblem,
                  part: slice) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per output/input entry on a block of lines: its columns of theta, the real rows of the weighted
    Jacobian restricted to them (real parts of the lines, then imaginary) and of the weighted residual."""
    P, Q, model = _resolvent_products(layout, theta, problem.points[part])
    weights = problem.weights[part]
    residual = weights * (model - problem.G[part])
    for i, j, columns, block in _entry_columns(layout, P, Q):
        block *= weights[:, i, j, None]
        yield (columns, np.concatenate([block.real, block.imag]),
               np.concatenate([residual[:, i, j].real, residual[:, i, j].imag]))


def normal_equations(layout: ModalLayout, theta: np.ndarray,
                     problem: FitProblem) -> tuple[np.ndarray, np.ndarray, float]:
    """``J^T J``, ``J^T r`` (real and imaginary rows together) and the cost ``|r|^2``, in one pass over the lines.

    Each entry ``G_ij``'s rows enter through the ``3 n + 1`` parameters that move it
    (:func:`entry_parameters`): ``(3 n + 1)^2`` products per row instead of a dense row's
    ``(n (1 + m + p) + p m)^2``, a quarter of them at two inputs and three outputs. The size x size
    products are all that is kept; a step's accuracy needs no more, as the residual of the
    fit, not the step's round-off, sets the estimate (the steps continue until the cost
    stops falling).
    """
    entries = entry_parameters(layout)
    blocks = [np.zeros((columns.size, columns.size)) for _, _, columns in entries]
    gradients = [np.zeros(columns.size) for _, _, columns in entries]
    total = 0.0
    for start in problem.chunks():
        part = slice(start, start + LINE_CHUNK)
        for k, (_, rows, residual) in enumerate(_entry_blocks(layout, theta, problem, part)):
            blocks[k] += rows.T @ rows
            gradients[k] += rows.T @ residual
            total += float(residual @ residual)
    curvature, gradient = np.zeros((layout.size, layout.size)), np.zeros(layout.size)
    for (_, _, columns), block, part in zip(entries, blocks, gradients):
        curvature[np.ix_(columns, columns)] += block
        gradient[columns] += part
    return curvature, gradient, total


def score_spread(layout: ModalLayout, theta: np.ndarray, problem: FitProblem) -> np.ndarray:
    """``sum_k s_k s_k^T`` of the lines' scores ``s_k = J_k^T r_k`` (the sandwich's meat), shape (size, size).

    The lines' errors are independent of one another (each line its own DFT bin or
    measurement), so no lag of the scores enters; their spread, not ``sigma^2 J^T J``, also
    holds where the given variances are off by a factor or a model error remains.
    """
    meat = np.zeros((layout.size, layout.size))
    for start in problem.chunks():
        part = slice(start, start + LINE_CHUNK)
        lines = problem.points[part].size
        scores = np.zeros((lines, layout.size))
        for columns, rows, residual in _entry_blocks(layout, theta, problem, part):
            products = rows * residual[:, None]
            scores[:, columns] += products[:lines] + products[lines:]
        meat += scores.T @ scores
    return meat


def weighted_jacobian(layout: ModalLayout, theta: np.ndarray, problem: FitProblem,
                      part: slice) -> tuple[np.ndarray, np.ndarray]:
    """The weighted Jacobian (lines, p, m, size), complex, and residual (lines, p, m) on the lines ``part``,
    for fits that add parameters of their own (:mod:`moli.method.frequency.delays`)."""
    P, Q, model = _resolvent_products(layout, theta, problem.points[part])
    weights = problem.weights[part]
    jacobian = np.zeros((P.shape[0], layout.p, layout.m, layout.size), dtype=complex)
    for i, j, columns, block in _entry_columns(layout, P, Q):
        jacobian[:, i, j, columns] = block * weights[:, i, j, None]
    return jacobian, weights * (model - problem.G[part])
