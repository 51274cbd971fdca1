"""Samples until the recursive estimate equals the batch model (Markov parameters to 1e-6).

Noise-free data from a seeded 3x3 plant with indices (2, 2, 2); the batch model is
the whole-record least-squares solution (docs/method.md §3) on the same samples.
Run: python benchmarks/recursive_convergence.py
"""


import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import warnings

import numpy as np

import moli
from moli.streaming.chunked import ChunkedEstimator
from moli.streaming.recursive import RecursiveMoli
from streaming_plant import StreamingPlant

INDICES = (2, 2, 2)
ALPHA = moli.filter_polynomial(0.5, 0.7, INDICES)

for noise in (0.0, 0.1):
    y, u = StreamingPlant(seed=0, noise=noise).chunk(20_000)
    est = RecursiveMoli(INDICES, ALPHA, 3)
    batch = ChunkedEstimator(INDICES, ALPHA, 3)
    first, gaps = None, {}
    for N in range(40, 20_001, 10):
        est.update_many(y[est.samples : N], u[est.samples : N])
        batch.add(y[batch.samples : N], u[batch.samples : N])
        if N in (100, 1000, 20_000) or (first is None and N % 50 == 0):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", moli.IllConditionedWarning)
                gap = np.max(np.abs(est.model.markov(31) - batch.model().markov(31)))
            if first is None and gap < 1e-6:
                first = N
            if N in (100, 1000, 20_000):
                gaps[N] = gap
    print(f"noise {noise}: max |Markov recursive - batch| <= 1e-6 first at N = {first}; "
          + ", ".join(f"N={k}: {v:.1e}" for k, v in gaps.items()))
