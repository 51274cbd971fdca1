"""A seeded random 3x3 plant (6 states, indices (2, 2, 2)) simulated chunk by chunk."""

import numpy as np

from moli.models.simulation import simulate_batch


class StreamingPlant:
    """Generates a long record piece by piece, carrying the plant state between chunks."""

    def __init__(self, seed: int = 0, noise: float = 0.0) -> None:
        rng = np.random.default_rng(seed)
        A = rng.standard_normal((6, 6))
        self.A = A * 0.9 / np.max(np.abs(np.linalg.eigvals(A)))
        self.B, self.C = rng.standard_normal((6, 3)), rng.standard_normal((3, 6))
        self.noise = noise
        self.rng = np.random.default_rng(seed + 1)
        self.x = np.zeros(6)

    def chunk(self, N: int) -> tuple[np.ndarray, np.ndarray]:
        u = self.rng.standard_normal((N, 3))
        # outputs [C; I] x give the states too, so the last one can be carried on
        Cx = np.vstack([self.C, np.eye(6)])
        out = simulate_batch(self.A[None], self.B[None], Cx[None], u, self.x[None])[0]
        self.x = self.A @ out[-1, 3:] + self.B @ u[-1]
        return out[:, :3] + self.noise * self.rng.standard_normal((N, 3)), u
