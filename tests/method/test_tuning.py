"""Filter scoring: shared factorizations, feedthrough, stability bound, trend-blind J, zoom search,
joint tuning of several lists, presets."""

from unittest import mock
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import moli
from moli.errors import OptionError
import moli.method.tuning.criterion
from moli.method.least_squares.shared_factors import RegressionCache
from moli.method.tuning.criterion import FilterScorer, error_ratio, score_lists
from moli.method.tuning.barycenter import default_omega, grid, tune_filter, tune_filters


def _random_system(n, p, m, seed, radius=0.9):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= radius / np.max(np.abs(np.linalg.eigvals(A)))
    return A, rng.standard_normal((n, m)), rng.standard_normal((p, n))


def _data(A, B, C, D=None, N=400, seed=1, noise=0.0, x0=None):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((N, B.shape[1]))
    y = moli.StateSpaceModel(A, B, C, D).simulate(u, x0)
    y = y + noise * rng.standard_normal(y.shape)
    return np.concatenate([y, u], axis=1)


@pytest.mark.parametrize("indices", [(1, 1), (2, 1), (1, 3), (3, 2), (2, 4)])
def test_shared_factors_match_direct_estimation(indices):
    z = _data(*_random_system(4, 2, 2, seed=3), noise=0.1)
    omega = default_omega()
    direct = FilterScorer(z, indices, 1.0, 2.0)
    shared = FilterScorer(z, indices, 1.0, 2.0, RegressionCache(z, 2))
    J1, (A1, B1, C1) = direct.score(omega)
    J2, (A2, B2, C2) = shared.score(omega)
    # same least-squares problems through R instead of X: agreement to round-off, amplified
    # by the condition of the regressors (below 1e6 here), so 1e-8 on O(1) quantities
    np.testing.assert_allclose(J2, J1, atol=1e-8)
    np.testing.assert_allclose(A2, A1, atol=1e-8)
    np.testing.assert_allclose(B2, B1, atol=1e-8)
    np.testing.assert_allclose(C2, C1, atol=1e-8)


def test_feedthrough_is_recovered_exactly_on_noise_free_data():
    A, B, C = _random_system(4, 2, 2, seed=5)
    D = np.array([[0.7, -0.3], [0.0, 0.4]])
    z = _data(A, B, C, D)
    scorer = FilterScorer(z, (2, 2), 1.0, 2.0, RegressionCache(z, 2, feedthrough=True))
    J, (Ah, Bh, Ch, Dh) = scorer.score(np.array([[0.5, 0.8], [1.2, 1.1]]))
    # noise-free data, any valid filter: the fit is exact (residuals at round-off)
    assert np.all(J < 1e-18)
    np.testing.assert_allclose(Dh[0], D, atol=1e-9)
    truth = moli.StateSpaceModel(A, B, C, D).markov(12)
    fitted = moli.StateSpaceModel(Ah[1], Bh[1], Ch[1], Dh[1]).markov(12)
    np.testing.assert_allclose(fitted, truth, atol=1e-8)


def test_auto_feedthrough_drops_an_absent_one_and_keeps_a_present_one():
    A, B, C = _random_system(4, 2, 2, seed=7)
    eta = np.array([[0.5, 0.8]])
    # strictly proper plant, small white output noise: no output passes the 0.1 % test
    z = _data(A, B, C, noise=0.01, N=600)
    _, mats = FilterScorer(z, (2, 2), 1.0, 2.0, RegressionCache(z, 2, "auto")).score(eta)
    assert np.all(mats[3] == 0.0)
    # a feedthrough of 0.5 on output 2 only is far above the noise
    D = np.array([[0.0, 0.0], [0.5, 0.0]])
    z = _data(A, B, C, D, noise=0.01, N=600)
    _, mats = FilterScorer(z, (2, 2), 1.0, 2.0, RegressionCache(z, 2, "auto")).score(eta)
    assert np.all(mats[3][0, 0] == 0.0)
    # the estimate of the present entry is within a few noise-induced standard errors
    assert mats[3][0, 1, 0] == pytest.approx(0.5, abs=0.05)


def test_auto_feedthrough_splits_a_duplicated_input_evenly():
    # two identical input channels make the regressors rank deficient: the tested
    # solve falls back to the minimum-norm solution, which gives each copy half of
    # the true input's coefficients
    A, B, C = _random_system(4, 2, 1, seed=9)
    D = np.array([[0.6], [0.0]])
    z = _data(A, B, C, D)
    z = np.concatenate([z, z[:, 2:]], axis=1)
    _, (Ah, Bh, Ch, Dh) = FilterScorer(z, (2, 2), 1.0, 2.0, RegressionCache(z, 2, "auto")).score(
        np.array([[0.5, 0.8]])
    )
    # noise-free data: exact fit, so round-off (amplified by the conditioning) is the only error
    np.testing.assert_allclose(Dh[0], [[0.3, 0.3], [0.0, 0.0]], atol=1e-8)
    np.testing.assert_allclose(Bh[0, :, 0], Bh[0, :, 1], atol=1e-8)
    truth = moli.StateSpaceModel(A, B, C, D).markov(12)
    fitted = moli.StateSpaceModel(Ah[0], Bh[0], Ch[0], Dh[0]).markov(12)
    np.testing.assert_allclose(fitted.sum(axis=-1), truth[..., 0], atol=1e-8)


