"""Online filter tuning: a bank of recursive estimators, one per candidate filter.

All candidates are estimated together (:class:`moli.streaming.recursive.BankRls` batches the
least squares across the bank). Every ``retune_every`` samples each candidate's
current model is simulated from the zero state on the latest ``window`` samples
and scored with the paper's ``J`` (docs/method.md §5), leaving out the first
``burn_in`` samples where the zero initial state dominates. Slot 0 of the bank is
the barycenter candidate: it moves to the barycenter (paper eq. 5) of the scored
bank and is re-estimated from the prior on the window, so it starts current; the
other candidates (the grid ``omega``) stay where they are and keep exploring.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..data.arguments import integer
from ..errors import DataError, OptionError
from ..method.structure.filters import filter_divisors, filter_polynomial
from ..models.statespace import StateSpaceModel
from .recursive import BankRls, check_options, checked_chunk
from ..models.simulation import simulate_batch
from ..method.structure.indices import check_indices
from ..method.tuning.barycenter import barycenter, check_omega
from ..numerics.blas_threads import limited_blas

__all__ = ["FilterBank"]


class FilterBank:
    """Recursive MOLI with a bank of candidate filters tuned online.

    Parameters
    ----------
    indices : sequence of int
        Observability indices, one per output.
    omega : array_like, shape (R, 2)
        Candidate rows ``(wc, zeta)``, e.g. :func:`moli.method.tuning.barycenter.default_omega`.
        The bank holds ``R + 1`` filters: the barycenter candidate, then ``omega``.
    m : int
        Number of inputs.
    retune_every : int, default 1000
        ``T_alpha``: samples between two scorings.
    window : int, default 1000
        Latest samples the candidates are scored on and the moved candidate is
        re-estimated on.
    burn_in : int, optional
        Leading window samples left out of ``J``; default ``window // 5``.
    forgetting, noise_variance, p0 : float
        See :class:`moli.RecursiveMoli`.
    Ts, s : float
        Sampling period and root spacing factor of the filters.

    Attributes
    ----------
    etas : ndarray, shape (R + 1, 2)
        Current candidates; row 0 is the barycenter candidate.
    costs : ndarray, shape (R + 1,)
        ``J`` of each slot's model at the last scoring (NaN before the first);
        slot 0 has since moved to the barycenter of these scores.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(600)
    >>> y = np.zeros(600)
    >>> for k in range(1, 600):
    ...     y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1]
    >>> bank = FilterBank([1], [[0.2, 1.0], [1.0, 1.0]], 1, retune_every=200, window=200)
    >>> np.round(bank.update_many(y, u).model.poles().real, 6)
    array([0.8])
    """

    def __init__(
        self, indices: Sequence[int], omega: object, m: int, *, retune_every: int = 1000,
        window: int = 1000, burn_in: int | None = None, forgetting: float = 1.0,
        noise_variance: float = 1.0, p0: float = 1e6, Ts: float = 1.0, s: float = 2.0,
    ) -> None:
        self.indices = check_indices(indices, len(indices))
        grid = check_omega(omega)
        m = integer("m (the number of inputs)", m, error=OptionError, low=1)
        retune_every = integer("retune_every", retune_every, error=OptionError, low=1)
        window = integer("window", window, error=OptionError, low=2)
        burn_in = window // 5 if burn_in is None else integer("burn_in", burn_in, error=OptionError, low=0)
        if burn_in > window - 2:
            raise OptionError(f"burn_in must be an integer in 0..window-2, got {burn_in!r}")
        check_options(forgetting, noise_variance, p0)
        self.m, self.Ts, self.s = int(m), float(Ts), float(s)
        self.retune_every, self.window, self.burn_in = int(retune_every), int(window), int(burn_in)
        # Before any scoring the barycenter candidate sits at the centre of omega.
        self.etas = np.vstack([grid.mean(axis=0), grid])
        self.costs = np.full(len(self.etas), np.nan)
        alphas = [self._divisors(eta) for eta in self.etas]
        self._bank = BankRls(self.indices, alphas, self.m, float(forgetting), float(noise_variance), float(p0))
        self._recent = np.zeros((0, len(self.indices) + self.m))

    def _divisors(self, eta: np.ndarray) -> list[np.ndarray]:
        return filter_divisors(float(eta[0]), float(eta[1]), self.indices, self.Ts, self.s)

    @property
    def samples(self) -> int:
        """Number of samples absorbed so far."""
        return self._bank.samples

    def update(self, y_k: object, u_k: object) -> "FilterBank":
        """Absorb one sample: outputs ``y_k`` (p,) and inputs ``u_k`` (m,)."""
        return self.update_many(np.reshape(y_k, (1, -1)), np.reshape(u_k, (1, -1)))

    def update_many(self, y: object, u: object) -> "FilterBank":
        """Absorb a chunk of samples, rescoring every ``retune_every`` samples.

        Parameters
        ----------
        y : array_like, shape (N, p)
        u : array_like, shape (N, m)

        Returns
        -------
        FilterBank
            ``self``.
        """
        with limited_blas():
            z = checked_chunk(y, u, len(self.indices), self.m)
            start = 0
            while start < z.shape[0]:
                # stop at the next multiple of retune_every so scoring sees the right window
                stop = min(z.shape[0], start + self.retune_every - self.samples % self.retune_every)
                piece = z[start:stop]
                self._bank.update(piece)
                self._recent = np.concatenate([self._recent, piece])[-self.window :]
                if self.samples % self.retune_every == 0 and len(self._recent) == self.window:
                    self.retune()
                start = stop
            return self

    def retune(self) -> None:
        """Score the bank on the latest window and move the barycenter candidate."""
        if len(self._recent) < self.window:
            raise DataError(f"retune needs a full window of {self.window} samples, have {len(self._recent)}")
        p = len(self.indices)
        y, u = self._recent[:, :p], self._recent[:, p:]
        A, B, C = self._bank.matrices()
        yhat = simulate_batch(A, B, C, u)[:, self.burn_in :]
        scored = y[self.burn_in :]
        with np.errstate(all="ignore"):
            ratio = np.var(scored[None] - yhat, axis=1) / np.var(scored, axis=0)
        # unstable or useless models score 1, as in moli.method.tuning.barycenter
        self.costs = np.where(np.isfinite(ratio), np.minimum(ratio, 1.0), 1.0).mean(axis=1)
        center = barycenter(self.etas, self.costs)
        self.etas[0] = center
        self._bank.restart(0, self._divisors(center), self._recent)

    @property
    def best(self) -> int:
        """Slot with the lowest ``J`` at the last scoring (0 before any scoring).

        When it is slot 0, the model is the one re-estimated at the barycenter.
        """
        return 0 if np.all(np.isnan(self.costs)) else int(np.nanargmin(self.costs))

    @property
    def model(self) -> StateSpaceModel:
        """Current model of the best-scoring candidate."""
        r = self.best
        A, B, C = self._bank.matrices()
        return StateSpaceModel(
            A[r], B[r], C[r], Ts=self.Ts, indices=self.indices,
            alpha=filter_polynomial(self.etas[r][0], self.etas[r][1], self.indices, self.Ts, self.s),
            info={"samples": self.samples, "eta": self.etas[r].tolist(), "J": float(self.costs[r])},
        )
