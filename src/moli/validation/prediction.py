"""k-step-ahead prediction with the model's Kalman predictor (docs/noise_model.md §3).

With a noise model (``model.K``), the one-step predictor is the innovations-form
Kalman predictor

    x̂[t+1] = (A - K C) x̂[t] + (B - K D) u[t] + K y[t],    ŷ[t|t-1] = C x̂[t] + D u[t],

and the k-step prediction runs it up to time ``t - k`` and then simulates ``k`` steps
with the inputs alone. Both state sequences come from one batched simulation each, so
every horizon costs O(N n^2), whatever ``k``.
"""

from __future__ import annotations

import numpy as np

from ..data.arguments import check_channel_order
from ..data.iodata import IOData
from ..errors import DataError, OptionError
from ..models.delays import shift_inputs
from ..models.simulation import free_response, simulate_batch
from ..models.protocol import LinearModel, check_model
from ..models.statespace import StateSpaceModel
from ..numerics.triangular import tall_factor
from ..numerics.blas_threads import limited_blas

__all__ = ["predict", "fit_free_response"]

# Rows of a free response below this share of its largest entry (a tenth of the state's
# own round-off) add nothing to an initial state's least squares.
NEGLIGIBLE_FREE_RESPONSE = 1e-17

X0_CHOICES = ("zero", "estimate")


def horizon_value(horizon: object) -> int | None:
    """``horizon`` as None (simulation) or an int >= 1; anything else is an error."""
    if horizon is None:
        return None
    if isinstance(horizon, bool) or not hasattr(horizon, "__index__") or int(horizon) < 1:  # type: ignore[call-overload]
        raise OptionError(f"horizon must be None (simulation) or an integer >= 1, got {horizon!r}")
    return int(horizon)  # type: ignore[call-overload]


def check_horizon(model: LinearModel, horizon: object) -> int | None:
    """``horizon`` as None (simulation) or an int >= 1 that the model can predict at."""
    if horizon_value(horizon) is not None and model.is_continuous:
        raise OptionError(
            f"horizon={horizon!r}: k-step prediction is defined for sampled models with a noise model; a "
            "continuous-time model has none (time='continuous' estimates no noise model): use horizon=None "
            "for its simulation, or predict with a sampled model (model.to_discrete(Ts) has no noise model "
            "either: identify one in discrete time)")
    if horizon_value(horizon) is not None and model.K is None:
        raise OptionError(
            f"horizon={horizon!r} needs a noise model, and this model has none (model.K is None); "
            "use horizon=None for simulation, or attach one with "
            "moli.estimate_noise_model(model, data) (identify does so by default)"
        )
    return horizon_value(horizon)


def deviations(model: LinearModel, data: IOData) -> tuple[np.ndarray, np.ndarray]:
    """``data``'s inputs and outputs as deviations from the model's operating point.

    The inputs are as recorded: the model's own methods apply its input delays.
    """
    if not isinstance(data, IOData):
        raise DataError(f"data must be an IOData, got {type(data).__name__}")
    if (data.p, data.m) != (model.p, model.m):
        raise DataError(
            f"model has {model.p} outputs and {model.m} inputs, data have {data.p} and {data.m}"
        )
    check_channel_order(model, data, "the model", "data")
    return data.u + data.u_offset - model.u_offset, data.y + data.y_offset - model.y_offset


def checked_deviations(
    model: LinearModel, data: IOData, x0: str, horizon: int | None
) -> tuple[int | None, np.ndarray, np.ndarray]:
    """The checked horizon and ``data`` as deviations (:func:`deviations`), after checking
    every argument of a simulation or prediction of ``model`` on ``data``."""
    if not isinstance(x0, str) or x0 not in X0_CHOICES:
        raise OptionError(f"x0 must be one of {X0_CHOICES}, got {x0!r}")
    k = check_horizon(check_model(model), horizon)
    u, y = deviations(model, data)
    return k, u, y


def _stamps(model: LinearModel, count: int, t: np.ndarray | None) -> np.ndarray:
    """A segment's stamps: ``t``, which a continuous model needs; a sampled model's sample numbers without it."""
    if t is None:
        if model.is_continuous:
            raise DataError("a continuous model is simulated on the record's time stamps: pass t")
        return np.arange(count)
    return t


