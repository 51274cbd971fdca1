"""The fleet benchmarks' records: seeded loop records, and one long record made chunk by chunk.

Shared by benchmarks/fleet.py and benchmarks/fleet_scaling.py; the chunks are made where
they are called (on a worker), from their position alone.
"""

import numpy as np

import moli
from moli.models.simulation import simulate_batch

INDICES = (2, 2)
ALPHA = moli.filter_polynomial(0.5, 0.7, INDICES)
# samples of the previous chunk's input that set a chunk's initial plant state: the
# plant forgets its state like 0.92^k, so 600 samples leave 1e-22 of it
WARM_UP = 600


def plant(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A seeded random stable 2x2 plant of order 4, spectral radius 0.9."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((4, 4))
    return A * 0.9 / np.max(np.abs(np.linalg.eigvals(A))), rng.standard_normal((4, 2)), rng.standard_normal((2, 4))


def loop_record(seed: int, N: int) -> moli.IOData:
    A, B, C = plant(seed)
    rng = np.random.default_rng([seed, 1])
    u = rng.standard_normal((N, 2))
    y = simulate_batch(A[None], B[None], C[None], u)[0]
    return moli.IOData(y + 0.05 * y.std(axis=0) * rng.standard_normal(y.shape), u)


# The long record's plant: output i is sum_j (b_ij / a_i) u_j, poles 0.9 +- 0.2j and
# 0.7 +- 0.3j; order 4, observability indices (2, 2). Filtered per channel, a chunk of
# 10^6 samples takes tens of milliseconds to make, so the benchmark times the reduction.
DENOMINATORS = [np.poly([0.9 + 0.2j, 0.9 - 0.2j]).real, np.poly([0.7 + 0.3j, 0.7 - 0.3j]).real]
NUMERATORS = [[[0.0, 1.0, -0.5], [0.0, 0.3, 0.2]], [[0.0, -0.4, 0.1], [0.0, 1.0, 0.3]]]


def chunk_input(k: int, length: int) -> np.ndarray:
    return np.random.default_rng([7, k]).standard_normal((length, 2))


def generated_chunk(k: int, length: int) -> tuple[np.ndarray, np.ndarray]:
    """Chunk k of the long record, made where it is called: its input, the plant's
    filter states after the previous chunk's last inputs, its outputs with noise."""
    from scipy.signal import lfilter

    u = chunk_input(k, length)
    previous = chunk_input(k - 1, length)[-WARM_UP:] if k else None
    y = np.zeros((length, 2))
    for i, a in enumerate(DENOMINATORS):
        for j, b in enumerate(NUMERATORS[i]):
            state = np.zeros(2) if previous is None else lfilter(b, a, previous[:, j], zi=np.zeros(2))[1]
            y[:, i] += lfilter(b, a, u[:, j], zi=state)[0]
    return y + 0.05 * np.random.default_rng([8, k]).standard_normal(y.shape), u
