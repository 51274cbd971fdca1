"""Structure search: the greedy path of lists of indices, and the exhaustive search."""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from ...data.iodata import IOData
from ...errors import DataError
from ..structure.rows import check_regression_rows
from ...models.statespace import StateSpaceModel
from ..options.identify_options import IdentifyOptions
from ..structure.indices import Indices, compositions, raised
from ..tuning.output_filters import tune_output_cutoffs
from ..least_squares.shared_factors import RegressionCache
from ..tuning.criterion import FilterScorer, score_lists
from ..tuning.barycenter import tune_filters
from ...validation.comparison import compare

__all__ = ["ScoredStep", "PathStep", "StructureSearch", "greedy_path", "best_eligible", "path_until_interrupted",
           "next_step", "exhaustive"]


class ScoredStep:
    """What the order rules read of a path step: its validation VAF and its model's stability."""

    vaf: np.ndarray
    model: Any

    @property
    def mean_vaf(self) -> float:
        """Average validation VAF over the outputs, percent."""
        return float(np.mean(self.vaf))

    @property
    def stable(self) -> bool:
        """Whether the model is asymptotically stable."""
        return self.model.is_stable()


@dataclass
class PathStep(ScoredStep):
    """One list of indices, its tuned filter, its model and its scores.

    Attributes
    ----------
    indices : tuple of int
    order : int
        McMillan degree ``sum(indices)``.
    J : float
        Criterion on the estimation data (simulation, zero state) of the model.
    J_barycenter : float
        Criterion at the last barycenter of the filter search.
    eta : ndarray, shape (2,)
        Shared filter ``(wc, zeta)`` chosen by the filter search.
    vaf : ndarray, shape (p,)
        Validation VAF per output, percent (simulation; initial state as requested).
    model : StateSpaceModel
    seconds : float
        Wall time spent tuning, estimating and validating this list (lists tuned
        together each count an equal share of the joint time).
    output_etas : ndarray, shape (p, 2), optional
        Each output's filter when per-output filters lowered J (the model then
        carries per-output ``divisors``); None when the shared filter was kept.
    """

    indices: Indices
    order: int
    J: float
    J_barycenter: float
    eta: np.ndarray
    vaf: np.ndarray
    model: StateSpaceModel = field(repr=False)
    seconds: float
    output_etas: np.ndarray | None = None


