"""How often the paired test of the order rules declares one of two equally good models better.

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/paired_test_size.py [--repeats 2000] [--seed 0]

The paired test (``moli.method.selection.order_rules.select_by_shares``, behind ``clearly_better``, the
paired order rule, the sibling lists, the selected model's optimum and the order-bound warning)
sums the per-sample differences of two models' squared validation errors in contiguous
batches (ten, or fewer and longer where the differences are correlated over many samples:
``moli.method.selection.paired_test``) and calls the difference significant beyond ``z`` batch standard
errors (with fewer batches, the t quantile of the same tail). Here the two
"models" are equally good by construction: each error is a shared noise plus a misfit of its
own, all AR(1) with the same pole ``r``. The share of records on which the test finds one of
them clearly better (one side, as the rules use it) is the test's real size, against the
nominal one of a t statistic with nine degrees of freedom (0.172 for ``z = 1``, 0.038 for
``z = 2``). White errors (``r = 0``) and strongly coloured ones (``r = 0.9``, the generalization
benchmark's coloured noise) are run on validation parts of 67 to 2000 samples.
"""

from __future__ import annotations

import argparse
from types import SimpleNamespace

import numpy as np

from moli.method.selection.order_rules import select_by_shares

LENGTHS = (67, 126, 193, 500, 2000)
POLES = (0.0, 0.9)
LEVELS = (1.0, 2.0)
NOMINAL = {1.0: 0.172, 2.0: 0.038}  # one-sided tails of Student's t with 9 degrees of freedom
BURN_IN = 200


def ar1(rng: np.random.Generator, n: int, pole: float) -> np.ndarray:
    """A stationary AR(1) series of unit variance."""
    e = rng.standard_normal(n + BURN_IN)
    x = np.empty_like(e)
    x[0] = e[0]
    for k in range(1, len(e)):
        x[k] = pole * x[k - 1] + np.sqrt(1 - pole ** 2) * e[k]
    return x[BURN_IN:]


def declared_better(first: np.ndarray, second: np.ndarray, z: float) -> bool:
    """Whether the order rule's test passes over the first model (order 1) for the second."""
    shares = (first ** 2, second ** 2)
    path = [SimpleNamespace(order=k + 1, stable=True, mean_vaf=-float(np.sum(s))) for k, s in enumerate(shares)]
    return select_by_shares(path, lambda i: shares[i], z=z) == 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f"{args.repeats} records per row; one-sided rate at which one of two equally good models is "
          "declared better\n")
    print("| error pole r | validation samples | " + " | ".join(f"z = {z:g} (nominal {NOMINAL[z]})" for z in LEVELS)
          + " |\n|---|---|" + "---|" * len(LEVELS))
    for pole in POLES:
        for n in LENGTHS:
            hits = dict.fromkeys(LEVELS, 0)
            for _ in range(args.repeats):
                shared = ar1(rng, n, pole)
                first, second = shared + 0.5 * ar1(rng, n, pole), shared + 0.5 * ar1(rng, n, pole)
                for z in LEVELS:       # the two are exchangeable: one side is the test's size
                    hits[z] += declared_better(first, second, z)
            print(f"| {pole:g} | {n} | " + " | ".join(f"{hits[z] / args.repeats:.3f}" for z in LEVELS) + " |")


if __name__ == "__main__":
    main()
