"""The method on records of several segments: no regressor row, simulation or lag spans a boundary."""

import warnings

import numpy as np
import pytest
from scipy.signal import lfilter

import moli
from moli.method.refinement.levenberg_marquardt import refine
from moli.method.least_squares.shared_factors import RegressionCache
from moli.method.tuning.criterion import FilterScorer

from systems_util import generic_indices, random_system


def _markov_error(model: moli.StateSpaceModel, system: moli.StateSpaceModel) -> float:
    truth = system.markov(22)[1:]
    return float(np.max(np.abs(model.markov(22)[1:] - truth)) / np.max(np.abs(truth)))


def _quiet_estimate(data, indices, alpha):
    with warnings.catch_warnings():
        # noise-free multi-output data leave the observer-form parameters non-unique
        # (the fit is exact; the minimum-norm solution is one of many)
        warnings.simplefilter("ignore", moli.IllConditionedWarning)
        return moli.estimate(data, indices, alpha)


def _gap_record(seed: int):
    """A noise-free record of a random 4-state 2x2 system that starts away from rest and
    loses 30 samples in the middle while the plant runs on."""
    rng = np.random.default_rng(seed)
    system = random_system(4, 2, 2, rng)
    u = rng.standard_normal((600, 2))
    y = system.simulate(u, rng.standard_normal(4))
    y[250:280] = np.nan
    return system, moli.IOData(y, u)


def test_exact_recovery_from_a_record_with_a_gap():
    system, data = _gap_record(7)
    assert data.bounds == ((0, 250), (250, 570))
    indices = generic_indices(4, 2)
    # the filter q^2 (all roots at zero): its observer states forget any initial state
    # after max(indices) samples, so every regression row of each segment is exact,
    # whatever state the plant is in when the segment starts
    model = _quiet_estimate(data, indices, [1.0, 0.0, 0.0])
    # exact equations: only round-off (regression condition ~1e3 here) separates them
    assert _markov_error(model, system) < 1e-8
    # the same samples taken as one stretch have rows across the jump: no longer exact
    joined = moli.IOData(data.y, data.u)
    assert _markov_error(_quiet_estimate(joined, indices, [1.0, 0.0, 0.0]), system) > 1e-3


def test_exact_recovery_from_merged_experiments_that_start_at_rest():
    rng = np.random.default_rng(3)
    system = random_system(5, 2, 2, rng)
    runs = []
    for N in (300, 250, 200):
        u = rng.standard_normal((N, 2))
        runs.append(moli.IOData(system.simulate(u), u))
    merged = moli.merge(runs)
    indices = generic_indices(5, 2)
    for wc, zeta in [(0.3, 0.7), (1.0, 1.1)]:
        # each experiment starts at rest, as the filters restarted from zero do: exact
        # rows for any filter; 1e-8 is round-off times the slow filter's conditioning
        model = _quiet_estimate(merged, indices, moli.filter_polynomial(wc, zeta, indices))
        assert _markov_error(model, system) < 1e-8


def test_identify_recovers_the_plant_from_merged_experiments():
    rng = np.random.default_rng(3)
    system = random_system(5, 2, 2, rng)
    runs = []
    for N in (300, 250, 200, 300):
        u = rng.standard_normal((N, 2))
        runs.append(moli.IOData(system.simulate(u), u))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")       # noise-free data: ill-conditioned candidates expected
        # uncentred: each experiment starts at rest, the zero state of the restarted
        # filters and simulations; removing the means would move that operating point
        result = moli.identify(moli.merge(runs[:3]), runs[3], order=5, nmax=5, center=False)
    # every candidate's equations are exact: round-off only (2e-15 seen)
    assert _markov_error(result.model, system) < 1e-8


def _siso_records(seed: int) -> tuple[moli.IOData, moli.IOData]:
    rng = np.random.default_rng(seed)
    plant = moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]])
    records = []
    for N, offset in ((300, 0.0), (200, 1e3)):
        u = rng.standard_normal(N)
        y = plant.simulate(u)[:, 0] + 0.2 * rng.standard_normal(N)
        # the second record sits 1000 units away: a row across the boundary would see a
        # jump a thousand times the signals' size
        records.append(moli.IOData(y + offset, u + offset))
    return records[0], records[1]


