"""The frequency-domain subspace start (McKelvey, Akçay and Ljung 1996): A and C per order, then B and D.

On the unit circle, ``G_k = C (z_k I - A)^-1 B + D`` stacked over ``q`` powers of ``z_k``
reads ``𝒢 = O X + Γ 𝒲``: ``𝒢`` holds ``z_k^i G_k`` (block rows i = 0..q-1, one column
block per line), ``𝒲`` the same powers times ``I_m``, ``O = [C; C A; ...; C A^(q-1)]`` the
extended observability matrix and ``X`` the lines' states. Real and imaginary parts side
by side keep ``A, B, C, D`` real. Projecting ``𝒲``'s row space out of ``𝒢`` (the LQ
factor of ``[𝒲; 𝒢]``) leaves ``O X`` projected, whose ``n`` leading left singular vectors
span ``O``: ``C`` is their first block row and ``A`` solves the shift ``O_up A = O_down``.
With ``A`` and ``C`` fixed, ``G_k`` is linear in ``B`` and ``D``: a weighted least squares.

Continuous-time data are mapped to the unit circle first by the bilinear map
``z = (1 + s) / (1 - s)`` (``s`` in units of the data's centre frequency, so that the lines
spread over the circle); a model ``(A_d, C_d)`` there is ``A = (A_d + I)^-1 (A_d - I)``,
``C = C_d (A_d + I)^-1`` in ``s``, up to a similarity (``B`` and ``D`` are then fitted in
``s`` itself).
"""

from __future__ import annotations

import numpy as np

from ...numerics.triangular import TALL_QR_BLOCK, fold

__all__ = ["observability_basis", "poles_and_output", "input_and_feedthrough", "bilinear_points", "LINE_BLOCK"]

# Eigenvector bases up to this condition number give C (s I - A)^-1 through the eigenvalues, F p n^2
# products instead of F pencils of n x n solved: their round-off, cond times eps (2e-8 at most), is
# far below any fit's, and B and D are refined after. Worse bases (poles about to merge) are solved.
MAX_EIGENVECTOR_CONDITION = 1e8
# Lines folded into the triangular factors at a time: a block's real rows (2 x 1024 x m or p)
# stay within a few megabytes.
LINE_BLOCK = 1024


def bilinear_points(s: np.ndarray) -> np.ndarray:
    """``z = (1 + s) / (1 - s)``: the imaginary axis onto the unit circle (``s = j`` to ``z = j``)."""
    return (1 + s) / (1 - s)


def observability_basis(z: np.ndarray, G: np.ndarray, line_weights: np.ndarray, block_rows: int) -> np.ndarray:
    """Left singular vectors of the projected ``𝒢`` (columns by decreasing singular value), shape (q p, q p).

    ``line_weights`` scales each line's columns of ``𝒢`` and ``𝒲`` alike (which keeps
    ``𝒢 = O X + Γ 𝒲``), so that each line counts by its precision. The triangular factor of
    ``[𝒲; 𝒢]^T`` is folded :data:`LINE_BLOCK` lines at a time: memory does not grow with the lines.
    """
    F, p, m = G.shape
    triangle = None
    for start in range(0, F, LINE_BLOCK):
        part = slice(start, start + LINE_BLOCK)
        lines = z[part].size
        powers = z[None, part] ** np.arange(block_rows)[:, None] * line_weights[None, part]          # (q, Fb)
        response = (powers[:, None, :, None] * G[part].transpose(1, 0, 2)[None]).reshape(block_rows * p, lines * m)
        inputs = (powers[:, None, :, None] * np.eye(m)[None, :, None, :]).reshape(block_rows * m, lines * m)
        stacked = np.concatenate([inputs, response])
        triangle = fold(triangle, np.concatenate([stacked.real, stacked.imag], axis=1), TALL_QR_BLOCK)
    lower = np.zeros((block_rows * (m + p),) * 2)
    lower[:, : triangle.shape[0]] = triangle.T                                 # [𝒲; 𝒢] = L Q
    projected = lower[block_rows * m:, block_rows * m:]
    basis, _, _ = np.linalg.svd(projected)
    return basis


def poles_and_output(basis: np.ndarray, order: int, p: int) -> tuple[np.ndarray, np.ndarray]:
    """``A`` and ``C`` of ``order`` states from the shift invariance of the observability basis."""
    span = basis[:, :order]
    A = np.linalg.lstsq(span[:-p], span[p:], rcond=None)[0]
    return A, span[:p].copy()


def input_and_feedthrough(A: np.ndarray, C: np.ndarray, points: np.ndarray, G: np.ndarray, weights: np.ndarray,
                          feedthrough: bool) -> tuple[np.ndarray, np.ndarray]:
    """``B`` and ``D`` minimizing ``sum_k |w_k (C (s_k I - A)^-1 B + D - G_k)|^2`` for fixed ``A``, ``C``.

    ``weights`` (F, p, m) weigh each entry; each input's column is its own least squares
    (the weights differ between columns, the regressors do not), its ``[X | y]`` folded
    :data:`LINE_BLOCK` lines at a time.
    """
    n, p, m = A.shape[0], C.shape[0], G.shape[2]
    unknowns = n + (p if feedthrough else 0)
    triangles: list[np.ndarray | None] = [None] * m
    values, vectors = np.linalg.eig(A)
    diagonal = n > 0 and np.linalg.cond(vectors) <= MAX_EIGENVECTOR_CONDITION
    if diagonal:
        left, right = C @ vectors, np.linalg.inv(vectors)
    for start in range(0, points.size, LINE_BLOCK):
        part = slice(start, start + LINE_BLOCK)
        s = points[part]
        if diagonal:                        # C (s I - A)^-1 = C V diag(1 / (s - lambda)) V^-1
            output_map = (left / (s[:, None, None] - values)) @ right
        else:                               # one solve of the transposed pencil per line
            pencil = s[:, None, None] * np.eye(n) - A
            output_map = np.linalg.solve(pencil.transpose(0, 2, 1),
                                         np.broadcast_to(C.T, (s.size, n, p))).transpose(0, 2, 1)
        regressors = output_map if not feedthrough else np.concatenate(
            [output_map, np.broadcast_to(np.eye(p), (s.size, p, p))], axis=2)
        for j in range(m):
            rows = np.concatenate([regressors, G[part, :, j, None]], axis=2) * weights[part, :, j, None]
            rows = rows.reshape(-1, unknowns + 1)
            triangles[j] = fold(triangles[j], np.concatenate([rows.real, rows.imag]).T, TALL_QR_BLOCK)
    B, D = np.zeros((n, m)), np.zeros((p, m))
    for j, triangle in enumerate(triangles):
        solution = np.linalg.lstsq(triangle[:, :unknowns], triangle[:, unknowns], rcond=None)[0]
        B[:, j] = solution[:n]
        if feedthrough:
            D[:, j] = solution[n:]
    return B, D
