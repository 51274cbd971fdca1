"""The selected model of a path, and the guarded refinement that may replace it (docs/method.md §5, §12).

:class:`PathSelection` is the path and the position of the model chosen so far; every
step that changes the choice (the order rule, the guarded refinement, the orders below)
writes it there at once, so that Ctrl-C between two of them leaves a complete choice.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ...data.iodata import IOData
from ...errors import DataError
from ..options.identify_options import IdentifyOptions
from ..refinement.refined_steps import RefinedSteps
from ..search.greedy_path import PathStep, StructureSearch
from .candidates import generic_candidate, generic_orders_below, polished_if_clearly_better, siblings
from .order_rules import clearly_better, select_order, select_order_paired

__all__ = ["PathSelection", "fixed_order", "rule_order", "guarded_refinement"]


@dataclass
class PathSelection:
    """The path, its steps as the search left them, and the position of the model chosen so far.

    Attributes
    ----------
    path : list of PathStep
        One step per order; the chosen position's step is replaced as refinements win.
    unrefined : list of PathStep
        The path's least-squares steps (the order rule's refinements may put another list's there).
    at_bound : PathStep
        The path's last least-squares step, as the search fitted it (the order-bound warning's).
    index : int or None
        Position of the chosen model in ``path``; None until an order is chosen.
    """

    path: list[PathStep]
    unrefined: list[PathStep]
    at_bound: PathStep
    index: int | None = None

    @classmethod
    def of(cls, path: list[PathStep]) -> PathSelection:
        """The selection of a path just searched: nothing chosen yet."""
        return cls(path=path, unrefined=list(path), at_bound=replace(path[-1]))

    @property
    def step(self) -> PathStep:
        """The chosen step."""
        assert self.index is not None, "no order chosen yet"
        return self.path[self.index]

    def keep(self, step: PathStep) -> None:
        """``step`` replaces the chosen one at its position."""
        assert self.index is not None, "no order chosen yet"
        self.path[self.index] = step


def fixed_order(path: list[PathStep], order: int | None, interrupted: bool) -> int | None:
    """Position of the path step of the fixed ``order``; None to apply the order rule.

    An interrupted search keeps the best model of the orders done, like one without a
    fixed order; a complete path that stops short of ``order`` is an error.
    """
    if order is None:
        return None
    found = [i for i, step in enumerate(path) if step.order == order]
    if found:
        return found[0]
    if interrupted:
        return None
    raise DataError(f"IdentifyOptions.order = {order} is not on the greedy path: the record has "
                    f"too few samples for lists beyond n = {path[-1].order}")


def rule_order(path: list[PathStep], options: IdentifyOptions, validation: IOData) -> int:
    """The order rule's choice where neither a fixed order nor the refined rule made one: the
    paired rule (also what the refined rule falls back to when Ctrl-C stops it), else the tolerance."""
    if options.order_rule in ("paired", "refined"):
        return select_order_paired(path, validation, options.x0, options.order_errors)
    return select_order(path, options.order_tolerance)


def guarded_refinement(selection: PathSelection, search: StructureSearch, refined: RefinedSteps,
                       options: IdentifyOptions, *, interrupted: bool, two_stage: bool) -> None:
    """The guarded refinement of the chosen model (``refine="guarded"``), in place.

    Each ridge refines the least-squares model, and the best on validation stays (the
    two-stage method keeps the free refinement: its error ``G (u - u_hat) + v`` is coloured,
    which biases the least squares); then the free refinement of each other list the greedy
    step compared at this order, where it is better by more than a paired standard error
    (unless ``options.refine_siblings`` is False).
    The generic list is kept where it fits validation within the order tolerance (with
    ``options.screen_generic`` judged at its early stop, then taken to its optimum), then those
    of the orders below while they fit as well; last, the model's own optimum where
    validation clearly prefers it. After an interrupted search only the chosen list's own
    refinements are tried.
    """
    validation, x0 = refined.validation, refined.x0
    for candidate in refined(selection.step, refined.ridges if not two_stage else (0.0,)):
        if two_stage or candidate.mean_vaf > selection.step.mean_vaf:
            selection.keep(candidate)
    compared = [] if interrupted or not options.refine_siblings else siblings(search, selection.path, selection.index)
    for sibling in compared:
        for candidate in refined(sibling):
            if clearly_better(candidate, selection.step, validation, x0):
                selection.keep(candidate)
    line = selection.step.mean_vaf - options.order_tolerance
    candidate = None if interrupted else generic_candidate(search, selection.step, refined,
                                                           polish=not options.screen_generic)
    if options.screen_generic and candidate is not None and candidate.mean_vaf >= line:
        # judged at its early stop; only the one kept goes on to its optimum, where its bands hold
        candidate = refined.polished(candidate)
        candidate = candidate if candidate.stable else None
    if candidate is not None and candidate.mean_vaf >= line:
        selection.keep(candidate)
    if not interrupted and options.order is None and options.lower_orders:
        selection.index = generic_orders_below(search, selection.path, selection.index, refined,
                                               options.order_tolerance)
    if not interrupted and options.polish_selected:
        selection.keep(polished_if_clearly_better(selection.step, refined))
