"""Pin BLAS and OpenMP pools to one thread; import before numpy.

On shared 2-core machines multi-threaded BLAS made the same small fits 10-200 times
slower and erratic, and timings must compare algorithms, not thread pools.
"""

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"
