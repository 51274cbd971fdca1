"""The noise model of an identified model: Kalman gain ``K`` and innovation covariance.

The deterministic part ``(A, B, C, D)`` is kept. Its simulation error ``e = y - y_sim``
is modelled as the output of the innovations form with the same ``(A, C)``,

    s[t+1] = A s[t] + K ε[t],    e[t] = C s[t] + ε[t],    ε white,

(docs/noise_model.md §2). A long AR model of ``e`` gives estimates ``ε̂`` of the
innovations; with them ``e - ε̂`` is linear in ``K``, and one least-squares problem
gives a first ``K``. Gauss-Newton steps on the one-step prediction errors then take it
to the prediction-error (maximum-likelihood) estimate. The predictor ``A - K C`` must
be stable: when the first ``K`` leaves it unstable, it is replaced by the stabilizing
Kalman gain of the same noise spectrum (a discrete Riccati equation), and failing that
by ``K = 0``; the steps keep it stable.
"""

from __future__ import annotations

import copy

import numpy as np
import scipy.linalg

from ...data.iodata import IOData, longest_segment
from ...errors import DataError
from ...models.simulation import free_response, simulate_batch, state_responses
from ...models.statespace import StateSpaceModel
from ...validation.prediction import deviations, predicted_deviations
from ...validation.whitening import fit_ar
from ...numerics.triangular import column_norms, tall_factor
from ...validation.prediction import NEGLIGIBLE_FREE_RESPONSE, fit_free_response
from ...numerics.blas_threads import limited_blas

__all__ = ["estimate_noise_model"]

# Longest AR model of the simulation error. The AR innovations only start the
# prediction-error steps, which converge from them in 2-3 steps whether 10, 20 or 40
# lags are allowed (K, predictions and step counts alike on random 5-state systems);
# the QR factor of the AR fit, the largest single cost, grows with the square of it.
MAX_AR_ORDER = 20
# Least-squares rows per unknown of each channel's AR equation (order h: h p unknowns,
# N - h rows, with one lag to spare), which bounds the order on short records.
ROWS_PER_PARAMETER = 10
# Prediction-error (Gauss-Newton) steps after the two-stage estimate, the halvings of
# a step that does not lower the criterion, and the decrease of log det(Σ) under which
# the steps stop. 1e-3 (0.1 % of the innovation volume) gave the same K accuracy and
# test rejection rates as 1e-4 in the checks of docs/noise_model.md §5, a third faster.
PEM_STEPS = 10
STEP_HALVINGS = 8
PEM_TOLERANCE = 1e-3


def _spectral_radius(matrix: np.ndarray) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(matrix)), initial=0.0))


def _gain_regression(F: np.ndarray, C: np.ndarray, target: np.ndarray, eps: np.ndarray) -> np.ndarray:
    """Least-squares ``K`` in ``target[t] = C s[t] + v[t]``, ``s[t+1] = F s[t] + K ε[t]``.

    ``s[0]`` is unknown too. ``C s[t]`` is ``sum_ij K_ij g_ij[t] + C F^t s[0]``, where
    ``g_ij`` is the output of ``(F, e_i, C)`` driven by ``ε_j``: the columns are the state
    responses of each ``ε_j`` (:func:`moli.models.simulation.state_responses`) and the free responses. Rows are weighted by the inverse
    Cholesky factor ``L^-1`` of the covariance of ``ε``, so that every output counts by
    its noise level; the weight enters through ``L^-1 C``, so the columns are built
    weighted.
    """
    N, p = target.shape
    n = F.shape[0]
    try:
        factor = np.linalg.cholesky(eps.T @ eps / N)
        C = scipy.linalg.solve_triangular(factor, C, lower=True)
        target = scipy.linalg.solve_triangular(factor, target.T, lower=True).T
    except np.linalg.LinAlgError:
        pass  # innovations of rank < p (a noise-free output): unweighted rows
    # [columns | target] filled in place: the record-long matrix is held once, stored
    # column by column (the column norms then sum each contiguous column)
    design = np.empty((N * p, n * p + n + 1), order="F")
    rows = design.reshape(N, p, -1)                # a view: sample, output, column
    # column i p + j: the response to ε_j injected into state i (B = e_i e_j^T), every state's at once
    for j, through_states in state_responses(F, C, eps):
        rows[:, :, j : n * p : p] = through_states
    rows[:, :, n * p : n * p + n] = free_response(F, C, N)
    rows[:, :, -1] = target
    norms = column_norms(design)
    norms[norms == 0.0] = 1.0
    design /= norms
    # only the triangular factor of [columns | target]: the small system it leaves has
    # the least-squares solution (lstsq: rank deficiency is possible, e.g. a state that
    # no innovation reaches)
    R = tall_factor(design)
    solution = np.linalg.lstsq(R[:-1, :-1], R[:-1, -1], rcond=None)[0]
    return (solution * norms[-1] / norms[:-1])[: n * p].reshape(n, p)


