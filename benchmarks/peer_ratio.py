"""CPU time of moli's default and fast identifications against the fastest peer's order sweep, same process.

Each record's split of benchmarks/peers.py (the evaporator's paper split: estimation 0..499,
validation 500..999; CD_player_arm, dryer2 and glassfurnace: first half, second half), orders
up to ``peers.NMAX``: ``moli.identify`` with the defaults and with ``preset="fast"`` against
every peer configuration of ``peers_lib.peer_fitters`` swept over the same orders
(estimation and validation simulation), one BLAS thread, each the fastest of ``repeats``
rounds with the methods alternated. Times are the process's CPU seconds
(``time.process_time``), which other processes on the machine change less than wall time.
Needs the ``bench`` extra.

    MOLI_DATA_DIR=/path/to/daisy OPENBLAS_NUM_THREADS=1 python benchmarks/peer_ratio.py [repeats] [--datasets evaporator ...]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse
import time
from typing import Callable

import peers
import peers_lib as pl
from daisy_data import load

PRESETS = {"moli default": {}, "moli fast": {"preset": "fast"}}


def cpu_seconds(run: Callable[[], object]) -> float:
    started = time.process_time()
    run()
    return time.process_time() - started


def ratios(name: str, repeats: int, fitters: dict) -> dict[str, float]:
    """Each method's fastest CPU time on the record's split, the methods alternated."""
    data = load(name)
    _, est, val = peers.splits(data, name)[0]
    nmax = peers.NMAX[name]
    best: dict[str, float] = {}
    for _ in range(repeats):
        for label, options in PRESETS.items():
            seconds = cpu_seconds(lambda: peers.run_moli(data, est, val, nmax, options))
            best[label] = min(best.get(label, float("inf")), seconds)
        for label, fit in fitters.items():
            seconds = cpu_seconds(lambda: peers.run_peer(fit, data, est, val, nmax))
            best[label] = min(best.get(label, float("inf")), seconds)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("repeats", type=int, nargs="?", default=5)
    parser.add_argument("--datasets", nargs="+", default=["evaporator"], choices=tuple(peers.NMAX))
    parser.add_argument("--peers", nargs="+", metavar="LABEL",
                        help="only these peer configurations (default: all of peers_lib.peer_fitters)")
    args = parser.parse_args()
    fitters = pl.peer_fitters()
    if args.peers:
        fitters = {label: fit for label, fit in fitters.items() if label in args.peers}
    print("| record | fastest peer | its CPU s | moli default s | moli fast s | default / peer | fast / peer |")
    print("|---|---|---|---|---|---|---|")
    for name in args.datasets:
        best = ratios(name, args.repeats, fitters)
        seconds, label = min((s, label) for label, s in best.items() if label not in PRESETS)
        default, fast = best["moli default"], best["moli fast"]
        print(f"| {name} | {label} | {seconds:.3f} | {default:.3f} | {fast:.3f} | {default / seconds:.2f} | "
              f"{fast / seconds:.2f} |", flush=True)


if __name__ == "__main__":
    main()
