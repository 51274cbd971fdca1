"""Test systems with known truth: random systems of known structure, a plant under PI loops."""

from __future__ import annotations

import numpy as np

import moli


def random_system(n: int, p: int, m: int, rng: np.random.Generator) -> moli.StateSpaceModel:
    """A random stable system with spectral radius 0.9 (generic observability indices)."""
    A = rng.standard_normal((n, n))
    A *= 0.9 / np.max(np.abs(np.linalg.eigvals(A)))
    return moli.StateSpaceModel(A, rng.standard_normal((n, m)), rng.standard_normal((p, n)))


def generic_indices(n: int, p: int) -> tuple[int, ...]:
    """ceil(n/p) for the first n mod p outputs, floor(n/p) for the rest (docs/method.md §4)."""
    return tuple(n // p + (1 if j < n % p else 0) for j in range(p))


def plant_record(N: int, noise: float, seed: int) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """A random stable 6-state 3x3 plant (generic indices (2, 2, 2)) driven by white noise.

    Returns ``(y, u, (A, B, C))`` with white output noise of standard deviation ``noise``.
    """
    rng = np.random.default_rng(seed)
    plant = random_system(6, 3, 3, rng)
    u = rng.standard_normal((N, 3))
    y = plant.simulate(u)
    return y + noise * rng.standard_normal(y.shape), u, (plant.A, plant.B, plant.C)


def kalman_gain(A: np.ndarray, C: np.ndarray, Q: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Steady-state Kalman gain and innovation covariance for process noise Q, measurement noise R.

    The gain of a Kalman filter makes ``A - K C`` stable, so ``(A, K, C)`` is a valid
    innovations form with a known innovation covariance.
    """
    from scipy.linalg import solve_discrete_are

    P = solve_discrete_are(A.T, C.T, Q, R)
    S = C @ P @ C.T + R
    return np.linalg.solve(S, C @ P @ A.T).T, S


def innovations_record(
    model: moli.StateSpaceModel, K: np.ndarray, cov: np.ndarray, N: int, rng: np.random.Generator
) -> moli.IOData:
    """Outputs of the innovations form ``x+ = A x + B u + K e, y = C x + D u + e``.

    White Gaussian inputs of unit variance; innovations ``e`` of covariance ``cov``.
    """
    u = rng.standard_normal((N, model.m))
    e = rng.standard_normal((N, model.p)) @ np.linalg.cholesky(cov).T
    full = moli.StateSpaceModel(model.A, np.hstack([model.B, K]), model.C,
                                np.hstack([model.D, np.eye(model.p)]))
    return moli.IOData(full.simulate(np.hstack([u, e])), u)


def resonant_noise_system() -> tuple[moli.StateSpaceModel, np.ndarray, np.ndarray]:
    """A 3-state, 2-output, 1-input system whose noise is dominated by a resonance.

    A lightly damped pair (modulus 0.95) that the input barely drives but the process
    noise does, and a real mode at 0.8 that carries the input: the noise is strongly
    coloured, and a model with fewer states cannot describe it. Returns the
    deterministic model, the Kalman gain and the innovation covariance.
    """
    radius, angle = 0.95, 0.6
    A = np.array([[radius * np.cos(angle), radius * np.sin(angle), 0.0],
                  [-radius * np.sin(angle), radius * np.cos(angle), 0.0],
                  [0.0, 0.0, 0.8]])
    B = np.array([[0.3], [0.0], [1.0]])
    C = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, -0.5]])
    K, cov = kalman_gain(A, C, np.diag([0.2, 0.2, 0.01]), 0.05 * np.eye(2))
    return moli.StateSpaceModel(A, B, C), K, cov


# The closed-loop plant (moli.systems.pi_loop_plant): two first-order channels, poles 0.9 and
# 0.85, with coupling, y = x + v; here under PI loops of its own (kp 1, ki 0.15) and noise 0.3.
PI_LOOP_A, PI_LOOP_B = moli.systems.pi_loop_plant().A, moli.systems.pi_loop_plant().B
PI_LOOP_GAIN = np.linalg.solve(np.eye(2) - PI_LOOP_A, PI_LOOP_B)


def pi_loop(seed: int, N: int = 3000, colour: float = 0.9, sd: float = 0.3) -> moli.IOData:
    """Two PI loops (kp 1, ki 0.15) on the plant, tracking random set-point steps held 30-150
    samples, output noise AR(1) with pole ``colour``; inputs u1, u2 and the references r1, r2."""
    rng = np.random.default_rng(seed)
    r = np.zeros((N, 2))
    for c in range(2):
        k = 0
        while k < N:
            hold = int(rng.integers(30, 151))
            r[k : k + hold, c] = rng.uniform(-1, 1)
            k += hold
    w = rng.standard_normal((N, 2))
    v = np.zeros((N, 2))
    for k in range(N):
        v[k] = colour * v[k - 1] + w[k] if k else w[k]
    v *= sd / v.std(axis=0)
    x, integral = np.zeros(2), np.zeros(2)
    y, u = np.zeros((N, 2)), np.zeros((N, 2))
    for k in range(N):
        y[k] = x + v[k]
        error = r[k] - y[k]
        integral += error
        u[k] = error + 0.15 * integral
        x = PI_LOOP_A @ x + PI_LOOP_B @ u[k]
    return moli.IOData(y, np.hstack([u, r]), input_names=["u1", "u2", "r1", "r2"])


# A 2x2 plant of four real modes in modal form (poles 0.97, 0.9, 0.8, 0.6, unit-order DC gains),
# for the residual tests on records that start away from rest.
STARTED_POLES = np.array([0.97, 0.9, 0.8, 0.6])
STARTED_B = np.array([[1.0, 0.5], [-0.6, 1.0], [0.8, 0.7], [0.5, -1.0]]) * (1.0 - STARTED_POLES)[:, None] * 3.0
STARTED_C = np.array([[1.0, 0.6, -0.8, 0.5], [0.4, -1.0, 0.7, 1.0]])


def started_models() -> dict[str, moli.StateSpaceModel]:
    """The plant, a model whose poles match its own to 3 decimals (each 1e-4 higher), and a model
    without its 0.8 mode (the other three modes exact)."""
    keep = [0, 1, 3]
    return {
        "true plant": moli.StateSpaceModel(np.diag(STARTED_POLES), STARTED_B, STARTED_C),
        "poles to 3 decimals": moli.StateSpaceModel(np.diag(STARTED_POLES + 1e-4), STARTED_B, STARTED_C),
        "missing mode": moli.StateSpaceModel(np.diag(STARTED_POLES[keep]), STARTED_B[keep], STARTED_C[:, keep]),
    }


def started_record(seed: int, N: int = 1000, noise: float = 0.05, start: float = 30.0) -> moli.IOData:
    """The plant of :func:`started_models` driven by input steps (standard normal levels held
    50 samples), starting at rest under an earlier input of standard deviation ``start`` (its
    outputs tens of units, hundreds of noise levels, from where the steps keep them), with white
    output noise of standard deviation ``noise``."""
    rng = np.random.default_rng(seed)
    plant = started_models()["true plant"]
    u = np.repeat(rng.standard_normal((-(-N // 50), 2)), 50, axis=0)[:N]
    x0 = np.linalg.solve(np.eye(4) - plant.A, plant.B @ (start * rng.standard_normal(2)))
    return moli.IOData(plant.simulate(u, x0) + noise * rng.standard_normal((N, 2)), u)
