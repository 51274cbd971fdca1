"""Feedback detection: closed loops are flagged, open loops are not (at the stated rate)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.signal

import moli


def pi_loop(seed: int, N: int = 1000) -> moli.IOData:
    """The plant y = 0.5 / (q - 0.9) u + v under a PI controller; white reference r.

    At each sample y[k] is measured, then u[k] = Kp (r[k] - y[k]) + I[k] is applied.
    """
    rng = np.random.default_rng(seed)
    r = rng.standard_normal(N)
    v = 0.3 * rng.standard_normal(N)
    x = integral = 0.0
    y, u = np.empty(N), np.empty(N)
    for k in range(N):
        y[k] = x + v[k]
        error = r[k] - y[k]
        u[k] = 0.5 * error + integral
        integral += 0.1 * error
        x = 0.9 * x + 0.5 * u[k]
    return moli.IOData(y, u)


def open_loop(seed: int, N: int = 1000) -> moli.IOData:
    """The same plant driven by a random binary signal (held 1 to 5 samples) in open loop."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.choice([-1.0, 1.0], size=N), rng.integers(1, 6, size=N))[:N]
    y = scipy.signal.lfilter([0.0, 0.5], [1.0, -0.9], u) + 0.3 * rng.standard_normal(N)
    return moli.IOData(y, u)


def test_pi_loop_is_flagged():
    for seed in range(20):
        check = moli.feedback_check(pi_loop(seed))
        # measured p-values below 1e-7 over these runs: none may pass
        assert check.detected and check.pvalues[0] < 1e-6
    assert "feedback detected" in check.summary() and "u1" in check.summary()


def test_open_loop_false_alarms_stay_at_the_level():
    alarms = sum(moli.feedback_check(open_loop(seed), level=0.01).detected for seed in range(100))
    # level 0.01: about 1 alarm in 100 runs (measured 1); 6 or more would happen with
    # probability 5e-4 if the test kept its level
    assert alarms <= 5


def test_mimo_loop_flags_the_controlled_input_only():
    rng = np.random.default_rng(5)
    N = 2000
    A = np.array([[0.8, 0.1], [0.0, 0.7]])
    r, v = rng.standard_normal((N, 2)), 0.5 * rng.standard_normal((N, 2))
    x = np.zeros(2)
    y, u = np.empty((N, 2)), np.empty((N, 2))
    for k in range(N):
        y[k] = x + v[k]
        u[k] = [r[k, 0] - 0.6 * y[k, 0], r[k, 1]]     # u2 is open loop
        x = A @ x + u[k]
    check = moli.feedback_check(moli.IOData(y, u))
    # over 200 seeds of this loop: u1's p-value at most 2e-18, u2 flagged in 0.5 % of
    # the runs (its level, 0.01 / 2)
    assert check.detected and check.flagged == ("u1",)
    assert check.pvalues[0] < 1e-6


def test_lag_zero_tells_feedthrough_from_feedback():
    rng = np.random.default_rng(6)
    u = rng.standard_normal(1000)
    y = 0.8 * u + 0.3 * rng.standard_normal(1000)     # open loop, direct feedthrough
    data = moli.IOData(y, u)
    assert moli.feedback_check(data).detected          # lag 0 cannot tell them apart
    assert not moli.feedback_check(data, lag_zero=False).detected


def test_identify_warns_on_closed_loop_data_only():
    with pytest.warns(moli.ClosedLoopWarning, match="closed-loop.*external|closed-loop.*outside"):
        moli.identify(pi_loop(1), nmax=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", moli.ClosedLoopWarning)
        moli.identify(open_loop(1), nmax=2)
    assert issubclass(moli.ClosedLoopWarning, UserWarning)


def test_feedback_check_checks_its_arguments():
    data = open_loop(0, N=200)
    with pytest.raises(moli.DataError, match="IOData"):
        moli.feedback_check(np.zeros((10, 2)))
    for name, value in (("lags", 0), ("lags", 2.5), ("level", 0.0), ("level", "high"), ("lag_zero", 1)):
        with pytest.raises(moli.DataError, match=name):
            moli.feedback_check(data, **{name: value})
    with pytest.raises(moli.DataError, match="too few"):
        moli.feedback_check(data, lags=40)
    check = moli.feedback_check(data, lags=3)
    assert check.lags == 3 and check.pvalues.shape == (1,)


def test_inputs_that_rarely_change_are_left_untested():
    rng = np.random.default_rng(7)
    u = np.where(np.arange(300) < 120, 1.0, -1.0)      # one switch in 300 samples
    y = scipy.signal.lfilter([0.0, 0.5], [1.0, -0.9], u) + 0.1 * rng.standard_normal(300)
    check = moli.feedback_check(moli.IOData(y, u))
    # a statistic resting on one sample says nothing either way
    assert np.isnan(check.pvalues[0]) and not check.detected
    assert "untested" in check.summary()
