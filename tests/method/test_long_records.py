"""Long records: row-block factors, bounded criterion batches, the search window."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.signal import lfilter

import moli
from moli.method.least_squares import estimation, row_blocks, sandwich, shared_factors
from moli.method.tuning import criterion
from moli.method.uncertainty import matrix_covariance
from moli.method.structure.filters import filter_polynomial
from moli.method.search.long_records import search_window
from moli.numerics import triangular


def _record(N: int, seed: int = 0, noise: float = 0.1) -> moli.IOData:
    rng = np.random.default_rng(seed)
    A = np.array([[0.8, 0.2, 0.0], [-0.2, 0.8, 0.0], [0.0, 0.0, 0.5]])
    B = rng.standard_normal((3, 2))
    C = rng.standard_normal((2, 3))
    u = rng.standard_normal((N, 2))
    y = moli.StateSpaceModel(A, B, C).simulate(u)
    return moli.IOData(y + noise * rng.standard_normal(y.shape), u)


@pytest.mark.parametrize("block_rows", [1, 3, 7, 1000])
def test_lagged_blocks_are_the_delays_of_each_segment_filtered_from_rest(block_rows):
    rng = np.random.default_rng(1)
    signals = rng.standard_normal((3, 60))
    a = np.array([1.0, -1.2, 0.5, -0.1])          # degree 3, stable
    segments = [(0, 25), (25, 26), (30, 60)]       # the middle one too short for a row
    got = {k0 + i: lagged[:, :, i].copy()
           for k0, k1, lagged in row_blocks.lagged_blocks(signals, a, 4, segments, block_rows)
           for i in range(k1 - k0)}
    expected = {}
    for start, stop in segments:
        base = lfilter([1.0], a, signals[:, start:stop], axis=1)   # from rest at the segment's start
        for k in range(start + 4, stop):
            expected[k] = np.stack([base[:, k - start - 3 + t] for t in range(3)], axis=1)
    assert got.keys() == expected.keys()
    for k in expected:
        # lfilter with a carried state repeats the same recursion: equal up to round-off
        np.testing.assert_allclose(got[k], expected[k], rtol=1e-12, atol=1e-14)


def test_streamed_factor_has_the_gram_matrix_of_the_whole_matrix():
    X = np.random.default_rng(2).standard_normal((1000, 7))
    R = triangular.streamed_factor(X[i : i + 97].T for i in range(0, 1000, 97))
    assert R.shape == (7, 7) and np.allclose(np.tril(R, -1), 0.0)
    # R^T R = X^T X in exact arithmetic; Householder QR keeps it to a few eps of |X|^2
    np.testing.assert_allclose(R.T @ R, X.T @ X, rtol=0, atol=1e-11 * np.abs(X.T @ X).max())


def _cache_solutions(z, alpha, starts=(0,)):
    cache = shared_factors.RegressionCache(z, 2, "auto", starts)
    full, parts = cache.filters(np.array([[0.6, 0.7]]), (3, 2), 1.0, 2.0)
    return cache.thetas(cache.solve([(full, parts, (3, 2))])[0], (3, 2))


def test_cache_streamed_in_row_blocks_solves_the_same_problems(monkeypatch):
    data = _record(3000)
    z = np.concatenate([data.y, data.u], axis=1)
    whole = _cache_solutions(z, None)
    monkeypatch.setattr(shared_factors, "WHOLE_ROWS", 100)
    streamed = _cache_solutions(z, None)
    # same least-squares problems, factored in another order: round-off apart
    for a, b in zip(whole, streamed):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)


def test_cache_folds_a_long_window_in_blocks_to_the_same_problems(monkeypatch):
    data = _record(3000)
    z = np.concatenate([data.y, data.u], axis=1)
    whole = _cache_solutions(z, None)
    monkeypatch.setattr(shared_factors, "WHOLE_TALL_ROWS", 1000)
    monkeypatch.setattr(triangular, "WHOLE_TALL_ROWS", 1000)
    monkeypatch.setattr(triangular, "TALL_BLOCK_ROWS", 700)
    folded = _cache_solutions(z, None)
    # same least-squares problems, factored in another order: round-off apart
    for a, b in zip(whole, folded):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)


def test_cache_segments_restart_the_filters():
    """Two segments give the problems of both records' rows together (filters from rest in each)."""
    first, second = _record(1500, 3), _record(1200, 4)
    z = np.concatenate([np.concatenate([d.y, d.u], axis=1) for d in (first, second)])
    split = _cache_solutions(z, None, (0, 1500))
    # independent route: the direct regressors of each record, stacked, solved by lstsq
    alpha = moli.filter_polynomial(0.6, 0.7, (3, 2))
    parts = moli.method.structure.filters.divisors(alpha, (3, 2))
    for j in range(2):
        phis = [estimation.output_regressors(np.concatenate([d.y, d.u], axis=1), (3, 2), parts)[j]
                for d in (first, second)]
        rows = np.vstack(phis)
        rows = np.column_stack([rows, np.vstack([d.u[3:] for d in (first, second)])])
        target = np.concatenate([d.y[3:, j] for d in (first, second)])
        theta = np.linalg.lstsq(rows, target, rcond=None)[0]
        got = split[j][0]
        if np.all(got[-2:] == 0):                # the F-test left the feedthrough out
            theta = np.append(np.linalg.lstsq(rows[:, :-2], target, rcond=None)[0], [0.0, 0.0])
        np.testing.assert_allclose(got, theta, rtol=1e-8, atol=1e-10)


