"""Running a simulated plant under a given input and recording the data."""

from __future__ import annotations

from typing import Protocol, Sequence

import numpy as np

from ..data.arguments import real_array
from ..data.iodata import IOData
from ..errors import DataError
from ..models.statespace import StateSpaceModel

__all__ = ["SampledPlant", "experiment"]


class SampledPlant(Protocol):
    """What :func:`experiment` needs from a nonlinear simulated plant.

    ``reset(seed=...)`` puts it in its initial state, ``measure()`` returns the
    outputs at the current sample, ``step(u)`` holds ``u`` over one period.
    :class:`moli.systems.TwinRotor` is one.
    """

    Ts: float
    output_names: Sequence[str]
    input_names: Sequence[str]

    def reset(self, seed: int | None = None) -> None: ...

    def measure(self) -> np.ndarray: ...

    def step(self, u: np.ndarray) -> None: ...


def experiment(plant: SampledPlant | StateSpaceModel, u: object, seed: int | None = None) -> IOData:
    """Drive ``plant`` with the input sequence ``u`` and record its outputs.

    At sample ``k`` the outputs are measured first, then ``u[k]`` is applied, so
    ``y[k]`` depends on inputs up to ``u[k-1]`` only.

    Parameters
    ----------
    plant : SampledPlant or StateSpaceModel
        A sampled simulator (reset, measure, step), started from its own initial
        state; or a linear model, simulated from the zero state around its
        operating point (``y_offset``, ``u_offset``).
    u : array_like, shape (N, m)
        Inputs in absolute units, time along axis 0 (1-D when m = 1). The record
        stores them as commanded (a plant may saturate them internally).
    seed : int, optional
        Seed passed to ``plant.reset`` (measurement noise); the plant's own by default.

    Returns
    -------
    IOData
        Outputs and inputs with the plant's sampling period and channel names.

    Examples
    --------
    >>> from moli import StateSpaceModel
    >>> model = StateSpaceModel([[0.5]], [[1.0]], [[1.0]], Ts=0.1)
    >>> experiment(model, [1.0, 1.0, 1.0]).y.ravel()
    array([0. , 1. , 1.5])
    """
    if not isinstance(plant, StateSpaceModel) and not all(
            hasattr(plant, name) for name in ("input_names", "output_names", "reset", "measure", "step")):
        raise DataError(f"plant must be a StateSpaceModel or a SampledPlant, got {type(plant).__name__}")
    uu = real_array("u", u, finite=False)
    if uu.ndim == 1:
        uu = uu[:, None]
    m = len(plant.input_names)
    if uu.ndim != 2 or uu.shape[1] != m or uu.shape[0] < 1:
        raise DataError(f"u must have shape (N, {m}) with time along axis 0, got {np.shape(u)}")
    if not np.all(np.isfinite(uu)):
        raise DataError("u contains NaN or inf")
    if isinstance(plant, StateSpaceModel):
        y = plant.simulate(uu - plant.u_offset) + plant.y_offset
    else:
        plant.reset(seed=seed)
        y = np.empty((uu.shape[0], len(plant.output_names)))
        for k, uk in enumerate(uu):
            y[k] = plant.measure()
            plant.step(uk)
    return IOData(y, uu, plant.Ts, plant.output_names, plant.input_names)