def _delay_free(model: LinearModel, u: np.ndarray) -> tuple[LinearModel, np.ndarray]:
    """The model without its input delays, and the inputs shifted by them instead.

    The predictor's recursions use ``A`` and ``B`` directly, on inputs that already
    carry the dead times. A continuous model keeps its delays (its own simulation
    says it cannot simulate them).
    """
    if model.is_continuous or not any(model.input_delays):
        return model, u
    return model.with_input_delays(0), shift_inputs(u, model.input_delays)


def _states(A: np.ndarray, B: np.ndarray, signal: np.ndarray, x0: np.ndarray | None) -> np.ndarray:
    """States ``x[0..N-1]`` of ``x[t+1] = A x[t] + B signal[t]``, shape (N, n)."""
    n = A.shape[0]
    start = None if x0 is None else x0[None]
    return simulate_batch(A[None], B[None], np.eye(n)[None], signal, start)[0]


def _predicted(
    model: StateSpaceModel, u: np.ndarray, y: np.ndarray, k: int, x0: np.ndarray | None
) -> np.ndarray:
    """k-step predictions ``ŷ[t|t-k]`` (deviations), ``k >= 1``, from the initial state ``x0``.

    With ``s = t - k + 1``, ``ŷ[t|t-k] = C A^(k-1) x̂[s] + sum_{j=s}^{t-1} C A^(t-1-j) B u[j]
    + D u[t]``, and the input sum equals ``y_sim[t] - C A^(k-1) x_sim[s]`` for the
    simulation from the same initial state; samples with ``s <= 0`` see no outputs and
    are the simulation.
    """
    N = u.shape[0]
    A, B, C, D, K = model.A, model.B, model.C, model.D, model.K
    xsim = _states(A, B, u, x0)
    yhat = xsim @ C.T + u @ D.T
    if k > N - 1:
        return yhat
    F = A - K @ C
    xpred = _states(F, np.hstack([B - K @ D, K]), np.hstack([u, y]), x0)
    gain = C @ np.linalg.matrix_power(A, k - 1)
    yhat[k - 1 :] += (xpred[: N - k + 1] - xsim[: N - k + 1]) @ gain.T
    return yhat


def initial_state(model: LinearModel, u: np.ndarray, y: np.ndarray, horizon: int | None = None,
                  t: np.ndarray | None = None) -> np.ndarray:
    """Least-squares initial state for the k-step predictions (deviation data).

    The k-step prediction is affine in the initial state: ``C A^t x0`` while no output
    has been seen (all samples for ``horizon=None``), then ``C A^(k-1) F^(t-k+1) x0``
    with ``F = A - K C``. The state minimizes the sum of squared prediction errors.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
    u : ndarray, shape (N, m)
    y : ndarray, shape (N, p)
    horizon : int or None, default None
        None: the simulation's initial state (the only one of a continuous model).
    t : ndarray, shape (N,), optional
        The samples' stamps: needed by a continuous model (its free response ``C exp(A t)``).

    Returns
    -------
    ndarray, shape (n,)
    """
    model, u = _delay_free(model, u)
    N = y.shape[0]
    stamps = _stamps(model, N, t)
    if horizon is None or horizon > N - 1:
        forced = model.simulate_at(u, stamps)
        basis = model.free_response_at(stamps, NEGLIGIBLE_FREE_RESPONSE)
    else:
        forced = _predicted(model, u, y, horizon, None)
        gain = model.C @ np.linalg.matrix_power(model.A, horizon - 1)
        basis = free_response(model.A - model.K @ model.C, gain, N - horizon + 1)
        if horizon > 1:  # the samples before any output is seen
            basis = np.concatenate([free_response(model.A, model.C, horizon - 1), basis])
    return fit_free_response(basis, (y - forced)[: basis.shape[0]])


