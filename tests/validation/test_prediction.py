"""k-step-ahead prediction with the Kalman predictor, and compare(horizon=k)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import moli

from systems_util import innovations_record, random_system, resonant_noise_system


def _with_gain(model: moli.StateSpaceModel, rng: np.random.Generator) -> moli.StateSpaceModel:
    K = 0.3 * rng.standard_normal((model.n, model.p))
    D = rng.standard_normal((model.p, model.m))
    return moli.StateSpaceModel(model.A, model.B, model.C, D, K=K, noise_cov=np.eye(model.p))


def _loop_prediction(model: moli.StateSpaceModel, u: np.ndarray, y: np.ndarray, k: int, x0: np.ndarray) -> np.ndarray:
    """The definition, sample by sample: Kalman predictor to t - k, then k simulation steps."""
    A, B, C, D, K = model.A, model.B, model.C, model.D, model.K
    N = u.shape[0]
    xhat = np.empty((N + 1, model.n))
    xhat[0] = x0
    for t in range(N):
        xhat[t + 1] = A @ xhat[t] + B @ u[t] + K @ (y[t] - C @ xhat[t] - D @ u[t])
    out = np.empty_like(y)
    for t in range(N):
        start = max(t - k + 1, 0)  # no output seen before t - k + 1 <= 0: simulate from x0
        x = xhat[start]
        for j in range(start, t):
            x = A @ x + B @ u[j]
        out[t] = C @ x + D @ u[t]
    return out


@settings(max_examples=40, deadline=None)
@given(N=st.integers(1, 60), n=st.integers(1, 4), p=st.integers(1, 2), m=st.integers(1, 2),
       k=st.integers(1, 8), seed=st.integers(0, 10_000))
def test_k_step_prediction_matches_the_sample_loop(N, n, p, m, k, seed):
    rng = np.random.default_rng(seed)
    model = _with_gain(random_system(n, p, m, rng), rng)
    u, y = rng.standard_normal((N, m)), rng.standard_normal((N, p))
    x0 = rng.standard_normal(n)
    from moli.validation.prediction import _predicted

    expected = _loop_prediction(model, u, y, k, x0)
    got = _predicted(model, u, y, k, x0)
    # the same arithmetic regrouped into block products and a difference of two state
    # sequences: agreement to round-off, relative to the largest value involved
    np.testing.assert_allclose(got, expected, atol=1e-9 * (1 + np.abs(expected).max()))


def test_estimated_initial_state_gives_exact_predictions_on_noise_free_data():
    rng = np.random.default_rng(1)
    model = _with_gain(random_system(3, 2, 1, rng), rng)
    u = rng.standard_normal((200, 1))
    x0 = rng.standard_normal(3)
    data = moli.IOData(model.simulate(u, x0), u)
    for k in (None, 1, 3):
        yhat = moli.predict(model, data, horizon=k)
        # noise-free outputs of the model itself: every predictor is exact from the true
        # state, and the least-squares state is that state, to round-off
        np.testing.assert_allclose(yhat, data.y, atol=1e-8)
    assert np.abs(moli.predict(model, data, horizon=1, x0="zero") - data.y).max() > 1e-3


def test_the_initial_state_of_a_long_record_comes_from_the_samples_before_its_response_decays():
    from moli.validation.prediction import initial_state

    rng = np.random.default_rng(4)
    model = random_system(3, 2, 1, rng)         # poles inside 0.9: decayed to 1e-17 in a few hundred samples
    N = 20000
    u = rng.standard_normal((N, 1))
    x0 = rng.standard_normal(3)
    y = model.simulate(u, x0) + 0.1 * rng.standard_normal((N, 2))
    found = initial_state(model, u, y)
    # independent route: the whole record's least squares, every row of the free response
    free = np.stack([model.simulate(np.zeros((N, 1)), e) for e in np.eye(3)], axis=2)
    expected = np.linalg.lstsq(free.reshape(-1, 3), (y - model.simulate(u)).reshape(-1), rcond=None)[0]
    # the rows left out carry a free response below 1e-17 of its largest entry: the
    # solutions agree to round-off of the (well-conditioned, 3-state) problem
    np.testing.assert_allclose(found, expected, rtol=1e-9, atol=1e-12)


def test_long_horizons_and_zero_gain_are_the_simulation():
    rng = np.random.default_rng(2)
    model = _with_gain(random_system(3, 2, 2, rng), rng)
    u, y = rng.standard_normal((50, 2)), rng.standard_normal((50, 2))
    data = moli.IOData(y, u)
    simulated = moli.predict(model, data, x0="zero")
    np.testing.assert_allclose(moli.predict(model, data, horizon=50, x0="zero"), simulated, atol=1e-12)
    silent = moli.StateSpaceModel(model.A, model.B, model.C, model.D, K=np.zeros((3, 2)), noise_cov=np.eye(2))
    np.testing.assert_allclose(moli.predict(silent, data, horizon=2, x0="zero"), simulated, atol=1e-12)
    np.testing.assert_array_equal(moli.predict(model, data, x0="zero"), model.simulate(u))


def test_offsets_are_handled_as_compare_does():
    plant, K, cov = resonant_noise_system()
    data = innovations_record(plant, K, cov, 400, np.random.default_rng(3))
    raw = moli.IOData(data.y + [5.0, -2.0], data.u + 1.0)
    centred = raw.remove_means()
    model = moli.StateSpaceModel(plant.A, plant.B, plant.C, y_offset=centred.y_offset,
                                 u_offset=centred.u_offset, K=K, noise_cov=cov)
    shift = moli.predict(model, raw, horizon=2) - moli.predict(model, centred, horizon=2)
    # the same deviations, returned in each record's units
    np.testing.assert_allclose(shift, np.broadcast_to(centred.y_offset, shift.shape), atol=1e-9)


def test_compare_scores_the_k_step_prediction():
    plant, K, cov = resonant_noise_system()
    data = innovations_record(plant, K, cov, 600, np.random.default_rng(4))
    model = moli.StateSpaceModel(plant.A, plant.B, plant.C, K=K, noise_cov=cov)
    one = moli.compare(model, data, x0="estimate", horizon=1)
    assert one.horizon == 1
    np.testing.assert_allclose(one.yhat, moli.predict(model, data, horizon=1), atol=1e-12)
    np.testing.assert_allclose(one.fit, moli.nrmse_fit(data.y, one.yhat))
    fits = [moli.compare(model, data, x0="estimate", horizon=k).mean_vaf for k in (1, 2, 5, 20)]
    assert fits == sorted(fits, reverse=True)  # less is known the further ahead
    simulation = moli.compare(model, data, x0="estimate")
    assert simulation.horizon is None and simulation.mean_vaf < fits[-1] + 1.0
    np.testing.assert_allclose(simulation.yhat, moli.predict(model, data), atol=1e-12)


def test_prediction_rejects_bad_input_before_any_work():
    rng = np.random.default_rng(5)
    plain = random_system(2, 1, 1, rng)
    data = moli.IOData(rng.standard_normal(30), rng.standard_normal(30))
    with pytest.raises(moli.OptionError, match="needs a noise model"):
        moli.predict(plain, data, horizon=1)
    with pytest.raises(moli.OptionError, match="needs a noise model"):
        moli.compare(plain, data, horizon=1)
    noisy = _with_gain(plain, rng)
    for bad in (0, -1, 1.5, True, "1"):
        with pytest.raises(moli.OptionError, match="horizon must be None"):
            moli.predict(noisy, data, horizon=bad)
    with pytest.raises(moli.OptionError, match="x0 must be one of"):
        moli.predict(noisy, data, horizon=1, x0="guess")
    with pytest.raises(moli.DataError, match="outputs"):
        moli.predict(noisy, moli.IOData(np.zeros((30, 2)), np.zeros(30)), horizon=1)
    with pytest.raises(moli.DataError, match="IOData"):
        moli.predict(noisy, np.zeros(30), horizon=1)
