"""What per-output filters cost: moli's default with and without them against the fastest peers.

Side by side in one process, one BLAS thread: for each record, the default `identify`
(per-output filters), the same with one shared filter (`output_filters=False`), and the
two fastest peer sweeps of benchmarks/peers.py (SIPPY N4SID f=2n, nfoursid r=2n) over
the same orders, run --repeats times with the methods alternated; each keeps its fastest
run. Evaporator: the paper split (0..499 / 500..999); the others: half/half.

    MOLI_DATA_DIR=<daisy folder> python benchmarks/output_filters_cost.py
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import peers_lib as pl  # noqa: E402
from daisy_data import load  # noqa: E402

import moli  # noqa: E402

NMAX = {"evaporator": 15, "CD_player_arm": 10, "dryer2": 12, "glassfurnace": 15}
PEERS = ("SIPPY N4SID f=2n", "nfoursid r=2n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="alternated runs per method")
    args = parser.parse_args()
    fitters = pl.peer_fitters()
    print("| record | per-output (s) | shared (s) | cost | fastest peer (s) | ratio per-output | ratio shared |")
    print("|---|---|---|---|---|---|---|")
    for name, nmax in NMAX.items():
        data = load(name)
        half = 500 if name == "evaporator" else data.N // 2
        est, val = slice(0, half), slice(half, 2 * half if name == "evaporator" else data.N)
        ye, ue, _, _ = pl.centred_split(data.y, data.u, est, val)
        runs = {
            "per-output": lambda: moli.identify(data[est], data[val], nmax=nmax, preset="improved"),
            "shared": lambda: moli.identify(data[est], data[val], nmax=nmax, preset="improved", output_filters=False),
            **{peer: (lambda peer=peer: [fitters[peer](ye, ue, n) for n in range(data.p, nmax + 1)])
               for peer in PEERS},
        }
        best = dict.fromkeys(runs, float("inf"))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for _ in range(args.repeats):
                for label, run in runs.items():
                    start = time.perf_counter()
                    run()
                    best[label] = min(best[label], time.perf_counter() - start)
        peer = min(best[p] for p in PEERS)
        print(f"| {name} | {best['per-output']:.4f} | {best['shared']:.4f} | "
              f"{best['per-output'] / best['shared'] - 1:+.0%} | {peer:.4f} | "
              f"{best['per-output'] / peer:.2f} | {best['shared'] / peer:.2f} |", flush=True)


if __name__ == "__main__":
    main()