def test_streamed_covariance_refuses_a_rank_deficient_problem():
    rng = np.random.default_rng(6)
    phi = rng.standard_normal((300, 2))
    phi[:, 1] = phi[:, 0]
    with pytest.raises(moli.DataError, match="rank deficient"):
        sandwich.streamed_sandwich_factor(lambda: iter([([phi], rng.standard_normal((300, 1)))]))


def test_criterion_in_bounded_batches_scores_each_model_alike(monkeypatch):
    data = _record(2000, 7)
    z = np.concatenate([data.y, data.u], axis=1)
    scorer = criterion.FilterScorer(z, (2, 1), 1.0, 2.0, shared_factors.RegressionCache(z, 2, "auto"),
                                  trend_degree=2, max_radius=1.0)
    etas = moli.method.tuning.barycenter.default_omega(1.0, "wide")
    models = scorer.fit(etas)
    whole = scorer.criterion(models)
    monkeypatch.setattr(criterion, "CRITERION_BATCH_VALUES", 3 * z.shape[0] * 2)
    # each model's simulation and score do not depend on its batch, but a batch of
    # another size may take another BLAS kernel (blocking, vector width), whose sums
    # round differently: a few ulps on some CPUs (relative 1.5e-16 seen on an AMD EPYC)
    np.testing.assert_allclose(scorer.criterion(models), whole, rtol=1e-12, atol=0)


def test_search_window_is_the_head_of_a_long_record():
    data = _record(1000).remove_means()
    assert search_window(data, None) is data and search_window(data, 1000) is data
    head = search_window(data, 600)
    np.testing.assert_array_equal(head.y, data.y[:600])
    np.testing.assert_array_equal(head.y_offset, data.y_offset)


