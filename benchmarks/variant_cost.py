"""Time of moli option sets relative to the default on the evaporator's paper split, one process.

Each named variant of ``generalization.VARIANTS`` identifies the evaporator's paper split
(estimation 0..499, validation 500..999, nmax 15; benchmarks/peer_ratio.py times the
same call against the peers), one BLAS thread, the variants alternated in every round and
each timed by its fastest of ``--repeats`` runs, so that a load that comes and goes
falls on all of them alike. Prints the seconds, the ratio to the default and the order
and validation VAF selected.

    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/variant_cost.py \\
        --variants default_refine5,default_ridge1,fast [--repeats 5]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import os  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import moli  # noqa: E402
from daisy_data import load  # noqa: E402
from generalization import VARIANTS  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--variants", required=True, help=f"comma-separated, among {', '.join(VARIANTS)}")
    parser.add_argument("--repeats", type=int, default=5, help="rounds; each variant's fastest is kept")
    args = parser.parse_args()
    chosen = ["default"] + [v for v in args.variants.split(",") if v != "default"]
    unknown = [v for v in chosen if v not in VARIANTS]
    if unknown:
        parser.error(f"unknown variants {unknown}; known: {', '.join(VARIANTS)}")
    data = load("evaporator")
    est, val = data[0:500], data[500:1000]
    warnings.simplefilter("ignore")
    moli.identify(est, val, nmax=15)            # imports scipy's modules: not timed
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    best: dict[str, float] = {}
    selected: dict[str, str] = {}
    for _ in range(args.repeats):
        for name in chosen:
            start = time.perf_counter()
            result = moli.identify(est, val, nmax=15, **VARIANTS[name])
            best[name] = min(best.get(name, float("inf")), time.perf_counter() - start)
            selected[name] = f"order {result.selected.order}, VAF {result.selected.mean_vaf:.2f}"
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    for name in chosen:
        print(f"{name:26s} {best[name]:7.3f} s  {best[name] / best['default']:5.2f}  {selected[name]}")


if __name__ == "__main__":
    main()
