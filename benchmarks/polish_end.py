"""Where the polish ends against the minimum of V, with and without its geometric jumps.

On the 3x3 example plant (``moli.example_data``, seeds 0..S-1, 600 and 1500 samples), each of
three lists of order 6-7 is estimated with the default filter, refined for ten steps as
``identify`` does, then continued to its minimum by the polish, once with the jumps of
``refinement._geometric_rest`` and once without. Each end is compared with the minimum that
800 steps without a stop reach, in sample variances ``V / (N p)`` (what one standard error of
the estimate costs in V), and the polish's steps are counted.

    OPENBLAS_NUM_THREADS=1 python benchmarks/polish_end.py [seeds]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import sys
import time
import warnings

import numpy as np

import moli
from moli.method.refinement import (DAMPING_FLOOR, MAX_RADIUS, POLISH_ITERATIONS, POLISH_SHARE, RefinementStart,
                                    refine)

LISTS = ((2, 2, 2), (3, 2, 2), (3, 2, 3))
MINIMUM_STEPS = 800


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 12
    warnings.simplefilter("ignore")
    rows = {False: [], True: []}
    for seed in range(seeds):
        for N in (600, 1500):
            est = moli.example_data(N=N, seed=seed).remove_means()
            n, p = est.y.shape
            for indices in LISTS:
                start = moli.estimate(est, list(indices), moli.filter_polynomial(0.5, 0.8, list(indices)))
                early = refine(start, est).model
                if not early.info.get("refine_iterations"):
                    continue
                minimum = refine(early, est, iterations=MINIMUM_STEPS, tolerance=0.0, damping=DAMPING_FLOOR).cost
                variance = minimum / (n * p)
                for jumps in (False, True):
                    began = time.process_time()
                    end = RefinementStart(early, est, True, MAX_RADIUS).descend(
                        0.0, POLISH_ITERATIONS, POLISH_SHARE / (n * p), DAMPING_FLOOR, extrapolate=jumps)
                    rows[jumps].append(((end.cost - minimum) / variance, end.iterations, time.process_time() - began))
    print(f"{len(rows[False])} polishes (seeds 0-{seeds - 1}, N = 600 and 1500, lists {LISTS})\n")
    print("| polish | median above the minimum (variances) | 90th percentile | above one variance "
          "| steps, total | CPU, total |")
    print("|---|---|---|---|---|---|")
    for jumps, label in ((False, "without jumps"), (True, "with jumps")):
        gap, steps, cpu = (np.array(column) for column in zip(*rows[jumps]))
        print(f"| {label} | {np.median(gap):.3g} | {np.percentile(gap, 90):.3g} | {int(np.sum(gap > 1))} "
              f"| {int(steps.sum())} | {cpu.sum():.1f} s |")


if __name__ == "__main__":
    main()
