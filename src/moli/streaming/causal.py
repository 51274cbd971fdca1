"""Causal MOLI regressors computed chunk by chunk, filter state carried across chunks.

The regressors of an output with index ``l`` at time ``k`` are ``(q^i/alpha_j) z``,
``i = 0..l-1``, i.e. the delays ``1..l`` of ``base = lfilter(1, alpha_j, z)``
(see :func:`moli.method.estimation.filtered_regressors`). Streaming them needs two pieces
of state per filter: the ``lfilter`` state ``zi`` and the last ``l`` samples of
``base``. Feeding a record in chunks of any sizes gives the same regressors as
filtering the whole record at once from the zero state.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CausalRegressors"]


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
        for every channel, with ``T`` this matrix. It is the one-sample map, read off
        the filter itself, raised to the power ``N``.
        """
        size = 2 * self.degree
        probe = CausalRegressors(self.filters, size)
        # channel q starts in the unit state e_q, so column q of its state is T e_q
        probe.set_state(np.broadcast_to(np.eye(size), (self.filters.shape[0], size, size)))
        probe.advance(np.zeros((1, size)))
        return np.linalg.matrix_power(probe.state(), N)

    def _filter(self, r: int, z: np.ndarray) -> np.ndarray:
        """Filter ``z`` by candidate ``r`` from its state; the last ``l`` filtered samples
        before ``z`` then the filtered ``z``, shape (l + N, c). Updates the state."""
        from scipy.signal import lfilter  # slow to import: only when filtering

        base, self._zi[r] = lfilter([1.0], self.filters[r], z, axis=0, zi=self._zi[r])
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
            the layout of :func:`moli.method.estimation.filtered_regressors`.
        """
        N, c = z.shape
        l = self.degree
        R = self.filters.shape[0]
        out = np.empty((R, N, c, l))
        # One C-level lfilter call per candidate and chunk: its cost is amortised
        # over the chunk, while the estimation itself is batched across the bank.
        for r in range(R):
            extended = self._filter(r, z)
            for i in range(l):
                # phi[k, :, i] = base[k - (l - i)] = extended[k + i]
                out[r, :, :, i] = extended[i : i + N]
        return out.reshape(R, N, c * l)
