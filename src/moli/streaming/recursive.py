"""Recursive MOLI estimation: sample by sample or chunk by chunk, constant memory.

Each output's parameters are estimated by recursive least squares on the causal
MOLI regressors (docs/method.md §6), ``P_0 = p0 I``, ``theta_0 = 0``,
output noise variance ``R2`` and an optional forgetting factor. Like
:func:`moli.estimate`, the first ``max(indices)`` samples only charge the
filters. The state-space model comes from :func:`moli.method.least_squares.realization.realize`.

Outputs whose indices are equal share the filter ``alpha_j`` and hence the
regressors, so they share one square-root factor (see :mod:`moli.streaming.sqrt_rls`).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .causal import CausalRegressors
from ..data.arguments import integer, period
from ..data.iodata import stack_signals
from ..errors import DataError, OptionError
from ..method.least_squares.realization import realize
from ..method.structure.filters import check_alpha, divisors
from ..models.statespace import StateSpaceModel

# A chunk's state map filters only the samples whose effect on the end state is above
# round-off: those after the point where every entry of the free response is below
# NEGLIGIBLE_RESPONSE (1e-17, a tenth of the state's own round-off), looked for from
# REACH_START samples on, doubling.
NEGLIGIBLE_RESPONSE = 1e-17
REACH_START = 4096
from .sqrt_rls import SquareRootRls
from ..method.structure.indices import Indices, check_indices
from ..numerics.blas_threads import limited_blas

__all__ = [
    "check_options", "solve_triangular_batch", "BankRls", "FixedFilterEstimator",
    "RecursiveMoli",
]

# update_many works through long records in pieces of this many samples, so the
# regressor arrays (candidates x piece x columns) stay a few megabytes.
PIECE = 4096


def check_options(forgetting: float, noise_variance: float, p0: float) -> None:
    """Raise :class:`OptionError` unless ``0 < forgetting <= 1``, ``noise_variance > 0``, ``p0 > 0``."""
    if not (np.isfinite(forgetting) and 0.0 < forgetting <= 1.0):
        raise OptionError(f"forgetting must lie in (0, 1], got {forgetting!r}")
    if not (np.isfinite(noise_variance) and noise_variance > 0):
        raise OptionError(f"noise_variance must be positive and finite, got {noise_variance!r}")
    if not (p0 > 0 and not np.isnan(p0)):
        raise OptionError(f"p0 must be positive (inf for no prior), got {p0!r}")


def checked_chunk(y: object, u: object, p: int, m: int) -> np.ndarray:
    """``[y, u]`` of a chunk, every sample checked before any is absorbed.

    A recursive state cannot skip a sample (the filters run through it), so NaN, which
    marks a missing sample in an :class:`IOData`, is refused here like inf: a chunk
    with one bad sample leaves the estimator exactly as it was.
    """
    z = stack_signals(y, u, p, m)
    if not np.all(np.isfinite(z)):
        raise DataError(f"the chunk holds NaN or inf at sample {int(np.argwhere(~np.isfinite(z))[0, 0])}; "
                        "a streaming estimator needs every sample: split the stream at a gap instead")
    return z


def solve_triangular_batch(factor: np.ndarray, count: int) -> np.ndarray:
    """Regression of column ``count`` on the columns before it, from triangular factors (G, K, K)."""
    return np.linalg.solve(factor[:, :count, :count], factor[:, :count, count][..., None])[..., 0]


class BankRls:
    """Recursive MOLI estimators for ``R`` filter candidates, updated together.

    Parameters
    ----------
    indices : tuple of int
        Validated list of observability indices.
    alphas : sequence of sequences of ndarray
        ``alphas[r][j]``: divisor of output ``j`` for candidate ``r``.
    m : int
        Number of inputs.
    forgetting, noise_variance, p0 : float
        See :class:`RecursiveMoli`.
    """

    def __init__(
        self, indices: Indices, alphas: Sequence[Sequence[np.ndarray]], m: int,
        forgetting: float, noise_variance: float, p0: float,
    ) -> None:
        self.indices = indices
        self.alphas = [list(a) for a in alphas]
        self.m = m
        self.options = (forgetting, noise_variance, p0)
        self.samples = 0
        p = len(indices)
        c = p + m
        self._groups = []
        for l in sorted(set(indices)):
            first = indices.index(l)
            filters = np.array([a[first] for a in self.alphas])
            rls = SquareRootRls(
                len(self.alphas), c * l + p, forgetting=forgetting,
                noise_variance=noise_variance, p0=p0,
            )
            self._groups.append((l, CausalRegressors(filters, c), rls))

    def update(self, z: np.ndarray) -> None:
        """Absorb samples ``z`` (N, p + m), outputs first."""
        p = len(self.indices)
        skip = max(0, max(self.indices) - self.samples)
        for start in range(0, z.shape[0], PIECE):
            piece = z[start : start + PIECE]
            y = np.broadcast_to(piece[:, :p], (len(self.alphas),) + piece[:, :p].shape)
            for _, regressors, rls in self._groups:
                rows = np.concatenate([regressors.push(piece), y], axis=2)
                rls.update(rows[:, skip:])
            skip = max(0, skip - piece.shape[0])
        self.samples += z.shape[0]

    def filter_states(self) -> list[np.ndarray]:
        """Per distinct index ``l`` (ascending), the filter states, shape (R, 2 l, p + m)."""
        return [regressors.state() for _, regressors, _ in self._groups]

    def resume(self, samples: int, states: Sequence[np.ndarray]) -> None:
        """Continue a record at sample ``samples`` whose filters hold ``states`` there."""
        for (_, regressors, _), state in zip(self._groups, states):
            regressors.set_state(state)
        self.samples = samples

    def state_map(self, z: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """How the samples ``z`` move the filter states, leaving this bank unchanged.

        Per distinct index ``l`` (ascending): ``(T, s)`` with the state after ``z``
        equal to ``T @ state_before + s`` (shapes (R, 2 l, 2 l) and (R, 2 l, p + m)).
        """
        maps = []
        for _, regressors, _ in self._groups:
            fresh = CausalRegressors(regressors.filters, z.shape[1])
            # the state from zero depends on the samples before the last K only through the
            # free response over K samples: once that is below round-off, those samples
            # need not be filtered (a chunk's map then costs a tail, not the chunk)
            fresh.advance(z[z.shape[0] - _reach(regressors, z.shape[0]) :])
            maps.append((regressors.transition(z.shape[0]), fresh.state()))
        return maps

    def merge(self, other: "BankRls") -> None:
        """Absorb the rows of ``other``, a bank over the same filters that continued
        this one's record; the states become ``other``'s (plain least squares only)."""
        for (_, regressors, rls), (_, later, later_rls) in zip(self._groups, other._groups):
            rls.factor = np.linalg.qr(np.concatenate([rls.factor, later_rls.factor], axis=1), mode="r")
            regressors.set_state(later.state())
        self.samples = other.samples

    def factors(self) -> list[tuple[int, np.ndarray]]:
        """Per output ``j``: the count ``k_j`` of its parameters and its group's factors.

        Output ``j`` regresses column ``k_j`` of the factor on the columns before it.
        """
        p = len(self.indices)
        by_degree = {l: rls.factor for l, _, rls in self._groups}
        return [((p + self.m) * l + j, by_degree[l]) for j, l in enumerate(self.indices)]

    def thetas(self) -> list[np.ndarray]:
        """Per output ``j``, the parameters of every candidate, shape (R, (p+m) l_j + j)."""
        return [solve_triangular_batch(F, k) for k, F in self.factors()]

    def covariances(self) -> list[np.ndarray]:
        """Per output ``j``, the Kalman-form covariance ``P_j`` of every candidate."""
        out = []
        for k, F in self.factors():
            inv = np.linalg.inv(F[:, :k, :k])
            out.append(inv @ inv.transpose(0, 2, 1))
        return out

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``A, B, C`` of every candidate's current model, see :func:`realize`."""
        return realize(self.thetas(), self.alphas, self.indices, self.m)

    def restart(self, r: int, alphas: Sequence[np.ndarray], z: np.ndarray) -> None:
        """Give candidate ``r`` new divisors and re-estimate it from the prior on ``z``.

        ``z`` is filtered from the zero state and its first ``max(indices)`` samples
        only charge the filters, as at the start of a record.
        """
        fresh = BankRls(self.indices, [alphas], self.m, *self.options)
        fresh.update(z)
        self.alphas[r] = list(alphas)
        for (_, regressors, rls), (_, new_regressors, new_rls) in zip(self._groups, fresh._groups):
            regressors.load(r, new_regressors, 0)
            rls.factor[r] = new_rls.factor[0]


