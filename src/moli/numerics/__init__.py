"""Numerical kernels every layer shares: :mod:`.triangular` (the R factor of a tall
matrix, in cache-sized row blocks)."""

__all__: list[str] = []
