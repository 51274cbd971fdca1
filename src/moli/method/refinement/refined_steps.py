"""Path steps refined once per ridge and validated: the memo every refinement phase of
:func:`moli.identify` shares (docs/method.md §12).

The order rule's refinements, the guarded refinement of the selected list and its
siblings, and the order-bound warning's like-for-like check may each ask for the same
step refined with the same ridge; :class:`RefinedSteps` refines it once. Its keys hold
the models they stand for, so a key cannot be taken over by another model that happens
to reuse a freed model's memory address.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Sequence

from ...data.iodata import IOData
from ...models.statespace import StateSpaceModel
from ...validation.comparison import compare
from ..search.greedy_path import PathStep
from .levenberg_marquardt import MAX_RADIUS, polish, refine_each

__all__ = ["RefinedSteps"]


class _ModelKey:
    """A dictionary key that is one model object itself (identity, not equality), kept alive by the key."""

    __slots__ = ("model",)

    def __init__(self, model: StateSpaceModel) -> None:
        self.model = model

    def __hash__(self) -> int:
        return id(self.model)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _ModelKey) and other.model is self.model


class RefinedSteps:
    """Each step's model refined with each ridge at most once, on ``data``, validated on ``validation``.

    Parameters
    ----------
    data : IOData
        The record the refinements run on (the search's estimation window).
    validation : IOData
        The record every path VAF is computed on.
    ridges : sequence of float
        The ridges of ``IdentifyOptions.refine_ridge``; the first is the one a step is
        refined with unless told otherwise.
    x0 : {"zero", "estimate"}
        Initial state of the validation simulations.
    max_radius : float
        Pole radius bound of the refinement's steps.
    iterations : int
        Levenberg-Marquardt steps of each refinement.

    Examples
    --------
    >>> import moli
    >>> from moli.method.search.greedy_path import StructureSearch
    >>> est, val = moli.example_data(N=400, seed=1).remove_means().split(250)
    >>> search = StructureSearch(est, val, moli.method.default_omega(1.0), "grid")
    >>> refined = RefinedSteps(est, val, (0.0,))
    >>> step = search.fit((2, 1, 1))
    >>> refined(step)[0] is refined(step)[0]     # refined once, the same step returned
    True
    """

    def __init__(self, data: IOData, validation: IOData, ridges: Sequence[float], *, x0: str = "zero",
                 max_radius: float = MAX_RADIUS, iterations: int = 10) -> None:
        self.data, self.validation = data, validation
        self.ridges = tuple(ridges)
        self.x0, self.max_radius, self.iterations = x0, max_radius, iterations
        self._done: dict[tuple[_ModelKey, float], PathStep] = {}

    def __call__(self, step: PathStep, ridges: Sequence[float] | None = None) -> list[PathStep]:
        """``step`` refined with each of ``ridges`` (default: the first ridge), each validated;
        each counts the time of all."""
        chosen = self.ridges[:1] if ridges is None else tuple(ridges)
        key = _ModelKey(step.model)
        todo = tuple(r for r in chosen if (key, r) not in self._done)
        if todo:
            started = time.perf_counter()
            models = [result.model for result in refine_each(step.model, self.data, todo, max_radius=self.max_radius,
                                                             iterations=self.iterations)]
            vafs = [compare(model, self.validation, self.x0).vaf for model in models]
            seconds = step.seconds + time.perf_counter() - started
            for ridge, model, vaf in zip(todo, models, vafs):
                self._done[key, ridge] = replace(step, model=model, vaf=vaf, seconds=seconds)
        return [self._done[key, r] for r in chosen]

    def free(self, step: PathStep) -> PathStep:
        """``step`` refined without a ridge, validated."""
        return self(step, (0.0,))[0]

    def polished(self, step: PathStep) -> PathStep:
        """``step`` with its free refinement continued to the optimum
        (:func:`moli.method.refinement.levenberg_marquardt.polish`) and validated; ``step`` itself
        where the polish leaves its model as it is."""
        model = polish(step.model, self.data, self.max_radius)
        return step if model is step.model else replace(step, model=model,
                                                         vaf=compare(model, self.validation, self.x0).vaf)
