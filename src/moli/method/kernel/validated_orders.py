"""What the kernel methods share around their models: the records and where the validation record
comes from, every order's model scored on it, the order kept by the paired rule, and its table.

:func:`moli.identify_kernel` (realized impulse responses) and :func:`moli.identify_kernel_arx`
(truncated ARX models) differ only in how each order's model is made.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from ...data.arguments import check_channel_order, check_validation_length
from ...data.iodata import IOData
from ...errors import DataError, OptionError, OrderBoundWarning
from ...models.statespace import StateSpaceModel
from ...validation.comparison import X0_CHOICES, compare, same_period
from ..search.greedy_path import ScoredStep
from ..selection.order_rules import PAIRED_Z, select_by_shares
from ..selection.paired_test import error_shares

__all__ = ["HOLDOUT_FRACTION", "KernelStep", "checked_records", "order_bound", "validated_orders", "order_table"]

# Share of the record held out for the order when no validation record is given, as identify's.
HOLDOUT_FRACTION = 0.3


@dataclass
class KernelStep(ScoredStep):
    """One order's model and its validation VAF per output (scored as a path step is)."""

    order: int
    model: StateSpaceModel
    vaf: np.ndarray


def checked_records(data: IOData, validation: IOData | None, x0: str) -> tuple[IOData, IOData, str]:
    """The estimation and validation records and where the latter came from (the last
    :data:`HOLDOUT_FRACTION` of ``data`` where none is given), after the checks of both."""
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    if x0 not in X0_CHOICES:
        raise OptionError(f"x0 must be one of {X0_CHOICES}, got {x0!r}")
    if validation is None:
        estimation, validation = data.split(1.0 - HOLDOUT_FRACTION)
        return estimation, validation, f"held out: last {HOLDOUT_FRACTION:.0%} of the record"
    if not isinstance(validation, IOData) or (validation.p, validation.m) != (data.p, data.m) \
            or not same_period(validation.Ts, data.Ts):
        raise DataError("validation must be an IOData of the same channels and sampling period as data")
    check_channel_order(data, validation, "data", "validation")
    check_validation_length(validation)
    return data, validation, "given"


def order_bound(nmax: object, p: int) -> int:
    """The last order a kernel method may try for ``p`` outputs: ``nmax``, default ``max(10, p + 4)``
    (the MOLI path's); an :class:`OptionError` where ``nmax`` is no positive integer."""
    if nmax is not None and (isinstance(nmax, bool) or not isinstance(nmax, (int, np.integer)) or nmax < 1):
        raise OptionError(f"nmax must be a positive integer, got {nmax!r}")
    return int(nmax) if nmax is not None else max(10, p + 4)


def warn_order_cap(nmax: object, top: int, why: str) -> None:
    """Say so where a kernel method's orders stop below the ``nmax`` its caller gave."""
    if nmax is not None and top < int(nmax):  # type: ignore[call-overload]
        warnings.warn(f"the orders tried stop at {top}, below nmax = {nmax}: {why}", OrderBoundWarning,
                      stacklevel=3)


def validated_orders(models: Iterable[tuple[int, StateSpaceModel]], validation: IOData,
                     x0: str) -> tuple[list[KernelStep], int]:
    """Each ``(order, model)`` simulated on ``validation``, and the position of the lowest order within
    one paired standard error of the best (:func:`moli.method.selection.order_rules.select_by_shares`)."""
    path, shares = [], []
    for order, model in models:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)      # an unstable model diverges
            simulated = compare(model, validation, x0)
            shares.append(error_shares(validation.y, simulated.yhat))
        path.append(KernelStep(order, model, simulated.vaf))
    return path, select_by_shares(path, shares.__getitem__, PAIRED_Z)


def order_table(title: str, path: list[KernelStep], selected_index: int) -> str:
    """``title``, then each order's mean validation VAF and stability, the selected one starred."""
    lines = [title, "  order  mean VAF  stable"]
    lines += [f"{'*' if i == selected_index else ' '} {step.order:5d}  {step.mean_vaf:8.2f}  {step.stable}"
              for i, step in enumerate(path)]
    return "\n".join(lines)
