"""Fast simulation of (batches of) discrete-time state-space models.

A per-sample Python loop costs microseconds per step. Here the record is cut into
blocks of ``L`` samples and each block's output is ``O_L x_b + H_L u_b`` (the
extended observability matrix and the block Toeplitz matrix of Markov
parameters), so Python iterates about ``L + N / L`` times and the rest is batched
matrix products. Cost and memory stay linear in ``N``.
"""

from __future__ import annotations

import math
from typing import Iterator

import numpy as np
from numpy.lib.stride_tricks import as_strided

__all__ = ["simulate_batch", "free_response", "state_responses"]

# The first length free_response(..., negligible=...) tries, doubled until the response has decayed
DECAY_START = 4096


def _block_length(N: int) -> int:
    # The Toeplitz product costs N L per model and the loops L + N / L steps. The
    # round-off of the block form grows with L on non-normal models (an observer form
    # with transient growth 6e6 lost 4e-4 of its output at L = 22, 4e-5 at L = 11, to
    # a plain recursion): sqrt(N) / 2 keeps it small at about the same speed.
    return int(min(max(0.5 * math.sqrt(N), 4), 64))


def _block_toeplitz(markov: np.ndarray) -> np.ndarray:
    """Transposed lower block Toeplitz matrices ``T[r, (j, c), (i, a)] = markov[i - 1 - j, r, a, c]``.

    Zero for ``j >= i``; ``markov`` has shape (L, R, p, m), the result (R, L m, L p),
    so that a block row of inputs times it is a block row of outputs. Row ``(j, c)``
    of ``T[r]`` is a contiguous slice of ``[0, ..., 0, markov[0], ..., markov[L-1]]``
    (input ``c``, entries ``(i, a)``), so the matrix is a strided view of that
    sequence copied once.
    """
    L, R, p, m = markov.shape
    sequence = np.zeros((R, m, 2 * L, p))
    sequence[:, :, L:] = markov.transpose(1, 3, 0, 2)
    s_r, s_c, s_k, s_a = sequence.strides
    # row j starts at position L - 1 - j: a negative stride along j from position L - 1
    view = as_strided(
        sequence[:, :, L - 1 :], (R, L, m, L, p), (s_r, -s_k, s_c, s_k, s_a), writeable=False
    )
    # always a C-ordered copy: a strided operand takes numpy's slow product path
    return np.ascontiguousarray(view).reshape(R, L * m, L * p)


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
        powers = _powers(A, L)
        CA = C[None] @ powers[:L]                       # (L, R, p, n)
        markov = CA @ B[None]                           # (L, R, p, m): C A^k B
        AB = powers[:L] @ B[None]                       # (L, R, n, m): A^k B
        obs = np.ascontiguousarray(CA.transpose(1, 3, 0, 2)).reshape(R, n, L * p)
        reach = AB[::-1].transpose(1, 2, 0, 3).reshape(R, n, L * m)   # [A^{L-1}B ... B]
        y = ub @ _block_toeplitz(markov)                               # (R, nb, L p)
        states = _block_states(powers[L], ub @ reach.transpose(0, 2, 1), x0, R, n)
        # in place: a second record-sized temporary costs more than the product
        y += states @ obs
    return y.reshape(R, nb * L, p)[:, :N]


def _powers(A: np.ndarray, L: int) -> np.ndarray:
    """``A^k``, k = 0..L, of a batch ``A`` (R, n, n): shape (L + 1, R, n, n).

    One product at a time: squaring (doubling) loses many digits on the strongly
    non-normal observer forms MOLI can produce.
    """
    powers = np.empty((L + 1,) + A.shape)
    powers[0] = np.eye(A.shape[-1])
    for k in range(L):
        np.matmul(powers[k], A, out=powers[k + 1])
    return powers


def _block_states(step: np.ndarray, drive: np.ndarray, x0: np.ndarray | None, R: int, n: int) -> np.ndarray:
    """States ``x_b`` at the block starts of ``x_{b+1} = P x_b + d_b`` (``P = A^L``).

    Block by block: a scan by doubling would need powers of ``P`` by squaring, which
    on strongly non-normal models amplifies round-off by the square of their transient
    growth.
    """
    nb = drive.shape[1]
    # blocks first, so that each step reads and writes whole (R, 1, n) blocks taken
    # from prebuilt lists: the loop costs Python a call per product, not the slicing
    states = np.empty((nb, R, 1, n))
    states[0] = 0.0 if x0 is None else np.asarray(x0, float).reshape(R, 1, n)
    blocks = list(states)
    drives = list(np.ascontiguousarray(drive.transpose(1, 0, 2)).reshape(nb, R, 1, n))
    step = step.transpose(0, 2, 1)                      # acts on row vectors: x P^T
    carry = np.empty((R, 1, n))
    for b in range(nb - 1):
        np.matmul(blocks[b], step, out=carry)
        np.add(carry, drives[b], out=blocks[b + 1])
    return np.ascontiguousarray(states.reshape(nb, R, n).transpose(1, 0, 2))


