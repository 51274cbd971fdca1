"""The covariance of a refined model: the Gauss-Newton sandwich of its output-error problem.

A refined model (docs/method.md §12) minimizes the weighted simulation error
``V(theta, x0) = |r(theta, x0)|^2`` over the observer-form parameters. Around its
minimum, ``theta_hat - theta* ~ (J^T J + P)^-1 J^T r``, with ``J`` the Jacobian of the
residuals, ``P`` the ridge's penalty (zero for the free refinement) and ``theta*`` the
value the estimate converges to. Output errors are coloured whatever the output noise
(the noise itself, and the model's own error), so the spread of ``J^T r`` is the
long-run covariance of the per-sample scores ``s_t = J_t^T r_t`` (Newey-West, the
Bartlett kernel of :mod:`moli.method.covariance`), not ``sigma^2 J^T J``:

    Cov(theta_hat) = (J^T J + P)^-1 S (J^T J + P)^-1,

which holds whether or not a noise model would be right (docs/uncertainty.md §2b).
The initial states are parameters of the same problem, so the parameters' covariance
is the corresponding block of the joint one. It is propagated to ``A, B, C, D``
through the observer form, ``A = A_D + D_o C``, ``C = (I - G)^-1 C_D``, ``B`` and the
feedthrough free: ``dA = dD_o C + D_o dC``, ``dC = H dG C`` with ``H = (I - G)^-1``.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import scipy.linalg

from ..errors import DataError
from ..models.delays import shift_inputs
from ..models.statespace import StateSpaceModel
from .covariance import long_run_covariance
from .observer_form import ObserverForm, observer_form
from .refinement import OutputErrorProblem

__all__ = ["refined_covariance"]

# Directions of the column-scaled Jacobian with a singular value below this share of the
# largest change the simulated output by less than round-off of the parameters (about
# 1e-8 relative to the best-determined direction, which sqrt(eps) = 1.5e-8 resolves).
NULL_DIRECTION = 1e-8


def refined_covariance(model: StateSpaceModel, u: np.ndarray, y: np.ndarray,
                       bounds: Sequence[tuple[int, int]]) -> tuple[np.ndarray, dict[str, object]]:
    """``cov_factor`` of a refined model from its output-error problem on a record, and its record.

    Parameters
    ----------
    model : StateSpaceModel
        A refined MOLI model (``info["refined"]``); ``info["refine_ridge"]`` sets the
        penalty of the problem it solved.
    u, y : ndarray, shape (N, m) and (N, p)
        The record it was refined on, as deviations from the model's operating point
        (inputs as recorded: the model's input delays are applied here).
    bounds : sequence of (start, stop)
        The record's segments: each has its own initial state, and no lag of the
        long-run covariance spans a boundary.

    Returns
    -------
    factor : ndarray, shape (n n + n m + p n + p m, k)
        ``Cov(vec[A, B, C, D]) = factor @ factor.T``.
    record : dict
        What ``info["covariance"]`` records: the method, kernel width, rows, parameters.

    Raises
    ------
    DataError
        The model is unstable (its simulation error has no finite Jacobian).
    """
    if not model.is_stable():
        raise DataError("the covariance of a refined model needs a stable model")
    form = observer_form(model)
    starts = tuple(a for a, _ in bounds)
    u = np.concatenate([shift_inputs(u[a:b], model.input_delays) for a, b in bounds])
    problem = OutputErrorProblem(form, u, y, True, starts)
    theta = problem.pack(form, np.zeros(problem.x0_size))
    yhat, _, _ = problem.simulate(theta)
    residual = problem.residual(yhat)
    # the initial states at their optimum for these matrices, as the refinement left them
    theta[-problem.x0_size :] = np.linalg.lstsq(problem.initial_state_columns(theta), residual, rcond=None)[0]
    yhat, _, _ = problem.simulate(theta)
    residual = problem.residual(yhat)
    jac = problem.jacobian(theta, yhat, residual)[:, :-1]
    if not (np.all(np.isfinite(jac)) and np.all(np.isfinite(residual))):
        raise DataError("the simulation error of the refined model is not finite on the record")
    (N, p), k = y.shape, jac.shape[1]
    norms = np.linalg.norm(jac, axis=0)
    norms[norms == 0] = 1.0
    rows = [jac / norms]
    ridge = float(model.info.get("refine_ridge", 0.0))
    if ridge > 0:
        # the ridge's penalty in the column-scaled parameters: sqrt(ridge) per model
        # parameter (its curvature's own scale, docs/method.md §12), none on x0
        penalty = np.full(k, math.sqrt(ridge))
        penalty[-problem.x0_size :] = 0.0
        rows.append(np.diag(penalty))
    # The bread's pseudo-inverse: some lists give the simulation error a direction that
    # leaves the simulated output unchanged (17 parameters for a 16-dimensional family,
    # e.g. the coupling G beside the injection D_o); such a direction changes no response
    # of the model, so dropping it leaves every band unchanged.
    _, values, vt = np.linalg.svd(np.vstack(rows), full_matrices=False)
    if not values[0] > 0:
        raise DataError("the refined model's simulation error does not depend on its parameters on this record")
    kept = values > values[0] * NULL_DIRECTION
    scores = np.einsum("tpk,tp->tk", (jac / norms).reshape(N, p, k), residual.reshape(N, p))
    long_run, width = long_run_covariance(scores, starts[1:])
    # root (R^T R)^+ with R^T R = V diag(values^2) V^T; a square root of S from its eigenvalues
    eig, vectors = np.linalg.eigh(long_run)
    root = np.sqrt(np.clip(eig, 0.0, None))[:, None] * vectors.T
    bread = (vt[kept].T / values[kept] ** 2) @ vt[kept]
    # the small-sample factor of a least-squares problem of N p rows and k parameters,
    # and the columns back in the parameters' units
    root = (root @ bread) * math.sqrt(N * p / max(N * p - int(kept.sum()), 1)) / norms
    parameters = k - problem.x0_size
    factor = _matrix_directions(model, form, problem.feedthrough, root[:, :parameters]).T
    record = {"method": "output-error refinement, Gauss-Newton sandwich, Newey-West",
              "kernel_width": width, "rows": N, "parameters": parameters,
              "rank": int(kept.sum()) - problem.x0_size}
    return factor, record


def _matrix_directions(model: StateSpaceModel, form: ObserverForm, feedthrough: bool, dtheta: np.ndarray) -> np.ndarray:
    """First-order changes of ``[A, B, C, D]`` (flattened, row-major) for each row of ``dtheta``,
    laid out as the refinement packs its parameters: ``D_o``, ``B``, ``G``'s lower part, ``F``."""
    n, p, m = model.n, model.p, model.m
    count = dtheta.shape[0]
    at = 0
    d_inj = dtheta[:, at : at + n * p].reshape(count, n, p)
    at += n * p
    dB = dtheta[:, at : at + n * m].reshape(count, n, m)
    at += n * m
    lower = np.tril_indices(p, -1)
    dG = np.zeros((count, p, p))
    dG[:, lower[0], lower[1]] = dtheta[:, at : at + len(lower[0])]
    at += len(lower[0])
    dD = dtheta[:, at : at + p * m].reshape(count, p, m) if feedthrough else np.zeros((count, p, m))
    H = scipy.linalg.solve_triangular(np.eye(p) - form.G, np.eye(p), lower=True, unit_diagonal=True)
    dC = H @ dG @ model.C
    dA = d_inj @ model.C + form.D @ dC
    return np.concatenate([d.reshape(count, -1) for d in (dA, dB, dC, dD)], axis=1)
