"""Long records: the search on a bounded window, the selected model on the whole record.

On an estimation record longer than ``IdentifyOptions.search_samples``, the filter
tuning, the greedy path, the per-output filters, the refinement and the noise model
run on the record's first ``search_samples`` samples; the order rule still scores on
the whole validation record. The selected structure is then re-estimated on the whole
estimation record with the filters the search chose and the same feedthrough rule,
its factor built in row blocks (:mod:`moli.method.least_squares.row_blocks`), and its covariance is
that of the whole record's least squares (docs/method.md §15).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ...data.iodata import IOData
from ...validation.comparison import compare
from ..least_squares.shared_factors import RegressionCache
from ..tuning.criterion import FilterScorer
from .greedy_path import PathStep

__all__ = ["search_window", "reestimate"]


def search_window(record: IOData, samples: int | None) -> IOData:
    """The part of ``record`` the search runs on: its first ``samples`` samples, or all of it.

    Returns ``record`` itself when it is not longer than ``samples`` (or ``samples`` is None).
    """
    if samples is None or record.N <= samples:
        return record
    return record[:samples]


def reestimate(
    step: PathStep, record: IOData, validation: IOData, s: float, feedthrough: bool | str, x0: str,
    *, regularization: str = "none",
) -> PathStep:
    """``step`` with its model's least squares redone on the whole ``record``.

    The list, the filters (the shared one, or each output's), the feedthrough rule and
    the regularization are the search's; the per-output problems are reduced by
    triangular factors built in row blocks, so memory does not grow with the record.
    Each segment of ``record`` is filtered from rest and gives its own rows. The step's validation VAF
    is recomputed; its ``J`` stays the search window's.

    Parameters
    ----------
    step : PathStep
        The selected step of a search run on a window of ``record``.
    record : IOData
        The whole estimation record (centred and shifted as the window).
    validation : IOData
        The validation record the order rule scored on.
    s : float
        Root spacing factor of the filters.
    feedthrough : {False, True, "auto"}
        The search's feedthrough rule.
    x0 : {"zero", "estimate"}
        Initial state of the validation simulation.
    regularization : {"none", "gcv"}
        The search's least squares (plain or ridge).
    """
    started = time.perf_counter()
    z = np.concatenate([record.y, record.u], axis=1)
    indices = step.indices
    cache = RegressionCache(z, record.p, feedthrough, record.segment_starts, regularization)
    etas = step.eta[None] if step.output_etas is None else step.output_etas
    full, parts = cache.filters(etas, indices, record.Ts, s)
    thetas = cache.thetas(cache.solve([(full, parts, indices)])[0], indices)
    if step.output_etas is None:
        chosen, divisors = [t[:1] for t in thetas], [parts[0]]
    else:                            # output j takes the problem of its own filter
        chosen = [t[j : j + 1] for j, t in enumerate(thetas)]
        divisors = [[parts[j][j] for j in range(len(indices))]]
    matrices = FilterScorer(z, indices, record.Ts, s, cache, starts=record.segment_starts).realize(chosen, divisors)
    A, B, C = (M[0] for M in matrices[:3])
    D = matrices[3][0] if len(matrices) == 4 else None
    info = dict(step.model.info, estimation_samples=record.N)
    model = step.model.with_matrices(A, B, C, D, info, step.model.divisors)
    vaf = compare(model, validation, x0).vaf
    return replace(step, model=model, vaf=vaf, seconds=step.seconds + time.perf_counter() - started)
