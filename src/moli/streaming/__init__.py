"""Estimation sample by sample or chunk by chunk, in constant memory (docs/recursive.md)."""

from .chunked import ChunkedEstimator
from .distributed import estimate_chunks
from .filter_bank import FilterBank
from .recursive import RecursiveMoli

__all__ = ["ChunkedEstimator", "FilterBank", "RecursiveMoli", "estimate_chunks"]
