"""Which order the truth itself would choose, on the generalization benchmark's synthetic cases.

The order targets count a selected order as right when it equals the simulated system's
order. On records of a few hundred samples some of those systems hold modes the data cannot
show (a stiff pole near zero, a mode of little gain, Hankel singular values of 1e-8), and
MOLI's structure needs at least one observability index per output (n >= p). This script
measures how far an order rule could go: for each synthetic case the order rule's table
counts (SNR of 20 dB or more, true order within nmax), ``identify`` is run at every fixed
order from p to nmax on the case's own estimation and V1 records, and each model is scored
against the truth (fit of the noise-free response to a fresh input, relative H2 error).

- **truth's order**: the lowest order whose model fits the truth within
  :data:`ORACLE_TOLERANCE` points of the best fixed-order model (the default rule's own
  tolerance, applied to noise-free data that no rule sees);
- per variant of a generalization run (``--against``): the selected order against the true
  order and against the truth's order, and the true-response fit lost against the truth's
  order.

    MOLI_DATA_DIR=<daisy> PYTHONPATH=src:benchmarks OPENBLAS_NUM_THREADS=1 \\
        python benchmarks/order_oracle.py --seed 0 --jobs 2 \\
        [--against <generalization run>/generalization.json] [--out DIR]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import re  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

import generalization_cases as gc  # noqa: E402
import moli  # noqa: E402

ORACLE_TOLERANCE = 0.1
MIN_SNR = 20.0


def counted(case: gc.Case) -> bool:
    """The cases of the order targets: SNR of 20 dB or more, true order within nmax."""
    return case.meta["snr_db"] >= MIN_SNR and case.meta["n_true"] <= case_nmax(case)


def case_nmax(case: gc.Case) -> int:
    return gc.nmax_rule(case.est.p, case.est.m, case.est.N)


def fixed_orders(seed: int, index: int) -> dict[str, Any] | None:
    """The case's models at every fixed order p..nmax, scored against the truth."""
    case = gc.synthetic_case(seed, index)
    if not counted(case):
        return None
    nmax, half = case_nmax(case), case.val.N // 2
    fits, h2 = {}, {}
    for order in range(case.est.p, nmax + 1):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                model = moli.identify(case.est, case.val[:half], nmax=nmax, order=order).model
            except moli.MoliError:
                continue
        scores = gc.true_scores(case, (model.A, model.B, model.C, model.D))
        fits[order], h2[order] = scores["true_fit"], scores["h2"]
    if not fits:
        return None
    best = max(fits.values())
    truth_order = min(k for k, fit in fits.items() if fit >= best - ORACLE_TOLERANCE)
    return {"name": case.name, "n_true": case.meta["n_true"], "kind": case.meta["kind"], "p": case.est.p,
            "N": case.est.N, "nmax": nmax, "true_fit": fits, "h2": h2, "truth_order": truth_order,
            "best_h2_order": min(h2, key=h2.get)}


def rule_rows(cases: list[dict[str, Any]], against: dict[str, Any]) -> list[dict[str, Any]]:
    """Per variant of a generalization run: its orders against the true and the truth's orders."""
    lines = {line["name"]: line for line in against["cases"]}
    rows = []
    for variant in against["variants"]:
        picked = [(case, lines[case["name"]]["moli"][variant]) for case in cases
                  if "order" in lines.get(case["name"], {}).get("moli", {}).get(variant, {})]
        if not picked:
            continue
        order = np.array([line["order"] for _, line in picked])
        true = np.array([case["n_true"] for case, _ in picked])
        oracle = np.array([case["truth_order"] for case, _ in picked])
        lost = [case["true_fit"][str(case["truth_order"])] - line["true_fit"] for case, line in picked]
        rows.append({"variant": variant, "cases": len(picked), "true": float(np.mean(order == true)),
                     "true_within_one": float(np.mean(np.abs(order - true) <= 1)),
                     "truth_order": float(np.mean(order == oracle)),
                     "truth_within_one": float(np.mean(np.abs(order - oracle) <= 1)),
                     "above_truth_order": float(np.mean(order > oracle)),
                     "fit_lost_median": float(np.median(lost)), "fit_lost_mean": float(np.mean(lost))})
    return rows


