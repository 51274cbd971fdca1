"""The MOLI start on a frequency grid: each output's filtered regression, one linear least squares over the lines.

The observer form of docs/method.md §3-§4 holds at every point ``lambda`` of the lines
(``z = exp(1j omega Ts)``, or ``s`` in the fit domain's units): with ``Z = [G; I_m]``
(outputs, then inputs, one column per input), output ``j``'s row of the response obeys

    G_jc = sum_r sum_{i < l_j} theta_jri lambda^i / alpha_j(lambda) Z_rc + sum_{i < j} g_ji G_ic + f_jc

for every input ``c``: the time domain's filtered regressors ``q^i / alpha_j(q) z`` become
products with ``lambda^i / alpha_j(lambda)`` on the grid, and the parameters of each output
solve one linear least squares over the lines and inputs, real and imaginary parts as
separate rows, each row weighted by ``1 / sqrt`` of its entry's variance. The lines are
folded into the triangular factor :data:`LINE_BLOCK` at a time, so memory does not grow
with them; the small problem is solved as the time domain solves it
(:func:`moli.method.least_squares.estimation.solve_batch`) and realized by its observer
form (:func:`moli.method.least_squares.realization.observer_form_matrices`).

The filter: discrete data take the time domain's root rule
(:func:`moli.method.structure.filters.filter_divisors`) in rad per sample; continuous data the
continuous one (:func:`moli.method.continuous.filters.unit_divisors`, built for ``wc = 1``)
at the points divided by ``wc``, whose model's ``A`` and ``B`` are then ``wc`` times the
unit model's. The candidates are cutoffs spread over the lines' band at one damping
(:func:`filter_candidates`); the order's start is the candidate whose model fits the
held-out lines best (docs/frequency.md §2b).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from ...numerics.triangular import TALL_QR_BLOCK, fold
from ..continuous.filters import unit_divisors
from ..least_squares.estimation import solve_batch
from ..least_squares.realization import observer_form_matrices
from ..structure.filters import filter_divisors
from ..structure.indices import Indices, generic_indices
from .fit_error import FitProblem, cost
from .modal_form import ModalLayout
from .orders import FrequencyStep, judged_step, modal_start
from .settings import FrequencySettings
from .subspace import LINE_BLOCK

__all__ = ["LineFilter", "output_parameters", "observer_matrices", "filter_candidates", "filtered_start",
           "moli_start", "with_moli_start", "CUTOFFS_PER_DECADE", "DAMPING", "ROOT_SPACING",
           "FASTEST_ANGLE"]

# Cutoffs per decade of the lines' band (the continuous time grid's two, docs/continuous.md §3).
CUTOFFS_PER_DECADE = 2
# The damping of every candidate: on the benchmark's systems the cutoffs spread the held-out
# error of an order's start over factors of several hundred, and the best cutoff at 0.7 came
# within 3.3 of the best candidate of any damping in 0.1-1.1 (docs/frequency.md §2b), so the
# candidates spread the cutoff alone.
DAMPING = 0.7
# The root spacing factor ``s`` of the filters (the time domain's default, docs/method.md §2).
ROOT_SPACING = 2.0
# The fastest discrete cutoff, in rad per sample: the dominant pair's angle ``wc sqrt(1 - zeta^2)``
# then stays below the Nyquist angle pi, where the pair would merge into a double root at -1.
FASTEST_ANGLE = 0.9 * np.pi


@dataclass(frozen=True)
class LineFilter:
    """One candidate filter: each output's divisor ``alpha_j`` and the time unit it is built in.

    ``unit`` divides the points before the divisors are evaluated (a continuous filter's
    cutoff in the fit domain's units; 1 for a discrete one, whose divisors carry their cutoff).
    """

    divisors: tuple[np.ndarray, ...]
    unit: float


def _rows(points: np.ndarray, G: np.ndarray, weights: np.ndarray, j: int, divisor: np.ndarray,
          feedthrough: bool) -> np.ndarray:
    """Output ``j``'s weighted complex rows ``[regressors | target]`` on a block of lines, shape (F m, k + 1)."""
    F, p, m = G.shape
    l = divisor.size - 1
    filtered = points[:, None] ** np.arange(l) / np.polyval(divisor, points)[:, None]          # (F, l)
    Z = np.concatenate([G, np.broadcast_to(np.eye(m), (F, m, m))], axis=1)                     # (F, p + m, m)
    columns = [(Z[:, :, None, :] * filtered[:, None, :, None]).transpose(0, 3, 1, 2).reshape(F * m, -1),
               G[:, :j].transpose(0, 2, 1).reshape(F * m, j)]
    if feedthrough:
        columns.append(np.broadcast_to(np.eye(m), (F, m, m)).reshape(F * m, m))
    columns.append(G[:, j].reshape(F * m, 1))
    return np.concatenate(columns, axis=1) * weights[:, j].reshape(F * m, 1)


def output_parameters(points: np.ndarray, G: np.ndarray, weights: np.ndarray, indices: Indices,
                      divisors: Sequence[np.ndarray], feedthrough: bool) -> tuple[list[np.ndarray], float] | None:
    """Each output's least-squares parameters on the lines, and the worst condition estimate.

    Parameters
    ----------
    points : ndarray, shape (F,)
        The lines' points in the filter's unit (``z``, or ``s / wc``).
    G, weights : ndarray, shape (F, p, m)
        The responses and each entry's weight (``1 / sqrt`` of its variance).
    indices : tuple of int
    divisors : sequence of ndarray
        Output ``j``'s monic divisor ``alpha_j`` of degree ``indices[j]``.
    feedthrough : bool
        Whether each output's equation carries the current inputs (``f_j``, last).

    Returns
    -------
    thetas : list of ndarray
        Output ``j``'s ``(p + m) l_j`` filter weights (column ``r l_j + i``), its ``j``
        weights ``g_j`` of the earlier outputs, then ``m`` feedthrough weights.
    cond : float
        The worst condition estimate of the column-scaled problems.
    None where the lines give fewer real rows than an output's unknowns.
    """
    F, p, m = G.shape
    thetas, worst = [], 1.0
    for j, divisor in enumerate(divisors):
        unknowns = (p + m) * indices[j] + j + (m if feedthrough else 0)
        if 2 * F * m <= unknowns:
            return None
        triangle = None
        for start in range(0, F, LINE_BLOCK):
            part = slice(start, start + LINE_BLOCK)
            rows = _rows(points[part], G[part], weights[part], j, divisor, feedthrough)
            triangle = fold(triangle, np.concatenate([rows.real, rows.imag]).T, TALL_QR_BLOCK)
        theta, cond = solve_batch(triangle[None, :unknowns, :unknowns], triangle[None, :unknowns, unknowns])
        thetas.append(theta[0])
        worst = max(worst, float(cond[0]))
    return thetas, worst


def observer_matrices(thetas: Sequence[np.ndarray], divisors: Sequence[np.ndarray], indices: Indices, m: int,
                      feedthrough: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``A, B, C, D`` of the fitted observer form (docs/method.md §4, §8).

    The equations say ``(I - G) y = C_D x + F u``: ``C`` and ``A = A_D + D_y C`` as in time,
    ``D = (I - G)^-1 F`` (the columns of ``C`` at each block's last state are ``(I - G)^-1``),
    and the output injection ``D_y y`` adds ``D_y D`` to ``B``.
    """
    p = len(indices)
    parts = [theta[None, : (p + m) * l + j] for j, (theta, l) in enumerate(zip(thetas, indices))]
    A, B, C, injection = observer_form_matrices(parts, [list(divisors)], indices, m)
    A, B, C, injection = A[0], B[0], C[0], injection[0]
    if not feedthrough:
        return A, B, C, np.zeros((p, m))
    D = C[:, np.cumsum(indices) - 1] @ np.array([theta[-m:] for theta in thetas])
    return A, B + injection @ D, C, D


def filter_candidates(points: np.ndarray, indices: Indices, continuous: bool) -> list[LineFilter]:
    """The candidate filters for these lines: cutoffs over their band, each with the damping :data:`DAMPING`.

    The band is the lines' smallest to largest positive frequency in the fit domain
    (``|s|``, or the angle of ``z`` in rad per sample), :data:`CUTOFFS_PER_DECADE` cutoffs a
    decade, at least two; a discrete cutoff at most :data:`FASTEST_ANGLE`.
    """
    reach = np.abs(points) if continuous else np.abs(np.angle(points))
    positive = reach[reach > 0]
    low, high = float(positive.min()), float(positive.max())
    count = max(int(np.ceil(CUTOFFS_PER_DECADE * np.log10(high / low))) + 1, 2)
    cutoffs = np.geomspace(low, high, count)
    if continuous:                  # one filter in its own time unit, at each cutoff
        divisors = tuple(unit_divisors(DAMPING, indices, ROOT_SPACING)[1:])
        return [LineFilter(divisors, float(wc)) for wc in cutoffs]
    return [LineFilter(tuple(filter_divisors(min(float(wc), FASTEST_ANGLE), DAMPING, indices, 1.0, ROOT_SPACING)), 1.0)
            for wc in cutoffs]


def filtered_start(indices: Indices, line_filter: LineFilter, problem: FitProblem, settings: FrequencySettings,
                   continuous: bool) -> tuple[ModalLayout, np.ndarray] | None:
    """The MOLI model of ``indices`` with ``line_filter`` on the lines of ``problem``, in modal form
    (:func:`moli.method.frequency.orders.modal_start`); None where it has none."""
    points = problem.points / line_filter.unit
    fitted = output_parameters(points, problem.G, problem.weights, indices, line_filter.divisors,
                               settings.feedthrough)
    if fitted is None:
        return None
    A, B, C, D = observer_matrices(fitted[0], line_filter.divisors, indices, problem.G.shape[2],
                                   settings.feedthrough)
    if not np.all(np.isfinite(A)) or not np.all(np.isfinite(B)):
        return None
    return modal_start(A * line_filter.unit, B * line_filter.unit, C, D, problem, settings, continuous=continuous)


def moli_start(order: int, estimation: FitProblem, held_out: FitProblem, settings: FrequencySettings,
               continuous: bool) -> tuple[ModalLayout, np.ndarray] | None:
    """The MOLI start of ``order`` states: the generic list (:func:`generic_indices`) with the candidate
    filter whose model fits the held-out lines best; None below ``p`` states or where no candidate gives a model."""
    p = estimation.G.shape[1]
    if order < p:
        return None
    indices = generic_indices(order, p)
    best, best_cost = None, np.inf
    for line_filter in filter_candidates(estimation.points, indices, continuous):
        start = filtered_start(indices, line_filter, estimation, settings, continuous)
        if start is None:
            continue
        judged = cost(*start, held_out)
        if judged < best_cost:
            best, best_cost = start, judged
    return best


def with_moli_start(step: FrequencyStep | None, order: int, estimation: FitProblem, held_out: FitProblem,
                    settings: FrequencySettings, continuous: bool, *, refine: bool) -> FrequencyStep | None:
    """The better on the held-out lines of ``step`` (the subspace start's) and the MOLI start's step of ``order``,
    each refined and judged alike (:func:`moli.method.frequency.orders.judged_step`); ``step`` on a tie."""
    start = moli_start(order, estimation, held_out, settings, continuous)
    if start is None:
        return step
    other = replace(judged_step(order, start, estimation, held_out, settings, continuous, refine=refine), start="moli")
    return other if step is None or other.shares.sum() < step.shares.sum() else step
