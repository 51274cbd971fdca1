"""Levenberg-Marquardt on the weighted FRF error, every step inside the stable region, and the sandwich covariance.

Each step solves ``(J^T J + mu S^2) d = -J^T r`` (:func:`moli.method.frequency.fit_error.normal_equations`)
with ``S`` the Jacobian's column norms (Marquardt's scaling: the poles, ``B``, ``C`` and ``D`` move on
their own scales). A step is taken where it lowers the cost and keeps every pole stable
(:func:`moli.method.frequency.modal_form.is_stable`); otherwise ``mu`` grows and the step
shrinks toward the gradient's. The refinement stops when a step lowers the cost by less
than :data:`RELATIVE_DECREASE` of it (:data:`PATH_RELATIVE_DECREASE` on the path), or after
:data:`MAX_STEPS` Jacobians (:data:`PATH_STEPS`).

Around the minimum, ``theta_hat - theta ~ -(J^T J)^+ J^T r``; the pseudo-inverse drops the
modal form's gauge directions (along which nothing is estimated). With ``J^T J = V S^2 V^T``
over the identifiable directions and ``T = d vec / d theta``: where the data give their
variances, every weighted real term has one variance ``s^2`` and ``Cov = s^2 V S^-2 V^T``,
factor ``s T V S^-1``; otherwise the sandwich ``Cov = (J^T J)^+ (sum_k s_k s_k^T) (J^T J)^+``
with ``s_k`` each line's score, ``V S^-2 V^T M V S^-2 V^T``, factor ``T V S^-2 V^T L`` with
``M = L L^T``. The first takes a lightly damped mode's variance from the given variances of its
few lines; the second from those lines' residuals, a noisy estimate (docs/frequency.md §5).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .fit_error import FitProblem, cost, normal_equations, score_spread
from .modal_form import ModalLayout, is_stable, matrix_jacobian

__all__ = ["Refined", "descend", "refine_modal", "covariance_factor", "MAX_STEPS", "PATH_STEPS", "RELATIVE_DECREASE",
           "PATH_RELATIVE_DECREASE"]

# Jacobians a refinement may form: from the subspace start a fit converges in 5-20.
MAX_STEPS = 100
# Jacobians of each order's refinement on the path: the true order's converges in a few;
# an order too low or too high has no good minimum to reach and takes 20-50 for little
# change in its held-out error (2-10 of the 40-60 points an order too low loses).
PATH_STEPS = 20
# A step that lowers the cost by less than this share of it ends the refinement.
RELATIVE_DECREASE = 1e-10
# The same on the path, whose models only rank the orders on the held-out lines, where the order
# rule takes 1 % of the error for no difference (identification.NEGLIGIBLE_SHARE): a step worth
# a tenth of that changes no ranking. Orders too low or too high, with no sharp minimum, crawl
# down by 1e-5 to 1e-2 of their cost a step and used to spend their 20 steps so; the true order
# converges in a few steps either way (docs/frequency.md §4).
PATH_RELATIVE_DECREASE = 1e-3
# Marquardt's damping: first value (relative to the scaled curvature), growth on a refused
# step, shrink on an accepted one, and the damping past which no step helps.
FIRST_DAMPING, GROW, SHRINK, MAX_DAMPING = 1e-3, 10.0, 0.3, 1e12


@dataclass(frozen=True)
class Refined:
    """The refined parameters, their cost, and the Jacobians formed."""

    theta: np.ndarray
    cost: float
    steps: int


def _step(curvature: np.ndarray, gradient: np.ndarray, scale: np.ndarray, damping: float) -> np.ndarray:
    return np.linalg.lstsq(curvature + damping * np.diag(scale**2), -gradient, rcond=None)[0]


def descend(linearize: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, float]],
            propose: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, float]], start: np.ndarray, *,
            max_steps: int, relative_decrease: float) -> Refined:
    """Levenberg-Marquardt from ``start``: ``linearize(x)`` gives ``J^T J``, ``J^T r`` and the cost at ``x``,
    ``propose(x, step)`` the point a step leads to and its cost (inf where the point is refused)."""
    x = start
    damping, steps = FIRST_DAMPING, 0
    N, g, current = linearize(x)
    while steps < max_steps and current > 0:
        steps += 1
        scale = np.sqrt(np.maximum(np.diag(N), np.finfo(float).tiny))
        improved = False
        while damping <= MAX_DAMPING:
            trial, trial_cost = propose(x, _step(N, g, scale, damping))
            if trial_cost < current:
                improved = True
                break
            damping *= GROW
        if not improved:
            break
        decrease = current - trial_cost
        x, damping = trial, max(damping * SHRINK, 1e-12)
        if decrease <= relative_decrease * current:
            current = trial_cost
            break
        N, g, current = linearize(x)
    return Refined(x, current, steps)


def refine_modal(layout: ModalLayout, theta: np.ndarray, problem: FitProblem, *, continuous: bool,
                 radius: float | None, max_steps: int = MAX_STEPS,
                 relative_decrease: float = RELATIVE_DECREASE) -> Refined:
    """Minimize the weighted FRF error from ``theta`` (stable where ``radius`` is not None), forming
    ``max_steps`` Jacobians at most and stopping at a step that lowers the cost by less than
    ``relative_decrease`` of it."""
    def propose(point: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, float]:
        trial = point + step
        return trial, cost(layout, trial, problem) if is_stable(layout, trial, continuous, radius) else np.inf

    return descend(lambda point: normal_equations(layout, point, problem), propose, theta.copy(),
                   max_steps=max_steps, relative_decrease=relative_decrease)


def covariance_factor(layout: ModalLayout, theta: np.ndarray, problem: FitProblem, *,
                      given_variance: bool = False) -> np.ndarray | None:
    """``F`` with ``cov(vec[A, B, C, D]) = F F^T``, or None where the fit leaves no information.

    With ``given_variance`` (the weights are the data's ``1 / sqrt(variance)``), the
    covariance is ``s^2 (J^T J)^+`` with ``s^2`` the weighted residual's variance per real
    row, ``|r|^2 / (rows - identifiable parameters)``: the variances give each line's share,
    and the one scale is estimated from every line. Otherwise it is the sandwich, whose
    meat takes each line's share from its own residual. The directions dropped are the
    :attr:`ModalLayout.gauge` ones of least curvature, which carry no information by
    construction.
    """
    curvature, _, total = normal_equations(layout, theta, problem)
    values, vectors = np.linalg.eigh(curvature)                          # ascending: the gauge first
    kept = layout.size - layout.gauge
    if kept <= 0 or values[layout.gauge] <= np.finfo(float).eps * values[-1] * layout.size:
        return None
    V = vectors[:, layout.gauge:]                                        # identifiable directions
    if given_variance:
        residual_variance = total / (2 * problem.G.size - kept)          # per real term: real and imaginary rows
        return matrix_jacobian(layout) @ (V * np.sqrt(residual_variance / values[layout.gauge:]))
    bread = V / values[layout.gauge:]                                    # V S^-2, then times V^T
    meat = score_spread(layout, theta, problem)
    inner = V.T @ meat @ V                                               # V^T M V (kept x kept), symmetric
    values, vectors = np.linalg.eigh(inner)
    root = vectors * np.sqrt(np.clip(values, 0.0, None))                 # inner = root root^T
    return matrix_jacobian(layout) @ (bread @ root)