def test_bad_feedthrough_choice_raises():
    with pytest.raises(OptionError, match="feedthrough"):
        RegressionCache(np.zeros((10, 2)), 1, feedthrough="sometimes")


def test_stability_bound_gives_the_worst_score():
    A, B, C = _random_system(2, 1, 1, seed=2, radius=0.9)
    z = _data(A, B, C)
    scorer = FilterScorer(z, (2,), 1.0, 2.0, RegressionCache(z, 1), max_radius=0.5)
    J, (Ah, _, _) = scorer.score(default_omega())
    # every exact fit has the plant's pole modulus 0.9 >= 0.5: all score J = 1
    assert np.all(np.max(np.abs(np.linalg.eigvals(Ah)), axis=1) == pytest.approx(0.9))
    assert np.all(J == 1.0)


def test_stability_rule_equals_fit_score_then_worst_for_slow_poles():
    # the rule skips the pole radii of models that leave every output's variance (already
    # the worst J); the result must be the fit score with every slow model set to 1
    A, B, C = _random_system(3, 2, 1, seed=6, radius=0.8)
    z = _data(A, B, C, noise=0.05)
    scorer = FilterScorer(z, (2, 1), 1.0, 2.0, max_radius=0.9)
    loud = C * np.array([[50.0], [1.0]])       # the first output's error exceeds its variance
    # the plant, a slow copy that still fits, a fast copy, a stable and a slow model that
    # miss both outputs, and a slow one that misses only the first
    batch_A = np.stack([A, 1.2 * A, 0.5 * A, A, 1.2 * A, 1.2 * A])
    batch_B = np.stack([B, B, B, 50.0 * B, 50.0 * B, B])
    batch_C = np.stack([C, C, C, C, C, loud])
    fit_only = scorer.criterion((batch_A, batch_B, batch_C), radius_rule=False)
    ruled = scorer.criterion((batch_A, batch_B, batch_C))
    slow = np.max(np.abs(np.linalg.eigvals(batch_A)), axis=1) >= 0.9
    assert slow.tolist() == [False, True, False, False, True, True]
    assert fit_only[1] < 1.0 and fit_only[3] == 1.0 and 0.5 <= fit_only[5] < 1.0
    np.testing.assert_array_equal(ruled, np.where(slow, 1.0, fit_only))


def test_initial_response_fits_a_free_response_exactly():
    from moli.method.tuning.criterion import _initial_response

    A, B, C = _random_system(3, 2, 1, seed=4, radius=0.95)
    x0 = np.array([3.0, -2.0, 1.0])
    free = moli.StateSpaceModel(A, B, C).simulate(np.zeros((200, 1)), x0)
    # the free response lies in the span of the basis: least squares recovers it to round-off
    np.testing.assert_allclose(_initial_response(A[None], C[None], free[None])[0], free, atol=1e-9)


def test_estimated_initial_state_never_scores_worse():
    A, B, C = _random_system(2, 1, 1, seed=4, radius=0.95)
    z = _data(A, B, C, x0=np.array([3.0, -2.0]), noise=0.05)
    omega = default_omega()
    zero = FilterScorer(z, (2,), 1.0, 2.0, RegressionCache(z, 1)).score(omega)[0]
    fitted = FilterScorer(z, (2,), 1.0, 2.0, RegressionCache(z, 1), x0="estimate").score(omega)[0]
    # x0 = 0 is one of the initial states the least squares chooses from
    assert np.all(fitted <= zero + 1e-12)
    assert fitted.min() < zero.min()


def test_the_fast_preset_finds_the_exact_plant_on_noise_free_records():
    plant = moli.StateSpaceModel(*_random_system(3, 2, 2, seed=4, radius=0.8))
    rng = np.random.default_rng(4)
    # two experiments from rest and no centring: every order from the true one up fits
    # the validation record exactly from the zero state, every lower one cannot
    records = []
    for N in (300, 200):
        u = rng.standard_normal((N, 2))
        records.append(moli.IOData(plant.simulate(u), u))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")       # noise-free data: ill-conditioned candidates expected
        result = moli.identify(*records, nmax=5, center=False, preset="fast")
    assert result.options == moli.IdentifyOptions.fast(nmax=5, center=False)
    assert result.selected.order == 3
    # exact equations: round-off times the regressions' condition only (below 1e-12 seen)
    np.testing.assert_allclose(result.model.markov(12), plant.markov(12), atol=1e-8)
    # the noise model is kept: the result still predicts and carries its bands
    assert result.model.K is not None and result.model.noise_cov is not None