def _innovations(A: np.ndarray, C: np.ndarray, K: np.ndarray, e: np.ndarray) -> np.ndarray:
    """One-step prediction errors of ``e`` under the noise model: ``ε = e - C s``, ``s⁺ = (A - K C) s + K e``."""
    return e - simulate_batch((A - K @ C)[None], K[None], C[None], e)[0]


def _log_det_cov(eps: np.ndarray) -> float:
    sign, value = np.linalg.slogdet(eps.T @ eps / eps.shape[0])
    return value if sign > 0 else -np.inf


def _significant(A: np.ndarray, C: np.ndarray, K: np.ndarray, e: np.ndarray) -> bool:
    """Whether the gain ``K`` explains the simulation error ``e`` better than white noise does.

    The likelihood-ratio test of ``K = 0``: with ``K = 0`` the innovations are the
    simulation error itself, less the free response of its best initial state (the
    transient of an unknown start, which a gain would otherwise be fitted to absorb).
    ``N (log det Σ_0 - log det Σ_K)`` is chi-squared with ``n p`` degrees of freedom
    when the error is white; a gain that lowers it by less than the 95 % point is noise
    fitted to noise, and on fresh data it makes the one-step errors coloured.
    """
    import scipy.special  # only when a gain is tested

    N = e.shape[0]
    free = free_response(A, C, N, NEGLIGIBLE_FREE_RESPONSE)     # cut where it has decayed
    white = e.copy()
    white[: free.shape[0]] -= free @ fit_free_response(free, e[: free.shape[0]])
    statistic = N * (_log_det_cov(white) - _log_det_cov(_innovations(A, C, K, e)))
    # the chi-squared 95 % point (scipy.stats.chi2.ppf's formula; scipy.stats is slow to import)
    return bool(statistic > 2.0 * scipy.special.gammaincinv(K.size / 2, 0.95))


def _prediction_error_steps(A: np.ndarray, C: np.ndarray, K: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, int]:
    """Gauss-Newton steps on ``K`` that lower ``log det`` of the innovation covariance.

    The derivative of ``ε`` with respect to ``K_ij`` is minus the output of
    ``(A - K C, e_i, C)`` driven by ``ε_j``: a step is :func:`_gain_regression` of ``ε``
    on the predictor's own dynamics. Steps are halved until the predictor stays stable
    and the criterion drops.
    """
    eps = _innovations(A, C, K, e)
    cost = _log_det_cov(eps)
    taken = 0
    for _ in range(PEM_STEPS):
        step = _gain_regression(A - K @ C, C, eps, eps)
        for _ in range(STEP_HALVINGS):
            trial = K + step
            if _spectral_radius(A - trial @ C) < 1.0:
                trial_eps = _innovations(A, C, trial, e)
                trial_cost = _log_det_cov(trial_eps)
                if trial_cost < cost:
                    break
            step = 0.5 * step
        else:
            break
        decrease = cost - trial_cost
        K, eps, cost, taken = trial, trial_eps, trial_cost, taken + 1
        if decrease < PEM_TOLERANCE:
            break
    return K, taken


def _stabilizing_gain(A: np.ndarray, C: np.ndarray, K: np.ndarray, cov: np.ndarray) -> np.ndarray | None:
    """The Kalman gain of the noise spectrum of ``(A, K, C, I, cov)``, or None.

    The innovations form with a non-minimum-phase noise model (``A - K C`` unstable)
    has the spectrum of a state-space model with process noise ``K ε`` and measurement
    noise ``ε``. Its steady-state Kalman filter is the stabilizing solution of the
    filter Riccati equation, with the same spectrum and a stable predictor.
    """
    Q, S = K @ cov @ K.T, K @ cov
    try:
        P = scipy.linalg.solve_discrete_are(A.T, C.T, Q, cov, s=S)
    except (np.linalg.LinAlgError, ValueError):
        return None
    innovation = C @ P @ C.T + cov
    gain = np.linalg.lstsq(innovation, (A @ P @ C.T + S).T, rcond=None)[0].T
    return gain if np.all(np.isfinite(gain)) and _spectral_radius(A - gain @ C) < 1.0 else None


