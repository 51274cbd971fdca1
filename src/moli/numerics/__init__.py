"""Numerical kernels every layer shares: :mod:`.triangular` (the R factor of a tall
matrix, in cache-sized row blocks) and :mod:`.recursive_filter` (``lfilter``'s recursion
as a banded triangular solve)."""

__all__: list[str] = []
