"""The covariance of the least-squares parameters and of the model's matrices."""

from __future__ import annotations

import json

import numpy as np
import pytest

import moli
import moli.method.pipeline.finishing as finishing
from moli.method.least_squares.sandwich import _moving_sums, matrix_directions, sandwich_factor
from moli.method.least_squares.estimation import output_regressors
from moli.method.least_squares.realization import observer_form_matrices
from moli.method.tuning.criterion import _realize_feedthrough

# A resonant SISO plant of order 2 (poles 0.8 exp(±0.4j), a zero at -0.5) and the
# filter identify's J-tuning picks on its records (wc 0.43-0.51, zeta 0.65-0.73 on four
# seeded records of 1000 samples with the noise below): the fixed structure of the
# coverage test is the true one, the filter the one the search would use.
POLE = 0.8 * np.exp(0.4j)
DENOMINATOR = np.real(np.poly([POLE, np.conj(POLE)]))
PLANT = moli.StateSpaceModel([[-DENOMINATOR[1], -DENOMINATOR[2]], [1.0, 0.0]], [[1.0], [0.0]], [[1.0, 0.5]])
FILTER = moli.filter_polynomial(0.45, 0.7, [2])
NOISE = 0.3  # output noise standard deviation; the output's own is 4.4


def _record(N: int, rng: np.random.Generator) -> moli.IOData:
    u = rng.standard_normal(N)
    return moli.IOData(PLANT.simulate(u) + NOISE * rng.standard_normal((N, 1)), u)


def _true_gain(omega: np.ndarray) -> np.ndarray:
    z = np.exp(1j * omega)
    return np.abs((z + 0.5) / (z**2 + DENOMINATOR[1] * z + DENOMINATOR[2]))


def test_magnitude_bands_cover_the_true_gain():
    rng = np.random.default_rng(2024)
    omega = np.linspace(0.05, 3.0, 30)
    truth = _true_gain(omega)
    covered = []
    for _ in range(200):
        lower, upper = moli.estimate(_record(500, rng), [2], FILTER).magnitude_bands(omega)
        covered.append((lower[:, 0, 0] <= truth) & (truth <= upper[:, 0, 0]))
    share = np.mean(covered)
    # 95 % bands, measured 0.939. The frequencies of one run are correlated, so the
    # binomial error is at most that of 200 independent runs, sqrt(0.94 * 0.06 / 200)
    # = 0.017: the accepted 0.85-0.99 is over 3 of those from the measured value
    assert 0.85 <= share <= 0.99


def test_gauss_bands_agree_with_monte_carlo_on_a_well_conditioned_case():
    model = moli.estimate(_record(2000, np.random.default_rng(1)), [2], FILTER)
    omega = np.linspace(0.05, 3.0, 30)
    data = _record(200, np.random.default_rng(2))
    pairs = [
        (model.magnitude_bands(omega), model.magnitude_bands(omega, method="monte_carlo", samples=4000, seed=3)),
        (model.step_bands(40), model.step_bands(40, method="monte_carlo", samples=4000, seed=3)),
        (moli.simulation_bands(model, data),
         moli.simulation_bands(model, data, method="monte_carlo", samples=4000, seed=3)),
    ]
    for gauss, drawn in pairs:
        half = (gauss[1] - gauss[0]) / 2
        live = half > 0          # the step response's first sample (D = 0) has no spread
        # a 2.5 % quantile of 4000 normal draws is off by sqrt(.025 .975 / 4000) / phi(1.96)
        # = 0.042 standard deviations, 2 % of the half-width: 10 % is five of those at the
        # worst of the 60-80 points, with room for the nonlinearity of the responses in the
        # matrices (measured at most 6.2 %, 4.4 % and 6.1 %)
        for g, d in zip(gauss, drawn):
            assert np.max(np.abs(d - g)[live] / half[live]) < 0.1


def test_covariance_shrinks_like_one_over_n():
    def scaled_trace(N: int) -> float:
        values = [N * np.sum(moli.estimate(_record(N, np.random.default_rng([N, s])), [2], FILTER).cov_factor ** 2)
                  for s in range(3)]
        return float(np.mean(values))

    # N tr Cov(vec[A, B, C, D]) is constant when the covariance falls like 1/N. One
    # record's value scatters by about 6 % at N = 1000 (the long-run covariance is
    # itself estimated), so a mean of 3 by under 4 % and a ratio of two by about 5 %:
    # 15 % is three of those (measured 0.263, 0.248, 0.252 at N = 1000, 4000, 16000)
    assert scaled_trace(8000) == pytest.approx(scaled_trace(2000), rel=0.15)


