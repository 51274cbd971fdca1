"""A continuous-time model goes where a sampled one goes: compare, predict, residuals, bands, fleets."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.linalg
import scipy.special

import moli
from moli.method.continuous import identification as continuous_identification
from moli.method.continuous.estimation import stamped_record
from moli.method.continuous.reach import largest_continuous_order
from moli.method.continuous.search import ContinuousSearch
from moli.method.structure.indices import generic_indices
from moli.validation.comparison import estimate_initial_state

Z95 = float(scipy.special.ndtri(0.975))


def plant(cov_factor: object = None) -> moli.ContinuousModel:
    """Two real modes (time constants 1 and 1/0.3), static gain 1 + 0.5 / 0.3."""
    return moli.ContinuousModel(np.array([[-1.0, 0.0], [0.0, -0.3]]), np.array([[1.0], [0.5]]),
                                np.array([[1.0, 1.0]]), np.zeros((1, 1)), ("y1",), ("u1",), np.zeros(1),
                                np.zeros(1), (0.0,), cov_factor=cov_factor)


def lag(sigma: float) -> moli.ContinuousModel:
    """``y' = -y + b u`` whose only uncertainty is ``b`` (standard deviation ``sigma``): every
    response is linear in ``b``, so the Gauss bands are exact."""
    return moli.ContinuousModel(np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]]), np.zeros((1, 1)),
                                ("y1",), ("u1",), np.zeros(1), np.zeros(1), (0.0,),
                                cov_factor=np.array([[0.0], [sigma], [0.0], [0.0]]))


def jittered_record(seed: int, N: int = 300, noise: float = 0.0, x0: object = None) -> tuple[moli.IOData, np.ndarray]:
    """The plant on stamps 0.1-0.3 apart, inputs held 10 samples; the outputs and the noise-free ones."""
    rng = np.random.default_rng(seed)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.1, 0.3, N - 1)])
    u = np.repeat(rng.standard_normal(N // 10), 10)
    clean = plant().simulate(u, t, x0=x0)
    y = clean + noise * rng.standard_normal(clean.shape)
    return moli.IOData(y, u, times=t), clean


def test_compare_simulates_on_the_record_s_own_stamps_and_finds_the_initial_state():
    x0 = np.array([2.0, -1.0])
    data, clean = jittered_record(0, x0=x0)
    # from rest: the zero-state simulation on the stamps (compare runs the same propagation per
    # segment: outputs of order 1 agree to a few ulps, 1e-12); the least-squares initial state is the true one
    np.testing.assert_allclose(moli.compare(plant(), data).yhat, plant().simulate(data.u, data.time()), atol=1e-12)
    fitted = moli.compare(plant(), data, "estimate")
    # noise-free outputs: the fit is exact to round-off of the propagation (1e-10 relative, docs/continuous.md)
    np.testing.assert_allclose(fitted.x0, x0, atol=1e-8)
    np.testing.assert_allclose(fitted.yhat, clean, atol=1e-8)
    np.testing.assert_allclose(estimate_initial_state(plant(), data.u, data.y, data.time()), x0, atol=1e-8)


def test_free_response_is_the_matrix_exponential():
    t = np.array([0.0, 0.5, 0.7, 2.0])
    model = plant()
    expected = np.stack([model.C @ scipy.linalg.expm(model.A * s) for s in t])
    # the exact propagation against scipy's Pade expm: both accurate to about 1e-13 relative; 1e-10 leaves room
    np.testing.assert_allclose(model.free_response_at(t), expected, rtol=1e-10, atol=1e-14)


def test_predict_is_the_simulation_and_a_horizon_is_refused_with_the_reason():
    data, clean = jittered_record(1)
    # the record's noise-free outputs were made by the same propagation from rest: round-off of outputs of order 1
    np.testing.assert_allclose(moli.predict(plant(), data, x0="zero"), clean, atol=1e-10)
    with pytest.raises(moli.OptionError, match="continuous-time model has none"):
        moli.predict(plant(), data, horizon=1)
    with pytest.raises(moli.OptionError, match="continuous-time model has none"):
        moli.compare(plant(), data, horizon=2)


def test_residual_analysis_of_the_true_plant_leaves_the_noise_and_a_missing_mode_fails():
    data, clean = jittered_record(2, N=600, noise=0.02)
    analysis = moli.residual_analysis(plant(), data, lags=15, x0="zero")
    assert analysis.horizon is None       # no noise model: simulation errors
    np.testing.assert_allclose(analysis.residuals, data.y - clean, atol=1e-10)   # as predict's, above
    # the slow mode (gain 0.5 / 0.3 of 2.67) left out: the inputs explain the residuals
    fast_only = moli.ContinuousModel(np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]]), np.zeros((1, 1)),
                                     ("y1",), ("u1",), np.zeros(1), np.zeros(1), (0.0,))
    assert moli.residual_analysis(fast_only, data, lags=15).independence_pvalue[0, 0] < 0.01


def test_bands_are_exact_where_the_response_is_linear_in_the_uncertain_entry():
    sigma = 0.1
    model = lag(sigma)
    t = np.array([0.0, 0.5, 1.0, 4.0])
    lower, upper = model.step_bands(t)
    # the response is linear in the uncertain entry: the Gauss band is exact, to round-off of numbers of order 0.2
    np.testing.assert_allclose((upper - lower)[:, 0, 0] / 2, Z95 * sigma * (1 - np.exp(-t)), atol=1e-12)
    omega = np.array([0.0, 1.0, 10.0])
    lower, upper = model.magnitude_bands(omega)
    np.testing.assert_allclose((upper - lower)[:, 0, 0] / 2, Z95 * sigma / np.hypot(1.0, omega), rtol=1e-12)
    data, _ = jittered_record(3)
    simulated = model.simulate(data.u, data.time())
    lower, upper = moli.simulation_bands(model, data)
    # the same, on a simulation of a few hundred propagated steps (round-off accumulates to 1e-12)
    np.testing.assert_allclose((upper - lower) / 2, Z95 * sigma * np.abs(simulated), atol=1e-10)


def test_monte_carlo_step_bands_agree_with_the_gauss_ones():
    model = lag(0.1)
    t = np.array([0.0, 3.0])
    gauss = model.step_bands(t)
    drawn = model.step_bands(t, method="monte_carlo", samples=4000, seed=0)
    # the response is linear in b, so the Gauss band is the exact normal quantile; the empirical
    # 2.5 % quantile of 4000 draws has standard error sqrt(0.025 0.975 / 4000) / phi(1.96) = 0.042 sd,
    # and the sd at t = 3 is 0.1 (1 - e^-3) = 0.095: four standard errors are 0.016
    np.testing.assert_allclose(drawn[1][1], gauss[1][1], atol=0.016)
    np.testing.assert_allclose(drawn[0][1], gauss[0][1], atol=0.016)


def test_step_bands_of_a_continuous_model_need_the_times():
    with pytest.raises(moli.OptionError, match="times after the step"):
        lag(0.1).step_bands(20)
    with pytest.raises(moli.DataError, match="increasing"):
        lag(0.1).step_bands([0.0, 2.0, 1.0])


def test_a_saved_continuous_model_keeps_its_hold_and_info(tmp_path):
    model = moli.ContinuousModel(np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]]), np.zeros((1, 1)),
                                 ("y1",), ("u1",), np.zeros(1), np.zeros(1), (0.0,), input_hold="foh",
                                 info={"options": {"time": "continuous"}})
    model.save(tmp_path / "m.json")
    loaded = moli.load_model(tmp_path / "m.json")
    assert loaded.input_hold == "foh" and loaded.info == {"options": {"time": "continuous"}}
    # a ramp between two samples: the linear hold's exact response, e^-1 of the zero-order hold's missing
    assert loaded.simulate_at(np.array([[0.0], [1.0]]), np.array([0.0, 1.0]))[1, 0] == pytest.approx(np.exp(-1.0))


def test_identify_many_in_continuous_time_returns_every_model():
    records = {f"loop{k}": jittered_record(k, noise=0.01)[0] for k in range(2)}
    options = moli.IdentifyOptions(time="continuous", nmax=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fleet = moli.identify_many(records, options, n_jobs=1, progress=False)
    assert not fleet.failures, [entry.error for entry in fleet]
    models = fleet.models()
    assert sorted(models) == ["loop0", "loop1"]
    for name, model in models.items():
        assert model.is_continuous and model.info["options"]["time"] == "continuous"
        assert fleet[name].fit is not None and np.isfinite(fleet[name].fit)


@pytest.mark.parametrize("name", ["nmax", "order"])
def test_an_order_beyond_the_record_is_refused_before_the_search(monkeypatch, name):
    def no_search(*args, **kwargs):
        raise AssertionError("the search ran")

    monkeypatch.setattr(continuous_identification, "greedy_path", no_search)
    data, _ = jittered_record(4, noise=0.01)
    with pytest.raises(moli.DataError, match=f"{name} = 100000 .*the largest order is"):
        moli.identify(data, time="continuous", **{name: 100000})


@pytest.mark.parametrize("N, p", [(60, 1), (300, 1), (200, 2)])
def test_the_largest_order_is_the_last_the_search_can_fit(N, p):
    rng = np.random.default_rng(N + p)
    data = moli.IOData(rng.standard_normal((N, p)), rng.standard_normal((N, 2)), 0.1)
    record = stamped_record(data)
    reach = largest_continuous_order(record)
    search = ContinuousSearch(record, record, np.ones((1, 2)), 2.0, linear_inputs=False,
                              names=(data.output_names, data.input_names), offsets=(np.zeros(p), np.zeros(2)),
                              largest_order=reach)
    assert reach >= p and search.feasible(generic_indices(reach, p))
    assert not search.feasible(generic_indices(reach + 1, p))


def test_the_irregular_steps_warning_says_what_each_time_domain_does(tmp_path):
    path = tmp_path / "rec.csv"
    t = np.r_[0.0, 0.1, 0.25, 0.3, 0.4, np.arange(5, 40) * 0.1]
    path.write_text("time,u,y\n" + "\n".join(f"{s:.3f},{k % 3},{k % 5}" for k, s in enumerate(t)))
    with pytest.warns(moli.IrregularSamplingWarning) as caught:
        moli.read_data(path, ["u"], ["y"])
    message = str(caught[0].message)
    assert "continuous-time fit (--continuous) uses every stamp as read" in message
    assert "The samples are used as if evenly spaced" not in message
