"""Residual tests on records that start away from rest: how often the true plant, a model whose
poles match it to 3 decimals, and a model missing a mode fail at least one test.

Each record (``started_record`` in tests/systems_util.py) drives a 2x2 plant of four modes
(poles 0.97, 0.9, 0.8, 0.6) with input steps, starting from the rest state of an earlier input
level: the outputs begin hundreds of noise levels from where the steps keep them. Each model's
simulation errors are tested from its least-squares initial state (``residual_analysis``'s
default ``x0="estimate"``), 6 tests at 1 %. The script prints each model's share of records with
at least one failed test, with its binomial standard deviation, the rate
``ResidualAnalysis.false_alarm_rate`` states, and the median number of leading samples skipped.

    OPENBLAS_NUM_THREADS=1 python benchmarks/started_residuals.py [--records 200]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse
import sys
from pathlib import Path

import numpy as np

import moli

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from systems_util import started_models, started_record  # noqa: E402


def failed(analysis: moli.ResidualAnalysis) -> bool:
    """Whether any of the analysis' tests rejects at its level."""
    level = 1 - analysis.confidence
    return bool(np.any(analysis.whiteness_pvalue < level) or np.any(analysis.independence_pvalue < level))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=200)
    args = parser.parse_args()
    models = started_models()
    fails = dict.fromkeys(models, 0)
    skipped: dict[str, list[int]] = {name: [] for name in models}
    for seed in range(args.records):
        record = started_record(seed)
        for name, model in models.items():
            analysis = moli.residual_analysis(model, record)
            fails[name] += failed(analysis)
            skipped[name].append(getattr(analysis, "first_tested", 0))
    print(f"{args.records} records of {record.N} samples; {analysis.tests} tests at "
          f"{1 - analysis.confidence:.0%}, false_alarm_rate {analysis.false_alarm_rate:.3f}")
    for name in models:
        share = fails[name] / args.records
        spread = np.sqrt(share * (1 - share) / args.records)
        print(f"  {name:20s} fails at least one test on {fails[name]:3d} records ({share:.3f} +- {spread:.3f}); "
              f"median samples skipped {np.median(skipped[name]):.0f}")


if __name__ == "__main__":
    main()
