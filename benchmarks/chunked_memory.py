"""Chunked batch identification of a 10^7-sample 3x3 record in bounded memory.

Run: python benchmarks/chunked_memory.py [samples]
"""


import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import resource
import sys
import time

import numpy as np

import moli
from moli.streaming.chunked import ChunkedEstimator
from moli.method.least_squares.estimation import filtered_regressors, realize, solve_batch
from moli.method.structure.filters import divisors
from streaming_plant import StreamingPlant


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def in_memory_markov(y: np.ndarray, u: np.ndarray) -> np.ndarray:
    """docs/method.md §3 solved on the whole prefix at once (zero filter state)."""
    z = np.concatenate([y, u], axis=1)
    alphas = divisors(ALPHA, INDICES)
    thetas = []
    for j, a in enumerate(alphas):
        phi = np.concatenate([filtered_regressors(z, a), y[:, :j]], axis=1)[2:]
        thetas.append(solve_batch(phi[None], y[None, 2:, j])[0])
    A, B, C = realize(thetas, [alphas], INDICES, 3)
    return moli.StateSpaceModel(A[0], B[0], C[0]).markov(30)


N = int(sys.argv[1]) if len(sys.argv) > 1 else 10**7
CHUNK = 100_000
PREFIX = 200_000
INDICES = (2, 2, 2)
ALPHA = moli.filter_polynomial(0.5, 0.7, INDICES)

plant = StreamingPlant(seed=0, noise=0.1)
est = ChunkedEstimator(INDICES, ALPHA, 3)
print(f"peak RSS after imports: {peak_mb():.0f} MB")
start = time.perf_counter()
prefix_y, prefix_u = [], []
while est.samples < N:
    y, u = plant.chunk(min(CHUNK, N - est.samples))
    if est.samples < PREFIX:
        prefix_y.append(y)
        prefix_u.append(u)
        if est.samples + len(y) == PREFIX:
            # the prefix fits in memory: compare with the in-memory batch solve
            prefix_model = est.add(y, u).model()
            yp, up = np.vstack(prefix_y), np.vstack(prefix_u)
            gap = np.max(np.abs(prefix_model.markov(30) - in_memory_markov(yp, up)))
            gap_est = np.max(np.abs(prefix_model.markov(30) - moli.estimate(moli.IOData(yp, up), INDICES, ALPHA).markov(30)))
            print(f"prefix of {PREFIX} samples, max |Markov chunked - in-memory|: {gap:.2e} "
                  f"(section 3 solve), {gap_est:.2e} (moli.estimate)")
            del prefix_y[:], prefix_u[:], yp, up
            continue
    est.add(y, u)
model = est.model()
elapsed = time.perf_counter() - start
print(f"samples: {est.samples}, chunk: {CHUNK}, time: {elapsed:.1f} s ({est.samples / elapsed:.3g} samples/s)")
print(f"model poles (moduli): {np.round(np.sort(np.abs(model.poles())), 4)}")
print(f"peak RSS: {peak_mb():.0f} MB (the record alone would take {est.samples * 6 * 8 / 2**20:.0f} MB)")
