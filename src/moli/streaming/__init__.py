"""Estimation sample by sample or chunk by chunk, in constant memory (docs/recursive.md).

A long record reduced on Dask workers: :func:`moli.fleets.estimate_chunks`.
"""

from .chunked import ChunkedEstimator
from .filter_bank import FilterBank
from .recursive import RecursiveMoli

__all__ = ["ChunkedEstimator", "FilterBank", "RecursiveMoli"]