def test_merged_estimate_is_the_least_squares_of_each_segments_own_rows():
    a, b = _siso_records(5)
    alpha = np.array([1.0, -0.5])
    model = moli.estimate(moli.merge([a, b]), [1], alpha, covariance=False)
    # docs/method.md §3 written out for l = 1: w_k = v_(k-1), v = z / alpha, rows k >= 1 of each record
    rows, targets = [], []
    for record in (a, b):
        z = np.column_stack([record.y, record.u])
        v = lfilter([1.0], alpha, z, axis=0)
        rows.append(v[:-1])
        targets.append(record.y[1:, 0])
    theta = np.linalg.lstsq(np.concatenate(rows), np.concatenate(targets), rcond=None)[0]
    # A = A_D + D C with A_D = 0.5, C = 1: same least squares, round-off apart
    np.testing.assert_allclose(model.A, [[0.5 + theta[0]]], rtol=1e-10)
    np.testing.assert_allclose(model.B, [[theta[1]]], rtol=1e-10)


def test_search_factors_give_the_stacked_rows_models_and_j_restarts_each_segment():
    a, b = _siso_records(6)
    merged = moli.merge([a, b, a[:150]])    # three segments: two folds of the factors
    z = np.column_stack([merged.y, merged.u])
    starts = merged.segment_starts
    etas = np.array([[0.3, 0.7], [1.0, 1.1], [0.6, 0.9]])
    cached = FilterScorer(z, (2,), 1.0, 2.0, RegressionCache(z, 1, False, starts), starts=starts)
    direct = FilterScorer(z, (2,), 1.0, 2.0, starts=starts)
    J, (A, B, C) = cached.score(etas)
    A2, B2, C2 = direct.fit(etas)
    # the combined per-segment QR factors and the stacked rows solve the same least squares
    np.testing.assert_allclose(A, A2, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(B, B2, rtol=1e-8, atol=1e-10)
    # J by hand: each segment simulated from the zero state, the errors scored together
    for r in range(len(etas)):
        model = moli.StateSpaceModel(A[r], B[r], C[r])
        yhat = np.concatenate([model.simulate(part.u) for part in merged.segments])
        error = merged.y - yhat
        expected = min(np.var(error) / np.var(merged.y), 1.0)
        assert J[r] == pytest.approx(expected, rel=1e-10)


def test_j_fits_initial_states_and_trends_per_segment():
    a, b = _siso_records(12)
    merged = moli.merge([a, b])
    z = np.column_stack([merged.y, merged.u])
    starts = merged.segment_starts
    model = moli.StateSpaceModel([[0.7]], [[0.6]], [[1.0]])
    matrices = (model.A[None], model.B[None], model.C[None])
    y = merged.y[:, 0]
    # x0 = "estimate": each segment's initial state by least squares (moli.compare's own fit)
    yhat = np.concatenate([moli.compare(model, part, x0="estimate").yhat[:, 0] for part in merged.segments])
    scorer = FilterScorer(z, (1,), 1.0, 2.0, x0="estimate", starts=starts)
    assert scorer.criterion(matrices)[0] == pytest.approx(np.var(y - yhat) / np.var(y), rel=1e-8)
    # trend degree 1: a straight line removed from each segment's error on its own
    error = y - np.concatenate([model.simulate(part.u)[:, 0] for part in merged.segments])
    for lo, hi in merged.bounds:
        k = np.arange(hi - lo)
        error[lo:hi] -= np.polyval(np.polyfit(k, error[lo:hi], 1), k)
    scorer = FilterScorer(z, (1,), 1.0, 2.0, trend_degree=1, starts=starts)
    assert scorer.criterion(matrices)[0] == pytest.approx(error @ error / (y.size * np.var(y)), rel=1e-8)


def test_compare_and_predict_run_each_segment_from_its_own_start():
    a, b = _siso_records(8)
    merged = moli.merge([a, b])
    model = moli.StateSpaceModel([[0.8]], [[0.5]], [[1.0]])
    whole = moli.compare(model, merged)
    parts = [moli.compare(model, part) for part in merged.segments]
    np.testing.assert_array_equal(whole.yhat, np.concatenate([p.yhat for p in parts]))
    np.testing.assert_allclose(whole.vaf, moli.vaf(merged.y, whole.yhat), rtol=1e-12)
    estimated = moli.compare(model, merged, x0="estimate")
    assert estimated.x0.shape == (2, 1)
    np.testing.assert_allclose(estimated.x0[:, 0], [moli.compare(model, p, x0="estimate").x0[0]
                                                   for p in merged.segments], rtol=1e-10)
    np.testing.assert_array_equal(moli.predict(model, merged, x0="zero"), whole.yhat)


def test_refinement_fits_one_initial_state_per_segment():
    system, data = _gap_record(11)
    model = _quiet_estimate(data, generic_indices(4, 2), [1.0, 0.0, 0.0])
    result = refine(model, data, iterations=0)
    assert result.x0.shape == (2, 4)
    # the start is the exact model, and each segment's unknown initial state is a linear
    # least-squares fit: the simulation error is round-off (relative squared error)
    assert result.cost < 1e-18
    joined = refine(model, moli.IOData(data.y, data.u), iterations=0)
    assert joined.cost > 1e-3          # one initial state cannot explain the jump


def test_short_segments_are_left_out_with_a_warning():
    long = moli.example_data(N=400, seed=1)
    # nmax = 4 with 3 outputs and 3 inputs: the list (1, 1, 2) with its feedthrough
    # (the default "auto" may keep it) needs 6 * 2 + 2 + 3 + 2 + 1 = 20 samples
    short = moli.example_data(N=19, seed=2)
    with pytest.warns(moli.DataQualityWarning, match=r"segments 1 \(19 samples\) are too short"):
        result = moli.identify(moli.merge([long, short]), moli.example_data(N=300, seed=3), nmax=4)
    assert result.estimation.N == 400 and result.estimation.n_segments == 1
    with pytest.raises(moli.DataError, match="every segment of the estimation record is too short"):
        moli.identify(moli.merge([short, short]), moli.example_data(N=300, seed=3), nmax=4)


def test_identify_holds_out_the_tail_of_a_record_of_segments():
    data = moli.merge([moli.example_data(N=500, seed=4), moli.example_data(N=500, seed=5)]).drop(200, 230)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", moli.OrderBoundWarning)
        result = moli.identify(data, nmax=5)
    assert result.estimation.N + result.validation.N == data.N
    assert result.estimation.bounds == ((0, 200), (200, 470), (470, 679))
    assert result.validation.n_segments == 1
    assert "in 3 segments" in result.summary()
    assert result.model.cov_factor is not None and result.model.K is not None
    assert result.model.info["noise_model"]["segment"] == 1    # the longest estimation segment


def test_covariance_takes_rows_of_every_segment():
    a, b = _siso_records(9)
    model = moli.estimate(moli.merge([a, b]), [1], [1.0, -0.5])
    assert model.info["covariance"]["rows"] == (300 - 1) + (200 - 1)


@pytest.mark.parametrize("analysis", [
    lambda d: moli.residual_analysis(moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]]), d),
    lambda d: moli.feedback_check(d),
    lambda d: moli.estimate_delays(d),
    lambda d: moli.empirical_frequency_response(d),
])
def test_analyses_through_time_refuse_several_segments(analysis):
    with pytest.raises(moli.DataError, match="needs a continuous record, and this one has 2 segments"):
        analysis(moli.merge(list(_siso_records(10))))