class StructureSearch:
    """Fits lists of indices on one estimation/validation pair, caching each list.

    Parameters
    ----------
    estimation, validation : IOData
        Centred records (same operating point).
    omega : ndarray, shape (R, 2)
        Filter candidates ``(wc, zeta)``.
    tuning : {"grid", "random"}
    iterations : int
        Steps of the randomized filter search.
    s : float
        Root spacing factor of the filters.
    seed : int
        Each list's random draws come from ``default_rng([seed, *indices])``, so a
        list gets the same model whichever search reaches it.
    x0 : {"zero", "estimate"}
        Initial state of the validation simulation.
    criterion_x0 : {"zero", "estimate"}
        Initial state of the estimation-data simulations behind J (the paper: zero).
    feedthrough : bool, default False
        Estimate a direct feedthrough ``D`` (current inputs as extra regressors).
    max_radius : float, optional
        Filter candidates whose model has a pole of at least this modulus score the
        worst J (see :class:`moli.method.tuning.criterion.FilterScorer`); None scores fit alone (paper).
    trend_degree : int, default 0
        Degree of the polynomial trend of the simulation error that J ignores (0:
        the paper's J; see :class:`moli.method.tuning.criterion.FilterScorer`).
    output_filters : bool, default False
        Before a list is validated, re-tune each output's filter cutoff on J
        (:func:`moli.method.tuning.output_filters.tune_output_cutoffs`); the lists compared by
        the greedy path keep the shared filter.
    regularization : {"none", "gcv"}, default "none"
        Least squares of every estimate (see :class:`moli.method.least_squares.shared_factors.RegressionCache`).
    screen_lists : bool, default False
        The greedy step tunes only the candidate list whose J is lowest at the filter of the
        list it raises (:meth:`screened`).
    """

    def __init__(
        self, estimation: IOData, validation: IOData, omega: np.ndarray, tuning: str = "random",
        iterations: int = 5, s: float = 2.0, *, seed: int = 0, x0: str = "zero",
        criterion_x0: str = "zero", feedthrough: bool = False, max_radius: float | None = None,
        trend_degree: int = 0, output_filters: bool = False, regularization: str = "none",
        screen_lists: bool = False,
    ) -> None:
        self.output_filters = output_filters
        self.screen_lists = screen_lists
        self.max_radius = max_radius
        self.trend_degree = trend_degree
        self.criterion_x0 = criterion_x0
        self.feedthrough = feedthrough
        self.estimation = estimation
        self.validation = validation
        self.omega = omega
        self.tuning = tuning
        self.iterations = iterations
        self.s = s
        self.seed = seed
        self.x0 = x0
        self._z = np.concatenate([estimation.y, estimation.u], axis=1)
        self._cache: dict[Indices, PathStep] = {}
        self._regressions = RegressionCache(
            self._z, estimation.p, feedthrough, estimation.segment_starts, regularization
        )

    @classmethod
    def from_options(cls, estimation: IOData, validation: IOData, omega: np.ndarray, options: IdentifyOptions,
                     max_radius: float | None) -> StructureSearch:
        """The search :func:`moli.identify` runs: every setting from ``options``, the pole bound
        ``max_radius`` resolved for the record (``options.max_radius`` may be "auto")."""
        return cls(estimation, validation, omega, options.tuning, options.iterations, options.s, seed=options.seed,
                   x0=options.x0, criterion_x0=options.criterion_x0, feedthrough=options.feedthrough,
                   max_radius=max_radius, trend_degree=options.trend_degree, output_filters=options.output_filters,
                   regularization=options.regularization, screen_lists=options.screen_lists)

    def feasible(self, indices: Indices) -> bool:
        """Whether the estimation record has enough samples for this list."""
        try:
            check_regression_rows(self.estimation.bounds, indices, self.estimation.m,
                                  self._regressions.feedthrough is not False)
        except DataError:
            return False
        return True

    def fit(self, indices: Indices, validate: bool = True) -> PathStep:
        """Tune the filter, estimate and (unless told not to) validate one list (cached).

        With ``validate=False`` the step's ``vaf`` is left empty (NaN) until a later
        call validates it: the greedy path validates only the lists it keeps. With
        ``output_filters`` a list's filters are re-tuned per output when it is validated.
        """
        return self.fit_many([indices], validate)[0]

    def fit_many(self, lists: Sequence[Indices], validate: bool = True) -> list[PathStep]:
        """:meth:`fit` for several lists; those not cached yet are tuned together.

        Joint tuning (:func:`moli.method.tuning.barycenter.tune_filters`) gives each list the model it
        gets alone; each step's ``seconds`` is then an equal share of the joint time.
        """
        todo = [ix for ix in dict.fromkeys(lists) if ix not in self._cache]
        if todo:
            self._tune(todo)
        steps = [self._cache[ix] for ix in lists]
        for step in steps:
            if validate and np.isnan(step.vaf).any():
                started = time.perf_counter()
                if self.output_filters:
                    self._separate(step)
                step.vaf = compare(step.model, self.validation, self.x0).vaf
                step.seconds += time.perf_counter() - started
        return steps

    def screened(self, lists: Sequence[Indices], eta: np.ndarray) -> Indices:
        """The list of lowest J at the one filter ``eta`` (each list's least squares and simulation
        at that filter, scored together), without tuning any of them.

        The greedy step compares lists one index apart, raised from the same list: their best
        filters are near the one that list was tuned to, and the ranking at that filter picks
        the list the full tuning would on most steps at a fraction of its cost (docs/method.md §5).
        """
        scored = score_lists([self._scorer(indices) for indices in lists], [np.asarray(eta, float)[None]] * len(lists))
        return lists[int(np.argmin([costs[0] for costs, _ in scored]))]

    def _scorer(self, indices: Indices) -> FilterScorer:
        return FilterScorer(
            self._z, indices, self.estimation.Ts, self.s, self._regressions, self.criterion_x0,
            max_radius=self.max_radius, trend_degree=self.trend_degree, starts=self.estimation.segment_starts,
        )

    def _separate(self, step: PathStep) -> None:
        """Give the step's model per-output filter cutoffs where they lower J."""
        found = tune_output_cutoffs(self._scorer(step.indices), step.eta, self.omega)
        if not found.J < found.J_shared:
            return
        A, B, C = found.matrices[:3]
        D = found.matrices[3] if len(found.matrices) == 4 else None
        info = dict(step.model.info, J=found.J, output_wc=found.etas[:, 0].tolist(),
                    output_zeta=found.etas[:, 1].tolist())
        step.model = step.model.with_matrices(A, B, C, D, info, found.divisors)
        step.J = found.J
        step.output_etas = found.etas

    def _tune(self, lists: list[Indices]) -> None:
        start = time.perf_counter()
        est = self.estimation
        scorers = [self._scorer(indices) for indices in lists]
        seeds = [np.random.default_rng([self.seed, *indices]) for indices in lists]
        tuned = tune_filters(scorers, self.omega, self.tuning, self.iterations, seeds)
        share = (time.perf_counter() - start) / len(lists)
        for indices, result in zip(lists, tuned):
            wc, zeta = result.eta
            # the filter the model was estimated with, as the search built it
            alpha = self._regressions.filters(result.eta[None], indices, est.Ts, self.s)[0][0]
            model = StateSpaceModel(
                result.A, result.B, result.C, result.D, Ts=est.Ts, output_names=est.output_names,
                input_names=est.input_names, indices=indices, alpha=alpha,
                y_offset=est.y_offset, u_offset=est.u_offset,
                info={"wc": float(wc), "zeta": float(zeta), "s": self.s, "J": result.J,
                      "J_barycenter": result.J_barycenter, "evaluations": result.evaluations},
            )
            self._cache[indices] = PathStep(
                indices=indices, order=sum(indices), J=result.J, J_barycenter=result.J_barycenter,
                eta=result.eta, vaf=np.full(est.p, np.nan), model=model, seconds=share,
            )


