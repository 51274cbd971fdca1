"""The orders a record can reach in continuous time: ``nmax`` and ``order`` checked before any work."""

from __future__ import annotations

from ...data.iodata import IOData
from ...errors import DataError
from ..structure.indices import Indices, generic_indices
from ..structure.rows import largest_fitting
from .estimation import StampedRecord, stamped_record

__all__ = ["largest_continuous_order", "check_continuous_reach"]


def _feasible(record: StampedRecord, indices: Indices) -> bool:
    """Whether the record's rows determine every output's parameters for the list (as the search asks)."""
    p, m, skip = record.p, record.m, max(indices)
    channels = p + m + record.with_rows(skip)
    needed = max(channels * l + j + 1 for j, l in enumerate(indices)) + 1
    return record.rows(skip) >= needed


def largest_continuous_order(record: StampedRecord) -> int:
    """The largest order whose cheapest list (the generic one) the record can estimate; ``p - 1`` when none."""
    return largest_fitting(lambda n: _feasible(record, generic_indices(n, record.p)), record.p)


def check_continuous_reach(nmax: int | None, order: int | None, estimation: IOData) -> None:
    """An ``nmax`` or ``order`` asked for must be within what the estimation record can estimate.

    Raises :class:`DataError` naming the option, the flag and the largest order, before
    the filters or the search run (they would take minutes and end in a singular solve).
    """
    if nmax is None and order is None:
        return
    record = stamped_record(estimation)
    reach = largest_continuous_order(record)
    for name, value in (("nmax", nmax), ("order", order)):
        if value is not None and value > reach:
            raise DataError(
                f"IdentifyOptions.{name} = {value} (moli fit --continuous --{name}) is beyond what "
                f"{record.rows(0)} samples of {record.p} outputs and {record.m} inputs can estimate in "
                f"continuous time: the largest order is {reach}; lower it or give a longer record")
