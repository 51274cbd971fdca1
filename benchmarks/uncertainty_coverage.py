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
  same two plants and on moli.example_data (3x3, order 6).

    python benchmarks/uncertainty_coverage.py [--runs 200]
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import argparse  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402

import moli  # noqa: E402
from moli.method.covariance import matrix_directions  # noqa: E402
from moli.method.estimation import output_regressors  # noqa: E402
from moli.method.observer_form import observer_form  # noqa: E402

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


def pipeline(truth: moli.StateSpaceModel, records: list[tuple[moli.IOData, moli.IOData]]) -> tuple[float, float]:
    """Gain coverage of identify's selected models, and the mean order selected."""
    true_gain = gain(truth, OMEGA)
    hits, orders = [], []
    for est, val in records:
        model = moli.identify(est, val).model
        lower, upper = model.magnitude_bands(OMEGA)
        hits.append(np.mean((lower <= true_gain) & (true_gain <= upper)))
        orders.append(model.n)
    return float(np.mean(hits)), float(np.mean(orders))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=200, help="records per configuration")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    print("| system | filter (wc, zeta) | gain: Newey-West | plain | Monte Carlo | step: Newey-West "
          "| sd predicted / actual: Newey-West | plain | bias / sd |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, truth, N, noise, indices in (("SISO, n = 2", siso(), 500, 0.3, [2]),
                                            ("2x2, n = 4", two_by_two(), 600, 0.3, [2, 2])):
        for name, filt in FILTERS.items():
            started = time.perf_counter()
            f = coverage(truth, N, noise, filt, indices, args.runs)
            print(f"| {label} | {name} | {f['gauss']:.3f} | {f['plain']:.3f} | {f['monte carlo']:.3f} | "
                  f"{f['step']:.3f} | {f['sd ratio']:.2f} | {f['plain sd ratio']:.2f} | {f['bias']:.2f} |"
                  f"  ({time.perf_counter() - started:.0f} s)")
    count = args.runs // 4
    for label, truth, N, noise in (("SISO plant above", siso(), 1000, 0.3), ("2x2 plant above", two_by_two(), 1000, 0.3)):
        rng = np.random.default_rng(7)
        records = []
        for _ in range(count):
            u = rng.standard_normal((N, truth.m))
            records.append(moli.IOData(truth.simulate(u) + noise * rng.standard_normal((N, truth.p)), u).split(600))
        share, order = pipeline(truth, records)
        print(f"identify, {label}, {count} records of 600 + 400: gain coverage {share:.3f}, mean order {order:.2f}")
    share, order = pipeline(moli.example_plant(),
                            [moli.example_data(N=1000, seed=s).split(600) for s in range(count)])
    print(f"identify, moli.example_data (3x3, n = 6), {count} records of 600 + 400: gain coverage {share:.3f}, "
          f"mean order {order:.2f}")

if __name__ == "__main__":
    main()