def greedy_path(
    search: StructureSearch, nmax: int, progress: Callable[[PathStep], None] | None = None, *,
    patience: int | None = None, margin: float = 0.0,
) -> list[PathStep]:
    """The paper's greedy path: from ``(1, ..., 1)`` raise the index that lowers J most.

    Parameters
    ----------
    search : StructureSearch
    nmax : int
        Largest McMillan degree to reach.
    progress : callable, optional
        Called with each step as it is added.
    patience : int, optional
        Stop once this many steps in a row have not raised the best validation VAF of the
        path's eligible steps by more than ``margin`` points (:func:`best_eligible`); None runs
        the path to ``nmax``.
    margin : float, default 0.0
        The least raise that counts, in points of mean validation VAF (:func:`moli.identify`
        gives its ``order_tolerance``: the order rule takes fits closer than that as equal).

    Returns
    -------
    list of PathStep
        One step per order ``p, p+1, ...``; shorter than ``nmax - p + 1`` when the
        record has too few samples for every larger list, or when ``patience`` stopped it.
    """
    current = (1,) * search.estimation.p
    path = [search.fit(current)]
    best = 0
    if progress:
        progress(path[-1])
    while path[-1].order < nmax and (patience is None or len(path) - 1 - best < patience):
        step = next_step(search, path[-1])
        if step is None:
            break
        path.append(step)
        if patience is not None:
            best = best_eligible(path, best, margin)
        if progress:
            progress(path[-1])
    return path


def best_eligible(path: Sequence[ScoredStep], best: int, margin: float = 0.0) -> int:
    """Position of the best eligible step of ``path`` given ``best``, that of all but its last step.

    Eligible are the stable steps, or all of them where none is stable (as for the order rules,
    :mod:`moli.method.selection.order_rules`); a later eligible step replaces the best only by
    raising its mean validation VAF by more than ``margin`` points. With ``margin`` 0 that is
    the order rules' best eligible step (the earlier one on a tie).
    """
    last, held = path[-1], path[best]
    if last.stable != held.stable:
        return len(path) - 1 if last.stable else best
    return len(path) - 1 if last.mean_vaf > held.mean_vaf + margin else best


def path_until_interrupted(search: StructureSearch, nmax: int, progress: Callable[[PathStep], None] | None = None,
                           *, patience: int | None = None, margin: float = 0.0) -> tuple[list[PathStep], bool]:
    """:func:`greedy_path`, kept as far as it got when Ctrl-C stops it, and whether it did.

    Unstable candidates are expected while searching (the selected model is checked
    later): their RuntimeWarnings are not shown. Ctrl-C before the first step is done
    stops the identification.
    """
    path: list[PathStep] = []

    def record(step: PathStep) -> None:
        path.append(step)
        if progress:
            progress(step)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            greedy_path(search, nmax, record, patience=patience, margin=margin)
        except KeyboardInterrupt:
            if not path:
                raise
            return path, True
    return path, False


def next_step(search: StructureSearch, step: PathStep) -> PathStep | None:
    """The greedy step from ``step``: of the lists one index above it, the one of lowest J,
    validated (with ``screen_lists``, of lowest J at ``step``'s filter); None where the record
    allows none of them."""
    candidates = [c for c in raised(step.indices) if search.feasible(c)]
    if not candidates:
        return None
    if search.screen_lists and len(candidates) > 1:
        return search.fit(search.screened(candidates, step.eta))
    steps = search.fit_many(candidates, validate=False)
    return search.fit(min(steps, key=lambda st: st.J).indices)


def exhaustive(search: StructureSearch, order: int) -> list[PathStep]:
    """Fit every list of indices of the given McMillan degree (``C(n-1, p-1)`` lists)."""
    return search.fit_many([c for c in compositions(order, search.estimation.p) if search.feasible(c)])
