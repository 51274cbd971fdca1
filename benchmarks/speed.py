"""Speed and memory of MOLI-ZOFT (BLAS pinned to one thread).

1. The whole automatic identification, greedy search n = 3..15 (and the default's
   refinements), on the evaporator (paper split, paper grid), with the default and
   three presets, against one least-squares solve of the same size (500 x 21, the
   largest list's regression), timed side by side in this process.
2. Fixed structure (2, 2, 2) and filter on a simulated 3x3 plant, N = 10^4 .. 10^6
   samples: estimation and simulation time and peak memory (tracemalloc), with the
   time per sample, to show cost linear in N; and the estimation with the covariance
   ``estimate`` attaches by default for the bands.

    OPENBLAS_NUM_THREADS=1 python benchmarks/speed.py
"""

from __future__ import annotations


import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import time
import tracemalloc
import warnings

import numpy as np

import moli
from daisy_data import load

PAPER_OMEGA = moli.method.tuning.barycenter.grid(np.array([0.02, 0.0355, 0.0631, 0.1122, 0.1995, 0.3548]) * np.pi, [0.6, 0.7, 1.1])


def best_of(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def greedy_speed() -> None:
    data = load("evaporator")
    est, val = data[0:500], data[500:1000]
    rng = np.random.default_rng(0)
    phi, target = rng.standard_normal((500, 21)), rng.standard_normal(500)
    one_solve = best_of(lambda: np.linalg.lstsq(phi, target, rcond=None), 200)
    print("## greedy search n = 3..15, evaporator paper split, 18-point paper grid")
    print(f"one least-squares solve 500 x 21: {one_solve * 1e6:.0f} us")
    presets = [("default (IdentifyOptions())", {}), ("improved (preset='improved')", {"preset": "improved"}),
               ("paper-faithful (preset='paper')", {"preset": "paper"}),
               ("paper with grid barycenter", {"preset": "paper", "tuning": "grid"})]
    for label, options in presets:
        with warnings.catch_warnings():
            # the evaporator's feedback and the path's unstable candidates warn on every call
            warnings.simplefilter("ignore")
            seconds = best_of(lambda: moli.identify(est, val, nmax=15, omega=PAPER_OMEGA, **options), 3)
            result = moli.identify(est, val, nmax=15, omega=PAPER_OMEGA, **options)
        print(f"{label:34s} {seconds:6.3f} s = {seconds / one_solve:7.0f} solves; selected n = "
              f"{result.selected.order}, VAF {result.selected.mean_vaf:.2f} %")
    print("(published MATLAB time, 2015: 1.59 s to n = 11)")


def long_record_speed() -> None:
    plant = moli.example_plant()
    indices = (2, 2, 2)
    alpha = moli.filter_polynomial(0.3, 0.8, indices)
    print("\n## fixed structure (2, 2, 2), simulated 3x3 plant")
    print("       N   estimate s   simulate s   us/sample   peak MB (estimate)   with covariance s (peak MB)")
    for N in (10**4, 10**5, 10**6):
        rng = np.random.default_rng(1)
        u = rng.standard_normal((N, 3))
        y = plant.simulate(u) + 0.1 * rng.standard_normal((N, 3))
        data = moli.IOData(y, u)
        del u, y
        # the least squares alone, then with the covariance the bands use (estimate's default)
        (model, t_est, peak), (_, t_cov, peak_cov) = (
            measured(lambda: moli.estimate(data, indices, alpha, covariance=covariance))
            for covariance in (False, True))
        start = time.perf_counter()
        model.simulate(data.u)
        t_sim = time.perf_counter() - start
        print(f"{N:8d}   {t_est:9.3f}   {t_sim:10.3f}   {1e6 * (t_est + t_sim) / N:9.2f}   {peak / 2**20:8.1f}"
              f"   ({peak / (N * 8 * 6):.1f} x the record)   {t_cov:6.3f} ({peak_cov / 2**20:.1f})")


def measured(call):
    """``call()``'s result, its wall time and its peak of traced memory."""
    tracemalloc.start()
    start = time.perf_counter()
    result = call()
    seconds = time.perf_counter() - start
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return result, seconds, peak


if __name__ == "__main__":
    greedy_speed()
    long_record_speed()
