"""Why `moli demo`'s report can flag a residual test: the true plant's verdicts on the same records.

`moli demo` identifies ``moli.example_data()`` (estimation on the first half, validation on
the second) and its report tests the selected model's residuals on the validation half:
each output's whiteness and its independence from each input, 12 tests at the 1 % level.
This script prints those p-values for the demo's model and for the true plant
(``moli.example_plant()``, whose output noise is white, so its simulation errors are the
noise itself), and then counts on how many of ``--seeds`` records of ``example_data`` the
true plant fails at least one test, against the rate ``1 - 0.99**12`` that
``ResidualAnalysis.false_alarm_rate`` states.

    OPENBLAS_NUM_THREADS=1 python benchmarks/demo_residuals.py [--seeds 200]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse
import warnings

import numpy as np

import moli


def failed(analysis: moli.ResidualAnalysis) -> bool:
    """Whether any of the analysis' tests rejects at its level."""
    level = 1 - analysis.confidence
    return bool(np.any(analysis.whiteness_pvalue < level) or np.any(analysis.independence_pvalue < level))


def describe(name: str, analysis: moli.ResidualAnalysis) -> None:
    print(f"{name}: whiteness p = {np.round(analysis.whiteness_pvalue, 4).tolist()}; independence p, smallest "
          f"per output = {np.round(np.nanmin(analysis.independence_pvalue, axis=1), 4).tolist()}; "
          f"fails a test: {failed(analysis)}; tested {analysis.tested_samples}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    plant = moli.example_plant()
    est, val = moli.example_data().split(0.5)
    result = moli.identify(est, val)
    print(f"moli demo's record (example_data(), seed 0), selected order {result.selected.order}")
    describe("  the demo's model", moli.residual_analysis(result.model, result.validation))
    truth = moli.residual_analysis(plant, val)
    describe("  the true plant  ", truth)
    fails = sum(failed(moli.residual_analysis(plant, moli.example_data(seed=seed).split(0.5)[1]))
                for seed in range(args.seeds))
    share = fails / args.seeds
    spread = np.sqrt(share * (1 - share) / args.seeds)
    print(f"the true plant fails at least one of its {truth.tests} tests on {fails} of {args.seeds} records "
          f"({share:.3f} +- {spread:.3f}); false_alarm_rate states {truth.false_alarm_rate:.3f}")


if __name__ == "__main__":
    main()
