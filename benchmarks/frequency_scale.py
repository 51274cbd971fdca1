"""Frequency-domain identification at scale: 10^4 and 10^5 lines, 36 states (docs/frequency.md §8, Scale).

The system: continuous time, 3 outputs, 2 inputs, 18 lightly damped modes (natural frequencies
spread evenly in log over 5-150 rad/s, each moved by up to 3 % at random, 22 % apart on
average; damping ratios log-uniform in 0.5-5 %; B and C standard normal), its FRF on F
log-spaced lines over 1-300 rad/s with 2 % circular complex noise on each entry (the data
carrying that variance). Each fit runs in a child process of its own, so that its peak
resident memory (``ru_maxrss``) is its own; the figures are the process time of
``moli.identify`` on one BLAS thread, the peak resident memory of the child and how much of
it the data held before the fit started, the selected order and the worst relative error of a
natural frequency and of a damping ratio over the 18 modes.

    OPENBLAS_NUM_THREADS=1 python benchmarks/frequency_scale.py --lines 10000 100000
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np

import moli

MODES = 18
NOISE = 0.02


def system(seed: int) -> tuple[moli.ContinuousModel, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    natural = np.geomspace(5.0, 150.0, MODES) * np.exp(rng.uniform(-0.03, 0.03, MODES))
    damping = np.exp(rng.uniform(np.log(0.005), np.log(0.05), MODES))
    n = 2 * MODES
    A = np.zeros((n, n))
    for i, (wn, zeta) in enumerate(zip(natural, damping)):
        sigma, omega = -zeta * wn, wn * np.sqrt(1 - zeta**2)
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[sigma, omega], [-omega, sigma]]
    model = moli.ContinuousModel(A, rng.standard_normal((n, 2)), rng.standard_normal((3, n)), np.zeros((3, 2)),
                                 ("y1", "y2", "y3"), ("u1", "u2"), np.zeros(3), np.zeros(2), (0.0, 0.0))
    return model, natural, damping


def kilobytes() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def child(lines: int, nmax: int, order: int | None, seed: int) -> dict:
    truth, natural, damping = system(seed)
    omega = np.logspace(0, np.log10(300.0), lines)
    G = truth.frequency_response(omega)
    rng = np.random.default_rng(10_000 + seed)
    spread = NOISE * np.abs(G)
    G = G + spread * (rng.standard_normal(G.shape) + 1j * rng.standard_normal(G.shape)) / np.sqrt(2)
    data = moli.FrequencyData(omega, G, unit="rad/s", variance=spread**2)
    del G, spread
    before = kilobytes()
    start = time.process_time()
    result = moli.identify(data, options=moli.IdentifyOptions(nmax=nmax, order=order))
    cpu = time.process_time() - start
    found = moli.modes(result.model)
    row = {"lines": lines, "order": result.selected.order, "cpu": cpu, "peak_mb": kilobytes() / 1024,
           "data_mb": before / 1024, "frequency": np.inf, "damping": np.inf}
    if len(found) == MODES:
        fitted = np.array([[mode.natural_frequency, mode.damping] for mode in found])
        row["frequency"] = float(np.max(np.abs(fitted[:, 0] / np.sort(natural) - 1)))
        row["damping"] = float(np.max(np.abs(fitted[:, 1] / damping[np.argsort(natural)] - 1)))
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, nargs="+", default=[10_000, 100_000])
    parser.add_argument("--nmax", type=int, default=40)
    parser.add_argument("--order", type=int, default=None, help="fit this order only (no sweep)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    arguments = parser.parse_args()
    if arguments.child:
        print(json.dumps(child(arguments.lines[0], arguments.nmax, arguments.order, arguments.seed)))
        return
    print("lines, selected order, worst natural-frequency error, worst damping error, CPU s, peak MB (data MB)")
    for lines in arguments.lines:
        command = [sys.executable, __file__, "--child", "--lines", str(lines), "--nmax", str(arguments.nmax),
                   "--seed", str(arguments.seed)]
        if arguments.order is not None:
            command += ["--order", str(arguments.order)]
        row = json.loads(subprocess.run(command, check=True, capture_output=True, text=True).stdout)
        print(f"  {row['lines']:7d}  {row['order']:2d}  {row['frequency']:.2e}  {row['damping']:.2e}  "
              f"{row['cpu']:7.1f}  {row['peak_mb']:6.0f} ({row['data_mb']:.0f})")


if __name__ == "__main__":
    main()
