"""Comparing a model with data: simulation (or k-step prediction) from a zero or an estimated initial state."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..data.display import console_text
from ..data.iodata import IOData
from ..data.stamps import irregular_steps
from ..errors import DataError
from .metrics import nrmse_fit, vaf
from ..models.protocol import LinearModel
# X0_CHOICES is read from here by the options and the command line
from .prediction import X0_CHOICES, checked_deviations, initial_state, predicted_deviations  # noqa: F401
from ..numerics.blas_threads import limited_blas

__all__ = ["Comparison", "estimate_initial_state", "compare", "same_period"]

# Relative difference of two sampling periods still taken as the same: room for a
# period written with fewer digits (0.1 against 0.1000000001), none for a real change.
TS_TOLERANCE = 1e-6


@dataclass(frozen=True, repr=False)
class Comparison:
    """Measured against simulated outputs of one model on one record.

    Attributes
    ----------
    yhat : ndarray, shape (N, p)
        Simulated (or k-step predicted) outputs in the data's units (offsets added back).
    vaf : ndarray, shape (p,)
        Variance accounted for per output, percent.
    fit : ndarray, shape (p,)
        NRMSE fit per output, percent.
    x0 : ndarray, shape (n,) or (segments, n)
        Initial state used; one row per segment when the record has several.
    horizon : int or None
        Prediction horizon ``k``; None for the simulation.
    output_names : tuple of str
        The record's output names, for the printed table.

    Its ``repr`` (what ``print`` and the interpreter show) is the table of scores per
    output, not the arrays.

    Examples
    --------
    >>> import moli
    >>> print(moli.Comparison(np.zeros((2, 1)), np.array([91.5]), np.array([70.25]), np.zeros(1)))
    simulation on 2 samples: VAF and NRMSE fit, percent
    output              VAF %    fit %
    y1                  91.50    70.25
    mean                91.50    70.25
    """

    yhat: np.ndarray
    vaf: np.ndarray
    fit: np.ndarray
    x0: np.ndarray
    horizon: int | None = None
    output_names: tuple[str, ...] = ()

    @property
    def mean_vaf(self) -> float:
        """Average VAF over the outputs, percent."""
        return float(np.mean(self.vaf))

    def __repr__(self) -> str:
        kind = "simulation" if self.horizon is None else f"{self.horizon}-step prediction"
        # names as a console shows them: a control character in a name cannot break a line
        names = tuple(map(console_text, self.output_names)) or tuple(f"y{i + 1}" for i in range(len(self.vaf)))
        width = max(16, *(len(name) + 2 for name in names))
        lines = [f"{kind} on {len(self.yhat)} samples: VAF and NRMSE fit, percent",
                 f"{'output':<{width}}{'VAF %':>9}{'fit %':>9}"]
        lines += [f"{name:<{width}}{v:>9.2f}{f:>9.2f}" for name, v, f in zip(names, self.vaf, self.fit)]
        lines.append(f"{'mean':<{width}}{self.mean_vaf:>9.2f}{float(np.mean(self.fit)):>9.2f}")
        return "\n".join(lines)


def estimate_initial_state(model: LinearModel, u: np.ndarray, y: np.ndarray, t: np.ndarray | None = None
                           ) -> np.ndarray:
    """Least-squares initial state of ``model`` for deviation data ``(u, y)``.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
    u : ndarray, shape (N, m)
    y : ndarray, shape (N, p)
    t : ndarray, shape (N,), optional
        The samples' stamps; needed by a continuous model.

    Returns
    -------
    ndarray, shape (n,)
    """
    return initial_state(model, u, y, None, t)


def same_period(a: float, b: float) -> bool:
    """True when two sampling periods agree to a relative 1e-6."""
    return math.isclose(a, b, rel_tol=TS_TOLERANCE)


def _sampled_form(model: LinearModel, data: IOData) -> LinearModel:
    """A continuous model with input delays as the sampled model that simulates it exactly on
    ``data``: held (or linear) inputs at evenly spaced samples, the delays whole samples. Its
    own simulation on time stamps cannot delay an input that is known only at them."""
    if data.times is not None and irregular_steps(data.times, data.segment_starts, data.Ts):
        raise DataError(f"the model has input delays {list(model.input_delays)}: it is scored on evenly sampled "
                        "records only (as its sampled form), and this record's time stamps step unevenly")
    return model.to_discrete(data.Ts, model.input_hold)  # type: ignore[attr-defined]


def compare(model: LinearModel, data: IOData, x0: str = "zero", horizon: int | None = None) -> Comparison:
    """Simulate ``model`` on ``data``'s inputs and score it against the outputs.

    With ``horizon=k`` the scored outputs are the k-step-ahead predictions instead
    (:func:`moli.predict`), like the System Identification Toolbox's ``compare``.
    A record of several segments is simulated segment by segment, each from its own
    initial state, and scored over all of them together.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
        A continuous model is simulated on the record's own stamps (``data.time()``,
        regular or not), its inputs held or linear between them as it was identified.
    data : IOData
        Raw or centred data; the model's operating point is used to move between
        the two (``data.u_offset``/``y_offset`` say what was already removed). Its
        ``Ts`` must be a sampled model's (relative tolerance 1e-6).
    x0 : {"zero", "estimate"}
        Start the simulation from the zero state, or from the least-squares
        initial state fitted to this record (uses the outputs: say so when reporting).
    horizon : int or None, default None
        None: simulation. ``k >= 1``: k-step-ahead prediction, which needs the
        model's noise model (``model.K``; a continuous model has none).

    Returns
    -------
    Comparison

    Raises
    ------
    DataError
        The record's channel counts or sampling period differ from the model's.

    Examples
    --------
    >>> import numpy as np, moli
    >>> m = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]])
    >>> u = np.random.default_rng(0).standard_normal(50)
    >>> data = moli.IOData(m.simulate(u), u)
    >>> float(compare(m, data).mean_vaf)
    100.0
    """
    with limited_blas():
        k, u, y = checked_deviations(model, data, x0, horizon)
        if model.is_continuous and any(model.input_delays):
            model = _sampled_form(model, data)
        if not model.is_continuous and not same_period(data.Ts, model.Ts):
            raise DataError(
                f"the record is sampled every Ts = {data.Ts:g}, the model every Ts = {model.Ts:g}; "
                "a discrete-time model only describes records of its own sampling period"
            )
        t = data.time()
        runs = [predicted_deviations(model, u[a:b], y[a:b], k, x0, t[a:b]) for a, b in data.bounds]
        ydev = np.concatenate([run[0] for run in runs])
        start = runs[0][1] if len(runs) == 1 else np.stack([run[1] for run in runs])
        return Comparison(
            yhat=ydev + model.y_offset - data.y_offset, vaf=vaf(y, ydev), fit=nrmse_fit(y, ydev), x0=start,
            horizon=k, output_names=tuple(data.output_names),
        )
