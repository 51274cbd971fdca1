"""Does the long-record shortcut (``IdentifyOptions.search_samples``) pick models as good as the full search?

For each seed, a random stable 3x3 plant of order 6 (benchmarks/scaling_core.py) gives
a long record (white inputs, 20 dB output noise; ``identify`` holds out its last 30 %)
and a fresh record of the same plant with new inputs and noise. ``identify`` runs with
the search on the whole estimation record (``search_samples=None``), with the default
window and with smaller ones; each selected model is scored on the fresh record (mean
VAF over the outputs, simulation from the zero state).

    OPENBLAS_NUM_THREADS=1 python benchmarks/long_record_search.py [N] [seeds] [windows...]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import sys
import time
import warnings

import numpy as np

import moli
from scaling_core import record

N = int(float(sys.argv[1])) if len(sys.argv) > 1 else 200_000
SEEDS = int(sys.argv[2]) if len(sys.argv) > 2 else 5
WINDOWS = [int(float(w)) for w in sys.argv[3:]] or [moli.IdentifyOptions().search_samples, 8192]
FRESH = 100_000


def main() -> None:
    labels = ["full"] + [f"window {w}" for w in WINDOWS]
    print(f"N = {N} (estimation {round(0.7 * N)}), fresh record {FRESH} samples, nmax = 8")
    print(f"{'seed':>4}  " + "  ".join(f"{lab:>30}" for lab in labels))
    gaps: dict[str, list[float]] = {lab: [] for lab in labels[1:]}
    for seed in range(SEEDS):
        data, fresh = record(N, 3, 3, seed), record(FRESH, 3, 3, seed)
        cells, scores = [], {}
        for label, samples in zip(labels, [None] + WINDOWS):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                start = time.perf_counter()
                result = moli.identify(data, nmax=8, search_samples=samples)
                seconds = time.perf_counter() - start
            scores[label] = float(np.mean(moli.compare(result.model, fresh).vaf))
            cells.append(f"{str(list(result.model.indices)):>10} {scores[label]:8.3f} {seconds:7.1f} s")
        for label in gaps:
            gaps[label].append(scores["full"] - scores[label])
        print(f"{seed:>4}  " + "  ".join(f"{c:>30}" for c in cells), flush=True)
    for label, values in gaps.items():
        print(f"{label}: fresh-data VAF of the full search minus this one, points: mean "
              f"{np.mean(values):.4f}, worst {np.max(values):.4f}")


if __name__ == "__main__":
    main()