def free_response(A: np.ndarray, C: np.ndarray, N: int, negligible: float | None = None) -> np.ndarray:
    """Responses ``C A^k e_i`` to each unit initial state, shape (N, p, n).

    With ``negligible``, only the first ``K <= N`` samples: ``K`` is the first of 4096,
    8192, ... (or ``N``) at which the response has decayed below ``negligible`` times its
    largest entry, so that a long record does not simulate (nor later factor) samples
    that hold nothing but round-off, or subnormal numbers.
    """
    K = N if negligible is None else min(N, DECAY_START)
    while True:
        y = _powers_response(A, C, K)
        if K == N or np.max(np.abs(y[-1])) <= negligible * np.max(np.abs(y)):
            return y
        K = min(2 * K, N)


def _powers_response(A: np.ndarray, C: np.ndarray, N: int) -> np.ndarray:
    """``C A^k``, k < N, shape (N, p, n): ``C A^i`` for the ``L`` samples of a block times ``A^(bL)``.

    One model's powers, block by block (``A^((b+1)L) = A^(bL) A^L`` by one product each, not
    by squaring, for the non-normal forms' sake as in :func:`_block_states`): simulating
    the ``n`` unit starts as a batch of ``n`` models repeated each power ``n`` times.
    """
    n, p = A.shape[0], C.shape[0]
    L = _block_length(N)
    nb = -(-N // L)
    out = np.empty((nb, L * p, n))
    with np.errstate(all="ignore"):
        powers = _powers(A[None], L)[:, 0]                                   # (L + 1, n, n)
        within = (C @ powers[:L]).reshape(L * p, n)                          # C A^i, i < L
        start = np.eye(n)
        for b in range(nb):
            np.matmul(within, start, out=out[b])
            start = start @ powers[L]
    return out.reshape(nb * L, p, n)[:N]


def state_responses(A: np.ndarray, C: np.ndarray, signals: np.ndarray) -> Iterator[tuple[int, np.ndarray]]:
    """Responses ``C (qI - A)^-1 e_a v_c`` of each signal ``v_c`` injected into each state ``a``.

    One signal at a time: yields ``(c, S_c)`` with ``S_c[t, :, a]`` the response to
    signal ``c`` through state ``a``, shape (N, p, n), computed when asked for (all ``k``
    signals at once would hold ``N p n k`` values, many times the record's). ``S_c[0]`` is
    zero: ``(qI - A)^-1`` delays by one sample.

    In blocks of ``L`` samples, as :func:`simulate_batch`: the state matrix ``X`` (n, n)
    of ``X_{t+1} = A X_t + v_c(t) I`` at the block starts comes from the block recursion
    of its columns, those of every signal at once, and each block's responses are a
    Toeplitz product of its samples by ``C A^k`` plus ``C A^i X_b``.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    C : ndarray, shape (p, n)
    signals : ndarray, shape (N, k)
    """
    n, p = A.shape[0], C.shape[0]
    N, k = signals.shape
    L = _block_length(N)
    nb = -(-N // L)
    padded = np.zeros((nb * L, k))
    padded[:N] = signals
    blocks = np.ascontiguousarray(padded.reshape(nb, L, k).transpose(2, 0, 1))    # (k, nb, L)
    with np.errstate(all="ignore"):
        powers = _powers(A[None], L)[:, 0]                                       # (L + 1, n, n)
        markov = C @ powers[:L]                                                  # (L, p, n): C A^i
        toeplitz = _block_toeplitz(markov.reshape(L, 1, p * n, 1))[0]            # (L, L p n)
        # X_{b+1} = A^L X_b + sum_j v(bL + j) A^(L-1-j), for each signal
        drives = (blocks @ powers[L - 1 :: -1].reshape(L, n * n)).reshape(k, nb, n, n)
        # every signal's X side by side, (n, k n): one product by A^L per block for all of them
        drive_rows = list(np.ascontiguousarray(drives.transpose(1, 2, 0, 3)).reshape(nb, n, k * n))
        stacked = np.empty((nb, n, k * n))
        stacked[0] = 0.0
        blocks_x = list(stacked)
        for b in range(nb - 1):
            np.matmul(powers[L], blocks_x[b], out=blocks_x[b + 1])
            blocks_x[b + 1] += drive_rows[b]
        states = np.ascontiguousarray(stacked.reshape(nb, n, k, n).transpose(2, 0, 1, 3))   # (k, nb, n, n): X_b
        observability = markov.reshape(L * p, n)

        def responses() -> Iterator[tuple[int, np.ndarray]]:
            for c in range(k):
                within = (blocks[c] @ toeplitz).reshape(nb, L * p, n)
                within += observability @ states[c]
                yield c, within.reshape(nb * L, p, n)[:N]

        return responses()
