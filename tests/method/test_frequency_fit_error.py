"""The frequency fit's normal equations by entries, its path on thinned lines, its covariance with given variances."""

import numpy as np
import pytest

import moli
from moli.method.frequency import orders
from moli.method.frequency.fit_error import FitProblem, normal_equations, response, score_spread
from moli.method.frequency.modal_form import ModalLayout

from .test_frequency_identification import DAMPINGS, FREQUENCIES, OMEGA, modal_system, noisy


@pytest.mark.parametrize("pairs, reals, p, m, feedthrough",
                         [(2, 1, 3, 2, True), (3, 0, 2, 3, False), (0, 2, 1, 1, True)])
def test_normal_equations_and_score_spread_are_those_of_the_finite_difference_jacobian(pairs, reals, p, m, feedthrough):
    layout = ModalLayout(pairs, reals, p, m, feedthrough)
    rng = np.random.default_rng(4)
    theta = rng.standard_normal(layout.size)
    theta[:pairs] = -0.2 - np.abs(theta[:pairs])                       # stable, well away from the lines
    theta[2 * pairs:2 * pairs + reals] = -0.5 - np.abs(theta[2 * pairs:2 * pairs + reals])
    F = 700                                                             # more than one block of lines
    problem = FitProblem(1j * np.linspace(0.1, 3.0, F), rng.standard_normal((F, p, m)) + 1j * rng.standard_normal(
        (F, p, m)), rng.uniform(0.5, 2.0, (F, p, m)))

    def residual(values):
        weighted = problem.weights * (response(layout, values, problem.points) - problem.G)
        return np.stack([weighted.real, weighted.imag], axis=-1).reshape(F, -1)           # rows per line

    step = 1e-6
    columns = [(residual(theta + step * e) - residual(theta - step * e)) / (2 * step) for e in np.eye(layout.size)]
    jacobian = np.stack(columns, axis=-1)                                                  # (F, rows, size)
    r = residual(theta)
    curvature, gradient, total = normal_equations(layout, theta, problem)
    scores = np.einsum("frt,fr->ft", jacobian, r)
    # central differences of a response of size 1-10 err by step^2 times its third derivative
    # (about 1e-12) plus round-off eps / step (about 1e-10) per entry, relative to entries of order 1
    scale = np.max(np.abs(curvature))
    assert np.allclose(curvature, np.einsum("frt,frs->ts", jacobian, jacobian), rtol=0, atol=1e-7 * scale)
    assert np.allclose(gradient, scores.sum(axis=0), rtol=0, atol=1e-7 * np.max(np.abs(gradient)))
    assert total == pytest.approx(np.sum(r**2), rel=1e-12)
    meat = score_spread(layout, theta, problem)
    assert np.allclose(meat, scores.T @ scores, rtol=0, atol=1e-7 * np.max(np.abs(meat)))


def test_the_paths_refinements_work_on_at_most_path_lines_and_the_selected_model_on_every_line(monkeypatch):
    truth = modal_system(FREQUENCIES[:2], DAMPINGS[:2], 1, 1, seed=2)
    omega = np.logspace(0, 2.5, 6000)                                  # 4800 estimation lines
    data = noisy(truth, omega, 0.01, 0)
    seen = []
    original = orders.refine_modal

    def recording(layout, theta, problem, **options):
        seen.append(problem.points.size)
        return original(layout, theta, problem, **options)

    monkeypatch.setattr(orders, "refine_modal", recording)
    result = moli.identify(data, nmax=5)
    assert seen and max(seen) <= 4096                                    # orders.PATH_LINES, docs/frequency.md
    assert result.selected.order == 4
    # each step's cost is its model's weighted error on every estimation line, not on the thinned ones
    kept = np.setdiff1d(np.arange(data.F), result.held_out)
    for step, model in zip(result.path, result.path_models):
        error = (model.frequency_response(omega[kept]) - data.G[kept]) / np.sqrt(data.variance[kept])
        assert step.cost == pytest.approx(np.sum(np.abs(error) ** 2), rel=1e-6)    # the physical model's round-off


def test_with_given_variances_a_sharp_modes_standard_deviation_does_not_follow_the_noise_draw():
    # The 10 rad/s mode (damping 0.5 %) has about 2 of the 1000 lines in its half-power band. With the
    # variances given, the standard deviation of its natural frequency depends on the draw only
    # through the estimate (relative errors near 1e-4) and the one scale of the residual, estimated
    # from 4000 real terms (its square root off by about 1 % of itself): its spread over 12 draws
    # stays near 1 %, within 5 %. A per-line sandwich takes the mode's variance from the residuals
    # of its few lines, and spread by 26 % over the same draws.
    truth = modal_system(FREQUENCIES[:2], DAMPINGS[:2], 2, 1, seed=3)
    omega = OMEGA[::2]
    spread = []
    for seed in range(12):
        model = moli.identify(noisy(truth, omega, 0.02, seed), order=4).model
        spread.append([mode.natural_frequency_std for mode in moli.modes(model)])
    spread = np.array(spread)
    assert np.all(np.std(spread, axis=0) <= 0.05 * np.mean(spread, axis=0))

