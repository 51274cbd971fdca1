"""The direct method for closed-loop records: prediction-error refinement in innovations form.

The innovations form of a model, ``x+ = A x + B u + K e``, ``y = C x + F u + e``, has the
one-step predictor

    x̂+ = (A - K C) x̂ + (B - K F) u + K y,    ŷ = C x̂ + F u.

In MOLI's observer form ``A = A_D + D_o C`` (docs/method.md §4), so the predictor's state
matrix is ``A_D + L C`` with ``L = D_o - K``: the predictor is itself an observer-form
model, driven by the inputs and the measured outputs, with injection ``L``, input matrix
``[B - K F, K]``, the coupling ``G`` and a feedthrough ``F`` of the inputs only. Its
simulation error is the one-step prediction error, so the output-error machinery
(:class:`moli.method.refinement.output_error.OutputErrorProblem`, Levenberg-Marquardt with analytic
Jacobians) minimizes the prediction errors over ``A, B, C, D`` and ``K`` jointly: the
prediction-error estimate. Unlike an output-error model it stays consistent under
feedback, provided the innovations form can describe the output noise (the direct method,
Ljung 1999 §13.4; docs/closed_loop.md).

The starts are the model with its noise model, without it (``K = 0``: the output-error
predictor) and with ``K = D_o`` (the predictor of MOLI's least squares, whose poles are the
filter's); the lowest prediction error is kept. Every step keeps both the predictor ``A - K C`` and the model
``A`` within the radius bound.
"""

from __future__ import annotations

import copy

import numpy as np
import scipy.linalg

from ...data.iodata import IOData
from ...errors import DataError
from ...models.statespace import StateSpaceModel
from .observer_form import ObserverForm, observer_form
from .output_error import OutputErrorProblem
from .levenberg_marquardt import MAX_RADIUS, RefinementStart, RefineResult

__all__ = ["PredictionErrorProblem", "PredictionErrorStart", "prediction_error_refine", "METHOD"]

# info["refine_method"] of a model refined by prediction error (the covariance reads it).
METHOD = "prediction error"
# Levenberg-Marquardt steps: the joint problem starts further from its minimum than the
# output-error refinement (K and the model move together), so it gets more steps.
ITERATIONS = 30


def _radius(matrix: np.ndarray) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(matrix)), initial=0.0))


class PredictionErrorProblem(OutputErrorProblem):
    """The one-step predictor's errors and Jacobian, in the predictor's observer-form parameters.

    The problem's inputs are ``[u, y]``; its "input matrix" is ``[B - K F, K]`` and its
    feedthrough covers the ``m`` plant inputs only.
    """

    def __init__(self, form: ObserverForm, u: np.ndarray, y: np.ndarray, fit_x0: bool,
                 starts: tuple[int, ...] = (0,)) -> None:
        self.plant_inputs = u.shape[1]
        super().__init__(form, np.concatenate([u, y], axis=1), y, fit_x0, starts, through=u.shape[1])

    def pieces(self, form: ObserverForm) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(predictor A, C, B - K F, K, F)`` of a predictor form."""
        m = self.plant_inputs
        P, inputs, C = form.matrices()
        return P, C, inputs[:, :m], inputs[:, m:], form.F[:, :m]

    def radius(self, theta: np.ndarray) -> float:
        P, C, _, K, _ = self.pieces(self.unpack(theta)[0])
        return max(_radius(P), _radius(P + K @ C))

    def model_matrices(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        P, C, B_K, K, F = self.pieces(self.unpack(theta)[0])
        return P + K @ C, B_K + K @ F, C, F, K

    def matrix_changes(self, C: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """First-order changes of ``[A, B, C, D]`` for each row of ``dtheta``.

        ``A = A_D + (L + K) C``, ``B = (B - K F) + K F``: ``dA = (dL + dK) C + (L + K) dC``,
        ``dB = d(B - K F) + dK F + K dF``, ``dC = H dG C``.
        """
        p, m = C.shape[0], self.plant_inputs
        H = scipy.linalg.solve_triangular(np.eye(p) - self.form.G, np.eye(p), lower=True, unit_diagonal=True)
        injection = self.form.D + self.form.B[:, m:]
        K, F = self.form.B[:, m:], self.form.F[:, :m]
        out = []
        for row in dtheta:
            d, _ = self.unpack(np.concatenate([row, np.zeros(self.x0_size)]))
            dK = d.B[:, m:]
            dC = H @ d.G @ C
            dA = (d.D + dK) @ C + injection @ dC
            dB = d.B[:, :m] + dK @ F + K @ d.F[:, :m]
            out.append(np.concatenate([dA.ravel(), dB.ravel(), dC.ravel(), d.F[:, :m].ravel()]))
        return np.array(out).reshape(dtheta.shape[0], -1)


class PredictionErrorStart(RefinementStart):
    """A refinement start whose problem is the model's one-step predictor (:class:`PredictionErrorProblem`)."""

    def make_problem(self, model: StateSpaceModel, u: np.ndarray,
                     data: IOData) -> tuple[PredictionErrorProblem, np.ndarray]:
        form = observer_form(model)
        K = np.zeros((model.n, model.p)) if model.K is None else np.asarray(model.K, dtype=float)
        predictor = ObserverForm(form.A_D, form.C_D, form.D - K, np.concatenate([form.B - K @ form.F, K], axis=1),
                                 form.G, np.concatenate([form.F, np.zeros((model.p, model.p))], axis=1))
        problem = PredictionErrorProblem(predictor, u, data.y, self.fit_x0, data.segment_starts)
        return problem, problem.pack(predictor, np.zeros(problem.x0_size))

    def starts_stable(self, model: StateSpaceModel) -> bool:
        return self.problem.radius(self.theta0) < self.max_radius

    def finish(self, model: StateSpaceModel, theta: np.ndarray, accepted: int,
               info: dict[str, object]) -> StateSpaceModel:
        if accepted == 0:
            A, B, C, F = model.A, model.B, model.C, model.D
            K = np.zeros((model.n, model.p)) if model.K is None else model.K
        else:
            A, B, C, F, K = self.problem.model_matrices(theta)
        yhat = self.problem.simulate(theta)
        errors = self.problem.y - yhat
        refined = model.with_matrices(A, B, C, F, {**info, "refine_method": METHOD}, model.divisors)
        refined.K = np.array(K, dtype=float)
        cov = errors.T @ errors / errors.shape[0]
        refined.noise_cov = 0.5 * (cov + cov.T)
        refined.info["noise_model"] = {"method": "prediction error, jointly with the model (direct method)",
                                       "predictor_radius": _radius(A - refined.K @ C)}
        return refined


