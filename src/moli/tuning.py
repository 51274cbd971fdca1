"""Zero-order oracle filter tuning (ZOFT): barycenter search over eta = (wc, zeta).

``J(eta)`` is the paper's criterion: estimate with the filter ``alpha(eta)``,
simulate the model from the zero state on the estimation inputs, and average
``min(var(y_i - yhat_i)/var(y_i), 1)`` over the outputs. Candidates are scored in
batches (one least-squares batch per output, one batched simulation).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from .errors import OptionError
from .estimation import filtered_regressors, fit_batch, realize, solve_batch
from .filters import _pick_divisor, filter_divisors, filter_roots
from .simulation import simulate_batch
from .structure import Indices

TUNING_METHODS = ("grid", "random")
# The paper's weight: mu = 40 / min J, i.e. a candidate whose J is 10 % above the
# best weighs exp(-4) ~ 2 % of it.
MU_SCALE = 40.0
# The paper's evaporator grid (T = 1): wc = 0.02*pi ... 0.3548*pi, log-spaced.
PAPER_ZETAS = (0.6, 0.7, 1.1)
PAPER_WCS_PER_TS = tuple(0.02 * np.pi * 10 ** (0.25 * k) for k in range(6))


def default_omega(Ts: float = 1.0) -> np.ndarray:
    """The paper's 18-point evaporator grid with frequencies scaled to ``Ts``.

    Cutoffs span 0.02*pi/Ts to 0.355*pi/Ts (1 % to 18 % of the Nyquist frequency,
    log-spaced), dampings 0.6, 0.7, 1.1: the range holds the dominant dynamics of
    plants sampled 5 to 50 times per time constant.

    Returns
    -------
    ndarray, shape (18, 2)
        Rows ``(wc, zeta)``, wc in rad per time unit of ``Ts``.
    """
    return grid(np.array(PAPER_WCS_PER_TS) / Ts, PAPER_ZETAS)


def grid(wcs: Sequence[float], zetas: Sequence[float]) -> np.ndarray:
    """All pairs ``(wc, zeta)`` of the given values, shape (len(wcs) * len(zetas), 2).

    Examples
    --------
    >>> grid([1.0, 2.0], [0.7])
    array([[1. , 0.7],
           [2. , 0.7]])
    """
    w, z = np.meshgrid(np.asarray(wcs, float), np.asarray(zetas, float), indexing="ij")
    return np.column_stack([w.ravel(), z.ravel()])


def check_omega(omega: object) -> np.ndarray:
    """Validate a candidate set: finite positive rows ``(wc, zeta)``."""
    array = np.array(omega, dtype=float)
    if array.ndim != 2 or array.shape[1] != 2 or array.shape[0] < 1:
        raise OptionError(f"omega must have shape (R, 2) with rows (wc, zeta), got {array.shape}")
    if not np.all(np.isfinite(array)) or np.any(array <= 0):
        raise OptionError("omega's wc and zeta must all be positive and finite")
    return array


def barycenter(etas: np.ndarray, costs: np.ndarray) -> np.ndarray:
    """Paper eq. (5): ``sum eta_r exp(-mu J_r) / sum exp(-mu J_r)``, ``mu = 40/min J``.

    Examples
    --------
    >>> barycenter(np.array([[1.0, 1.0], [3.0, 1.0]]), np.array([0.1, 0.1]))
    array([2., 1.])
    """
    best = costs.min()
    if best <= 0:
        weights = (costs <= best).astype(float)
    else:
        weights = np.exp(-MU_SCALE * (costs - best) / best)
    return weights @ etas / weights.sum()


class RegressionCache:
    """Triangular factors and per-output solutions shared by the lists of one search.

    For a filter ``alpha`` of degree ``nbar`` the observer state ``xi`` holds every
    signal filtered by ``q^t/alpha``, ``t < nbar``; each output's regressors are ``xi``
    times a fixed matrix built from ``alpha/alpha_j`` (ALGORITHM.md, section 3), and
    its earlier outputs are columns of ``y``. So one QR of ``X = [xi, y]`` (triangular
    factor only) serves every output and every list that uses the same ``alpha``: each
    least-squares problem ``min |X (T theta - e)|`` becomes the small problem
    ``min |R (T theta - e)|``, with the same solution. Solutions are cached per
    ``(alpha, output, index)``, so a list that differs from an earlier one in a single
    index re-solves a single output.

    Parameters
    ----------
    z : ndarray, shape (N, p + m)
        Estimation outputs then inputs (centred).
    p : int
        Number of outputs.
    """

    def __init__(self, z: np.ndarray, p: int) -> None:
        self.z = z
        self.p = p
        self._factors: dict[bytes, np.ndarray] = {}
        self._thetas: dict[tuple[bytes, int, int], tuple[np.ndarray, float]] = {}
        self._filters: dict[tuple, tuple[np.ndarray, dict[int, np.ndarray]]] = {}
        self.factorizations = 0
        self.solves = 0

    def filters(
        self, wc: float, zeta: float, indices: Indices, Ts: float, s: float
    ) -> tuple[np.ndarray, dict[int, np.ndarray]]:
        """``alpha`` and its divisors by degree for ``eta = (wc, zeta)`` (cached).

        The roots depend on ``indices`` only through ``max(indices)`` and the set of
        index values (see :mod:`moli.filters`), which is the cache key.
        """
        key = (wc, zeta, Ts, s, max(indices), frozenset(indices))
        if key not in self._filters:
            roots = filter_roots(wc, zeta, indices, Ts, s)
            alpha = np.real(np.poly(roots))
            nbar = alpha.size - 1
            self._filters[key] = (
                alpha, {l: (alpha if l == nbar else _pick_divisor(roots, l)) for l in set(indices)}
            )
        return self._filters[key]

    def factor(self, alphas: Sequence[np.ndarray]) -> list[np.ndarray]:
        """Triangular factors of ``[xi, y]`` for each filter polynomial (batched, cached)."""
        keys = [a.tobytes() for a in alphas]
        todo = {k: a for k, a in zip(keys, alphas) if k not in self._factors}
        if todo:
            by_degree: dict[int, list[tuple[bytes, np.ndarray]]] = {}
            for k, a in todo.items():
                by_degree.setdefault(a.size - 1, []).append((k, a))
            N, c = self.z.shape
            for nbar, items in by_degree.items():
                stack = np.empty((len(items), N - nbar, c * nbar + self.p))
                for i, (_, a) in enumerate(items):
                    stack[i, :, : c * nbar] = filtered_regressors(self.z, a)[nbar:]
                stack[:, :, c * nbar :] = self.z[nbar:, : self.p]
                factors = np.linalg.qr(stack, mode="r")
                for (k, _), r in zip(items, factors):
                    self._factors[k] = r
                self.factorizations += len(items)
        return [self._factors[k] for k in keys]

    def thetas(
        self, alphas: Sequence[np.ndarray], divisors_: Sequence[Sequence[np.ndarray]], indices: Indices
    ) -> tuple[list[np.ndarray], np.ndarray]:
        """Per-output parameters for a batch of filters, as :func:`fit_batch` computes them.

        Returns
        -------
        thetas : list of ndarray
            ``thetas[j]`` has shape (R, (p + m) l_j + j).
        cond : ndarray, shape (R,)
            Worst condition estimate over the outputs.
        """
        R = len(alphas)
        c = self.z.shape[1]
        keys = [a.tobytes() for a in alphas]
        factors = self.factor(alphas)
        thetas = []
        cond = np.ones(R)
        for j, l in enumerate(indices):
            out = np.empty((R, c * l + j))
            missing = [r for r in range(R) if (keys[r], j, l) not in self._thetas]
            if missing:
                small, rhs = [], []
                for r in missing:
                    T = _regressor_map(alphas[r], divisors_[r][j], c, self.p, j)
                    small.append(factors[r] @ T)
                    rhs.append(factors[r][:, c * (alphas[r].size - 1) + j])
                rows = {M.shape[0] for M in small}
                if len(rows) == 1 and rows.pop() >= small[0].shape[1]:
                    theta, cnd = solve_batch(np.stack(small), np.stack(rhs))
                else:  # short records: fall back to one problem at a time
                    pairs = [solve_batch(M[None], b[None]) for M, b in zip(small, rhs)]
                    theta = np.concatenate([t for t, _ in pairs])
                    cnd = np.concatenate([k for _, k in pairs])
                for i, r in enumerate(missing):
                    self._thetas[(keys[r], j, l)] = (theta[i], float(cnd[i]))
                self.solves += len(missing)
            for r in range(R):
                out[r], cr = self._thetas[(keys[r], j, l)]
                cond[r] = max(cond[r], cr)
            thetas.append(out)
        return thetas, cond


def _regressor_map(alpha: np.ndarray, alpha_j: np.ndarray, c: int, p: int, j: int) -> np.ndarray:
    """Matrix ``T`` with ``[xi, y] T`` = output ``j``'s regressors ``[w_j, y_<j]``.

    Column ``r l + i`` is ``q^i (alpha/alpha_j)(q) / alpha(q)`` applied to channel ``r``:
    with ``alpha/alpha_j = sum_k c_k q^(d-k)``, ``d = nbar - l``, it is
    ``sum_k c_k xi_(r, i+d-k)``.
    """
    nbar, l = alpha.size - 1, alpha_j.size - 1
    d = nbar - l
    # monic long division alpha / alpha_j (exact: alpha_j divides alpha)
    quotient = np.empty(d + 1)
    rest = alpha.copy()
    for k in range(d + 1):
        quotient[k] = rest[k]
        rest[k : k + l + 1] -= quotient[k] * alpha_j
    T = np.zeros((c, nbar, c, l))
    channels = np.arange(c)
    for i in range(l):
        for k in range(d + 1):
            T[channels, i + d - k, channels, i] = quotient[k]
    T = T.reshape(c * nbar, c * l)
    tail = np.zeros((p, c * l + j))
    tail[np.arange(j), c * l + np.arange(j)] = 1.0
    return np.vstack([np.hstack([T, np.zeros((c * nbar, j))]), tail])


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
    """

    def __init__(
        self, z: np.ndarray, indices: Indices, Ts: float, s: float,
        cache: RegressionCache | None = None,
    ) -> None:
        self.z = z
        self.indices = indices
        self.Ts = Ts
        self.s = s
        self.cache = cache
        p = len(indices)
        self.y = z[:, :p]
        self.u = z[:, p:]
        self.y_var = np.var(self.y, axis=0)
        self.evaluations = 0

    def fit(self, etas: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The batch of models ``(A, B, C)`` estimated with each candidate filter."""
        p = len(self.indices)
        if self.cache is None:
            alphas = [filter_divisors(w, zeta, self.indices, self.Ts, self.s) for w, zeta in etas]
            A, B, C, _ = fit_batch(self.z, self.indices, alphas)
            return A, B, C
        full, parts = [], []
        for w, zeta in etas:
            alpha, divs = self.cache.filters(float(w), float(zeta), self.indices, self.Ts, self.s)
            full.append(alpha)
            parts.append([divs[l] for l in self.indices])
        thetas, _ = self.cache.thetas(full, parts, self.indices)
        return realize(thetas, parts, self.indices, self.z.shape[1] - p)

    def score(self, etas: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """J of each candidate and the batch of fitted models ``(A, B, C)``."""
        A, B, C = self.fit(etas)
        yhat = simulate_batch(A, B, C, self.u)
        with np.errstate(all="ignore"):
            ratio = np.var(self.y[None] - yhat, axis=1) / self.y_var
        ratio = np.where(np.isfinite(ratio), np.minimum(ratio, 1.0), 1.0)
        self.evaluations += len(etas)
        return ratio.mean(axis=1), (A, B, C)


@dataclass
class TuningResult:
    """Outcome of filter tuning for one list of indices.

    Attributes
    ----------
    eta : ndarray, shape (2,)
        Chosen ``(wc, zeta)``: the lowest J among every candidate and barycenter scored.
    J : float
        Its criterion value.
    barycenter : ndarray, shape (2,)
        Last barycenter computed.
    J_barycenter : float
        J evaluated at that barycenter.
    J_grid_best : float
        Lowest J over the grid Omega alone.
    evaluations : int
        Number of least-squares fits (each one per output) performed.
    A, B, C : ndarray
        Matrices of the chosen model.
    """

    eta: np.ndarray
    J: float
    barycenter: np.ndarray
    J_barycenter: float
    J_grid_best: float
    evaluations: int
    A: np.ndarray = field(repr=False)
    B: np.ndarray = field(repr=False)
    C: np.ndarray = field(repr=False)


class _Tracker:
    """Keeps the best candidate seen so far."""

    def __init__(self) -> None:
        self.J = np.inf
        self.eta: np.ndarray | None = None
        self.matrices: tuple[np.ndarray, ...] = ()

    def offer(self, etas: np.ndarray, costs: np.ndarray, matrices: tuple[np.ndarray, ...]) -> None:
        i = int(np.argmin(costs))
        if costs[i] < self.J:
            self.J = float(costs[i])
            self.eta = etas[i].copy()
            self.matrices = tuple(M[i] for M in matrices)


def tune_filter(
    scorer: FilterScorer,
    omega: np.ndarray,
    method: str = "random",
    iterations: int = 5,
    seed: int | np.random.Generator = 0,
) -> TuningResult:
    """Tune the filter of one list of indices.

    Parameters
    ----------
    scorer : FilterScorer
    omega : ndarray, shape (R, 2)
        Grid of candidates ``(wc, zeta)``.
    method : {"grid", "random"}
        ``"grid"``: one barycenter over ``omega`` (paper eq. 5). ``"random"``: the
        paper's randomized variant; starting from the grid barycenter, each step
        scores seven candidates (the previous barycenter, three points of ``omega``
        drawn at random, three normal draws around the barycenter with standard
        deviation 20 % of the range of ``omega``'s wc and zeta values, clipped to
        ``omega``'s bounding box) and moves to their barycenter.
    iterations : int, default 5
        Steps of the randomized variant.
    seed : int or numpy.random.Generator
        Seed of the random draws (results are reproducible for a given seed).

    Returns
    -------
    TuningResult
    """
    if method not in TUNING_METHODS:
        raise OptionError(f"tuning method must be one of {TUNING_METHODS}, got {method!r}")
    if int(iterations) != iterations or iterations < 0:
        raise OptionError(f"iterations must be a non-negative integer, got {iterations!r}")
    rng = np.random.default_rng(seed)
    start = scorer.evaluations
    best = _Tracker()
    costs, matrices = scorer.score(omega)
    best.offer(omega, costs, matrices)
    grid_best = best.J
    center = barycenter(omega, costs)
    if method == "grid":
        steps = 0
    else:
        steps = int(iterations)
    low, high = omega.min(axis=0), omega.max(axis=0)
    spread = 0.2 * (high - low)
    for _ in range(steps):
        drawn = omega[rng.choice(len(omega), size=min(3, len(omega)), replace=False)]
        local = np.clip(center + spread * rng.standard_normal((3, 2)), low, high)
        etas = np.vstack([center, drawn, local])
        costs, matrices = scorer.score(etas)
        best.offer(etas, costs, matrices)
        center = barycenter(etas, costs)
    center_cost, matrices = scorer.score(center[None])
    best.offer(center[None], center_cost, matrices)
    A, B, C = best.matrices
    return TuningResult(
        eta=best.eta, J=best.J, barycenter=center, J_barycenter=float(center_cost[0]),
        J_grid_best=grid_best, evaluations=scorer.evaluations - start, A=A, B=B, C=C,
    )