def fit_free_response(basis: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Least-squares ``x`` of ``basis x ~ target``: the initial state whose free response best
    fits ``target``.

    ``basis`` (N, p, n) is a free response (``C A^t e_a``), ``target`` (N, p) (the rows of a
    longer record after a free response cut where it decayed add nothing). Only the rows
    up to the last where the basis is above :data:`NEGLIGIBLE_FREE_RESPONSE` of its largest
    entry enter: later rows add nothing to the solution but round-off (and a stable model's
    response has decayed there to subnormal numbers, on which arithmetic is many times
    slower). The problem is reduced to its triangular factor, and lstsq's rank cut-off
    applies to the same singular values.
    """
    n = basis.shape[2]
    size = np.max(np.abs(basis), axis=(1, 2))
    above = np.flatnonzero(size > NEGLIGIBLE_FREE_RESPONSE * np.max(size, initial=0.0))
    rows = int(above[-1]) + 1 if above.size else 0
    if rows == 0 or not np.all(np.isfinite(size)):
        return np.linalg.lstsq(basis.reshape(-1, n), target.reshape(-1), rcond=None)[0]
    factor = tall_factor(np.column_stack([basis[:rows].reshape(-1, n), target[:rows].reshape(-1)]))
    return np.linalg.lstsq(factor[:n, :n], factor[:n, n], rcond=None)[0]


def predicted_deviations(
    model: LinearModel, u: np.ndarray, y: np.ndarray, horizon: int | None, x0: str, t: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Predictions (or the simulation) on deviation data, and the initial state used.

    ``horizon`` and ``x0`` must already be checked (:func:`check_horizon`, :data:`X0_CHOICES`);
    ``t``, the segment's stamps, is needed by a continuous model.
    """
    model, u = _delay_free(model, u)
    start = initial_state(model, u, y, horizon, t) if x0 == "estimate" else np.zeros(model.n)
    if horizon is None:
        return model.simulate_at(u, _stamps(model, u.shape[0], t), start), start
    return _predicted(model, u, y, horizon, start), start


def predict(
    model: LinearModel, data: IOData, horizon: int | None = None, x0: str = "estimate"
) -> np.ndarray:
    """k-step-ahead predicted outputs of ``model`` on ``data``.

    ``ŷ[t|t-k]`` uses the outputs up to ``t - k`` and the inputs up to ``t``: the
    model's Kalman predictor (gain ``model.K``) runs to time ``t - k`` and the model
    then simulates ``k`` steps. Samples ``t < k`` see no output and are the simulation.

    Parameters
    ----------
    model : StateSpaceModel or ContinuousModel
        With a noise model (``model.K`` not None) for ``horizon >= 1``; a continuous model
        has none, so only its simulation (``horizon=None``) is defined.
    data : IOData
        Raw or centred data; offsets are handled as :func:`moli.compare` does. Each
        segment is predicted from its own initial state.
    horizon : int or None, default None
        ``k >= 1``; None: pure simulation (no outputs used, as :func:`moli.compare`).
    x0 : {"estimate", "zero"}, default "estimate"
        Initial state: the least-squares one for this horizon's prediction errors on
        ``data`` (uses the outputs), or zero.

    Returns
    -------
    ndarray, shape (N, p)
        Predicted outputs in the data's units (offsets added back).

    Raises
    ------
    OptionError
        ``horizon`` not None or an integer >= 1, ``horizon >= 1`` for a model without a
        noise model (``model.K is None``, every continuous model), or ``x0`` not one of the choices.
    DataError
        ``data`` not an :class:`IOData` with the model's channels.

    Examples
    --------
    >>> import numpy as np, moli
    >>> m = moli.StateSpaceModel([[0.9]], [[1.0]], [[1.0]], K=[[0.5]], noise_cov=[[0.01]])
    >>> rng = np.random.default_rng(0)
    >>> u, e = rng.standard_normal(400), 0.1 * rng.standard_normal(400)
    >>> y = moli.StateSpaceModel([[0.9]], [[1.0, 0.5]], [[1.0]], D=[[0.0, 1.0]]).simulate(np.column_stack([u, e]))
    >>> data = moli.IOData(y, u)
    >>> one_step = moli.predict(m, data, horizon=1)
    >>> bool(np.std(y[:, 0] - one_step[:, 0]) < np.std(y[:, 0] - moli.predict(m, data)[:, 0]))
    True
    """
    with limited_blas():
        k, u, y = checked_deviations(model, data, x0, horizon)
        t = data.time()
        # each segment from its own initial state: the predictor does not run across a gap
        ydev = np.concatenate([predicted_deviations(model, u[a:b], y[a:b], k, x0, t[a:b])[0] for a, b in data.bounds])
        return ydev + model.y_offset - data.y_offset