def prediction_error_refine(model: StateSpaceModel, data: IOData, *, iterations: int = ITERATIONS,
                            max_radius: float = MAX_RADIUS, tolerance: float = 1e-4) -> RefineResult:
    """The prediction-error estimate of ``A, B, C, D`` and ``K`` from ``model`` as the start.

    Parameters
    ----------
    model : StateSpaceModel
        A MOLI model (it carries ``indices`` and its filters), with or without a noise
        model (``K`` None starts from the output-error predictor).
    data : IOData
        The estimation record, centred like the data the model was estimated on; each
        segment's predictor starts from its own fitted state.
    iterations : int, default 30
        Most Levenberg-Marquardt steps to accept.
    max_radius : float, default 1 - 1e-3
        Steps that put a pole of the model or of its predictor at this radius or beyond
        are refused.
    tolerance : float, default 1e-4
        Stop when a step lowers the criterion by less than this fraction.

    Returns
    -------
    RefineResult
        Its model carries the estimated ``K``, the innovation covariance ``noise_cov`` and
        ``info["refine_method"] = "prediction error"``.

    Examples
    --------
    >>> import numpy as np, moli
    >>> est = moli.example_data(N=600, seed=1).remove_means()
    >>> start = moli.estimate(est, [2, 2, 2], moli.filter_polynomial(0.5, 0.8, [2, 2, 2]))
    >>> result = prediction_error_refine(start, est)
    >>> bool(result.cost <= result.cost_start), result.model.K.shape
    (True, (6, 3))
    """
    if (data.p, data.m) != (model.p, model.m):
        raise DataError(f"model has {model.p} outputs and {model.m} inputs, data {data.p} and {data.m}")
    # from the model's noise model, from none (the output-error predictor) and from the
    # predictor of MOLI's own least squares (K = D_o: the filter's poles): a noise model whose
    # predictor sits at the radius bound leaves no room for steps, and the starts can lead to
    # different minima; the lower criterion is kept
    bare = model.with_matrices(model.A, model.B, model.C, model.D, dict(model.info), model.divisors)
    own = copy.deepcopy(bare)
    own.K = observer_form(model).D          # the predictor A_D: the filters' own poles, always stable
    starts = [bare, own] if model.K is None else [model, bare, own]
    results = [PredictionErrorStart(start, data, True, max_radius).descend(0.0, iterations, tolerance)
               for start in starts]
    moved = [result for result in results if result.iterations > 0] or results[:1]
    return min(moved, key=lambda result: result.cost)

