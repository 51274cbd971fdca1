"""A built-in simulated plant: the example that needs no files."""

from __future__ import annotations

import numpy as np

from ..data.arguments import integer, real_number
from ..data.iodata import IOData
from ..models.statespace import StateSpaceModel

__all__ = ["example_plant", "example_data"]


def example_plant() -> StateSpaceModel:
    """A fixed stable 3-input, 3-output plant of order 6 (Ts = 1).

    Three lightly coupled channels: a slow first-order mode and an oscillatory pair
    feeding the first output, a second-order channel on the second, a first-order
    one on the third, with cross-couplings through the input matrix. Its
    observability indices are (2, 2, 2).

    Returns
    -------
    StateSpaceModel
    """
    # poles: 0.95, 0.8 +- 0.3j, 0.9, 0.7, 0.6 (discrete time)
    rng = np.random.default_rng(20151215)
    poles = np.diag([0.95, 0.9, 0.7, 0.6])
    rotation = np.array([[0.8, 0.3], [-0.3, 0.8]])
    modal = np.zeros((6, 6))
    modal[:4, :4] = poles
    modal[4:, 4:] = rotation
    T = np.eye(6) + 0.3 * rng.standard_normal((6, 6))
    A = T @ modal @ np.linalg.inv(T)
    B = rng.standard_normal((6, 3))
    C = rng.standard_normal((3, 6))
    return StateSpaceModel(A, B, C, output_names=("y1", "y2", "y3"), input_names=("u1", "u2", "u3"))


def example_data(N: int = 1000, noise: float = 0.1, seed: int = 0) -> IOData:
    """Simulated records of :func:`example_plant` with white output noise.

    Parameters
    ----------
    N : int, default 1000
        Number of samples.
    noise : float, default 0.1
        Standard deviation of the output noise relative to each output's standard
        deviation.
    seed : int, default 0
        Seed of the input and noise draws.

    Returns
    -------
    IOData
        Inputs: random binary signals (levels +-1, held 1 to 5 samples); outputs with noise.

    Examples
    --------
    >>> example_data(N=200)
    IOData(N=200, p=3, m=3, Ts=1, outputs=['y1', 'y2', 'y3'], inputs=['u1', 'u2', 'u3'])
    """
    N = integer("N", N, low=2)
    noise = real_number("noise", noise, low=0.0)
    rng = np.random.default_rng(integer("seed", seed, low=0))
    plant = example_plant()
    hold = rng.integers(1, 6, size=(N, 3))
    u = np.empty((N, 3))
    for ch in range(3):
        levels = np.repeat(rng.choice([-1.0, 1.0], size=N), hold[:, ch])[:N]
        u[:, ch] = levels
    y = plant.simulate(u)
    y += noise * y.std(axis=0) * rng.standard_normal(y.shape)
    return IOData(y, u, Ts=plant.Ts, output_names=plant.output_names, input_names=plant.input_names)
