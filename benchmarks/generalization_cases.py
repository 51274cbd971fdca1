"""Cases, peer sweeps and true-system scores for ``benchmarks/generalization.py``.

A :class:`Case` holds an estimation record E and a validation record V (its first
``V.N // 2`` samples are V1, the rest V2); synthetic cases also hold the true
``(A, B, C, D)``, a fresh input and its noise-free response. Every random draw comes
from ``numpy.random.default_rng([seed, case number, purpose])``.

nfoursid takes the SVD of its observability estimate with the full N x N right factor
and keeps only its leading ``n`` rows; here that SVD is the economy one (the same
leading singular vectors up to rounding and sign, so the same models), which avoids
800 MB and seconds per fit at N = 10,000.
"""

from __future__ import annotations

import single_thread  # noqa: F401  (before numpy: one BLAS thread)

import warnings  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from nfoursid.utils import Decomposition, Utils  # noqa: E402
from scipy import linalg, signal  # noqa: E402

import moli  # noqa: E402
import peers_lib as pl  # noqa: E402
from daisy_data import daisy_dir  # noqa: E402


def _economy_decomposition(matrix: np.ndarray) -> Decomposition:
    u, s, vh = np.linalg.svd(matrix, full_matrices=False)
    return Decomposition(u, np.diag(s), vh)


Utils.eigenvalue_decomposition = staticmethod(_economy_decomposition)

# every file of the DaISy folder but distill2 (DAISY_SKIPPED says why)
DAISY = ("ballbeam", "CD_player_arm", "cstr", "destill", "dryer", "dryer2", "evaporator",
         "exchanger", "flutter", "glassfurnace", "heating_system", "pHdata", "robot_arm",
         "thermic_res_wall")
# destill's four noise levels are one simulated experiment: counting all four would weigh
# one 90-sample record four times, so only the lowest noisy level (10 %) is used
DESTILL_NOISE = 10
DAISY_SKIPPED = {"distill2": "three step responses, not an input-output record (the inputs "
                             "are unit steps from sample 0): a half split would validate on a "
                             "constant input"}
BLOCK, WINDOWS = 500, 11
KINDS = ("generic", "lightly damped", "stiff", "near-integrator")
SNRS = (40.0, 20.0, 10.0, 3.0)
COLOURS = ("white", "coloured")
INPUTS = ("gaussian", "binary", "lowpass")
NOISE_POLE = 0.9  # coloured noise: white noise through 1 / (1 - 0.9 z^-1)
# peers_lib's settings without PARSIM-K (several times slower than the other SIPPY
# methods, and never the best one in docs/benchmarks.md)
PEERS = {k: f for k, f in pl.peer_fitters().items() if "PARSIM" not in k}


@dataclass
class Case:
    """One estimation/validation pair; synthetic cases also carry their truth."""

    name: str
    group: str  # "daisy", "evaporator" or "synthetic"
    est: moli.IOData
    val: moli.IOData
    meta: dict[str, Any] = field(default_factory=dict)
    truth: pl.ABCD | None = None
    fresh_u: np.ndarray | None = None
    fresh_y: np.ndarray | None = None  # noise-free true response to fresh_u, zero state