class FixedFilterEstimator:
    """One list of indices and one filter, estimated from chunks fed to a square-root bank.

    The common part of :class:`RecursiveMoli` and :class:`moli.streaming.chunked.ChunkedEstimator`:
    it checks the structure, keeps the bank and builds the models of its estimates.
    """

    def __init__(
        self, indices: Sequence[int], alpha: Sequence[float], m: int, Ts: float,
        forgetting: float, noise_variance: float, *, p0: float,
    ) -> None:
        self.indices = check_indices(indices, len(indices))
        self.alpha = check_alpha(alpha)
        integer("m (number of inputs)", m, error=OptionError, low=1)
        check_options(forgetting, noise_variance, p0)
        period(Ts, error=OptionError)
        self.m = int(m)
        self.Ts = float(Ts)
        self._alphas = divisors(self.alpha, self.indices)
        self._bank = BankRls(
            self.indices, [self._alphas], self.m, float(forgetting), float(noise_variance), float(p0)
        )

    @property
    def samples(self) -> int:
        """Number of samples absorbed so far."""
        return self._bank.samples

    def _absorb(self, y: object, u: object) -> None:
        self._bank.update(checked_chunk(y, u, len(self.indices), self.m))

    def _model(self, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> StateSpaceModel:
        return StateSpaceModel(
            A[0], B[0], C[0], Ts=self.Ts, indices=self.indices, alpha=self.alpha,
            info={"samples": self.samples},
        )


class RecursiveMoli(FixedFilterEstimator):
    """Streaming MOLI identification with one filter: constant memory, model always current.

    Parameters
    ----------
    indices : sequence of int
        Observability indices, one per output.
    alpha : array_like
        Monic, stable filter polynomial of degree ``max(indices)``.
    m : int
        Number of inputs.
    forgetting : float, default 1.0
        Forgetting factor in (0, 1]; below 1 the estimate tracks slowly varying
        plants with a memory of about ``1 / (1 - forgetting)`` samples.
    noise_variance : float, default 1.0
        Output noise variance ``R2`` of the Kalman form (with ``p0`` it sets how
        strongly the prior ``theta_0 = 0`` weighs against the data).
    p0 : float, default 1e6
        Initial covariance ``P_0 = p0 I``.
    Ts : float, default 1.0
        Sampling period given to the models.

    Notes
    -----
    With ``forgetting = 1`` the estimate after ``N`` samples minimises
    ``sum_k |y_k - phi_k theta|^2 / R2 + |theta|^2 / p0`` over samples
    ``max(indices)..N-1``: the batch least-squares problem of :func:`moli.estimate`
    plus a ridge term, so the two models agree once the data outweigh ``1/p0``
    (exactly, on noise-free data from a system with these indices).
    ``update`` and ``update_many`` give the same estimate whatever the chunking.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(300)
    >>> y = np.zeros(300)
    >>> for k in range(1, 300):
    ...     y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1]
    >>> est = RecursiveMoli([1], moli.filter_polynomial(1.0, 1.0, [1]), 1)
    >>> est = est.update_many(y, u)
    >>> np.round(est.model.poles().real, 6)
    array([0.8])
    """

    def __init__(
        self, indices: Sequence[int], alpha: Sequence[float], m: int, *,
        forgetting: float = 1.0, noise_variance: float = 1.0, p0: float = 1e6, Ts: float = 1.0,
    ) -> None:
        super().__init__(indices, alpha, m, Ts, forgetting, noise_variance, p0=p0)

    def update(self, y_k: object, u_k: object) -> "RecursiveMoli":
        """Absorb one sample: outputs ``y_k`` (p,) and inputs ``u_k`` (m,)."""
        # without update_many's BLAS limit: a sample's products are too small for BLAS's threads to
        # matter, and setting the limit would cost a quarter of the sample (about 25 of 100 us)
        self._absorb(np.reshape(y_k, (1, -1)), np.reshape(u_k, (1, -1)))
        return self

    def update_many(self, y: object, u: object) -> "RecursiveMoli":
        """Absorb a chunk of samples.

        Parameters
        ----------
        y : array_like, shape (N, p)
            Outputs, time along axis 0 (1-D accepted when p = 1).
        u : array_like, shape (N, m)
            Inputs, time along axis 0 (1-D accepted when m = 1).

        Returns
        -------
        RecursiveMoli
            ``self``.
        """
        with limited_blas():
            self._absorb(y, u)
            return self

    @property
    def theta(self) -> list[np.ndarray]:
        """Current parameters ``theta_j`` per output, shape ((p+m) l_j + j,)."""
        return [t[0] for t in self._bank.thetas()]

    @property
    def covariance(self) -> list[np.ndarray]:
        """Current Kalman-form covariance ``P_j`` per output (symmetric positive definite)."""
        return [P[0] for P in self._bank.covariances()]

    @property
    def model(self) -> StateSpaceModel:
        """The state-space model of the current estimate (observer-form coordinates)."""
        return self._model(*self._bank.matrices())


def _reach(regressors: CausalRegressors, N: int) -> int:
    """The samples, counted back from the end of ``N``, that set the state from zero to
    round-off: the first of ``REACH_START``, twice that, ... whose free response is below
    :data:`NEGLIGIBLE_RESPONSE` in every entry, else ``N``."""
    K = REACH_START
    while K < N:
        if np.max(np.abs(regressors.transition(K)), initial=0.0) <= NEGLIGIBLE_RESPONSE:
            return K
        K *= 2
    return N
