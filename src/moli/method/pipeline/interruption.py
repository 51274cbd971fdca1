"""What Ctrl-C after the greedy path cuts.

Once the path is done, :func:`moli.identify` re-estimates, refines and attaches the
covariance and the noise model to the selected model. Ctrl-C during one of these phases
keeps the best complete model before it; ``IdentificationResult.skipped`` names that
phase and those that would have followed, from :func:`post_path_phases`.
"""

from __future__ import annotations

from ..options.identify_options import IdentifyOptions

__all__ = ["post_path_phases"]


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
