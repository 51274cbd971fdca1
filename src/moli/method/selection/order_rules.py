"""Order rules: which model of the greedy path is selected.

- :func:`select_order`: the lowest order within a tolerance of the best mean validation VAF;
- :func:`select_order_paired`: the lowest order whose validation error is within one paired
  standard error of the best model's (docs/method.md §5);
- :func:`select_order_refined`: the same test, each order judged by the best refinement of
  the lists the greedy step compared there (docs/method.md §5b);
- :func:`clearly_better`: the paired test the other way round, which every candidate that
  would replace a selected model must pass (:mod:`moli.method.selection.candidates`).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ...data.iodata import IOData
from ...models.statespace import StateSpaceModel
from ...validation.comparison import compare
from .paired_test import error_shares, paired_difference
from ..search.greedy_path import PathStep

__all__ = ["select_order", "select_order_paired", "select_by_shares", "select_order_refined", "clearly_better",
           "PAIRED_Z"]

PAIRED_Z = 1.0


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
