"""Frequency-domain identification on synthetic MIMO modal systems (docs/frequency.md §6).

Each seed draws a continuous-time system of 2 inputs, 3 outputs and 4 lightly damped modes
(natural frequencies log-uniform in 5-150 rad/s, at least 15 % apart; damping ratios
log-uniform in 0.5-5 %; B and C standard normal), its FRF on 2000 log-spaced lines
over 1-300 rad/s, and circular complex noise of a level drawn uniformly in 1-3 % of |G| on
each entry (the data carry that variance). ``moli.identify`` fits it; the figures are the
worst relative error of a natural frequency and of a damping ratio over the modes, the
selected order, the share of lines whose 95 % band of |G| (discrete twin, below) holds the
true gain, and the CPU time of the fit (process time, one BLAS thread); over all seeds, the mean
square of each mode's errors in its standard deviations (1 where they are calibrated). Beside
each share, the range (5-95 %) of the shares that 200 errors drawn from the model's own
covariance give: how far one seed's share scatters when the covariance is exact, because a
seed's lines err together (the CPU time excludes these draws).

The same system sampled at Ts = 0.01 (zero-order hold) on 2000 log-spaced lines up to
Nyquist is fitted as discrete data: its model's ``magnitude_bands`` give the coverage.

    OPENBLAS_NUM_THREADS=1 python benchmarks/frequency.py --seeds 20 [--first 100]

``--frequency-start both`` adds the MOLI start at each order (docs/frequency.md §2b) and
counts the seeds whose selected order kept it.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import moli
from moli.models.bands import magnitude_bands

TS = 0.01
# Draws from a model's covariance for the shares an exact covariance would give.
DRAWS = 200


def system(seed: int, modes: int = 4) -> tuple[moli.ContinuousModel, np.ndarray, np.ndarray]:
    """The seed's continuous-time truth with ``modes`` modes, their natural frequencies and damping ratios.

    With the default four modes it draws what it always drew (the figures of docs/frequency.md
    §8); ``benchmarks/frequency_peers.py`` shares it, with 4-8 modes.
    """
    rng = np.random.default_rng(seed)
    while True:
        natural = np.sort(np.exp(rng.uniform(np.log(5.0), np.log(150.0), modes)))
        if np.all(np.diff(np.log(natural)) > np.log(1.15)):
            break
    damping = np.exp(rng.uniform(np.log(0.005), np.log(0.05), modes))
    states = 2 * modes
    A = np.zeros((states, states))
    for i, (wn, zeta) in enumerate(zip(natural, damping)):
        sigma, omega = -zeta * wn, wn * np.sqrt(1 - zeta**2)
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = [[sigma, omega], [-omega, sigma]]
    model = moli.ContinuousModel(A, rng.standard_normal((states, 2)), rng.standard_normal((3, states)),
                                 np.zeros((3, 2)), ("y1", "y2", "y3"), ("u1", "u2"), np.zeros(3), np.zeros(2),
                                 (0.0, 0.0))
    return model, natural, damping


def lines(kind: str) -> tuple[float | None, np.ndarray]:
    """The sampling period (None: continuous) and the 2000 log-spaced lines (rad/s) of ``kind``."""
    if kind == "continuous":
        return None, np.logspace(0, np.log10(300), 2000)
    return TS, np.logspace(0, np.log10(np.pi / TS), 2000)


def noisy(G: np.ndarray, omega: np.ndarray, seed: int, Ts: float | None) -> moli.FrequencyData:
    rng = np.random.default_rng(10_000 + seed)
    spread = rng.uniform(0.01, 0.03) * np.abs(G)
    noise = spread * (rng.standard_normal(G.shape) + 1j * rng.standard_normal(G.shape)) / np.sqrt(2)
    return moli.FrequencyData(omega, G + noise, unit="rad/s", Ts=Ts, variance=spread**2)


def errors(model, natural: np.ndarray, damping: np.ndarray) -> tuple[float, float, np.ndarray]:
    """Worst relative errors of the natural frequencies and damping ratios, and each error in standard deviations."""
    found = moli.modes(model)
    if len(found) != natural.size:
        return np.inf, np.inf, np.full((natural.size, 2), np.nan)
    fitted = np.array([[mode.natural_frequency, mode.damping] for mode in found])
    spread = np.array([[mode.natural_frequency_std or np.nan, mode.damping_std or np.nan] for mode in found])
    standardized = (fitted - np.column_stack([natural, damping])) / spread
    return (float(np.max(np.abs(fitted[:, 0] / natural - 1))), float(np.max(np.abs(fitted[:, 1] / damping - 1))),
            standardized)


def exact_covariance_shares(model, omega: np.ndarray, lower: np.ndarray, upper: np.ndarray, seed: int) -> np.ndarray:
    """Shares of lines inside the bands for errors drawn from the model's own covariance (DRAWS of them).

    What a seed's share would scatter by if the covariance were exact and the estimate's error
    normal: the bands' calibration apart, the spread that correlated errors across lines give.
    """
    n, p, m = model.n, model.p, model.m
    nominal = np.concatenate([model.A.ravel(), model.B.ravel(), model.C.ravel(), model.D.ravel()])
    draws = nominal + np.random.default_rng(20_000 + seed).standard_normal((DRAWS, model.cov_factor.shape[1])) \
        @ model.cov_factor.T
    points = 1j * omega if model.is_continuous else np.exp(1j * omega * model.Ts)
    shares = np.empty(DRAWS)
    for k, vector in enumerate(draws):
        A, B, C, D = np.split(vector, np.cumsum([n * n, n * m, p * n]))
        pencil = points[:, None, None] * np.eye(n) - A.reshape(n, n)
        gain = np.abs(C.reshape(p, n) @ np.linalg.solve(pencil, np.broadcast_to(B.reshape(n, m), (omega.size, n, m)))
                      + D.reshape(p, m))
        shares[k] = np.mean((lower <= gain) & (gain <= upper))
    return shares


def one_seed(seed: int, frequency_start: str = "subspace") -> dict:
    truth, natural, damping = system(seed)
    row = {"seed": seed}
    for kind in ("continuous", "discrete"):
        Ts, omega = lines(kind)
        plant = truth if Ts is None else truth.to_discrete(Ts)
        G = plant.frequency_response(omega)
        data = noisy(G, omega, seed, Ts)
        start = time.process_time()
        result = moli.identify(data, frequency_start=frequency_start)
        cpu = time.process_time() - start
        frequency_error, damping_error, standardized = errors(result.model, natural, damping)
        lower, upper = magnitude_bands(result.model, omega) if result.model.cov_factor is not None else (None, None)
        held = np.nan if lower is None else float(np.mean((lower <= np.abs(G)) & (np.abs(G) <= upper)))
        exact = (np.full(DRAWS, np.nan) if lower is None
                 else exact_covariance_shares(result.model, omega, lower, upper, seed))
        row[kind] = {"order": result.selected.order, "frequency": frequency_error, "damping": damping_error,
                     "coverage": held, "cpu": cpu, "start": result.selected.start, "standardized": standardized,
                     "exact": exact}
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--frequency-start", choices=("subspace", "both"), default="subspace")
    parser.add_argument("--first", type=int, default=0, help="the first seed (the seeds run from it on)")
    arguments = parser.parse_args()
    seeds = arguments.seeds
    rows = [one_seed(seed, arguments.frequency_start) for seed in range(arguments.first, arguments.first + seeds)]
    for kind in ("continuous", "discrete"):
        print(f"\n{kind}: seed, order, worst natural-frequency error, worst damping error, band coverage, CPU s, "
              "the coverage's 5-95 % range under an exact covariance")
        for row in rows:
            r = row[kind]
            low, high = np.quantile(r["exact"], [0.05, 0.95])
            print(f"  {row['seed']:3d}  {r['order']:2d}  {r['frequency']:.2e}  {r['damping']:.2e}  "
                  f"{r['coverage']:.3f}  {r['cpu']:.2f}  {low:.3f}-{high:.3f}")
        table = [row[kind] for row in rows]
        coverage, cpu = [r["coverage"] for r in table], [r["cpu"] for r in table]
        print(f"  true order on {sum(r['order'] == 8 for r in table)}/{seeds}; every mode within 0.2 % and 10 % on "
              f"{sum(r['frequency'] < 0.002 and r['damping'] < 0.10 for r in table)}/{seeds}; coverage median "
              f"{np.nanmedian(coverage):.3f}, mean {np.nanmean(coverage):.3f} (range {np.nanmin(coverage):.3f}-"
              f"{np.nanmax(coverage):.3f}), in 0.90-0.98 on {sum(0.90 <= c <= 0.98 for c in coverage)}/{seeds}; "
              f"CPU median {np.median(cpu):.2f} s, max {np.max(cpu):.2f} s; selected step from the MOLI start on "
              f"{sum(r['start'] == 'moli' for r in table)}/{seeds}")
        exact = np.concatenate([r["exact"] for r in table])
        print(f"  under an exact covariance the coverage would be in 0.90-0.98 for "
              f"{np.nanmean((exact >= 0.90) & (exact <= 0.98)):.2f} of the draws (mean {np.nanmean(exact):.3f})")
        squares = np.concatenate([r["standardized"] for r in table]) ** 2
        print(f"  mode errors in standard deviations, mean square (1 for calibrated standard deviations): natural "
              f"frequency {np.nanmean(squares[:, 0]):.2f}, damping {np.nanmean(squares[:, 1]):.2f}, over "
              f"{np.sum(np.isfinite(squares[:, 0]))} modes; beyond 3: {np.sum(squares[:, 0] > 9)} and "
              f"{np.sum(squares[:, 1] > 9)}")


if __name__ == "__main__":
    main()