def nmax_rule(p: int, m: int, n_est: int) -> int:
    """moli's default ``max(10, p + 4)`` capped at ``N_E // (2 (p + m) + 4)``, at least p.

    The cap keeps the peers' ``f = 2n`` Hankel regressions (``2n (p + m)`` rows, about
    ``N_E - 4n`` columns) and moli's least-squares problems overdetermined.
    """
    return max(p, min(max(10, p + 4), n_est // (2 * (p + m) + 4)))


def load_record(name: str) -> moli.IOData:
    """A DaISy record read in place (destill at its 10 % noise level)."""
    noise = {"noise": DESTILL_NOISE} if name == "destill" else {}
    return moli.load_daisy(name, data_dir=daisy_dir(), **noise)


def daisy_cases(names: tuple[str, ...] = DAISY) -> list[Case]:
    """Each record split in halves: first estimates and second validates, then the reverse."""
    cases = []
    for name in names:
        first, second = load_record(name).split(0.5)
        cases.append(Case(f"{name}/fwd", "daisy", first, second))
        cases.append(Case(f"{name}/rev", "daisy", second, first))
    return cases


def evaporator_cases(windows: int = WINDOWS) -> list[Case]:
    """Window k: estimation samples k*500..k*500+499, validation the next 500."""
    data = load_record("evaporator")
    return [Case(f"evaporator/w{k}", "evaporator", data[k * BLOCK:(k + 1) * BLOCK],
                 data[(k + 1) * BLOCK:(k + 2) * BLOCK]) for k in range(windows)]


def _poles(kind: str, n: int, rng: np.random.Generator) -> list[tuple[float, float]]:
    """(radius, angle) of the real poles (angle 0) and of one pole of each complex pair."""
    pairs = int(rng.integers(1 if kind == "lightly damped" else 0, n // 2 + 1))
    if kind in ("near-integrator", "stiff"):  # room for the slow real pole, or two modes
        pairs = min(pairs, (n - 1) // 2 if kind == "near-integrator" else (n - 2) // 2)
    poles = []
    for k, oscillating in enumerate([False] * (n - 2 * pairs) + [True] * pairs):
        angle = float(rng.uniform(0.05, 0.6) * np.pi) if oscillating else 0.0
        if kind == "lightly damped" and angle:
            radius = rng.uniform(0.96, 0.995)
        elif kind == "stiff":  # alternately slow and fast modes
            radius = rng.uniform(0.97, 0.995) if k % 2 == 0 else rng.uniform(0.02, 0.3)
        elif kind == "near-integrator" and k == 0:
            radius = rng.uniform(0.995, 0.999)
        else:
            radius = rng.uniform(0.5, 0.95) if angle else rng.uniform(0.2, 0.95)
        poles.append((float(radius), angle))
    return poles


def random_system(kind: str, n: int, p: int, m: int, feedthrough: bool,
                  rng: np.random.Generator) -> pl.ABCD:
    """A stable ``(A, B, C, D)`` with the poles of ``kind``, in mixed coordinates.

    Each mode's input gain is scaled by ``sqrt(1 - r^2)`` so that every mode adds about
    the same output variance under white input; a random rotation mixes the states.
    """
    blocks, scale = [], []
    for radius, angle in _poles(kind, n, rng):
        c, s = np.cos(angle), np.sin(angle)
        block = radius * (np.array([[c, -s], [s, c]]) if angle else np.ones((1, 1)))
        blocks.append(block)
        scale += [np.sqrt(1 - radius ** 2)] * len(block)
    rotation, _ = np.linalg.qr(rng.standard_normal((n, n)))
    A = rotation @ linalg.block_diag(*blocks) @ rotation.T
    B = rotation @ (rng.standard_normal((n, m)) * np.array(scale)[:, None])
    C = rng.standard_normal((p, n)) @ rotation.T
    D = 0.5 * rng.standard_normal((p, m)) if feedthrough else np.zeros((p, m))
    return A, B, C, D


def make_input(kind: str, param: float, N: int, m: int, rng: np.random.Generator) -> np.ndarray:
    """White Gaussian, random binary held ``param`` samples, or first-order low-pass noise."""
    if kind == "binary":
        hold = int(param)
        return np.repeat(rng.choice([-1.0, 1.0], size=(-(-N // hold), m)), hold, axis=0)[:N]
    white = rng.standard_normal((N, m))
    if kind == "lowpass":
        return signal.lfilter([np.sqrt(1 - param ** 2)], [1.0, -param], white, axis=0)
    return white


def synthetic_case(seed: int, index: int) -> Case:
    """Synthetic case ``index``: N estimation samples, N validation samples.

    Pole kind, SNR and noise colour cycle with the index (kinds fastest, then the four
    SNRs, then the colour); every third case has a feedthrough (3 is prime to 4, so
    these spread evenly over kinds and SNRs). Order 1-12 (2-12 for lightly damped and
    stiff kinds), p and m 1-4, N log-uniform in 100..10,000 and the input kind are
    drawn. The SNR holds per output on the whole record.
    """
    rng = np.random.default_rng([seed, index, 0])
    kind = KINDS[index % len(KINDS)]
    snr = SNRS[(index // len(KINDS)) % len(SNRS)]
    colour = COLOURS[(index // (len(KINDS) * len(SNRS))) % len(COLOURS)]
    n = int(rng.integers(2 if kind in ("lightly damped", "stiff") else 1, 13))
    p, m = (int(v) for v in rng.integers(1, 5, size=2))
    N = int(round(10 ** rng.uniform(2, 4)))
    feedthrough = index % 3 == 0
    input_kind = INPUTS[int(rng.integers(len(INPUTS)))]
    param = (float(rng.integers(1, 6)) if input_kind == "binary"
             else float(rng.uniform(0.5, 0.9)) if input_kind == "lowpass" else 0.0)
    truth = random_system(kind, n, p, m, feedthrough, rng)
    u = make_input(input_kind, param, 2 * N, m, rng)
    y0 = moli.StateSpaceModel(*truth).simulate(u)
    noise = rng.standard_normal((2 * N, p))
    if colour == "coloured":
        noise = signal.lfilter([1.0], [1.0, -NOISE_POLE], noise, axis=0)
    noise *= y0.std(axis=0) / noise.std(axis=0) / 10 ** (snr / 20)
    data = moli.IOData(y0 + noise, u)
    fresh_rng = np.random.default_rng([seed, index, 1])
    fresh_u = make_input(input_kind, param, max(N, 1000), m, fresh_rng)
    meta = {"kind": kind, "snr_db": snr, "colour": colour, "n_true": n, "feedthrough": feedthrough,
            "input": input_kind, "input_param": param}
    return Case(f"synthetic/{index:03d}", "synthetic", data[:N], data[N:], meta, truth,
                fresh_u, moli.StateSpaceModel(*truth).simulate(fresh_u))


def mean_vaf(y: np.ndarray, yhat: np.ndarray) -> float:
    """Mean over outputs of the VAF (percent, clipped at 0; a diverged simulation scores 0)."""
    return float(np.mean(moli.vaf(y, yhat)))


def peer_sweep(fit: pl.Fitter, y_e: np.ndarray, u_e: np.ndarray, y_v: np.ndarray,
               u_v: np.ndarray, half: int, nmax: int) -> dict[str, Any]:
    """One peer setting at orders 1..nmax on centred data; the order best on V1 is chosen.

    Each model is simulated from the zero state over the whole of V; V1's VAF selects,
    V2's scores. A fit that returns nothing or raises is recorded as failed (None).
    """
    v1: list[float | None] = []
    v2: list[float | None] = []
    errors: list[str] = []
    best: tuple[float, int, pl.ABCD] | None = None
    for n in range(1, nmax + 1):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model = fit(y_e, u_e, n)
                yhat = None if model is None else moli.StateSpaceModel(*model).simulate(u_v)
        except (Exception, SystemExit) as exc:  # a peer's crash is a result, never a stop
            model, yhat = None, None
            errors.append(f"n={n}: {type(exc).__name__}: {exc}"[:200])
        if yhat is None:
            v1.append(None)
            v2.append(None)
            continue
        v1.append(mean_vaf(y_v[:half], yhat[:half]))
        v2.append(mean_vaf(y_v[half:], yhat[half:]))
        if best is None or v1[-1] > best[0]:
            best = (v1[-1], n, model)
    line: dict[str, Any] = {"v1_per_order": v1, "v2_per_order": v2, "errors": errors,
                            "failed": best is None}
    if best is not None:
        line.update(order=best[1], v1=best[0], v2=v2[best[1] - 1], model=best[2],
                    stable=bool(np.max(np.abs(np.linalg.eigvals(best[2][0])), initial=0) < 1))
    return line


def h2_norm(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray) -> float:
    """H2 norm of a discrete-time system, ``sqrt(||D||^2 + tr(C P C'))``; inf if unstable."""
    if A.size and np.max(np.abs(np.linalg.eigvals(A))) >= 1:
        return float("inf")
    gramian = linalg.solve_discrete_lyapunov(A, B @ B.T) if A.size else np.zeros((0, 0))
    return float(np.sqrt(max(np.trace(C @ gramian @ C.T) + np.sum(D ** 2), 0.0)))


def true_scores(case: Case, model: pl.ABCD) -> dict[str, float]:
    """VAF of the noise-free true response to the fresh input, and relative H2 error."""
    A, B, C, D = case.truth
    Ah, Bh, Ch, Dh = model
    error = (linalg.block_diag(A, Ah), np.vstack([B, Bh]), np.hstack([C, -Ch]), D - Dh)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = mean_vaf(case.fresh_y, moli.StateSpaceModel(*model).simulate(case.fresh_u))
    return {"true_fit": fit, "h2": h2_norm(*error) / h2_norm(*case.truth)}


# Frequencies of the band scores, rad per sample: from near the static gain to close to Nyquist.
BAND_OMEGA = np.linspace(0.05, 3.0, 30)
Z95 = 1.959963984540054


def band_scores(case: Case, model: moli.StateSpaceModel) -> dict[str, float]:
    """How the model's 95 % gain bands hold the true gain: the share of (frequency, channel)
    points inside, and the median over them of |gain error| / predicted standard deviation
    (NaN where the model carries no covariance)."""
    if model.cov_factor is None or not model.is_stable():
        return {"coverage": float("nan"), "bias_sd": float("nan")}
    omega = BAND_OMEGA / model.Ts
    truth = np.abs(moli.StateSpaceModel(*case.truth, Ts=model.Ts).frequency_response(omega))
    estimate = np.abs(model.frequency_response(omega))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lower, upper = model.magnitude_bands(omega)
    sd = (upper - estimate) / Z95          # the upper edge is never clipped
    ratio = np.abs(estimate - truth) / np.where(sd > 0, sd, np.nan)
    return {"coverage": float(np.mean((lower <= truth) & (truth <= upper))),
            "bias_sd": float(np.nanmedian(ratio)) if np.any(np.isfinite(ratio)) else float("nan")}


def truth_v2(case: Case, half: int) -> float:
    """The true system's own V2 VAF under the protocol (zero state over V1 and V2, noisy
    outputs scored on V2): the most a model can reach there, up to chance."""
    yhat = moli.StateSpaceModel(*case.truth).simulate(case.val.u)
    return mean_vaf(case.val.y[half:], yhat[half:])