def test_jacobian_matches_finite_differences_of_the_realization():
    rng = np.random.default_rng(4)
    indices, p, m = (2, 1, 2), 3, 2
    alphas = moli.divisors(moli.filter_polynomial(0.6, 0.7, indices), indices)
    through = np.array([True, False, True])
    sizes = [(p + m) * l + j + (m if through[j] else 0) for j, l in enumerate(indices)]
    theta = 0.3 * rng.standard_normal(sum(sizes))

    def realize(vector: np.ndarray) -> np.ndarray:
        parts, at = [], 0
        for j, size in enumerate(sizes):
            part = vector[at : at + size]
            parts.append((part if through[j] else np.concatenate([part, np.zeros(m)]))[None])
            at += size
        return np.concatenate([x[0].ravel() for x in _realize_feedthrough(parts, [alphas], indices, m)])

    A, B, C, D = _realize_feedthrough(
        [np.concatenate([t, np.zeros(m)])[None] if not f else t[None]
         for t, f in zip(np.split(theta, np.cumsum(sizes)[:-1]), through)], [alphas], indices, m)
    injection = observer_form_matrices(
        [t[None, : (p + m) * l + j] for j, (t, l) in enumerate(zip(np.split(theta, np.cumsum(sizes)[:-1]), indices))],
        [alphas], indices, m)[3][0]
    directions = rng.standard_normal((5, theta.size))
    analytic = matrix_directions(indices, C[0], D[0], injection, through, directions)
    step = 1e-6
    numeric = np.array([(realize(theta + step * d) - realize(theta - step * d)) / (2 * step) for d in directions])
    # central differences: truncation ~ step^2 times the (order-one) curvature, round-off
    # ~ 1e-16 / step = 1e-10, so 1e-7 of the scale is far above both
    np.testing.assert_allclose(analytic, numeric, atol=1e-7 * np.abs(numeric).max())


def test_moving_sums_give_the_bartlett_weighted_autocovariances():
    rng = np.random.default_rng(5)
    scores = rng.standard_normal((50, 3))
    width = 4
    sums = np.concatenate([_moving_sums(scores, width, a, min(a + 7, 53)) for a in range(0, 53, 7)])
    expected = sum(
        (1 - abs(h) / width) * (scores[max(h, 0) : 50 + min(h, 0)].T @ scores[max(-h, 0) : 50 - max(h, 0)])
        for h in range(-width + 1, width)
    )
    # the same sums regrouped: round-off only
    np.testing.assert_allclose(sums.T @ sums / width, expected, atol=1e-12 * np.abs(expected).max())


def test_sandwich_is_the_newey_west_formula_for_every_output_together():
    rng = np.random.default_rng(6)
    phis = [rng.standard_normal((60, 3)), rng.standard_normal((60, 2))]
    noise = np.convolve(rng.standard_normal(62), [1.0, 0.8, 0.5], mode="valid")   # coloured
    targets = np.column_stack([phis[0] @ [1.0, -2.0, 0.5] + noise, phis[1] @ [0.3, 0.2] + noise])
    factor, thetas, width = sandwich_factor(phis, targets)
    # the reference formula, with the inverse of the normal equations the code avoids
    scores = np.concatenate([phi * (t - phi @ np.linalg.lstsq(phi, t, rcond=None)[0])[:, None]
                             for phi, t in zip(phis, targets.T)], axis=1)
    middle = sum((1 - abs(h) / width) * scores[max(h, 0) : 60 + min(h, 0)].T @ scores[max(-h, 0) : 60 - max(h, 0)]
                 for h in range(-width + 1, width))
    bread = np.zeros((5, 5))
    bread[:3, :3] = np.linalg.inv(phis[0].T @ phis[0]) * np.sqrt(60 / 57)
    bread[3:, 3:] = np.linalg.inv(phis[1].T @ phis[1]) * np.sqrt(60 / 58)
    assert width > 1                                   # the coloured scores ask for lags
    # the same sums by triangular solves instead: round-off only
    np.testing.assert_allclose(factor.T @ factor, bread @ middle @ bread, rtol=1e-9, atol=1e-15)
    for phi, target, theta in zip(phis, targets.T, thetas):
        np.testing.assert_allclose(theta, np.linalg.lstsq(phi, target, rcond=None)[0], rtol=1e-10)


def test_estimate_covariance_rebuilds_what_estimate_attached_and_keeps_its_input():
    data = _record(600, np.random.default_rng(7))
    model = moli.estimate(data, [2], FILTER)
    bare = moli.StateSpaceModel(model.A, model.B, model.C, indices=model.indices, alpha=model.alpha)
    attached = moli.estimate_covariance(bare, data)
    assert bare.cov_factor is None and "covariance" not in bare.info
    # two routes to the same least squares (the model's matrices against a fresh solve)
    np.testing.assert_allclose(attached.cov_factor @ attached.cov_factor.T,
                               model.cov_factor @ model.cov_factor.T, rtol=1e-8, atol=1e-14)
    assert attached.info["covariance"] == model.info["covariance"]


