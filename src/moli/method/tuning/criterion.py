"""The criterion J of a filter candidate: estimate, simulate, score (docs/method.md §5).

``J(eta)`` estimates with the filter ``alpha(eta)``, simulates the model from the
zero state on the estimation inputs and averages ``min(var(y_i - yhat_i)/var(y_i), 1)``
over the outputs. :class:`FilterScorer` scores candidates of one list in batches (one
least-squares batch per output, one batched simulation); :func:`score_lists` scores
several lists in shared batches.
"""

from __future__ import annotations

import functools
from typing import Callable, Sequence

import numpy as np

from ...errors import OptionError
from ...models.simulation import simulate_batch
from ...validation.comparison import X0_CHOICES
from ..least_squares.estimation import fit_batch
from ..least_squares.realization import observer_form_matrices, realize
from ..structure.filters import filter_divisors
from ..least_squares.shared_factors import RegressionCache
from ..structure.indices import Indices

__all__ = ["check_trend_degree", "error_ratio", "FilterScorer", "score_lists"]

# Highest degree of the error trend J may ignore: beyond a few terms the polynomials
# reach the plant's own frequencies on short records.
MAX_TREND_DEGREE = 5
# Lists scored together (score_lists) share a simulation batch of at most this many
# simulated values (1 MB): that saves the per-call cost of many small batches, while
# larger batches leave the processor's cache (with a 16 MB limit, glassfurnace's six
# lists of 18 models, 3 MB, were scored 11-21 % slower together than one by one).
JOINT_BATCH_VALUES = 2**17
# The models of one criterion call are simulated at most this many values at a time
# (16 MB): a long record's batch of candidates would otherwise hold models x N x p
# simulated values, and the error's copy beside them.
CRITERION_BATCH_VALUES = 2**21


def check_trend_degree(degree: object) -> int:
    """Validate the degree of the error trend J ignores: an integer 0..MAX_TREND_DEGREE."""
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or not (
        0 <= degree <= MAX_TREND_DEGREE
    ):
        raise OptionError(f"trend_degree must be an integer from 0 to {MAX_TREND_DEGREE}, got {degree!r}")
    return int(degree)


