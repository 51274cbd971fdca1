"""Per-output filters: after the shared filter search, each output's cutoff on its own.

Output ``j``'s least-squares problem involves only its own divisor ``alpha_j``
(docs/method.md §3), so the divisors need not come from one filter ``alpha``:
any monic stable ``alpha_j`` of degree ``l_j`` gives an observable observer form, and
every output keeps its exact-recovery property. Outputs with very different speeds
(a slow temperature next to a fast moisture reading) are then each weighted by a
filter of their own bandwidth. The shared filter's search stays as it is (it ranks
the lists of the structure path); this step only re-tunes the cutoffs of a list's
model, on the same criterion J, from the least-squares solutions the search has
already cached.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import OptionError
from .criterion import FilterScorer

__all__ = ["OutputFilters", "cutoff_candidates", "tune_output_cutoffs"]


@dataclass
class OutputFilters:
    """Outcome of :func:`tune_output_cutoffs` for one list of indices.

    Attributes
    ----------
    etas : ndarray, shape (p, 2)
        Each output's filter ``(wc, zeta)``.
    divisors : list of ndarray
        Each output's filter polynomial, degree ``indices[j]``.
    J : float
        Criterion of the model with these filters.
    J_shared : float
        Criterion of the model with the shared filter it started from.
    matrices : tuple of ndarray
        ``(A, B, C)`` (and ``D`` when the scorer estimates feedthrough) of that model.
    """

    etas: np.ndarray
    divisors: list[np.ndarray]
    J: float
    J_shared: float
    matrices: tuple[np.ndarray, ...] = field(repr=False)


def cutoff_candidates(eta: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """``eta`` followed by the other cutoffs of ``omega`` at the damping nearest ``eta``'s.

    Parameters
    ----------
    eta : ndarray, shape (2,)
        The shared filter ``(wc, zeta)``.
    omega : ndarray, shape (R, 2)
        The filter grid.

    Returns
    -------
    ndarray, shape (K + 1, 2)

    Examples
    --------
    >>> from moli.method.tuning.barycenter import grid
    >>> cutoff_candidates(np.array([0.3, 0.8]), grid([0.1, 1.0], [0.6, 1.1]))
    array([[0.3, 0.8],
           [0.1, 0.6],
           [1. , 0.6]])
    >>> cutoff_candidates(np.array([1.0, 1.1]), grid([0.1, 1.0], [0.6, 1.1]))
    array([[1. , 1.1],
           [0.1, 1.1]])
    """
    zetas = np.unique(omega[:, 1])
    zeta = zetas[np.argmin(np.abs(zetas - eta[1]))]
    row = omega[(omega[:, 1] == zeta) & np.any(omega != eta, axis=1)]
    return np.vstack([eta[None], row])


def tune_output_cutoffs(scorer: FilterScorer, eta: np.ndarray, omega: np.ndarray) -> OutputFilters:
    """Give each output of a list the filter cutoff that lowers J most.

    The candidates are :func:`cutoff_candidates`. One step scores, in a single
    batch, the model with the shared filter and every model that changes one
    output's filter to another candidate; the model that takes each output's best
    change at once is scored next, and the lowest J of all is kept, so the result
    is never worse than the shared filter on J.

    Parameters
    ----------
    scorer : FilterScorer
        Scorer of the list, with the search's :class:`moli.method.least_squares.shared_factors.RegressionCache`
        (the grid's solutions are reused from it).
    eta : ndarray, shape (2,)
        The shared filter found by the search.
    omega : ndarray, shape (R, 2)
        The filter grid.

    Returns
    -------
    OutputFilters
    """
    cache = scorer.cache
    if cache is None:
        raise OptionError("per-output filters need a scorer built with a RegressionCache")
    indices = scorer.indices
    p = len(indices)
    candidates = cutoff_candidates(np.asarray(eta, float), omega)
    full, parts = cache.filters(candidates, indices, scorer.Ts, scorer.s)
    thetas = cache.thetas(cache.solve([(full, parts, indices)])[0], indices)
    K = len(candidates)

    def models(choices: np.ndarray) -> tuple[np.ndarray, ...]:
        return scorer.realize(
            [thetas[j][choices[:, j]] for j in range(p)],
            [[parts[k][j] for j, k in enumerate(row)] for row in choices],
        )

    # row 0: the shared filter; then output j's filter set to candidate k, others shared
    choices = np.zeros((1 + p * (K - 1), p), int)
    for j in range(p):
        choices[1 + j * (K - 1) : 1 + (j + 1) * (K - 1), j] = np.arange(1, K)
    batch = models(choices)
    # the fit first; the pole-radius rule (J = 1) only for the models that could win,
    # which gives the winners of the rule applied to all at a fraction of the eigenvalues
    costs = scorer.criterion(batch, radius_rule=False)
    checked = np.zeros(len(costs), bool)
    checked[0] = True                       # the shared filter's J is reported as it is
    if scorer.too_slow(batch[0][:1])[0]:
        costs[0] = 1.0

    def winners() -> np.ndarray:
        while True:
            per_output = np.column_stack([np.full(p, costs[0]), costs[1:].reshape(p, K - 1)])
            picks = per_output.argmin(axis=1)
            rows = np.unique(np.where(picks > 0, 1 + np.arange(p) * (K - 1) + picks - 1, 0))
            rows = rows[~checked[rows]]
            if not rows.size:
                return picks
            checked[rows] = True
            costs[rows[scorer.too_slow(batch[0][rows])]] = 1.0

    combined = winners()
    if np.count_nonzero(combined) > 1:
        last = models(combined[None])
        choices = np.vstack([choices, combined])
        costs = np.append(costs, scorer.criterion(last))
        batch = tuple(np.concatenate(pair) for pair in zip(batch, last))
    best = int(np.argmin(costs))
    row = choices[best]
    matrices = tuple(M[best] for M in batch)
    return OutputFilters(
        etas=candidates[row], divisors=[parts[k][j] for j, k in enumerate(row)],
        J=float(costs[best]), J_shared=float(costs[0]), matrices=matrices,
    )
