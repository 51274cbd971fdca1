"""What the validation scores that chose the order can and cannot say.

The order rule ranks the path's models by their validation scores. A record of a few
dozen samples still yields a path and a "best" order, and nothing in the scores says
that they rest on too few samples: :func:`warn_if_short_selection` says so. An order at
the search's bound may call for a higher one, but only where the bound order wins by more
than the validation record's chance: :func:`warn_if_at_bound`. And a model whose simulation
fits an output no better than that output's mean has learnt nothing the record can show of
it, whatever order was "selected": :func:`warn_if_no_better_than_mean`.
"""

from __future__ import annotations

import warnings
from typing import Sequence

import numpy as np

from ...data.iodata import IOData
from ...errors import MoliError, NoFitWarning, OrderBoundWarning, ShortValidationWarning
from ...models.statespace import StateSpaceModel
from ...validation.comparison import compare
from .candidates import refined_as
from .order_rules import PAIRED_Z, clearly_better
from .paired_test import error_shares, paired_difference
from ..refinement.refined_steps import RefinedSteps
from ..refinement.levenberg_marquardt import is_refined
from ..structure.rows import parameter_counts
from ..search.greedy_path import PathStep, StructureSearch, next_step

__all__ = ["SAMPLES_PER_PARAMETER", "BOUND_Z", "selection_samples_needed", "warn_if_short_selection",
           "warn_if_at_bound", "outputs_no_better_than_mean", "warn_if_no_better_than_mean"]

# A rule of thumb, not a test: the order rule compares validation VAFs that differ by a
# point or two between neighbouring orders, and a VAF scored on N samples moves by about
# (100 - VAF) * sqrt(2 / N) points from one noise realisation to the next (the relative
# standard error of a variance from N white samples), i.e. 2.5 points at VAF 80 and
# N = 130. Ten samples per parameter of the largest model compared (per output, where
# each least-squares problem lives) keeps that below the differences the rule acts on
# for the usual path (3x3, nmax 10: about 260 samples); the common least-squares rule
# of ten observations per unknown says the same.
SAMPLES_PER_PARAMETER = 10
# Paired standard errors by which the model at the search's bound must beat every lower
# order of the path before the run says a higher order may fit better (one-sided, about
# 2 % by chance where the lower order is as good).
BOUND_Z = 2.0


def selection_samples_needed(path: Sequence[PathStep], m: int) -> int:
    """Validation samples the order rule needs to tell the path's orders apart.

    Parameters
    ----------
    path : sequence of PathStep
        The greedy path (its lists of observability indices).
    m : int
        Number of inputs.

    Returns
    -------
    int
        ``SAMPLES_PER_PARAMETER`` times the largest per-output parameter count on the path.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> selection_samples_needed([SimpleNamespace(indices=(1, 1)), SimpleNamespace(indices=(2, 1))], 1)
    60
    """
    most = max(int(parameter_counts(step.indices, m).max()) for step in path)
    return SAMPLES_PER_PARAMETER * most


def warn_if_short_selection(path: Sequence[PathStep], validation_samples: int, m: int,
                            stacklevel: int = 2) -> None:
    """Issue a :class:`ShortValidationWarning` when the order was chosen on too few samples.

    Parameters
    ----------
    path : sequence of PathStep
    validation_samples : int
        Samples of the validation part that scored the path.
    m : int
        Number of inputs.
    stacklevel : int
        As for :func:`warnings.warn`, counted from the caller.
    """
    need = selection_samples_needed(path, m)
    if len(path) > 1 and validation_samples < need:
        warnings.warn(
            f"the order was chosen on {validation_samples} validation samples, fewer than the "
            f"{need} that tell the path's orders apart ({SAMPLES_PER_PARAMETER} per parameter of "
            f"its largest model, {need // SAMPLES_PER_PARAMETER} per output), so the choice of order "
            "is uncertain; give a longer record or more validation data, or fix the order (order=..., moli fit --order)",
            ShortValidationWarning, stacklevel=stacklevel + 1,
        )


def _next_order_fits_better(beyond: tuple[StructureSearch, PathStep, PathStep, RefinedSteps | None],
                            x0: str) -> tuple[bool, PathStep | None]:
    """Whether the path's next step clearly beats its least squares at the bound and the model
    returned (refined as that model was), and the step; (True, None) where the record allows no
    higher list."""
    search, last, returned, refined = beyond
    with warnings.catch_warnings():
        # a list above the path: its least squares may be unstable, as on the path itself
        warnings.simplefilter("ignore", RuntimeWarning)
        above = next_step(search, last)
        if above is None:
            return True, None
        if not clearly_better(above, last, search.validation, x0, BOUND_Z):
            return False, above
        rival = above
        if refined is not None and is_refined(returned.model):
            try:
                rival = refined_as(returned.model, refined)(above)
            except (MoliError, np.linalg.LinAlgError):
                pass
    return clearly_better(rival, returned, search.validation, x0, BOUND_Z), above


