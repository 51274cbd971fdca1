"""Order rules: which model of the greedy path is selected.

- :func:`select_order`: the lowest order within a tolerance of the best mean validation VAF;
- :func:`select_order_paired`: the lowest order whose validation error is within one paired
  standard error of the best model's (docs/method.md §5);
- :func:`select_order_refined`: the same test, each order judged by the best refinement of
  the lists the greedy step compared there (docs/method.md §5b);

and what the guarded refinement tries once an order is selected (docs/method.md §12): the
generic list of that order (:func:`generic_candidate`) and of the orders below it
(:func:`generic_orders_below`), refined to their optimum, and the selected model's own
optimum (:func:`polished_if_clearly_better`).
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from typing import Callable

import numpy as np

from ...data.iodata import IOData
from ...models.statespace import StateSpaceModel
from ...validation.comparison import compare
from ...errors import MoliError
from .paired_test import error_shares, paired_difference
from ..refinement.levenberg_marquardt import MAX_RADIUS, polish
from ..search.greedy_path import PathStep, StructureSearch
from ..structure.indices import generic_indices, raised

__all__ = ["select_order", "select_order_paired", "select_by_shares", "select_order_refined", "siblings", "generic_candidate",
           "generic_orders_below", "polished_if_clearly_better", "polished", "refined_as", "RefineSteps",
           "clearly_better"]

PAIRED_Z = 1.0
# ``refine(step, ridges)``: the step refined with each ridge, validated (what identify's search does).
RefineSteps = Callable[[PathStep, tuple[float, ...]], list[PathStep]]
# Paired standard errors by which a model refined to its optimum must beat the same model
# stopped early before it replaces it: the early stop is the default's choice (docs/accuracy.md),
# so leaving it asks for the significance of the order-bound warning, not the sibling lists'.
POLISH_Z = 2.0


def select_order(path: list[PathStep], tolerance: float = 1.0) -> int:
    """Position in ``path`` of the lowest order within ``tolerance`` points of the best.

    Only stable models are eligible when the path has any.

    Parameters
    ----------
    path : list of PathStep
    tolerance : float, default 1.0
        Percentage points of mean validation VAF.

    Returns
    -------
    int
    """
    eligible = [i for i, st in enumerate(path) if st.stable] or list(range(len(path)))
    best = max(path[i].mean_vaf for i in eligible)
    return min(i for i in eligible if path[i].mean_vaf >= best - tolerance)


def select_order_paired(path: list[PathStep], validation: IOData, x0: str = "zero",
                        z: float = PAIRED_Z) -> int:
    """Position in ``path`` of the lowest order not significantly worse than the best.

    The one-standard-error rule on the validation record: each model's mean VAF
    differs from the best model's by a sum over samples of squared-error differences
    (same samples, so the comparison is paired); its standard error comes from
    contiguous batch sums, which keep the serial correlation of simulation errors
    (:func:`moli.method.selection.paired_test.paired_difference`: ten batches, fewer and longer
    where the differences are correlated over many samples). The lowest order within
    ``z`` standard errors of the best is kept. Long records shrink the standard error, so the rule keeps more of the
    accuracy there; short ones favour the simpler model. Only stable models are
    eligible when the path has any.

    Parameters
    ----------
    path : list of PathStep
    validation : IOData
        The record the path's VAFs were computed on (centred like the models).
    x0 : {"zero", "estimate"}
        Initial state of the validation simulations.
    z : float, default 1.0
        Standard errors of tolerance.

    Returns
    -------
    int
    """
    return select_by_shares(path, lambda i: _error_shares(path[i].model, validation, x0), z)


def select_by_shares(path: list, shares: Callable[[int], np.ndarray], z: float = PAIRED_Z,
                     negligible: float = 0.0) -> int:
    """:func:`select_order_paired` given each path model's per-sample error shares.

    ``shares(i)`` is model ``i``'s squared validation error per sample, in points
    (summed over the samples: the mean over the outputs of
    ``100 |e_j|^2 / |y_j - mean(y_j)|^2``). Any path whose steps have ``order``,
    ``stable`` and ``mean_vaf`` will do (the continuous-time path uses it too). An order
    also passes when it loses at most ``negligible`` points, however many standard
    errors that is (long records make tiny differences significant).
    """
    eligible = [i for i, st in enumerate(path) if st.stable] or list(range(len(path)))
    best = max(eligible, key=lambda i: path[i].mean_vaf)
    reference = shares(best)
    for i in sorted(eligible, key=lambda i: path[i].order):
        if i == best:
            return i
        worse, margin = paired_difference(shares(i), reference, z)
        if np.isfinite(worse) and worse <= max(margin, negligible):
            return i
    return best


def select_order_refined(
    path: list[PathStep], lists_at: Callable[[int], list[PathStep]],
    refine: Callable[[PathStep], list[PathStep]], validation: IOData, x0: str = "zero",
    z: float = PAIRED_Z,
) -> tuple[int, PathStep]:
    """The lowest order whose best refined list is not significantly worse than the best model.

    The least-squares models of the path are biased under output noise, each by its
    own amount, and a higher order buys back part of that bias: judged by their own
    validation errors, the orders run up to the best one. Here each order, from the
    lowest, is judged by the best of its lists' least-squares models and their
    refinements (consistent under output noise, docs/method.md §12), and the paired test
    of :func:`select_order_paired` compares it with the best model known, the best
    least-squares model of the path or its refinement, on the same validation samples.
    The first order that passes is kept; if none passes before the best model's own
    order, that order is kept.

    Parameters
    ----------
    path : list of PathStep
        The greedy path, one step per order, validated.
    lists_at : callable
        ``lists_at(i)``: the validated steps of the lists compared at ``path[i]``'s order
        (``path[i]`` first).
    refine : callable
        ``refine(step)``: the refined steps of one step (validated).
    validation : IOData
        The record the path's VAFs were computed on (centred like the models).
    x0 : {"zero", "estimate"}
        Initial state of the validation simulations.
    z : float, default 1.0
        Standard errors of tolerance.

    Returns
    -------
    position : int
        Position of the selected order in ``path``.
    step : PathStep
        The least-squares step of the list whose model, or one of its refinements, was
        best at that order.
    """
    eligible = [i for i, st in enumerate(path) if st.stable] or list(range(len(path)))
    best = max(eligible, key=lambda i: path[i].mean_vaf)
    # the reference is the best model known: the best least-squares model or its refinement
    # (under strong noise the least squares of every order are poor, and a weak reference
    # would let an order through that the refinement of the best order beats by far)
    top = max([path[best], *(st for st in refine(path[best]) if st.stable)], key=lambda st: st.mean_vaf)
    reference = _error_shares(top.model, validation, x0)
    for i in range(best + 1):
        pool = [(candidate, step) for step in lists_at(i) for candidate in (step, *refine(step))
                if candidate.stable]
        if not pool:
            continue
        candidate, step = max(pool, key=lambda pair: pair[0].mean_vaf)
        if i == best:
            return i, step
        worse, margin = paired_difference(_error_shares(candidate.model, validation, x0), reference, z)
        if np.isfinite(worse) and worse <= margin:
            return i, step
    return best, path[best]


def siblings(search: StructureSearch, path: list[PathStep], selected: int) -> list[PathStep]:
    """The other lists of the selected order that the greedy step from the order below
    compared, fitted and validated.

    The greedy step ranks them by J, the simulation error of their least-squares
    models; under output noise those models are biased, each list by its own amount, so
    the list J ranks first is not always the one the plant's structure needs (a 2x2
    plant of indices (2, 2) reached as (1, 3)). Their refinements are compared on
    validation instead.
    """
    if selected == 0:
        return []
    chosen = path[selected].indices
    lists = [c for c in raised(path[selected - 1].indices) if c != chosen and search.feasible(c)]
    return search.fit_many(lists)


def generic_candidate(search: StructureSearch, step: PathStep, refine_free: Callable[[PathStep], PathStep],
                      data: IOData, validation: IOData, x0: str = "zero", max_radius: float = MAX_RADIUS,
                      own_list: bool = False) -> PathStep | None:
    """The generic list of ``step``'s order, refined freely to its optimum and validated; None
    where it cannot be fitted or is unstable, or where it is ``step``'s own list and not
    ``own_list`` (``step``'s refinement is then the one compared already).

    The greedy step reaches an order through the list whose least-squares model simulates
    best, and under output noise that is often a thinner family than the plant needs (the
    3x3 example plant reached as (3, 1, 2): a Jacobian of rank 34 where systems of order 6
    have 36 dimensions, and two of its output-2 gains held by their 95 % bands at 0.6-0.7
    of the points). The generic list (:func:`moli.method.structure.indices.generic_indices`) spans
    almost every system of the order (an open dense set), so its refinement is consistent
    whatever the plant's structure. It starts from a least-squares model of a list the
    greedy step did not choose, often far from its optimum, so the few steps ``refine_free``
    takes (those of every list compared) are continued by
    :func:`moli.method.refinement.levenberg_marquardt.polish`.

    Parameters
    ----------
    search : StructureSearch
        The search of the path (fits, tunes and validates the list).
    step : PathStep
        The path's model at the order.
    refine_free : callable
        ``refine_free(step)``: the free refinement of a step, validated.
    data : IOData
        The record the refinements run on.
    validation : IOData
        The record the path's VAFs were computed on.
    x0 : {"zero", "estimate"}
        Initial state of the validation simulations.
    max_radius : float
        Pole radius bound of the refinement's steps.
    own_list : bool, default False
        Where ``step``'s list is the generic one: refine ``step`` itself to its optimum.

    Returns
    -------
    PathStep or None
    """
    generic = generic_indices(step.order, len(step.indices))
    own = generic == tuple(step.indices)
    if (own and not own_list) or not search.feasible(generic):
        return None
    with warnings.catch_warnings():
        # a list the path did not take: its least squares may be unstable, and it is optional
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            candidate = refine_free(step if own else search.fit(generic))
        except (MoliError, np.linalg.LinAlgError):
            return None
        candidate = polished(candidate, data, validation, x0, max_radius)
    return candidate if candidate.stable else None


def generic_orders_below(search: StructureSearch, path: list[PathStep], selected: int,
                         refine_free: Callable[[PathStep], PathStep], data: IOData, validation: IOData,
                         x0: str = "zero", max_radius: float = MAX_RADIUS, tolerance: float = 0.1) -> int:
    """Position in ``path`` of the lowest order, counting down one order at a time from
    ``selected``, whose generic list refined to its optimum fits ``validation`` within
    ``tolerance`` points of ``path[selected]``; each order passed on the way has its
    generic model put into ``path``.

    The order rule judges each order by the least-squares model of the list the greedy step
    took there. Under output noise that model is biased, and a thin list (the 2x2 plant of
    docs/uncertainty.md §5 reached at its order 4 as (1, 3)) makes its order look worse than
    the order can do: the rule then selects one or two orders above the plant's. The generic
    list of each lower order, refined to its optimum (:func:`generic_candidate`), is that
    order's consistent estimate; where it fits validation as well as the selected model, the
    lower order is kept (docs/method.md §12).

    Parameters
    ----------
    search : StructureSearch
    path : list of PathStep
        The greedy path, one step per order; changed in place.
    selected : int
        Position of the model so far.
    refine_free, data, validation, x0, max_radius
        As for :func:`generic_candidate`.
    tolerance : float, default 0.1
        Points of mean validation VAF, the order rule's.

    Returns
    -------
    int
    """
    reference = path[selected].mean_vaf
    while selected > 0 and path[selected - 1].order == path[selected].order - 1:
        candidate = generic_candidate(search, path[selected - 1], refine_free, data, validation, x0, max_radius,
                                      own_list=True)
        if candidate is None or candidate.mean_vaf < reference - tolerance:
            break
        selected -= 1
        path[selected] = candidate
    return selected


def polished_if_clearly_better(step: PathStep, data: IOData, validation: IOData, x0: str = "zero",
                               max_radius: float = MAX_RADIUS, z: float = POLISH_Z) -> PathStep:
    """``step`` with its free refinement continued to the optimum (:func:`moli.method.refinement.levenberg_marquardt.polish`)
    where that fits ``validation`` better by more than ``z`` paired standard errors; else ``step``.

    A few refinement steps act as early stopping, which the benchmark chose for noisy records.
    On a record whose noise is small against what the model still misses, they stop far above
    the optimum: a lightly damped SISO plant of order 10 at 40 dB (3184 samples) stopped at 350
    times the noise floor of ``V`` and fitted its true response at 96 %, at the optimum 100 %.

    Parameters
    ----------
    step : PathStep
        The selected model so far.
    data : IOData
        The record it was refined on.
    validation : IOData
        The record its VAF was computed on.
    x0 : {"zero", "estimate"}
        Initial state of the validation simulations.
    max_radius : float
        Pole radius bound of the polish's steps.
    z : float, default 2
        Paired standard errors (:func:`clearly_better`).

    Returns
    -------
    PathStep
        ``step`` itself, or a new step with the polished model and its VAF.
    """
    candidate = polished(step, data, validation, x0, max_radius)
    return candidate if candidate.stable and clearly_better(candidate, step, validation, x0, z) else step


def polished(step: PathStep, data: IOData, validation: IOData, x0: str = "zero",
             max_radius: float = MAX_RADIUS) -> PathStep:
    """``step`` with its free refinement continued to the optimum (:func:`moli.method.refinement.levenberg_marquardt.polish`)
    and validated; ``step`` itself where the polish leaves its model as it is.

    Parameters
    ----------
    step : PathStep
    data, validation, x0, max_radius
        As for :func:`polished_if_clearly_better`.

    Returns
    -------
    PathStep
    """
    model = polish(step.model, data, max_radius)
    return step if model is step.model else replace(step, model=model, vaf=compare(model, validation, x0).vaf)


def refined_as(model: StateSpaceModel, refine: RefineSteps, data: IOData, validation: IOData, x0: str = "zero",
               max_radius: float = MAX_RADIUS) -> Callable[[PathStep], PathStep]:
    """A function refining a step as ``model`` was refined, for comparisons like for like.

    Parameters
    ----------
    model : StateSpaceModel
        An output-error refinement (``info["refined"]``): its ridge is used, and the step is
        taken on to its optimum (:func:`polished`) where ``model`` was.
    refine : callable
        ``refine(step, ridges)``: the step refined with each ridge, validated (the search's).
    data, validation, x0, max_radius
        As for :func:`polished`.

    Returns
    -------
    callable
        ``PathStep -> PathStep``.
    """
    ridge = float(model.info.get("refine_ridge", 0.0))

    def refined(step: PathStep) -> PathStep:
        step = refine(step, (ridge,))[0]
        return polished(step, data, validation, x0, max_radius) if model.info.get("refine_polished") else step
    return refined


def clearly_better(step: PathStep, than: PathStep, validation: IOData, x0: str = "zero",
                   z: float = PAIRED_Z) -> bool:
    """Whether ``step`` beats ``than`` on validation by more than ``z`` paired standard errors.

    The test of :func:`select_order_paired` the other way round: a candidate that wins by
    less could win by the validation record's chance alone, and on short records choosing
    among many such candidates loses on fresh data.
    """
    # the mean VAF clips each output at 0 and the errors do not: both must agree
    if (not step.stable and than.stable) or not step.mean_vaf > than.mean_vaf:
        return False
    worse, margin = paired_difference(_error_shares(than.model, validation, x0),
                                      _error_shares(step.model, validation, x0), z)
    return bool(np.isfinite(worse) and worse > margin)


def _error_shares(model: StateSpaceModel, validation: IOData, x0: str = "zero") -> np.ndarray:
    """Each sample's squared simulation error, in points: summed over the samples, the mean
    over the outputs of ``100 |e_j|^2 / |y_j - mean(y_j)|^2``; inf where the simulation diverges."""
    return error_shares(validation.y, compare(model, validation, x0).yhat)
