"""Zero-order oracle filter tuning (ZOFT): barycenter search over eta = (wc, zeta).

The candidates of the grid ``Omega`` are scored by :mod:`moli.method.tuning.criterion`; the
barycenter of paper eq. (5) weighs them by ``exp(-mu J)`` (docs/method.md §5).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ...data.arguments import real_array
from ...errors import OptionError
from .criterion import FilterScorer, score_lists

__all__ = [
    "default_omega", "grid", "check_omega", "barycenter", "TuningResult", "tune_filter",
    "tune_filters",
]

TUNING_METHODS = ("grid", "random", "zoom")
# The paper's weight: mu = 40 / min J, i.e. a candidate whose J is 10 % above the
# best weighs exp(-4) ~ 2 % of it.
MU_SCALE = 40.0
# The paper's evaporator grid (T = 1): wc = 0.02*pi ... 0.3548*pi, log-spaced.
PAPER_ZETAS = (0.6, 0.7, 1.1)
PAPER_WCS_PER_TS = tuple(0.02 * np.pi * 10 ** (0.25 * k) for k in range(6))


# Candidate families of default_omega: cutoffs as powers 10**(k/4) of 0.02*pi per Ts,
# and dampings. "paper" is the evaporator grid; the others add lightly damped
# candidates and (wide) a decade more of cutoffs.
GRIDS = {
    "paper": (range(6), PAPER_ZETAS),
    "damped": (range(6), (0.1, 0.3) + PAPER_ZETAS),
    "wide": (range(-2, 7), (0.1, 0.3) + PAPER_ZETAS),
    "wide3": (range(-2, 7), PAPER_ZETAS),
    "wider": (range(-4, 7), (0.1, 0.3) + PAPER_ZETAS),
    "widez": (range(-2, 7), (0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.1, 1.5)),
}


def default_omega(Ts: float = 1.0, family: str = "paper") -> np.ndarray:
    """A grid of filter candidates with frequencies scaled to ``Ts``.

    "paper": the paper's 18-point evaporator grid. Cutoffs span 0.02*pi/Ts to
    0.355*pi/Ts (1 % to 18 % of the sampling frequency, log-spaced), dampings 0.6, 0.7,
    1.1: the range holds the dominant dynamics of plants sampled 5 to 50 times per
    time constant. "damped" adds the dampings 0.1 and 0.3 (30 points); "wide" also
    spans cutoffs from 0.0063*pi/Ts to 0.63*pi/Ts (45 points).

    Returns
    -------
    ndarray, shape (R, 2)
        Rows ``(wc, zeta)``, wc in rad per time unit of ``Ts``.
    """
    if family not in GRIDS:
        raise OptionError(f"family must be one of {tuple(GRIDS)}, got {family!r}")
    powers, zetas = GRIDS[family]
    return grid(np.array([0.02 * np.pi * 10 ** (0.25 * k) for k in powers]) / Ts, zetas)


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
    array = real_array("omega", omega, error=OptionError, finite=False)
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
    D : ndarray or None
        Its feedthrough, when the scorer estimates one.
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
    D: np.ndarray | None = field(default=None, repr=False)


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
    method : {"grid", "random", "zoom"}
        ``"grid"``: one barycenter over ``omega`` (paper eq. 5). ``"zoom"``: a bounded
        coarse-to-fine search from the best point of ``omega``: each step scores the
        eight neighbours at half the previous spacing (wc on a log scale, the first
        spacing half of ``omega``'s), clipped to ``omega``'s bounding box, and moves to
        the best point seen. ``"random"``: the
        paper's randomized variant; starting from the grid barycenter, each step
        scores seven candidates (the previous barycenter, three points of ``omega``
        drawn at random, three normal draws around the barycenter with standard
        deviation 20 % of the range of ``omega``'s wc and zeta values, clipped to
        ``omega``'s bounding box) and moves to their barycenter.
    iterations : int, default 5
        Steps of the randomized or the zoom search.
    seed : int or numpy.random.Generator
        Seed of the random draws (results are reproducible for a given seed).

    Returns
    -------
    TuningResult
    """
    return tune_filters([scorer], omega, method, iterations, [seed])[0]