def test_zoom_never_ends_worse_than_the_grid():
    z = _data(*_random_system(4, 2, 2, seed=8), noise=0.2)
    scorer = FilterScorer(z, (2, 2), 1.0, 2.0, RegressionCache(z, 2))
    omega = grid(np.geomspace(0.1, 1.0, 3), [0.6, 1.1])
    result = tune_filter(scorer, omega, "zoom", iterations=3)
    assert result.J <= result.J_grid_best
    assert result.evaluations > len(omega)
    # the chosen point stays inside omega's bounding box
    assert omega[:, 0].min() - 1e-12 <= result.eta[0] <= omega[:, 0].max() + 1e-12
    assert omega[:, 1].min() <= result.eta[1] <= omega[:, 1].max()


def test_presets_and_their_errors():
    est, val = moli.example_data(N=500, seed=2).split(350)
    paper = moli.identify(est, val, nmax=4, preset="paper")
    assert (paper.options.tuning, paper.options.feedthrough, paper.max_radius) == (
        "random", False, None)
    assert np.all(paper.model.D == 0.0)
    bounded = moli.identify(est, val, nmax=4, preset="bounded")
    # "auto" radius: time constants up to a tenth of the 350-sample record
    assert bounded.max_radius == pytest.approx(np.exp(-10 / 350))
    assert all(np.max(np.abs(st.model.poles())) < bounded.max_radius for st in bounded.path
               if st.J < 1.0)
    with pytest.raises(OptionError, match="preset"):
        moli.identify(est, val, nmax=4, preset="quick")
    with pytest.raises(OptionError, match="refine"):
        moli.identify(est, val, nmax=4, refine="all")
    with pytest.raises(OptionError, match="max_radius"):
        moli.identify(est, val, nmax=4, max_radius=1.5)
    with pytest.raises(OptionError, match="max_radius"):
        moli.identify(est, val, nmax=4, max_radius=True)
    default = moli.identify(est, val, nmax=4)
    assert default.max_radius == 1.0
    assert all(st.stable for st in default.path if st.J < 1.0)
    # the default's bound on candidates the fit alone would score: on this record four
    # filters of the list (1, 2, 1) give an unstable model; those, and only those, score 1
    e = est.remove_means()
    z = np.concatenate([e.y, e.u], axis=1)
    free = FilterScorer(z, (1, 2, 1), 1.0, 2.0, RegressionCache(z, 3), trend_degree=2)
    J_free, (A, _, _) = free.score(default_omega())
    unstable = np.max(np.abs(np.linalg.eigvals(A)), axis=1) >= 1.0
    assert unstable.sum() == 4
    bounded = FilterScorer(z, (1, 2, 1), 1.0, 2.0, RegressionCache(z, 3), max_radius=1.0, trend_degree=2)
    J_bounded, _ = bounded.score(default_omega())
    assert np.all(J_bounded[unstable] == 1.0) and np.all(J_free[unstable] < 1.0)
    np.testing.assert_array_equal(J_bounded[~unstable], J_free[~unstable])
    assert moli.identify(est, val, nmax=4, max_radius="none").max_radius is None


@settings(max_examples=40, deadline=None)
@given(
    degree=st.integers(0, 5),
    coeffs=st.lists(st.floats(-5, 5), min_size=6, max_size=6),
    seed=st.integers(0, 2**16),
    models=st.integers(1, 3),
)
def test_trend_blind_error_ignores_a_polynomial_drift(degree, coeffs, seed, models):
    rng = np.random.default_rng(seed)
    N = 200
    y = rng.standard_normal((N, 2)).cumsum(axis=0)
    yhat = rng.standard_normal((models, N, 2))
    kept = yhat.copy()
    drift = np.polynomial.legendre.legval(np.linspace(-1, 1, N), coeffs[: degree + 1])
    plain = error_ratio(y, yhat, degree)
    # the error is formed in a buffer of its own: the simulations passed in stay as they were
    np.testing.assert_array_equal(yhat, kept)
    shifted = error_ratio(y, yhat + drift[None, :, None], degree)
    # a drift inside the removed polynomial space changes nothing (up to round-off)
    np.testing.assert_allclose(shifted, plain, rtol=1e-9, atol=1e-12)
    # degree 0 is the paper's ratio; a larger degree never scores worse
    paper = np.minimum(np.var(y[None] - yhat, axis=1) / np.var(y, axis=0), 1.0)
    np.testing.assert_allclose(error_ratio(y, yhat, 0), paper, rtol=1e-12)
    assert np.all(plain <= error_ratio(y, yhat, max(degree - 1, 0)) + 1e-12)