def warn_if_at_bound(path: Sequence[PathStep], selected: int, nmax: int, validation: IOData, x0: str = "zero", *,
                     beyond: tuple[StructureSearch, PathStep, PathStep, RefinedSteps | None] | None = None,
                     stacklevel: int = 2) -> None:
    """Issue an :class:`OrderBoundWarning` when the selected order is the search's bound
    ``nmax`` and beats the best lower order of ``path`` by more than :data:`BOUND_Z` paired
    standard errors on ``validation`` (:func:`moli.method.selection.order_rules.clearly_better`), and,
    with ``beyond``, the path's step one order above the bound beats its step at the bound by
    as much, and (refined as the selected model was) the selected model too.

    A bound order that wins by less than the validation record's chance says nothing about
    higher ones; one that clearly wins may (under strong output noise that is often the
    least-squares path buying back its bias with each state, docs/accuracy.md), and the
    path's next step says whether it goes on doing so.

    Parameters
    ----------
    path : sequence of PathStep
    selected : int
        Position of the selected model in ``path``.
    nmax : int
        The search's bound.
    validation : IOData
        The record the path's VAFs were computed on.
    x0 : {"zero", "estimate"}
        Initial state of the validation simulations.
    beyond : (StructureSearch, PathStep, PathStep, RefinedSteps or None), optional
        The search, the path's least-squares step at the bound as the search fitted it, the
        selected step as it is returned (without input delays), and the identification's
        refinements (:class:`moli.method.refinement.refined_steps.RefinedSteps`; None without
        refinement). The greedy step from the bound's
        (:func:`moli.method.search.greedy_path.next_step`) is fitted only where the rest would warn; all are
        scored on the search's own validation record (with its inputs shifted by any delays, as
        they were fitted). Nothing is said where that step does not clearly beat the bound's
        least squares, or where it (refined, when the selected model is a refinement) does not
        clearly beat the selected model: a higher order that fits no better than the model
        returned gives no reason to raise the bound. Where the record allows no higher list,
        the warning stands on the lower orders alone; where Ctrl-C stops this check, nothing is
        said (the identification's result is kept).
    stacklevel : int
        As for :func:`warnings.warn`, counted from the caller.
    """
    chosen = path[selected]
    lower = [step for step in path if step.order < chosen.order and (step.stable or not chosen.stable)]
    if chosen.order < nmax or (lower and not clearly_better(chosen, max(lower, key=lambda step: step.mean_vaf),
                                                              validation, x0, BOUND_Z)):
        return
    above = None
    if beyond is not None:
        try:
            better, above = _next_order_fits_better(beyond, x0)
        except KeyboardInterrupt:       # Ctrl-C during this check: the result is kept, and nothing said
            return
        if not better:
            return
    still = "" if above is None else f"; the path's order {above.order} fits it clearly better still"
    warnings.warn(
        f"the selected order {chosen.order} is the search's bound nmax = {nmax} and fits the "
        f"validation data clearly better than every lower order{still}: a higher order may fit better; "
        f"raise it with nmax=... (moli fit --nmax)",
        OrderBoundWarning, stacklevel=stacklevel + 1,
    )


def outputs_no_better_than_mean(model: StateSpaceModel, validation: IOData, x0: str = "zero",
                                z: float = PAIRED_Z) -> list[int]:
    """The outputs whose validation mean ``model``'s simulation does not beat by more than ``z``
    paired standard errors (:func:`moli.method.selection.paired_test.paired_difference`).

    The mean is what a VAF of 0 stands for: a model at or below it on an output explains none
    of that output, and one a little above it on a short record may do so by chance alone.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> noise = moli.IOData(rng.standard_normal((60, 1)), rng.standard_normal((60, 1)))
    >>> outputs_no_better_than_mean(moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]]), noise)
    [0]
    """
    yhat = compare(model, validation, x0).yhat
    lost = []
    for j in range(validation.p):
        y = validation.y[:, j : j + 1]
        mean = np.broadcast_to(y.mean(axis=0), y.shape)
        # points by which the mean loses to the model; the model beats it only where that is clear
        worse, margin = paired_difference(error_shares(y, mean), error_shares(y, yhat[:, j : j + 1]), z)
        if not (np.isfinite(worse) and worse > margin):
            lost.append(j)
    return lost


def warn_if_no_better_than_mean(model: StateSpaceModel, validation: IOData, x0: str = "zero",
                                stacklevel: int = 2) -> None:
    """Issue a :class:`NoFitWarning` naming the outputs :func:`outputs_no_better_than_mean` finds.

    ``stacklevel`` as for :func:`warnings.warn`, counted from the caller.
    """
    lost = outputs_no_better_than_mean(model, validation, x0)
    if not lost:
        return
    names = ", ".join(model.output_names[j] for j in lost)
    which = (f"every output ({names})" if len(lost) == validation.p > 1
             else f"output{'s' if len(lost) > 1 else ''} {names}")
    warnings.warn(
        f"the model fits {which} no better than {'its' if len(lost) == 1 else 'their'} mean on the "
        f"validation data: whatever order was selected, it explains nothing of {'it' if len(lost) == 1 else 'them'} "
        "that the record can show; check that the right channels are inputs "
        "and outputs, or give a longer or better excited record",
        NoFitWarning, stacklevel=stacklevel + 1,
    )
