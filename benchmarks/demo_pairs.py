"""`moli demo` and its report, two source trees alternated in fresh processes.

On a shared machine whose speed drifts between minutes, two versions are compared pair by
pair: each pair runs the first tree, then the second, and the figures are the medians, the
median of the pairs' ratios, how many pairs the second won and Wilcoxon's signed-rank test
on the pairs. Each run is a new interpreter (one BLAS thread), as in ``first_run.py``:

- ``moli demo`` into a temporary folder, report included: CPU seconds (user + system) of
  the whole command;
- the same work in one process, timed between its steps: the report alone (seven PNG
  figures, the residual analysis, the page).

Usage::

    OPENBLAS_NUM_THREADS=1 python benchmarks/demo_pairs.py BEFORE/src AFTER/src [--pairs 10]
"""

from __future__ import annotations

import argparse
import statistics

from scipy.stats import wilcoxon

from first_run import DEMO_PARTS, _child_json, _env, demo_runs


def _row(label: str, values: list[float]) -> str:
    return f"| {label} | {', '.join(f'{v:.2f}' for v in values)} | {statistics.median(values):.2f} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", help="the first tree's src folder")
    parser.add_argument("after", help="the second tree's src folder")
    parser.add_argument("--pairs", type=int, default=10)
    args = parser.parse_args()
    trees = {"before": _env(args.before), "after": _env(args.after)}
    demo: dict[str, list[float]] = {name: [] for name in trees}
    report: dict[str, list[float]] = {name: [] for name in trees}
    for _ in range(args.pairs):
        for name, env in trees.items():
            demo[name].append(demo_runs(1, env)[0][0])
            report[name].append(_child_json(DEMO_PARTS, env)["report"])
    for title, runs in (("`moli demo`, whole command", demo), ("the report alone", report)):
        print(f"\n{title}, CPU seconds, {args.pairs} pairs\n\n| tree | run by run | median |\n|---|---|---|")
        print(_row(f"before ({args.before})", runs["before"]))
        print(_row(f"after ({args.after})", runs["after"]))
        ratios = [b / a for a, b in zip(runs["before"], runs["after"])]
        won = sum(b < a for a, b in zip(runs["before"], runs["after"]))
        p = wilcoxon(runs["before"], runs["after"]).pvalue
        print(f"\nafter / before, median of the pairs: {statistics.median(ratios):.2f}; "
              f"after faster in {won} of {args.pairs} pairs; Wilcoxon p = {p:.2g}")


if __name__ == "__main__":
    main()
