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
from .estimation import fit_batch
from .filters import filter_divisors
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


class FilterScorer:
    """Scores filter candidates for one list of indices on one estimation record.

    Parameters
    ----------
    z : ndarray, shape (N, p + m)
        Estimation outputs then inputs (centred).
    indices : tuple of int
    Ts, s : float
        Sampling period and root spacing factor of the filters.
    """

    def __init__(self, z: np.ndarray, indices: Indices, Ts: float, s: float) -> None:
        self.z = z
        self.indices = indices
        self.Ts = Ts
        self.s = s
        p = len(indices)
        self.y = z[:, :p]
        self.u = z[:, p:]
        self.y_var = np.var(self.y, axis=0)
        self.evaluations = 0

    def score(self, etas: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """J of each candidate and the batch of fitted models ``(A, B, C)``."""
        alphas = [filter_divisors(w, zeta, self.indices, self.Ts, self.s) for w, zeta in etas]
        A, B, C, _ = fit_batch(self.z, self.indices, alphas)
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
