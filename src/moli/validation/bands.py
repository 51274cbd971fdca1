"""Confidence bands of a model's simulated outputs on a record (docs/uncertainty.md §4)."""

from __future__ import annotations

import numpy as np

from ..data.iodata import IOData
from ..models.bands import output_bands
from ..models.protocol import LinearModel, check_model
from .prediction import deviations
from ..numerics.blas_threads import limited_blas

__all__ = ["simulation_bands"]


def simulation_bands(
    model: LinearModel, data: IOData, confidence: float = 0.95, *, method: str = "gauss",
    samples: int = 1000, seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Pointwise confidence bands of ``model``'s simulation on ``data``'s inputs.

    The simulation is the one :func:`moli.compare` scores with ``x0="zero"``; the
    bands carry the uncertainty of the model's matrices (``model.cov_factor``), not the
    noise on the measured outputs.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
        With a covariance (from :func:`moli.identify` or :func:`moli.estimate`). A
        continuous model is simulated on the record's own stamps (``data.time()``).
    data : IOData
        Raw or centred data; offsets are handled as :func:`moli.compare` does. Each
        segment is simulated from the zero state.
    confidence, method, samples, seed
        As in :meth:`StateSpaceModel.magnitude_bands`: probability of each pointwise
        interval, "gauss" or "monte_carlo" (which keeps ``samples x N x p`` outputs in
        memory), and the draws and their seed.

    Returns
    -------
    lower, upper : ndarray, shape (N, p)
        In the data's units (offsets added back).

    Raises
    ------
    OptionError
        An invalid ``confidence``, ``method``, ``samples`` or ``seed``.
    DataError
        ``data`` does not match the model, or the model carries no covariance.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(0)
    >>> truth = moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]])
    >>> u = rng.standard_normal(500)
    >>> data = moli.IOData(truth.simulate(u) + 0.1 * rng.standard_normal((500, 1)), u)
    >>> model = moli.estimate(data, [1], moli.filter_polynomial(1.0, 1.0, [1]))
    >>> lower, upper = simulation_bands(model, data)
    >>> inside = (lower <= truth.simulate(u)) & (truth.simulate(u) <= upper)
    >>> lower.shape, bool(inside.mean() > 0.8)
    ((500, 1), True)
    """
    with limited_blas():
        u, _ = deviations(check_model(model), data)
        t = data.time()
        # each segment simulated from the zero state, as moli.compare does
        runs = [output_bands(model, u[a:b], confidence, method=method, samples=samples, seed=seed, t=t[a:b])
                for a, b in data.bounds]
        lower, upper = (np.concatenate([run[i] for run in runs]) for i in (0, 1))
        shift = model.y_offset - data.y_offset
        return lower + shift, upper + shift
