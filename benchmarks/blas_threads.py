"""moli's computations with BLAS as the process has it against moli's one-thread limit, side by side.

Unlike every other script here, this one leaves BLAS's thread pools as a user's process has them
(it does not import ``single_thread``): it measures what moli's own limit
(:mod:`moli.numerics.blas_threads`) is worth to a user who never set ``OPENBLAS_NUM_THREADS``.
Each computation runs with ``MOLI_BLAS_THREADS=keep`` (BLAS left alone, as moli ran before the
limit) and unset (one thread), alternated, the fastest of ``--rounds`` of each; wall and CPU
seconds of the process. ``--long`` adds a 60000-sample record (about a minute).

    MOLI_DATA_DIR=/path/to/daisy python benchmarks/blas_threads.py [--rounds 3] [--long]
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from typing import Callable

from daisy_data import load

import moli

# the DaISy splits of benchmarks/peer_ratio.py: the evaporator's paper split, the others' halves
SPLITS = {"evaporator": (slice(0, 500), slice(500, 1000), 15), "CD_player_arm": (None, None, 10),
          "dryer2": (None, None, 12), "glassfurnace": (None, None, 15)}


def computations(long: bool) -> dict[str, Callable[[], object]]:
    est, val = moli.example_data(N=1000, seed=1).split(600)
    jobs: dict[str, Callable[[], object]] = {
        "identify, built-in 3x3 (600 + 400 samples)": lambda: moli.identify(est, val),
        "identify, fast preset, the same": lambda: moli.identify(est, val, preset="fast"),
        "impulse_response, the same 600 samples": lambda: moli.impulse_response(est),
        "identify_kernel, the same": lambda: moli.identify_kernel(est, val),
        "identify_kernel_arx, the same": lambda: moli.identify_kernel_arx(est, val),
    }
    for name, (first, second, nmax) in SPLITS.items():
        data = load(name)
        half = slice(0, data.N // 2), slice(data.N // 2, data.N)
        e, v = data[first or half[0]], data[second or half[1]]
        jobs[f"identify, {name} split"] = lambda e=e, v=v, nmax=nmax: moli.identify(e, v, nmax=nmax)
    if long:
        record = moli.example_data(N=60000, seed=2)
        jobs["identify, built-in 3x3, 60000 samples"] = lambda: moli.identify(record)
    return jobs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--long", action="store_true", help="also a 60000-sample record")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    print(f"{os.cpu_count()} CPUs; OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}\n")
    print("| computation | BLAS as the process has it: wall s / CPU s | one BLAS thread: wall s / CPU s | "
          "wall, as it is / one thread |")
    print("|---|---|---|---|")
    for label, job in computations(args.long).items():
        best: dict[str, tuple[float, float]] = {}
        for _ in range(args.rounds):
            for setting in ("keep", "1"):
                os.environ["MOLI_BLAS_THREADS"] = setting
                wall, cpu = time.perf_counter(), time.process_time()
                job()
                wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
                if setting not in best or wall < best[setting][0]:
                    best[setting] = (wall, cpu)
        (kw, kc), (ow, oc) = best["keep"], best["1"]
        print(f"| {label} | {kw:.2f} / {kc:.2f} | {ow:.2f} / {oc:.2f} | {kw / ow:.1f} |", flush=True)
    os.environ.pop("MOLI_BLAS_THREADS")


if __name__ == "__main__":
    main()
