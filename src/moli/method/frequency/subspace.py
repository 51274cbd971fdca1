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

__all__ = ["observability_basis", "poles_and_output", "input_and_feedthrough", "bilinear_points"]


def bilinear_points(s: np.ndarray) -> np.ndarray:
    """``z = (1 + s) / (1 - s)``: the imaginary axis onto the unit circle (``s = j`` to ``z = j``)."""
    return (1 + s) / (1 - s)


def observability_basis(z: np.ndarray, G: np.ndarray, line_weights: np.ndarray, block_rows: int) -> np.ndarray:
    """Left singular vectors of the projected ``𝒢`` (columns by decreasing singular value), shape (q p, q p).

    ``line_weights`` scales each line's columns of ``𝒢`` and ``𝒲`` alike (which keeps
    ``𝒢 = O X + Γ 𝒲``), so that each line counts by its precision.
    """
    F, p, m = G.shape
    powers = z[None, :] ** np.arange(block_rows)[:, None] * line_weights[None, :]          # (q, F)
    response = (powers[:, None, :, None] * G.transpose(1, 0, 2)[None]).reshape(block_rows * p, F * m)
    inputs = (powers[:, None, :, None] * np.eye(m)[None, :, None, :]).reshape(block_rows * m, F * m)
    stacked = np.concatenate([inputs, response])
    real = np.concatenate([stacked.real, stacked.imag], axis=1)
    lower = np.linalg.qr(real.T, mode="r").T                                 # [𝒲; 𝒢] = L Q
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
    (the weights differ between columns, the regressors do not).
    """
    n, p, m = A.shape[0], C.shape[0], G.shape[2]
    pencil = points[:, None, None] * np.eye(n) - A
    # C (s I - A)^-1, one solve of the transposed pencil per line
    output_map = np.linalg.solve(pencil.transpose(0, 2, 1), np.broadcast_to(C.T, (points.size, n, p))).transpose(0, 2, 1)
    regressors = output_map if not feedthrough else np.concatenate(
        [output_map, np.broadcast_to(np.eye(p), (points.size, p, p))], axis=2)
    B, D = np.zeros((n, m)), np.zeros((p, m))
    for j in range(m):
        rows = regressors * weights[:, :, j, None]                               # (F, p, n [+ p])
        target = G[:, :, j] * weights[:, :, j]
        X = np.concatenate([rows.real, rows.imag]).reshape(-1, rows.shape[2])
        y = np.concatenate([target.real, target.imag]).ravel()
        solution = np.linalg.lstsq(X, y, rcond=None)[0]
        B[:, j] = solution[:n]
        if feedthrough:
            D[:, j] = solution[n:]
    return B, D
