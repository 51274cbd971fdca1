"""Throughput of update_many: 3x3 plant, list (2, 2, 2), BLAS on one thread.

Also checks the covariance over a long run: symmetric and positive definite.
Run: python benchmarks/recursive_throughput.py [samples]
"""


import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import sys
import time

import numpy as np

import moli
from moli.streaming.filter_bank import FilterBank
from moli.streaming.recursive import RecursiveMoli
from moli.method.tuning.barycenter import default_omega
from streaming_plant import StreamingPlant

N = int(sys.argv[1]) if len(sys.argv) > 1 else 200_000
CHUNK = 10_000
INDICES = (2, 2, 2)
y, u = StreamingPlant(seed=0, noise=0.1).chunk(N)


def rate(estimator, chunk: int, samples: int) -> float:
    start = time.perf_counter()
    for a in range(0, samples, chunk):
        estimator.update_many(y[a : a + chunk], u[a : a + chunk])
    return samples / (time.perf_counter() - start)


single = rate(RecursiveMoli(INDICES, moli.filter_polynomial(0.5, 0.7, INDICES), 3), CHUNK, N)
omega = default_omega()[:17]  # 17 grid points + the barycenter candidate = 18 filters
bank = FilterBank(INDICES, omega, 3, retune_every=10_000, window=2_000)
banked = rate(bank, CHUNK, N)
one = rate(RecursiveMoli(INDICES, moli.filter_polynomial(0.5, 0.7, INDICES), 3), 1, 2_000)
print(f"samples: {N}, chunks of {CHUNK}")
print(f"RecursiveMoli, 1 filter:        {single:.3g} samples/s")
print(f"FilterBank, {len(bank.etas)} filters (retune every 1e4 on 2e3): {banked:.3g} samples/s "
      f"= {banked * len(bank.etas):.3g} filter-samples/s, {banked / 1e5:.2f} x the 1e5 target")
print(f"update(), one sample per call:  {one:.3g} samples/s ({single / one:.0f} x slower than chunks)")

# Long run of the covariance with forgetting: symmetric positive definite throughout.
est = RecursiveMoli(INDICES, moli.filter_polynomial(0.5, 0.7, INDICES), 3, forgetting=0.999)
plant, worst = StreamingPlant(seed=5, noise=0.1), np.inf
LONG = int(sys.argv[2]) if len(sys.argv) > 2 else 10**6
start = time.perf_counter()
for _ in range(LONG // 100_000):
    est.update_many(*plant.chunk(100_000))
    for P in est.covariance:
        assert np.array_equal(P, P.T)
        worst = min(worst, np.linalg.eigvalsh(P).min())
print(f"{est.samples} steps at forgetting 0.999: P symmetric, smallest eigenvalue seen {worst:.3g} "
      f"({time.perf_counter() - start:.1f} s)")
