"""Numerical kernels every layer shares: :mod:`.triangular` (the R factor of a tall
matrix, in cache-sized row blocks), :mod:`.recursive_filter` (``lfilter``'s recursion
as a banded triangular solve) and :mod:`.blas_threads` (one BLAS thread inside moli's
computations)."""

__all__: list[str] = []
