"""Output-error refinement of a MOLI model: minimize the simulation error over theta.

The MOLI estimate minimizes a one-step (filtered) equation error. Refinement starts
from it and minimizes the *simulation* error on the estimation record,

    V(theta, x0) = sum_j |y_j - yhat_j(theta, x0)|^2 / |y_j|^2
                   + ridge * sum_k d_k^2 (theta_k - theta0_k)^2,

over the same parameters ``theta`` (the observer-form matrices ``D``, ``B``, the
output coupling ``G`` of docs/method.md §4 and the feedthrough when the model
has one, with the filter ``alpha`` kept), and
optionally the initial state ``x0`` of the estimation record, a nuisance parameter.
``d_k`` is the norm of the ``k``-th Jacobian column at the start, so ``ridge`` is a
fraction of the data term's own curvature and does not depend on the units.

The solver is Levenberg-Marquardt with analytic Jacobians: every parameter's
sensitivity is the model's response, from one state, to an input or a simulated output,
one block simulation per signal for all states at once. A step is
accepted only if it lowers ``V`` *and* keeps every pole inside the circle of radius
``max_radius``, so a stable start stays stable and ``V`` never increases.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...data.iodata import IOData
from ...errors import DataError, OptionError
from .damped_steps import Linearization
from .observer_form import observer_form
from .output_error import OutputErrorProblem
from ...models.delays import shift_inputs
from ...models.statespace import StateSpaceModel

__all__ = ["RefineResult", "refine", "refine_each", "polish", "is_refined"]

# Poles may move up to this radius: 1 - 1e-3 keeps time constants below 1000 samples,
# far beyond any record the method is used on, while leaving round-off room.
MAX_RADIUS = 1.0 - 1e-3
# polish runs on until a step lowers V by less than this share of one sample's error
# (V / (N p)): a Gauss-Newton step lowers V by its length squared in standard errors, so
# the last step moved the estimate by about a tenth of one.
POLISH_SHARE = 0.01
POLISH_ITERATIONS = 100
# Levenberg-Marquardt's damping, in units of each column's squared norm: a least-squares start
# is far from the minimum and takes its first steps short; steps end near the floor.
START_DAMPING = 1e-3
DAMPING_FLOOR = 1e-9


@dataclass
class RefineResult:
    """Outcome of :func:`refine`.

    Attributes
    ----------
    model : StateSpaceModel
        Refined model (same indices, alpha, offsets; ``info['refined']`` added).
    x0 : ndarray, shape (n,) or (segments, n)
        Initial state of the estimation record (zero unless estimated); one row per
        segment when the record has several.
    cost_start, cost : float
        ``V`` at the start and at the end (``cost <= cost_start``).
    iterations : int
        Accepted steps.
    rejected_unstable : int
        Proposed steps refused because they left the stability radius.
    """

    model: StateSpaceModel
    x0: np.ndarray
    cost_start: float
    cost: float
    iterations: int
    rejected_unstable: int


def refine(
    model: StateSpaceModel,
    data: IOData,
    *,
    iterations: int = 10,
    ridge: float = 0.0,
    fit_x0: bool = True,
    max_radius: float = MAX_RADIUS,
    tolerance: float = 1e-4,
    damping: float = START_DAMPING,
) -> RefineResult:
    """Minimize the simulation error of a MOLI model on its estimation data.

    Parameters
    ----------
    model : StateSpaceModel
        Start, e.g. ``moli.estimate(...)`` or ``identify(...).model``; must carry
        ``indices`` and ``alpha``. Must be stable (an unstable start is returned
        unchanged, with zero iterations).
    data : IOData
        Estimation record, centred like the data the model was estimated on. Each of
        its segments is simulated from its own initial state.
    iterations : int, default 10
        Most Levenberg-Marquardt steps to accept (few steps act as early stopping).
    ridge : float, default 0.0
        Weight of the penalty toward the start, relative to each parameter's
        curvature in the data term (0: free refinement).
    fit_x0 : bool, default True
        Estimate the initial state of the estimation record jointly.
    max_radius : float, default 1 - 1e-3
        Steps that move a pole to this radius or beyond are refused.
    tolerance : float, default 1e-4
        Stop when a step lowers ``V`` by less than this fraction.
    damping : float, default 1e-3
        Levenberg-Marquardt's first damping, relative to each column's squared norm
        (between 1e-9 and 1e8); :func:`polish` continues a refined model from 1e-9.

    Returns
    -------
    RefineResult

    Examples
    --------
    >>> import numpy as np, moli
    >>> from moli.method.refinement.levenberg_marquardt import refine
    >>> est, _ = moli.example_data(N=600, seed=1).split(400)
    >>> est = est.remove_means()
    >>> start = moli.estimate(est, [2, 1, 1], moli.filter_polynomial(0.5, 0.8, [2, 1, 1]))
    >>> result = refine(start, est)
    >>> bool(result.cost <= result.cost_start)
    True
    """
    return refine_each(model, data, (ridge,), iterations=iterations, fit_x0=fit_x0,
                       max_radius=max_radius, tolerance=tolerance, damping=damping)[0]


def refine_each(
    model: StateSpaceModel,
    data: IOData,
    ridges: Sequence[float],
    *,
    iterations: int = 10,
    fit_x0: bool = True,
    max_radius: float = MAX_RADIUS,
    tolerance: float = 1e-4,
    damping: float = START_DAMPING,
) -> list[RefineResult]:
    """:func:`refine` of one start with each of several ridges.

    Each result is the one :func:`refine` gives with that ridge, to the bit; the work
    they share (the start's simulation, its initial state, its Jacobian and that
    Jacobian's triangular factor) is done once.

    Parameters
    ----------
    model, data, iterations, fit_x0, max_radius, tolerance, damping
        As in :func:`refine`.
    ridges : sequence of float
        The ridges, at least one.

    Returns
    -------
    list of RefineResult
        One per ridge, in order.
    """
    if int(iterations) != iterations or iterations < 0:
        raise OptionError(f"iterations must be a non-negative integer, got {iterations!r}")
    ridges = tuple(ridges)
    if not ridges or not all(np.isfinite(r) and r >= 0 for r in ridges):
        raise OptionError(f"each ridge must be a non-negative number, and one at least; got {ridges!r}")
    if not 0 < max_radius <= 1:
        raise OptionError(f"max_radius must be in (0, 1], got {max_radius!r}")
    if not DAMPING_FLOOR <= damping < 1e8:
        raise OptionError(f"damping must be in [1e-9, 1e8), got {damping!r}")
    if (data.p, data.m) != (model.p, model.m):
        raise DataError(f"model has {model.p} outputs and {model.m} inputs, data {data.p} and {data.m}")
    start = RefinementStart(model, data, fit_x0, max_radius)
    return [start.descend(ridge, iterations, tolerance, damping) for ridge in ridges]


class RefinementStart:
    """The start of a refinement, shared by the ridges refined from it (and by the
    covariance of a refined model, taken at its own matrices)."""

    def __init__(self, model: StateSpaceModel, data: IOData, fit_x0: bool, max_radius: float) -> None:
        self.model, self.data, self.fit_x0, self.max_radius = model, data, fit_x0, max_radius
        # a model with input delays is refined on the inputs as its simulation shifts them
        # each segment from its own initial state, its inputs shifted within it
        u = np.concatenate([shift_inputs(data.u[a:b], model.input_delays) for a, b in data.bounds])
        problem, self.theta0 = self.make_problem(model, u, data)
        self.problem = problem
        theta = self.theta0.copy()
        yhat = problem.simulate(theta)
        residual = problem.residual(yhat)
        self.stable = self.starts_stable(model)
        if fit_x0 and self.stable:
            # start from the best initial state for the start model (a linear problem)
            theta[-problem.x0_size :] = np.linalg.lstsq(problem.initial_state_columns(theta), residual, rcond=None)[0]
            yhat = problem.simulate(theta)
            residual = problem.residual(yhat)
        self.theta, self.yhat, self.residual = theta, yhat, residual
        self.cost = float(residual @ residual)
        self._linearized: Linearization | None = None

    def make_problem(self, model: StateSpaceModel, u: np.ndarray, data: IOData) -> tuple[OutputErrorProblem, np.ndarray]:
        """The problem refined and its parameters at the start (initial states zero)."""
        form = observer_form(model)
        problem = OutputErrorProblem(form, u, data.y, self.fit_x0, data.segment_starts)
        return problem, problem.pack(form, np.zeros(problem.x0_size))

    def starts_stable(self, model: StateSpaceModel) -> bool:
        """Whether the start is inside the bound (an unstable start is returned unchanged)."""
        return bool(np.max(np.abs(model.poles()), initial=0.0) < self.max_radius)

    def finish(self, model: StateSpaceModel, theta: np.ndarray, accepted: int,
               info: dict[str, object]) -> StateSpaceModel:
        """The refined model at ``theta`` (the start's matrices bit for bit when no step was accepted)."""
        A, B, C, F, _ = self.problem.model_matrices(theta)
        if accepted == 0:
            A, B, C, F = model.A, model.B, model.C, model.D
        return model.with_matrices(A, B, C, F, info, model.divisors)

    def linearize(self, theta: np.ndarray, yhat: np.ndarray, residual: np.ndarray) -> Linearization:
        """The Jacobian and residual at ``theta`` reduced to what the damped steps solve
        (:class:`moli.method.refinement.damped_steps.Linearization`), once at the start for every ridge."""
        at_start = theta is self.theta
        if at_start and self._linearized is not None:
            return self._linearized
        linearized = Linearization(self.problem.jacobian(theta, yhat, residual), DAMPING_FLOOR)
        if at_start:
            self._linearized = linearized
        return linearized

    def descend(self, ridge: float, iterations: int, tolerance: float,
                damping: float = START_DAMPING) -> RefineResult:
        """Levenberg-Marquardt steps from the start with this ridge, from this damping."""
        problem, theta0, model, data = self.problem, self.theta0, self.model, self.data
        theta, yhat, residual = self.theta, self.yhat, self.residual
        scale = None
        penalty = np.sqrt(ridge)

        def total(res: np.ndarray, th: np.ndarray) -> float:
            extra = 0.0 if scale is None or ridge == 0 else float(np.sum((penalty * scale * (th - theta0)) ** 2))
            return float(res @ res) + extra

        cost = cost_start = self.cost
        accepted = rejected = 0
        while self.stable and accepted < iterations:
            linearized = self.linearize(theta, yhat, residual)
            norms = linearized.norms
            if scale is None:
                scale = norms.copy()
                if self.fit_x0:
                    scale[-problem.x0_size :] = 0.0     # x0 is a nuisance parameter: not penalised
            if not linearized.finite:
                break                           # nothing sound to step along: keep what we have
            improved = False
            while damping < 1e8:
                # solved for the step in units of each column's norm: the parameters'
                # scales (the record's units) then leave the solution unchanged
                if ridge > 0:
                    scaled = linearized.step(damping, penalty * scale / norms, -penalty * scale * (theta - theta0))
                else:
                    scaled = linearized.step(damping)
                if scaled is None:
                    damping *= 10
                    continue
                step = scaled / norms
                trial = theta + step
                if problem.radius(trial) >= self.max_radius:   # refused before it is simulated
                    rejected += 1
                    damping *= 10
                    continue
                new_yhat = problem.simulate(trial)
                new_res = problem.residual(new_yhat)
                new_cost = total(new_res, trial)
                if np.isfinite(new_cost) and new_cost < cost:
                    gain = (cost - new_cost) / cost
                    theta, yhat, residual, cost = trial, new_yhat, new_res, new_cost
                    damping = max(damping / 10, DAMPING_FLOOR)
                    improved = True
                    accepted += 1
                    break
                damping *= 10
            if not improved or gain < tolerance:
                break
        _, x0 = problem.unpack(theta)
        info = {key: value for key, value in model.info.items() if key != "refine_polished"}   # polish's own mark
        info.update({"refined": True, "refine_iterations": accepted, "refine_ridge": ridge,
                     "refine_cost_start": cost_start, "refine_cost": cost})
        refined = self.finish(model, theta, accepted, info)
        return RefineResult(refined, x0 if data.n_segments == 1 else x0.reshape(data.n_segments, -1),
                            cost_start, cost, accepted, rejected)


def is_refined(model: StateSpaceModel) -> bool:
    """Whether ``model`` is a refinement that moved from its start (at least one accepted step):
    its estimate, and so its covariance, is the output-error problem's."""
    return bool(model.info.get("refined")) and model.info.get("refine_iterations", 0) > 0


def polish(model: StateSpaceModel, data: IOData, max_radius: float = MAX_RADIUS) -> StateSpaceModel:
    """A free output-error refinement continued to its optimum (a model of any other kind as it is).

    ``identify`` compares lists and ridges on validation after a few refinement steps,
    which act as early stopping (chosen on the generalization benchmark, docs/accuracy.md).
    The generic list's refinement (:func:`moli.method.selection.candidates.generic_candidate`) is taken
    on to the minimum of ``V``, where its estimate is consistent and the covariance of
    :func:`moli.method.uncertainty.refined_covariance.refined_covariance` holds: on the 3x3 example
    plant (600 samples) its least-squares start is 10-66 steps away, and stopped at ten
    its bands held the true gain at 0.73-0.78 of the points, at the minimum 0.91-0.95. The
    selected model is taken there too where validation clearly prefers it
    (:func:`moli.method.selection.candidates.polished_if_clearly_better`).

    Parameters
    ----------
    model : StateSpaceModel
        The model to continue; only a free output-error refinement with accepted steps is,
        and not one this function already continued (``info["refine_polished"]``).
    data : IOData
        The record it was refined on.
    max_radius : float, default 1 - 1e-3
        Pole radius bound of the steps, as the refinement's.

    Returns
    -------
    StateSpaceModel
        ``info["refine_iterations"]`` counts the steps of both refinements, and
        ``info["refine_polished"]`` is True.
    """
    info = model.info
    if not (info.get("refined") and info.get("refine_iterations", 0) > 0 and info.get("refine_ridge", 0.0) == 0.0
            and "refine_method" not in info) or info.get("refine_polished"):
        return model
    N, p = data.y.shape
    # it continues a refinement whose steps ended at or near the damping floor: restarted at a
    # least-squares start's damping, its first steps were short enough to meet the stop (an
    # order-6 list of a 3x3 record, 12.7 sample variances above its minimum, stopped after one
    # step, 12.6 above it)
    result = refine(model, data, iterations=POLISH_ITERATIONS, max_radius=max_radius,
                    tolerance=POLISH_SHARE / (N * p), damping=DAMPING_FLOOR)
    if result.iterations == 0:
        return model
    result.model.info.update(refine_iterations=info["refine_iterations"] + result.iterations,
                             refine_cost_start=info["refine_cost_start"], refine_polished=True)
    return result.model
