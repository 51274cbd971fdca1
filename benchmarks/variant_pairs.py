"""Two moli option sets paired on the synthetic cases of one seed, without the peers.

Usage::

    MOLI_DATA_DIR=<daisy folder> PYTHONPATH=src:benchmarks OPENBLAS_NUM_THREADS=1 \\
        python benchmarks/variant_pairs.py --seed 3 --variants default_early_stop,default [--jobs 2] \\
        [--synthetic 80] [--out pairs.json]

A cheap check of a choice on synthetic families that took no part in it: the peers' sweeps
are most of a generalization run's time, and a paired comparison of two moli variants does
not need them. Each case is run as ``benchmarks/generalization.py`` runs it (the same cases,
split, nmax and scoring: ``generalization.run_moli``), once per variant in the same worker,
one after the other. Printed: the second variant minus the first on V2 and on the true
response (mean; cases better or worse by more than a point; cases changed), the selected
order against the true one on the cases of 20 dB or more whose true order is within nmax,
the seconds per case, and every case that moved by more than 0.05 point.
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from joblib import Parallel, delayed  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import generalization as gen  # noqa: E402
import generalization_cases as gc  # noqa: E402


def run_case(seed: int, index: int, variants: list[str]) -> dict[str, Any]:
    case = gc.synthetic_case(seed, index)
    nmax = gc.nmax_rule(case.est.p, case.est.m, case.est.N)
    return {"name": case.name, "N": case.est.N, "nmax": nmax, **case.meta,
            "moli": {v: gen.run_moli(case, case.val.N // 2, nmax, gen.VARIANTS[v]) for v in variants}}


def order_counts(lines: list[dict[str, Any]], variant: str) -> tuple[float, float, float]:
    """Shares of the selected order equal to, within one of, and above the true one (20 dB or more)."""
    rows = [(res["moli"][variant].get("order", 0), res["n_true"]) for res in lines
            if res["snr_db"] >= 20 and res["n_true"] <= res["nmax"]]
    return tuple(float(np.mean([test(o, n) for o, n in rows])) for test in
                 (lambda o, n: o == n, lambda o, n: abs(o - n) <= 1, lambda o, n: o > n))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, required=True, help="seed of the synthetic family")
    parser.add_argument("--variants", required=True, help="two option sets of generalization.VARIANTS: A,B")
    parser.add_argument("--synthetic", type=int, default=80, help="number of synthetic cases")
    parser.add_argument("--jobs", type=int, default=2, help="parallel workers (loky)")
    parser.add_argument("--out", help="JSON file of every case's results")
    args = parser.parse_args()
    variants = args.variants.split(",")
    if len(variants) != 2 or any(v not in gen.VARIANTS for v in variants):
        parser.error(f"--variants takes two of: {', '.join(gen.VARIANTS)}")
    lines = Parallel(n_jobs=args.jobs, backend="loky")(
        delayed(run_case)(args.seed, i, variants) for i in range(args.synthetic))
    if args.out:
        Path(args.out).write_text(json.dumps({"variants": variants, "cases": lines}, indent=1, default=float))
    first, second = variants

    def paired(key: str) -> np.ndarray:
        return np.array([res["moli"][second].get(key, 0.0) - res["moli"][first].get(key, 0.0) for res in lines])

    print(f"seed {args.seed}, {len(lines)} synthetic cases: {second} minus {first}")
    for label, key in (("V2", "v2"), ("true-response fit", "true_fit")):
        d = paired(key)
        print(f"  {label}: mean {d.mean():+.3f}; better / worse by > 1: {(d > 1).sum()} / {(d < -1).sum()}; "
              f"changed {(np.abs(d) > 1e-9).sum()}")
    for v in variants:
        seconds = np.mean([res["moli"][v].get("seconds", 0.0) for res in lines])
        print(f"  {v}: true order / within one / above %.2f / %.2f / %.2f; %.3f s per case"
              % (*order_counts(lines, v), seconds))
    dv2, dtrue = paired("v2"), paired("true_fit")
    for res, a, b in zip(lines, dv2, dtrue):
        if abs(a) > 0.05 or abs(b) > 0.05:
            print(f"  {res['name']} N={res['N']} {res['kind']}, {res['snr_db']:g} dB {res['colour']}, n={res['n_true']}: "
                  f"order {res['moli'][first].get('order')} -> {res['moli'][second].get('order')}, "
                  f"V2 {a:+.2f}, true fit {b:+.2f}")


if __name__ == "__main__":
    main()
