"""Bad arguments to the figures of merit and the data-only diagnostics: a moli error."""

from __future__ import annotations

import numpy as np
import pytest

import moli
from moli import DataError, OptionError

MODEL = moli.StateSpaceModel([[0.5]], [[1.0]], [[1.0]])
RNG = np.random.default_rng(1)
U = RNG.standard_normal(200)
DATA = moli.IOData(MODEL.simulate(U) + 0.1 * RNG.standard_normal((200, 1)), U)


@pytest.mark.parametrize("metric", [moli.vaf, moli.nrmse_fit, moli.cost_j])
@pytest.mark.parametrize("y, yhat, message", [
    (np.zeros((0, 1)), np.zeros((0, 1)), "at least two samples"),
    (np.ones((10, 2)), np.ones((10, 3)), "same shape"),
    (np.zeros((10, 0)), np.zeros((10, 0)), "p >= 1"),
    (np.arange(10.0) * 1j, np.arange(10.0), "y must be real"),
    ("abc", "abc", "y must be an array of real"),
    (np.full(10, np.nan), np.ones(10), "y must be finite"),
])
def test_a_metric_refuses_what_it_cannot_score(metric, y, yhat, message):
    with pytest.raises(DataError, match=message):
        metric(y, yhat)


def test_a_diverging_simulation_scores_zero_rather_than_failing():
    # yhat may be inf (an unstable model's simulation); that is no fit, not bad input
    assert moli.vaf(np.arange(10.0), np.full(10, np.inf))[0] == 0.0


@pytest.mark.parametrize("call, error, message", [
    (lambda: moli.compare("model", DATA), DataError, "model must be a StateSpaceModel"),
    (lambda: moli.compare(MODEL, DATA.y), DataError, "data must be an IOData"),
    (lambda: moli.compare(MODEL, DATA, "foo"), OptionError, "x0 must be one of"),
    (lambda: moli.compare(MODEL, DATA, np.zeros(1)), OptionError, "x0 must be one of"),
    (lambda: moli.compare(MODEL, DATA, "zero", "3"), OptionError, "horizon must be"),
    (lambda: moli.predict(MODEL, DATA, 1, np.zeros(1)), OptionError, "x0 must be one of"),
    (lambda: moli.residual_analysis(MODEL, DATA, "a"), OptionError, "lags must be"),
    (lambda: moli.residual_analysis(MODEL, DATA, 10, float("nan")), OptionError, "confidence must be"),
    (lambda: moli.residual_analysis(MODEL, DATA, x0=np.zeros(1)), OptionError, "x0 must be one of"),
    (lambda: moli.empirical_frequency_response(DATA[:1]), DataError, "at least 8 samples"),
    (lambda: moli.empirical_frequency_response(DATA, "abc"), DataError, "omega"),
    (lambda: moli.empirical_frequency_response(DATA, None, 0), DataError, "nperseg must be"),
])
def test_bad_arguments_of_validation_functions(call, error, message):
    with pytest.raises(error, match=message):
        call()
