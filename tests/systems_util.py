"""Random test systems with known structure."""

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