def test_long_record_search_reestimates_the_selected_list_on_the_whole_record():
    data = _record(4000, 8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = moli.identify(data, nmax=4, search_samples=800, feedthrough=False,
                               output_filters=False, refine="none", noise_model=False)
    model = result.model
    assert model.info["search_samples"] == 800 and model.info["estimation_samples"] == result.estimation.N
    # the same list and filter estimated by moli.estimate (direct regressors, another
    # route to the same least squares) on the whole centred estimation record
    direct = moli.estimate(result.estimation, model.indices, model.alpha)
    for M, N in [(model.A, direct.A), (model.B, direct.B), (model.C, direct.C)]:
        np.testing.assert_allclose(M, N, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(result.selected.vaf, moli.compare(model, result.validation).vaf)
    assert "searched on the first 800" in result.summary()


def test_long_record_search_recovers_a_noise_free_plant():
    data = _record(3000, 9, noise=0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # not centred: exact recovery needs the plant's zero initial state, and removing
        # the means would add the response to a step at the record's start
        result = moli.identify(data, order=3, search_samples=600, refine="none", center=False)
    truth = moli.StateSpaceModel(*_plant(9))
    # exact recovery on noise-free data: Markov parameters to round-off of the fit
    np.testing.assert_allclose(result.model.markov(20), truth.markov(20), atol=1e-6)


def _plant(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    A = np.array([[0.8, 0.2, 0.0], [-0.2, 0.8, 0.0], [0.0, 0.0, 0.5]])
    return A, rng.standard_normal((3, 2)), rng.standard_normal((2, 3))


def test_screening_a_long_record_finds_what_the_whole_hankel_matrix_shows(monkeypatch):
    from moli.data import quality

    rng = np.random.default_rng(10)
    rich = rng.standard_normal((3000, 2))
    poor = np.column_stack([rich[:, 0], rich[:, 0] + 1e-7 * rng.standard_normal(3000)])
    cases = [(u, L, bounds) for u in (rich, poor) for L in (1, 3)
             for bounds in (((0, 3000),), ((0, 1400), (1400, 3000)))]
    whole = [quality._exciting(*case) for case in cases]
    monkeypatch.setattr(quality, "WHOLE_ROWS", 100)
    monkeypatch.setattr(quality, "BLOCK_ROWS", 250)
    # the blocked factor (of every segment's windows) has the Hankel matrix's singular
    # values: the same verdicts
    assert [quality._exciting(*case) for case in cases] == whole == [True] * 4 + [False] * 4


def test_auto_delays_of_a_long_record_come_from_its_search_window():
    rng = np.random.default_rng(11)
    u = rng.standard_normal((3000, 1))
    y = np.zeros((3000, 1))
    y[3:, 0] = u[:-3, 0] + 0.01 * rng.standard_normal(2997)     # a pure delay of 3 samples
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = moli.identify(moli.IOData(y, u), nmax=2, delays="auto", search_samples=600,
                               refine="none", noise_model=False)
    # y_k = u_(k-3): the first significant lag is 3, so the model's dead time is 2
    # (the MOLI regressors supply one step of delay themselves)
    assert result.model.input_delays == (2,)


def test_tall_factor_in_row_blocks_has_the_gram_matrix_of_the_whole(monkeypatch):
    X = np.random.default_rng(12).standard_normal((5000, 9))
    whole = triangular.tall_factor(X)
    # both Householder, so the same signs; X is well conditioned (Gaussian, 5000 x 9), so
    # two backward-stable factorizations agree to a few hundred eps of |R|
    reference = np.linalg.qr(X, mode="r")
    np.testing.assert_allclose(whole, reference, rtol=0, atol=1e-12 * np.abs(reference).max())
    monkeypatch.setattr(triangular, "WHOLE_TALL_ROWS", 1000)
    monkeypatch.setattr(triangular, "TALL_BLOCK_ROWS", 700)
    blocked = triangular.tall_factor(X)
    # sums of squares in blocks: the norms to round-off
    np.testing.assert_allclose(triangular.column_norms(X), np.linalg.norm(X, axis=0), rtol=1e-13)
    # Householder QR in another order: R^T R = X^T X to a few eps of |X|^2
    np.testing.assert_allclose(blocked.T @ blocked, whole.T @ whole, rtol=0, atol=1e-11 * np.abs(X.T @ X).max())


def test_streamed_covariance_of_segments_takes_no_lag_across_a_boundary():
    rng = np.random.default_rng(14)
    phis = [rng.standard_normal((900, 3)), rng.standard_normal((900, 2))]
    noise = np.convolve(rng.standard_normal(902), [1.0, 0.8, 0.5], mode="valid")   # coloured
    targets = np.column_stack([phis[0] @ [1.0, -2.0, 0.5] + noise, phis[1] @ [0.3, 0.2] + noise])
    breaks = [400, 650]
    # sandwich_factor with breaks is the sum of each segment's own Newey-West sum (test_segments)
    whole, _, width = sandwich.sandwich_factor(phis, targets, breaks)

    def blocks():                      # blocks of 97 rows: two of them straddle a boundary
        for i in range(0, 900, 97):
            yield [phi[i : i + 97] for phi in phis], targets[i : i + 97]

    streamed, _, streamed_width, rows = sandwich.streamed_sandwich_factor(blocks, breaks)
    assert (streamed_width, rows) == (width, 900) and width > 1
    # the same sums cumulated in other blocks: 1e-9 of the largest entry
    cov = whole.T @ whole
    np.testing.assert_allclose(streamed.T @ streamed, cov, rtol=0, atol=1e-9 * np.abs(cov).max())
    joined, _, _, _ = sandwich.streamed_sandwich_factor(blocks)
    assert not np.allclose(joined.T @ joined, cov, rtol=1e-6)      # the breaks do matter


@pytest.mark.parametrize("segments", [(6000,), (2500, 1800)], ids=["one segment", "two segments"])
def test_estimate_in_row_blocks_matches_the_whole_record(monkeypatch, segments):
    data = moli.merge([_record(n, 5 + i) for i, n in enumerate(segments)])
    indices, alpha = (2, 1), filter_polynomial(0.5, 0.8, (2, 1))
    whole = moli.estimate(data, indices, alpha)          # every segment's rows, stacked
    for module in (estimation, matrix_covariance):
        monkeypatch.setattr(module, "WHOLE_ROWS", 500)
    streamed = moli.estimate(data, indices, alpha)
    again = moli.estimate_covariance(whole, data)
    for M, N in [(whole.A, streamed.A), (whole.B, streamed.B), (whole.C, streamed.C)]:
        np.testing.assert_allclose(M, N, rtol=1e-10, atol=1e-12)   # same problems, round-off apart
    cov = whole.cov_factor @ whole.cov_factor.T
    for other in (streamed, again):          # moving sums cumulated in other blocks: 1e-9
        np.testing.assert_allclose(other.cov_factor @ other.cov_factor.T, cov, rtol=0,
                                   atol=1e-9 * np.abs(cov).max())
        assert other.info["covariance"] == whole.info["covariance"]
    assert whole.info["covariance"]["rows"] == sum(n - 2 for n in segments)   # n̄ = 2 per segment


def test_long_record_search_of_segments_keeps_the_boundaries_and_reestimates_every_segment():
    data = moli.merge([_record(500, 17), _record(2500, 18)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = moli.identify(data, _record(1000, 19), nmax=4, search_samples=800, feedthrough=False,
                               output_filters=False, refine="none", noise_model=False)
    assert search_window(result.estimation, 800).bounds == ((0, 500), (500, 800))
    model = result.model
    assert model.info["search_samples"] == 800 and model.info["estimation_samples"] == 3000
    # moli.estimate stacks each segment's rows (filters from rest in each): the same least squares
    direct = moli.estimate(result.estimation, model.indices, model.alpha)
    for M, N in [(model.A, direct.A), (model.B, direct.B), (model.C, direct.C)]:
        np.testing.assert_allclose(M, N, rtol=1e-8, atol=1e-10)
    assert model.info["covariance"]["rows"] == direct.info["covariance"]["rows"]


def test_criterion_in_bounded_batches_restarts_every_segment_alike(monkeypatch):
    data = moli.merge([_record(900, 20), _record(1100, 21)])
    z = np.concatenate([data.y, data.u], axis=1)
    starts = data.segment_starts
    scorer = criterion.FilterScorer(z, (2, 1), 1.0, 2.0, shared_factors.RegressionCache(z, 2, "auto", starts),
                                  x0="estimate", trend_degree=1, starts=starts)
    models = scorer.fit(moli.method.tuning.barycenter.default_omega(1.0, "wide"))
    whole = scorer.criterion(models)
    # three models per batch: each simulates the record and its 3 free responses
    monkeypatch.setattr(criterion, "CRITERION_BATCH_VALUES", 3 * z.shape[0] * 2 * (1 + 3))
    # each model's simulation and score do not depend on its batch, but a batch of
    # another size may take another BLAS kernel (blocking, vector width), whose sums
    # round differently: a few ulps on some CPUs (relative 1.5e-16 seen on an AMD EPYC)
    np.testing.assert_allclose(scorer.criterion(models), whole, rtol=1e-12, atol=0)
