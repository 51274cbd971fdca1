"""Realization: the state-space matrices ``A, B, C`` of fitted observer-form models (docs/method.md §4).

Each output ``j``'s parameters fill a block of the observer form: the filter's companion
block ``A_D``, the output injection ``D_y`` and the input matrix ``B``; ``C`` follows from
the current outputs each output's problem regresses on, by forward substitution.
"""

from __future__ import annotations

import functools
from itertools import accumulate
from typing import Sequence

import numpy as np

from ..structure.indices import Indices

__all__ = ["realize", "filter_companion", "observer_form_matrices"]


def realize(
    thetas: Sequence[np.ndarray], alphas: Sequence[Sequence[np.ndarray]], indices: Indices, m: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """State-space matrices of a batch of fitted observer-form models.

    Parameters
    ----------
    thetas : sequence of ndarray
        Per output ``j``, the parameters of the batch, shape (R, (p+m) l_j + j).
    alphas : sequence of sequences of ndarray
        ``alphas[r][j]`` is candidate ``r``'s divisor for output ``j``.
    indices : tuple of int
    m : int
        Number of inputs.

    Returns
    -------
    A, B, C : ndarray, shapes (R, n, n), (R, n, m), (R, p, n)
    """
    return observer_form_matrices(thetas, alphas, indices, m)[:3]


@functools.lru_cache(maxsize=None)
def _companion_layout(indices: Indices) -> tuple[np.ndarray, tuple[int, ...]]:
    """The ones of the observer form's companion blocks (an ``n x n`` matrix) and each block's start."""
    n = sum(indices)
    starts = tuple(accumulate(indices, initial=0))[:-1]
    shift = np.zeros((n, n))
    for s, l in zip(starts, indices):
        shift[range(s + 1, s + l), range(s, s + l - 1)] = 1.0
    shift.flags.writeable = False
    return shift, starts


def filter_companion(divisors_: Sequence[np.ndarray], indices: Indices) -> np.ndarray:
    """The observer's block companion matrices ``A_D`` of a batch of per-output filters.

    ``divisors_[j]`` holds output ``j``'s monic filter polynomial of each model, shape
    (R, l_j + 1); the result has shape (R, n, n).
    """
    shift, starts = _companion_layout(tuple(indices))
    A_D = np.empty((divisors_[0].shape[0],) + shift.shape)
    A_D[:] = shift
    for alpha_j, l, s in zip(divisors_, indices, starts):
        A_D[:, s : s + l, s + l - 1] = -alpha_j[:, :0:-1]
    return A_D


def observer_form_matrices(
    thetas: Sequence[np.ndarray], alphas: Sequence[Sequence[np.ndarray]], indices: Indices, m: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`realize`, and the output injection ``D_y`` with ``A = A_D + D_y C``.

    Returns
    -------
    A, B, C, D_y : ndarray, shapes (R, n, n), (R, n, m), (R, p, n), (R, n, p)
    """
    p = len(indices)
    R = thetas[0].shape[0]
    n = sum(indices)
    A_D = filter_companion([np.array([alpha[j] for alpha in alphas]) for j in range(p)], indices)
    D = np.empty((R, n, p))
    B = np.empty((R, n, m))
    C = np.zeros((R, p, n))
    for j, (l, s) in enumerate(zip(indices, _companion_layout(tuple(indices))[1])):
        block = slice(s, s + l)
        coeffs = thetas[j][:, : (p + m) * l].reshape(R, p + m, l).transpose(0, 2, 1)
        D[:, block] = coeffs[:, :, :p]
        B[:, block] = coeffs[:, :, p:]
        # (I - G) C = C_D with G strictly lower triangular: forward substitution
        C[:, j, s + l - 1] = 1.0
        if j:
            C[:, j] += np.einsum("ri,rin->rn", thetas[j][:, (p + m) * l :], C[:, :j])
    return A_D + D @ C, B, C, D