def _initial_response(A: np.ndarray, C: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Least-squares fit of the free responses ``C A^k x0`` to ``error``, per model.

    Parameters: ``A`` (R, n, n), ``C`` (R, p, n), ``error`` (R, N, p). Returns (R, N, p);
    zero where the fit is not finite (unstable models).
    """
    R, n, _ = A.shape
    N, p = error.shape[1:]
    out = np.zeros(error.shape)
    with np.errstate(all="ignore"):
        free = simulate_batch(
            np.repeat(A, n, axis=0), np.zeros((R * n, n, 1)), np.repeat(C, n, axis=0),
            np.zeros((N, 1)), x0=np.tile(np.eye(n), (R, 1)),
        ).reshape(R, n, N * p).transpose(0, 2, 1)                       # (R, N p, n)
        ok = np.all(np.isfinite(free), axis=(1, 2)) & np.all(np.isfinite(error), axis=(1, 2))
        for r in np.flatnonzero(ok):
            x0 = np.linalg.lstsq(free[r], error[r].reshape(-1), rcond=None)[0]
            out[r] = (free[r] @ x0).reshape(N, p)
    return out


def _realize_feedthrough(
    thetas: Sequence[np.ndarray], parts: Sequence[Sequence[np.ndarray]], indices: Indices, m: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """State-space batch of observer-form fits whose last ``m`` parameters feed ``u`` through.

    Output ``j``'s equation is ``y_j = theta_j w_j + g_j y_<j + f_j u``, so
    ``y = (I - G)^-1 (C_D x + F u)``: ``C`` is unchanged, ``D = (I - G)^-1 F``, and the
    observer's output injection ``D_y y`` adds ``D_y D`` to ``B``.
    """
    A, B, C, D_y = observer_form_matrices([t[:, :-m] for t in thetas], parts, indices, m)
    F = np.stack([t[:, -m:] for t in thetas], axis=1)             # (R, p, m)
    H = C[:, :, np.cumsum(indices) - 1]                           # (I - G)^-1
    D = H @ F
    return A, B + D_y @ D, C, D


@functools.lru_cache(maxsize=16)
def _trend_basis(N: int, degree: int) -> np.ndarray:
    """Orthonormal basis (N, degree + 1) of the polynomials of that degree over N samples."""
    basis = np.polynomial.legendre.legvander(np.linspace(-1.0, 1.0, N), degree)
    return np.linalg.qr(basis)[0]


def error_ratio(
    y: np.ndarray, yhat: np.ndarray, degree: int = 0, y_var: np.ndarray | None = None,
    starts: Sequence[int] = (0,),
) -> np.ndarray:
    """Per-output share of the output variance left in the simulation error, at most 1.

    ``min(|e - P e|^2 / (N var(y)), 1)`` with ``e = y - yhat`` and ``P`` the projection
    on the polynomials of the given degree over the record: degree 0 removes the
    error's mean (the paper's J); a higher degree also ignores a slow drift of the
    error. Diverging simulations (inf or NaN) score 1.

    Parameters
    ----------
    y : ndarray, shape (N, p)
        Measured outputs.
    yhat : ndarray, shape (R, N, p)
        Simulated outputs of ``R`` models.
    degree : int, default 0
        Degree of the polynomial trend ignored.
    y_var : ndarray, shape (p,), optional
        ``np.var(y, axis=0)`` when already known.
    starts : sequence of int, default (0,)
        First sample of each segment of the record: a trend of degree 1 or more is
        fitted to each segment's errors separately (a drift does not continue
        across a gap); degree 0 removes the mean of all the errors together.

    Returns
    -------
    ndarray, shape (R, p)
    """
    y_var = np.var(y, axis=0) if y_var is None else y_var
    with np.errstate(all="ignore"):
        # samples first: the sums run over long contiguous rows, the same sequential
        # sums as along axis 1 of (R, N, p) but several times faster; the error is then
        # formed in place in that copy (a record-sized temporary costs about as much as
        # the arithmetic), never in a view of yhat
        error = yhat.transpose(1, 0, 2).copy(order="C")
        np.subtract(y[:, None, :], error, out=error)
        if degree == 0:
            ratio = np.var(error, axis=0) / y_var
        else:
            N = y.shape[0]
            flat = error.reshape(N, -1)
            for a, b in zip(starts, (*starts[1:], N)):
                basis = _trend_basis(b - a, min(degree, b - a - 1))
                flat[a:b] -= basis @ (basis.T @ flat[a:b])
            ratio = np.einsum("ij,ij->j", flat, flat).reshape(error.shape[1:]) / (N * y_var)
    return np.where(np.isfinite(ratio), np.minimum(ratio, 1.0), 1.0)


class FilterScorer:
    """Scores filter candidates for one list of indices on one estimation record.

    Parameters
    ----------
    z : ndarray, shape (N, p + m)
        Estimation outputs then inputs (centred).
    indices : tuple of int
    Ts, s : float
        Sampling period and root spacing factor of the filters.
    cache : RegressionCache, optional
        Factorizations shared with the other lists of a search on the same ``z``;
        without one, each candidate is estimated directly by :func:`fit_batch`. Both
        routes give the same models up to round-off.
    x0 : {"zero", "estimate"}
        Initial state of the simulations behind J: zero (the paper), or fitted by least
        squares to the estimation record (the record need not start at rest).
    max_radius : float, optional
        Candidates with a pole of at least this modulus score the worst J, 1, so that
        tuning and the structure path never prefer a (nearly) unstable model. None
        (the paper) scores every candidate by its fit alone.
    trend_degree : int, default 0
        J ignores the polynomial trend of this degree in the simulation error (see
        :func:`error_ratio`); 0 is the paper's J.
    starts : sequence of int, default (0,)
        First sample of each segment of ``z``: the models are fitted without a row
        across a boundary, and each segment is simulated from its own initial state;
        J scores the errors of all segments together.
    """

    def __init__(
        self, z: np.ndarray, indices: Indices, Ts: float, s: float,
        cache: RegressionCache | None = None, x0: str = "zero", *,
        max_radius: float | None = None, trend_degree: int = 0, starts: Sequence[int] = (0,),
    ) -> None:
        self.max_radius = max_radius
        self.trend_degree = check_trend_degree(trend_degree)
        if not isinstance(x0, str) or x0 not in X0_CHOICES:
            raise OptionError(f"x0 must be one of {X0_CHOICES}, got {x0!r}")
        self.x0 = x0
        self.z = z
        self.indices = indices
        self.Ts = Ts
        self.s = s
        self.cache = cache
        self.starts = tuple(starts)
        if cache is not None and cache.starts != self.starts:
            raise OptionError("the scorer and its regression cache must share the record's segments")
        p = len(indices)
        self.y = z[:, :p]
        self.u = z[:, p:]
        self.y_var = np.var(self.y, axis=0)
        self.evaluations = 0

    def fit(self, etas: np.ndarray) -> tuple[np.ndarray, ...]:
        """The batch of models ``(A, B, C)`` (and ``D`` with feedthrough) for each candidate."""
        if self.cache is None:
            alphas = [filter_divisors(w, zeta, self.indices, self.Ts, self.s) for w, zeta in etas]
            A, B, C, _ = fit_batch(self.z, self.indices, alphas, self.starts)
            return A, B, C
        return _fit_cached([self], [etas])[0]

    def realize(self, thetas: list[np.ndarray], parts: list[list[np.ndarray]]) -> tuple[np.ndarray, ...]:
        """State-space batch ``(A, B, C[, D])`` of per-output parameters.

        ``thetas[j]`` holds output ``j``'s parameters of each model (rows), as
        :meth:`RegressionCache.thetas` gives them; ``parts[r][j]`` is model ``r``'s
        divisor for output ``j``. Needs the scorer's cache.
        """
        m = self.z.shape[1] - len(self.indices)
        if not self.cache.feedthrough:
            return realize(thetas, parts, self.indices, m)
        return _realize_feedthrough(thetas, parts, self.indices, m)

    def score(self, etas: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        """J of each candidate and the batch of fitted models ``(A, B, C[, D])``."""
        return score_lists([self], [etas])[0]

    def criterion(self, matrices: tuple[np.ndarray, ...], radius_rule: bool = True) -> np.ndarray:
        """J of a batch of models ``(A, B, C[, D])`` on this scorer's record.

        With ``radius_rule=False`` the models are scored by their fit alone; the
        caller then applies :meth:`too_slow` to the ones it keeps.
        """
        A, B, C = matrices[:3]
        # with a fitted initial state each model also simulates its n free responses
        per_model = self.y.size * (1 + (A.shape[1] if self.x0 == "estimate" else 0))
        step = max(CRITERION_BATCH_VALUES // per_model, 1)
        if A.shape[0] > step:
            return np.concatenate([
                self.criterion(tuple(M[i : i + step] for M in matrices), radius_rule)
                for i in range(0, A.shape[0], step)
            ])
        yhat = self._simulate(A, B, C)
        if len(matrices) == 4:
            yhat = yhat + self.u @ matrices[3].transpose(0, 2, 1)
        if self.x0 == "estimate":
            yhat = yhat + self._by_segment(lambda a, b: _initial_response(A, C, self.y[None, a:b] - yhat[:, a:b]))
        ratio = error_ratio(self.y, yhat, self.trend_degree, self.y_var, self.starts)
        if radius_rule:
            # a model that leaves every output's whole variance already scores the worst J
            undecided = np.flatnonzero(ratio.min(axis=1) < 1.0)
            ratio[undecided[self.too_slow(A[undecided])]] = 1.0
        return ratio.mean(axis=1)

    def _simulate(self, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> np.ndarray:
        """Simulations (R, N, p) of a batch from the zero state, restarted at each segment."""
        if len(self.starts) == 1:
            return simulate_batch(A, B, C, self.u)
        return self._by_segment(lambda a, b: simulate_batch(A, B, C, self.u[a:b]))

    def _by_segment(self, run: Callable[[int, int], np.ndarray]) -> np.ndarray:
        """``run(start, stop)`` on each segment, the results (R, segment length, p) end to end."""
        N = self.z.shape[0]
        return np.concatenate([run(a, b) for a, b in zip(self.starts, (*self.starts[1:], N))], axis=1)

    def too_slow(self, A: np.ndarray) -> np.ndarray:
        """Which models of the batch ``A`` (R, n, n) have a pole of modulus ``max_radius`` or more."""
        if self.max_radius is None:
            return np.zeros(A.shape[0], bool)
        return np.max(np.abs(np.linalg.eigvals(A)), axis=1) >= self.max_radius


def score_lists(
    scorers: Sequence[FilterScorer], etas: Sequence[np.ndarray]
) -> list[tuple[np.ndarray, tuple[np.ndarray, ...]]]:
    """:meth:`FilterScorer.score` for several lists of indices at once.

    The models of lists of the same order share one simulation batch (up to
    :data:`JOINT_BATCH_VALUES` simulated values), which saves the per-call cost of
    the many small batches a structure search scores (one barycenter per list).

    Parameters
    ----------
    scorers : sequence of FilterScorer
        Scorers of one record, cache and criterion (``x0``, ``max_radius``,
        ``trend_degree``).
    etas : sequence of ndarray, shape (R_i, 2)
        Candidates ``(wc, zeta)`` of each scorer.

    Returns
    -------
    list of (ndarray, tuple of ndarray)
        Each scorer's J and models, as :meth:`FilterScorer.score` returns them.
    """
    first = scorers[0]
    for other in scorers[1:]:
        if other.z is not first.z or other.cache is not first.cache or (
            other.x0, other.max_radius, other.trend_degree, other.starts
        ) != (first.x0, first.max_radius, first.trend_degree, first.starts):
            raise OptionError("lists scored together must share the record, the cache and the criterion")
    if first.cache is None:
        fits = [scorer.fit(np.asarray(e, float)) for scorer, e in zip(scorers, etas)]
    else:
        fits = _fit_cached(scorers, etas)
    costs: list[np.ndarray] = [np.empty(0)] * len(scorers)
    by_order: dict[int, list[int]] = {}
    for i, matrices in enumerate(fits):
        by_order.setdefault(matrices[0].shape[1], []).append(i)
    limit = max(JOINT_BATCH_VALUES // first.y.size, 1)
    for members in by_order.values():
        for chunk in _chunks(members, [len(fits[i][0]) for i in members], limit):
            joint = first.criterion(tuple(
                np.concatenate([fits[i][k] for i in chunk]) for k in range(len(fits[chunk[0]]))
            ))
            ends = np.cumsum([len(fits[i][0]) for i in chunk])[:-1]
            for i, part in zip(chunk, np.split(joint, ends)):
                costs[i] = part
    for scorer, e in zip(scorers, etas):
        scorer.evaluations += len(e)
    return list(zip(costs, fits))


def _fit_cached(scorers: Sequence[FilterScorer], etas: Sequence[np.ndarray]) -> list[tuple[np.ndarray, ...]]:
    """Each scorer's models, with the least-squares problems of all of them solved together."""
    cache = scorers[0].cache
    filters = [cache.filters(np.asarray(e, float), sc.indices, sc.Ts, sc.s) for sc, e in zip(scorers, etas)]
    keys = cache.solve([(full, parts, sc.indices) for (full, parts), sc in zip(filters, scorers)])
    return [
        sc.realize(cache.thetas(k, sc.indices), parts) for sc, k, (_, parts) in zip(scorers, keys, filters)
    ]


def _chunks(items: list[int], sizes: list[int], limit: int) -> list[list[int]]:
    """Consecutive groups of ``items`` whose sizes add up to at most ``limit``.

    An item larger than ``limit`` forms a group of its own.
    """
    groups: list[list[int]] = []
    total = 0
    for item, size in zip(items, sizes):
        if not groups or total + size > limit:
            groups.append([])
            total = 0
        groups[-1].append(item)
        total += size
    return groups
