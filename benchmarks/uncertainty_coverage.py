"""How often the 95 % bands cover the truth (docs/uncertainty.md §5).

Monte Carlo over seeded records of known systems with white output noise: the share of
(run, frequency, channel) points where the magnitude band holds the true gain, and of
(run, sample, channel) points where the step band holds the true step response.

- SISO: the resonant plant of tests/method/test_uncertainty.py (poles 0.8 exp(±0.4j),
  N = 500, noise 0.3 against an output of standard deviation 4.4), true indices [2],
  with the filter identify's search picks (wc 0.45, zeta 0.7), a slower and a faster
  one; the Newey-West sandwich (moli) against the plain sigma^2 (Phi^T Phi)^-1.
- 2x2: a fourth-order plant with generic indices (2, 2), N = 600, same filters.
- identify: the whole automatic identification (structure, filters, order rule) on the
  same two plants and on moli.example_plant (3x3, order 6), with white and with coloured
  (AR(1), pole 0.9) output noise: the order selected against the true one, the gain
  coverage at the true order and over all records, the order-bound warnings; and the 2x2
  plant with its order given at 600 and 6000 estimation samples (consistency: the gain
  error, its bias against its spread, the coverage).

    python benchmarks/uncertainty_coverage.py [--runs 200] [--identify-runs 200] [--jobs 2]
        [--skip-fixed] [--option NAME=JSON ...]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402
import scipy.signal  # noqa: E402

import moli  # noqa: E402
from generalization_cases import NOISE_POLE  # noqa: E402  (coloured noise as the benchmark's)
from moli.method.least_squares.sandwich import matrix_directions  # noqa: E402
from moli.method.least_squares.estimation import output_regressors  # noqa: E402
from moli.method.refinement.observer_form import observer_form  # noqa: E402

OMEGA = np.linspace(0.05, 3.0, 30)
STEPS = 40
Z95 = 1.959963984540054
FILTERS = {"tuned (0.45, 0.7)": (0.45, 0.7), "slow (0.2, 0.7)": (0.2, 0.7), "fast (1.0, 0.7)": (1.0, 0.7)}


def siso() -> moli.StateSpaceModel:
    pole = 0.8 * np.exp(0.4j)
    den = np.real(np.poly([pole, np.conj(pole)]))
    return moli.StateSpaceModel([[-den[1], -den[2]], [1.0, 0.0]], [[1.0], [0.0]], [[1.0, 0.5]])


def two_by_two() -> moli.StateSpaceModel:
    def rotation(z: complex) -> np.ndarray:
        return np.array([[z.real, z.imag], [-z.imag, z.real]])

    A = scipy.linalg.block_diag(rotation(0.8 * np.exp(0.4j)), rotation(0.6 * np.exp(1.2j)))
    B = np.array([[1.0, 0.3], [0.5, -0.4], [-0.2, 1.0], [0.7, 0.6]])
    C = np.array([[1.0, 0.0, 0.4, 0.2], [0.3, -0.5, 1.0, 0.0]])
    return moli.StateSpaceModel(A, B, C)


def gain(model: moli.StateSpaceModel, omega: np.ndarray) -> np.ndarray:
    z = np.exp(1j * omega * model.Ts)
    return np.abs(model.C @ np.linalg.solve(z[:, None, None] * np.eye(model.n) - model.A,
                                            model.B.astype(complex)) + model.D)


def steps(model: moli.StateSpaceModel) -> np.ndarray:
    return np.cumsum(model.markov(STEPS), axis=0)


def plain(model: moli.StateSpaceModel, data: moli.IOData) -> moli.StateSpaceModel:
    """The model with sigma^2 (Phi^T Phi)^-1 per output in place of the sandwich."""
    z = np.concatenate([data.y, data.u], axis=1)
    phis = output_regressors(z, model.indices, moli.divisors(model.alpha, model.indices))
    blocks = []
    for j, phi in enumerate(phis):
        target = data.y[max(model.indices):, j]
        theta, residual = np.linalg.lstsq(phi, target, rcond=None)[:2]
        r = np.linalg.qr(phi, mode="r")
        # Cov = s2 R^-1 R^-T = F^T F with F = sqrt(s2) R^-T
        blocks.append(np.sqrt(residual[0] / (phi.shape[0] - phi.shape[1]))
                      * scipy.linalg.solve_triangular(r, np.eye(r.shape[0]), trans="T"))
    factor = scipy.linalg.block_diag(*blocks)
    copy = moli.StateSpaceModel(model.A, model.B, model.C, model.D, model.Ts, indices=model.indices,
                                alpha=model.alpha, cov_factor=matrix_directions(
                                    model.indices, model.C, model.D, observer_form(model).D,
                                    np.zeros(model.p, bool), factor).T)
    return copy


def coverage(truth: moli.StateSpaceModel, N: int, noise: float, filt: tuple[float, float],
             indices: list[int], runs: int) -> dict[str, float]:
    """Coverage of each kind of band, and how the predicted spread of the gain compares with the actual one."""
    rng = np.random.default_rng(2024)
    alpha = moli.filter_polynomial(*filt, indices)
    true_gain, true_step = gain(truth, OMEGA), steps(truth)
    hits: dict[str, list[float]] = {"gauss": [], "plain": [], "monte carlo": [], "step": []}
    gains, spreads, plain_spreads = [], [], []
    for run in range(runs):
        u = rng.standard_normal((N, truth.m))
        data = moli.IOData(truth.simulate(u) + noise * rng.standard_normal((N, truth.p)), u)
        model = moli.estimate(data, indices, alpha)
        simple = plain(model, data)
        for name, bands in (
            ("gauss", model.magnitude_bands(OMEGA)),
            ("plain", simple.magnitude_bands(OMEGA)),
            ("monte carlo", model.magnitude_bands(OMEGA, method="monte_carlo", samples=400, seed=run)),
        ):
            hits[name].append(np.mean((bands[0] <= true_gain) & (true_gain <= bands[1])))
        lower, upper = model.step_bands(STEPS)
        hits["step"].append(np.mean(((lower <= true_step) & (true_step <= upper))[1:]))
        gains.append(gain(model, OMEGA))
        # the upper edge is never clipped: (upper - gain) / q is the predicted standard deviation
        spreads.append((model.magnitude_bands(OMEGA)[1] - gains[-1]) / Z95)
        plain_spreads.append((simple.magnitude_bands(OMEGA)[1] - gains[-1]) / Z95)
    actual = np.std(gains, axis=0)
    found = {name: float(np.mean(v)) for name, v in hits.items()}
    found["sd ratio"] = float(np.median(np.mean(spreads, axis=0) / actual))
    found["plain sd ratio"] = float(np.median(np.mean(plain_spreads, axis=0) / actual))
    found["bias"] = float(np.median(np.abs(np.mean(gains, axis=0) - true_gain) / actual))
    return found


def record(truth: moli.StateSpaceModel, N: int, noise: float, colour: str,
           rng: np.random.Generator) -> moli.IOData:
    """N samples of ``truth`` under a white input, with white or coloured output noise of
    standard deviation ``noise``."""
    u = rng.standard_normal((N, truth.m))
    e = rng.standard_normal((N, truth.p))
    if colour == "coloured":
        e = scipy.signal.lfilter([1.0], [1.0, -NOISE_POLE], e, axis=0) * np.sqrt(1 - NOISE_POLE**2)
    return moli.IOData(truth.simulate(u) + noise * e, u)


def identified(truth: moli.StateSpaceModel, N: int, noise: float, colour: str, seed: int,
               **options: object) -> dict[str, float]:
    """One record of 0.6 N estimation and 0.4 N validation samples through ``identify``:
    the selected order, whether the 95 % gain bands hold the true gain at each point, the
    gain error over the predicted standard deviation, and the relative gain error."""
    data = record(truth, N, noise, colour, np.random.default_rng([seed, N]))
    est, val = data.split(int(0.6 * N))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = moli.identify(est, val, **options).model
    true_gain, found = gain(truth, OMEGA), gain(model, OMEGA)
    out = {"order": model.n, "error": float(np.median(np.abs(found - true_gain) / true_gain)),
           "bound_warning": any(issubclass(w.category, moli.OrderBoundWarning) for w in caught)}
    if model.cov_factor is None:
        return {**out, "coverage": np.nan}
    lower, upper = model.magnitude_bands(OMEGA)
    sd = (upper - found) / Z95
    return {**out, "coverage": float(np.mean((lower <= true_gain) & (true_gain <= upper))),
            "signed": ((found - true_gain) / np.where(sd > 0, sd, np.nan)).ravel(),
            "found": found.ravel()}


def pipeline_rows(runs: int, jobs: int, options: dict[str, object]) -> list[str]:
    """The default identification on SISO, 2x2 and 3x3 plants, white and coloured noise."""
    from joblib import Parallel, delayed

    plants = (("SISO (n = 2)", siso(), 0.3), ("2x2 (n = 4)", two_by_two(), 0.3),
              ("3x3 example_plant (n = 6)", moli.example_plant(), 0.3))
    rows = []
    for label, truth, noise in plants:
        for colour in ("white", "coloured"):
            found = Parallel(n_jobs=jobs)(delayed(identified)(truth, 1000, noise, colour, seed, **options)
                                          for seed in range(runs))
            orders = np.array([f["order"] for f in found])
            cover = np.array([f["coverage"] for f in found])
            exact = orders == truth.n
            rows.append(f"| {label} | {colour} | {runs} | {np.mean(exact):.2f} | "
                        f"{np.mean(np.abs(orders - truth.n) <= 1):.2f} | {np.nanmean(cover[exact]):.3f} | "
                        f"{np.nanmean(cover):.3f} | {sum(f['bound_warning'] for f in found)} |")
    return rows


def consistency_rows(runs: int, jobs: int, options: dict[str, object]) -> list[str]:
    """The 2x2 plant with its order given: the gain error and bias at N = 1000 and 10,000
    (0.6 N estimation samples: 600 and 6000)."""
    from joblib import Parallel, delayed

    truth = two_by_two()
    rows = []
    for N in (1000, 10000):
        found = Parallel(n_jobs=jobs)(delayed(identified)(truth, N, 0.3, "white", seed, **{**options, "order": 4})
                                      for seed in range(runs))
        signed = np.array([f["signed"] for f in found if "signed" in f])
        gains = np.array([f["found"] for f in found if "found" in f])
        # the bias against the estimates' own spread across records, per point, median over points
        bias = np.median(np.abs(np.mean(gains, axis=0) - gain(truth, OMEGA).ravel()) / np.std(gains, axis=0))
        rows.append(f"| {int(0.6 * N)} | {len(found)} | {np.median([f['error'] for f in found]):.4f} | "
                    f"{bias:.2f} | {np.nanmean([f['coverage'] for f in found]):.3f} | "
                    f"{np.nanmedian(np.abs(signed)):.2f} |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=200, help="records per fixed-structure configuration")
    parser.add_argument("--identify-runs", type=int, default=200, help="records per identify configuration")
    parser.add_argument("--jobs", type=int, default=2, help="parallel workers of the identify rows")
    parser.add_argument("--skip-fixed", action="store_true", help="only the identify rows")
    parser.add_argument("--option", action="append", default=[], metavar="NAME=JSON",
                        help="an IdentifyOptions field for the identify rows, e.g. order_rule='\"paired\"'")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    print("| system | filter (wc, zeta) | gain: Newey-West | plain | Monte Carlo | step: Newey-West "
          "| sd predicted / actual: Newey-West | plain | bias / sd |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, truth, N, noise, indices in (() if args.skip_fixed else
                                            (("SISO, n = 2", siso(), 500, 0.3, [2]),
                                             ("2x2, n = 4", two_by_two(), 600, 0.3, [2, 2]))):
        for name, filt in FILTERS.items():
            started = time.perf_counter()
            f = coverage(truth, N, noise, filt, indices, args.runs)
            print(f"| {label} | {name} | {f['gauss']:.3f} | {f['plain']:.3f} | {f['monte carlo']:.3f} | "
                  f"{f['step']:.3f} | {f['sd ratio']:.2f} | {f['plain sd ratio']:.2f} | {f['bias']:.2f} |"
                  f"  ({time.perf_counter() - started:.0f} s)")
    print()
    print("| plant | output noise | records | true order | within one | gain coverage, true order "
          "| gain coverage, all | OrderBoundWarning |")
    print("|---|---|---|---|---|---|---|---|")
    options = {name: json.loads(value) for name, value in (o.split("=", 1) for o in args.option)}
    for row in pipeline_rows(args.identify_runs, args.jobs, options):
        print(row, flush=True)
    print()
    print("| estimation samples | records | median relative gain error | bias / sd | gain coverage "
          "| median abs(error) / predicted sd |")
    print("|---|---|---|---|---|---|")
    for row in consistency_rows(args.identify_runs, args.jobs, options):
        print(row, flush=True)


if __name__ == "__main__":
    main()
