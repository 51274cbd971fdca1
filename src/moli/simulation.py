"""Fast simulation of (batches of) discrete-time state-space models.

A per-sample Python loop costs microseconds per step. Here the record is cut into
blocks of ``L`` samples and each block's output is ``O_L x_b + H_L u_b`` (the
extended observability matrix and the block Toeplitz matrix of Markov
parameters), so Python iterates about ``2 sqrt(N)`` times and the rest is
matrix products. Cost and memory stay linear in ``N``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.lib.stride_tricks import as_strided


def _block_length(N: int) -> int:
    return int(min(max(math.sqrt(N), 4), 64))


def _block_toeplitz(markov: np.ndarray) -> np.ndarray:
    """Lower block Toeplitz matrices ``T[r, (i, a), (j, c)] = markov[i - 1 - j, r, a, c]``.

    Zero for ``j >= i``; ``markov`` has shape (L, R, p, m), the result (R, L p, L m).
    Row ``(i, a)`` of ``T[r]`` is a contiguous slice of ``[markov[L-1], ..., markov[0],
    0, ..., 0]`` (channel ``a``, entries ``(j, c)``), so the matrix is a strided view of
    that sequence copied once.
    """
    L, R, p, m = markov.shape
    sequence = np.zeros((R, p, 2 * L, m))
    sequence[:, :, :L] = markov[::-1].transpose(1, 2, 0, 3)
    s_r, s_a, s_k, s_c = sequence.strides
    # row i starts at position L - i: a negative stride along i from position L
    view = as_strided(
        sequence[:, :, L:], (R, L, p, L, m), (s_r, -s_k, s_a, s_k, s_c), writeable=False
    )
    # always a C-ordered copy: reshape keeps the strided view when p = 1, and the
    # product with such a view takes another path with different rounding
    return np.ascontiguousarray(view).reshape(R, L * p, L * m)


def simulate_batch(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, u: np.ndarray, x0: np.ndarray | None = None
) -> np.ndarray:
    """Outputs of ``x_{k+1} = A x_k + B u_k, y_k = C x_k`` for a batch of models.

    Parameters
    ----------
    A, B, C : ndarray, shapes (R, n, n), (R, n, m), (R, p, n)
        ``R`` models of the same dimensions.
    u : ndarray, shape (N, m)
        Input shared by the batch.
    x0 : ndarray, shape (R, n), optional
        Initial states; zero by default.

    Returns
    -------
    ndarray, shape (R, N, p)
        Unstable models may produce inf or NaN; no warning is raised here.
    """
    R, n, _ = A.shape
    p, m = C.shape[1], B.shape[2]
    N = u.shape[0]
    L = _block_length(N)
    nb = -(-N // L)
    ub = np.zeros((nb * L, m))
    ub[:N] = u
    ub = ub.reshape(nb, L * m)
    with np.errstate(all="ignore"):
        # powers[k] = A^k, k = 0..L
        powers = np.empty((L + 1, R, n, n))
        powers[0] = np.eye(n)
        for k in range(L):
            np.matmul(powers[k], A, out=powers[k + 1])
        CA = C[None] @ powers[:L]                       # (L, R, p, n)
        markov = CA @ B[None]                           # (L, R, p, m): C A^k B
        AB = powers[:L] @ B[None]                       # (L, R, n, m): A^k B
        obs = CA.transpose(1, 0, 2, 3).reshape(R, L * p, n)
        toeplitz = _block_toeplitz(markov)
        reach = AB[::-1].transpose(1, 2, 0, 3).reshape(R, n, L * m)   # [A^{L-1}B ... B]
        forced = ub @ toeplitz.transpose(0, 2, 1)                      # (R, nb, L p)
        drive = ub @ reach.transpose(0, 2, 1)                          # (R, nb, n)
        step = powers[L].transpose(0, 2, 1)
        states = np.empty((R, nb, n))                                  # x at each block start
        states[:, 0] = 0.0 if x0 is None else np.asarray(x0, float).reshape(R, n)
        carry = np.empty((R, 1, n))
        for b in range(nb - 1):
            np.matmul(states[:, b : b + 1], step, out=carry)
            np.add(carry, drive[:, b : b + 1], out=states[:, b + 1 : b + 2])
        y = forced + states @ obs.transpose(0, 2, 1)
    return y.reshape(R, nb * L, p)[:, :N]


def free_response(A: np.ndarray, C: np.ndarray, N: int) -> np.ndarray:
    """Responses ``C A^k e_i`` to each unit initial state, shape (N, p, n)."""
    n = A.shape[0]
    y = simulate_batch(
        np.broadcast_to(A, (n, n, n)), np.zeros((n, n, 1)), np.broadcast_to(C, (n,) + C.shape),
        np.zeros((N, 1)), x0=np.eye(n),
    )
    return y.transpose(1, 2, 0)
