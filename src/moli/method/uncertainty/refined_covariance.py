"""The covariance of a refined model: the Gauss-Newton sandwich of its output-error problem.

A refined model (docs/method.md §12) minimizes the weighted simulation error
``V(theta, x0) = |r(theta, x0)|^2`` over the observer-form parameters. Around its
minimum, ``theta_hat - theta* ~ (J^T J)^-1 J^T r``, with ``J`` the Jacobian of the
residuals and ``theta*`` the value the estimate converges to. Output errors are coloured
whatever the output noise (the noise itself, and the model's own error), so the spread
of ``J^T r`` is the long-run covariance of the per-sample scores ``s_t = J_t^T r_t``
(Newey-West, the Bartlett kernel of :mod:`moli.method.least_squares.sandwich`), not ``sigma^2 J^T J``:

    Cov(theta_hat) = (J^T J)^+ S (J^T J)^+,

which holds whether or not a noise model would be right (docs/uncertainty.md §2b).
A ridge-refined model gets the same free-problem covariance: its penalty pulls toward
the least-squares start, which is itself an estimate from the same record (and biased
under output noise), so the penalty's curvature is not information about the
parameters; counted in the bread, it made the bands hold the true gain at a third to a
half of the points where the ridge's model was kept.
The initial states are parameters of the same problem, so the parameters' covariance
is the corresponding block of the joint one. It is propagated to ``A, B, C, D``
through the observer form, ``A = A_D + D_o C``, ``C = (I - G)^-1 C_D``, ``B`` and the
feedthrough free: ``dA = dD_o C + D_o dC``, ``dC = H dG C`` with ``H = (I - G)^-1``.
"""

from __future__ import annotations

import math

import numpy as np

from ...data.iodata import IOData
from ...errors import DataError
from ...models.statespace import StateSpaceModel
from ..least_squares.sandwich import long_run_covariance
from ...models.simulation import simulate_batch
from ..closed_loop.reference_projection import FirstStage
from ..refinement.prediction_error import METHOD as PREDICTION_ERROR, PredictionErrorStart
from ..refinement.levenberg_marquardt import RefinementStart
from ...numerics.triangular import tall_factor

__all__ = ["refined_covariance"]

# Directions of the column-scaled Jacobian with a singular value below this share of the
# largest change the simulated output by less than round-off of the parameters (about
# 1e-8 relative to the best-determined direction, which sqrt(eps) = 1.5e-8 resolves).
NULL_DIRECTION = 1e-8