def markdown(cases: list[dict[str, Any]], rows: list[dict[str, Any]], seed: int) -> str:
    if not cases:
        return f"# The truth's order, seed {seed}\n\nNo synthetic case of {MIN_SNR:g} dB or more with the true order within nmax.\n"
    true = np.array([c["n_true"] for c in cases])
    oracle = np.array([c["truth_order"] for c in cases])
    below_p = int(np.sum(true < np.array([c["p"] for c in cases])))
    out = [f"# The truth's order, seed {seed}", "",
           f"{len(cases)} synthetic cases of {MIN_SNR:g} dB or more with the true order within nmax.", "",
           "| | share of the cases |", "|---|---|",
           f"| the truth's order is the true order | {np.mean(oracle == true):.2f} |",
           f"| within one of it | {np.mean(np.abs(oracle - true) <= 1):.2f} |",
           f"| below it | {np.mean(oracle < true):.2f} |",
           f"| true order below p (no MOLI structure holds it) | {below_p / len(cases):.2f} |", ""]
    if rows:
        out += ["| variant | cases | true order | within one | truth's order | within one of it | above it "
                "| true fit lost against the truth's order, median / mean |",
                "|---|---|---|---|---|---|---|---|"]
        out += [f"| {r['variant']} | {r['cases']} | {r['true']:.2f} | {r['true_within_one']:.2f} | "
                f"{r['truth_order']:.2f} | {r['truth_within_one']:.2f} | {r['above_truth_order']:.2f} | "
                f"{r['fit_lost_median']:.3f} / {r['fit_lost_mean']:.2f} |" for r in rows]
    out += ["", "| case | kind | N | p | true order | truth's order | lowest-H2 order |", "|---|---|---|---|---|---|---|"]
    out += [f"| {c['name']} | {c['kind']} | {c['N']} | {c['p']} | {c['n_true']} | {c['truth_order']} | "
            f"{c['best_h2_order']} |" for c in cases]
    return "\n".join(out) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=0, help="seed of the synthetic family")
    parser.add_argument("--synthetic", type=int, default=80, help="number of synthetic cases")
    parser.add_argument("--jobs", type=int, default=2, help="parallel workers (loky)")
    parser.add_argument("--against", metavar="JSON", help="a generalization.json of the same seed")
    parser.add_argument("--out", default="bench-results", help="folder of the results")
    args = parser.parse_args()
    from joblib import Parallel, delayed

    against = json.loads(Path(args.against).read_text()) if args.against else None
    if against is not None:
        # the case names repeat across seeds: another seed's run would pair unrelated systems
        named = re.search(r"--seed (\d+)", against["command"])
        if (int(named.group(1)) if named else 0) != args.seed:
            parser.error(f"{args.against} is not a run of seed {args.seed} (its command: {against['command']})")
    started = time.perf_counter()
    found = Parallel(n_jobs=args.jobs)(delayed(fixed_orders)(args.seed, i) for i in range(args.synthetic))
    cases = [c for c in found if c is not None]
    for case in cases:   # JSON keys: the orders as text, as they read back
        case["true_fit"] = {str(k): v for k, v in case["true_fit"].items()}
        case["h2"] = {str(k): v for k, v in case["h2"].items()}
    rows = rule_rows(cases, against) if against else []
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    report = {"seed": args.seed, "seconds": time.perf_counter() - started, "cases": cases, "rules": rows}
    (out / "order_oracle.json").write_text(json.dumps(report, indent=1))
    text = markdown(cases, rows, args.seed)
    (out / "order_oracle.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