def test_trend_degree_zero_is_the_papers_J_and_bad_degrees_raise():
    z = _data(*_random_system(3, 2, 2, seed=5), noise=0.1)
    y, u = z[:, :2], z[:, 2:]
    omega = default_omega()
    zero, (A, B, C) = FilterScorer(z, (2, 1), 1.0, 2.0, RegressionCache(z, 2), trend_degree=0).score(omega)
    # the paper's J written out: each model simulated from rest, error variance over output variance
    paper = [np.mean(np.minimum(np.var(y - moli.StateSpaceModel(a, b, c).simulate(u), axis=0)
                                / np.var(y, axis=0), 1.0)) for a, b, c in zip(A, B, C)]
    np.testing.assert_allclose(zero, paper, rtol=1e-9)
    quadratic = FilterScorer(z, (2, 1), 1.0, 2.0, RegressionCache(z, 2), trend_degree=2).score(omega)[0]
    # same models, less of the error counted
    assert np.all(quadratic <= zero + 1e-12) and np.any(quadratic < zero - 1e-6)
    with pytest.raises(OptionError, match="trend_degree"):
        FilterScorer(z, (2, 1), 1.0, 2.0, trend_degree=-1)
    est, val = moli.example_data(N=400, seed=2).split(300)
    for bad in (-1, 6, 1.5, True, "2"):
        with pytest.raises(OptionError, match="trend_degree"):
            moli.identify(est, val, nmax=4, trend_degree=bad)
    assert moli.identify(est, val, nmax=4).options.trend_degree == 2


_JOINT_DATA = _data(*_random_system(5, 3, 2, seed=11), N=300, noise=0.1)


@settings(max_examples=12, deadline=None)
@given(
    lists=st.lists(st.tuples(st.integers(1, 4), st.integers(1, 4), st.integers(1, 4)), min_size=1, max_size=5),
    method=st.sampled_from(["grid", "random", "zoom"]),
    feedthrough=st.sampled_from([False, "auto"]),
    chunked=st.booleans(),
)
def test_joint_tuning_gives_each_list_its_own_result(lists, method, feedthrough, chunked):
    z = _JOINT_DATA
    omega = grid(np.geomspace(0.1, 1.2, 3), [0.6, 1.1])

    def scorers(cache):
        return [FilterScorer(z, ix, 1.0, 2.0, cache, max_radius=1.0, trend_degree=2) for ix in lists]

    alone = [tune_filter(sc, omega, method, 2, seed) for seed, sc in enumerate(scorers(RegressionCache(z, 3, feedthrough)))]
    # a batch limit of one value puts every list in a chunk of its own; the default joins
    # them all (5 lists of 6 candidates, 300 samples, 3 outputs: 27,000 values)
    limit = 1 if chunked else moli.method.tuning.criterion.JOINT_BATCH_VALUES
    with mock.patch.object(moli.method.tuning.criterion, "JOINT_BATCH_VALUES", limit):
        joint = tune_filters(scorers(RegressionCache(z, 3, feedthrough)), omega, method, 2, range(len(lists)))
    for a, b in zip(alone, joint):
        # the same problems, stacked differently: LAPACK and the products work matrix by
        # matrix, so the results agree to the last bits (1e-12 leaves room for the BLAS)
        np.testing.assert_allclose(b.J, a.J, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(b.eta, a.eta, rtol=1e-12)
        np.testing.assert_allclose(b.A, a.A, rtol=1e-9, atol=1e-12)
        assert b.evaluations == a.evaluations


def test_lists_scored_together_must_share_record_and_criterion():
    z = _data(*_random_system(4, 2, 2, seed=3), noise=0.1)
    cache = RegressionCache(z, 2)
    eta = default_omega()[:2]
    with pytest.raises(OptionError, match="share"):
        score_lists([FilterScorer(z, (1, 2), 1.0, 2.0, cache), FilterScorer(z, (2, 1), 1.0, 2.0, cache, trend_degree=1)],
                    [eta, eta])
    with pytest.raises(OptionError, match="share"):
        score_lists([FilterScorer(z, (1, 2), 1.0, 2.0, cache), FilterScorer(z.copy(), (2, 1), 1.0, 2.0, cache)],
                    [eta, eta])
    with pytest.raises(OptionError, match="one seed per scorer"):
        tune_filters([FilterScorer(z, (1, 2), 1.0, 2.0, cache)], eta, "grid", 0, [1, 2])