def estimate_noise_model(model: StateSpaceModel, data: IOData) -> StateSpaceModel:
    """A copy of ``model`` with a noise model estimated from its residuals on ``data``.

    The deterministic part ``(A, B, C, D)`` is kept; the copy gets the Kalman gain
    ``K`` (n, p) of the innovations form and the innovation covariance ``noise_cov``
    (p, p): the mean square of the one-step prediction errors on ``data`` (initial
    state fitted). ``info["noise_model"]`` records the method used (docs/noise_model.md).

    Parameters
    ----------
    model : StateSpaceModel
        Stable (its simulation error is what the noise model describes).
    data : IOData
        Record to estimate on, raw or centred (offsets handled as :func:`moli.compare`),
        with at least ``20 p + 1`` samples. Of a record of several segments, the
        longest one is used (``info["noise_model"]["segment"]`` says which).

    Returns
    -------
    StateSpaceModel
        A new model; ``model`` is not modified.

    Raises
    ------
    DataError
        ``model`` is not a stable :class:`StateSpaceModel`, ``data`` does not match it
        or is too short.

    Examples
    --------
    >>> import numpy as np, moli
    >>> rng = np.random.default_rng(1)
    >>> u, e = rng.standard_normal(3000), 0.3 * rng.standard_normal(3000)
    >>> truth = moli.StateSpaceModel([[0.9]], [[1.0, 0.6]], [[1.0]], D=[[0.0, 1.0]])
    >>> data = moli.IOData(truth.simulate(np.column_stack([u, e])), u)
    >>> noisy = estimate_noise_model(moli.StateSpaceModel([[0.9]], [[1.0]], [[1.0]]), data)
    >>> np.round(noisy.K, 1), np.round(np.sqrt(noisy.noise_cov), 1)
    (array([[0.6]]), array([[0.3]]))
    """
    with limited_blas():
        if not isinstance(model, StateSpaceModel):
            raise DataError(f"model must be a StateSpaceModel, got {type(model).__name__}")
        if not model.is_stable():
            raise DataError("the noise model needs a stable model: its simulation error grows without bound")
        whole = data
        # the AR fit and the innovations run through time: one continuous stretch, the longest
        data = longest_segment(data) if isinstance(data, IOData) else data
        u, y = deviations(model, data)
        N, p = y.shape
        order = min(MAX_AR_ORDER, (N - ROWS_PER_PARAMETER * p) // (ROWS_PER_PARAMETER * p + 1))
        if order < 1:  # N < 2 ROWS_PER_PARAMETER p + 1
            raise DataError(f"data must have at least {2 * ROWS_PER_PARAMETER * p + 1} samples to "
                            f"estimate a noise model, got {N}")
        e = y - model.simulate(u)
        ar = fit_ar(e, order)
        # the AR residuals start at sample ``ar.start``; the regression's free state absorbs
        # everything before it
        K = _gain_regression(model.A, model.C, e[ar.start :] - ar.residuals, ar.residuals)
        start = "regression"
        if _spectral_radius(model.A - K @ model.C) >= 1.0:
            cov = ar.residuals.T @ ar.residuals / ar.residuals.shape[0]
            stable = _stabilizing_gain(model.A, model.C, K, cov)
            K, start = (stable, "spectral factor") if stable is not None else (np.zeros_like(K), "output error")
        K, steps = _prediction_error_steps(model.A, model.C, K, e)
        if not _significant(model.A, model.C, K, e):
            K, start = np.zeros_like(K), "white simulation error"
        attached = copy.deepcopy(model)  # keeps every field of the model, whatever it holds
        attached.K = K
        yhat, _ = predicted_deviations(attached, u, y, 1, "estimate")
        errors = y - yhat
        cov = errors.T @ errors / N
        attached.noise_cov = 0.5 * (cov + cov.T)  # symmetric to the last bit
        attached.info["noise_model"] = {
            "method": "prediction error", "start": start, "ar_order": ar.order, "gauss_newton_steps": steps,
            "predictor_radius": _spectral_radius(model.A - K @ model.C),
        }
        if whole.n_segments > 1:
            attached.info["noise_model"]["segment"] = list(whole.bounds).index(
                max(whole.bounds, key=lambda bound: bound[1] - bound[0]))
        return attached