def refined_covariance(model: StateSpaceModel, data: IOData,
                       first_stage: FirstStage | None = None) -> tuple[np.ndarray, dict[str, object]]:
    """``cov_factor`` of a refined model from its output-error problem on ``data``, and its record.

    Parameters
    ----------
    model : StateSpaceModel
        A refined MOLI model (:func:`moli.method.refinement.levenberg_marquardt.is_refined`), free or with a ridge: either gets the
        free problem's covariance.
    data : IOData
        The record it was refined on, raw or centred (offsets handled as
        :func:`moli.compare`). Each segment has its own initial state, and no lag of the
        long-run covariance spans a boundary.
    first_stage : FirstStage, optional
        The two-stage method's first stage on the samples of ``data``, whose inputs are its
        projections: the scores are corrected for the first stage's estimation error (the
        two-step estimator's sandwich, docs/closed_loop.md §3).

    Returns
    -------
    factor : ndarray, shape (n n + n m + p n + p m, k)
        ``Cov(vec[A, B, C, D]) = factor @ factor.T``.
    record : dict
        What ``info["covariance"]`` records: the method, kernel width, rows, parameters
        and the rank of the parameters' covariance.

    Raises
    ------
    DataError
        The model is unstable (its simulation error has no finite Jacobian), or the record has
        no more output values than the problem has unknowns.
    """
    # the refinement's own start at these matrices: the problem, the initial states at
    # their optimum, the simulation and its residual
    predictor = model.info.get("refine_method") == PREDICTION_ERROR
    start = (PredictionErrorStart if predictor else RefinementStart)(
        model, data.remove_means(model.y_offset, model.u_offset), True, 1.0)
    if not start.stable:
        raise DataError("the covariance of a refined model needs a stable model")
    problem, residual = start.problem, start.residual
    jac = problem.jacobian(start.theta, start.yhat, residual)[:, :-1]
    if not (np.all(np.isfinite(jac)) and np.all(np.isfinite(residual))):
        raise DataError("the simulation error of the refined model is not finite on the record")
    (N, p), k = data.y.shape, jac.shape[1]
    if N * p <= k:
        raise DataError(f"the covariance of the refined model needs more output values than its {k} unknowns "
                        f"({k - problem.x0_size} parameters and {problem.x0_size} initial-state entries); the "
                        f"record gives {N} samples of {p} outputs: give the record it was refined on")
    norms = np.linalg.norm(jac, axis=0)
    norms[norms == 0] = 1.0
    # the singular values and right vectors of the record-long matrix are its triangular factor's
    scaled = jac / norms
    # The bread's pseudo-inverse: some lists give the simulation error a direction that
    # leaves the simulated output unchanged (17 parameters for a 16-dimensional family,
    # e.g. the coupling G beside the injection D_o); such a direction changes no response
    # of the model, so dropping it leaves every band unchanged.
    _, values, vt = np.linalg.svd(tall_factor(scaled), full_matrices=False)
    if not values[0] > 0:
        raise DataError("the refined model's simulation error does not depend on its parameters on this record")
    kept = values > values[0] * NULL_DIRECTION
    scores = np.einsum("tpk,tp->tk", scaled.reshape(N, p, k), residual.reshape(N, p))
    if first_stage is not None:
        scores -= _first_stage_scores(model, data, first_stage, scaled, problem.weights)
    long_run, width = long_run_covariance(scores, data.segment_starts[1:])
    # root (R^T R)^+ with R^T R = V diag(values^2) V^T; a square root of S from its eigenvalues
    eig, vectors = np.linalg.eigh(long_run)
    root = np.sqrt(np.clip(eig, 0.0, None))[:, None] * vectors.T
    bread = (vt[kept].T / values[kept] ** 2) @ vt[kept]
    # the small-sample factor of a least-squares problem of N p rows and k parameters,
    # and the columns back in the parameters' units
    root = (root @ bread) * math.sqrt(N * p / max(N * p - int(kept.sum()), 1)) / norms
    parameters = k - problem.x0_size
    factor = problem.matrix_changes(model.C, root[:, :parameters]).T
    record = {"method": ("prediction-error" if predictor else "output-error")
              + " refinement, Gauss-Newton sandwich, Newey-West",
              "kernel_width": width, "rows": N, "parameters": parameters,
              "rank": int(kept.sum()) - problem.x0_size}
    if first_stage is not None:
        record["first_stage"] = "first-stage estimation error included"
    return factor, record


def _first_stage_scores(model: StateSpaceModel, data: IOData, first_stage: FirstStage, jac: np.ndarray,
                        weights: np.ndarray) -> np.ndarray:
    """What the first stage's estimation error adds to each sample's score, (N, k).

    Linearized, ``theta_hat - theta = bread sum_t (s_t - P (X^T X)^-1 X_t^T w_t)``: ``P = J^T J_beta``
    with ``J_beta`` the weighted response of the outputs to each first-stage coefficient (the model
    driven by that regressor, centred like the inputs, through its input), ``X`` the first stage's
    regressors and ``w`` its residuals. With ``X = Q R``, ``(X^T X)^-1 X_t^T = R^-1 Q_t^T``.
    """
    design, residual = first_stage.design, first_stage.residual
    N, q = design.shape
    n, p = model.n, model.p
    centred = design - design.mean(axis=0)       # the intercept moves no centred input
    Q, R = np.linalg.qr(design)
    pinv_R = np.linalg.pinv(R)                   # references may be collinear: a rank-deficient R
    A, C = np.broadcast_to(model.A, (q, n, n)), np.broadcast_to(model.C, (q, p, n))
    columns = np.arange(q)
    out = np.zeros((N, jac.shape[1]))
    for j in range(model.m):
        through = np.zeros((q, n, q))            # model i takes regressor i through input j
        through[columns, :, columns] = model.B[:, j]
        response = np.empty((N, p, q))
        for a, b in data.bounds:                 # each segment from rest, as its inputs
            response[a:b] = simulate_batch(A, through, C, centred[a:b]).transpose(1, 2, 0)
        response += model.D[None, :, j, None] * centred[:, None, :]
        response *= weights[None, :, None]
        P = jac.T @ response.reshape(N * p, q)
        out += (Q * residual[:, j : j + 1]) @ (P @ pinv_R).T
    return out