def test_the_long_run_covariance_takes_no_lag_across_a_boundary():
    from moli.method.least_squares.sandwich import sandwich_factor

    rng = np.random.default_rng(13)
    phis = [rng.standard_normal((90, 3)), rng.standard_normal((90, 2))]
    noise = np.convolve(rng.standard_normal(92), [1.0, 0.8, 0.5], mode="valid")   # coloured
    targets = np.column_stack([phis[0] @ [1.0, -2.0, 0.5] + noise, phis[1] @ [0.3, 0.2] + noise])
    factor, _, width = sandwich_factor(phis, targets, breaks=[40])
    # the Newey-West sum of each segment's own scores (rows 0-39, 40-89), added
    scores = np.concatenate([phi * (t - phi @ np.linalg.lstsq(phi, t, rcond=None)[0])[:, None]
                             for phi, t in zip(phis, targets.T)], axis=1)

    def bartlett(s):
        n = s.shape[0]
        return sum((1 - abs(h) / width) * s[max(h, 0) : n + min(h, 0)].T @ s[max(-h, 0) : n - max(h, 0)]
                   for h in range(-width + 1, width))

    middle = bartlett(scores[:40]) + bartlett(scores[40:])
    bread = np.zeros((5, 5))
    bread[:3, :3] = np.linalg.inv(phis[0].T @ phis[0]) * np.sqrt(90 / 87)
    bread[3:, 3:] = np.linalg.inv(phis[1].T @ phis[1]) * np.sqrt(90 / 88)
    assert width > 1                                   # lags that could have crossed
    np.testing.assert_allclose(factor.T @ factor, bread @ middle @ bread, rtol=1e-9, atol=1e-15)
    whole, _, _ = sandwich_factor(phis, targets)
    assert not np.allclose(whole.T @ whole, factor.T @ factor, rtol=1e-6)