def tune_filters(
    scorers: Sequence[FilterScorer],
    omega: np.ndarray,
    method: str = "random",
    iterations: int = 5,
    seeds: Sequence[int | np.random.Generator] | None = None,
) -> list[TuningResult]:
    """:func:`tune_filter` for several lists, run in step so their batches are scored together.

    Each list gets the result :func:`tune_filter` gives it alone (with its own seed),
    up to round-off; the scorers must qualify for :func:`score_lists`.

    Parameters
    ----------
    scorers : sequence of FilterScorer
    omega, method, iterations
        As in :func:`tune_filter`.
    seeds : sequence of int or numpy.random.Generator, optional
        One per scorer; 0 for each by default.

    Returns
    -------
    list of TuningResult
    """
    if method not in TUNING_METHODS:
        raise OptionError(f"tuning method must be one of {TUNING_METHODS}, got {method!r}")
    if int(iterations) != iterations or iterations < 0:
        raise OptionError(f"iterations must be a non-negative integer, got {iterations!r}")
    seeds = [0] * len(scorers) if seeds is None else list(seeds)
    if len(seeds) != len(scorers):
        raise OptionError(f"give one seed per scorer: {len(scorers)} scorers, {len(seeds)} seeds")
    rngs = [np.random.default_rng(seed) for seed in seeds]
    starts = [scorer.evaluations for scorer in scorers]
    trackers = [_Tracker() for _ in scorers]
    centers = []
    grid_scores = score_lists(scorers, [omega] * len(scorers))
    for tracker, (costs, matrices) in zip(trackers, grid_scores):
        tracker.offer(omega, costs, matrices)
        centers.append(barycenter(omega, costs))
    grid_best = [tracker.J for tracker in trackers]
    if method == "zoom":
        _zoom(scorers, omega, trackers, int(iterations))
        return [
            _result(tracker, center, np.nan, best, scorer.evaluations - start)
            for tracker, center, best, scorer, start in zip(trackers, centers, grid_best, scorers, starts)
        ]
    steps = 0 if method == "grid" else int(iterations)
    low, high = omega.min(axis=0), omega.max(axis=0)
    spread = 0.2 * (high - low)
    for _ in range(steps):
        drawn = [rng.choice(len(omega), size=min(3, len(omega)), replace=False) for rng in rngs]
        fresh = [
            np.vstack([center, np.clip(center + spread * rng.standard_normal((3, 2)), low, high)])
            for center, rng in zip(centers, rngs)
        ]
        for i, (costs, matrices) in enumerate(score_lists(scorers, fresh)):
            trackers[i].offer(fresh[i], costs, matrices)
            # the grid points drawn keep the J they scored in the grid round
            etas = np.vstack([fresh[i][:1], omega[drawn[i]], fresh[i][1:]])
            centers[i] = barycenter(etas, np.concatenate([costs[:1], grid_scores[i][0][drawn[i]], costs[1:]]))
    results = []
    last = score_lists(scorers, [center[None] for center in centers])
    for tracker, center, (cost, matrices), best, scorer, start in zip(
        trackers, centers, last, grid_best, scorers, starts
    ):
        tracker.offer(center[None], cost, matrices)
        results.append(_result(tracker, center, float(cost[0]), best, scorer.evaluations - start))
    return results


def _result(
    best: _Tracker, center: np.ndarray, J_barycenter: float, grid_best: float, evaluations: int
) -> TuningResult:
    A, B, C = best.matrices[:3]
    D = best.matrices[3] if len(best.matrices) == 4 else None
    return TuningResult(
        eta=best.eta, J=best.J, barycenter=center, J_barycenter=J_barycenter,
        J_grid_best=grid_best, evaluations=evaluations, A=A, B=B, C=C, D=D,
    )


def _spacing(values: np.ndarray) -> float:
    unique = np.unique(values)
    return float(np.median(np.diff(unique))) if unique.size > 1 else 0.1 * max(abs(unique[0]), 1e-3)


def _zoom(scorers: Sequence[FilterScorer], omega: np.ndarray, best: list[_Tracker], steps: int) -> None:
    """Coarse-to-fine search in ``(log wc, zeta)`` from each list's best grid point."""
    low = np.array([np.log(omega[:, 0].min()), omega[:, 1].min()])
    high = np.array([np.log(omega[:, 0].max()), omega[:, 1].max()])
    step = 0.5 * np.array([_spacing(np.log(omega[:, 0])), _spacing(omega[:, 1])])
    offsets = np.array([(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1) if (a, b) != (0, 0)], float)
    for _ in range(steps):
        etas = []
        for tracker in best:
            here = np.array([np.log(tracker.eta[0]), tracker.eta[1]])
            points = np.unique(np.clip(here + offsets * step, low, high), axis=0)
            etas.append(np.column_stack([np.exp(points[:, 0]), points[:, 1]]))
        for tracker, e, (costs, matrices) in zip(best, etas, score_lists(scorers, etas)):
            tracker.offer(e, costs, matrices)
        step = step / 2
