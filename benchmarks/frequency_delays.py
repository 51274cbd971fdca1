"""Input delays fitted to frequency responses (docs/frequency.md §4, "Input delays").

A continuous-time system of 2 inputs, 3 outputs and 4 modes (10, 23, 41 and 77 rad/s, damping
0.5, 2, 1 and 5 %; B and C standard normal, drawn once), input 2 delayed by 3 ms; its FRF on 2000
log-spaced lines over 1-316 rad/s with 1 % circular complex noise on each entry (the data carry
that variance). ``moli.identify(..., delays="auto")`` fits it with the feedthrough fixed at zero
and estimated; each row gives the seed, the feedthrough, the order, the delays (ms) and the CPU
time of the fit (process time, one BLAS thread).

    OPENBLAS_NUM_THREADS=1 python benchmarks/frequency_delays.py --seeds 6
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import moli

FREQUENCIES = np.array([10.0, 23.0, 41.0, 77.0])
DAMPINGS = np.array([0.005, 0.02, 0.01, 0.05])
OMEGA = np.logspace(0, 2.5, 2000)
DELAYS = np.array([0.0, 0.003])
LEVEL = 0.01


def modal_system(seed: int = 12) -> moli.ContinuousModel:
    A = np.zeros((8, 8))
    for i, (wn, zeta) in enumerate(zip(FREQUENCIES, DAMPINGS)):
        sigma, omega = -zeta * wn, wn * np.sqrt(1 - zeta**2)
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[sigma, omega], [-omega, sigma]]
    rng = np.random.default_rng(seed)
    return moli.ContinuousModel(A, rng.standard_normal((8, 2)), rng.standard_normal((3, 8)), np.zeros((3, 2)),
                                ("y1", "y2", "y3"), ("u1", "u2"), np.zeros(3), np.zeros(2), (0.0, 0.0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=6)
    args = parser.parse_args()
    G = modal_system().frequency_response(OMEGA) * np.exp(-1j * np.outer(OMEGA, DELAYS))[:, None, :]
    for seed in range(args.seeds):
        rng = np.random.default_rng(seed)
        spread = LEVEL * np.abs(G)
        noisy = G + spread * (rng.standard_normal(G.shape) + 1j * rng.standard_normal(G.shape)) / np.sqrt(2)
        data = moli.FrequencyData(OMEGA, noisy, unit="rad/s", variance=spread**2)
        for feedthrough in (False, "auto"):
            start = time.process_time()
            model = moli.identify(data, delays="auto", feedthrough=feedthrough).model
            seconds = time.process_time() - start
            shown = ", ".join(f"{1e3 * d:.4f}" for d in model.input_delays)
            print(f"seed {seed}  feedthrough {str(feedthrough):5}  order {model.n}  delays (ms) {shown}  "
                  f"{seconds:.1f} s", flush=True)


if __name__ == "__main__":
    main()
