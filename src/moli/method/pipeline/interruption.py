"""What Ctrl-C after the greedy path cuts.

Once the path is done, :func:`moli.identify` re-estimates, refines and attaches the
covariance and the noise model to the selected model. Ctrl-C during one of these phases
keeps the best complete model before it; ``IdentificationResult.skipped`` names that
phase and those that would have followed, from :func:`post_path_phases`, as
:class:`Phases` tracks them.
"""

from __future__ import annotations

from typing import Callable

from ..options.identify_options import IdentifyOptions

__all__ = ["post_path_phases", "Phases", "SELECTION_CHECKS"]

# What Ctrl-C skips when it comes after the model is complete: the warnings about its selection
# (unstable, order at the bound, short validation, no better than the mean); the model is kept.
SELECTION_CHECKS = "checks of the selection"


def post_path_phases(options: IdentifyOptions, long_record: bool, direct: bool = False) -> list[str]:
    """The phases after the greedy path, in the order :func:`moli.identify` runs them.

    Parameters
    ----------
    options : IdentifyOptions
    long_record : bool
        The path was searched on a window of the record (``options.search_samples``):
        the selected list is re-estimated on the whole record.
    direct : bool, default False
        The direct closed-loop method: a noise model starts the joint prediction-error
        estimate before the covariance.

    Returns
    -------
    list of str

    Examples
    --------
    >>> post_path_phases(IdentifyOptions(), long_record=False)
    ['refinement', 'covariance', 'noise model']
    """
    refine = options.refine
    phases = ["refinement of the path"] if refine == "path" else []
    phases += ["order rule's refinements"] if options.order_rule == "refined" and options.order is None else []
    phases += ["re-estimation on the whole record"] if long_record else []
    phases += ["refinement"] if refine != "none" and (long_record or refine != "path") else []
    if direct:
        return phases + ["noise model", "prediction error", "covariance"]
    return phases + ["covariance"] + (["noise model"] if options.noise_model else [])


class Phases:
    """The phases after the path, the one running, and those Ctrl-C left undone.

    Parameters
    ----------
    names : list of str
        :func:`post_path_phases`.
    hook : callable, optional
        Called with each phase's name as it starts (``identify(..., phase=...)``).

    Examples
    --------
    >>> phases = Phases(["refinement", "covariance", "noise model"])
    >>> phases.begin("covariance")
    >>> phases.cut()
    >>> phases.skipped
    ('covariance', 'noise model')
    """

    def __init__(self, names: list[str], hook: Callable[[str], None] | None = None) -> None:
        self.names, self.hook = names, hook
        self.current = names[0]
        self.skipped: tuple[str, ...] = ()

    def begin(self, name: str) -> None:
        """Phase ``name`` starts."""
        if self.hook:
            self.hook(name)
        self.current = name

    def cut(self) -> None:
        """Ctrl-C stopped the phase running: it and every later phase are skipped."""
        self.skipped = tuple(self.names[self.names.index(self.current):])
