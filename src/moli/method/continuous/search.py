"""Filter tuning and the greedy structure search in continuous time (docs/continuous.md §5).

The same search as the discrete one (docs/method.md §5): every list's filter is tuned
on J over a grid of ``(wc, zeta)`` and its barycenter, the greedy path raises one
index at a time and keeps the lowest J. The barycenter is taken over
``(log wc, zeta)``: the continuous grid spans decades of cutoffs, and a linear mean of
them would sit near the fastest.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ...models.continuous import ContinuousModel
from ..selection.paired_test import error_shares
from ..search.greedy_path import ScoredStep
from ..structure.indices import Indices, raised
from ..tuning.barycenter import barycenter
from .estimation import StampedRecord, filter_factor, fit_list, simulate_stamped, warm_up_rows
from .filters import unit_divisors

__all__ = ["ContinuousStep", "ContinuousSearch", "greedy_path", "error_ratios", "WARM_UP"]

# Share of each validation segment on which its initial state is fitted (and not scored).
WARM_UP = 0.2


@dataclass
class ContinuousStep(ScoredStep):
    """One list of indices on the continuous path: its filter, model and scores.

    Attributes
    ----------
    indices : tuple of int
    order : int
    J : float
        Criterion on the estimation record (simulation from the zero state).
    eta : ndarray, shape (2,)
        The filter ``(wc, zeta)``, wc in rad per time unit.
    vaf : ndarray, shape (p,)
        Validation VAF per output, percent.
    model : ContinuousModel
    seconds : float
    errors : ndarray, shape (N_val,)
        Squared validation errors per sample, in points of mean VAF (the paired rule,
        :func:`moli.method.selection.order_rules.select_by_shares`).
    thetas : list of ndarray
        Each output's least-squares parameters (docs/continuous.md §4).
    """

    indices: Indices
    order: int
    J: float
    eta: np.ndarray
    vaf: np.ndarray
    model: ContinuousModel = field(repr=False)
    seconds: float
    errors: np.ndarray = field(repr=False)
    thetas: list[np.ndarray] = field(repr=False, default_factory=list)


def error_ratios(simulated: list[np.ndarray], measured: tuple[np.ndarray, ...]) -> np.ndarray:
    """Per output ``var(y - yhat) / var(y)`` over all segments, 1 where not finite."""
    y = np.concatenate(measured)
    error = y - np.concatenate(simulated)
    with np.errstate(invalid="ignore", over="ignore"):
        ratio = np.var(error, axis=0) / np.maximum(np.var(y, axis=0), np.finfo(float).tiny)
    return np.where(np.isfinite(ratio), ratio, np.inf)


class ContinuousSearch:
    """Tunes and fits lists of indices on one estimation/validation pair.

    Parameters
    ----------
    estimation, validation : StampedRecord
    omega : ndarray, shape (R, 2)
        Candidate filters ``(wc, zeta)``.
    s : float
        Root spacing factor.
    linear_inputs : bool
        Inputs linear between samples (else held).
    names : tuple of (output names, input names)
    offsets : tuple of (y offset, u offset)
    largest_order : int
        The path's end: every model's validation warm-up is the one this order needs,
        so that all are scored on the same samples (the paired rule compares them
        sample by sample).
    """

    def __init__(self, estimation: StampedRecord, validation: StampedRecord, omega: np.ndarray,
                 s: float, *, linear_inputs: bool, names: tuple[tuple[str, ...], tuple[str, ...]],
                 offsets: tuple[np.ndarray, np.ndarray], largest_order: int) -> None:
        self.estimation, self.validation = estimation, validation
        self.largest_order = largest_order
        self.omega, self.s, self.linear_inputs = omega, s, linear_inputs
        self.names, self.offsets = names, offsets
        self._factors: dict[tuple, np.ndarray] = {}
        self._steps: dict[Indices, ContinuousStep] = {}

    def feasible(self, indices: Indices) -> bool:
        """Whether the estimation rows determine every output's parameters."""
        p, m, S = self.estimation.p, self.estimation.m, self.estimation.with_rows(max(indices))
        needed = max((p + m + S) * l + j + 1 for j, l in enumerate(indices)) + 1
        return self.estimation.rows(max(indices)) >= needed

    def factor(self, wc: float, zeta: float, indices: Indices) -> np.ndarray:
        alpha = unit_divisors(zeta, indices, self.s)[0]
        key = (wc, zeta, alpha.tobytes())
        if key not in self._factors:
            self._factors[key] = filter_factor(self.estimation, wc, alpha, self.linear_inputs,
                                               skip=alpha.size - 1)
        return self._factors[key]

    def fitted(self, wc: float, zeta: float, indices: Indices) -> tuple[tuple[np.ndarray, ...], float, list]:
        """The list's model with this filter, its J and thetas."""
        A, B, C, thetas = fit_list(self.factor(wc, zeta, indices), wc, zeta, indices, self.s,
                                   self.estimation.m)
        with np.errstate(all="ignore"):
            simulated = simulate_stamped(A, B, C, self.estimation, self.linear_inputs)
        J = float(np.mean(np.minimum(error_ratios(simulated, self.estimation.y), 1.0)))
        return (A, B, C), J, thetas

    def fit(self, indices: Indices) -> ContinuousStep:
        """The list's tuned filter and model, scored on the validation record (cached)."""
        if indices in self._steps:
            return self._steps[indices]
        start = time.perf_counter()
        scored = [(self.fitted(wc, zeta, indices), (wc, zeta)) for wc, zeta in self.omega]
        costs = np.array([fit[1] for fit, _ in scored])
        logs = np.column_stack([np.log(self.omega[:, 0]), self.omega[:, 1]])
        center = barycenter(logs, costs)
        eta = (float(np.exp(center[0])), float(center[1]))
        scored.append((self.fitted(*eta, indices), eta))
        (matrices, J, thetas), best = min(scored, key=lambda item: item[0][1])
        model = self._model(matrices)
        vaf, errors = self._validate(model)
        step = ContinuousStep(indices, sum(indices), J, np.array(best), vaf, model,
                              time.perf_counter() - start, errors, thetas)
        self._steps[indices] = step
        return step

    def _model(self, matrices: tuple[np.ndarray, ...]) -> ContinuousModel:
        A, B, C = matrices
        p, m = C.shape[0], B.shape[1]
        return ContinuousModel(A, B, C, np.zeros((p, m)), *self.names, self.offsets[0].copy(),
                               self.offsets[1].copy(), (0.0,) * m)

    def _validate(self, model: ContinuousModel) -> tuple[np.ndarray, np.ndarray]:
        """Validation VAF and error shares on each segment past its warm-up.

        The initial state is fitted on a segment's first :data:`WARM_UP` share and the
        errors are counted on the rest: fitted and counted on the same samples, a
        higher order would buy validation fit with its extra initial states alone.
        """
        with np.errstate(all="ignore"):
            simulated = simulate_stamped(model.A, model.B, model.C, self.validation, self.linear_inputs,
                                         WARM_UP, states=self.largest_order)
        kept = [slice(warm_up_rows(t.size, WARM_UP, self.largest_order, model.p), None)
                for t in self.validation.times]
        simulated = [part[rows] for part, rows in zip(simulated, kept)]
        measured = tuple(part[rows] for part, rows in zip(self.validation.y, kept))
        ratios = error_ratios(simulated, measured)
        vaf = 100.0 * (1.0 - np.minimum(ratios, 1.0))
        return vaf, error_shares(np.concatenate(measured), np.concatenate(simulated))


def greedy_path(search: ContinuousSearch, end: int, progress: Callable[[ContinuousStep], None] | None = None
                ) -> list[ContinuousStep]:
    """From ``(1, ..., 1)``, raise the index whose list has the lowest J, up to order ``end``."""
    p = search.estimation.p
    indices: Indices = (1,) * p
    if not search.feasible(indices):
        return []
    path = [search.fit(indices)]
    if progress is not None:
        progress(path[-1])
    while path[-1].order < end:
        candidates = [c for c in raised(path[-1].indices) if search.feasible(c)]
        if not candidates:
            break
        path.append(min((search.fit(c) for c in candidates), key=lambda st: st.J))
        if progress is not None:
            progress(path[-1])
    return path