def test_identify_attaches_the_covariance_and_changes_nothing_else(monkeypatch):
    est, val = moli.example_data(N=600, seed=1).split(400)
    result = moli.identify(est, val, nmax=6)
    monkeypatch.setattr(finishing, "estimate_covariance", lambda model, data: model)
    plain = moli.identify(est, val, nmax=6)
    model = result.model
    assert model.cov_factor is not None and plain.model.cov_factor is None
    for name in ("A", "B", "C", "D", "K", "noise_cov"):
        np.testing.assert_array_equal(getattr(model, name), getattr(plain.model, name))
    assert [st.vaf.tolist() for st in result.path] == [st.vaf.tolist() for st in plain.path]
    record = model.info["covariance"]
    # a refined model's covariance is its output-error problem's (every sample a row), the
    # least squares' has the rows after the filters' start
    refined = record["method"].startswith("output-error")
    assert record["rows"] == (est.N if refined else est.N - max(model.indices)) and record["kernel_width"] >= 1
    assert model.cov_factor.shape[0] == model.n * (model.n + model.m + model.p) + model.p * model.m
    # the feedthrough is estimated (improved preset): its uncertainty reaches D
    assert np.any(model.cov_factor[-model.p * model.m :] != 0)
    again = moli.models.model_from_dict(json.loads(json.dumps(model.to_dict())))
    np.testing.assert_array_equal(again.cov_factor, model.cov_factor)
    np.testing.assert_array_equal(again.magnitude_bands([0.1, 1.0])[1], model.magnitude_bands([0.1, 1.0])[1])


def test_per_output_filters_and_refined_models_get_a_covariance():
    est, val = moli.example_data(N=600, seed=3).split(400)
    # the earlier default's grid gives this record per-output filters (the wide grid keeps one)
    refined = moli.identify(est, val, moli.IdentifyOptions.improved(nmax=8, refine=True)).model
    assert refined.info["refined"] and refined.divisors is not None and refined.cov_factor is not None
    lower, upper = refined.magnitude_bands(np.linspace(0.1, 3.0, 5))
    assert np.all(lower <= upper)


def test_rank_deficient_problems_leave_no_covariance_and_say_why():
    rng = np.random.default_rng(8)
    plant = moli.StateSpaceModel(np.diag([0.8, 0.5]), rng.standard_normal((2, 2)), np.eye(2))
    u = rng.standard_normal((300, 2))
    # noise-free, with a current earlier output that the filtered regressors already span
    with pytest.warns(moli.IllConditionedWarning):
        model = moli.estimate(moli.IOData(plant.simulate(u), u), [1, 1], moli.filter_polynomial(0.5, 1.0, [1, 1]))
    assert model.cov_factor is None and "rank deficient" in model.info["covariance"]["reason"]
    with pytest.raises(moli.DataError, match="carries no covariance"):
        model.magnitude_bands([0.1])


def test_estimate_covariance_errors():
    data = _record(300, np.random.default_rng(9))
    model = moli.estimate(data, [2], FILTER)
    with pytest.raises(moli.DataError, match="model must be a StateSpaceModel"):
        moli.estimate_covariance("model", data)
    with pytest.raises(moli.DataError, match="indices and filter polynomials"):
        moli.estimate_covariance(moli.StateSpaceModel(model.A, model.B, model.C), data)
    with pytest.raises(moli.DataError, match="data must be an IOData"):
        moli.estimate_covariance(model, data.y)
    with pytest.raises(moli.DataError, match="1 outputs and 1 inputs"):
        moli.estimate_covariance(model, moli.IOData(np.zeros((300, 2)), data.u))
    with pytest.raises(moli.DataError, match="too few samples"):
        moli.estimate_covariance(model, data[:6])
    with pytest.raises(moli.OptionError, match="covariance must be True or False"):
        moli.estimate(data, [2], FILTER, covariance="yes")
    bare = moli.estimate(data, [2], FILTER, covariance=False)
    assert bare.cov_factor is None and "covariance" not in bare.info
    np.testing.assert_array_equal(bare.A, model.A)


def test_output_regressors_are_the_estimation_problems():
    data = _record(200, np.random.default_rng(10))
    z = np.concatenate([data.y, data.u], axis=1)
    (phi,) = output_regressors(z, (2,), [FILTER])
    theta = np.linalg.lstsq(phi, data.y[2:, 0], rcond=None)[0]
    A, B, C, _ = observer_form_matrices([theta[None]], [[FILTER]], (2,), 1)
    # the same least squares as moli.estimate, solved another way: round-off only
    np.testing.assert_allclose(A[0], moli.estimate(data, [2], FILTER).A, atol=1e-10)
