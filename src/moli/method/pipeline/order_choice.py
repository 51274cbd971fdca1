"""The third step of :func:`moli.identify`: which order of the path is chosen (docs/method.md §5).

A fixed order where one is asked for; else the order rule, refined (each order judged by
the refinements of the lists compared there), paired or by tolerance. Ctrl-C during the
refinements this step runs keeps the path as the search left it and chooses by the paired
rule, as an interrupted search does.
"""

from __future__ import annotations

from ..options.identify_options import IdentifyOptions
from ..refinement.refined_steps import RefinedSteps
from ..search.greedy_path import PathStep, StructureSearch
from ..selection.candidates import siblings
from ..selection.guarded import PathSelection, fixed_order, rule_order
from ..selection.order_rules import select_order_refined
from .interruption import Phases

__all__ = ["choose_order"]


def choose_order(path: list[PathStep], search: StructureSearch, refined: RefinedSteps,
                 options: IdentifyOptions, phases: Phases, *, interrupted: bool) -> PathSelection:
    """The path's selection with its order chosen; with ``refine="path"`` every step of the path
    is refined first.

    Parameters
    ----------
    path : list of PathStep
        The path just searched (the selection holds it, and changes it in place).
    search : StructureSearch
        The search of the path (the refined rule fits the lists compared at each order).
    refined : RefinedSteps
        The identification's refinements.
    options : IdentifyOptions
    phases : Phases
        The phases after the path; Ctrl-C here cuts the one running.
    interrupted : bool
        Ctrl-C stopped the search: no refinement, and a fixed order beyond the path is not an error.

    Returns
    -------
    PathSelection
    """
    selection = PathSelection.of(path)
    try:
        if options.refine == "path" and not interrupted:
            phases.begin("refinement of the path")
            path[:] = [refined(step)[0] for step in path]
        selection.index = fixed_order(path, options.order, interrupted)
        if selection.index is None and options.order_rule == "refined" and not interrupted:
            phases.begin("order rule's refinements")
            index, chosen = select_order_refined(path, lambda i: [path[i], *siblings(search, path, i)], refined,
                                                 refined.validation, options.x0, options.order_errors)
            selection.index = index
            path[index] = selection.unrefined[index] = chosen
    except KeyboardInterrupt:   # the path as it was, and the order rule of an interrupted search
        phases.cut()
        selection.index = fixed_order(path, options.order, True)
    if selection.index is None:
        selection.index = rule_order(path, options, refined.validation)
    return selection
