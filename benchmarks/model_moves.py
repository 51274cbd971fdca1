"""Whether a change that moves models passes the rule of docs/performance.md: scores now, compare later.

A change may restructure the arithmetic, and models may move, when on the generalization
benchmark's cases (benchmarks/generalization_cases.py, three seeds) against the code before:

- the paired mean difference of the V2 VAF is within +-0.05 points;
- no case moves by more than 1 point;
- the synthetic cases' true-order share, gain-band coverage and bias stay within their
  seed-to-seed spread (the three seeds' figures are printed side by side for that).

``save`` runs ``moli.identify`` on every case exactly as benchmarks/generalization.py does
(its ``run_moli``: selection on V1, scores on V2 and against the truth) and writes the lines;
``compare`` reads two such files (or a benchmarks/generalization.py result, its ``--variant``) and prints the rule's figures and every case that moved.
The peers are not run: the rule compares moli with itself. benchmarks/same_models.py says,
bit for bit, which matrices moved.

    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/model_moves.py save before_0.json --seed 0
    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/model_moves.py compare before_0.json after_0.json

``--preset fast`` scores the fast preset, ``--set NAME=JSON`` an option on top of it; ``--jobs`` runs cases in parallel workers (the
results do not depend on it).
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from joblib import Parallel, delayed  # noqa: E402

import generalization as gb  # noqa: E402
import generalization_cases as gc  # noqa: E402

# The rule's limits (docs/performance.md)
MEAN_LIMIT = 0.05
CASE_LIMIT = 1.0
# A case counts as moved where its V2 VAF changed by more than this (points)
MOVED = 0.01
PRESETS = {"default": {}, "fast": {"preset": "fast"}}


def score_case(case: gc.Case, options: dict[str, Any]) -> dict[str, Any]:
    """One case's line as benchmarks/generalization.py keeps it, moli only."""
    half, (p, m) = case.val.N // 2, (case.est.p, case.est.m)
    nmax = gc.nmax_rule(p, m, case.est.N)
    return {"name": case.name, "group": case.group, "N": case.est.N, "nmax": nmax, **case.meta,
            "moli": {"run": gb.run_moli(case, half, nmax, options)}}


def save(path: Path, seed: int, options: dict[str, Any], jobs: int) -> None:
    cases = gb.build_cases(80, seed, False)
    order = sorted(range(len(cases)), key=lambda i: -gb.cost(cases[i]))
    started = time.perf_counter()
    lines = Parallel(n_jobs=jobs, backend="loky")(delayed(score_case)(cases[i], options) for i in order)
    lines = sorted(lines, key=lambda line: line["name"])
    path.write_text(json.dumps({"seed": seed, "options": options, "seconds": time.perf_counter() - started,
                                "cases": lines}, indent=1, default=float))
    print(f"{len(lines)} cases scored in {time.perf_counter() - started:.0f} s; wrote {path}")


def v2(line: dict[str, Any]) -> float:
    return float(line["moli"]["run"].get("v2", 0.0))


def read_lines(path: Path, variant: str) -> dict[str, dict[str, Any]]:
    """The cases of a file of ``save`` or of benchmarks/generalization.py (its ``variant``'s results)."""
    lines = json.loads(path.read_text())["cases"]
    for line in lines:
        if "run" not in line["moli"]:
            line["moli"] = {"run": line["moli"][variant]}
    return {line["name"]: line for line in lines}


def compare(before_path: Path, after_path: Path, variant: str) -> None:
    before, after = read_lines(before_path, variant), read_lines(after_path, variant)
    names = sorted(set(before) & set(after))
    if set(before) ^ set(after):
        print(f"cases in one file only: {sorted(set(before) ^ set(after))}")
    d = np.array([v2(after[name]) - v2(before[name]) for name in names])
    moved = [(name, delta) for name, delta in zip(names, d) if abs(delta) > MOVED]
    orders = [name for name in names if before[name]["moli"]["run"].get("order") != after[name]["moli"]["run"].get("order")]
    print(f"{len(names)} cases: paired mean difference {d.mean():+.4f} points (limit +-{MEAN_LIMIT}), "
          f"median {np.median(d):+.4f}, largest |difference| {np.max(np.abs(d)):.3f} (limit {CASE_LIMIT}); "
          f"{len(moved)} moved by more than {MOVED}, {int(np.sum(np.abs(d) > CASE_LIMIT))} by more than "
          f"{CASE_LIMIT}; selected order changed on {len(orders)}")
    passed = abs(d.mean()) <= MEAN_LIMIT and np.max(np.abs(d)) <= CASE_LIMIT
    print(f"V2 part of the rule: {'passed' if passed else 'FAILED'}")
    for name, delta in sorted(moved, key=lambda item: -abs(item[1])):
        b, a = before[name]["moli"]["run"], after[name]["moli"]["run"]
        print(f"  {name:28s} {delta:+8.3f}  order {b.get('order')} -> {a.get('order')}")
    print("| code | clean cases | true order | within one | above | coverage | coverage at the true order | bias / sd |")
    print("|---|---|---|---|---|---|---|---|")
    for label, lines in (("before", before), ("after", after)):
        row = gb.soundness_rows([lines[name] for name in names], ["run"])[0]
        print(f"| {label} | {row['clean']} | {row['exact']:.3f} | {row['within_one']:.3f} | {row['above']:.3f} | "
              f"{row['coverage']:.3f} | {row['coverage_true_order']:.3f} ({row['true_order_cases']}) | "
              f"{row['bias_sd']:.3f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("save", "compare"))
    parser.add_argument("files", nargs="+", help="save: the file to write; compare: before and after")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--preset", default="default", choices=tuple(PRESETS))
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], metavar="NAME=JSON",
                        help="save: an option on top of the preset, e.g. filter_grid='\"paper\"' (repeatable)")
    parser.add_argument("--variant", default="default",
                        help="compare: the variant read from a benchmarks/generalization.py file")
    args = parser.parse_args()
    if args.action == "save":
        if len(args.files) != 1:
            parser.error("save writes one file")
        options = dict(PRESETS[args.preset])
        for item in args.set:
            name, _, value = item.partition("=")
            options[name] = json.loads(value)
        save(Path(args.files[0]), args.seed, options, args.jobs)
    else:
        if len(args.files) != 2:
            parser.error("compare reads two files: before and after")
        compare(Path(args.files[0]), Path(args.files[1]), args.variant)


if __name__ == "__main__":
    main()
