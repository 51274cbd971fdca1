"""Confidence bands from a model's covariance: exact cases, options, errors, save and load."""

from __future__ import annotations

import json

import numpy as np
import pytest

import moli
from moli.models import model_from_dict

# x+ = a x + b u, y = x: the gain b / |z - a| and the step response b (1 - a^k) / (1 - a)
# are linear in b, so with uncertainty on b alone the Gauss bands are exact.
POLE, GAIN, SPREAD = 0.6, 2.0, 0.1
Z95 = 1.959963984540054


def _model(**extra: object) -> moli.StateSpaceModel:
    # rows: A, B, C, D entries; one direction, moving b by SPREAD
    return moli.StateSpaceModel([[POLE]], [[GAIN]], [[1.0]], cov_factor=[[0.0], [SPREAD], [0.0], [0.0]], **extra)


def test_gauss_bands_are_exact_for_a_response_linear_in_the_parameters():
    model = _model()
    omega = np.array([0.0, 0.5, np.pi])
    distance = np.abs(np.exp(1j * omega) - POLE)
    lower, upper = model.magnitude_bands(omega)
    np.testing.assert_allclose(lower[:, 0, 0], (GAIN - Z95 * SPREAD) / distance, rtol=1e-12)
    np.testing.assert_allclose(upper[:, 0, 0], (GAIN + Z95 * SPREAD) / distance, rtol=1e-12)
    lower, upper = model.step_bands(6, confidence=0.9)
    shape = (1 - POLE ** np.arange(6)) / (1 - POLE)
    np.testing.assert_allclose(upper[:, 0, 0] - lower[:, 0, 0], 2 * 1.6448536269514722 * SPREAD * shape,
                               atol=1e-12)
    np.testing.assert_allclose((upper + lower)[:, 0, 0] / 2, GAIN * shape, atol=1e-12)


def test_monte_carlo_bands_are_seeded_quantiles_of_the_draws():
    model = _model()
    omega = np.array([0.3])
    first = model.magnitude_bands(omega, method="monte_carlo", samples=20000, seed=4)
    assert np.array_equal(first[0], model.magnitude_bands(omega, method="monte_carlo", samples=20000, seed=4)[0])
    assert not np.array_equal(first[0], model.magnitude_bands(omega, method="monte_carlo", samples=20000, seed=5)[0])
    gauss = model.magnitude_bands(omega)
    # a linear response: the draws' 2.5 % quantile misses the exact one by about
    # sqrt(.025 .975 / 20000) / phi(1.96) = 0.019 standard deviations; 0.1 is five of them
    for drawn, exact in zip(first, gauss):
        assert abs(drawn - exact).item() < 0.1 * SPREAD / abs(np.exp(0.3j) - POLE)


def test_simulation_bands_follow_the_data_units():
    model = _model(y_offset=[5.0], u_offset=[1.0])
    u = np.random.default_rng(1).standard_normal(50)
    raw = moli.IOData(model.simulate(u) + 5.0, u + 1.0)
    centred = raw.remove_means([5.0], [1.0])
    lower, upper = moli.simulation_bands(model, raw)
    lower_c, upper_c = moli.simulation_bands(model, centred)
    np.testing.assert_allclose(lower, lower_c + 5.0, atol=1e-12)
    np.testing.assert_allclose((lower + upper) / 2, moli.compare(model, raw).yhat, atol=1e-12)
    assert np.all(upper - lower >= 0)


def test_bands_need_a_covariance():
    bare = moli.StateSpaceModel([[POLE]], [[GAIN]], [[1.0]])
    data = moli.IOData(np.zeros(10), np.zeros(10))
    for call in (lambda: bare.magnitude_bands([0.1]), lambda: bare.step_bands(5),
                 lambda: moli.simulation_bands(bare, data)):
        with pytest.raises(moli.DataError, match="carries no covariance .*moli.estimate_covariance"):
            call()


@pytest.mark.parametrize("keyword, value, message", [
    ("confidence", 1.0, "confidence must be a number strictly between 0 and 1"),
    ("confidence", 0.0, "confidence must be a number strictly between 0 and 1"),
    ("confidence", True, "confidence must be a number strictly between 0 and 1"),
    ("confidence", "95%", "confidence must be a number strictly between 0 and 1"),
    ("method", "mc", r"method must be one of \('gauss', 'monte_carlo'\)"),
    ("samples", 1, "samples must be an integer >= 2"),
    ("samples", 100.0, "samples must be an integer >= 2"),
    ("seed", -1, "seed must be an integer >= 0"),
    ("seed", None, "seed must be an integer >= 0"),
])
def test_band_options_are_checked(keyword, value, message):
    model = _model()
    data = moli.IOData(np.zeros(10), np.zeros(10))
    for call in (lambda **kw: model.magnitude_bands([0.1], **kw), lambda **kw: model.step_bands(5, **kw),
                 lambda **kw: moli.simulation_bands(model, data, **kw)):
        with pytest.raises(moli.OptionError, match=message):
            call(**{keyword: value})


@pytest.mark.parametrize("omega", [[], [[0.1, 0.2]], [np.nan], "low", None])
def test_frequencies_are_checked(omega):
    with pytest.raises(moli.OptionError, match="omega must be a non-empty 1-D sequence of finite frequencies"):
        _model().magnitude_bands(omega)


@pytest.mark.parametrize("n_steps", [0, 2.5, True, "10"])
def test_step_count_is_checked(n_steps):
    with pytest.raises(moli.OptionError, match="n_steps must be an integer >= 1"):
        _model().step_bands(n_steps)


def test_inputs_are_not_modified():
    model = _model()
    omega = np.array([0.1, 0.2])
    u = np.ones(5)
    factor = model.cov_factor.copy()
    model.magnitude_bands(omega, method="monte_carlo", samples=10)
    moli.simulation_bands(model, moli.IOData(u.copy(), u))
    assert omega.tolist() == [0.1, 0.2] and u.tolist() == [1.0] * 5
    np.testing.assert_array_equal(model.cov_factor, factor)


def test_covariance_is_saved_checked_and_dropped_with_new_matrices(tmp_path):
    model = _model()
    model.save(tmp_path / "m.json")
    loaded = moli.load_model(tmp_path / "m.json")
    np.testing.assert_array_equal(loaded.cov_factor, model.cov_factor)
    content = model.to_dict()
    del content["cov_factor"]                      # a file written before the field existed
    assert model_from_dict(content).cov_factor is None
    content["cov_factor"] = [[0.0]] * 3
    with pytest.raises(moli.ModelFileError, match="cov_factor needs one row per entry of A, B, C and D"):
        model_from_dict(json.loads(json.dumps(content)))
    with pytest.raises(moli.DataError, match="cov_factor must be a finite 2-D matrix"):
        moli.StateSpaceModel([[POLE]], [[GAIN]], [[1.0]], cov_factor=[[np.inf]] * 4)
    assert model.with_matrices([[0.5]], [[1.0]], [[1.0]], None, {}, None).cov_factor is None
