"""Time of moli's default and fast identifications against the fastest peer's order sweep, same process.

The evaporator's paper split (estimation 0..499, validation 500..999), orders 3..15:
``moli.identify`` with the defaults and with ``preset="fast"`` against every peer
configuration of ``peers_lib.peer_fitters`` swept over the same orders (estimation and
validation simulation), one BLAS thread, each the fastest of ``repeats`` runs with the
methods alternated (benchmarks/peers.py times the same way). Needs the ``bench`` extra.

    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/peer_ratio.py [repeats]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import sys

import peers
import peers_lib as pl
from daisy_data import load

REPEATS = int(sys.argv[1]) if len(sys.argv) > 1 else 5
PRESETS = {"moli default": {}, "moli fast": {"preset": "fast"}}


def main() -> None:
    data = load("evaporator")
    est, val = slice(0, 500), slice(500, 1000)
    nmax = peers.NMAX["evaporator"]
    fitters = pl.peer_fitters()
    best: dict[str, float] = {}
    for _ in range(REPEATS):
        for label, options in PRESETS.items():
            seconds = peers.run_moli(data, est, val, nmax, options)["seconds"]
            best[label] = min(best.get(label, float("inf")), seconds)
        for label, fit in fitters.items():
            seconds = peers.run_peer(fit, data, est, val, nmax)["seconds"]
            best[label] = min(best.get(label, float("inf")), seconds)
    fastest = min((s, label) for label, s in best.items() if label not in PRESETS)
    for label, seconds in sorted(best.items(), key=lambda item: item[1]):
        print(f"{label:32s} {seconds:8.3f} s")
    for label in PRESETS:
        print(f"{label} / fastest peer ({fastest[1]}): {best[label] / fastest[0]:.2f}")
    print(f"moli fast / moli default: {best['moli fast'] / best['moli default']:.2f}")


if __name__ == "__main__":
    main()
