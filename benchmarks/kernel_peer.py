"""moli's regularized impulse response beside the SISO kernel package on PyPI, ``impulseest``.

Each case is a random stable SISO plant of order 2-8 (real poles of radius 0.2-0.95 and either
sign, complex pairs of radius 0.5-0.95 and angle 0.05-0.6 pi), driven by white
Gaussian noise for 100-300 samples from rest, its output measured at an SNR of 10-20 dB (white
noise). Both estimators fit the same FIR regression: lags 0..n-1 (``impulseest`` always
estimates lag 0; moli with ``feedthrough=True``), n = ``LENGTH``, the record not centred (the
peer does not centre; moli with ``center=False``), the rows where every lag lies in the record.
The score is the relative error of the impulse response over those lags,
``||g_hat - g||^2 / ||g||^2``, and the cost the CPU time of the call (``time.process_time``,
one BLAS thread). Every random draw comes from ``numpy.random.default_rng([plant, seed])``.

    PYTHONPATH=src OPENBLAS_NUM_THREADS=1 python benchmarks/kernel_peer.py [plants] [seeds] [kernels]

(default 30 plants, 5 seeds each, kernels TC,DC; ``pip install impulseest``, in moli's
``bench`` extra).
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402
from scipy import signal  # noqa: E402

import moli  # noqa: E402

# Coefficients of every estimate: 0.95^50 = 0.08, so the slowest plants' responses are mostly inside.
LENGTH = 50


def random_plant(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The numerator and denominator of a stable strictly proper plant of order 2-8."""
    order = int(rng.integers(2, 9))
    pairs = int(rng.integers(0, order // 2 + 1))
    poles = list(rng.uniform(0.2, 0.95, order - 2 * pairs) * rng.choice([-1.0, 1.0], order - 2 * pairs))
    for _ in range(pairs):
        pole = rng.uniform(0.5, 0.95) * np.exp(1j * rng.uniform(0.05, 0.6) * np.pi)
        poles += [pole, np.conj(pole)]
    den = np.real(np.poly(poles))
    num = np.r_[0.0, rng.standard_normal(order)]          # no feedthrough: g(0) = 0
    return num, den


def truth(num: np.ndarray, den: np.ndarray, samples: int) -> np.ndarray:
    """The plant's impulse response at lags 0..samples-1."""
    impulse = np.zeros(samples)
    impulse[0] = 1.0
    return signal.lfilter(num, den, impulse)


def record(num: np.ndarray, den: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A white input of 100-300 samples and the plant's output at an SNR of 10-20 dB."""
    N = int(rng.integers(100, 301))
    u = rng.standard_normal(N)
    clean = signal.lfilter(num, den, u)
    snr_db = rng.uniform(10.0, 20.0)
    return u, clean + np.std(clean) * 10 ** (-snr_db / 20) * rng.standard_normal(N)


def fit_moli(u: np.ndarray, y: np.ndarray, kernel: str) -> np.ndarray:
    return moli.impulse_response(moli.IOData(y, u), kernel=kernel, length=LENGTH, feedthrough=True,
                                 center=False).coefficients[:, 0, 0]


def _peer_regressors(u: np.ndarray, n: int, N: int) -> np.ndarray:
    """``impulseest.creation.create_Phi``'s matrix, ``Phi[i, j] = u[n + j - i]``, built whole: the
    package's loop assigns a one-element array to each entry, which numpy 2 refuses."""
    return u[n + np.arange(N - n)[None, :] - np.arange(n)[:, None], 0]


def _peer_outputs(y: np.ndarray, n: int, N: int) -> np.ndarray:
    """``impulseest.creation.create_Y``'s column ``y[n:]``, for the same reason."""
    return y[n:N].reshape(-1, 1)


def fit_peer(u: np.ndarray, y: np.ndarray, kernel: str) -> np.ndarray:
    import impulseest  # noqa: F401  (the package's __init__ hides its module behind the function)

    peer = sys.modules["impulseest.impulseest"]
    # the package's own regressor builders fail under numpy 2; these build the same arrays, faster
    # than its loops would: the peer's time is, if anything, understated
    peer.create_Phi, peer.create_Y = _peer_regressors, _peer_outputs
    return np.asarray(peer.impulseest(u, y, n=LENGTH, RegularizationKernel=kernel)).ravel()


def timed(fit, *args) -> tuple[np.ndarray, float]:
    start = time.process_time()
    estimate = fit(*args)
    return estimate, time.process_time() - start


def main() -> None:
    plants = int(sys.argv[1]) if len(sys.argv) > 1 else 30
    seeds = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    kernels = sys.argv[3].split(",") if len(sys.argv) > 3 else ["TC", "DC"]
    warnings.simplefilter("ignore")            # the peer's optimizer warns on the records it fails
    fit_moli(*record(*random_plant(np.random.default_rng(0)), np.random.default_rng(0)), "TC")  # imports
    fit_peer(*record(*random_plant(np.random.default_rng(0)), np.random.default_rng(0)), "TC")
    results = {(who, kernel): ([], []) for kernel in kernels for who in ("moli", "impulseest")}
    for plant in range(plants):
        num, den = random_plant(np.random.default_rng([plant, 0]))
        g = truth(num, den, LENGTH)
        for seed in range(1, seeds + 1):
            u, y = record(num, den, np.random.default_rng([plant, seed]))
            for kernel in kernels:
                for who, fit in (("moli", fit_moli), ("impulseest", fit_peer)):
                    estimate, seconds = timed(fit, u, y, kernel)
                    errors, costs = results[who, kernel]
                    errors.append(float(np.sum((estimate - g) ** 2) / np.sum(g ** 2)))
                    costs.append(seconds)
    cases = plants * seeds
    print(f"{plants} plants x {seeds} seeds = {cases} records; FIR length {LENGTH}")
    print("| kernel | estimator | relative error: median | mean | 90th percentile | CPU s per fit: median | mean |"
          " moli's error lower on |")
    print("|---|---|---|---|---|---|---|---|")
    for kernel in kernels:
        ours = np.array(results["moli", kernel][0])
        theirs = np.array(results["impulseest", kernel][0])
        for who in ("moli", "impulseest"):
            errors, costs = map(np.array, results[who, kernel])
            wins = f"{np.mean(ours < theirs):.2f} of the records" if who == "moli" else ""
            print(f"| {kernel} | {who} | {np.median(errors):.4f} | {np.mean(errors):.4f} | "
                  f"{np.quantile(errors, 0.9):.4f} | {np.median(costs):.4f} | {np.mean(costs):.4f} | {wins} |")
        ratio = ours / theirs
        print(f"  {kernel}: moli / impulseest error ratio, median {np.median(ratio):.3f}, "
              f"quartiles {np.quantile(ratio, 0.25):.3f}-{np.quantile(ratio, 0.75):.3f}")


if __name__ == "__main__":
    main()
