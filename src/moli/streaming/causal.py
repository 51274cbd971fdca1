"""Causal MOLI regressors computed chunk by chunk, filter state carried across chunks.

The regressors of an output with index ``l`` at time ``k`` are ``(q^i/alpha_j) z``,
``i = 0..l-1``, i.e. the delays ``1..l`` of ``base = lfilter(1, alpha_j, z)``
(see :func:`moli.method.least_squares.estimation.filtered_regressors`). Streaming them needs two pieces
of state per filter: the ``lfilter`` state ``zi`` and the last ``l`` samples of
``base``. Feeding a record in chunks of any sizes gives the same regressors as
filtering the whole record at once from the zero state.
"""

from __future__ import annotations

import functools

import numpy as np

from ..numerics.recursive_filter import recursive_filter

__all__ = ["CausalRegressors"]

# Zero samples per filter call of a free response: long chunks in bounded memory.
FREE_RESPONSE_PIECE = 65536


class CausalRegressors:
    """Streaming regressors for a bank of filters of one degree.

    Parameters
    ----------
    filters : ndarray, shape (R, l + 1)
        Monic denominators ``alpha_j``, one per candidate, all of degree ``l``.
    channels : int
        Number of signals ``c`` in ``z`` (outputs then inputs).

    Examples
    --------
    >>> reg = CausalRegressors(np.array([[1.0, -0.5]]), 1)
    >>> reg.push(np.array([[1.0], [0.0], [0.0]]))[0, :, 0]
    array([0. , 1. , 0.5])
    """

    def __init__(self, filters: np.ndarray, channels: int) -> None:
        self.filters = np.array(filters, dtype=float)
        R, order = self.filters.shape
        self.degree = order - 1
        self._zi = np.zeros((R, self.degree, channels))
        self._tail = np.zeros((R, self.degree, channels))

    def load(self, r: int, other: "CausalRegressors", s: int) -> None:
        """Make candidate ``r`` a copy of candidate ``s`` of ``other`` (filter and state)."""
        self.filters[r] = other.filters[s]
        self._zi[r] = other._zi[s]
        self._tail[r] = other._tail[s]

    def state(self) -> np.ndarray:
        """The state carried to the next sample, shape (R, 2 l, c): the ``lfilter`` state
        ``zi`` (rows ``0..l-1``), then the last ``l`` filtered samples (rows ``l..2l-1``)."""
        return np.concatenate([self._zi, self._tail], axis=1)

    def set_state(self, state: np.ndarray) -> None:
        """Continue from ``state`` (the layout of :meth:`state`), e.g. mid-record."""
        l = self.degree
        self._zi, self._tail = state[:, :l].copy(), state[:, l:].copy()

    def advance(self, z: np.ndarray) -> None:
        """Carry the state over the samples ``z`` (N, c) without forming regressors."""
        for r in range(self.filters.shape[0]):
            self._filter(r, z)

    def transition(self, N: int) -> np.ndarray:
        """The free response of the state over ``N`` samples, shape (R, 2 l, 2 l).

        The state is linear in its start and the samples, and each channel's is
        separate: after ``N`` more samples ``state = T @ start + (state from zero)``
        for every channel, with ``T`` this matrix. Column ``q`` is the state reached
        from the unit state ``e_q`` through ``N`` zero samples, filtered like the data
        (the power of the one-sample map by squaring is no substitute: on slow filters
        its state map is far from normal, and squaring lost every digit in tests).
        """
        return np.stack([_free_response(f.tobytes(), N) for f in self.filters])

    def _filter(self, r: int, z: np.ndarray) -> np.ndarray:
        """Filter ``z`` by candidate ``r`` from its state; the last ``l`` filtered samples
        before ``z`` then the filtered ``z``, shape (l + N, c). Updates the state."""
        base, self._zi[r] = recursive_filter([1.0], self.filters[r], z, axis=0, zi=self._zi[r])
        extended = np.concatenate([self._tail[r], base])
        self._tail[r] = extended[z.shape[0]:]
        return extended

    def push(self, z: np.ndarray) -> np.ndarray:
        """Regressors of the next samples.

        Parameters
        ----------
        z : ndarray, shape (N, c)

        Returns
        -------
        ndarray, shape (R, N, c * l)
            Column ``r * l + i`` holds channel ``r`` filtered by ``q^i / alpha_j``,
            the layout of :func:`moli.method.least_squares.estimation.filtered_regressors`.
        """
        N, c = z.shape
        l = self.degree
        R = self.filters.shape[0]
        out = np.empty((R, N, c, l))
        # One LAPACK filter call per candidate and chunk: its cost is amortised
        # over the chunk, while the estimation itself is batched across the bank.
        for r in range(R):
            extended = self._filter(r, z)
            for i in range(l):
                # phi[k, :, i] = base[k - (l - i)] = extended[k + i]
                out[r, :, :, i] = extended[i : i + N]
        return out.reshape(R, N, c * l)


@functools.lru_cache(maxsize=64)
def _free_response(filter_bytes: bytes, N: int) -> np.ndarray:
    """:meth:`CausalRegressors.transition` of one filter; chunks of one length share it."""
    alpha = np.frombuffer(filter_bytes)
    size = 2 * (alpha.size - 1)
    probe = CausalRegressors(alpha[None], size)
    probe.set_state(np.eye(size)[None])
    zeros = np.zeros((min(N, FREE_RESPONSE_PIECE), size))
    for start in range(0, N, FREE_RESPONSE_PIECE):
        probe.advance(zeros[: N - start])
    response = probe.state()[0]
    response.flags.writeable = False  # shared by every caller
    return response
